"""The study engine: a study file -> its kind's batches on dask -> one labelled Dataset -> a
netCDF archive, resumable, for any registered study kind (`urmx.study.kinds`), which it
never asks the name of.

The engine resolves the study's records, asks the study's kind for its batches
(:func:`batch_tasks`), loads what an archive's parts folder already holds, computes the
rest (:func:`compute`: in this process or on a dask cluster, saving each batch as it
arrives), and hands every result to the kind to assemble.

Resumable archives: with ``out=FILE.nc`` every finished batch is saved at once in the
sidecar folder ``FILE.nc.parts/`` under its key (`urmx.study.parts`). A run that is stopped
(Ctrl-C, a killed worker, a full disk) keeps those files; run it again and only the missing
batches are computed. One run at a time holds the folder (an OS file lock); a second run on
the same archive stops with a clear error. The archive is written to a temporary name and
renamed, and the sidecar folder is removed after that. The archive's ``history`` carries
the time the run was first started, so a resumed run writes the same archive as an
uninterrupted one.

Schedulers (`urmx.study.clients`): the client already active in the process is used, a
small study runs in this process (:func:`compute`); on a cluster, every worker must run
this process's code (checked when the run connects and on every result), a worker lost
mid-run is survived (dask reruns its batches, and the record samples are tasks it can
recompute, not scattered data), and a cluster left with no worker, or whose scheduler
goes away, stops the run with a `urmx.errors.RunError` instead of a hang.

Outputs: the archive path is resolved and checked (a test file written in its folder, no
input file of the run) before any work (`urmx.errors.check_output`); a failure to write
a part or the archive says how many finished batches are kept.

:func:`run_study` reads a study file, resolves its records and writes the archive;
:func:`run_grid` runs a study built in code on records given in memory, with no archive
(benchmarks).
"""

from __future__ import annotations

import datetime as _dt
import os
import shutil
import time
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ..catalog import Study, load_study
from ..errors import InputError, OutputError, RunError, check_output
from ..netcdf import write_netcdf
from ..provenance import differs
from . import kinds
from .batches import Batch
from .clients import (
    Watch,
    active_client,
    check_scheduler,
    check_workers,
    fetch_all,
    get_client,
    mismatch,
    quiet_client,
    record_samples,
    refuse_in_worker_import,
    release,
    run_stamped,
    setting,
    worker_timeout,
)
from .dataset import global_attrs
from .parts import Lock, PartStore
from .progress import Progress
from .samples import resolve_records

if TYPE_CHECKING:
    import xarray as xr


def batch_tasks(study: Study, records: dict, batch_size: int = 16,
                kernel: Callable | None = None) -> list[tuple[Batch, dict[str, Any]]]:
    """The batches of a study, each with the task a worker runs (its kind's ``run``).

    Parameters
    ----------
    study : Study
        The study (its kind: ``study.kind``).
    records : dict of urmx.records.Record
        The study's records by id (:func:`urmx.study.samples.resolve_records`).
    batch_size : int
        Target number of cells (the kind's unit: analyses, ...) per batch. [1]
    kernel : callable, optional
        Integrator with the signature of `urmx.kernel.run` (default).

    Returns
    -------
    list of (Batch, dict)
        Each batch (its ``key`` set to a hash of everything that decides its result) and
        its task: plain Python and numpy values, picklable, no xarray.
    """
    return kinds.get(study.kind).tasks(study, records, batch_size, kernel)


def compute(tasks: list[tuple[Batch, dict]], records: dict, rec_ids: list[str],
            scheduler: Any, on_result: Callable[[Batch, dict], None],
            runner: Callable[[dict, np.ndarray], dict]) -> None:
    """Run the batches (each through `runner`, a kind's ``run``) and hand each result to
    `on_result` as it arrives.

    ``scheduler=None`` uses the ``distributed.Client`` already active in this process when
    there is one; else a study small enough runs in this process (:func:`_in_process`),
    and a larger one on a local cluster. ``"serial"`` runs in this process; any other
    scheduler given is used. On a cluster, every worker must run this process's code
    (`urmx.study.clients.check_workers`, before any work; each result's identity is
    checked again as it arrives), the cluster is watched (`urmx.study.clients.Watch`: the
    scheduler gone, or no worker for ``urmx.worker-timeout`` seconds, is a
    `urmx.errors.RunError`), and a worker lost mid-run is survived: dask runs its batches
    again elsewhere (up to its ``allowed-failures``), and the record samples are tasks it
    can recompute.
    """
    check_scheduler(scheduler)
    if scheduler == "serial":
        tasks = _here(tasks, records, rec_ids, on_result, runner)
    elif scheduler is None and active_client() is None:
        tasks = _in_process(tasks, records, rec_ids, on_result, runner)
    if not tasks:
        return
    client, owned = get_client(scheduler)
    pending: dict = {}
    with quiet_client():
        try:
            watch = Watch(client, worker_timeout())
            check_workers(client, watch.timeout)
            _submit(client, tasks, records, rec_ids, runner, pending)
            _gather(pending, on_result, watch)
        finally:
            release(client, owned, [f for f, _ in pending.values()])


def _here(tasks: list, records: dict, rec_ids: list[str], on_result: Callable,
          runner: Callable) -> list:
    """Run `tasks` in this process; nothing is left."""
    for batch, task in tasks:
        on_result(batch, runner(task, records[rec_ids[batch.record]].acceleration))
    return []


def serial_estimate(seconds: float, size: int, total: int) -> float:
    """The time a study of `total` cells would take in this process, from a batch of
    `size` cells that took `seconds`. [s]"""
    return seconds * total / max(size, 1)


def _in_process(tasks: list, records: dict, rec_ids: list[str], on_result: Callable,
                runner: Callable) -> list:
    """Run a small study in this process and return the batches left for a cluster.

    The rule: a study of one batch runs here. Otherwise the kernel is loaded and the
    first batch runs here, timed; when that time per cell times the study's cells
    (:func:`serial_estimate`) is below ``urmx.serial-below`` seconds (dask config,
    default 10: less than starting a local cluster and sharing the work would save), the
    other batches run here too; else they go to a local cluster.
    """
    if len(tasks) <= 1:
        return _here(tasks, records, rec_ids, on_result, runner)
    from ..kernel import warm_up

    warm_up()  # loading (or compiling) the kernel is not the study's cost
    start = time.perf_counter()
    _here(tasks[:1], records, rec_ids, on_result, runner)
    estimate = serial_estimate(time.perf_counter() - start, tasks[0][0].size,
                               sum(b.size for b, _ in tasks))
    if estimate < setting("serial-below"):
        return _here(tasks[1:], records, rec_ids, on_result, runner)
    return tasks[1:]


def _submit(client: Any, tasks: list, records: dict, rec_ids: list[str],
            runner: Callable, futures: dict) -> None:
    """Submit each record's samples once and every batch on them (into `futures`), each
    batch stamped with the identity of the code that runs it
    (`urmx.study.clients.run_stamped`)."""
    acc = {}
    for rid in {rec_ids[b.record] for b, _ in tasks}:
        acc[rid] = client.submit(record_samples, records[rid].acceleration,
                                 key=f"urmx-record-{records[rid].digest}", pure=False)
    for batch, task in tasks:
        f = client.submit(run_stamped, runner, task, acc[rec_ids[batch.record]],
                          key=f"urmx-batch-{batch.key}", pure=False)
        futures[f.key] = (f, batch)


def _gather(futures: dict, on_result: Callable[[Batch, dict], None], watch: Watch) -> None:
    """Hand each finished batch to `on_result` (and forget its future, so the cluster
    frees it), checking the cluster while none arrives. Results are fetched in the
    client's event loop (`urmx.study.clients.fetch_all`), so a result that can no longer
    be fetched (its worker gone, the batch rescheduled on a cluster with no worker) never
    blocks this loop. A batch the cluster lost for good, the scheduler gone, no worker
    left, or a result from other code is a `urmx.errors.RunError`."""
    import queue

    arrived = fetch_all([f for f, _ in futures.values()])
    while futures:
        try:
            f, outcome = arrived.get(timeout=watch.period / 2)
        except queue.Empty:
            watch.check()
            continue
        _take(f, outcome, futures.pop(f.key)[1], on_result, watch)


def _take(future: Any, outcome: Any, batch: Batch, on_result: Callable[[Batch, dict], None],
          watch: Watch) -> None:
    """Check one finished batch's outcome (its result, or the exception fetching it
    raised) and hand the result to `on_result`."""
    from concurrent.futures import CancelledError

    from distributed import KilledWorker

    if isinstance(outcome, KilledWorker):
        raise RunError(f"batch {batch.key} was running on every worker that died (dask's "
                       "allowed-failures)") from None
    if isinstance(outcome, (CancelledError, OSError)):
        if getattr(outcome, "reason", "") == "scheduler-connection-lost":
            raise watch.gone()
        watch.check(now=True)  # the scheduler gone says so
        if isinstance(outcome, OSError):
            raise RunError(f"the result of batch {batch.key} could not be fetched from the "
                           f"cluster: {outcome}") from None
        raise RunError(f"dask cancelled batch {batch.key} (the cluster lost it)")
    if isinstance(outcome, BaseException):
        raise outcome  # a bug in the kind: its own traceback
    if differs(outcome["identity"]):
        raise mismatch(outcome["worker"], outcome["identity"], f"its result of batch "
                       f"{batch.key} is not kept")
    on_result(batch, outcome["result"])


def _now() -> str:
    return _dt.datetime.now(_dt.timezone.utc).replace(microsecond=0).isoformat()


def _run(study: Study, records: dict, tasks: list[tuple[Batch, dict]], parts: Path | None,
         scheduler: Any, progress: bool, command: str | None) -> xr.Dataset:
    """Load what `parts` holds, compute the rest (saving each batch as it arrives) and
    have the study's kind assemble the Dataset."""
    kind = kinds.get(study.kind)
    store = PartStore(parts, kind.outputs) if parts is not None else None
    started = store.started(_now()) if store is not None else _now()
    results, rejected = store.resume([b.key for b, _ in tasks]) if store else ({}, 0)
    sizes = {b.key: b.size for b, _ in tasks}
    todo = [(b, t) for b, t in tasks if b.key not in results]
    bar = Progress(sum(sizes.values()), sum(sizes[k] for k in results), progress,
                   label=f"urmx {study.name}", unit=kind.unit)
    if results or rejected:
        bar.note(f"urmx: resuming from {parts}: {len(results)} of {len(tasks)} batches done"
                 + (f"; {rejected} damaged or foreign part file(s) are computed again"
                    if rejected else ""))

    def on_result(batch: Batch, result: dict[str, np.ndarray]) -> None:
        if store is not None:
            store.save(batch.key, result)
        results[batch.key] = result
        bar.update(sizes[batch.key])

    try:
        compute(todo, records, study.records, scheduler, on_result, kind.run)
    except RunError as exc:
        if store is None or not store.count():
            raise
        raise RunError(f"{exc}; {len(results)} of {len(tasks)} batches are kept in "
                       f"{str(parts)!r}: run again to resume") from None
    finally:
        bar.close()
    return kind.assemble(study, records, tasks, results, global_attrs(study, started, command))


def run_grid(study: Study, records: dict, scheduler: Any = "serial", *,
             batch_size: int = 16, kernel: Callable | None = None,
             command: str | None = None) -> xr.Dataset:
    """Run a study in memory: the batches, the scheduler and the Dataset assembly of
    :func:`run_study`, without its archive (nothing kept on disk, no resume) and with the
    records given rather than resolved from the manifest.

    Parameters
    ----------
    study : Study
        The study (e.g. built in code rather than read from a file), of any kind.
    records : dict of urmx.records.Record
        Every record the study names, by id.
    scheduler : "serial", None, "threads", address or distributed.Client
        As for :func:`run_study` (default here: this process).
    batch_size : int
        Target number of cells (the kind's unit) per batch. [1]
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
    return _run(study, records, tasks, None, scheduler, False, command)


def _check_batch_size(batch_size: Any) -> None:
    if isinstance(batch_size, bool) or not isinstance(batch_size, (int, np.integer)) \
            or batch_size < 1:
        raise InputError(f"batch_size={batch_size!r} must be a whole number >= 1 "
                         "(cells of the study's kind per batch)")


def input_files(study: Study, records_dir: str | os.PathLike | None = None
                ) -> list[tuple[str, Path]]:
    """The files a study run reads, each with what it is: the study file, the record files
    it declares itself (``[records.<id>]``), and the records manifest and file of each of
    its manifest records (as far as the manifest can be read: a bad one is said when the
    records are loaded)."""
    from .. import records as rec
    from ..errors import UrmxError

    found = [("the study file", Path(study.path))] if study.path is not None else []
    found += [(f"the file of record {rid!r}", Path(own.path))
              for rid, own in study.own_records.items()]
    try:
        entries = rec.manifest(records_dir)
    except (UrmxError, OSError):
        return found
    for rid in study.records:
        entry = entries.get(rid, {})
        for key, label in (("path", f"the file of record {rid!r}"),
                           ("manifest", "the records manifest")):
            if entry.get(key):
                found.append((label, Path(entry[key])))
    return found


def _parts_folder(out: str | os.PathLike, inputs: list[tuple[str, Path]] = ()
                  ) -> tuple[Path, Path]:
    """(the checked archive path, resolved; its parts folder): an archive that is one of
    the run's `inputs`, a name that is not UTF-8, or a folder where no test file can be
    written is refused before any work."""
    out = check_output(out, "archive", inputs=inputs, utf8=True)
    parts = out.with_name(out.name + ".parts")
    if parts.exists() and not parts.is_dir():
        raise OutputError(f"{str(parts)!r} is in the way of the archive's parts folder: "
                          "remove it")
    return out, parts


def run_study(study: Study | str | os.PathLike, *, out: str | os.PathLike | None = None,
              scheduler: Any = None, progress: bool = True, batch_size: int = 16,
              records_dir: str | os.PathLike | None = None, kernel: Callable | None = None,
              command: str | None = None) -> xr.Dataset:
    """Run a study of any kind and return one labelled Dataset (and write it to `out`).

    Parameters
    ----------
    study : Study or str or path
        A loaded study, a study file, or the name of a catalog study.
    out : str or path, optional
        netCDF archive to write. Finished batches are kept in ``<out>.parts/`` until the
        archive is written, so an interrupted run resumes where it stopped. Resolved
        (symbolic links, ``..``) and checked before any work: a folder, a place where a
        test file cannot be written (no permission, a full disk), a name that is not UTF-8,
        or an input of the run (the study file, a record's file, the records manifest) is
        refused; a second run on the same archive while one is running stops with a
        `urmx.errors.RunError`.
    scheduler : None, "serial", "threads", "processes", address or distributed.Client
        Where batches run (`urmx.study.clients`). Default: the ``distributed.Client``
        already active in this process, else this process for a small study (estimated
        under ``urmx.serial-below`` seconds, :func:`compute`), else local worker
        processes, one per core. A closed or asynchronous Client is an
        `urmx.errors.InputError`.
    progress : bool
        Show progress on stderr (a bar with rate and ETA on a terminal, plain lines in a
        log file), counted in the kind's unit.
    batch_size : int
        Target number of cells per batch (the kind's unit: analyses for a grid), >= 1. [1]
    records_dir : str or path, optional
        Records folder (default `urmx.config.records_dir`).
    kernel : callable, optional
        Integrator with the signature of `urmx.kernel.run` (default), e.g. a reference solver.
    command : str, optional
        Command line for the ``history`` attribute.

    Returns
    -------
    xarray.Dataset
        The study kind's Dataset (`urmx.study.kinds`). Outputs of cells that were not run,
        or have no valid result, are NaN (integer outputs are float64 in memory, int32 with
        ``_FillValue`` -1 on disk).

    Raises
    ------
    urmx.UrmxError
        Bad arguments or study file (`urmx.errors.InputError`,
        `urmx.catalog.CatalogError`), an archive that cannot be written
        (`urmx.errors.OutputError`, also for a full disk, saying what is kept), another
        run on the same archive, an unreachable scheduler, a cluster that lost a batch for
        good, a worker that runs other code, no worker left for ``urmx.worker-timeout``
        seconds or the scheduler gone (`urmx.errors.RunError`).
    """
    refuse_in_worker_import()
    _check_batch_size(batch_size)
    check_scheduler(scheduler)
    parts = None
    if out is not None:  # an input never becomes the output
        study = study if isinstance(study, Study) else load_study(study)
        out, parts = _parts_folder(out, input_files(study, records_dir))

    def prepare():
        s = study if isinstance(study, Study) else load_study(study)
        records = resolve_records(s, records_dir)
        return s, records, batch_tasks(s, records, batch_size, kernel)

    if parts is None:
        return _run(*prepare(), None, scheduler, progress, command)
    with Lock(parts, out):  # before reading records: a second run stops at once
        try:
            ds = _run(*prepare(), parts, scheduler, progress, command)
        except BaseException as exc:
            if not any(parts.glob("*.npz")):  # nothing to resume from: leave nothing
                shutil.rmtree(parts, ignore_errors=True)
            if isinstance(exc, OutputError):  # a full disk while saving parts
                raise _kept(exc, parts, "and run the same command again to resume") \
                    from None
            raise
        _write_archive(ds, out, parts)
        shutil.rmtree(parts, ignore_errors=True)
    return ds


def _write_archive(ds: xr.Dataset, out: Path, parts: Path) -> None:
    """Write the archive; a failure (a full disk) says that the parts are kept and how to
    finish."""
    try:
        write_netcdf(ds, out)
    except OutputError as exc:
        raise _kept(exc, parts, "and run the same command again: the archive is written "
                    "from them, nothing is computed again") from None


def _kept(exc: OutputError, parts: Path, then: str) -> OutputError:
    """`exc` with how many finished batches `parts` keeps and how to go on (free space
    when the disk is full, else fix the cause)."""
    import errno

    from ..netcdf import disk_full

    n = PartStore(parts, ()).count()
    if not n:
        return OutputError(f"{exc}; no finished batch is kept")
    full = getattr(exc.__cause__, "errno", None) == errno.ENOSPC or disk_full(parts)
    return OutputError(f"{exc}; {n} finished batch{'es' if n > 1 else ''} kept in "
                       f"{str(parts)!r}: {'free space on its disk' if full else 'fix that'} "
                       f"{then}")
