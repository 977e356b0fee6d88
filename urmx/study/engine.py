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

Schedulers (`urmx.study.clients`): a worker lost mid-run is survived: dask reruns its
batches, and the record samples are tasks it can recompute, not scattered data.

:func:`run_study` reads a study file, resolves its records and writes the archive;
:func:`run_grid` runs a study built in code on records given in memory, with no archive
(benchmarks).
"""

from __future__ import annotations

import datetime as _dt
import os
import shutil
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ..catalog import Study, load_study
from ..errors import InputError, OutputError, RunError, check_output
from ..netcdf import write_netcdf
from . import kinds
from .batches import Batch
from .clients import check_scheduler, close_client, get_client, record_samples
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

    ``scheduler=None`` runs a single batch in this process (no cluster for one batch);
    any scheduler given explicitly is used. A worker lost mid-run is survived: dask runs
    its batches again elsewhere (up to its ``allowed-failures``), and the record samples
    are tasks it can recompute.
    """
    check_scheduler(scheduler)
    if scheduler == "serial" or (scheduler is None and len(tasks) <= 1):
        for batch, task in tasks:
            on_result(batch, runner(task, records[rec_ids[batch.record]].acceleration))
        return
    client, owned = get_client(scheduler)
    futures: dict = {}
    try:
        _submit(client, tasks, records, rec_ids, runner, futures)
        _gather(futures, on_result)
    finally:
        if owned:  # a cluster urmx started is closed with its work
            close_client(client)
        elif futures:
            client.cancel([f for f, _ in futures.values()])


def _submit(client: Any, tasks: list, records: dict, rec_ids: list[str],
            runner: Callable, futures: dict) -> None:
    """Submit each record's samples once and every batch on them (into `futures`)."""
    acc = {}
    for rid in {rec_ids[b.record] for b, _ in tasks}:
        acc[rid] = client.submit(record_samples, records[rid].acceleration,
                                 key=f"urmx-record-{records[rid].digest}", pure=False)
    for batch, task in tasks:
        f = client.submit(runner, task, acc[rec_ids[batch.record]],
                          key=f"urmx-batch-{batch.key}", pure=False)
        futures[f.key] = (f, batch)


def _gather(futures: dict, on_result: Callable[[Batch, dict], None]) -> None:
    """Hand each finished batch to `on_result`; a batch the cluster lost for good is a
    `urmx.errors.RunError`."""
    from concurrent.futures import CancelledError

    from distributed import KilledWorker, as_completed

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


def _parts_folder(out: str | os.PathLike) -> tuple[Path, Path]:
    """(the checked archive path, its parts folder)."""
    out = check_output(out, "archive")
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
        archive is written, so an interrupted run resumes where it stopped. Checked before
        any work (a folder, or a place that cannot be written, is refused); a second run
        on the same archive while one is running stops with a `urmx.errors.RunError`.
    scheduler : None, "serial", "threads", "processes", address or distributed.Client
        Where batches run (`urmx.study.clients`). Default: local worker processes, one per
        core (a study of one batch runs in this process).
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
        (`urmx.errors.OutputError`), another run on the same archive, an unreachable
        scheduler or a cluster that lost a batch for good (`urmx.errors.RunError`).
    """
    _check_batch_size(batch_size)
    check_scheduler(scheduler)
    parts = None
    if out is not None:
        out, parts = _parts_folder(out)

    def prepare():
        s = study if isinstance(study, Study) else load_study(study)
        records = resolve_records(s, records_dir)
        return s, records, batch_tasks(s, records, batch_size, kernel)

    if parts is None:
        return _run(*prepare(), None, scheduler, progress, command)
    with Lock(parts, out):  # before reading records: a second run stops at once
        try:
            ds = _run(*prepare(), parts, scheduler, progress, command)
        except BaseException:
            if not any(parts.glob("*.npz")):  # nothing to resume from: leave nothing
                shutil.rmtree(parts, ignore_errors=True)
            raise
        write_netcdf(ds, out)
        shutil.rmtree(parts, ignore_errors=True)
    return ds
