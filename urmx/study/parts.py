"""The part store of a resumable study run: batch keys (the one key function), each finished
batch saved as ``<key>.npz`` in the archive's ``.parts`` folder, loading what a folder holds,
and the lock that keeps a second run off the folder.

A batch's key is a hash of everything that decides its result: its task (walls, record
step and scale factor, the kind's settings), the record's samples (their digest), the
kernel's name, the urmx version and `urmx.jitcache.SOURCE_HASH`, the hash of the compiled
kernel's sources, so a part an older kernel computed is never reused. Each part stores its
key too, so a part copied or renamed from another batch, or cut short, is computed again.
"""

from __future__ import annotations

import datetime as _dt
import hashlib
import json
import os
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import RunError, writing


def kernel_name(kernel: Callable | None) -> str | None:
    """The dotted name of an integrator in a batch key (None: `urmx.kernel.run`)."""
    return None if kernel is None else f"{kernel.__module__}.{kernel.__qualname__}"


def task_key(task: dict[str, Any], record: Any, prefix: str = "", **identity: Any) -> str:
    """The key of a batch: `prefix` and 20 hex digits of the SHA-256 of its task with the
    `identity` entries replacing the task's own (plain values for objects: walls as
    dicts, a kind's name), the record's id and digest, the kernel's name, the urmx version
    and the kernel sources' hash.

    Parameters
    ----------
    task : dict
        The task a worker runs; its ``kernel`` entry (a callable or None) is named.
    record : urmx.records.Record
        The batch's record.
    prefix : str
        Put before the hash (a kind's keys may be told apart by it).
    **identity
        Entries of the task to hash as these values instead.
    """
    from .. import __version__, jitcache

    ident = dict(task, **identity, record=record.id, record_digest=record.digest,
                 kernel=kernel_name(task.get("kernel")), urmx=__version__,
                 kernel_source=jitcache.SOURCE_HASH)
    return prefix + hashlib.sha256(json.dumps(ident, sort_keys=True, default=str).encode()
                                   ).hexdigest()[:20]


class PartStore:
    """The ``.parts`` folder of an archive: finished batches as ``<key>.npz`` and the time
    the run was first started (``started``, so that a resumed run writes the archive of an
    uninterrupted one)."""

    def __init__(self, folder: Path, outputs: tuple[str, ...]):
        self.folder, self.outputs = Path(folder), tuple(outputs)

    def started(self, now: str) -> str:
        """The first run's start time, stamped now (`now`) when the folder has none."""
        stamp = self.folder / "started"
        if stamp.is_file():
            return stamp.read_text().strip()
        with writing(self.folder, "parts folder"):
            stamp.write_text(now + "\n")
        return now

    def save(self, key: str, result: dict[str, np.ndarray]) -> None:
        """Save one batch's arrays as ``<key>.npz`` (written under a temporary name and
        renamed); the key is stored inside too, so a copied or renamed part is recognised."""
        # the temporary name does not end in .npz, so no glob for parts ever counts a part
        # still being written (a SIGINT then deletes it, and the count would go down)
        tmp = self.folder / f".{key}.{os.getpid()}.npz.tmp"
        try:
            with writing(self.folder, "part file in"):
                with open(tmp, "wb") as fh:
                    np.savez(fh, **result, batch_key=np.array(key))
                os.replace(tmp, self.folder / f"{key}.npz")
        finally:  # a full disk leaves no temporary file behind
            if tmp.exists():
                tmp.unlink()

    def load(self, key: str) -> dict[str, np.ndarray] | None:
        """The saved batch `key`, or None when there is none or it is damaged (truncated by
        a full disk or a kill mid-write), lacks one of the kind's `outputs`, or holds another
        batch (copied or renamed): such a batch is computed again. Pickled objects are
        never loaded."""
        path = self.folder / f"{key}.npz"
        return load_part(path, key, self.outputs) if path.is_file() else None

    def resume(self, keys: list[str]) -> tuple[dict[str, dict[str, np.ndarray]], int]:
        """(the saved batches among `keys` by key, the number of part files rejected)."""
        results, rejected = {}, 0
        for key in keys:
            if not (self.folder / f"{key}.npz").is_file():
                continue
            part = self.load(key)
            if part is None:
                rejected += 1
            else:
                results[key] = part
        return results, rejected

    def count(self) -> int:
        """Part files in the folder (any batch)."""
        return len(list(self.folder.glob("*.npz"))) if self.folder.is_dir() else 0


def load_part(path: Path, key: str | None, outputs: tuple[str, ...]
              ) -> dict[str, np.ndarray] | None:
    """A saved batch's arrays, or None when the file is damaged, lacks one of `outputs` or
    holds another batch than `key` (`PartStore.load`)."""
    try:
        with np.load(path, allow_pickle=False) as z:
            out = {k: z[k] for k in z.files}
    except Exception:  # noqa: BLE001 - any unreadable file is recomputed, never trusted
        return None
    stored = out.pop("batch_key", None)
    if key is not None and (stored is None or str(stored) != key):
        return None
    if any(name not in out for name in outputs):
        return None
    return out


class Lock:
    """An exclusive claim on an archive's parts folder: a second run on the same archive
    stops with a clear message instead of repeating the work. The lock is an OS file lock
    (``flock``), released by the system when the process ends however it ends, so a killed
    run leaves no stale lock."""

    def __init__(self, parts: Path, out: Path):
        self.parts, self.out, self.fd = parts, out, None

    def __enter__(self) -> Lock:
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
