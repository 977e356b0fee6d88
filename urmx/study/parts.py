"""The part store of a resumable study run: each finished batch saved as ``<key>.npz`` in the
archive's ``.parts`` folder with its cells' keys beside their results, reading what a folder
holds, the study that owns the folder, and the lock that keeps a second run off it.

A part holds the kind's outputs of its cells (block-shaped as the kind's ``run`` returned
them, or one axis of cells for parts taken over from an archive), ``cell_key`` (the cells'
keys, `urmx.study.cells`, in the same shape) and ``batch_key``, the name it was saved under
(:func:`batch_key`: a hash of its cells' keys). Finished work is found per cell by those keys,
so a part is reused whatever cut made it; a part copied or renamed from another batch (its
stored key is not its name), cut short, or lacking an output or its keys, is computed again.
Pickled objects are never loaded. Parts written by urmx before cells were keyed (no
``cell_key``, no ``study`` file in the folder) cannot be resumed.
"""

from __future__ import annotations

import ast
import datetime as _dt
import hashlib
import json
import os
import zipfile
from collections.abc import Callable, Iterator
from pathlib import Path

import numpy as np

from ..errors import RunError, writing
from .definition import Definition


def kernel_name(kernel: Callable | None) -> str | None:
    """The dotted name of an integrator in the cells' keys (None: `urmx.kernel.run`)."""
    return None if kernel is None else f"{kernel.__module__}.{kernel.__qualname__}"


def batch_key(prefix: str, cells: np.ndarray) -> str:
    """The key of a batch: `prefix` and 20 hex digits of the SHA-256 of its cells' keys (in
    block order), so a batch's key changes with anything that decides any of its cells."""
    data = np.ascontiguousarray(cells, dtype="<u8").tobytes()
    return prefix + hashlib.sha256(data).hexdigest()[:20]


class PartStore:
    """The ``.parts`` folder of an archive: finished batches as ``<key>.npz``, the time the
    run was first started (``started``, so that a resumed run writes the archive of an
    uninterrupted one) and the name of the study that owns it (``study``)."""

    def __init__(self, folder: Path, outputs: tuple[str, ...]):
        self.folder, self.outputs = Path(folder), tuple(outputs)

    def started(self, now: str) -> str:
        """The first run's start time, stamped now (`now`) when the folder has none.

        Parameters
        ----------
        now : str
            The time now (ISO 8601).
        """
        stamp = self.folder / "started"
        if stamp.is_file():
            return stamp.read_text().strip()
        with writing(self.folder, "parts folder"):
            stamp.write_text(now + "\n")
        return now

    def owner(self) -> Definition | None:
        """The definition of the study whose parts the folder holds (None: not said; only
        a name: written by an older urmx)."""
        stamp = self.folder / "study"
        if not stamp.is_file():
            return None
        text = stamp.read_text(encoding="utf-8").strip()
        try:
            return Definition.from_json(text)
        except (ValueError, AttributeError):
            return Definition(text, None)

    def claim(self, study: Definition) -> None:
        """Say that the folder holds the parts of the study of definition `study`.

        Parameters
        ----------
        study : urmx.study.definition.Definition
            The study's definition.
        """
        with writing(self.folder, "parts folder"):
            (self.folder / "study").write_text(study.to_json() + "\n", encoding="utf-8")

    def code(self, now: dict | None = None) -> dict | None:
        """The code (kernel, its source hash, urmx version) the folder's parts were last
        computed by; with `now`, say that they are computed by `now` from here on.

        Parameters
        ----------
        now : dict, optional
            This run's code (kernel, source hash, urmx version).
        """
        stamp = self.folder / "code"
        try:
            before = json.loads(stamp.read_text(encoding="utf-8"))
        except (OSError, ValueError):
            before = None
        if now is not None and now != before:
            with writing(self.folder, "parts folder"):
                stamp.write_text(json.dumps(now) + "\n", encoding="utf-8")
        return before

    def save(self, key: str, result: dict[str, np.ndarray], cells: np.ndarray) -> Path:
        """Save one batch's arrays and its cells' keys as ``<key>.npz`` (written under a
        temporary name and renamed); its key is stored inside too, so a copied or renamed
        part is recognised.

        Parameters
        ----------
        key : str
            The batch's key.
        result : dict of str to ndarray
            The batch's output arrays.
        cells : ndarray of uint64
            Its cells' keys.
        """
        # the temporary name does not end in .npz, so no glob for parts ever counts a part
        # still being written (a SIGINT then deletes it, and the count would go down)
        tmp = self.folder / f".{key}.{os.getpid()}.npz.tmp"
        path = self.folder / f"{key}.npz"
        try:
            with writing(self.folder, "part file in"):
                with open(tmp, "wb") as fh:
                    np.savez(fh, **result, batch_key=np.array(key),
                             cell_key=np.asarray(cells, dtype=np.uint64))
                os.replace(tmp, path)
        finally:  # a full disk leaves no temporary file behind
            if tmp.exists():
                tmp.unlink()
        return path

    def load(self, key: str) -> dict[str, np.ndarray] | None:
        """The saved batch `key`, or None when there is none or it is damaged (truncated by
        a full disk or a kill mid-write), lacks one of the kind's `outputs` or its cells'
        keys, or holds another batch (copied or renamed): such a batch is computed again.

        Parameters
        ----------
        key : str
            The batch's key.
        """
        path = self.folder / f"{key}.npz"
        return load_part(path, key, self.outputs) if path.is_file() else None

    def files(self) -> list[Path]:
        """The part files in the folder (any batch), sorted."""
        return sorted(self.folder.glob("*.npz")) if self.folder.is_dir() else []

    def scan(self) -> Iterator[tuple[Path, dict[str, np.ndarray] | None]]:
        """Every part file with its arrays (None: damaged or foreign, `load`)."""
        for path in self.files():
            yield path, load_part(path, path.stem, self.outputs)

    def count(self) -> int:
        """Part files in the folder (any batch)."""
        return len(self.files())

    def legacy(self) -> int:
        """Part files written by urmx before cells were keyed (no ``cell_key``)."""
        n = 0
        for path in self.files():
            try:
                with zipfile.ZipFile(path) as z:
                    n += "cell_key.npy" not in z.namelist()
            except (OSError, zipfile.BadZipFile):
                continue  # damaged: recomputed like any damaged part
        return n

    def clear(self) -> int:
        """Remove every part file (and the stamps); the number of parts removed."""
        files = self.files()
        for path in [*files, self.folder / "study", self.folder / "started",
                     self.folder / "code"]:
            path.unlink(missing_ok=True)
        return len(files)


def load_part(path: Path, key: str | None, outputs: tuple[str, ...]
              ) -> dict[str, np.ndarray] | None:
    """A saved batch's arrays, or None when the file is damaged, lacks one of `outputs` or
    its cells' keys (or their shapes disagree), or holds another batch than `key`
    (`PartStore.load`)."""
    try:
        out = read_npz(path)
    except Exception:  # noqa: BLE001 - any unreadable file is recomputed, never trusted
        return None
    stored = out.pop("batch_key", None)
    if key is not None and (stored is None or str(stored) != key):
        return None
    cells = out.get("cell_key")
    if cells is None or cells.dtype != np.uint64 or any(name not in out for name in outputs):
        return None
    if any(out[name].shape[:cells.ndim] != cells.shape for name in outputs):
        return None
    return out


_HEADERS: dict[bytes, tuple] = {}  # .npy headers already parsed -> (dtype, shape, order)


def _array(raw: bytes) -> np.ndarray:
    """One ``.npy`` member's array (read-only, over `raw`); pickled objects are refused."""
    if raw[:6] != b"\x93NUMPY" or raw[6] not in (1, 2, 3):
        raise ValueError("not a .npy array")
    start = 10 if raw[6] == 1 else 12
    end = start + int.from_bytes(raw[8:start], "little")
    header = raw[start:end]
    meta = _HEADERS.get(header)
    if meta is None:
        d = ast.literal_eval(header.decode("latin1"))
        dtype = np.lib.format.descr_to_dtype(d["descr"])
        if dtype.hasobject:
            raise ValueError("an array of Python objects")
        if len(_HEADERS) > 4096:
            _HEADERS.clear()
        meta = _HEADERS[header] = (dtype, tuple(d["shape"]), "F" if d["fortran_order"] else "C")
    dtype, shape, order = meta
    count = int(np.prod(shape, dtype=np.int64))
    return np.frombuffer(raw, dtype=dtype, count=count, offset=end).reshape(shape, order=order)


def read_npz(path: Path) -> dict[str, np.ndarray]:
    """The arrays of an ``.npz`` file written by `numpy.savez`, as `numpy.load` gives them
    (each member's checksum checked; no pickles), parsing each distinct ``.npy`` header
    once: a part's twenty small arrays read about ten times faster."""
    with zipfile.ZipFile(path) as z:
        return {name[:-4]: _array(z.read(name)) for name in z.namelist()
                if name.endswith(".npy")}


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
