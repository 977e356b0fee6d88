"""The study engine: a study file -> its kind's cells, cut into batches on dask -> one
labelled Dataset -> a netCDF archive, resumable and reusing finished cells, for any
registered study kind (`urmx.study.kinds`), which it never asks the name of.

How a run goes (:func:`run_study`):

1. **Size.** The study's cells and its archive's bytes are computed from the sizes of its
   dimensions (`urmx.study.limits`); above the run's limits (``max_cells``, ``max_gb``) it
   stops before any work, with the size and the way on.
2. **Whose archive.** An existing ``out`` holding another study (another definition,
   `urmx.study.definition`, whatever its name), or no urmx study, is never overwritten
   without ``force=True``; a parts folder holding another study's finished parts is never
   emptied without it (the message names both studies and what differs). The same study
   renamed, extended or shrunk is not another one. Temporary files of this archive and its
   parts left by killed runs are removed (and said).
3. **Cells and their keys.** Each cell of the kind's grid has a key, a hash of everything
   that decides its result (`urmx.study.cells`: the wall's parameters, the diaphragm, the
   record's samples and scale factor, the values of every other dimension, the kind's
   settings, the kernel's name and source hash, the urmx version).
4. **Finished cells found per cell.** The parts folder ``FILE.nc.parts/`` holds each
   finished batch with its cells' keys (`urmx.study.parts`); an earlier archive of the same
   study holds its cells' keys as the variable ``cell_key`` (over the kind's dimensions; 0
   where the study ran no cell). Every cell whose key is found is taken, from the parts or
   from the archive (copied into parts first, `urmx.study.sources.take_over`), whatever
   batches made it: a resumed run with another ``batch_size``, or a study extended by a
   record, a wall or a cor value, computes only the cells not found. A record file whose
   samples changed has another digest, hence other keys: its cells are computed again.
   Cells whose kind keeps extra arrays for them (a grid's time histories) are taken from
   parts only.
5. **Batches.** The cells still to run are cut over every dimension into blocks of about
   ``batch_size`` cells, one record each (`urmx.study.batches.Cut`); a kind's ``task``
   makes each block's task and its ``run`` computes it on a worker. Batches are handed to
   dask `WINDOW` at a time (the scheduler and the workers hold no more), and each result is
   saved as a part at once and dropped: the main process keeps two int32 per cell
   (`urmx.study.sources.Sources`), not the results.
6. **Assembly.** The kind builds its Dataset from the per-cell arrays (`Kind.assemble`);
   with an archive these are dask arrays gathered from the parts slab by slab, so the
   archive is written (through `urmx.netcdf.write_netcdf`, under a temporary name, then
   renamed) without holding the results; then the parts folder is removed and the archive
   reopened lazily. The archive's ``history`` carries the time the run was first started,
   and, after it, the lines of the earlier archive whose cells the run took over (one line
   per contributing run, newest first; `merged_history`).

Counts of the last run (cells found in parts, taken from the archive, computed): :func:`last_run`.

Schedulers (`urmx.study.clients`): the client already active in the process is used, a
small study runs in this process (:func:`compute`); on a cluster, every worker must run
this process's code (checked when the run connects and on every result), a worker lost
mid-run is survived (dask reruns its batches, and the record samples are tasks it can
recompute, not scattered data), and a cluster left with no worker, or whose scheduler
goes away, stops the run with a `urmx.errors.RunError` instead of a hang.

Outputs: the archive path is resolved and checked (a test file written in its folder, no
input file of the run) before any work (`urmx.errors.check_output`); a failure to write
a part or the archive says how many finished batches are kept.

Schedulers (`urmx.study.clients`): a worker lost mid-run is survived: dask reruns its
batches, and the record samples are tasks it can recompute, not scattered data.

:func:`run_grid` runs a study built in code on records given in memory, with no archive
(benchmarks); :func:`batch_tasks` lists a study's batches and tasks.
"""

from __future__ import annotations

import contextvars
import datetime as _dt
import itertools
import os
import shutil
import threading
import time
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from .. import netcdf, variables
from .. import records as rec
from ..errors import InputError, OutputError, RunError, UrmxError, check_output, got, stop_if_asked
from ..netcdf import write_netcdf
from ..provenance import differs
from . import kinds
from .archive import open_study
from .batches import Batch, Cut
from .cells import Cells
from .clients import (
    Watch,
    active_client,
    check_scheduler,
    check_workers,
    fetch_all,
    get_client,
    mismatch,
    owning,
    quiet_client,
    record_samples,
    refuse_in_worker_import,
    release,
    run_stamped,
    setting,
    worker_timeout,
)
from .dataset import global_attrs
from .definition import Definition, base, compare
from .file import Study, load_study
from .limits import MAX_CELLS, MAX_GB, check_size
from .parts import Lock, PartStore, batch_key
from .progress import Progress
from .samples import resolve_records
from .sources import Sources, take_over

if TYPE_CHECKING:
    import xarray as xr

#: batches handed to dask at once (more when the cluster has more than WINDOW / 32 workers,
#: fewer when they hold more than WINDOW_CELLS cells in all)
WINDOW = 256
WINDOW_CELLS = 2 ** 18
#: bytes of netCDF chunk cache per variable while an archive is written: none, as each slab is
#: one whole chunk written once (a 2 MiB cache per variable held 29 MB more while a
#: 399,600-analysis archive was written)
CHUNK_CACHE = 0
MESSAGE_LOG = 16  # batches of messages a local cluster's connections keep (distributed: 1000)


@dataclass
class RunStats:
    """What a run found and computed, in cells of its kind (`unit`).

    ``runs`` cells of the study are run (its pairs leave the others out): ``from_parts``
    were found in the parts folder, ``from_archive`` taken from the earlier archive, and
    ``computed`` computed now in ``batches`` batches; ``rejected`` part files were damaged
    or foreign.
    """

    study: str
    unit: str
    runs: int
    from_parts: int = 0
    from_archive: int = 0
    computed: int = 0
    batches: int = 0
    rejected: int = 0


_LAST: list[RunStats] = []


def last_run() -> RunStats | None:
    """The counts of the last study run in this process (None before any)."""
    return _LAST[-1] if _LAST else None


def _made(cells: Cells, batch: Batch, records: dict, kernel: Callable | None,
          sources: Sources | None = None) -> tuple[Batch, dict[str, Any]]:
    """A batch with its cells' keys, its key, the results its chains start from (a
    chained kind, `_before`) and its task (the kind's ``task``)."""
    batch.cells = cells.keys(list(batch.block.values()))
    batch.key = batch_key(f"{cells.kind.name}-", batch.cells)
    if cells.chain is not None:
        batch.before = _before(cells, batch, sources)
    return batch, cells.kind.task(cells.study, records, batch, kernel)


def _before(cells: Cells, batch: Batch, sources: Sources | None) -> dict[str, np.ndarray]:
    """A chained kind's outputs (``Kind.chained``) of the cells just before the batch's
    block along the chain (the previous wall the study pairs with the record), found
    finished before the run (`urmx.study.batches.Cut` never puts a predecessor in another
    batch of the run); NaN where the block starts its chains."""
    names, ax = cells.names, cells.chain
    block = [list(v) for v in batch.block.values()]
    shape = [len(v) for v in block]
    shape[ax] = 1
    out = {name: np.full(shape, np.nan) for name in cells.kind.chained}
    paired = np.flatnonzero(cells.runnable()[:, batch.record]) if names[ax] == "wall" \
        else np.arange(cells.shape[ax])
    at = int(np.searchsorted(paired, block[ax][0]))
    if at == 0 or sources is None:
        return out
    block[ax] = [int(paired[at - 1])]
    flat = cells.flat(block).ravel()
    if not (sources.src[flat] >= 0).all():
        raise RunError(f"internal: a batch of {cells.study.name!r} would start a chain "
                       "from a cell not computed yet")
    for name in cells.kind.chained:
        out[name] = sources.values(flat, name).reshape(shape)
    out["index"] = np.array(block[ax][0])  # the predecessor's index on the chain
    return out


def batch_tasks(study: Study, records: dict, batch_size: int = 16,
                kernel: Callable | None = None) -> list[tuple[Batch, dict[str, Any]]]:
    """Every batch of a study (none found finished), each with the task a worker runs.

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
        Each batch (its ``cells`` keys and its ``key`` set) and its task: plain Python and
        numpy values, picklable, no xarray.
    """
    cells = Cells(study, kinds.get(study.kind), records, kernel)
    return [_made(cells, b, records, kernel) for b in Cut(cells, batch_size)]


def compute(tasks: list[tuple[Batch, dict]], records: dict, rec_ids: list[str],
            scheduler: Any, on_result: Callable[[Batch, dict], None],
            runner: Callable[[dict, np.ndarray], dict],
            warm_up: Callable[[], None] | None = None) -> None:
    """Run the batches (each through `runner`, a kind's ``run``; `warm_up`, its kind's,
    loads the integrator before a batch is timed or a cluster starts) and hand each result
    to `on_result` as it arrives.

    ``scheduler=None`` uses the ``distributed.Client`` already active in this process when
    there is one; else a study small enough runs in this process (:func:`_in_process`),
    and a larger one on a local cluster. ``"serial"`` runs in this process; any other
    scheduler given is used. On a cluster, every worker must run this process's code
    (`urmx.study.clients.check_workers`, before any work; each result's identity is
    checked again as it arrives), the cluster is watched (`urmx.study.clients.Watch`: the
    scheduler gone, or no worker for ``urmx.worker-timeout`` seconds, is a
    `urmx.errors.RunError`), and a worker lost mid-run is survived: dask runs its batches
    again elsewhere (up to its ``allowed-failures``), and the record samples are tasks it
    can recompute. Batches go to dask a window at a time (:func:`_window`), so the
    scheduler, the workers and this process hold few of them at once.

    Parameters
    ----------
    tasks : list of (Batch, dict)
        The batches to run and each one's task (what the kind's ``run`` takes).
    records : dict
        The study's records by id (:func:`resolve_records`), whose ``acceleration`` a batch
        runs on.
    rec_ids : list of str
        The record ids in the order of the study's record dimension (``Batch.record`` indexes
        it).
    scheduler : None, str or distributed.Client
        Where the batches run, as `urmx.run_study` takes it.
    on_result : callable
        Called with each batch and its result as it arrives.
    runner : callable
        The kind's ``run(task, acceleration)``.
    warm_up : callable, optional
        The kind's warm-up (loads or compiles its integrator), called before a batch is
        timed here and before the worker processes of a local cluster start.
    """
    _compute_all(iter(tasks), sum(b.size for b, _ in tasks), records, rec_ids, scheduler,
                 on_result, runner, warm_up)


def _compute_all(batches: Iterator, total: int, records: dict, rec_ids: list[str],
                 scheduler: Any, on_result: Callable, runner: Callable,
                 warm_up: Callable[[], None] | None = None) -> None:
    """:func:`compute` over batches made as they are needed (`total`: their cells)."""
    check_scheduler(scheduler)
    if scheduler == "serial":
        _here(batches, records, rec_ids, on_result, runner)
        return
    if scheduler is None and active_client() is None:
        batches = _in_process(batches, total, records, rec_ids, on_result, runner, warm_up)
    first = list(itertools.islice(batches, 1))
    if not first:
        return
    client, owned = _client(scheduler, warm_up)
    with quiet_client(), owning(client, owned):  # Ctrl-C: the cluster stopped within bounds
        watch = Watch(client, worker_timeout())
        check_workers(client, watch.timeout)
        for chunk in _windows(itertools.chain(first, batches), _window(client, first)):
            pending: dict = {}
            try:
                _submit(client, chunk, records, rec_ids, runner, pending)
                _gather(pending, on_result, watch)
            finally:
                if pending and not owned:
                    release(client, False, [f for f, _ in pending.values()])


def _here(tasks: Iterable, records: dict, rec_ids: list[str], on_result: Callable,
          runner: Callable) -> Iterator:
    """Run `tasks` in this process, one at a time; nothing is left."""
    for batch, task in tasks:
        stop_if_asked()
        on_result(batch, runner(task, records[rec_ids[batch.record]].acceleration))
    return iter(())


def serial_estimate(seconds: float, size: int, total: int) -> float:
    """The time a study of `total` cells would take in this process, from a batch of
    `size` cells that took `seconds`. [s]"""
    return seconds * total / max(size, 1)


def _in_process(tasks: Iterator, total: int, records: dict, rec_ids: list[str],
                on_result: Callable, runner: Callable,
                warm_up: Callable[[], None] | None = None) -> Iterator:
    """Run a small study in this process and return the batches left for a cluster.

    The rule: a study of one batch runs here. Otherwise the kernel is loaded and the
    first batch runs here, timed; when that time per cell times the `total` cells to
    compute (:func:`serial_estimate`) is below ``urmx.serial-below`` seconds (dask config,
    default 10: less than starting a local cluster and sharing the work would save), the
    other batches run here too; else they go to a local cluster.
    """
    first = list(itertools.islice(tasks, 2))
    if len(first) <= 1:
        return _here(first, records, rec_ids, on_result, runner)
    if warm_up is not None:
        warm_up()  # loading (or compiling) the integrator is not the study's cost
    start = time.perf_counter()
    _here(first[:1], records, rec_ids, on_result, runner)
    estimate = serial_estimate(time.perf_counter() - start, first[0][0].size, total)
    rest = itertools.chain(first[1:], tasks)
    if estimate < setting("serial-below"):
        return _here(rest, records, rec_ids, on_result, runner)
    return rest


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
        stop_if_asked()
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


def _resume(store: PartStore, sources: Sources) -> tuple[int, int]:
    """Place the cells the parts folder holds: (cells found, part files rejected)."""
    found, rejected = [], 0
    for path, arrays in store.scan():
        if arrays is None:
            rejected += 1
            continue
        found.append((sources.register(path, arrays), arrays["cell_key"]))
    return sources.match(found), rejected


def _unused_parts(store: PartStore, sources: Sources, cells: Cells) -> list[str]:
    """What a run says of the parts it found that hold no cell it runs (they are computed
    again, or not run): computed by another kernel or urmx (the folder's ``code`` stamp
    differs), or for cells this study no longer has. The folder is stamped with this
    run's code."""
    before = store.code(cells.code)
    unused = len(sources.parts) - np.unique(sources.src[sources.src >= 0]).size
    if not unused:
        return []
    head = f"urmx: {unused} finished part(s) in {store.folder} hold no cell of this run"
    if before is not None and before != cells.code:
        changed = ", ".join(f"{k} {before.get(k)} there, {v} now"
                            for k, v in cells.code.items() if before.get(k) != v)
        return [f"{head}: they were computed by another kernel ({changed}), so their cells "
                "are computed again"]
    return [f"{head} (cells this study no longer has): they are left out"]


def _windows(batches: Iterator, size: int) -> Iterator[list]:
    while chunk := list(itertools.islice(batches, size)):
        yield chunk


def _window(client: Any, first: list) -> int:
    """Batches to hand to dask at once: `WINDOW`, or fewer when they would hold more than
    `WINDOW_CELLS` cells (the tasks and results in flight stay small), but never fewer than
    64 or 32 per worker (every worker stays busy)."""
    try:
        workers = len(client.scheduler_info().get("workers", ()))
    except Exception:  # noqa: BLE001 - a scheduler that cannot say: the default
        workers = 0
    per = max(1, max((b.size for b, _ in first), default=1))
    return max(32 * workers, 64, min(WINDOW, WINDOW_CELLS // per))


def _client(scheduler: Any, warm_up: Callable[[], None] | None = None) -> tuple[Any, bool]:
    """`get_client`, a cluster it starts keeping short logs of the messages it sent
    (distributed keeps the last 1000 batches of messages of every connection, the batches'
    tasks with them: hundreds of MB in the main process over a long study)."""
    import dask
    import distributed  # noqa: F401 - its config defaults first, kept when the set ends

    with dask.config.set({"distributed.admin.low-level-log-length": MESSAGE_LOG}):
        return get_client(scheduler, warm_up)


def _saver(cells: Cells, sources: Sources, bar: Progress, stats: RunStats,
           first: Callable[[], None] = lambda: None) -> Callable:
    """The callback that keeps each finished batch (a part, its cells placed); `first` is
    called as each result arrives (the kind's `_Prepared` starts on the first: once the
    workers run, not while the cluster starts)."""
    kind = cells.kind

    def on_result(batch: Batch, result: dict[str, np.ndarray]) -> None:
        first()
        arrays = {}
        for name, value in result.items():
            if name.startswith("extra."):
                _, local, rest = name.split(".", 2)
                name = f"extra.{int(batch.cells.ravel()[int(local)]):016x}.{rest}"
            arrays[name] = np.asarray(value)
        for name in kind.outputs:
            shape = arrays[name].shape if name in arrays else None
            if shape is None or shape[:len(batch.shape)] != batch.shape:
                raise RunError(f"the {kind.name!r} kind's run returned {name!r} of shape "
                               f"{shape}, not its block's {batch.shape} (+ per-cell axes)")
        arrays["cell_key"] = batch.cells
        sources.add(batch.key, arrays, cells.flat(list(batch.block.values())))
        stats.computed += batch.size
        stats.batches += 1
        bar.update(batch.size)

    return on_result


def _notes(cut: Cut, stats: RunStats, parts: Path | None, archive: str | None) -> list[str]:
    """What a run says before it computes: the finished cells it found and where."""
    notes = []
    if stats.from_parts or stats.rejected:
        finished, total = cut.counts()
        notes.append(f"urmx: resuming from {parts}: {stats.from_parts:,} of {stats.runs:,} "
                     f"{stats.unit} found, {finished} of {total} batches done"
                     + (f"; {stats.rejected} damaged or foreign part file(s) are computed "
                        "again" if stats.rejected else ""))
    if stats.from_archive:
        notes.append(f"urmx: {stats.from_archive:,} {stats.unit} taken from the archive "
                     f"{archive}")
    reused = stats.from_parts + stats.from_archive
    if reused:
        notes.append(f"urmx {stats.study}: {reused:,} of {stats.runs:,} {stats.unit} reused "
                     f"({stats.from_parts:,} from parts, {stats.from_archive:,} from the "
                     f"archive), {stats.runs - reused:,} to compute")
    return notes


def _run(study: Study, records: dict, store: PartStore | None, scheduler: Any,
         progress: bool, command: str | None, batch_size: int, kernel: Callable | None,
         archive: tuple[Any, str] | None = None, notes: tuple[str, ...] = ()
         ) -> xr.Dataset:
    """Find the finished cells (parts, then `archive`: an earlier archive of the study,
    opened, and its path), compute the rest (saving each batch
    as it arrives) and have the study's kind assemble the Dataset (lazy over the parts when
    there is a parts folder)."""
    kind = kinds.get(study.kind)
    cells = Cells(study, kind, records, kernel)
    started = store.started(_now()) if store is not None else _now()
    sources = Sources(cells, store)
    pairs = cells.runnable()  # (wall, record): every other dimension runs whole
    stats = RunStats(study.name, kind.unit, int(pairs.sum()) * (cells.size // pairs.size))
    _LAST.append(stats)
    del _LAST[:-1]
    if store is not None:
        stats.from_parts, stats.rejected = _resume(store, sources)
        notes = (*notes, *_unused_parts(store, sources, cells))
    earlier = ""
    if archive is not None:
        try:
            stats.from_archive = take_over(sources, archive[0])
            earlier = str(archive[0].attrs.get("history", "")) if stats.from_archive else ""
        finally:
            archive[0].close()
    cut = Cut(cells, batch_size, sources.done())
    bar = Progress(stats.runs, stats.from_parts + stats.from_archive, progress,
                   label=f"urmx {study.name}", unit=kind.unit)
    for line in (*notes, *_notes(cut, stats, store.folder if store else None,
                                  archive[1] if archive else None)):
        bar.note(line)
    batches = (_made(cells, b, records, kernel, sources) for b in cut)
    preparing = _Prepared(kind.prepare, study, records)
    try:
        _compute_all(batches, stats.runs - stats.from_parts - stats.from_archive, records,
                     study.records, scheduler,
                     _saver(cells, sources, bar, stats, preparing.start), kind.run,
                     kind.warm_up)
    except RunError as exc:
        kept = store.count() if store is not None else 0
        if not kept:
            raise
        left = sum(1 for _ in Cut(cells, batch_size, sources.done()))
        raise RunError(f"{exc}; {kept} of {kept + left} batches are kept in "
                       f"{str(store.folder)!r}: run again to resume") from None
    finally:
        bar.close()
    attrs = {**global_attrs(study, started, command), "study_definition": base(study, kind)}
    attrs["history"] = merged_history(attrs["history"], earlier)
    return _assemble(cells, sources, records, attrs, lazy=store is not None,
                     prepared=preparing.result())


class _Prepared:
    """A kind's ``prepare(study, records)``, run in a thread of this process while the
    cells run (its CPU time taken from the workers' slack; started by :meth:`start` when
    the first result arrives: on a cluster it urmx starts, once the workers run, not while
    they start), and its result. The thread is a daemon: a run that fails does not wait
    for it."""

    def __init__(self, prepare: Callable | None, study: Study, records: dict):
        self._prepare, self._args = prepare, (study, records)
        self._value = self._error = self._thread = None

    def _work(self) -> None:
        try:
            self._value = self._prepare(*self._args)
        except BaseException as exc:  # noqa: BLE001 - raised where the result is taken
            self._error = exc

    def start(self) -> None:
        """Start the thread (once; nothing without ``prepare``), in a copy of this thread's
        context (``allow_unusual_walls()`` and the like hold there too)."""
        if self._prepare is not None and self._thread is None:
            self._thread = threading.Thread(target=contextvars.copy_context().run,
                                            args=(self._work,), name="urmx-prepare",
                                            daemon=True)
            self._thread.start()

    def result(self) -> Any:
        """The kind's prepared value (None without ``prepare``; computed here if no result
        started it); its error, raised here."""
        if self._prepare is None:
            return None
        if self._thread is None:
            self._work()
        else:
            self._thread.join()
        if self._error is not None:
            raise self._error
        return self._value


def merged_history(line: str, earlier: str) -> str:
    """An archive's ``history`` (CF convention: one line per run that contributed cells,
    newest first): this run's `line`, then the earlier archive's lines when cells were
    taken over from it (each line once)."""
    lines = [line] + [x for x in earlier.splitlines() if x.strip() and x != line]
    return "\n".join(lines)


def _assemble(cells: Cells, sources: Sources, records: dict, attrs: dict,
              lazy: bool, prepared: Any = None) -> xr.Dataset:
    """The kind's Dataset of every cell's result; with `lazy`, over dask arrays gathered
    from the parts, with ``cell_key`` and netCDF chunks of one slab; `prepared`: what the
    kind's ``prepare`` gave (passed on when it has one)."""
    import xarray as xr


    kind = cells.kind
    missing = sources.missing()
    if missing:
        raise RunError(f"{missing:,} {kind.unit} of study {cells.study.name!r} have no "
                       "result after the run (a bug in urmx): run again")
    arrays = sources.lazy() if lazy else sources.eager()
    more = {"prepared": prepared} if kind.prepare is not None else {}
    ds = kind.assemble(cells.study, records, {n: arrays[n] for n in kind.outputs},
                       sources.extras(), attrs, **more)
    if lazy:
        ds["cell_key"] = xr.Variable(cells.names, arrays["cell_key"],
                                     attrs=variables.attrs("cell_key"))
        for var in ds.variables.values():
            if var.chunks is not None:
                var.encoding["chunksizes"] = tuple(c[0] for c in var.chunks)
    return ds


def run_grid(study: Study, records: dict, scheduler: Any = "serial", *,
             batch_size: int = 16, kernel: Callable | None = None,
             command: str | None = None) -> xr.Dataset:
    """Run a study in memory: the batches, the scheduler and the Dataset assembly of
    :func:`run_study`, without its archive (nothing kept on disk, no resume, no size
    limits) and with the records given rather than resolved from the manifest.

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
        The Dataset :func:`run_study` returns without an archive (in memory).
    """
    if not isinstance(study, Study):
        raise InputError(f"run_grid: study must be a urmx.study.file.Study (urmx.study.file."
                         f"load_study), got {got(study)}")
    if not isinstance(records, dict):
        raise InputError(f"run_grid: records must be a dict of records by id, got "
                         f"{got(records)}")
    _check_batch_size(batch_size)
    return _run(study, records, None, scheduler, False, command, batch_size, kernel)


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


def _earlier_archive(out: Path, study: Study, force: bool, notes: list[str]) -> Any:
    """The archive already at `out`, opened, when it holds the same study, extended or
    shrunk (`urmx.study.definition`: its cells may be reused); None when there is none or
    `force` replaces another one.

    Raises
    ------
    urmx.errors.OutputError
        `out` holds another study (another definition, whatever its name), or is no urmx
        study archive, and `force` is False.
    """
    if not out.exists():
        return None
    import xarray as xr

    kind = kinds.get(study.kind)
    try:
        ds = xr.open_dataset(out, engine="netcdf4")
    except Exception:  # noqa: BLE001 - whatever it is, it is not an archive to reuse
        ds = None
    name = ds.attrs.get("study_name") if ds is not None else None
    verdict = None
    if name is not None:
        verdict = compare(Definition.of_archive(ds, list(kind.cell_dims(study))),
                          Definition.of(study, kind))
    if verdict is not None and verdict.same:
        if "cell_key" not in ds.variables:
            notes.append(f"urmx: {out} holds no cell keys (written by an older urmx): its "
                         "cells are computed again")
        if verdict.dropped:
            notes.append(f"urmx: study {study.name!r} leaves out {verdict.dropped_text()} "
                         f"of the archive {out}: their cells are not kept")
        return ds
    if ds is not None:
        ds.close()
    what = (f"study {name!r} of another definition ({verdict.why})" if verdict is not None
            else "no urmx study archive")
    if not force:
        raise OutputError(f"--out {str(out)!r} holds {what}, not study {study.name!r}: its "
                          "cells would be lost; give another --out, or --force to replace it")
    notes.append(f"urmx: --force: {out} ({what}) is replaced by study {study.name!r}")
    return None


def _claim_parts(parts: Path, study: Study, kind: Any, force: bool,
                 notes: list[str]) -> PartStore:
    """The parts folder of `study`: refused when it holds another study's finished parts
    (another definition, `urmx.study.definition`), or parts of an urmx from before cells
    were keyed (they cannot resume, and whose they are is not said), unless `force`
    removes them."""
    store = PartStore(parts, kind.outputs)
    owner, count = store.owner(), store.count()
    mine = Definition.of(study, kind)
    who = None
    if count and owner is not None:
        verdict = compare(owner, mine)
        if not verdict.same:
            who = f"study {owner.name!r} of another definition ({verdict.why})"
    elif count and store.legacy():
        who = "an older urmx (parts without cell keys, which cannot resume)"
    if who is not None:
        if not force:
            raise RunError(f"{str(parts)!r} holds {count} finished part(s) of {who}, not "
                           f"of study {study.name!r}: finish that study with the same --out, "
                           "give another --out, or --force to discard them")
        notes.append(f"urmx: --force: removed {store.clear()} finished part(s) of {who} "
                     f"from {parts}")
    elif count == 0 and (owner is None or not compare(owner, mine).same):
        store.clear()  # the start time of another study's run that saved nothing
    store.claim(mine)
    return store


def run_study(study: Study | str | os.PathLike, *, out: str | os.PathLike | None = None,
              scheduler: Any = None, progress: bool = True, batch_size: int = 16,
              records_dir: str | os.PathLike | None = None, kernel: Callable | None = None,
              command: str | None = None, force: bool = False,
              max_cells: float | None = MAX_CELLS, max_gb: float | None = MAX_GB
              ) -> xr.Dataset:
    """Run a study of any kind and return one labelled Dataset (and write it to `out`).

    Parameters
    ----------
    study : Study or str or path
        A loaded study, a study file, or the name of a catalog study.
    out : str or path, optional
        netCDF archive to write. Finished batches are kept in ``<out>.parts/`` until the
        archive is written, so an interrupted run resumes where it stopped; an earlier
        archive of the same study (its ``study_name``) lends every cell it holds (module
        docstring). Resolved (symbolic links, ``..``) and checked before any work: a
        folder, a place where a test file cannot be written (no permission, a full disk), a
        name that is not UTF-8, or an input of the run (the study file, a record's file,
        the records manifest) is refused; a second run on the same archive while one is
        running stops with a `urmx.errors.RunError`.
    scheduler : None, "serial", "threads", "processes", address or distributed.Client
        Where batches run (`urmx.study.clients`). Default: the ``distributed.Client``
        already active in this process, else this process for a small study (estimated
        under ``urmx.serial-below`` seconds, :func:`compute`), else local worker
        processes, one per core. A closed or asynchronous Client is an
        `urmx.errors.InputError`.
    progress : bool
        Show progress on stderr (a bar with rate and ETA on a terminal, plain lines in a
        log file), counted in the kind's unit, and say what was reused.
    batch_size : int
        Target number of cells per batch (the kind's unit: analyses for a grid), >= 1. [1]
    records_dir : str or path, optional
        Records folder (default `urmx.config.records_dir`).
    kernel : callable, optional
        Integrator with the signature of `urmx.kernel.run` (default), e.g. a reference solver.
    command : str, optional
        Command line for the ``history`` attribute.
    force : bool
        Replace an `out` that holds another study (or no urmx study), and discard the
        finished parts of another study in its parts folder; without it both stop the run.
    max_cells, max_gb : float or None
        Limits on the study's cells and its archive's (uncompressed) size [GB]
        (`urmx.study.limits`; None: no limit); a larger study stops before any work.

    Returns
    -------
    xarray.Dataset
        The study kind's Dataset (`urmx.study.kinds`): with `out`, the archive reopened
        lazily (`urmx.open_study`), else in memory. Outputs of cells not run or with no
        valid result are NaN (integers: float64 in memory, int32 with _FillValue -1 on disk).

    Raises
    ------
    urmx.UrmxError
        Bad arguments or study file (`urmx.errors.InputError`,
        `urmx.catalog.CatalogError`), a study over the limits
        (`urmx.study.limits.SizeError`), an archive that cannot be written or holds another
        study (`urmx.errors.OutputError`, also for a full disk, saying what is kept),
        another run on the same archive, another study's parts, an unreachable scheduler,
        a cluster that lost a batch for good, a worker that runs other code, no worker left
        for ``urmx.worker-timeout`` seconds or the scheduler gone (`urmx.errors.RunError`).
    """
    refuse_in_worker_import()
    _check_batch_size(batch_size)
    check_scheduler(scheduler)
    s = _study(study)
    check_size(s, kinds.get(s.kind), max_cells, max_gb)
    parts = None
    if out is not None:  # an input never becomes the output
        out, parts = _parts_folder(out, input_files(s, records_dir))
    if parts is None:
        return _run(s, resolve_records(s, records_dir), None, scheduler, progress, command,
                    batch_size, kernel)
    with Lock(parts, out):  # before reading records: a second run stops at once
        _into_archive(s, out, parts, force, records_dir, scheduler, progress, command,
                      batch_size, kernel)

    return open_study(out)


def _study(study: Any) -> Study:
    """A loaded study, a study file or a catalog study name, as a loaded study."""
    if isinstance(study, Study):
        return study
    if not isinstance(study, (str, os.PathLike)):
        raise InputError(f"run_study: study must be a Study, a study file or a catalog study "
                         f"name, got {got(study)}")
    return load_study(study)


def _into_archive(study: Study, out: Path, parts: Path, force: bool, records_dir: Any,
                  *args: Any) -> None:
    """Run `study` into the archive `out` (its lock held): check whose archive and parts
    these are, resolve the records, run (``*args``: scheduler, progress, command,
    batch_size, kernel of `_run`), write, remove the parts. A failure to write a part or
    the archive (a full disk) says how many finished batches are kept and how to go on."""
    try:
        notes: list[str] = []
        earlier = _earlier_archive(out, study, force, notes)
        try:
            store = _claim_parts(parts, study, kinds.get(study.kind), force, notes)
            _remove_stale(out, parts, notes)
            records = resolve_records(study, records_dir)
            try:
                ds = _run(study, records, store, *args,
                          archive=(earlier, str(out)) if earlier is not None else None,
                          notes=tuple(notes))
            except OutputError as exc:  # a full disk while saving parts
                raise _kept(exc, parts, "and run the same command again to resume") \
                    from None
        finally:
            if earlier is not None:
                earlier.close()
    except BaseException:
        if not any(parts.glob("*.npz")):  # nothing to resume from: leave nothing
            shutil.rmtree(parts, ignore_errors=True)
        raise
    try:
        _write(ds, out)
    except OutputError as exc:
        raise _kept(exc, parts, "and run the same command again: the archive is written "
                    "from them, nothing is computed again") from None
    shutil.rmtree(parts, ignore_errors=True)


def _remove_stale(out: Path, parts: Path, notes: list[str]) -> None:
    """Remove the temporary files of this archive and its parts that runs killed while
    writing them left (their PID no longer runs), and say so."""
    gone = netcdf.remove_stale(out.parent, f".{out.name}.", ".tmp")
    gone += netcdf.remove_stale(parts, ".", ".npz.tmp")
    for path, pid in gone:
        notes.append(f"urmx: removed {path}, a temporary file left by a run that was killed "
                     f"while writing it (pid {pid}, no longer running)")


def _write(ds: xr.Dataset, out: Path) -> None:
    """Write the lazy Dataset of a run, slab by slab, in this process (never on a cluster
    that may be the default dask scheduler: its workers need not see the parts), with no
    chunk cache (`CHUNK_CACHE`): each slab is one whole netCDF chunk, written once, so a
    cache only holds memory (netCDF's default is 64 MiB per variable)."""
    import dask
    import netCDF4

    saved = netCDF4.get_chunk_cache()
    netCDF4.set_chunk_cache(CHUNK_CACHE, 61, 1.0)
    try:
        with dask.config.set(scheduler="synchronous"):
            write_netcdf(ds, out)
    finally:
        netCDF4.set_chunk_cache(*saved)


def _kept(exc: OutputError, parts: Path, then: str) -> OutputError:
    """`exc` with how many finished batches `parts` keeps and how to go on (free space
    when the disk is full, else fix the cause)."""
    import errno


    n = PartStore(parts, ()).count()
    if not n:
        return OutputError(f"{exc}; no finished batch is kept")
    full = getattr(exc.__cause__, "errno", None) == errno.ENOSPC or netcdf.disk_full(parts)
    return OutputError(f"{exc}; {n} finished batch{'es' if n > 1 else ''} kept in "
                       f"{str(parts)!r}: {'free space on its disk' if full else 'fix that'} "
                       f"{then}")
