"""The time-history grid, the default study kind: one kernel analysis per cell of wall x
diaphragm x record x cor (x scale, impact, damping when the study adds them), the peak
outputs of every cell and the time histories of the study's ``[[study.history]]`` cells.

A batch is a group of walls on one diaphragm under one record, over every value of the
other dimensions; it returns numpy arrays of shape (walls, cor, scale, impact, damping)
(:func:`run_batch`, the layout its saved parts keep), and the Dataset is built once from
them (:func:`assemble`). Every output of a cell whose status is not ``ok`` or
``collapsed`` (left out by the study's pairs, or stopped at the event limit) is NaN; the
integer outputs are float64 in the Dataset and int32 with a CF ``_FillValue`` on disk.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import numpy as np

from ... import variables
from ...netcdf import INT_FILL  # the integer outputs' _FillValue on disk
from ..batches import Batch, by_walls
from ..dataset import MISSING, NOT_RUN, STATUS, VALID
from ..parts import task_key
from .kind import Kind

if TYPE_CHECKING:
    import xarray as xr

#: the arrays every batch of :func:`run_batch` returns (besides its kept histories)
BATCH_OUTPUTS = (*variables.SCALARS, "status", "history_labels")
ADDED = ("scale", "impact", "damping")  # the dimensions a study may add, in order


def _task(study: Any, batch: Batch, records: dict, kernel: Callable | None) -> dict[str, Any]:
    """Everything a worker needs for one batch (picklable, no xarray); sets its key."""
    d = study.diaphragms[batch.diaphragm]
    rec = records[study.records[batch.record]]
    dampings = study.extra.get("damping", [None])
    walls = [[study.wall(study.walls[iw], d, z) for z in dampings] for iw in batch.walls]
    hist = []
    for h in study.histories:
        if h.diaphragm == d.id and h.record == rec.id:
            ids = [study.walls[iw].id for iw in batch.walls]
            if h.wall in ids:
                hist.append((ids.index(h.wall), study.cor.index(h.cor), h.label))
    task = dict(
        walls=walls, dt=rec.dt, scale_factor=rec.scale_factor, cor=list(study.cor),
        scale=study.extra.get("scale", [1.0]), impact=study.extra.get("impact", [study.impact]),
        tail=study.tail, history=hist, kernel=kernel,
        has_damping="damping" in study.extra)
    batch.key = task_key(task, rec, walls=[[w.to_dict() for w in ws] for ws in walls])
    return task


def tasks(study: Any, records: dict, batch_size: int = 16,
          kernel: Callable | None = None) -> list[tuple[Batch, dict[str, Any]]]:
    """The batches of a grid, each with its task and key: walls grouped to reach about
    `batch_size` analyses (`urmx.study.batches.by_walls`)."""
    return [(b, _task(study, b, records, kernel)) for b in by_walls(study, study.dims,
                                                                      batch_size)]


def unrun(shape) -> dict[str, np.ndarray]:
    """A batch's output arrays before its cells run: NaN, INT_FILL for integers, status
    not_run (the sampling kind's time histories start from them too)."""
    out: dict[str, np.ndarray] = {}
    for name in variables.SCALARS:
        if name in variables.INTEGER_SCALARS:
            out[name] = np.full(shape, INT_FILL, dtype=np.int32)
        else:
            out[name] = np.full(shape, np.nan)
    out["status"] = np.full(shape, NOT_RUN, dtype=np.int8)
    return out


def run_batch(task: dict[str, Any], acceleration: np.ndarray) -> dict[str, np.ndarray]:
    """Run one batch through the kernel: numpy arrays of shape (walls, cor, scale, impact,
    damping) per output, plus the kept time histories. Numpy only."""
    kernel = task["kernel"]
    if kernel is None:
        from ...kernel import run as kernel
    nw, nz = len(task["walls"]), len(task["walls"][0])
    shape = (nw, len(task["cor"]), len(task["scale"]), len(task["impact"]), nz)
    out = unrun(shape)
    hist = {(iw, ic): label for iw, ic, label in task["history"]}
    labels = []
    for iw, ic, isc, ii, iz in np.ndindex(*shape):
        keep = (iw, ic) in hist and isc == 0 and ii == 0 and iz == 0
        kw = dict(scale=task["scale_factor"] * task["scale"][isc], cor=task["cor"][ic],
                  impact=task["impact"][ii], tail=task["tail"])
        if keep:
            kw["history"] = True
        result = kernel(task["walls"][iw][iz], acceleration, task["dt"], **kw)
        for name in variables.SCALARS:
            out[name][iw, ic, isc, ii, iz] = result[name]
        out["status"][iw, ic, isc, ii, iz] = STATUS.index(result["status"])
        if keep:
            h = result["history"]
            j = len(labels)
            labels.append(hist[(iw, ic)])
            for name in (*variables.HISTORIES, "time"):
                if name in h:
                    out[f"history{j}.{name}"] = np.asarray(h[name], dtype=np.float64)
    out["history_labels"] = np.array(labels, dtype=str)
    return out


# ---- the Dataset ----------------------------------------------------------------------------

def _block(study: Any) -> Callable[[np.ndarray, Batch], np.ndarray]:
    """How a batch's (walls, cor, scale, impact, damping) array maps onto its block of the
    study's dimensions (the added dimensions the study lacks dropped)."""
    absent = [2 + i for i, k in enumerate(ADDED) if k not in study.extra]

    def block(values: np.ndarray, batch: Batch) -> np.ndarray:
        kept = [n for i, n in enumerate(values.shape) if i not in absent]
        return values.reshape(kept[0], 1, 1, *kept[1:])

    return block


def _outputs(study: Any, tasks: list, results: dict) -> dict[str, np.ndarray]:
    """Every output over the study's dimensions: float64, NaN where no valid result exists
    (integer outputs too, so that sums and means over the grid skip those cells)."""
    from ..dataset import cell_array

    shape = tuple(len(v) for v in study.dims.values())
    batches = [b for b, _ in tasks]
    block = _block(study)
    status = cell_array(shape, batches, results, "status", block, NOT_RUN, np.int8)
    invalid = ~np.isin(status, VALID)
    data = {}
    for name in variables.SCALARS:
        data[name] = cell_array(shape, batches, results, name, block)
        data[name][invalid] = np.nan
    data["status"] = status
    return data


def output_attrs(name: str) -> dict[str, Any]:
    """Attributes of a grid output (the sampling kind's time histories too): the
    registry's, with what a missing cell holds (the status' CF flags)."""
    from ..dataset import status_attrs

    if name == "status":
        return status_attrs()
    attrs = variables.attrs(name)
    if name in variables.INTEGER_SCALARS:
        attrs["comment"] = (f"{MISSING}; stored as int32 with _FillValue {INT_FILL}, "
                            "read by xarray as float64 with NaN")
    else:
        attrs["comment"] = MISSING
    return attrs


def _added_coords(study: Any) -> dict[str, xr.Variable]:
    from ..dataset import coord

    dims, coords = study.dims, {}
    for k in ("scale", "damping"):
        if k in dims:
            coords[k] = coord(k, k, np.array(dims[k], dtype=np.float64))
    if "impact" in dims:
        coords["impact"] = coord("impact", "impact", np.array(dims["impact"], dtype=object))
    return coords


def assemble(study: Any, records: dict, tasks: list, results: dict,
             attrs: dict[str, Any]) -> xr.Dataset:
    """The Dataset of a grid: every output over the study's dimensions, the shared and the
    added dimensions' coordinates, and the kept histories."""
    import xarray as xr

    from ..dataset import grid_coords

    names = list(study.dims)
    data_vars = {name: xr.Variable(names, arr, attrs=output_attrs(name))
                 for name, arr in _outputs(study, tasks, results).items()}
    coords = {**grid_coords(study, records), **_added_coords(study)}
    if study.histories:
        hist_coords, hist_vars = _histories(study, tasks, results)
        coords.update(hist_coords)
        data_vars.update(hist_vars)
    return xr.Dataset(data_vars, coords=coords, attrs=attrs)


# ---- kept histories ---------------------------------------------------------------------------

def _kept(tasks: list, results: dict) -> dict[str, dict[str, np.ndarray]]:
    """Every kept history by label: its arrays (time and the histories) as the batch
    returned them."""
    hist: dict[str, dict[str, np.ndarray]] = {}
    for batch, _ in tasks:
        r = results[batch.key]
        for j, label in enumerate(r["history_labels"]):
            prefix = f"history{j}."
            hist[str(label)] = {k[len(prefix):]: v for k, v in r.items() if k.startswith(prefix)}
    return hist


def _histories(study: Any, tasks: list, results: dict) -> tuple[dict, dict]:
    """(coordinates, variables) of the kept histories on one time axis."""
    import xarray as xr

    from ..dataset import coord

    hist = _kept(tasks, results)
    cells = study.histories
    labels = [h.label for h in cells]
    time, hist_dt = _history_time(hist, labels)
    coords = {
        "history": coord("history", "history", np.array(labels, dtype=object)),
        "history_wall": coord("history_wall", "history",
                              np.array([h.wall for h in cells], dtype=object)),
        "history_diaphragm": coord("history_diaphragm", "history",
                                   np.array([h.diaphragm for h in cells], dtype=object)),
        "history_record": coord("history_record", "history",
                                np.array([h.record for h in cells], dtype=object)),
        "history_cor": coord("history_cor", "history", np.array([h.cor for h in cells])),
        "history_dt": coord("history_dt", "history", np.array(hist_dt)),
        "time": xr.Variable("time", time, attrs=variables.attrs("time")),
    }
    data_vars = {}
    for v in [v for v in variables.HISTORIES if v in hist[labels[0]]]:
        arr = np.full((len(labels), len(time)), np.nan)
        for i, lab in enumerate(labels):
            arr[i] = _on_grid(time, hist[lab]["time"], hist[lab][v], v == "pattern")
        data_vars[v] = xr.Variable(("history", "time"), arr, attrs=variables.attrs(v))
    return coords, data_vars


def _history_time(hist: dict, labels: list[str]) -> tuple[np.ndarray, list[float]]:
    """The shared time axis of the kept histories: the finest record step, up to the
    longest history."""
    dts = [float(np.median(np.diff(hist[lab]["time"]))) if len(hist[lab]["time"]) > 1
           else 0.0 for lab in labels]
    dt = min(d for d in dts if d > 0) if any(d > 0 for d in dts) else 1.0
    end = max(float(hist[lab]["time"][-1]) for lab in labels)
    n = int(round(end / dt)) + 1
    longest = max(labels, key=lambda lab: len(hist[lab]["time"]))
    if len(hist[longest]["time"]) == n:
        return np.asarray(hist[longest]["time"], dtype=np.float64), dts
    return np.arange(n) * dt, dts


def _on_grid(time: np.ndarray, own: np.ndarray, values: np.ndarray, step: bool) -> np.ndarray:
    """A history on the shared time axis: as it is when its record has that step (NaN after
    its end); else linearly interpolated (the pattern, a state, held from the last sample)."""
    out = np.full(len(time), np.nan)
    n = len(own)
    if n <= len(time) and np.allclose(own, time[:n], rtol=0, atol=1e-9 * max(1.0, time[-1])):
        out[:n] = values
        return out
    inside = time <= own[-1] + 1e-12
    if step:
        idx = np.clip(np.searchsorted(own, time[inside] + 1e-12, side="right") - 1, 0, n - 1)
        out[inside] = values[idx]
    else:
        out[inside] = np.interp(time[inside], own, values)
    return out


# ---- archives of older urmx ------------------------------------------------------------------

def reopen(ds: xr.Dataset) -> xr.Dataset | None:
    """A grid archive written before urmx stored missing cells with a ``_FillValue``
    (integer outputs holding -1, event-limit cells holding their partial peaks), masked
    by ``status``; None when `ds` is not a grid archive of that kind."""
    legacy = [n for n in variables.INTEGER_SCALARS
              if n in ds.data_vars and ds[n].dtype.kind in "iub"]
    if "status" not in ds.data_vars or not legacy:
        return None
    valid = ds["status"].isin(list(VALID))
    for name in variables.SCALARS:
        if name in ds.data_vars:
            ds[name] = ds[name].where(valid).assign_attrs(dict(ds[name].attrs, comment=MISSING))
    return ds


def counts(ds: xr.Dataset) -> dict[str, int] | None:
    """The grid's cells by status (``ok``, ``collapsed``, ``event-limit``, ``not-run``);
    None when `ds` has no ``status``."""
    if "status" not in ds.data_vars:
        return None
    status = np.asarray(ds["status"].values)
    return {name: int((status == code).sum()) for code, name in enumerate(STATUS)}


KIND = Kind(name="grid", unit="analyses", outputs=BATCH_OUTPUTS, tasks=tasks, run=run_batch,
            assemble=assemble, reopen=reopen, counts=counts)
