"""Study grids: a study file -> batches on dask -> one labelled Dataset -> a netCDF archive.

A study (`urmx.catalog.load_study`) is a grid over ``wall``, ``diaphragm``, ``record``,
``cor`` and any of ``scale``, ``impact``, ``damping``. It runs in **batches**: one record,
one diaphragm and a group of walls, over every value of the other dimensions; a batch returns
plain numpy arrays (the kernel knows nothing of xarray), and the Dataset is built once from
them.

Resumable archives: with ``out=FILE.nc`` every finished batch is saved at once as a small
``.npz`` in the sidecar folder ``FILE.nc.parts/``, named by a hash of everything that decides
its result (walls, record samples, scale factor, CORs, kernel, urmx version). A run that is
stopped (Ctrl-C, a killed worker, a full disk) keeps those files; run it again and only the
missing batches are computed. The archive is written to a temporary name and renamed, and the
sidecar folder is removed after that. The archive's ``history`` carries the time the run was
first started, so a resumed run writes the same archive as an uninterrupted one.

IDA studies (a study file with ``[study.ida]``) run through the same machinery: a batch
is a group of walls of one diaphragm and record, and each cell is one collapse capacity
(`urmx.fragility.run_ida_batch`, assembled by `urmx.fragility.assemble_ida`).

Schedulers: ``None`` (default) starts a local ``dask.distributed`` cluster of worker
processes, one per core (the numba kernel holds the GIL, so processes beat threads);
``"threads"`` the same with threads; ``"serial"`` runs in this process; any other string is a
scheduler address (``tcp://host:8786``); a ``distributed.Client`` is used as it is
(:func:`local_client` starts one on this machine, :func:`close_client` stops it).

:func:`run_study` reads a study file, resolves its records and writes the archive;
:func:`run_grid` runs a grid built in code on records given in memory, with no archive
(benchmarks); :func:`batch_tasks` lists the batches both hand to :func:`run_batch` (IDA:
`urmx.fragility.run_ida_batch`). :func:`grid_coords` and :func:`global_attrs` give the
coordinates and global attributes every study kind's Dataset shares.
"""

from __future__ import annotations

import datetime as _dt
import hashlib
import json
import math
import os
import shutil
import sys
import time as _time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from . import variables
from .catalog import SPECIMEN, Study, load_study
from .netcdf import write_netcdf

STATUS = ("ok", "collapsed", "event-limit", "not-run")  # flag values 0, 1, 2, 3
NOT_RUN = STATUS.index("not-run")
INT_FILL = -1  # integer outputs of cells a study's pairs leave out

# ---- records --------------------------------------------------------------------------------

@dataclass
class RecordData:
    """One record as the study uses it: samples in m s-2 (unscaled), dt and scale factor."""

    id: str
    acceleration: np.ndarray
    dt: float
    scale_factor: float
    digest: str

    @property
    def pga(self) -> float:
        return float(np.max(np.abs(self.acceleration)))


def resolve_records(study: Study, records_dir: str | os.PathLike | None = None,
                    ) -> dict[str, RecordData]:
    """Load the study's records through `urmx.records` (manifest scale factors unless the
    study overrides them); an unknown id fails with the study file and line."""
    from . import records as rec

    manifest = rec.manifest(records_dir)
    out = {}
    for rid in study.records:
        if rid not in manifest:
            raise study.error("study.records", f"record {rid!r} is not in the records manifest "
                              f"(known: {', '.join(sorted(manifest))})", "records", rid)
    for rid in study.records:
        trace = rec.load(rid, records_dir)
        acc = np.ascontiguousarray(trace.data, dtype=np.float64)
        sf = study.scale_factor.get(rid, manifest[rid].get("scale_factor", 1.0))
        digest = hashlib.sha256(acc.tobytes()).hexdigest()[:16]
        out[rid] = RecordData(rid, acc, float(trace.stats.delta), float(sf), digest)
    return out


# ---- batches --------------------------------------------------------------------------------

@dataclass
class Batch:
    """A group of walls x one diaphragm x one record, over all cor and added dimensions."""

    walls: list[int]  # indices into the wall dimension
    diaphragm: int
    record: int
    key: str = ""


def _batches(study: Study, batch_size: int) -> list[Batch]:
    inner = math.prod(len(v) for k, v in study.dims.items()
                      if k not in ("wall", "diaphragm", "record"))
    per = max(1, batch_size // inner)
    out = []
    for ir, rid in enumerate(study.records):
        for idp in range(len(study.diaphragms)):
            walls = [iw for iw, w in enumerate(study.walls) if study.paired(w.id, rid)]
            for i in range(0, len(walls), per):
                out.append(Batch(walls[i:i + per], idp, ir))
    return out


def _task(study: Study, batch: Batch, records: dict[str, RecordData],
          kernel: Callable | None) -> dict[str, Any]:
    """Everything a worker needs for one batch (picklable, no xarray), and its hash key."""
    from . import __version__

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
    ident = dict(task, walls=[[w.to_dict() for w in ws] for ws in walls], record=rec.id,
                 record_digest=rec.digest,
                 kernel=None if kernel is None else f"{kernel.__module__}.{kernel.__qualname__}",
                 urmx=__version__)
    batch.key = hashlib.sha256(json.dumps(ident, sort_keys=True, default=str).encode()
                               ).hexdigest()[:20]
    return task


def batch_tasks(study: Study, records: dict[str, RecordData], batch_size: int = 16,
                kernel: Callable | None = None) -> list[tuple[Batch, dict[str, Any]]]:
    """The batches of a study grid, each with the task a worker runs (:func:`run_batch`;
    for an IDA study `urmx.fragility.run_ida_batch`).

    Parameters
    ----------
    study : Study
        The grid.
    records : dict of RecordData
        The study's records by id (:func:`resolve_records`).
    batch_size : int
        Target number of analyses per batch (walls are grouped to reach it); for an IDA
        study, of cells (collapse capacities) of one diaphragm and record. [1]
    kernel : callable, optional
        Integrator with the signature of `urmx.kernel.run` (default).

    Returns
    -------
    list of (Batch, dict)
        Each batch (its ``key`` set to a hash of everything that decides its result) and
        its task: plain Python and numpy values, picklable, no xarray.
    """
    if study.ida is not None:
        from . import fragility

        return fragility.ida_tasks(study, records, batch_size, kernel)
    return [(b, _task(study, b, records, kernel)) for b in _batches(study, batch_size)]


def _unrun(shape) -> dict[str, np.ndarray]:
    """Output arrays of cells not (yet) run: NaN, INT_FILL for integers, status not_run."""
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
        from .kernel import run as kernel
    nw, nz = len(task["walls"]), len(task["walls"][0])
    shape = (nw, len(task["cor"]), len(task["scale"]), len(task["impact"]), nz)
    out = _unrun(shape)
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


def _save_part(parts: Path, key: str, result: dict[str, np.ndarray]) -> None:
    tmp = parts / f".{key}.{os.getpid()}.tmp.npz"
    np.savez(tmp, **result)
    os.replace(tmp, parts / f"{key}.npz")


def _load_part(path: Path) -> dict[str, np.ndarray] | None:
    try:
        with np.load(path) as z:
            return {k: z[k] for k in z.files}
    except Exception:  # a truncated file (disk full, killed mid-write): compute it again
        return None


# ---- running ----------------------------------------------------------------------------------

class _Progress:
    """A one-line progress bar on stderr."""

    def __init__(self, total: int, cells: int, enabled: bool, unit: str = "analyses"):
        self.total, self.cells, self.enabled, self.unit = total, cells, enabled, unit
        self.done = 0
        self.start = _time.perf_counter()

    def update(self, n: int = 1) -> None:
        self.done += n
        if not self.enabled or not self.total:
            return
        frac = self.done / self.total
        bar = "#" * int(30 * frac)
        sys.stderr.write(f"\r[{bar:<30}] {self.done}/{self.total} batches "
                         f"({int(frac * self.cells)}/{self.cells} {self.unit}) "
                         f"{_time.perf_counter() - self.start:.1f} s")
        if self.done == self.total:
            sys.stderr.write("\n")
        sys.stderr.flush()


def local_client(n_workers: int | None = None, threads: bool = False):
    """A ``distributed.Client`` on a new local cluster.

    Parameters
    ----------
    n_workers : int, optional
        Worker processes of one thread each (default: one per core). The numba kernel
        holds the GIL, so processes beat threads; the kernel is compiled (or loaded from
        numba's cache) here first, so the workers load it from the cache.
    threads : bool
        One worker in this process with `n_workers` threads instead.

    Returns
    -------
    distributed.Client
        Close it with :func:`close_client`, which also stops the cluster.
    """
    from distributed import Client, LocalCluster

    n = n_workers or os.cpu_count() or 1
    if not threads:
        from .kernel import warm_up

        warm_up()
    cluster = LocalCluster(n_workers=1 if threads else n, threads_per_worker=n if threads else 1,
                           processes=not threads, dashboard_address=":0")
    return Client(cluster)


def get_client(scheduler: Any) -> tuple[Any, bool]:
    """(client, owned) for a `scheduler` argument of :func:`run_study`: a Client is used as
    it is (owned False); None or "processes" start local worker processes, "threads" a
    threaded local worker, any other string connects to that scheduler address (owned True:
    the caller closes it with :func:`close_client`)."""
    from distributed import Client

    if isinstance(scheduler, Client):
        return scheduler, False
    if scheduler in (None, "processes", "threads"):
        return local_client(threads=scheduler == "threads"), True
    return Client(scheduler), True


def close_client(client: Any) -> None:
    """Close a client and the local cluster it started, if any."""
    cluster = getattr(client, "cluster", None)
    client.close()
    if cluster is not None:
        cluster.close()


def _compute(tasks: list[tuple[Batch, dict]], records: dict[str, RecordData], rec_ids: list[str],
             scheduler: Any, on_result: Callable[[Batch, dict], None],
             runner: Callable[[dict, np.ndarray], dict] | None = None) -> None:
    runner = runner or run_batch
    if scheduler == "serial" or len(tasks) <= 1 and not hasattr(scheduler, "submit"):
        for batch, task in tasks:
            on_result(batch, runner(task, records[rec_ids[batch.record]].acceleration))
        return
    from distributed import as_completed

    client, owned = get_client(scheduler)
    futures = {}
    try:
        acc = {rid: client.scatter(records[rid].acceleration, broadcast=True)
               for rid in {rec_ids[b.record] for b, _ in tasks}}
        for batch, task in tasks:
            f = client.submit(runner, task, acc[rec_ids[batch.record]],
                              key=f"urmx-batch-{batch.key}", pure=False)
            futures[f.key] = (f, batch)
        for f in as_completed([f for f, _ in futures.values()]):
            on_result(futures[f.key][1], f.result())
    finally:
        if owned:
            for f, _ in futures.values():
                f.cancel()
            close_client(client)


def run_grid(study: Study, records: dict[str, RecordData], scheduler: Any = "serial", *,
             batch_size: int = 16, kernel: Callable | None = None,
             command: str | None = None) -> xr.Dataset:
    """Run a study grid in memory: the batches, the scheduler and the Dataset assembly of
    :func:`run_study`, without its archive (nothing kept on disk, no resume) and with the
    records given rather than resolved from the manifest.

    Parameters
    ----------
    study : Study
        The grid (e.g. built in code rather than read from a file).
    records : dict of RecordData
        Every record the study names, by id.
    scheduler : "serial", None, "threads", address or distributed.Client
        As for :func:`run_study` (default here: this process).
    batch_size : int
        Target number of analyses (IDA study: cells) per batch. [1]
    kernel : callable, optional
        Integrator with the signature of `urmx.kernel.run` (default).
    command : str, optional
        Command line for the ``history`` attribute.

    Returns
    -------
    xarray.Dataset
        The same Dataset :func:`run_study` returns.
    """
    tasks = batch_tasks(study, records, batch_size, kernel)
    results: dict[str, dict[str, np.ndarray]] = {}

    def on_result(batch: Batch, result: dict[str, np.ndarray]) -> None:
        results[batch.key] = result

    runner, assemble, _ = _kind(study)
    started = _dt.datetime.now(_dt.timezone.utc).replace(microsecond=0).isoformat()
    _compute(tasks, records, study.records, scheduler, on_result, runner)
    return assemble(study, records, tasks, results, started, command)


def run_study(study: Study | str | os.PathLike, *, out: str | os.PathLike | None = None,
              scheduler: Any = None, progress: bool = True, batch_size: int = 16,
              records_dir: str | os.PathLike | None = None, kernel: Callable | None = None,
              command: str | None = None) -> xr.Dataset:
    """Run a study grid and return one labelled Dataset (and write it to `out`).

    Parameters
    ----------
    study : Study or str or path
        A loaded study, a study file, or the name of a catalog study.
    out : str or path, optional
        netCDF archive to write. Finished batches are kept in ``<out>.parts/`` until the
        archive is written, so an interrupted run resumes where it stopped.
    scheduler : None, "serial", "threads", address or distributed.Client
        Where batches run (module docstring). Default: local worker processes, one per core.
    progress : bool
        Show a progress bar on stderr.
    batch_size : int
        Target number of analyses per batch (walls are grouped to reach it). [1]
    records_dir : str or path, optional
        Records folder (default `urmx.config.records_dir`).
    kernel : callable, optional
        Integrator with the signature of `urmx.kernel.run` (default), e.g. a reference solver.
    command : str, optional
        Command line for the ``history`` attribute.

    Returns
    -------
    xarray.Dataset

    Notes
    -----
    A study with an ``[study.ida]`` table runs one collapse capacity per (wall, diaphragm,
    record, cor) cell instead (`urmx.fragility.run_ida_batch`, assembled by
    `urmx.fragility.assemble_ida`); then a batch holds up to ``batch_size`` cells of one
    diaphragm and record.
    """
    if not isinstance(study, Study):
        study = load_study(study)
    records = resolve_records(study, records_dir)
    tasks = batch_tasks(study, records, batch_size, kernel)
    return _execute(study, records, tasks, out, scheduler, progress, command)


def _kind(study: Study) -> tuple[Callable, Callable, str]:
    """(runner of a batch, assembly of the Dataset, what a cell is) of a study's kind: a grid
    of analyses, or one collapse capacity per cell for an IDA study (`urmx.fragility`)."""
    if study.ida is not None:
        from . import fragility

        return fragility.run_ida_batch, fragility.assemble_ida, "cells"
    return run_batch, _assemble, "analyses"


def _execute(study: Study, records: dict[str, RecordData], tasks: list[tuple[Batch, dict]],
             out: str | os.PathLike | None, scheduler: Any, progress: bool,
             command: str | None) -> xr.Dataset:
    """Run the batches not already in ``<out>.parts/``, keep each as it finishes, assemble
    the Dataset and write the archive (shared by every study kind)."""
    runner, assemble, unit = _kind(study)
    parts = None
    results: dict[str, dict[str, np.ndarray]] = {}
    started = _dt.datetime.now(_dt.timezone.utc).replace(microsecond=0).isoformat()
    if out is not None:
        out = Path(out)
        parts = out.with_name(out.name + ".parts")
        parts.mkdir(parents=True, exist_ok=True)
        stamp_file = parts / "started"
        if stamp_file.is_file():
            started = stamp_file.read_text().strip()
        else:
            stamp_file.write_text(started + "\n")
        for b, _ in tasks:
            p = parts / f"{b.key}.npz"
            if p.is_file():
                r = _load_part(p)
                if r is not None:
                    results[b.key] = r
    todo = [(b, t) for b, t in tasks if b.key not in results]
    bar = _Progress(len(tasks), study.size, progress, unit)
    bar.done = len(tasks) - len(todo)

    def on_result(batch: Batch, result: dict[str, np.ndarray]) -> None:
        if parts is not None:
            _save_part(parts, batch.key, result)
        results[batch.key] = result
        bar.update()

    _compute(todo, records, study.records, scheduler, on_result, runner)
    ds = assemble(study, records, tasks, results, started, command)
    if out is not None:
        write_netcdf(ds, out)
        shutil.rmtree(parts, ignore_errors=True)
    return ds


# ---- the Dataset ----------------------------------------------------------------------------

def _coord(name: str, dims: Any, values: Any) -> xr.Variable:
    return xr.Variable(dims, values, attrs=variables.attrs(name))


def _assemble(study: Study, records: dict[str, RecordData], tasks: list[tuple[Batch, dict]],
              results: dict[str, dict[str, np.ndarray]], started: str,
              command: str | None) -> xr.Dataset:
    dims = study.dims
    names = list(dims)
    shape = tuple(len(v) for v in dims.values())
    data = _unrun(shape)
    # batch arrays are (walls, cor, scale, impact, damping); drop the axes the study lacks
    drop = tuple(i + 2 for i, k in enumerate(("scale", "impact", "damping"))
                 if k not in study.extra)
    hist: dict[str, dict[str, np.ndarray]] = {}
    for batch, _ in tasks:
        r = results[batch.key]
        for name in data:
            arr = r[name].reshape([n for i, n in enumerate(r[name].shape) if i not in drop])
            for j, iw in enumerate(batch.walls):
                data[name][iw, batch.diaphragm, batch.record] = arr[j]
        for j, label in enumerate(r["history_labels"]):
            prefix = f"history{j}."
            hist[str(label)] = {k[len(prefix):]: v for k, v in r.items() if k.startswith(prefix)}

    data_vars = {}
    for name, arr in data.items():
        attrs = variables.attrs(name)
        if name == "status":
            attrs["flag_values"] = np.arange(len(STATUS), dtype=np.int8)
            attrs["flag_meanings"] = " ".join(s.replace("-", "_") for s in STATUS)
        elif name in variables.INTEGER_SCALARS:
            attrs["comment"] = f"{INT_FILL} where the cell was not run"
        data_vars[name] = xr.Variable(names, arr, attrs=attrs)

    coords = grid_coords(study, records)
    for k in ("scale", "damping"):
        if k in dims:
            coords[k] = _coord(k, k, np.array(dims[k], dtype=np.float64))
    if "impact" in dims:
        coords["impact"] = _coord("impact", "impact", np.array(dims["impact"], dtype=object))

    if study.histories:
        labels = [h.label for h in study.histories]
        time, hist_dt = _history_time(hist, labels)
        coords.update({
            "history": _coord("history", "history", np.array(labels, dtype=object)),
            "history_wall": _coord("history_wall", "history",
                                   np.array([h.wall for h in study.histories], dtype=object)),
            "history_diaphragm": _coord("history_diaphragm", "history", np.array(
                [h.diaphragm for h in study.histories], dtype=object)),
            "history_record": _coord("history_record", "history",
                                     np.array([h.record for h in study.histories], dtype=object)),
            "history_cor": _coord("history_cor", "history",
                                  np.array([h.cor for h in study.histories])),
            "history_dt": _coord("history_dt", "history", np.array(hist_dt)),
            "time": xr.Variable("time", time, attrs=variables.attrs("time")),
        })
        present = [v for v in variables.HISTORIES if v in hist[labels[0]]]
        for v in present:
            arr = np.full((len(labels), len(time)), np.nan)
            for i, lab in enumerate(labels):
                arr[i] = _on_grid(time, hist[lab]["time"], hist[lab][v], v == "pattern")
            data_vars[v] = xr.Variable(("history", "time"), arr, attrs=variables.attrs(v))

    return xr.Dataset(data_vars, coords=coords,
                      attrs=global_attrs(study, started, command))


def global_attrs(study: Study, started: str, command: str | None) -> dict[str, str]:
    """Global attributes of a study archive (title, CF convention, ``history`` with the
    time `started` and the `command`, the urmx version, the study file's text); shared by
    every study kind."""
    from . import __version__

    cmd = command or f"urmx.run_study({study.name!r})"
    return {
        "title": study.title or study.name,
        "Conventions": "CF-1.8",
        "history": f"{started} urmx {__version__}: {cmd}",
        "urmx_version": __version__,
        "study_name": study.name,
        "study": study.text,
        "source": "urmx: exact event-driven rocking of cracked URM walls (MODEL.md)",
    }


def grid_coords(study: Study, records: dict[str, RecordData]) -> dict[str, xr.Variable]:
    """Coordinates of the wall, diaphragm, record and cor dimensions, with the items'
    properties (shared by every study kind)."""
    dims = study.dims
    walls = [w.wall for w in study.walls]
    specimen = study.supports == SPECIMEN
    cell_walls = [[study.wall(s, d) for d in study.diaphragms] for s in study.walls]
    cell_freq = np.array([[w.diaphragm_frequency("top") for w in row] for row in cell_walls])
    median = len(walls) // 2
    md = study.catalog.building.diaphragm_mass
    recs = [records[r] for r in study.records]
    coords = {
        "wall": _coord("wall", "wall", np.array(dims["wall"], dtype=object)),
        "slenderness": _coord("slenderness", "wall", np.array([w.slenderness for w in walls])),
        "height": _coord("height", "wall", np.array([w.height for w in walls])),
        "thickness": _coord("thickness", "wall", np.array([w.thickness for w in walls])),
        "mass": _coord("mass", "wall", np.array([w.mass for w in walls])),
        "crack_ratio": _coord("crack_ratio", "wall", np.array([w.crack_ratio for w in walls])),
        "pmr": _coord("pmr", "wall", np.array([w.pmr for w in walls])),
        "diaphragm": _coord("diaphragm", "diaphragm", np.array(dims["diaphragm"], dtype=object)),
        "stiffness": _coord("stiffness", "diaphragm", np.array(
            [math.nan if specimen else d.stiffness_value for d in study.diaphragms])),
        "frequency": _coord("frequency", "diaphragm", np.array(
            [math.nan if specimen else cell_freq[median, i]
             for i in range(len(study.diaphragms))])),
        "cell_frequency": _coord("cell_frequency", ("wall", "diaphragm"), cell_freq),
        "diaphragm_mass": _coord("diaphragm_mass", "diaphragm", np.array(
            [math.nan if specimen else md for _ in study.diaphragms])),
        "diaphragm_damping": _coord("diaphragm_damping", "diaphragm", np.array(
            [d.damping for d in study.diaphragms])),
        "record": _coord("record", "record", np.array(dims["record"], dtype=object)),
        "pga": _coord("pga", "record", np.array([r.pga for r in recs])),
        "scale_factor": _coord("scale_factor", "record",
                               np.array([r.scale_factor for r in recs])),
        "scaled_pga": _coord("scaled_pga", "record",
                             np.array([r.pga * r.scale_factor for r in recs])),
        "record_dt": _coord("record_dt", "record", np.array([r.dt for r in recs])),
        "cor": _coord("cor", "cor", np.array(dims["cor"], dtype=np.float64)),
    }
    if study.own_supports:
        coords["supports"] = _coord("supports", "diaphragm", np.array(
            [study.supports_of(d) for d in study.diaphragms], dtype=object))
    return coords


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


def open_study(path: str | os.PathLike, chunks: Any = None) -> xr.Dataset:
    """Reopen a study archive lazily (dask arrays; ``chunks`` as for `xarray.open_dataset`,
    default one chunk per variable)."""
    return xr.open_dataset(path, engine="netcdf4", chunks={} if chunks is None else chunks)


def status_names(status: xr.DataArray) -> xr.DataArray:
    """The status codes of a study as strings (``ok``, ``collapsed``, ...)."""
    return xr.apply_ufunc(lambda a: np.asarray(STATUS, dtype=object)[a], status,
                          dask="allowed")

