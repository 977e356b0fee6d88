"""What every study kind's Dataset shares: the one status vocabulary, the coordinates of the
wall, diaphragm, record and cor dimensions with the items' properties, and the global
attributes (each cell's results are placed in the study's arrays by
`urmx.study.sources`).

xarray is imported only by the functions that build its objects, so a worker that runs a
batch (numpy only) can use the vocabulary without it.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

import numpy as np

from .. import provenance, variables
from ..provenance import attrs
from ..records.record import PROVENANCE

if TYPE_CHECKING:
    import xarray as xr

#: an analysis' status (ok, collapsed, event-limit: the codes 0, 1, 2 the kernel reports,
#: `urmx.kernel.STATUS`, held to these by tests/test_structure.py) and a cell no analysis ran
#: for; the flag values 0, 1, 2, 3 of a grid's ``status`` variable
STATUS = ("ok", "collapsed", "event-limit", "not-run")
NOT_RUN = STATUS.index("not-run")
VALID = (STATUS.index("ok"), STATUS.index("collapsed"))  # statuses whose outputs are kept
MISSING = ("NaN where the cell was not run or its status is not ok/collapsed (event-limit: "
           "the run stopped early, its peaks are not the record's)")


def status_attrs() -> dict[str, Any]:
    """Attributes of a ``status`` variable: the registry's, the CF flags and a comment."""
    attrs = variables.attrs("status")
    attrs["flag_values"] = np.arange(len(STATUS), dtype=np.int8)
    attrs["flag_meanings"] = " ".join(s.replace("-", "_") for s in STATUS)
    attrs["comment"] = ("not_run: the study's pairs leave the cell out or its batch is "
                        "missing; every output of a cell that is not ok or collapsed is "
                        "missing (NaN)")
    return attrs


def status_names(status: xr.DataArray) -> xr.DataArray:
    """The status codes of a study as strings (``ok``, ``collapsed``, ...).

    Parameters
    ----------
    status : xarray.DataArray
        A grid study's ``status`` codes (`STATUS`).
    """
    import xarray as xr

    return xr.apply_ufunc(lambda a: np.asarray(STATUS, dtype=object)[a], status,
                          dask="allowed")


def coord(name: str, dims: Any, values: Any) -> xr.Variable:
    """A coordinate with the registry's attributes."""
    import xarray as xr

    return xr.Variable(dims, values, attrs=variables.attrs(name))


def global_attrs(study: Any, started: str, command: str | None) -> dict[str, Any]:
    """Global attributes of a study archive, shared by every study kind: title, CF
    convention, ``history`` (the time `started`, the urmx version, the `command`), the study
    (``study_name``, ``study``: the study file's text; ``t_rest``, the rest time of held
    joints, MODEL.md section 4) and how it was made
    (`urmx.provenance.attrs`: ``urmx_version`` with the git commit, ``urmx_git_commit``,
    ``urmx_git_dirty``, ``kernel_source_hash`` and the Python and library versions).

    Parameters
    ----------
    study : urmx.study.file.Study
        The study, as loaded from its file.
    started : str
        When the run started (ISO 8601).
    command : str or None
        The command that ran it; None: ``urmx.run_study(NAME)``.
    """
    cmd = command or f"urmx.run_study({study.name!r})"
    return {
        "title": study.title or study.name,
        "Conventions": "CF-1.8",
        "history": f"{started} urmx {provenance.VERSION}: {cmd}",
        "study_name": study.name,
        "study": study.text,
        "t_rest": float(study.t_rest),
        "source": "urmx: exact event-driven rocking of cracked URM walls (MODEL.md)",
        **attrs(),
    }


def _wall_coords(study: Any) -> dict[str, xr.Variable]:
    walls = [w.wall for w in study.walls]
    return {
        "wall": coord("wall", "wall", np.array(study.dims["wall"], dtype=object)),
        "slenderness": coord("slenderness", "wall", np.array([w.slenderness for w in walls])),
        "height": coord("height", "wall", np.array([w.height for w in walls])),
        "thickness": coord("thickness", "wall", np.array([w.thickness for w in walls])),
        "mass": coord("mass", "wall", np.array([w.mass for w in walls])),
        "crack_ratio": coord("crack_ratio", "wall", np.array([w.crack_ratio for w in walls])),
        "pmr": coord("pmr", "wall", np.array([w.pmr for w in walls])),
    }


def reference_wall(catalog: Any) -> Any:
    """The wall a diaphragm's ``frequency`` is given for: the median (by slenderness) of the
    catalog's parametric walls (``s16`` in urmx's catalog), None when it has none. It is
    the catalog's, never the study's: a label never depends on the other cells."""
    specs = sorted((w for w in catalog.walls.values() if w.parametric),
                   key=lambda w: w.slenderness)
    return specs[len(specs) // 2] if specs else None


def diaphragm_frequency(study: Any, diaphragm: Any) -> float:
    """The indicative frequency of a diaphragm, its own property (Table IV footnote: an SDOF
    of its stiffness over the building's diaphragm mass plus half the mass of
    :func:`reference_wall`; the diaphragm mass alone when the catalog has no parametric
    wall), whatever walls the study runs on it. [Hz]"""
    spec = reference_wall(study.catalog)
    if diaphragm.rigid:
        return math.inf
    if not diaphragm.stiffness_value > 0:  # a specimen's own supports: no diaphragm
        return math.nan
    if spec is None:
        return math.sqrt(diaphragm.stiffness_value / study.catalog.building.diaphragm_mass) / (
            2.0 * math.pi)
    return study.catalog.building.wall(spec, diaphragm, "top", 0.0) \
        .diaphragm_frequency("top")


def _diaphragm_coords(study: Any) -> dict[str, xr.Variable]:
    specimen = study.specimen
    cells = [[study.wall(s, d) for d in study.diaphragms] for s in study.walls]
    cell_freq = np.array([[w.diaphragm_frequency("top") for w in row] for row in cells])
    md = study.catalog.building.diaphragm_mass
    nan_if = (lambda value: math.nan if specimen else value)  # noqa: E731
    coords = {
        "diaphragm": coord("diaphragm", "diaphragm",
                           np.array(study.dims["diaphragm"], dtype=object)),
        "stiffness": coord("stiffness", "diaphragm", np.array(
            [nan_if(d.stiffness_value) for d in study.diaphragms])),
        "frequency": coord("frequency", "diaphragm", np.array(
            [nan_if(diaphragm_frequency(study, d)) for d in study.diaphragms])),
        "cell_frequency": coord("cell_frequency", ("wall", "diaphragm"), cell_freq),
        "diaphragm_mass": coord("diaphragm_mass", "diaphragm", np.array(
            [nan_if(md) for _ in study.diaphragms])),
        "diaphragm_damping": coord("diaphragm_damping", "diaphragm", np.array(
            [d.damping for d in study.diaphragms])),
    }
    if specimen:  # each wall's own top support, which the 1-D coordinates cannot hold
        coords.update(_own_support_coords(cells))
    if study.own_supports:
        coords["supports"] = coord("supports", "diaphragm", np.array(
            [study.supports_of(d) for d in study.diaphragms], dtype=object))
    return coords


def _own_support_coords(cells: list[list[Any]]) -> dict[str, xr.Variable]:
    """The top support of every (wall, diaphragm) cell of a study whose walls stand on
    their own supports: stiffness (inf when rigid), mass and damping ratio."""
    def value(w, name: str) -> float:
        v = getattr(w, name)
        return math.inf if v == "rigid" else float(v)

    return {name: coord(name, ("wall", "diaphragm"),
                        np.array([[value(w, field) for w in row] for row in cells]))
            for name, field in (("cell_stiffness", "top_stiffness"),
                                ("cell_diaphragm_mass", "top_mass"),
                                ("cell_diaphragm_damping", "top_damping"))}


def _record_coords(study: Any, records: dict) -> dict[str, xr.Variable]:
    """The record dimension: ids, peaks, scale factors, time steps, and where each record
    comes from (`urmx.records.record.PROVENANCE`: file, SHA-256, format, channel, unit,
    source, processing, points; empty strings for records given in memory)."""
    recs = [records[r] for r in study.records]
    coords = {
        "record": coord("record", "record", np.array(study.dims["record"], dtype=object)),
        "pga": coord("pga", "record", np.array([r.pga for r in recs])),
        "scale_factor": coord("scale_factor", "record",
                              np.array([r.scale_factor for r in recs])),
        "scaled_pga": coord("scaled_pga", "record",
                            np.array([r.pga * r.scale_factor for r in recs])),
        "record_dt": coord("record_dt", "record", np.array([r.dt for r in recs])),
    }
    given = [r.provenance() for r in recs]
    for name in PROVENANCE:
        values = [g[name] for g in given]
        coords[name] = coord(name, "record", np.array(
            values, dtype=np.int64 if name == "record_npts" else object))
    return coords


def grid_coords(study: Any, records: dict) -> dict[str, xr.Variable]:
    """Coordinates of the wall, diaphragm, record and cor dimensions, with the items'
    properties (shared by every study kind).

    Parameters
    ----------
    study : urmx.study.file.Study
        The study, as loaded from its file.
    records : dict
        The study's records by id (:func:`resolve_records`).
    """
    coords = {**_wall_coords(study), **_diaphragm_coords(study), **_record_coords(study, records),
              "cor": coord("cor", "cor", np.array(study.dims["cor"], dtype=np.float64))}
    if "supports" in coords:  # after cor, where it always stood
        coords["supports"] = coords.pop("supports")
    return coords
