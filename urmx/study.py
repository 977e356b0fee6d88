"""Study grids: a study file -> batches on dask -> one labelled Dataset -> a netCDF archive.

A study (`urmx.catalog.load_study`) is a grid over ``wall``, ``diaphragm``, ``record``,
``cor`` and any of ``scale``, ``impact``, ``damping``. It runs in **batches**: one record,
one diaphragm and a group of walls, over every value of the other dimensions; a batch returns
plain numpy arrays (the kernel knows nothing of xarray), and the Dataset is built once from
them.

Resumable archives: with ``out=FILE.nc`` every finished batch is saved at once as a small
``.npz`` in the sidecar folder ``FILE.nc.parts/``, named by a hash of everything that decides
its result (walls, record samples, scale factor, CORs, kernel, urmx version, and
`urmx.jitcache.SOURCE_HASH`, the hash of the compiled kernel's sources, so a part an older
kernel computed is never reused). A run that is stopped (Ctrl-C, a killed worker, a full
disk) keeps those files; run it again and only the missing batches are computed. Each part
stores its key too, so a part copied or renamed from another batch, or cut short, is
computed again. One run at a time holds the folder (an OS file lock); a second run on the
same archive stops with a clear error. The archive is written to a temporary name and
renamed, and the sidecar folder is removed after that. The archive's ``history`` carries
the time the run was first started, so a resumed run writes the same archive as an
uninterrupted one.

Missing results: every output of a cell whose status is not ``ok`` or ``collapsed`` (left
out by the study's pairs, or stopped at the event limit) is NaN; the integer outputs are
float64 in the Dataset and int32 with a CF ``_FillValue`` on disk, which xarray masks.

IDA studies (a study file with ``[study.ida]``) run through the same machinery (parts and
their keys, the lock, progress, lost workers, missing cells): a batch is a group of walls of
one diaphragm and record, and each cell is one collapse capacity
(`urmx.fragility.run_ida_batch`, assembled by `urmx.fragility.assemble_ida`). A cell the
study's pairs leave out is missing in every output: NaN, with ``censored``, ``analyses``
and ``event_limits`` float64 in the Dataset and int32 with the ``_FillValue`` on disk.

Schedulers: ``None`` (default) starts a local ``dask.distributed`` cluster of worker
processes, one per core (the numba kernel holds the GIL, so processes beat threads);
``"threads"`` the same with threads; ``"serial"`` runs in this process; any other string is a
scheduler address (``tcp://host:8786``); a ``distributed.Client`` is used as it is
(:func:`local_client` starts one on this machine, :func:`close_client` stops it). A worker
lost mid-run is survived: dask reruns its batches, and the record samples are tasks it can
recompute, not scattered data. Ctrl-C reaches only this process (local workers have SIGINT
blocked), which then closes the cluster.

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
import logging
import math
import os
import re
import shutil
import signal
import sys
import threading
import time as _time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from . import jitcache, variables
from .catalog import SPECIMEN, Study, load_study
from .errors import (
    InputError,
    MissingFileError,
    OutputError,
    RunError,
    check_output,
    writing,
)
from .netcdf import INT_FILL, write_netcdf  # INT_FILL: integer outputs' _FillValue

STATUS = ("ok", "collapsed", "event-limit", "not-run")  # flag values 0, 1, 2, 3
NOT_RUN = STATUS.index("not-run")
VALID = (STATUS.index("ok"), STATUS.index("collapsed"))  # statuses whose outputs are kept
MISSING = ("NaN where the cell was not run or its status is not ok/collapsed (event-limit: "
           "the run stopped early, its peaks are not the record's)")

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
                 urmx=__version__, kernel_source=jitcache.SOURCE_HASH)
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


#: the arrays every batch of :func:`run_batch` returns (besides its kept histories)
BATCH_OUTPUTS = (*variables.SCALARS, "status", "history_labels")


def _save_part(parts: Path, key: str, result: dict[str, np.ndarray]) -> None:
    """Save one batch's arrays as ``<key>.npz`` (written under a temporary name and
    renamed); the key is stored inside too, so a copied or renamed part is recognised."""
    tmp = parts / f".{key}.{os.getpid()}.tmp.npz"
    with writing(parts, "part file in"):
        np.savez(tmp, **result, batch_key=np.array(key))
        os.replace(tmp, parts / f"{key}.npz")


def _load_part(path: Path, key: str | None = None,
               outputs: tuple[str, ...] = ()) -> dict[str, np.ndarray] | None:
    """A saved batch, or None when the file is damaged (truncated by a full disk or a kill
    mid-write), lacks one of the `outputs` its kind's batches hold (default: those of
    :func:`run_batch`), or holds another batch than `key` (copied or renamed): such a batch
    is computed again. Pickled objects are never loaded."""
    try:
        with np.load(path, allow_pickle=False) as z:
            out = {k: z[k] for k in z.files}
    except Exception:  # noqa: BLE001 - any unreadable file is recomputed, never trusted
        return None
    stored = out.pop("batch_key", None)
    if key is not None and (stored is None or str(stored) != key):
        return None
    if any(name not in out for name in outputs or BATCH_OUTPUTS):
        return None
    return out


class _Lock:
    """An exclusive claim on an archive's parts folder: a second run on the same archive
    stops with a clear message instead of repeating the work. The lock is an OS file lock
    (``flock``), released by the system when the process ends however it ends, so a killed
    run leaves no stale lock."""

    def __init__(self, parts: Path, out: Path):
        self.parts, self.out, self.fd = parts, out, None

    def __enter__(self) -> _Lock:
        try:
            import fcntl
        except ImportError:  # pragma: no cover - not POSIX: no lock
            return self
        path = self.parts / "lock"
        while True:
            with writing(self.parts, "parts folder"):
                self.parts.mkdir(parents=True, exist_ok=True)
                fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o644)
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except OSError:
                holder = os.read(fd, 200).decode(errors="replace").strip() or "unknown"
                os.close(fd)
                raise RunError(f"another urmx run ({holder}) is writing {str(self.out)!r}; "
                               "wait for it to finish, or give another output file") from None
            try:  # the folder may have been removed by a run that just finished: retry
                same = os.stat(path).st_ino == os.fstat(fd).st_ino
            except FileNotFoundError:
                same = False
            if same:
                break
            os.close(fd)
        os.ftruncate(fd, 0)
        os.write(fd, f"pid {os.getpid()}, started {_dt.datetime.now():%Y-%m-%d %H:%M:%S}"
                 .encode())
        self.fd = fd
        return self

    def __exit__(self, *exc) -> None:
        if self.fd is not None:
            os.close(self.fd)  # releases the flock
            self.fd = None


# ---- running ----------------------------------------------------------------------------------

class _Progress:
    """Progress of a study in analyses (IDA: cells), on stderr: a tqdm bar (rate, ETA) on a
    terminal; on a file or pipe, plain lines (no carriage returns) at every tenth of the
    work and at least once a minute."""

    def __init__(self, total: int, done: int, enabled: bool, label: str = "urmx",
                 stream: Any = None, unit: str = "analyses"):
        self.stream = stream or sys.stderr
        self.total, self.done, self.label, self.unit = total, done, label, f" {unit}"
        self.enabled = enabled and total > 0
        self.bar = None
        self.start = _time.monotonic()
        self.initial = done
        self.last_line = (-1, self.start)
        if not self.enabled:
            return
        isatty = getattr(self.stream, "isatty", None)
        if isatty is not None and isatty():
            from tqdm import tqdm

            self.bar = tqdm(total=total, initial=done, unit=self.unit, desc=label,
                            file=self.stream, dynamic_ncols=True, smoothing=0.05, leave=True)
        else:
            self._line()

    def note(self, message: str) -> None:
        """A line of text above the bar (nothing when progress is off)."""
        if not self.enabled:
            return
        if self.bar is not None:
            self.bar.write(message, file=self.stream)
        else:
            self.stream.write(message + "\n")
            self.stream.flush()

    def _line(self) -> None:
        from tqdm import tqdm

        now = _time.monotonic()
        meter = tqdm.format_meter(self.done, self.total, now - self.start, ncols=0,
                                  prefix=self.label, unit=self.unit, initial=self.initial)
        self.stream.write(meter + "\n")
        self.stream.flush()
        self.last_line = (10 * self.done // self.total, now)

    def update(self, n: int) -> None:
        self.done += n
        if not self.enabled:
            return
        if self.bar is not None:
            self.bar.update(n)
            return
        tenth, when = self.last_line
        if (10 * self.done // self.total > tenth or self.done == self.total
                or _time.monotonic() - when > 60.0):
            self._line()

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()
            self.bar = None


_ADDRESS = re.compile(r"^[a-z][a-z0-9+.-]*://\S+$")


def check_scheduler(scheduler: Any) -> None:
    """Refuse a scheduler argument that is none of the accepted kinds (module docstring)."""
    if scheduler is None or hasattr(scheduler, "submit"):
        return
    if isinstance(scheduler, str) and (scheduler in ("serial", "threads", "processes")
                                       or _ADDRESS.match(scheduler)):
        return
    raise InputError(f"scheduler {scheduler!r} is not one of 'serial', 'threads', "
                     "'processes', a scheduler address such as 'tcp://host:8786' or a "
                     "distributed.Client")


def _quiet_worker() -> None:
    """Run in each local worker process: Ctrl-C in the terminal reaches the whole process
    group, but only the main process should handle it (it cancels the work and closes the
    cluster); workers that die of it print a traceback each."""
    if threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGINT, signal.SIG_IGN)


def _quiet_workers():
    """A worker plugin applying `_quiet_worker` to every worker, restarted ones included."""
    from distributed import WorkerPlugin

    class QuietWorkers(WorkerPlugin):
        name = "urmx-quiet-sigint"
        idempotent = True

        def setup(self, worker) -> None:
            _quiet_worker()

    return QuietWorkers()


def local_client(n_workers: int | None = None, threads: bool = False):
    """A ``distributed.Client`` on a new local cluster.

    Parameters
    ----------
    n_workers : int, optional
        Worker processes of one thread each (default: one per core). The kernel holds
        the GIL, so processes beat threads; the kernel is compiled (or loaded from the
        cache) here first, so the workers load its native code from the cache.
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
    # Ctrl-C in a terminal reaches the whole process group. SIGINT is blocked while the
    # cluster starts: the worker processes (and those restarted later, spawned from the
    # cluster's thread) inherit the blocked signal, so only this process handles it; a
    # Ctrl-C pressed meanwhile is delivered when it is unblocked.
    block = (threading.current_thread() is threading.main_thread()
             and hasattr(signal, "pthread_sigmask"))
    mask = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT}) if block else None
    cluster = client = None
    try:
        cluster = LocalCluster(n_workers=1 if threads else n,
                               threads_per_worker=n if threads else 1,
                               processes=not threads, dashboard_address=":0",
                               silence_logs=logging.CRITICAL)
        client = Client(cluster)
        if not threads:
            client.register_plugin(_quiet_workers())
        if block:
            signal.pthread_sigmask(signal.SIG_SETMASK, mask)  # a pending Ctrl-C: now
    except BaseException:
        if block:
            signal.pthread_sigmask(signal.SIG_SETMASK, mask)
        if client is not None:
            close_client(client)
        elif cluster is not None:
            cluster.close()
        raise
    return client


def get_client(scheduler: Any) -> tuple[Any, bool]:
    """(client, owned) for a `scheduler` argument of :func:`run_study`: a Client is used as
    it is (owned False); None or "processes" start local worker processes, "threads" a
    threaded local worker, any other string connects to that scheduler address (owned True:
    the caller closes it with :func:`close_client`).

    Raises
    ------
    urmx.errors.InputError
        `scheduler` is none of these.
    urmx.errors.RunError
        The scheduler address cannot be reached.
    """
    from distributed import Client

    check_scheduler(scheduler)
    if isinstance(scheduler, Client):
        return scheduler, False
    if scheduler in (None, "processes", "threads"):
        return local_client(threads=scheduler == "threads"), True
    try:
        return Client(scheduler), True
    except (OSError, TimeoutError) as exc:
        raise RunError(f"cannot reach the dask scheduler {scheduler!r}: {exc}") from None


def close_client(client: Any) -> None:
    """Close a client and the local cluster it started, if any (quietly: workers stopped on
    purpose are not errors, and a scheduler closed while results are still on their way
    would log each one)."""
    cluster = getattr(client, "cluster", None)
    previous = logging.root.manager.disable
    logging.disable(logging.CRITICAL)
    try:
        client.close()
        if cluster is not None:
            cluster.close()
    finally:
        logging.disable(previous)


def _record_samples(acceleration: np.ndarray) -> np.ndarray:
    """A record's samples as a dask task: held by one worker and fetched by the others;
    when that worker is lost, the scheduler computes it again from this task (scattered
    data would be lost for good, and every batch waiting on it cancelled)."""
    return acceleration


def _compute(tasks: list[tuple[Batch, dict]], records: dict[str, RecordData], rec_ids: list[str],
             scheduler: Any, on_result: Callable[[Batch, dict], None],
             runner: Callable[[dict, np.ndarray], dict] | None = None) -> None:
    """Run the batches (each through `runner`, default :func:`run_batch`) and hand each
    result to `on_result` as it arrives.

    ``scheduler=None`` runs a single batch in this process (no cluster for one batch);
    any scheduler given explicitly is used. A worker lost mid-run is survived: dask runs
    its batches again elsewhere (up to its ``allowed-failures``), and the record samples
    are tasks it can recompute.
    """
    runner = runner or run_batch
    check_scheduler(scheduler)
    if scheduler == "serial" or (scheduler is None and len(tasks) <= 1):
        for batch, task in tasks:
            on_result(batch, runner(task, records[rec_ids[batch.record]].acceleration))
        return
    from concurrent.futures import CancelledError

    from distributed import KilledWorker, as_completed

    client, owned = get_client(scheduler)
    futures = {}
    try:
        acc = {}
        for rid in {rec_ids[b.record] for b, _ in tasks}:
            acc[rid] = client.submit(_record_samples, records[rid].acceleration,
                                     key=f"urmx-record-{records[rid].digest}", pure=False)
        for batch, task in tasks:
            f = client.submit(runner, task, acc[rec_ids[batch.record]],
                              key=f"urmx-batch-{batch.key}", pure=False)
            futures[f.key] = (f, batch)
        for f in as_completed([f for f, _ in futures.values()]):
            try:
                result = f.result()
            except KilledWorker:
                raise RunError(f"batch {futures[f.key][1].key} was running on every worker "
                               "that died (dask's allowed-failures)") from None
            except CancelledError:
                raise RunError(f"dask cancelled batch {futures[f.key][1].key} (the cluster "
                               "lost it)") from None
            on_result(futures[f.key][1], result)
    finally:
        if owned:  # a cluster urmx started is closed with its work
            close_client(client)
        elif futures:
            client.cancel([f for f, _ in futures.values()])


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

    kind = _kind(study)
    started = _dt.datetime.now(_dt.timezone.utc).replace(microsecond=0).isoformat()
    _compute(tasks, records, study.records, scheduler, on_result, kind.runner)
    return kind.assemble(study, records, tasks, results, started, command)


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
        archive is written, so an interrupted run resumes where it stopped. Checked before
        any work (a folder, or a place that cannot be written, is refused); a second run
        on the same archive while one is running stops with a `urmx.errors.RunError`.
    scheduler : None, "serial", "threads", "processes", address or distributed.Client
        Where batches run (module docstring). Default: local worker processes, one per
        core (a study of one batch runs in this process).
    progress : bool
        Show progress on stderr (a bar with rate and ETA on a terminal, plain lines in a
        log file).
    batch_size : int
        Target number of analyses per batch (walls are grouped to reach it), >= 1. [1]
    records_dir : str or path, optional
        Records folder (default `urmx.config.records_dir`).
    kernel : callable, optional
        Integrator with the signature of `urmx.kernel.run` (default), e.g. a reference solver.
    command : str, optional
        Command line for the ``history`` attribute.

    Returns
    -------
    xarray.Dataset
        Outputs of cells that were not run, or whose status is not ``ok``/``collapsed``,
        are NaN (integer outputs are float64 in memory, int32 with ``_FillValue`` -1 on
        disk).

    Raises
    ------
    urmx.UrmxError
        Bad arguments or study file (`urmx.errors.InputError`,
        `urmx.catalog.CatalogError`), an archive that cannot be written
        (`urmx.errors.OutputError`), another run on the same archive, an unreachable
        scheduler or a cluster that lost a batch for good (`urmx.errors.RunError`).

    Notes
    -----
    A study with an ``[study.ida]`` table runs one collapse capacity per (wall, diaphragm,
    record, cor) cell instead (`urmx.fragility.run_ida_batch`, assembled by
    `urmx.fragility.assemble_ida`); then a batch holds up to ``batch_size`` cells of one
    diaphragm and record. Its parts, lock, progress and missing cells work as above.
    """
    if isinstance(batch_size, bool) or not isinstance(batch_size, (int, np.integer)) \
            or batch_size < 1:
        raise InputError(f"batch_size={batch_size!r} must be a whole number >= 1 "
                         "(analyses, or IDA cells, per batch)")
    check_scheduler(scheduler)
    parts = None
    if out is not None:
        out = check_output(out, "archive")
        parts = out.with_name(out.name + ".parts")
        if parts.exists() and not parts.is_dir():
            raise OutputError(f"{str(parts)!r} is in the way of the archive's parts folder: "
                              "remove it")

    def prepare():
        s = study if isinstance(study, Study) else load_study(study)
        records = resolve_records(s, records_dir)
        return s, records, batch_tasks(s, records, batch_size, kernel)

    if parts is None:
        return _run(*prepare(), None, scheduler, progress, command)
    with _Lock(parts, out):  # before reading records: a second run stops at once
        try:
            ds = _run(*prepare(), parts, scheduler, progress, command)
        except BaseException:
            if not any(parts.glob("*.npz")):  # nothing to resume from: leave nothing
                shutil.rmtree(parts, ignore_errors=True)
            raise
        write_netcdf(ds, out)
        shutil.rmtree(parts, ignore_errors=True)
    return ds


@dataclass(frozen=True)
class _Kind:
    """How the batches of one study kind run: the batch runner (numpy only, on a worker),
    the Dataset assembly, what a cell is (progress unit), the arrays every saved batch
    holds (a part lacking one is recomputed) and the number of cells of a batch's task."""

    runner: Callable[[dict, np.ndarray], dict[str, np.ndarray]]
    assemble: Callable[..., xr.Dataset]
    unit: str
    outputs: tuple[str, ...]
    cells: Callable[[dict], int]


def _grid_cells(task: dict[str, Any]) -> int:
    """Analyses of a :func:`run_batch` task: walls x damping x cor x scale x impact."""
    return (len(task["walls"]) * len(task["walls"][0]) * len(task["cor"])
            * len(task["scale"]) * len(task["impact"]))


def _kind(study: Study) -> _Kind:
    """The study's kind: a grid of analyses, or one collapse capacity per cell for a study
    with ``[study.ida]`` (`urmx.fragility`)."""
    if study.ida is not None:
        from . import fragility

        return _Kind(fragility.run_ida_batch, fragility.assemble_ida, "cells",
                     fragility.IDA_OUTPUTS, fragility.ida_cells)
    return _Kind(run_batch, _assemble, "analyses", BATCH_OUTPUTS, _grid_cells)


def _run(study: Study, records: dict[str, RecordData], tasks: list[tuple[Batch, dict]],
         parts: Path | None, scheduler: Any, progress: bool, command: str | None) -> xr.Dataset:
    """Load what `parts` holds, compute the rest (saving each batch as it arrives) and
    assemble the Dataset (every study kind, :func:`_kind`)."""
    kind = _kind(study)
    results: dict[str, dict[str, np.ndarray]] = {}
    started = _dt.datetime.now(_dt.timezone.utc).replace(microsecond=0).isoformat()
    rejected = 0
    if parts is not None:
        stamp_file = parts / "started"
        if stamp_file.is_file():
            started = stamp_file.read_text().strip()
        else:
            with writing(parts, "parts folder"):
                stamp_file.write_text(started + "\n")
        for b, _ in tasks:
            p = parts / f"{b.key}.npz"
            if p.is_file():
                r = _load_part(p, b.key, kind.outputs)
                if r is None:
                    rejected += 1
                else:
                    results[b.key] = r
    sizes = {b.key: kind.cells(t) for b, t in tasks}
    todo = [(b, t) for b, t in tasks if b.key not in results]
    bar = _Progress(sum(sizes.values()), sum(sizes[k] for k in results), progress,
                    label=f"urmx {study.name}", unit=kind.unit)
    if results or rejected:
        bar.note(f"urmx: resuming from {parts}: {len(results)} of {len(tasks)} batches done"
                 + (f"; {rejected} damaged or foreign part file(s) are computed again"
                    if rejected else ""))

    def on_result(batch: Batch, result: dict[str, np.ndarray]) -> None:
        if parts is not None:
            _save_part(parts, batch.key, result)
        results[batch.key] = result
        bar.update(sizes[batch.key])

    try:
        _compute(todo, records, study.records, scheduler, on_result, kind.runner)
    except RunError as exc:
        if parts is None or not any(parts.glob("*.npz")):
            raise
        raise RunError(f"{exc}; {len(results)} of {len(tasks)} batches are kept in "
                       f"{str(parts)!r}: run again to resume") from None
    finally:
        bar.close()
    return kind.assemble(study, records, tasks, results, started, command)


# ---- the Dataset ----------------------------------------------------------------------------

def _coord(name: str, dims: Any, values: Any) -> xr.Variable:
    return xr.Variable(dims, values, attrs=variables.attrs(name))


def _assemble(study: Study, records: dict[str, RecordData], tasks: list[tuple[Batch, dict]],
              results: dict[str, dict[str, np.ndarray]], started: str,
              command: str | None) -> xr.Dataset:
    dims = study.dims
    names = list(dims)
    shape = tuple(len(v) for v in dims.values())
    # every output is float64 here, NaN where no valid result exists (integer outputs too,
    # so that sums and means over the grid skip those cells)
    data: dict[str, np.ndarray] = {name: np.full(shape, np.nan) for name in variables.SCALARS}
    data["status"] = np.full(shape, NOT_RUN, dtype=np.int8)
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
    invalid = ~np.isin(data["status"], VALID)
    for name in variables.SCALARS:
        data[name][invalid] = np.nan

    data_vars = {}
    for name, arr in data.items():
        attrs = variables.attrs(name)
        if name == "status":
            attrs["flag_values"] = np.arange(len(STATUS), dtype=np.int8)
            attrs["flag_meanings"] = " ".join(s.replace("-", "_") for s in STATUS)
            attrs["comment"] = ("not_run: the study's pairs leave the cell out or its batch "
                                "is missing; every output of a cell that is not ok or "
                                "collapsed is missing (NaN)")
        elif name in variables.INTEGER_SCALARS:
            attrs["comment"] = (f"{MISSING}; stored as int32 with _FillValue {INT_FILL}, "
                                "read by xarray as float64 with NaN")
        else:
            attrs["comment"] = MISSING
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
    default one chunk per variable).

    Outputs of cells with no valid result read as NaN: the integer and flag outputs carry
    a CF ``_FillValue`` that xarray masks. Archives written before urmx stored them so are
    masked here: a grid's by ``status`` (integer outputs holding -1, event-limit cells
    holding their partial peaks), an IDA study's by ``analyses`` (-1 where a cell was not
    run, ``censored`` False there).
    """
    path = Path(path)
    if not path.is_file():
        raise MissingFileError(f"no study archive {str(path)!r}")
    ds = xr.open_dataset(path, engine="netcdf4", chunks={} if chunks is None else chunks)
    legacy = [n for n in variables.INTEGER_OUTPUTS
              if n in ds.data_vars and ds[n].dtype.kind in "iub"]
    if not legacy:
        return ds
    if "status" in ds.data_vars:
        valid, names, comment = ds["status"].isin(list(VALID)), variables.SCALARS, MISSING
    elif "collapse_intensity" in ds.data_vars and "analyses" in legacy:
        from .fragility import IDA_CELL_OUTPUTS, IDA_MISSING

        valid, names, comment = ds["analyses"] >= 0, IDA_CELL_OUTPUTS, IDA_MISSING
    else:
        return ds
    for name in names:
        if name in ds.data_vars:
            attrs = dict(ds[name].attrs, comment=comment)
            ds[name] = ds[name].where(valid).assign_attrs(attrs)
    return ds


def status_names(status: xr.DataArray) -> xr.DataArray:
    """The status codes of a study as strings (``ok``, ``collapsed``, ...)."""
    return xr.apply_ufunc(lambda a: np.asarray(STATUS, dtype=object)[a], status,
                          dask="allowed")

