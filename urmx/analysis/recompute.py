"""One cell of a study archive computed again, with its time histories (``urmx show``).

A study keeps each cell's scalars, not its histories (unless ``[[study.history]]`` asked);
one analysis takes milliseconds, so :func:`recompute` runs the cell again from the study
definition the archive carries (its ``study`` attribute: the study file's text), with the
wall, supports, record, scale factor, COR, impact law and tail the study gave it. Before
it runs, it checks that the result can be the archive's: the archive's
``kernel_source_hash`` must be this urmx's kernel, and the record's SHA-256 (and scale
factor and time step) must be those the archive stored; otherwise it refuses, naming what
differs. A grid cell's recomputed scalars are then compared with the archive's, bit for bit
(:func:`compare`).

An IDA archive's cell has no one intensity: it is recomputed at ``scale`` (a factor on
the record as the study scales it), by default its scale factor at collapse
(``collapse_scale``).
"""

from __future__ import annotations

import copy
import os
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from .. import variables
from ..errors import InputError
from ..jitcache import SOURCE_HASH
from ..simulation import simulate
from ..study.archive import open_archive
from ..study.file import load_study, load_study_text
from ..study.samples import resolve_records

#: the optional dimensions a cell may be picked along, with the study's default
OPTIONAL = ("cor", "scale", "impact", "damping")


def load_archived_study(ds: xr.Dataset, where: str | os.PathLike, study_file: Any = None):
    """The study of an archive: `study_file` when given, else the study text the archive
    carries, read as if it lay in folder `where` (the file's own record files are
    resolved against it)."""
    if study_file is not None:
        return load_study(study_file)
    text = str(ds.attrs.get("study", ""))
    if not text.strip():
        raise InputError("the archive carries no study definition (attribute 'study'): "
                         "give the study file with --study")
    name = str(ds.attrs.get("study_name") or "study")
    return load_study_text(text, Path(where) / f"{name}.toml")


def _label(ds: xr.Dataset, dim: str, value: Any, option: str) -> Any:
    """The archive's label of `dim` matching `value` (text, or a number for a numeric
    dimension); the only label when `value` is None and the dimension has one."""
    labels = ds[dim].values.tolist()
    if value is None:
        if len(labels) == 1:
            return labels[0]
        raise InputError(f"{option}: the archive has {len(labels)} values of {dim} "
                         f"({', '.join(map(str, labels[:12]))}): name one")
    for lab in labels:
        if isinstance(lab, (int, float)):
            try:
                if float(lab) == float(value):
                    return lab
            except ValueError:
                continue
        elif str(lab) == str(value):
            return lab
    raise InputError(f"{option} {value}: no such {dim} in the archive "
                     f"({', '.join(map(str, labels[:12]))}{', ...' if len(labels) > 12 else ''})")


def pick(ds: xr.Dataset, wall: str, diaphragm: str, record: str,
         **optional: Any) -> dict[str, Any]:
    """The labels of one cell: `wall`, `diaphragm`, `record` and, for the optional
    dimensions the archive has, their value (required when it has several)."""
    cell = {"wall": _label(ds, "wall", wall, "--wall"),
            "diaphragm": _label(ds, "diaphragm", diaphragm, "--diaphragm"),
            "record": _label(ds, "record", record, "--record")}
    for dim in OPTIONAL:
        if dim in ds.dims and dim in ds.coords:
            cell[dim] = _label(ds, dim, optional.get(dim), f"--{dim}")
        elif optional.get(dim) is not None:
            raise InputError(f"--{dim} {optional[dim]}: the archive has no {dim} dimension "
                             f"(it has {', '.join(map(str, ds.dims))})")
    return cell


def not_run(archive: Any, cell: dict) -> bool:
    """Whether the study left `cell` out (status ``not_run``: a wall not paired with the
    record): the archive holds no result of it to compare with."""
    ds = open_archive(archive)
    if "status" not in ds:
        return False
    meanings = str(ds["status"].attrs.get("flag_meanings", "")).split()
    code = float(ds["status"].sel({k: v for k, v in cell.items() if k in ds["status"].dims}))
    return "not_run" in meanings and np.isfinite(code) and \
        meanings[int(code)] == "not_run"


def check_provenance(ds: xr.Dataset, record_id: str, rec: Any) -> None:
    """Refuse (`InputError`) when the archive's kernel or record is not this one: the
    kernel source hash, the record's SHA-256, scale factor and time step."""
    theirs = str(ds.attrs.get("kernel_source_hash", ""))
    if theirs != SOURCE_HASH:
        raise InputError(f"the archive was computed by kernel {theirs or '(unknown)'} "
                         f"(urmx {ds.attrs.get('urmx_version', '?')}), this urmx's kernel is "
                         f"{SOURCE_HASH}: the recomputed cell would not be the archive's; "
                         "use the urmx that wrote it, or run the study again")
    at = ds.sel(record=record_id)
    stored = str(at["record_sha256"].values) if "record_sha256" in ds.coords else ""
    if stored and stored != rec.sha256:
        raise InputError(f"record {record_id!r}: its file {rec.file or ''} now has SHA-256 "
                         f"{rec.sha256[:12]}..., the archive was computed from "
                         f"{stored[:12]}...: the file changed since; refusing to draw another "
                         "record's response")
    for name, ours in (("scale_factor", rec.scale_factor), ("record_dt", rec.dt)):
        if name in ds.coords and float(at[name]) != float(ours):
            raise InputError(f"record {record_id!r}: {name} is {float(ours)!r} now, "
                             f"{float(at[name])!r} in the archive: refusing")


def recompute(archive: Any, wall: str, diaphragm: str, record: str, *,
              cor: Any = None, scale: Any = None, impact: Any = None, damping: Any = None,
              records_dir: Any = None, study_file: Any = None) -> tuple[xr.Dataset, dict]:
    """Run one cell of a study archive again, with histories.

    Parameters
    ----------
    archive : path
        A study archive (``urmx run``).
    wall, diaphragm, record : str
        The cell's labels.
    cor, scale, impact, damping : optional
        The cell's value of each dimension the archive has (needed when it has several).
        For an IDA archive, `scale` is the factor on the record as the study scales it
        (default: the cell's ``collapse_scale``).
    records_dir : path, optional
        Records folder of manifest records (default ``$URMX_RECORDS``).
    study_file : path, optional
        The study file, when the archive's own text cannot be read where the archive lies
        (own record files given relative to a folder elsewhere).

    Returns
    -------
    (xarray.Dataset, dict)
        `urmx.simulate`'s Dataset of the cell (histories over ``time``; attributes
        ``study_name`` and the cell's labels as ``cell_<dim>``) and the cell's labels.

    Raises
    ------
    urmx.errors.InputError
        An unknown label, a missing choice, or a kernel or record that is not the
        archive's (`check_provenance`).
    """
    path = Path(archive)
    ds = open_archive(path)
    ida = "collapse_intensity" in ds
    cell = pick(ds, wall, diaphragm, record, cor=cor, damping=damping, impact=impact,
                **({} if ida else {"scale": scale}))
    study = load_archived_study(ds, path.resolve().parent, study_file)
    one = copy.copy(study)
    one.records = [cell["record"]]
    rec = resolve_records(one, records_dir)[cell["record"]]
    check_provenance(ds, cell["record"], rec)
    spec = next(w for w in study.walls if w.id == cell["wall"])
    dia = next(d for d in study.diaphragms if d.id == cell["diaphragm"])
    w = study.wall(spec, dia, cell.get("damping"))
    factor = float(cell.get("scale", 1.0))
    if ida:
        at = ds.sel({k: v for k, v in cell.items() if k in ds["collapse_scale"].dims})
        factor = float(at["collapse_scale"]) if scale is None else float(scale)
        if not np.isfinite(factor) or factor <= 0:
            raise InputError("this IDA cell has no scale factor at collapse: give --scale")
    out = simulate(w, rec.acceleration, rec.dt, scale=rec.scale_factor * factor,
                   cor=float(cell.get("cor", study.cor[0])),
                   impact=str(cell.get("impact", study.impact)), tail=study.tail,
                   history=True)
    out.attrs.update({"study_name": str(ds.attrs.get("study_name", "")),
                      "archive": str(path),
                      **{f"cell_{k}": (float(v) if isinstance(v, (int, float)) else str(v))
                         for k, v in cell.items()}})
    if ida:
        out.attrs["cell_scale"] = factor
    return out, cell


def compare(archive: Any, cell: dict, sim: xr.Dataset) -> dict[str, tuple[float, float]]:
    """The scalars of `cell` in the archive that differ from the recomputed ones, bit for
    bit ({name: (archive, recomputed)}; NaN equals NaN); empty when all agree. Only the
    outputs the archive stores per cell are compared (a grid's; an IDA archive has none)."""
    ds = open_archive(archive)
    diff = {}
    for name in variables.SCALARS:
        if name not in ds or name not in sim or set(ds[name].dims) - set(cell):
            continue
        a = float(ds[name].sel({k: v for k, v in cell.items() if k in ds[name].dims}))
        b = float(sim[name])
        same = (np.isnan(a) and np.isnan(b)) or \
            np.float64(a).tobytes() == np.float64(b).tobytes()
        if not same:
            diff[name] = (a, b)
    return diff


def compared(archive: Any, cell: dict) -> int:
    """How many of the archive's scalars `compare` looks at for `cell`."""
    ds = open_archive(archive)
    return sum(1 for n in variables.SCALARS if n in ds and not set(ds[n].dims) - set(cell))

