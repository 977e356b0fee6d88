"""The dask side of a study run: checking the scheduler argument, finding the client the user
already has, starting and closing local clusters quietly, checking that every worker runs
this process's code, and watching the cluster while a run waits on it.

Schedulers: ``None`` uses the ``distributed.Client`` already active in this process (a
notebook's, `distributed.default_client`) when there is one, else starts a local
``dask.distributed`` cluster of worker processes, one per core (the numba kernel holds the
GIL, so processes beat threads) unless the study is small enough to run here
(`urmx.study.engine.compute`); ``"processes"`` always starts that local cluster;
``"threads"`` the same with threads; ``"serial"`` runs in this process; any other string
is a scheduler address (``tcp://host:8786``); a ``distributed.Client`` is used as it is
(a closed or asynchronous one is an `urmx.errors.InputError`). :func:`local_client`
starts a cluster on this machine, :func:`close_client` stops it. Ctrl-C reaches only this
process (local workers have SIGINT blocked), which then closes the cluster.

One code per run: when a run connects, every worker reports the urmx version, the kernel
source hash (`urmx.jitcache.SOURCE_HASH`) and the numpy version it runs
(:func:`check_workers`); a worker that differs from this process stops the run before
any work, naming it and both. Every batch result carries the same identity
(:func:`run_stamped`), so a worker that joins later with other code is caught too.

A cluster that dies is said (:class:`Watch`): the scheduler gone, or no worker left for
:func:`worker_timeout` seconds, stops the run with a `urmx.errors.RunError` instead of
waiting forever.

Settings (dask's configuration, so ``dask.config.set`` or the environment set them):
``urmx.worker-timeout`` (seconds a run waits with no worker, default 60; ``urmx run
--worker-timeout``; ``DASK_URMX__WORKER_TIMEOUT``) and ``urmx.serial-below`` (a study
whose estimated time in this process is below it, in seconds, runs here, default 10;
``DASK_URMX__SERIAL_BELOW``).
"""

from __future__ import annotations

import contextlib
import logging
import math
import os
import queue
import re
import signal
import sys
import threading
import time
from collections.abc import Callable
from typing import Any

import numpy as np

from .. import provenance
from ..errors import InputError, RunError

_ADDRESS = re.compile(r"^[a-z][a-z0-9+.-]*://\S+$")


def check_scheduler(scheduler: Any) -> None:
    """Refuse a scheduler argument that is none of the accepted kinds (module docstring).

    Parameters
    ----------
    scheduler : None, str or distributed.Client
        As `urmx.run_study` takes it: None, ``"serial"``, ``"threads"``, ``"processes"``, a
        scheduler address or a Client.
    """
    if scheduler is None:
        return
    if hasattr(scheduler, "submit"):
        _usable(scheduler)
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


#: why a script must guard its call of run_study when the study starts a local cluster
UNGUARDED = ("a script that calls urmx.run_study must call it under "
             "`if __name__ == \"__main__\":` (the local cluster's worker processes import "
             "the script again, and each would start the study)")


def refuse_in_worker_import() -> None:
    """Stop a worker process that is importing the user's script (``__mp_main__``, how
    dask's worker processes start) and reaches ``run_study`` at the script's top level:
    with one line, not a second run of the study that fails on the archive's lock."""
    # while multiprocessing's spawn runs the script as ``__mp_main__``, ``__main__`` is
    # still the process's bootstrap module; afterwards both names are the script
    importing = sys.modules.get("__mp_main__")
    if importing is not None and sys.modules.get("__main__") is not importing:
        raise SystemExit(f"urmx: a worker process reached run_study while importing the "
                         f"script: {UNGUARDED}")


def local_client(n_workers: int | None = None, threads: bool = False,
                 warm_up: Callable[[], None] | None = None):
    """A ``distributed.Client`` on a new local cluster.

    Parameters
    ----------
    n_workers : int, optional
        Worker processes of one thread each (default: one per core). The kernel holds
        the GIL, so processes beat threads.
    threads : bool
        One worker in this process with `n_workers` threads instead.
    warm_up : callable, optional
        Called before the worker processes start: a study kind's ``warm_up`` compiles its
        integrator (or loads it from the cache) here first, so the workers load its native
        code from the cache.

    Returns
    -------
    distributed.Client
        Close it with :func:`close_client`, which also stops the cluster.
    """
    from distributed import Client, LocalCluster

    n = n_workers or os.cpu_count() or 1
    if not threads and warm_up is not None:
        warm_up()  # compiled once here: the worker processes load it from the cache
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
    except BaseException as err:
        if block:
            signal.pthread_sigmask(signal.SIG_SETMASK, mask)
        if client is not None:
            close_client(client)
        elif cluster is not None:
            cluster.close()
        if isinstance(err, Exception) and not threads:
            raise RunError(f"the local dask cluster did not start ({type(err).__name__}: "
                           f"{err}); {UNGUARDED}") from err
        raise
    return client


def active_client() -> Any:
    """The ``distributed.Client`` already active in this process (a notebook's), or None
    (distributed is not imported unless something here already did)."""
    if "distributed" not in sys.modules:
        return None
    from distributed import default_client

    try:
        client = default_client()
    except ValueError:
        return None
    return client if client.status == "running" and not client.asynchronous else None


def _usable(client: Any) -> Any:
    """`client` if a study run can use it, else an `urmx.errors.InputError`."""
    status = getattr(client, "status", "running")
    if status != "running":
        raise InputError(f"scheduler: the distributed.Client given is not running (status "
                         f"{status!r}: closed, or its scheduler lost); give an open Client, "
                         "an address or None")
    if getattr(client, "asynchronous", False):
        raise InputError("scheduler: the distributed.Client given is asynchronous; a study "
                         "run needs a synchronous Client (Client(..., asynchronous=False))")
    return client


@contextlib.contextmanager
def owning(client: Any, owned: bool):
    """Hold `client` (as :func:`get_client` gives it) for a run or several: one urmx
    started (`owned`) is stopped within bounds on Ctrl-C or SIGTERM (:func:`stop_now`),
    else closed when the runs end; any other is left as it is."""
    try:
        yield client
    except KeyboardInterrupt:
        if owned:
            owned = False
            stop_now(client)
        raise
    finally:
        if owned:
            close_client(client)


def get_client(scheduler: Any, warm_up: Callable[[], None] | None = None
               ) -> tuple[Any, bool]:
    """(client, owned) for a `scheduler` argument of `urmx.run_study`: a Client is used as
    it is, and so is the active client for None (owned False); None (without an active
    client) or "processes" start local worker processes, "threads" a threaded local
    worker, any other string connects to that scheduler address (owned True: the caller
    closes it with :func:`close_client`).

    Parameters
    ----------
    scheduler : None, str or distributed.Client
        As `urmx.run_study` takes it (but ``"serial"``, which needs no client).
    warm_up : callable, optional
        A study kind's warm-up (loads or compiles its integrator), called before the worker
        processes of a local cluster start (they load it from the cache).

    Raises
    ------
    urmx.errors.InputError
        `scheduler` is none of these, or a closed or asynchronous Client.
    urmx.errors.RunError
        The scheduler address cannot be reached.
    """
    check_scheduler(scheduler)
    if scheduler is None and active_client() is not None:
        return active_client(), False
    from distributed import Client

    if not isinstance(scheduler, (str, type(None))):
        if not isinstance(scheduler, Client):
            raise InputError(f"scheduler: {type(scheduler).__name__} is not a "
                             "distributed.Client")
        return _usable(scheduler), False
    if scheduler in (None, "processes", "threads"):
        return local_client(threads=scheduler == "threads", warm_up=warm_up), True
    previous = logging.root.manager.disable
    logging.disable(logging.CRITICAL)  # a refused connection is said once, below
    try:
        return Client(scheduler), True
    except (OSError, TimeoutError) as exc:
        raise RunError(f"cannot reach the dask scheduler {scheduler!r}: {exc}") from None
    finally:
        logging.disable(previous)


# ---- settings -----------------------------------------------------------------------------

#: the settings of study runs in dask's configuration (``urmx.<name>``): their defaults
#: and whether 0 is allowed
SETTINGS = {"worker-timeout": (60.0, False), "serial-below": (10.0, True)}


def setting(name: str) -> float:
    """A study-run setting from dask's configuration ``urmx.<name>`` (:data:`SETTINGS`
    holds the defaults), checked: a finite number of seconds, > 0 (>= 0 where 0 is
    allowed)."""
    import dask.config

    default, zero = SETTINGS[name]
    value = dask.config.get(f"urmx.{name}", default)
    try:
        number = float(value)
    except (TypeError, ValueError):
        number = math.nan
    if not (math.isfinite(number) and (number >= 0.0 if zero else number > 0.0)):
        raise InputError(f"urmx.{name}={value!r} (dask config) must be a number of seconds "
                         + (">= 0" if zero else "> 0"))
    return number


def worker_timeout() -> float:
    """Seconds a run waits while its cluster has no worker (``urmx.worker-timeout``,
    default 60) before it stops. [s]"""
    return setting("worker-timeout")


# ---- one code per run ----------------------------------------------------------------------

def _identity_probe():
    """The function each worker runs to report the code it runs (its identity). It is
    made here, inside a function, so that it travels by value: a worker whose urmx has no
    `urmx.provenance` (an older one) answers too."""
    def urmx_identity() -> dict:
        try:
            from urmx.provenance import identity

            return dict(identity())
        except Exception:  # noqa: BLE001 - an older or broken urmx is reported, not raised
            pass
        try:
            import numpy

            import urmx.jitcache  # binds urmx (an older urmx may lack urmx.provenance)

            return {"urmx": getattr(urmx, "__version__", "?"), "numpy": numpy.__version__,
                    "kernel_source": getattr(urmx.jitcache, "SOURCE_HASH", "?")}
        except Exception as exc:  # noqa: BLE001
            return {"urmx": f"none importable ({type(exc).__name__}: {exc})"}

    return urmx_identity


def mismatch(worker: str, theirs: dict, when: str) -> RunError:
    """The error for a worker that runs other code than this process."""
    here = provenance.describe(provenance.identity())
    return RunError(f"worker {worker} runs other code than this process "
                    f"({provenance.describe(theirs)} there; {here} here): {when}; give workers "
                    "the same urmx and numpy")


def check_workers(client: Any, timeout: float) -> int:
    """Wait (up to `timeout` seconds) for a worker, then check that every worker runs this
    process's code (:func:`urmx.provenance.differs`); returns the number of workers.

    Raises
    ------
    urmx.errors.RunError
        No worker within `timeout`, a worker with other code (named, with both
        identities), or a scheduler that cannot be asked.
    """
    address = scheduler_address(client)
    try:
        client.wait_for_workers(1, timeout=timeout)
    except TimeoutError:
        raise RunError(f"no dask worker joined the scheduler {address} within {timeout:g} s "
                       "(urmx.worker-timeout; --worker-timeout): start workers, then run "
                       "again") from None
    except OSError as exc:
        raise RunError(f"the dask scheduler {address} went away: {exc}") from None
    try:
        answers = client.run(_identity_probe(), on_error="return")
    except OSError as exc:
        raise RunError(f"the dask scheduler {address} went away: {exc}") from None
    for worker, theirs in sorted(answers.items()):
        if isinstance(theirs, OSError):  # a worker gone meanwhile runs nothing
            continue
        if isinstance(theirs, BaseException):
            theirs = {"urmx": f"unknown ({type(theirs).__name__}: {theirs})"}
        if provenance.differs(theirs):
            raise mismatch(worker, theirs, "nothing was computed")
    return len(answers)


def run_stamped(runner: Callable[[dict, np.ndarray], dict], task: dict,
                acceleration: np.ndarray) -> dict[str, Any]:
    """Run one batch on a worker (`runner`, a kind's ``run``) and return its result with
    the identity of the code that computed it and the worker's address."""
    try:
        from distributed import get_worker

        where = get_worker().address
    except (ImportError, ValueError):
        where = "this process"
    return {"result": runner(task, acceleration), "identity": provenance.identity(),
            "worker": where}


# ---- a cluster that dies -------------------------------------------------------------------

def scheduler_address(client: Any) -> str:
    """The address of `client`'s scheduler (for messages)."""
    return str(getattr(getattr(client, "scheduler", None), "address", None) or "(unknown)")


class Watch:
    """Checks, at most once a `period` seconds, that a run's cluster is alive: its client
    connected to the scheduler, and some worker there within `timeout` seconds."""

    def __init__(self, client: Any, timeout: float, period: float = 1.0):
        self.client, self.timeout, self.period = client, timeout, period
        self.address = scheduler_address(client)
        self.alone_since: float | None = None
        self.next_check = 0.0

    def gone(self) -> RunError:
        return RunError(f"the dask scheduler {self.address} went away (connection lost)")

    def check(self, now: bool = False) -> None:
        """Raise a `urmx.errors.RunError` when the scheduler is gone or no worker has been
        left for `timeout` seconds (checked now with ``now=True``)."""
        t = time.monotonic()
        if not now and t < self.next_check:
            return
        self.next_check = t + self.period
        if self.client.status != "running":
            raise self.gone()
        try:
            workers = _worker_count(self.client)
        except (OSError, TimeoutError):
            raise self.gone() from None
        if workers:
            self.alone_since = None
        elif self.alone_since is None:
            self.alone_since = t
        elif t - self.alone_since >= self.timeout:
            raise RunError(f"no dask worker left on the scheduler {self.address} for "
                           f"{self.timeout:g} s (urmx.worker-timeout; --worker-timeout)")


#: the loggers of this process's side of a dask cluster (levels set by dask's config)
CLIENT_LOGGERS = ("distributed", "distributed.client", "distributed.batched",
                  "distributed.core", "distributed.comm")


@contextlib.contextmanager
def quiet_client():
    """While a run uses its cluster, this process's dask messages below ERROR stay unsaid
    (``Couldn't gather 1 keys, rescheduling`` when a worker holding results dies, ``Batched
    Comm Closed`` with a traceback when the scheduler goes): the run says what happened to
    the cluster itself (a lost worker is survived; no worker left, or the scheduler gone,
    is its one-line error)."""
    logs = [logging.getLogger(name) for name in CLIENT_LOGGERS]
    levels = [log.level for log in logs]
    for log in logs:
        log.setLevel(max(log.getEffectiveLevel(), logging.ERROR))
    try:
        yield
    finally:
        for log, level in zip(logs, levels, strict=True):
            log.setLevel(level)


def fetch_all(futures: list) -> queue.Queue:
    """Fetch the results of `futures` in their client's event loop as they finish: a
    queue of ``(future, outcome)``, the outcome being the result or the exception that
    fetching it raised (the task's error, a cancellation, a lost connection). Nothing is
    raised or logged in the loop, and the caller waits on the queue with its own timeout:
    a fetch that never ends (a result whose worker died, rescheduled on a cluster left
    with no worker) blocks nobody."""
    arrived: queue.Queue = queue.Queue()

    async def fetch(future) -> None:
        try:
            outcome = await future
        except BaseException as exc:  # noqa: BLE001 - handed to the caller, never lost
            outcome = exc
        arrived.put((future, outcome))

    if futures:
        loop = futures[0].client.loop
        for future in futures:
            loop.add_callback(fetch, future)
    return arrived


def _worker_count(client: Any, timeout: float = 10.0) -> int:
    """The number of workers `client`'s scheduler has, asked now (an `OSError` or
    `TimeoutError` when it cannot answer within `timeout` seconds: the client's
    ``scheduler_info`` would return its last answer instead)."""
    try:
        info = client.sync(client.scheduler.identity, n_workers=0, callback_timeout=timeout)
    except TypeError:  # distributed before 2025: no n_workers argument
        info = client.sync(client.scheduler.identity, callback_timeout=timeout)
    return int(info.get("n_workers", len(info.get("workers", {}))))


def release(client: Any, owned: bool, pending: list) -> None:
    """After a run: close a client urmx started (and its local cluster); on the user's
    client, cancel the run's unfinished batches. Quietly, and without waiting on a
    scheduler that is gone."""
    if owned:
        close_client(client)
        return
    if not pending or client.status != "running":
        return
    previous = logging.root.manager.disable
    logging.disable(logging.CRITICAL)
    try:
        client.cancel(pending)
    except (OSError, TimeoutError):
        pass
    finally:
        logging.disable(previous)


def close_client(client: Any) -> None:
    """Close a client and the local cluster it started, if any (quietly: workers stopped on
    purpose are not errors, and a scheduler closed while results are still on their way
    would log each one).

    Parameters
    ----------
    client : distributed.Client
        The client (from :func:`get_client`, owned).
    """
    cluster = getattr(client, "cluster", None)
    previous = logging.root.manager.disable
    logging.disable(logging.CRITICAL)
    try:
        client.close()
        if cluster is not None:
            cluster.close()
    finally:
        logging.disable(previous)


#: seconds a run stopped by Ctrl-C or SIGTERM gives the cluster it started to close, before
#: it kills the worker processes still alive
STOP_TIMEOUT = 10.0


def stop_now(client: Any, timeout: float = STOP_TIMEOUT) -> None:
    """After Ctrl-C or SIGTERM: close `client` and the local cluster it started within
    `timeout` seconds, saying nothing (dask's messages stay off for the rest of the
    process: closed comms and futures scheduled after shutdown are no news to someone who
    stopped the run); the worker processes still alive then, or when a further Ctrl-C
    comes meanwhile, are killed."""
    import multiprocessing

    logging.disable(logging.CRITICAL)  # for good: the process is ending
    workers = multiprocessing.active_children()
    done = threading.Event()

    def close() -> None:
        try:
            client.close(timeout=timeout)
            cluster = getattr(client, "cluster", None)
            if cluster is not None:
                cluster.close(timeout=timeout)
        except BaseException:  # noqa: BLE001,S110 - whatever it says, the workers go below
            pass
        finally:
            done.set()

    threading.Thread(target=close, name="urmx-stop", daemon=True).start()
    try:
        done.wait(timeout)
    finally:  # a further Ctrl-C while waiting: kill at once
        kill_workers(workers)


def kill_workers(workers: list | None = None) -> None:
    """Kill (SIGKILL) the worker processes this process started that are still alive
    (default: every child of `multiprocessing`); they hold no result that is not saved."""
    import multiprocessing

    for proc in workers if workers is not None else multiprocessing.active_children():
        with contextlib.suppress(Exception):
            if proc.is_alive():
                proc.kill()


def end_quietly() -> None:
    """Before the process ends at once (``os._exit``): kill its worker processes and
    multiprocessing's resource tracker, which would otherwise print a warning about the
    semaphores of the killed workers after urmx's last line."""
    kill_workers()
    with contextlib.suppress(Exception):
        from multiprocessing import resource_tracker

        pid = getattr(resource_tracker._resource_tracker, "_pid", None)
        if pid:
            os.kill(pid, signal.SIGKILL)


def record_samples(acceleration: np.ndarray) -> np.ndarray:
    """A record's samples as a dask task: held by one worker and fetched by the others;
    when that worker is lost, the scheduler computes it again from this task (scattered
    data would be lost for good, and every batch waiting on it cancelled)."""
    return acceleration
