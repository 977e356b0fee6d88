"""The sampling study kinds (a ``[study.sampling]`` table): each sample is a wall whose
model parameters (COR, PMR, crack height, the diaphragm's frequency, the impact law, ...)
are drawn from their distributions; every sample runs over the study's walls, diaphragms
and records, as time histories (the kind ``sampling``) or, with ``[study.ida]`` beside it,
as collapse capacities with the lognormal fits per sample and over records and samples
together (the kind ``sampling-ida``).

The table holds ``samples``, ``seed``, optionally ``method`` (``lhs``, ``sobol``,
``random``, ``saltelli``) and ``[study.sampling.parameters]``, one inline table per
parameter (`urmx.uncertainty.sampler` says what each parameter does, and
`urmx.uncertainty.distributions` the distributions). A sampled value replaces the study's
(a factor multiplies it); the study's ``cor`` (one value) and ``impact`` (one law) are
what the samples that do not draw them use. The samples are drawn and every sample's wall
is built for every (wall, diaphragm) cell when the study file is loaded: a sample that
makes no valid wall (a PMR outside (0, 100], or one that leaves no plateau with the wall's
kappa) is refused then, naming the parameter, and nothing runs.

The cells are (wall, diaphragm, record, sample); the engine cuts them over every dimension,
``sample`` included, and keys each cell by what decides its result (`urmx.study.cells`):
a sample by its values, cor and impact law (:func:`identity`), the settings by the IDA
settings alone. So a design extended by more samples (``sobol`` or ``random`` of the same
seed keep their first points) reuses the cells of the samples it shares, from the parts or
from an earlier archive, as a study extended by a wall or a record does. The archive has a
``sample`` dimension with each sampled value as a coordinate on it (a factor as
``<parameter>_factor``), the design's points ``sample_unit(sample, parameter)`` and
``cell_frequency(wall, diaphragm, sample)``. A block of cells runs sample by sample through
the grid's or the IDA kind's own batch runner (:func:`run_batch`): time histories give the
grid's peak outputs and ``status`` per cell; collapse capacities give the IDA kind's per-cell
outputs, ``median_collapse_intensity`` and ``dispersion`` per (wall, diaphragm, sample) over
the records, and per (wall, diaphragm) the fit over records and samples together
(``total_median_collapse_intensity``, ``total_dispersion``) with its parts
(``record_dispersion``, ``model_dispersion``; `urmx.uncertainty.spread`). With
``[study.ida]`` the cells form the IDA kind's chains along ``wall`` (per diaphragm, record
and sample: each wall's search starts from the capacity of the wall before it,
`urmx.study.kinds.ida`); a study of one wall runs every cell cold.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from dataclasses import InitVar, dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from ... import fragility, variables
from ...fragility.intensity import IM_ATTRS, record_measures
from ...fragility.predictors import PREDICTORS, wall_predictors
from ...model import EFFECTIVE_MASS, PAPER_G
from ...netcdf import INT_FILL
from ...records.readers import check_finite
from ...uncertainty import ParameterError, apply, check_samples, modelling_fit, parse_sampling
from ...uncertainty.sampler import GEOMETRY, PARAMETERS, coordinate_name, sample_values
from ..batches import Batch
from ..dataset import NOT_RUN, VALID, coord, grid_coords
from . import grid, ida
from .kind import Kind

if TYPE_CHECKING:
    import xarray as xr

DIMS = ("wall", "diaphragm", "record", "sample")
#: the keys of ``[study.sampling]`` (`urmx.uncertainty.sampler.KEYS`; docs/study-files.md)
SAMPLING_KEYS = ("samples", "seed", "method", "parameters", "max_slenderness")
FIT_OUTPUTS = ("total_median_collapse_intensity", "total_dispersion", "record_dispersion",
               "model_dispersion")


@dataclass(frozen=True, eq=False)
class SamplingSettings:
    """A sampling study's settings: the IDA settings when ``[study.ida]`` sits beside the
    table, and the drawn design.

    Its one field, ``ida``, is what the settings add to every cell's key
    (`urmx.study.cells`); the draw is keyed sample by sample on the ``sample`` dimension
    (:func:`identity`), so that two designs share the cells of the samples they share.

    Attributes
    ----------
    sampling : urmx.uncertainty.Sampling
        The ``[study.sampling]`` table.
    unit : ndarray, shape (samples, parameters)
        The design's points of the unit hypercube. [1]
    values : dict of str to ndarray
        Each parameter's value per sample.
    """

    ida: Any = None
    draw: InitVar[tuple] = None

    def __post_init__(self, draw: tuple) -> None:
        sampling, unit, values = draw
        for name, value in (("sampling", sampling), ("unit", unit), ("values", values)):
            object.__setattr__(self, name, value)

    @property
    def size(self) -> int:
        return self.unit.shape[0]

    def sample(self, j: int) -> dict[str, Any]:
        """Sample `j`'s value of each parameter."""
        return sample_values(self.values, j)


def _error(study: Any, exc: Any) -> Exception:
    """A `urmx.uncertainty.ParameterError` as the study file's error (file, key, line)."""
    parts = [p for p in exc.key.split(".") if p]
    return study.error(".".join(["study.sampling", *parts]), str(exc), "sampling",
                       *[p for p in parts if p != "parameters"])


def _check_grid(study: Any) -> None:
    """The study's grid a sampling study can run: one cor, one impact law, no added
    dimension and no kept histories."""
    if len(study.cor) != 1:
        raise study.error("study.cor", f"a sampling study runs one cor per sample: give one "
                          f"value (what samples that do not draw cor use), not {study.cor}",
                          "cor")
    for k in study.extra:
        how = ("with [study.ida] each record is scaled to collapse" if k == "scale" else
               f"sample it: [study.sampling.parameters] {k} = {{ ... }}")
        raise study.error(f"study.{k}", f"a sampling study cannot have {k} as a dimension "
                          f"({how})", k)
    if study.histories:
        raise study.error("study.history", "a sampling study keeps no time histories",
                          "history")


def parse(study: Any) -> SamplingSettings:
    """Validate ``[study.sampling]`` (and ``[study.ida]`` beside it) and the grid, draw the
    samples and build every sample's wall of every (wall, diaphragm) cell: a bad table or
    an invalid sample is an error naming file, key and line, before any work."""
    try:
        sampling = parse_sampling(study.tables["sampling"])
    except ParameterError as exc:
        raise _error(study, exc) from None
    _check_grid(study)
    settings = ida.parse(study) if "ida" in study.tables else None
    unit, values = sampling.draw()
    walls = {f"{spec.id!r} on diaphragm {d.id!r}": study.wall(spec, d)
             for spec in study.walls for d in study.diaphragms}
    try:
        check_samples(values, walls)
    except ParameterError as exc:
        raise _error(study, exc) from None
    return SamplingSettings(ida=settings, draw=(sampling, unit, values))


def dims(study: Any) -> dict[str, list]:
    """The cells: wall, diaphragm, record, sample."""
    return {"wall": study.dims["wall"], "diaphragm": study.dims["diaphragm"],
            "record": study.dims["record"], "sample": list(range(study.settings.size))}


def _law(study: Any, s: dict[str, Any]) -> tuple[float, str]:
    """(cor, impact law) a sample runs with: its own where it draws them, else the
    study's."""
    return float(s.get("cor", study.cor[0])), str(s.get("impact", study.impact))


def identity(study: Any, records: dict) -> dict[str, list]:
    """What a sample means for a cell's result: its values, cor and impact law (the wall
    and diaphragm it changes have their own identities)."""
    out = []
    for j in range(study.settings.size):
        s = study.settings.sample(j)
        cor, law = _law(study, s)
        out.append({"values": s, "cor": cor, "impact": law})
    return {"sample": out}


def _walls(study: Any, iw: int, idp: int, samples: list[int]) -> list:
    """Sample j's wall of the study's (wall, diaphragm) cell, for each j of `samples`."""
    base = study.wall(study.walls[iw], study.diaphragms[idp])
    return [apply(base, study.settings.sample(j)) for j in samples]


def task(study: Any, records: dict, batch: Batch, kernel: Callable | None) -> dict[str, Any]:
    """One block of cells as one task of the grid's or the IDA kind's runner per sample
    (plain values, picklable, no xarray)."""
    b, settings = batch.block, study.settings
    rec = records[study.records[batch.record]]
    walls = {(iw, idp): _walls(study, iw, idp, b["sample"]) for iw in b["wall"]
             for idp in b["diaphragm"]}
    per_sample = []
    for n, j in enumerate(b["sample"]):
        cor, law = _law(study, settings.sample(j))
        cells = [[walls[iw, idp][n] for idp in b["diaphragm"]] for iw in b["wall"]]
        if settings.ida is None:
            per_sample.append(dict(
                walls=[[[w] for w in row] for row in cells], dt=rec.dt,
                scale_factor=rec.scale_factor, cor=[cor], scale=[1.0], impact=[law],
                tail=study.tail, t_rest=study.t_rest, history=[], kernel=kernel,
                shape=(len(b["wall"]), len(b["diaphragm"]), 1, 1)))
        else:
            before = None if batch.before is None else {
                k: (v[..., n:n + 1] if v.ndim else v) for k, v in batch.before.items()}
            per_sample.append(dict(walls=cells, dt=rec.dt, scale_factor=rec.scale_factor,
                                   record=rec.digest, cor=[cor], impact=law,
                                   t_rest=study.t_rest,
                                   hint=ida.hints(before, lambda iw, j=j: [
                                       _walls(study, iw, idp, [j])[0]
                                       for idp in b["diaphragm"]]),
                                   ida=settings.ida.to_dict(), kernel=kernel))
    return {"samples": per_sample, "ida": settings.ida is not None}


# ---- a block on a worker (numpy only) ----------------------------------------------------

def run_batch(task: dict[str, Any], acceleration: np.ndarray) -> dict[str, np.ndarray]:
    """One block, sample by sample through the grid's (time histories) or the IDA kind's
    (collapse capacities) runner, joined on the sample axis: arrays of the block's shape
    (IDA curves padded with NaN to the longest). Numpy only."""
    run = ida.run_batch if task["ida"] else grid.run_batch
    parts = [run(t, acceleration) for t in task["samples"]]
    out = {}
    for name in parts[0]:
        arrays = [p[name] for p in parts]
        if arrays[0].ndim > 4:  # an IDA curve: pad its points to the longest
            k = max(a.shape[4] for a in arrays)
            arrays = [np.pad(a, [(0, 0)] * 4 + [(0, k - a.shape[4])],
                             constant_values=np.nan) for a in arrays]
        out[name] = np.concatenate(arrays, axis=3)
    return out


# ---- the Dataset ------------------------------------------------------------------------------

def _history_vars(cells: dict) -> dict[str, xr.Variable]:
    """The grid's peak outputs and status over the cells (NaN where not valid)."""
    import xarray as xr

    status = cells["status"]
    invalid = ~np.isin(status, VALID)
    out = {name: xr.Variable(DIMS, np.where(invalid, np.nan,
                                            cells[name].astype(np.float64)),
                             attrs=grid.output_attrs(name)) for name in variables.SCALARS}
    out["status"] = xr.Variable(DIMS, status, attrs=grid.output_attrs("status"))
    return out


def _fits(cap: np.ndarray, cen: np.ndarray) -> dict[str, np.ndarray]:
    """Per (wall, diaphragm): the fit of each sample over the records and over records
    and samples together (`urmx.uncertainty.modelling_fit`)."""
    nw, nd, _, ns = cap.shape
    out = {"median_collapse_intensity": np.full((nw, nd, ns), np.nan),
           "dispersion": np.full((nw, nd, ns), np.nan),
           **{name: np.full((nw, nd), np.nan) for name in FIT_OUTPUTS}}
    for iw, idp in np.ndindex(nw, nd):
        f = modelling_fit(cap[iw, idp].T, cen[iw, idp].T)
        out["median_collapse_intensity"][iw, idp] = f["median"]
        out["dispersion"][iw, idp] = f["dispersion"]
        out["total_median_collapse_intensity"][iw, idp] = f["total_median"]
        for name in FIT_OUTPUTS[1:]:
            out[name][iw, idp] = f[name]
    return out


def _capacity_vars(cells: dict, attrs: Callable) -> dict[str, xr.Variable]:
    """The IDA kind's per-cell outputs over (wall, diaphragm, record, sample) and the fits
    with modelling uncertainty."""
    import xarray as xr


    missing = "NaN where the study's pairs leave the cell out (not run)"
    stored = f"{missing}; stored as int32 with _FillValue {INT_FILL}, read as float64"
    cap, cen = np.asarray(cells["capacity"]), np.asarray(cells["censored"], dtype=np.float64)
    fits = _fits(cap, cen)
    out = {
        "collapse_intensity": xr.Variable(DIMS, cap, attrs=attrs(
            "collapse_intensity", comment=missing)),
        "censored": xr.Variable(DIMS, cen, attrs=attrs(
            "censored", comment=f"1 censored, 0 not; {stored}")),
        "instability_ratio": xr.Variable((*DIMS, "intensity_step"), cells["ratio"], attrs=attrs(
            "instability_ratio", comment="IDA curve: one value per analysis of the cell, "
            "ascending intensity; NaN after the cell's last analysis")),
        "analyses": xr.Variable(DIMS, cells["analyses"], attrs=attrs("analyses",
                                                                     comment=stored)),
        "event_limits": xr.Variable(DIMS, cells["event_limits"],
                                    attrs=attrs("event_limits", comment=stored)),
        "record_intensity": xr.Variable(DIMS, cells["unit"], attrs=attrs("record_intensity")),
    }
    for name in ("median_collapse_intensity", "dispersion"):
        out[name] = xr.Variable(("wall", "diaphragm", "sample"), fits[name], attrs=attrs(
            name, comment="over the records, the model held at the sample"))
    for name in FIT_OUTPUTS:
        out[name] = xr.Variable(("wall", "diaphragm"), fits[name], attrs=attrs(name))
    return out


# ---- coordinates --------------------------------------------------------------------------------

def _cell_walls(study: Any, fn: Callable) -> np.ndarray:
    """``fn(wall)`` of every (wall, diaphragm, sample) cell's sampled wall."""
    n = study.settings.size
    out = np.full((len(study.walls), len(study.diaphragms), n), np.nan)
    for iw, idp in np.ndindex(*out.shape[:2]):
        out[iw, idp] = [fn(w) for w in _walls(study, iw, idp, list(range(n)))]
    return out


def _sample_coords(study: Any) -> dict[str, xr.Variable]:
    """The ``sample`` dimension: each sampled value, the cor and impact law every sample
    runs with, and the design's points of the unit hypercube."""
    import xarray as xr

    s = study.settings
    n = s.size
    coords = {"sample": coord("sample", "sample", np.arange(n)),
              "parameter": coord("parameter", "parameter",
                                 np.array(list(s.sampling.names), dtype=object)),
              "sample_unit": coord("sample_unit", ("sample", "parameter"), s.unit)}
    for name, dist in s.sampling.parameters.items():
        values = s.values[name]
        values = values.astype(object) if dist.kind == "choice" and \
            isinstance(values[0], str) else values.astype(np.float64)
        attrs = {"units": PARAMETERS[name].units, "long_name": PARAMETERS[name].long_name}
        attrs = {k: v for k, v in attrs.items() if v}
        attrs["comment"] = f"sampled: {dist.describe()}"
        coords[coordinate_name(name)] = xr.Variable("sample", values, attrs=attrs)
    if "cor" not in coords:
        coords["cor"] = coord("cor", "sample", np.full(n, float(study.cor[0])))
    if "impact" not in coords:
        coords["impact"] = coord("impact", "sample", np.full(n, study.impact, dtype=object))
    return coords


def _coords(study: Any, records: dict) -> dict[str, xr.Variable]:
    """The shared coordinates (a sampled wall field's replaced by the sample's), the
    sample's, and each cell's diaphragm frequency."""
    coords = grid_coords(study, records)
    drawn = _geometry_sampled(study)
    for name in list(coords):
        if name in ("cor", "cell_frequency") or name in study.settings.values or (
                drawn and name in ("slenderness", "mass", "diaphragm_mass")):
            del coords[name]
    coords.update(_sample_coords(study))
    coords["cell_frequency"] = coord("cell_frequency", ("wall", "diaphragm", "sample"),
                                     _cell_walls(study, lambda w: w.diaphragm_frequency("top")))
    if drawn:
        coords.update(_drawn_coords(study))
    return coords


def _geometry_sampled(study: Any) -> bool:
    """Whether the study draws its walls in geometry (`urmx.uncertainty.sampler.GEOMETRY`)."""
    return any(k in study.settings.values for k in GEOMETRY)


def _drawn_coords(study: Any) -> dict[str, xr.Variable]:
    """Each cell's drawn wall: slenderness, effective wall and diaphragm masses and the
    tributary plan area of the diaphragm's seismic weight (`urmx.uncertainty.sampler`)."""
    import xarray as xr


    dims3 = ("wall", "diaphragm", "sample")
    out = {"slenderness": xr.Variable(dims3, _cell_walls(study, lambda w: w.slenderness),
                                      attrs={"units": "1", "long_name": "h/t of the drawn "
                                             "wall"}),
           "mass": xr.Variable(dims3, _cell_walls(study, lambda w: w.mass), attrs={
               "units": "kg", "long_name": "effective wall mass (Eq. 7)"}),
           "diaphragm_mass": xr.Variable(dims3, _cell_walls(study, lambda w: w.top_mass),
                                         attrs={"units": "kg", "long_name": "effective top "
                                                "diaphragm mass (Eq. 7; the overburden)"})}
    q = study.settings.values.get("diaphragm_weight")
    if q is not None:
        area = out["diaphragm_mass"].values * PAPER_G / (EFFECTIVE_MASS * 1e3 * q)
        out["plan_area"] = xr.Variable(dims3, area, attrs={
            "units": "m2", "long_name": "tributary plan area of the diaphragm mass at the "
            "sampled seismic weight", "comment": "m_d g / (8/15 q)"})
    return out


def _predictor_vars(study: Any, records: dict) -> dict[str, xr.Variable]:
    """The candidate predictors of each drawn wall (`urmx.fragility.predictors`) and each
    record's measures for it as analysed (`urmx.fragility.intensity.record_measures`):
    ``predictor_<name>`` over (wall, diaphragm, sample), ``measure_<im>`` over (wall,
    diaphragm, record, sample)."""
    import xarray as xr

    n, nw, nd = study.settings.size, len(study.walls), len(study.diaphragms)
    walls = [w for iw, idp in np.ndindex(nw, nd) for w in _walls(study, iw, idp, list(range(n)))]
    table = [wall_predictors(w) for w in walls]
    dims3 = ("wall", "diaphragm", "sample")
    out = {f"predictor_{k}": xr.Variable(dims3, np.array([t[k] for t in table]).reshape(
        nw, nd, n), attrs={"units": units, "long_name": name, "comment": "from the wall "
                           "alone: formula and source in urmx.fragility.predictors"})
           for k, (units, name) in PREDICTORS.items()}
    ims = ("pga", "pgv", "sa_avg", "sa_diaphragm")
    vals = {im: np.full((nw, nd, len(study.records), n), np.nan) for im in ims}
    for ir, rid in enumerate(study.records):
        rec = records[rid]
        acc = check_finite(rec.scaled(), f"record {rec.id!r}", rec.dt)
        m = record_measures(acc, rec.dt, walls)
        for im in ims:
            vals[im][:, :, ir, :] = m[im].reshape(nw, nd, n)
    for im in ims:
        units, name = IM_ATTRS[im]
        out[f"measure_{im}"] = xr.Variable((*dims3[:2], "record", "sample"), vals[im], attrs={
            "units": units, "long_name": f"{name} of the record as analysed (scale 1) for "
            "the cell's wall", "comment": "urmx.fragility.intensity.record_measures; a "
            "capacity in pga times measure/measure_pga is the capacity in that measure"})
    return out


def _attrs(study: Any, attrs: dict[str, Any]) -> dict[str, Any]:
    s = study.settings
    out = dict(attrs)
    out.update({"sampling_method": s.sampling.method, "sampling_seed": s.sampling.seed,
                "sampling_samples": s.sampling.samples,
                "sampled_parameters": " ".join(s.sampling.names),
                "sampling_parameters": json.dumps(s.sampling.to_dict()["parameters"])})
    if s.ida is not None:
        out.update({"intensity_measure": s.ida.im, "ida_rtol": s.ida.rtol,
                    "ida_step": s.ida.step, "ida_max_intensity": s.ida.max_intensity,
                    "ida_convention": "first collapse: the lowest collapse the hunt and "
                                      "bisection saw; censored cells hold max_intensity"})
    return out


def assemble(study: Any, records: dict, cells: dict, extras: dict,
             attrs: dict[str, Any]) -> xr.Dataset:
    """The Dataset of a sampling study: the cells' outputs over (wall, diaphragm, record,
    sample), the fits with modelling uncertainty (with IDA), and the coordinates."""
    import xarray as xr

    coords = _coords(study, records)
    settings = study.settings
    if settings.ida is None:
        return xr.Dataset(_history_vars(cells), coords=coords, attrs=_attrs(study, attrs))

    ctx = variables.intensity_context(settings.ida.im)

    def var_attrs(name, **extra):
        return {**variables.attrs(name, None, **ctx), **extra}

    data_vars = _capacity_vars(cells, var_attrs)
    coords["intensity_step"] = xr.Variable(
        "intensity_step", np.arange(cells["intensity"].shape[-1]),
        attrs=var_attrs("intensity_step"))
    coords["intensity"] = xr.Variable((*DIMS, "intensity_step"), cells["intensity"],
                                      attrs=var_attrs("intensity"))
    coords["rocking_period"] = xr.Variable(("wall", "diaphragm", "sample"), _cell_walls(
        study, fragility.rocking_period), attrs=var_attrs("rocking_period"))
    coords["predominant_frequency"] = xr.Variable(
        "record", np.fmax.reduce(np.asarray(cells["predominant"]), axis=(0, 1, 3)),
        attrs=var_attrs("predominant_frequency", comment="of each record, Konno-Ohmachi "
                        "smoothed (urmx.records.predominant_frequency)"))
    if _geometry_sampled(study):
        data_vars.update(_predictor_vars(study, records))
    return xr.Dataset(data_vars, coords=coords, attrs=_attrs(study, attrs))


def counts(ds: xr.Dataset) -> dict[str, int] | None:
    """The cells of a sampling archive as the IDA kind (capacities) or the grid (time
    histories) counts them; None when `ds` has no ``sample`` dimension."""
    if "sample" not in ds.dims:
        return None
    return ida.counts(ds) if "collapse_intensity" in ds.data_vars else grid.counts(ds)


#: time histories of every sample: the grid's outputs per cell
KIND = Kind(name="sampling", table="sampling", unit="analyses", outputs=grid.BATCH_OUTPUTS,
            parse=parse, dims=dims, identity=identity, task=task, run=run_batch,
            assemble=assemble, counts=counts, keys=SAMPLING_KEYS,
            fills={"status": (NOT_RUN, "int8")}, cell_bytes=grid.cell_bytes,
            warm_up=grid.KIND.warm_up, dt_above=grid.KIND.dt_above)
#: collapse capacities of every sample (``[study.ida]`` beside ``[study.sampling]``): the
#: IDA kind's outputs per cell
KIND_IDA = Kind(name="sampling-ida", table="sampling", combines=("ida",), unit="cells",
                outputs=ida.OUTPUTS, parse=parse, dims=dims, identity=identity, task=task,
                run=run_batch, assemble=assemble, counts=counts, keys=SAMPLING_KEYS,
                archived={**ida.ARCHIVED, "unit": "record_intensity"},
                cell_bytes=ida.cell_bytes, warm_up=ida.KIND.warm_up,
                dt_above=ida.KIND.dt_above, chain=ida.KIND.chain,
                chain_tag=ida.KIND.chain_tag, chained=ida.KIND.chained)
