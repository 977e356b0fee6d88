"""Every registered procedure against urmx's IDA, in one currency: the record scale factor.

For a wall, a diaphragm and a record, a procedure's *capacity scale* is the record scale
factor at which its check is exactly at its limit (`urmx.assess`), computed on the record's
5 %-damped spectrum at scale 1 (the record as the study analysed it: its samples times its
scale factor). urmx's own is the IDA's ``collapse_scale`` (`urmx.study.kinds.ida`): the
lowest scale factor at which the wall collapsed. ``ratio`` is the procedure's capacity scale
over the IDA's; ``unconservative`` is 1 where the procedure accepts a scale at which the wall
collapses (its capacity scale exceeds the IDA's), 0 where it does not, NaN where the
procedure is not applicable or the IDA cell is censored (the wall survived the highest
intensity analysed, so the IDA capacity is only a lower bound) and the procedure accepts more.
"""

from __future__ import annotations

import math
import os
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from ..assess import PROCEDURES
from ..assess.demand import RecordDemand, position_of, record_demand
from ..errors import InputError, MissingFileError
from ..model import Wall
from ..records.record import as_record
from ..study.file import load_study

CAPACITY_ATTRS = {"long_name": "record scale factor at which the procedure's check is at its "
                               "limit", "units": "1"}


def compare(archive, procedures: dict[str, Callable] | None = None, records_dir=None,
            walls: dict[tuple[str, str], Wall] | None = None,
            records: dict[str, Any] | None = None, progress: Callable | None = None
            ) -> xr.Dataset:
    """Capacity scales of the registered procedures beside the IDA's (module docstring).

    Parameters
    ----------
    archive : str, path or xarray.Dataset
        An IDA archive (`urmx run`): ``collapse_scale`` and ``censored`` over
        (wall, diaphragm, record, cor); the first cor is compared.
    procedures : dict, optional
        Name -> procedure (default `urmx.assess.PROCEDURES`, in its order).
    records_dir : str or path, optional
        Records folder for the archive's manifest ids (default ``$URMX_RECORDS``).
    walls : dict, optional
        ``(wall id, diaphragm id) -> urmx.Wall``; default: rebuilt from the study file the
        archive holds (``attrs["study"]``), checked against its wall coordinates.
    records : dict, optional
        Record id -> record (anything `urmx.assess.record_demand` takes), instead of reading
        the archive's records (their scale factor is the record's own).
    progress : callable, optional
        Called with each record id as its demand is computed.

    Returns
    -------
    xarray.Dataset
        Dims ``procedure``, ``wall``, ``diaphragm``, ``record``; variables
        ``capacity_scale`` (procedure, wall, diaphragm, record), ``ida_capacity_scale`` and
        ``ida_censored`` (wall, diaphragm, record), ``ratio``, ``unconservative``; the
        ``reason`` a procedure is not applicable (procedure); the archive's provenance in
        the attributes.
    """
    procs = dict(PROCEDURES if procedures is None else procedures)
    if not procs:
        raise InputError("compare: no procedures to compare")
    ds = _open(archive)
    wall_ids = [str(w) for w in ds["wall"].values]
    diaphragm_ids = [str(d) for d in ds["diaphragm"].values]
    record_ids = [str(r) for r in ds["record"].values]
    cells = walls if walls is not None else _walls(ds, wall_ids, diaphragm_ids)
    ida = ds["collapse_scale"].isel(cor=0).transpose("wall", "diaphragm", "record").values
    censored = ds["censored"].isel(cor=0).transpose("wall", "diaphragm", "record").values
    shape = (len(procs), len(wall_ids), len(diaphragm_ids), len(record_ids))
    cap = np.full(shape, np.nan)
    reasons = [""] * len(procs)
    for ir, rid in enumerate(record_ids):
        demand = _demand(ds, rid, records, records_dir)
        if progress is not None:
            progress(rid)
        for iw, w in enumerate(wall_ids):
            for idp, d in enumerate(diaphragm_ids):
                if math.isnan(ida[iw, idp, ir]):
                    continue  # a cell the study's pairs leave out
                wall = cells[(w, d)]
                pos = position_of(wall)
                for ip, fn in enumerate(procs.values()):
                    result = fn(wall, demand, position=pos)
                    if result.applicable:
                        cap[ip, iw, idp, ir] = result.capacity_scale
                    elif not reasons[ip]:
                        reasons[ip] = result.reason
    return _dataset(ds, procs, wall_ids, diaphragm_ids, record_ids, cap, ida, censored, reasons)


def _open(archive) -> xr.Dataset:
    if isinstance(archive, xr.Dataset):
        ds = archive
    else:
        path = Path(os.fspath(archive))
        if not path.is_file():
            raise MissingFileError(f"IDA archive {str(path)!r} does not exist")
        try:
            with xr.open_dataset(path) as f:
                ds = f.load()
        except (OSError, ValueError) as exc:
            first = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
            raise InputError(f"{path}: not a netCDF archive ({first[:120]})") from None
    missing = [v for v in ("collapse_scale", "censored") if v not in ds]
    if missing or "cor" not in ds.dims:
        raise InputError(f"not an IDA archive (no {', '.join(missing) or 'cor dimension'}): "
                         "write one with `urmx run STUDY --out FILE.nc`")
    return ds


def _walls(ds: xr.Dataset, wall_ids: list[str], diaphragm_ids: list[str]
           ) -> dict[tuple[str, str], Wall]:
    """The cells' walls, from the study file the archive holds."""
    text = ds.attrs.get("study")
    if not text:
        raise InputError("the archive holds no study file (attrs['study']): give walls=")
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / f"{ds.attrs.get('study_name', 'study')}.toml"
        path.write_text(text, encoding="utf-8")
        study = load_study(path)
    specs = {s.id: s for s in study.walls}
    diaphragms = {d.id: d for d in study.diaphragms}
    out = {}
    for iw, w in enumerate(wall_ids):
        for d in diaphragm_ids:
            wall = study.wall(specs[w], diaphragms[d])
            for name in ("thickness", "height"):
                if name in ds.coords and not math.isclose(getattr(wall, name),
                                                          float(ds[name].values[iw])):
                    raise InputError(f"wall {w}: the catalog's {name} differs from the "
                                     "archive's (the catalog changed since the archive)")
            out[(w, d)] = wall
    return out


def _demand(ds: xr.Dataset, rid: str, records: dict | None, records_dir) -> RecordDemand:
    """The record at scale 1 as the study analysed it (its samples times the archive's
    scale factor), checked against the archive's scaled PGA."""
    if records is not None:
        if rid not in records:
            raise InputError(f"compare: records= lacks the archive's record {rid!r}")
        return record_demand(records[rid], label=rid)
    rec = as_record(rid, records_dir)
    factor = float(ds["scale_factor"].sel(record=rid)) if "scale_factor" in ds.coords \
        else rec.scale_factor
    demand = record_demand((np.asarray(rec.acceleration) * factor, rec.dt), label=rid)
    if "scaled_pga" in ds.coords:
        want = float(ds["scaled_pga"].sel(record=rid))
        if not math.isclose(demand.pga, want, rel_tol=1e-6):
            raise InputError(f"record {rid!r}: its PGA now ({demand.pga:.6g} m s-2) is not the "
                             f"archive's ({want:.6g}): the record changed since the archive")
    return demand


def _dataset(ds, procs, wall_ids, diaphragm_ids, record_ids, cap, ida, censored,
             reasons) -> xr.Dataset:
    dims4 = ("procedure", "wall", "diaphragm", "record")
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = cap / ida[None]
    cens = np.broadcast_to(censored[None] > 0.5, cap.shape)
    unc = np.where(cap > ida[None], 1.0, 0.0)
    unc = np.where(np.isnan(cap) | np.isnan(ida[None]) | (cens & (unc > 0)), np.nan, unc)
    coords = {"procedure": ("procedure", list(procs)), "wall": ("wall", wall_ids),
              "diaphragm": ("diaphragm", diaphragm_ids), "record": ("record", record_ids),
              "reason": ("procedure", reasons)}
    for name in ("slenderness", "supports"):
        if name in ds.coords:
            coords[name] = ds[name].variable.copy()
    out = xr.Dataset({
        "capacity_scale": (dims4, cap, CAPACITY_ATTRS),
        "ida_capacity_scale": (dims4[1:], ida, {
            "long_name": "IDA collapse scale (collapse_scale of the archive, first cor)",
            "units": "1"}),
        "ida_censored": (dims4[1:], censored, {"long_name": "1: the IDA cell is censored (the "
                                                            "wall survived); 0 not"}),
        "ratio": (dims4, ratio, {"long_name": "capacity_scale / ida_capacity_scale",
                                 "units": "1"}),
        "unconservative": (dims4, unc, {
            "long_name": "1: the procedure accepts a scale at which the wall collapses; 0: "
                         "it does not; NaN: not applicable, or unknown (censored IDA cell)"}),
    }, coords=coords)
    out.attrs = {"title": "Assessment procedures against the IDA (urmx.analysis.assessment)",
                 "cor": float(ds["cor"].values[0])}
    for key in ("study_name", "urmx_git_commit", "urmx_git_dirty", "kernel_source_hash",
                "urmx_version"):
        if key in ds.attrs:
            out.attrs[f"archive_{key}"] = ds.attrs[key]
    return out
