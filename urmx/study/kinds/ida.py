"""The IDA study kind (a ``[study.ida]`` table): one collapse capacity per (wall, diaphragm,
record, cor) cell by incremental dynamic analysis (`urmx.fragility`), the IDA curves, and
the lognormal fragility fit of each (wall, diaphragm, cor) over the records.

The table holds ``im`` (the intensity measure), ``rtol``, ``step``, ``max_intensity`` and
``sa_avg_range`` (`IdaSettings`; defaults those of `urmx.fragility.collapse_capacity`). A
batch is any block of cells of one record (`urmx.study.batches`; :func:`run_batch`, numpy
only); the record's intensity for each wall and its predominant frequency travel with every
cell (computed once per batch, and the frequency once per record on each worker). A cell
the study's pairs leave out is missing in every output: NaN, with ``censored``,
``analyses`` and ``event_limits`` float64 in the Dataset and int32 with the ``_FillValue``
on disk.

The cells form chains along ``wall`` (``Kind.chain``): per (diaphragm, record, cor), each
wall's search starts from the capacity of the wall before it that the study pairs with the
record (:func:`warm_hint`; `urmx.fragility.capacity`, "Warm start"), the first one cold. A
batch computes its walls in order; the cut never splits a chain and a chain's finished
predecessor travels with the batch (:func:`hints`); the cells' keys fold the chain before
them (`urmx.study.cells`). The kernel runs with ``track="capacity"`` (the default kernel
only: another integrator is called as given).

The capacities are scale factors times the record's intensity, so one run holds the
capacities in every measure: the archive keeps the scale factor at collapse
(``collapse_scale``) and each record's intensity at scale 1 in every measure
(``record_pga``, ``record_pgv``, ``record_sa_wall``, ``record_sa_diaphragm``,
``record_sa_avg``, computed from the records when the Dataset is assembled), and the
bootstrap intervals of the fits (``median_collapse_intensity_lower`` / ``_upper``,
``dispersion_lower`` / ``_upper``; `urmx.fragility.fit_lognormal`).
"""

from __future__ import annotations

import dataclasses
import functools
import math
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from ... import fragility, variables
from ...kernel import WINDOW, warm_up_capacity
from ...kernel import run as run_kernel
from ...netcdf import INT_FILL
from ...records.measures import dominant_frequency
from ..batches import Batch
from ..dataset import grid_coords
from . import grid
from .kind import Kind

if TYPE_CHECKING:
    import xarray as xr

#: the arrays every batch of :func:`run_batch` returns, per cell (a saved part lacking one is
#: computed again)
OUTPUTS = ("capacity", "censored", "analyses", "event_limits", "intensity", "ratio", "unit",
           "predominant")
#: the archive variable each output is kept in (cells taken over from an earlier archive)
ARCHIVED = {"capacity": "collapse_intensity", "ratio": "instability_ratio",
            "unit": "record_intensity", "predominant": "predominant_frequency"}
CURVE_POINTS = 64  # points of an IDA curve assumed by the size check (a generous bound)
#: the outputs of an IDA archive with one value per (wall, diaphragm, record, cor) cell
CELL_OUTPUTS = ("collapse_intensity", "censored", "analyses", "event_limits",
                "instability_ratio")
MISSING = "NaN where the study's pairs leave the cell out (not run)"
DIMS = ("wall", "diaphragm", "record", "cor")  # the cells: no added dimension
#: what the chain of warm starts means (in the chained cells' keys, `urmx.study.cells`)
CHAIN_TAG = {"warm_start": "previous paired wall", "margin": fragility.MARGIN,
             "exponent": fragility.HINT_EXPONENT, "grid": "(1 + rtol) ** 2 ** j"}


@dataclass(frozen=True)
class IdaSettings:
    """The ``[study.ida]`` table: one collapse capacity per cell (`urmx.fragility`).

    Parameters
    ----------
    im : str
        Intensity measure (`urmx.fragility.IMS`).
    rtol : float
        Relative width of the final bracket. [1]
    step : float
        Ratio of the hunt's geometric grid of scale factors. [1]
    max_intensity : float
        Highest intensity analysed (censoring). [units of the measure]
    sa_avg_range : (float, float) or None
        Periods of ``sa_avg`` for every wall; None: each wall's default range
        (`urmx.fragility.sa_avg_range`). [s]
    """

    im: str = fragility.DEFAULT_IM
    rtol: float = fragility.RTOL
    step: float = fragility.STEP
    max_intensity: float = math.nan
    sa_avg_range: tuple[float, float] | None = None

    def to_dict(self) -> dict[str, Any]:
        """The settings (``sa_avg_range`` only when given: batch keys of studies without it
        stay those of before it existed)."""
        out = dataclasses.asdict(self)
        if out["sa_avg_range"] is None:
            del out["sa_avg_range"]
        return out


#: the keys of ``[study.ida]`` (the fields of `IdaSettings`)
KEYS = ("im", "rtol", "step", "max_intensity", "sa_avg_range")


def parse(study: Any) -> IdaSettings:
    """Validate ``[study.ida]`` and the grid it runs on (errors name file, key and line)."""
    table = study.tables["ida"]
    if not isinstance(table, dict):
        raise study.error("study.ida", "must be a table (im, rtol, step, max_intensity)",
                          "ida")
    for k in table:
        if k not in KEYS:
            raise study.error(f"study.ida.{k}", f"unknown key (known: {', '.join(KEYS)})",
                              "ida", k)
    im = table.get("im", IdaSettings.im)
    if im not in fragility.IMS:
        raise study.error("study.ida.im", f"{im!r} is not an intensity measure (known: "
                          f"{', '.join(fragility.IMS)})", "ida", "im")
    values = {}
    for k, default, low in (("rtol", IdaSettings.rtol, 0.0), ("step", IdaSettings.step, 1.0),
                            ("max_intensity", fragility.MAX_INTENSITY[im], 0.0)):
        v = table.get(k, default)
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) \
                or v <= low:
            raise study.error(f"study.ida.{k}", f"{v!r} must be a number above {low:g}", "ida",
                              k)
        values[k] = float(v)
    if values["rtol"] >= 1.0:
        raise study.error("study.ida.rtol", f"{values['rtol']!r} must be below 1", "ida",
                          "rtol")
    if "sa_avg_range" in table:
        try:
            values["sa_avg_range"] = fragility.intensity.check_period_range(
                table["sa_avg_range"], "sa_avg_range")
        except ValueError as exc:
            raise study.error("study.ida.sa_avg_range", str(exc), "ida",
                              "sa_avg_range") from None
    for k in ("scale", "impact", "damping"):
        if k in study.extra:
            raise study.error(f"study.{k}", "an IDA study scales each record itself and runs "
                              f"one capacity per (wall, diaphragm, record, cor): {k} cannot be "
                              "a dimension here", k)
    if study.histories:
        raise study.error("study.history", "an IDA study keeps no time histories", "history")
    settings = IdaSettings(im=im, **values)
    _check_learnable(study, settings)
    return settings


def _check_learnable(study: Any, settings: IdaSettings) -> None:
    """Refuse a ``max_intensity`` below the search's first analysis in every cell: each
    cell would be analysed once, at max_intensity, and (surviving it, as the search expects
    below half a wall's static acceleration) censored there, so the study could learn no
    capacity. Checked for ``im = "pga"``, whose start depends on the wall alone
    (`urmx.fragility.START_FRACTION` of its `static_acceleration`); the other measures'
    starts depend on the records, which are read after loading."""
    if settings.im != "pga":
        return
    starts = [(fragility.START_FRACTION * fragility.static_acceleration(study.wall(w, d)),
               w.id, d.id) for w in study.walls for d in study.diaphragms]
    least = min(starts)
    if settings.max_intensity < least[0]:
        raise study.error(
            "study.ida.max_intensity", f"{settings.max_intensity:g} m s-2 lies below where "
            f"the collapse search starts in every cell ({fragility.START_FRACTION:g} x the "
            f"wall's static acceleration; the least: {least[0]:.3g} m s-2, wall "
            f"{least[1]!r} on {least[2]!r}): every cell would be analysed once, at "
            "max_intensity, and censored there, so nothing could be learnt; raise it "
            f"(default {fragility.MAX_INTENSITY['pga']:g} m s-2, 5 g)", "ida", "max_intensity")


def dims(study: Any) -> dict[str, list]:
    """The cells: wall, diaphragm, record, cor."""
    return {k: study.dims[k] for k in DIMS}


def task(study: Any, records: dict, batch: Batch, kernel: Callable | None) -> dict[str, Any]:
    """Everything a worker needs for one block of cells (picklable, no xarray)."""
    b = batch.block
    rec = records[study.records[batch.record]]
    return dict(walls=[[study.wall(study.walls[iw], study.diaphragms[idp])
                        for idp in b["diaphragm"]] for iw in b["wall"]],
                dt=rec.dt, scale_factor=rec.scale_factor, record=rec.digest,
                cor=[study.cor[i] for i in b["cor"]], impact=study.impact,
                ida=study.settings.to_dict(), kernel=kernel, t_rest=study.t_rest,
                hint=hints(batch.before, lambda iw: [
                    study.wall(study.walls[iw], study.diaphragms[idp])
                    for idp in b["diaphragm"]]))


def hints(before: dict[str, np.ndarray] | None, walls: Callable[[int], list]
          ) -> tuple[np.ndarray, np.ndarray] | None:
    """What the block's first wall starts its searches from, per (diaphragm, cor) of the
    block: the capacity of the wall before it in the chain as a scale factor (its capacity
    over its record intensity; NaN: a cold start) and that wall's static acceleration
    [m s-2] (`walls(index)`: the block's diaphragms' walls at that wall index); None when
    the block starts every chain."""
    if before is None or not np.isfinite(before["capacity"]).any():
        return None
    scale = (before["capacity"] / before["unit"])[0, :, 0, :]
    static = np.array([fragility.static_acceleration(w) for w in walls(int(before["index"]))])
    return scale, np.broadcast_to(static[:, None], scale.shape).copy()


def warm_hint(scale: float, static_before: float, static: float) -> float:
    """The scale factor a wall's search starts from (`urmx.fragility.capacity`, "Warm
    start"): the capacity of the wall before it in the chain, times the ratio of the two
    walls' static accelerations to the power `fragility.HINT_EXPONENT` (NaN: cold)."""
    return float(scale * (static / static_before) ** fragility.HINT_EXPONENT)


_PREDOMINANT: dict[tuple, float] = {}  # a worker's predominant frequencies, by record


def _predominant(task: dict, acc: np.ndarray) -> float:
    """The record's predominant frequency, computed once per record in each process."""
    key = (task["record"], task["scale_factor"], task["dt"])
    if key not in _PREDOMINANT:
        if len(_PREDOMINANT) > 256:
            _PREDOMINANT.clear()
        _PREDOMINANT[key] = float(dominant_frequency(acc, task["dt"]))
    return _PREDOMINANT[key]


def run_batch(task: dict, acceleration: np.ndarray) -> dict[str, np.ndarray]:
    """One block: the collapse capacity of every (wall, diaphragm, cor) cell, as numpy
    arrays of the block's shape (capacity, censored, analyses, event_limits; the IDA points
    ``intensity`` and ``ratio`` with a last axis of points, NaN-padded; the record's
    intensity ``unit`` for the cell's wall and its ``predominant`` frequency). Numpy only."""
    kernel = task["kernel"] or run_kernel
    # the default kernel tracks only what the search needs (bit-identical capacities)
    track = fragility.capacity.TRACK if task["kernel"] is None else None
    rest = grid.rest_time(task)
    if rest:
        kernel = functools.partial(kernel, **rest)
    acc = np.ascontiguousarray(acceleration * task["scale_factor"], dtype=np.float64)
    ida, dt = task["ida"], task["dt"]
    walls = [w for row in task["walls"] for w in row]
    shape = (len(task["walls"]), len(task["walls"][0]), 1, len(task["cor"]))
    unit = fragility.record_intensities(acc, dt, ida["im"], walls,
                                        ida.get("sa_avg_range")).reshape(shape[:2])
    results = {}
    nan = np.full((shape[1], shape[3]), np.nan)
    prev, static = (np.array(a) for a in (task.get("hint") or (nan, nan)))
    for iw, idp, _, ic in np.ndindex(*shape):  # each wall after the one before it
        wall = task["walls"][iw][idp]
        a = fragility.static_acceleration(wall)
        r = results[iw, idp, ic] = fragility.cell_capacity(
            kernel, wall, acc, dt, float(unit[iw, idp]), ida["im"],
            task["cor"][ic], task["impact"], ida["rtol"], ida["step"], ida["max_intensity"],
            hint_scale=warm_hint(prev[idp, ic], static[idp, ic], a), track=track)
        # the next wall's, as a later batch computes it from the stored outputs
        prev[idp, ic] = np.float64(r.capacity) / np.float64(unit[iw, idp])
        static[idp, ic] = a
    k = max(r.analyses for r in results.values())
    out = {"capacity": np.full(shape, np.nan), "censored": np.zeros(shape, bool),
           "analyses": np.zeros(shape, np.int32), "event_limits": np.zeros(shape, np.int32),
           "intensity": np.full((*shape, k), np.nan), "ratio": np.full((*shape, k), np.nan),
           "unit": np.broadcast_to(unit[:, :, None, None], shape).copy(),
           "predominant": np.full(shape, _predominant(task, acc))}
    for (iw, idp, ic), r in results.items():
        at = (iw, idp, 0, ic)
        out["capacity"][at] = r.capacity
        out["censored"][at] = r.censored
        out["analyses"][at] = r.analyses
        out["event_limits"][at] = r.event_limits
        out["intensity"][at][:r.analyses] = r.intensity
        out["ratio"][at][:r.analyses] = r.instability_ratio
    return out


# ---- the Dataset ----------------------------------------------------------------------------

def _cells(cells: dict) -> dict[str, np.ndarray]:
    """Every per-cell output over (wall, diaphragm, record, cor [, intensity_step]), in
    memory: float64, NaN where the cell was not run (the flag and counts too, so that sums
    and means skip those cells; int32 with a _FillValue on disk); the record's intensity
    per (wall, diaphragm, record) and its predominant frequency per record."""
    c = {name: np.asarray(v) for name, v in cells.items()}
    out = {"collapse_intensity": c["capacity"], "censored": c["censored"],
           "analyses": c["analyses"], "event_limits": c["event_limits"],
           "intensity": c["intensity"], "instability_ratio": c["ratio"]}
    out["record_intensity"] = np.fmax.reduce(c["unit"], axis=3)
    out["predominant_frequency"] = np.fmax.reduce(c["predominant"], axis=(0, 1, 3))
    return out


def _record_measures(study: Any, records: dict) -> dict[str, np.ndarray]:
    """Each record's intensity at scale 1 in every measure (`urmx.fragility.RECORD_IMS`):
    ``record_pga`` and ``record_pgv`` per record, the spectral ones per (wall, diaphragm,
    record); and the ``sa_avg`` period range per (wall, diaphragm). One pass of the
    response spectrum per record over every cell's periods."""
    walls = [study.wall(w, d) for w in study.walls for d in study.diaphragms]
    shape = (len(study.walls), len(study.diaphragms))
    rng = study.settings.sa_avg_range
    out = {f"record_{im}": np.full((*shape, len(study.records)), np.nan)
           for im in fragility.RECORD_IMS}
    for ir, rid in enumerate(study.records):
        rec = records[rid]
        m = fragility.record_measures(rec.scaled(), rec.dt, walls, rng)
        for im, v in m.items():
            out[f"record_{im}"][..., ir] = v.reshape(shape)
    for im in ("pga", "pgv"):  # a property of the record alone
        out[f"record_{im}"] = out[f"record_{im}"][0, 0]
    ranges = np.array([rng or fragility.sa_avg_range(w) for w in walls]).reshape(*shape, 2)
    out["sa_avg_period_low"], out["sa_avg_period_high"] = ranges[..., 0], ranges[..., 1]
    return out


FIT_OUTPUTS = ("median_collapse_intensity", "dispersion", "median_collapse_intensity_lower",
               "median_collapse_intensity_upper", "dispersion_lower", "dispersion_upper")


def _fits(cap: np.ndarray, cen: np.ndarray) -> dict[str, np.ndarray]:
    """The lognormal fit over the records of each (wall, diaphragm, cor) and the bootstrap
    intervals of its median and dispersion (`FIT_OUTPUTS`); NaN where no fit exists."""
    shape = (cap.shape[0], cap.shape[1], cap.shape[3])
    out = {name: np.full(shape, np.nan) for name in FIT_OUTPUTS}

    def fit(at):
        iw, idp, ic = at
        ran = np.isfinite(cap[iw, idp, :, ic])
        try:
            f = fragility.fit_lognormal(cap[iw, idp, ran, ic], cen[iw, idp, ran, ic])
        except ValueError:
            return
        for name, v in zip(FIT_OUTPUTS, (f.median, f.dispersion, *f.median_ci,
                                         *f.dispersion_ci), strict=True):
            out[name][at] = v

    # (each fit on its own: two threads, whose numpy work runs without the GIL, take 0.7
    # of the time; the same numbers)
    with ThreadPoolExecutor(max_workers=2) as pool:
        for _ in pool.map(fit, np.ndindex(shape)):
            pass
    return out


def _data_vars(cells: dict, fits: dict, measures: dict,
               attrs: Callable) -> dict[str, xr.Variable]:
    import xarray as xr

    curve = (*DIMS, "intensity_step")
    fit_dims = ("wall", "diaphragm", "cor")
    stored = f"{MISSING}; stored as int32 with _FillValue {INT_FILL}, read as float64"
    ci = (f"percentile bootstrap over the records at {fragility.CONFIDENCE:g}, "
          f"{fragility.RESAMPLES} resamples (urmx.fragility.fit_lognormal)")
    out = {
        "collapse_intensity": xr.Variable(DIMS, cells["collapse_intensity"], attrs=attrs(
            "collapse_intensity", comment=MISSING)),
        "censored": xr.Variable(DIMS, cells["censored"], attrs=attrs(
            "censored", comment=f"1 censored, 0 not; {stored}")),
        "instability_ratio": xr.Variable(curve, cells["instability_ratio"], attrs=attrs(
            "instability_ratio", comment="IDA curve: one value per analysis of the cell, "
            "ascending intensity; NaN after the cell's last analysis and where the cell "
            "was not run")),
        **{name: xr.Variable(fit_dims, fits[name], attrs=attrs(name, **(
            {"comment": ci} if name.endswith(("_lower", "_upper")) else {})))
           for name in FIT_OUTPUTS},
        "analyses": xr.Variable(DIMS, cells["analyses"], attrs=attrs("analyses",
                                                                     comment=stored)),
        "event_limits": xr.Variable(DIMS, cells["event_limits"], attrs=attrs(
            "event_limits", comment=stored)),
        "record_intensity": xr.Variable(DIMS[:3], cells["record_intensity"],
                                        attrs=attrs("record_intensity")),
        "collapse_scale": xr.Variable(DIMS, cells["collapse_intensity"]
                                      / cells["record_intensity"][..., None],
                                      attrs=attrs("collapse_scale", comment=MISSING)),
    }
    for im in fragility.RECORD_IMS:
        v = measures[f"record_{im}"]
        out[f"record_{im}"] = xr.Variable(DIMS[2:3] if v.ndim == 1 else DIMS[:3], v,
                                          attrs=attrs(f"record_{im}"))
    return out


def _coords(study: Any, records: dict, cells: dict, attrs: Callable) -> dict[str, xr.Variable]:
    import xarray as xr


    k = cells["intensity"].shape[-1]
    periods = np.array([[fragility.rocking_period(study.wall(w, d)) for d in study.diaphragms]
                        for w in study.walls])
    coords = grid_coords(study, records)
    coords["intensity_step"] = xr.Variable("intensity_step", np.arange(k),
                                           attrs=attrs("intensity_step"))
    coords["intensity"] = xr.Variable((*DIMS, "intensity_step"), cells["intensity"],
                                      attrs=attrs("intensity"))
    coords["rocking_period"] = xr.Variable(("wall", "diaphragm"), periods,
                                           attrs=attrs("rocking_period"))
    for name in ("sa_avg_period_low", "sa_avg_period_high"):
        coords[name] = xr.Variable(("wall", "diaphragm"), cells[name], attrs=attrs(name))
    coords["predominant_frequency"] = xr.Variable(
        "record", cells["predominant_frequency"], attrs=attrs(
            "predominant_frequency", comment="of each record, Konno-Ohmachi smoothed "
            "(urmx.records.predominant_frequency)"))
    return coords


def assemble(study: Any, records: dict, cells: dict, extras: dict,
             attrs: dict[str, Any], prepared: dict | None = None) -> xr.Dataset:
    """The Dataset of an IDA study: capacities, censoring, IDA curves and the lognormal
    fits per (wall, diaphragm, cor), with the grid's coordinates (`prepared`: the record
    measures, `_record_measures`, computed while the cells ran)."""
    import xarray as xr

    settings = study.settings
    ctx = variables.intensity_context(settings.im)

    def var_attrs(name, **extra):
        return {**variables.attrs(name, None, **ctx), **extra}

    cells = _cells(cells)
    measures = dict(prepared) if prepared is not None else _record_measures(study, records)
    cells.update({k: measures.pop(k) for k in ("sa_avg_period_low", "sa_avg_period_high")})
    fits = _fits(cells["collapse_intensity"], cells["censored"])
    gattrs = dict(attrs)
    gattrs.update({"intensity_measure": settings.im, "ida_rtol": settings.rtol,
                   "ida_step": settings.step, "ida_max_intensity": settings.max_intensity,
                   "ida_convention": "first collapse: the lowest collapse the hunt and "
                                     "bisection saw; censored cells hold max_intensity",
                   "sa_avg_periods": fragility.SA_AVG_PERIODS,
                   "sa_avg_range": "per wall: urmx.fragility.sa_avg_range" if
                   settings.sa_avg_range is None else list(settings.sa_avg_range),
                   "confidence_level": fragility.CONFIDENCE,
                   "bootstrap_resamples": fragility.RESAMPLES,
                   "bootstrap_seed": fragility.fits.SEED})
    return xr.Dataset(_data_vars(cells, fits, measures, var_attrs),
                      coords=_coords(study, records, cells, var_attrs), attrs=gattrs)


def reopen(ds: xr.Dataset) -> xr.Dataset | None:
    """An IDA archive written before urmx stored missing cells with a ``_FillValue`` (-1
    counts, ``censored`` False where a cell was not run), masked by ``analyses``; None when
    `ds` is not an IDA archive of that kind."""
    if "collapse_intensity" not in ds.data_vars or "analyses" not in ds.data_vars \
            or ds["analyses"].dtype.kind not in "iub":
        return None
    valid = ds["analyses"] >= 0
    for name in CELL_OUTPUTS:
        if name in ds.data_vars:
            ds[name] = ds[name].where(valid).assign_attrs(dict(ds[name].attrs, comment=MISSING))
    return ds


def cell_bytes(study: Any) -> float:
    """Bytes of one cell's outputs in the archive, for IDA curves of `CURVE_POINTS`
    points. [B]"""
    return 8 + 3 * 4 + 2 * 8 * CURVE_POINTS


def counts(ds: xr.Dataset) -> dict[str, int] | None:
    """The cells of an IDA archive: ``collapsed`` (a capacity), ``censored`` (survived
    max_intensity) and ``missing`` (not run); None when `ds` is not an IDA archive."""
    if "collapse_intensity" not in ds.data_vars or "censored" not in ds.data_vars:
        return None
    censored = np.asarray(ds["censored"].values, dtype=np.float64)
    return {"collapsed": int((censored == 0).sum()), "censored": int((censored == 1).sum()),
            "missing": int(np.isnan(censored).sum())}


KIND = Kind(name="ida", table="ida", unit="cells", outputs=OUTPUTS, parse=parse, dims=dims,
            task=task, run=run_batch, assemble=assemble, reopen=reopen, archived=ARCHIVED,
            cell_bytes=cell_bytes, counts=counts, keys=KEYS,
            warm_up=warm_up_capacity, prepare=_record_measures, dt_above=WINDOW, chain="wall",
            chain_tag=CHAIN_TAG,
            chained=("capacity", "unit"))
