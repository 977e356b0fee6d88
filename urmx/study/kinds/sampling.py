"""The sampling study kind (a ``[study.sampling]`` table): each sample is a wall whose
model parameters (COR, PMR, crack height, the diaphragm's frequency, the impact law, ...)
are drawn from their distributions; every sample runs over the study's walls, diaphragms
and records, as time histories or, with ``[study.ida]`` beside it, as collapse capacities
with the lognormal fits per sample and over records and samples together.

The table holds ``samples``, ``seed``, optionally ``method`` (``lhs``, ``sobol``,
``random``, ``saltelli``) and ``[study.sampling.parameters]``, one inline table per
parameter (`urmx.uncertainty.sampler` says what each parameter does, and
`urmx.uncertainty.distributions` the distributions). A sampled value replaces the study's
(a factor multiplies it); the study's ``cor`` (one value) and ``impact`` (one law) are
what the samples that do not draw them use. The samples are drawn and every sample's wall
is built for every (wall, diaphragm) cell when the study file is loaded: a sample that
makes no valid wall (a PMR outside (0, 100], or one that leaves no plateau with the wall's
kappa) is refused then, naming the parameter, and nothing runs.

The cells are (wall, diaphragm, record, sample); the archive has a ``sample`` dimension
with each sampled value as a coordinate on it (a factor as ``<parameter>_factor``), the
design's points ``sample_unit(sample, parameter)`` and ``cell_frequency(wall, diaphragm,
sample)``. A batch is one record and one diaphragm, a group of walls and a block of
samples of about ``batch_size`` cells (:func:`cut`); its key holds the sampled walls, so a
cell reruns only when what it computes changes. Time histories give the grid's peak
outputs and ``status`` per cell; collapse capacities give the IDA kind's per-cell outputs,
``median_collapse_intensity`` and ``dispersion`` per (wall, diaphragm, sample) over the
records, and per (wall, diaphragm) the fit over records and samples together
(``total_median_collapse_intensity``, ``total_dispersion``) with its parts
(``record_dispersion``, ``model_dispersion``; `urmx.uncertainty.spread`).
"""

from __future__ import annotations

import json
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from ... import variables
from ..batches import Batch
from ..dataset import NOT_RUN, STATUS, VALID
from ..parts import task_key
from .kind import Kind

if TYPE_CHECKING:
    import xarray as xr

DIMS = ("wall", "diaphragm", "record", "sample")
#: the keys of ``[study.sampling]`` (`urmx.uncertainty.sampler.KEYS`; docs/study-files.md)
SAMPLING_KEYS = ("samples", "seed", "method", "parameters")
OUTPUTS = ("status",)  # every batch returns it (capacity batches: collapsed or censored)
CAPACITY_OUTPUTS = ("capacity", "censored", "analyses", "event_limits", "intensity", "ratio",
                    "unit", "predominant")
FIT_OUTPUTS = ("total_median_collapse_intensity", "total_dispersion", "record_dispersion",
               "model_dispersion")


@dataclass(frozen=True, eq=False)
class SamplingSettings:
    """A sampling study's settings: the design (`urmx.uncertainty.Sampling`), the IDA
    settings when ``[study.ida]`` sits beside it, and the drawn samples.

    Attributes
    ----------
    unit : ndarray, shape (samples, parameters)
        The design's points of the unit hypercube. [1]
    values : dict of str to ndarray
        Each parameter's value per sample.
    """

    sampling: Any
    ida: Any = None
    unit: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))
    values: dict[str, np.ndarray] = field(default_factory=dict)

    @property
    def size(self) -> int:
        return self.unit.shape[0]

    def sample(self, j: int) -> dict[str, Any]:
        """Sample `j`'s value of each parameter."""
        from ...uncertainty.sampler import sample_values

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
    from ...uncertainty import ParameterError, check_samples, parse_sampling

    try:
        sampling = parse_sampling(study.tables["sampling"])
    except ParameterError as exc:
        raise _error(study, exc) from None
    _check_grid(study)
    ida = None
    if "ida" in study.tables:
        from .ida import parse as parse_ida

        ida = parse_ida(study)
    unit, values = sampling.draw()
    walls = {f"{spec.id!r} on diaphragm {d.id!r}": study.wall(spec, d)
             for spec in study.walls for d in study.diaphragms}
    try:
        check_samples(values, walls)
    except ParameterError as exc:
        raise _error(study, exc) from None
    return SamplingSettings(sampling=sampling, ida=ida, unit=unit, values=values)


def dims(study: Any) -> dict[str, list]:
    """The cells: wall, diaphragm, record, sample."""
    return {"wall": study.dims["wall"], "diaphragm": study.dims["diaphragm"],
            "record": study.dims["record"], "sample": list(range(study.settings.size))}


def cut(study: Any, batch_size: int) -> list[Batch]:
    """Batches of one record and one diaphragm: the walls the study pairs with the record
    in groups, times blocks of at most `batch_size` samples, about `batch_size` cells a
    batch; records outermost, then diaphragms, walls, samples."""
    n = study.settings.size
    per_sample = min(n, batch_size)
    per_wall = max(1, batch_size // per_sample)
    out = []
    for ir, rid in enumerate(study.records):
        walls = [iw for iw, w in enumerate(study.walls) if study.paired(w.id, rid)]
        for idp in range(len(study.diaphragms)):
            for i in range(0, len(walls), per_wall):
                for j in range(0, n, per_sample):
                    out.append(Batch({"wall": walls[i:i + per_wall], "diaphragm": [idp],
                                      "record": [ir],
                                      "sample": list(range(j, min(n, j + per_sample)))}))
    return out


def cell(study: Any, wall: Any, j: int) -> tuple[Any, float, str]:
    """(the wall, cor and impact law) of sample `j` on the study's wall of a cell."""
    from ...uncertainty import apply

    s = study.settings.sample(j)
    return apply(wall, s), float(s.get("cor", study.cor[0])), str(s.get("impact", study.impact))


def tasks(study: Any, records: dict, batch_size: int = 16,
          kernel: Callable | None = None) -> list[tuple[Batch, dict[str, Any]]]:
    """Each batch (:func:`cut`) with its task: the cells' sampled walls, cors and impact
    laws, the record's step and scale factor and the IDA settings (or the tail of a time
    history); keyed by all of them and the record's samples (`urmx.study.parts.task_key`)."""
    settings = study.settings
    ida = settings.ida.to_dict() if settings.ida is not None else None
    out, first = [], {}
    for batch in cut(study, batch_size):
        rec = records[study.records[batch.record]]
        d = study.diaphragms[batch.diaphragm]
        cells = [cell(study, study.wall(study.walls[iw], d), j) for iw in batch.walls
                 for j in batch.block["sample"]]
        task = dict(walls=[c[0] for c in cells], cor=[c[1] for c in cells],
                    impact=[c[2] for c in cells], shape=[len(batch.walls),
                                                         len(batch.block["sample"])],
                    dt=rec.dt, scale_factor=rec.scale_factor, kernel=kernel, ida=ida)
        if ida is None:
            task["tail"] = study.tail
        else:
            task["predominant"] = first.setdefault(batch.record, batch) is batch
        batch.key = task_key(task, rec, prefix="sampling-", kind="sampling",
                             walls=[w.to_dict() for w in task["walls"]])
        out.append((batch, task))
    return out


# ---- a batch on a worker (numpy only) ----------------------------------------------------------

def run_batch(task: dict[str, Any], acceleration: np.ndarray) -> dict[str, np.ndarray]:
    """One batch: each cell's time history (the grid's peak outputs and status) or, with IDA
    settings, its collapse capacity (the IDA kind's outputs), as arrays of shape (walls,
    samples) (IDA curves (walls, samples, points)). Numpy only."""
    kernel = task["kernel"]
    if kernel is None:
        from ...kernel import run as kernel
    if task["ida"] is None:
        return _histories(task, acceleration, kernel)
    return _capacities(task, acceleration, kernel)


def _histories(task: dict, acceleration: np.ndarray, kernel: Callable) -> dict:
    from .grid import unrun

    shape = tuple(task["shape"])
    out = unrun(shape)
    for i, wall in enumerate(task["walls"]):
        at = np.unravel_index(i, shape)
        result = kernel(wall, acceleration, task["dt"], scale=task["scale_factor"],
                        cor=task["cor"][i], impact=task["impact"][i], tail=task["tail"])
        for name in variables.SCALARS:
            out[name][at] = result[name]
        out["status"][at] = STATUS.index(result["status"])
    return out


def _capacities(task: dict, acceleration: np.ndarray, kernel: Callable) -> dict:
    from ... import fragility
    from ...records.measures import dominant_frequency

    acc = np.ascontiguousarray(acceleration * task["scale_factor"], dtype=np.float64)
    ida, walls, dt = task["ida"], task["walls"], task["dt"]
    unit = fragility.record_intensities(acc, dt, ida["im"], walls)
    results = [fragility.cell_capacity(
        kernel, wall, acc, dt, float(unit[i]), ida["im"], task["cor"][i], task["impact"][i],
        ida["rtol"], ida["step"], ida["max_intensity"]) for i, wall in enumerate(walls)]
    shape = tuple(task["shape"])
    k = max(r.analyses for r in results)
    out = {"capacity": np.array([r.capacity for r in results]).reshape(shape),
           "censored": np.array([r.censored for r in results]).reshape(shape),
           "analyses": np.array([r.analyses for r in results], np.int32).reshape(shape),
           "event_limits": np.array([r.event_limits for r in results],
                                    np.int32).reshape(shape),
           "intensity": np.full((len(walls), k), np.nan), "ratio": np.full((len(walls), k),
                                                                           np.nan),
           "unit": np.asarray(unit, dtype=np.float64).reshape(shape),
           "predominant": np.array(dominant_frequency(acc, dt) if task["predominant"]
                                   else np.nan)}
    for i, r in enumerate(results):
        out["intensity"][i, :r.analyses] = r.intensity
        out["ratio"][i, :r.analyses] = r.instability_ratio
    out["intensity"] = out["intensity"].reshape(*shape, k)
    out["ratio"] = out["ratio"].reshape(*shape, k)
    out["status"] = np.where(out["censored"], STATUS.index("ok"),
                             STATUS.index("collapsed")).astype(np.int8)
    return out


# ---- the Dataset ------------------------------------------------------------------------------

def _on_block(values: np.ndarray, batch: Batch) -> np.ndarray:
    """A batch's (walls, samples, ...) array on its (wall, diaphragm, record, sample) block."""
    return values.reshape(values.shape[0], 1, 1, *values.shape[1:])


def _shape(study: Any) -> tuple[int, ...]:
    return tuple(len(v) for v in dims(study).values())


def _history_vars(study: Any, tasks: list, results: dict) -> dict[str, xr.Variable]:
    """The grid's peak outputs and status over the cells (NaN where not valid)."""
    import xarray as xr

    from ..dataset import cell_array
    from .grid import output_attrs

    shape, batches = _shape(study), [b for b, _ in tasks]
    status = cell_array(shape, batches, results, "status", _on_block, NOT_RUN, np.int8)
    invalid = ~np.isin(status, VALID)
    out = {}
    for name in variables.SCALARS:
        values = cell_array(shape, batches, results, name, _on_block)
        values[invalid] = np.nan
        out[name] = xr.Variable(DIMS, values, attrs=output_attrs(name))
    out["status"] = xr.Variable(DIMS, status, attrs=output_attrs("status"))
    return out


def _capacity_cells(study: Any, tasks: list, results: dict) -> dict[str, np.ndarray]:
    """The per-cell capacity outputs (NaN where not run) and the records' predominant
    frequencies."""
    from ..dataset import cell_array

    shape, batches = _shape(study), [b for b, _ in tasks]
    k = max([results[b.key]["intensity"].shape[-1] for b in batches] or [1])
    out = {name: cell_array(shape, batches, results, source, _on_block)
           for name, source in (("collapse_intensity", "capacity"), ("censored", "censored"),
                                ("analyses", "analyses"), ("event_limits", "event_limits"),
                                ("record_intensity", "unit"))}
    for name in ("intensity", "ratio"):
        out[name] = cell_array((*shape, k), batches, results, name, _on_block)
    predominant = np.full(shape[2], np.nan)
    for b in batches:
        if np.isfinite(results[b.key]["predominant"]):
            predominant[b.record] = results[b.key]["predominant"]
    out["predominant_frequency"] = predominant
    return out


def _fits(cap: np.ndarray, cen: np.ndarray) -> dict[str, np.ndarray]:
    """Per (wall, diaphragm): the fit of each sample over the records and over records
    and samples together (`urmx.uncertainty.modelling_fit`)."""
    from ...uncertainty import modelling_fit

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


def _capacity_vars(study: Any, cells: dict, attrs: Callable) -> dict[str, xr.Variable]:
    import xarray as xr

    from ...netcdf import INT_FILL

    missing = "NaN where the study's pairs leave the cell out (not run)"
    stored = f"{missing}; stored as int32 with _FillValue {INT_FILL}, read as float64"
    fits = _fits(cells["collapse_intensity"], cells["censored"])
    out = {
        "collapse_intensity": xr.Variable(DIMS, cells["collapse_intensity"], attrs=attrs(
            "collapse_intensity", comment=missing)),
        "censored": xr.Variable(DIMS, cells["censored"], attrs=attrs(
            "censored", comment=f"1 censored, 0 not; {stored}")),
        "instability_ratio": xr.Variable((*DIMS, "intensity_step"), cells["ratio"], attrs=attrs(
            "instability_ratio", comment="IDA curve: one value per analysis of the cell, "
            "ascending intensity; NaN after the cell's last analysis")),
        "analyses": xr.Variable(DIMS, cells["analyses"], attrs=attrs("analyses",
                                                                     comment=stored)),
        "event_limits": xr.Variable(DIMS, cells["event_limits"],
                                    attrs=attrs("event_limits", comment=stored)),
        "record_intensity": xr.Variable(DIMS, cells["record_intensity"],
                                        attrs=attrs("record_intensity")),
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
    out = np.full(_shape(study)[:2] + (study.settings.size,), np.nan)
    for iw, spec in enumerate(study.walls):
        for idp, d in enumerate(study.diaphragms):
            base = study.wall(spec, d)
            for j in range(study.settings.size):
                out[iw, idp, j] = fn(cell(study, base, j)[0])
    return out


def _sample_coords(study: Any) -> dict[str, xr.Variable]:
    """The ``sample`` dimension: each sampled value, the cor and impact law every sample
    runs with, and the design's points of the unit hypercube."""
    import xarray as xr

    from ...uncertainty.sampler import PARAMETERS, coordinate_name
    from ..dataset import coord

    s = study.settings
    n = s.size
    coords = {"sample": coord("sample", "sample", np.arange(n)),
              "parameter": coord("parameter", "parameter",
                                 np.array(list(s.sampling.names), dtype=object)),
              "sample_unit": coord("sample_unit", ("sample", "parameter"), s.unit)}
    for name, dist in s.sampling.parameters.items():
        values = s.values[name]
        values = values.astype(object) if dist.kind == "choice" and name == "impact" \
            else values.astype(np.float64)
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
    from ..dataset import coord, grid_coords

    coords = grid_coords(study, records)
    for name in ("cor", "cell_frequency", "pmr", "crack_ratio"):
        if name in ("cor", "cell_frequency") or name in study.settings.values:
            del coords[name]
    coords.update(_sample_coords(study))
    coords["cell_frequency"] = coord("cell_frequency", ("wall", "diaphragm", "sample"),
                                     _cell_walls(study, lambda w: w.diaphragm_frequency("top")))
    return coords


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


def assemble(study: Any, records: dict, tasks: list, results: dict,
             attrs: dict[str, Any]) -> xr.Dataset:
    """The Dataset of a sampling study: the cells' outputs over (wall, diaphragm, record,
    sample), the fits with modelling uncertainty (with IDA), and the coordinates."""
    import xarray as xr

    coords = _coords(study, records)
    settings = study.settings
    if settings.ida is None:
        data_vars = _history_vars(study, tasks, results)
    else:
        from ... import fragility

        ctx = variables.intensity_context(settings.ida.im)

        def var_attrs(name, **extra):
            return {**variables.attrs(name, None, **ctx), **extra}

        cells = _capacity_cells(study, tasks, results)
        data_vars = _capacity_vars(study, cells, var_attrs)
        coords["intensity_step"] = xr.Variable(
            "intensity_step", np.arange(cells["intensity"].shape[-1]),
            attrs=var_attrs("intensity_step"))
        coords["intensity"] = xr.Variable((*DIMS, "intensity_step"), cells["intensity"],
                                          attrs=var_attrs("intensity"))
        coords["rocking_period"] = xr.Variable(("wall", "diaphragm", "sample"), _cell_walls(
            study, fragility.rocking_period), attrs=var_attrs("rocking_period"))
        coords["predominant_frequency"] = xr.Variable(
            "record", cells["predominant_frequency"], attrs=var_attrs(
                "predominant_frequency", comment="of each record, Konno-Ohmachi smoothed "
                "(urmx.records.predominant_frequency)"))
    return xr.Dataset(data_vars, coords=coords, attrs=_attrs(study, attrs))


def counts(ds: xr.Dataset) -> dict[str, int] | None:
    """The cells of a sampling archive as the IDA kind (capacities) or the grid (time
    histories) counts them; None when `ds` has no ``sample`` dimension."""
    if "sample" not in ds.dims:
        return None
    from . import grid, ida

    return ida.counts(ds) if "collapse_intensity" in ds.data_vars else grid.counts(ds)


KIND = Kind(name="sampling", table="sampling", combines=("ida",), unit="cells",
            outputs=OUTPUTS, parse=parse, dims=dims, tasks=tasks, run=run_batch,
            assemble=assemble, counts=counts, keys=SAMPLING_KEYS)
