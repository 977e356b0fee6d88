"""The time-history grid, the default study kind: one kernel analysis per cell of wall x
diaphragm x record x cor (x scale, impact, damping when the study adds them), the peak
outputs of every cell and the time histories of the study's ``[[study.history]]`` cells.

A batch is any block of cells of one record (`urmx.study.batches`); :func:`run_batch` returns
numpy arrays of the block's shape per output (and the kept histories of the block's cells
that keep one, as extra arrays), and the Dataset is built once from every cell's outputs
(:func:`assemble`). Every output of a cell whose status is not ``ok`` or ``collapsed``
(left out by the study's pairs, or stopped at the event limit) is NaN; the integer outputs
are float64 in the Dataset and int32 with a CF ``_FillValue`` on disk.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import numpy as np

from ... import variables
from ...kernel import WINDOW, warm_up
from ...kernel import run as run_kernel
from ...model import T_REST
from ...netcdf import INT_FILL  # the integer outputs' _FillValue on disk
from ..batches import Batch
from ..dataset import MISSING, NOT_RUN, STATUS, VALID, coord, grid_coords, status_attrs
from .kind import Kind

if TYPE_CHECKING:
    import xarray as xr

#: the arrays every batch of :func:`run_batch` returns, one value per cell
BATCH_OUTPUTS = (*variables.SCALARS, "status")
ADDED = ("scale", "impact", "damping")  # the dimensions a study may add, in order


def extras(study: Any) -> dict[tuple[int, ...], str]:
    """The cells whose time history is kept (at the first scale, impact and damping), by
    index over the study's dimensions: their history label."""
    out = {}
    for h in study.histories:
        index = (next(i for i, w in enumerate(study.walls) if w.id == h.wall),
                 next(i for i, d in enumerate(study.diaphragms) if d.id == h.diaphragm),
                 study.records.index(h.record), study.cor.index(h.cor))
        out[index + (0,) * sum(k in study.extra for k in ADDED)] = h.label
    return out


def task(study: Any, records: dict, batch: Batch, kernel: Callable | None) -> dict[str, Any]:
    """Everything a worker needs for one block of cells (picklable, no xarray)."""
    b = batch.block
    rec = records[study.records[batch.record]]
    dampings = [study.extra["damping"][i] for i in b["damping"]] if "damping" in b else [None]
    walls = [[[study.wall(study.walls[iw], study.diaphragms[idp], z) for z in dampings]
              for idp in b["diaphragm"]] for iw in b["wall"]]
    index = {cell: label for cell, label in extras(study).items()
             if all(i in ix for i, ix in zip(cell, b.values(), strict=True))}
    hist = [int(np.ravel_multi_index(tuple(ix.index(i) for i, ix in zip(cell, b.values(),
                                                                       strict=True)),
                                     batch.shape)) for cell in index]
    return dict(
        walls=walls, dt=rec.dt, scale_factor=rec.scale_factor,
        cor=[study.cor[i] for i in b["cor"]],
        scale=[study.extra["scale"][i] for i in b["scale"]] if "scale" in b else [1.0],
        impact=[study.extra["impact"][i] for i in b["impact"]] if "impact" in b
        else [study.impact], tail=study.tail, t_rest=study.t_rest, history=hist, kernel=kernel,
        shape=batch.shape)


def _unrun(shape) -> dict[str, np.ndarray]:
    """A batch's output arrays before its cells run: NaN, INT_FILL for integers, status
    not_run."""
    out: dict[str, np.ndarray] = {}
    for name in variables.SCALARS:
        if name in variables.INTEGER_SCALARS:
            out[name] = np.full(shape, INT_FILL, dtype=np.int32)
        else:
            out[name] = np.full(shape, np.nan)
    out["status"] = np.full(shape, NOT_RUN, dtype=np.int8)
    return out


def rest_time(task: dict[str, Any]) -> dict[str, float]:
    """The kernel's ``t_rest`` argument for a task's cells: given only when the study sets
    another than the default (`urmx.model.T_REST`), so that an integrator with the
    interface of `urmx.kernel.run` before it had ``t_rest`` (a stand-in) still serves."""
    t_rest = task.get("t_rest", T_REST)
    return {} if t_rest == T_REST else {"t_rest": t_rest}


def run_batch(task: dict[str, Any], acceleration: np.ndarray) -> dict[str, np.ndarray]:
    """Run one block through the kernel: a numpy array of the block's shape per output,
    and ``extra.<i>.<name>`` arrays of the kept time histories (``i`` the cell's flat index
    in the block). Numpy only.

    Parameters
    ----------
    task : dict
        The block: its walls' parameters, the dimensions' values, the kept histories, the
        settings (what the grid kind's task maker writes).
    acceleration : ndarray of float
        The block's record samples, unscaled. [m s-2]
    """
    kernel = task["kernel"] or run_kernel
    walls = task["walls"]
    shape = (len(walls), len(walls[0]), len(task["cor"]), len(task["scale"]),
             len(task["impact"]), len(walls[0][0]))
    out = _unrun(shape)
    kept = set(task["history"])
    for n, (iw, idp, ic, isc, ii, iz) in enumerate(np.ndindex(*shape)):
        kw = dict(scale=task["scale_factor"] * task["scale"][isc], cor=task["cor"][ic],
                  impact=task["impact"][ii], tail=task["tail"], **rest_time(task))
        if n in kept:
            kw["history"] = True
        result = kernel(walls[iw][idp][iz], acceleration, task["dt"], **kw)
        for name in variables.SCALARS:
            out[name][iw, idp, ic, isc, ii, iz] = result[name]
        out["status"][iw, idp, ic, isc, ii, iz] = STATUS.index(result["status"])
        if n in kept:
            h = result["history"]
            for name in (*variables.HISTORIES, "time"):
                if name in h:
                    out[f"extra.{n}.{name}"] = np.asarray(h[name], dtype=np.float64)
    return {k: v if k.startswith("extra.") else v.reshape(task["shape"]) for k, v in out.items()}


# ---- the Dataset ----------------------------------------------------------------------------

def _outputs(cells: dict) -> dict[str, Any]:
    """Every output over the study's dimensions: float64, NaN where no valid result exists
    (integer outputs too, so that sums and means over the grid skip those cells). Numpy or
    dask arrays alike."""
    status = cells["status"]
    invalid = ~np.isin(status, VALID)
    data = {name: np.where(invalid, np.nan, cells[name].astype(np.float64))
            for name in variables.SCALARS}
    data["status"] = status
    return data


def output_attrs(name: str) -> dict[str, Any]:
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
    dims, coords = study.dims, {}
    for k in ("scale", "damping"):
        if k in dims:
            coords[k] = coord(k, k, np.array(dims[k], dtype=np.float64))
    if "impact" in dims:
        coords["impact"] = coord("impact", "impact", np.array(dims["impact"], dtype=object))
    return coords


def assemble(study: Any, records: dict, cells: dict, extras: dict,
             attrs: dict[str, Any]) -> xr.Dataset:
    """The Dataset of a grid: every output over the study's dimensions, the shared and the
    added dimensions' coordinates, and the kept histories (`extras`, by label)."""
    import xarray as xr


    names = list(study.dims)
    data_vars = {name: xr.Variable(names, arr, attrs=output_attrs(name))
                 for name, arr in _outputs(cells).items()}
    coords = {**grid_coords(study, records), **_added_coords(study)}
    if study.histories:
        hist_coords, hist_vars = _histories(study, extras)
        coords.update(hist_coords)
        data_vars.update(hist_vars)
    return xr.Dataset(data_vars, coords=coords, attrs=attrs)


# ---- kept histories ---------------------------------------------------------------------------

def _histories(study: Any, hist: dict) -> tuple[dict, dict]:
    """(coordinates, variables) of the kept histories (`hist`: arrays by label) on one
    time axis."""
    import xarray as xr


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


def cell_bytes(study: Any) -> float:
    """Bytes of one cell's outputs in the archive: float64, int32 for the integer outputs,
    int8 for the status. [B]"""
    return sum(4 if n in variables.INTEGER_SCALARS else 8 for n in variables.SCALARS) + 1


KIND = Kind(name="grid", unit="analyses", outputs=BATCH_OUTPUTS, task=task, run=run_batch,
            assemble=assemble, reopen=reopen, extras=extras,
            fills={"status": (NOT_RUN, "int8")}, cell_bytes=cell_bytes, counts=counts,
            warm_up=warm_up, dt_above=WINDOW)
