"""The dask side of a study run: checking the scheduler argument, starting and closing local
clusters quietly, and connecting to a scheduler.

Schedulers: ``None`` starts a local ``dask.distributed`` cluster of worker processes, one per
core (the numba kernel holds the GIL, so processes beat threads); ``"threads"`` the same with
threads; ``"serial"`` runs in this process (`urmx.study.engine`); any other string is a
scheduler address (``tcp://host:8786``); a ``distributed.Client`` is used as it is
(:func:`local_client` starts one on this machine, :func:`close_client` stops it). Ctrl-C
reaches only this process (local workers have SIGINT blocked), which then closes the
cluster.
"""

from __future__ import annotations

import logging
import os
import re
import signal
import threading
from typing import Any

import numpy as np

from ..errors import InputError, RunError

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
        from ..kernel import warm_up

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
    """(client, owned) for a `scheduler` argument of `urmx.run_study`: a Client is used as
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


def record_samples(acceleration: np.ndarray) -> np.ndarray:
    """A record's samples as a dask task: held by one worker and fetched by the others;
    when that worker is lost, the scheduler computes it again from this task (scattered
    data would be lost for good, and every batch waiting on it cancelled)."""
    return acceleration
