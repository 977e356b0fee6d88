"""The errors urmx raises for bad input and runs that cannot proceed.

Every error a user can cause (a bad value, a missing input file, an output that cannot be
written, a study that cannot run) is a :class:`UrmxError` whose message is one line naming
the bad value. The command line prints that line and exits with status 2; any other
exception is a bug in urmx and shows its traceback.

The subclasses keep the built-in type a caller would expect: bad values are also
:class:`ValueError` (``urmx.records.RecordError``, ``urmx.catalog.CatalogError``,
``urmx.analysis.MissingDataError``, :class:`InputError`), missing inputs also
:class:`FileNotFoundError`, unwritable outputs also :class:`OSError`.
"""

from __future__ import annotations

import contextlib
import os
from collections.abc import Iterable
from pathlib import Path
from typing import Any


class UrmxError(Exception):
    """Base class of every error urmx raises for input or a run it cannot accept."""


class InputError(UrmxError, ValueError):
    """An argument or input value is not acceptable; the message names it."""


class MissingFileError(UrmxError, FileNotFoundError):
    """A file or folder named by the user (or by a study or manifest) does not exist."""


class OutputError(UrmxError, OSError):
    """An output cannot be written where it was asked for."""


class RunError(UrmxError, RuntimeError):
    """A run cannot proceed: another run holds the archive, the scheduler cannot be
    reached, or the cluster lost its workers."""


class Terminated(KeyboardInterrupt):
    """SIGTERM, raised in the main thread like Ctrl-C's KeyboardInterrupt, so that a
    terminated run cleans up as an interrupted one does (its parts kept)."""


STOPS: list[int] = []  # the Ctrl-C and SIGTERM the ``urmx`` command received (urmx.cli)


def stop_if_asked() -> None:
    """Raise the stop a Ctrl-C or SIGTERM asked for, again.

    The ``urmx`` command's handler raises the first stop where the signal lands; when that
    is a garbage-collector callback or a ``__del__`` (dask's GC diagnosis, a finalizer),
    Python prints "Exception ignored" and drops it, and the run would go on. The loops that
    wait for a study's batches call this between batches, so a dropped stop still stops
    the run (urmx.cli keeps Python from printing it)."""
    if STOPS:
        import signal

        raise Terminated if STOPS[0] == signal.SIGTERM else KeyboardInterrupt


def check_output(path: str | os.PathLike, what: str = "--out", *, folder: bool = False,
                 inputs: Iterable[tuple[str, str | os.PathLike]] = (),
                 utf8: bool = False) -> Path:
    """Check, before any work, that an output file (or folder) can be written, and return
    it resolved (``~``, symbolic links and ``..`` as the operating system follows them), so
    that the work writes exactly where the check looked.

    Parameters
    ----------
    path : str or path-like
        The output file (``folder=False``) or folder (``folder=True``).
    what : str
        How the user named it (an option or argument), for the message.
    folder : bool
        Whether `path` is a folder to create or reuse.
    inputs : iterable of (str, path)
        The run's input files, each with what it is (``("the study file", path)``): an
        output that is one of them (the same file, by any name) is refused, so an input
        never becomes an output.
    utf8 : bool
        Refuse a name that is not valid UTF-8 (netCDF file names must be).

    Returns
    -------
    pathlib.Path
        The resolved path.

    Raises
    ------
    OutputError
        `path` is a folder where a file is wanted (or the reverse), a parent of it is a
        file, it is one of the `inputs`, its name is not UTF-8 (with `utf8`), or a test
        file cannot be written and removed in its nearest existing folder (no permission,
        a read-only or full disk).
    """
    given = Path(path).expanduser()
    p = Path(os.path.realpath(given))
    if utf8:
        try:
            str(p).encode("utf-8")
        except UnicodeEncodeError:
            raise OutputError(f"{what} {str(given)!r} cannot be written: its name is not "
                              "valid UTF-8 (netCDF file names must be); give another "
                              "name") from None
    if folder and p.exists() and not p.is_dir():
        raise OutputError(f"{what} {str(given)!r} is a file, not a folder")
    if not folder and p.is_dir():
        raise OutputError(f"{what} {str(given)!r} is a folder; give a file name")
    for label, source in inputs:
        if p.exists() and _same_file(p, source):
            raise OutputError(f"{what} {str(given)!r} is {label} {str(source)!r}: an input "
                              "is never overwritten; give another output file")
    base = p if folder else p.parent
    while not base.exists() and base != base.parent:
        base = base.parent
    if not base.is_dir():
        raise OutputError(f"{what} {str(given)!r} cannot be written: {str(base)!r} is a "
                          "file, not a folder")
    _probe(base, f"{what} {str(given)!r}")
    return p


def _same_file(a: Path, b: str | os.PathLike) -> bool:
    try:
        return os.path.samefile(a, b)
    except (OSError, ValueError):
        return False


def _probe(folder: Path, named: str) -> None:
    """Write a small test file in `folder`, flush it to disk and remove it."""
    probe = folder / f".urmx-probe-{os.getpid()}"
    try:
        fd = os.open(probe, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
        try:
            os.write(fd, b"urmx output check\n")
            os.fsync(fd)
        finally:
            os.close(fd)
    except OSError as exc:
        reason = exc.strerror or str(exc)
        raise OutputError(f"{named} cannot be written: a test file in {str(folder)!r} "
                          f"failed: {reason}") from None
    finally:
        with contextlib.suppress(OSError):
            probe.unlink()


@contextlib.contextmanager
def writing(path: str | os.PathLike, what: str = "output"):
    """Turn an operating-system error while writing a user-named output (disk full, folder
    removed meanwhile) into an :class:`OutputError` naming it."""
    try:
        yield
    except UrmxError:
        raise
    except OSError as exc:
        import errno

        reason = exc.strerror or str(exc)
        if exc.errno == errno.EFBIG:
            reason += " (this process's file-size limit, ulimit -f: raise it)"
        raise OutputError(f"cannot write {what} {str(path)!r}: {reason}") from exc


def got(value: Any) -> str:
    """What an argument got, for a message: its repr (cut to 60 characters) and type."""
    text = repr(value)
    if len(text) > 60:
        text = text[:57] + "..."
    return f"{text} ({type(value).__name__})"


def path_argument(function: str, name: str, value: Any) -> None:
    """Refuse an argument that should name a file (a str or path) with an `InputError`
    naming the function, the argument and what it got."""
    if not isinstance(value, (str, os.PathLike)):
        raise InputError(f"{function}: {name} must be a file name (str or path), got "
                         f"{got(value)}")


def numbers_argument(function: str, name: str, value: Any) -> Any:
    """`value` as a float array, or an `InputError` naming the function, the argument and
    what it got (strings are refused even when they would parse: ``'False'`` is not 0)."""
    import numpy as np

    try:
        arr = np.asarray(value)
        if arr.dtype.kind in "USVM" or (arr.dtype.kind == "O" and any(
                isinstance(v, (str, bytes)) for v in arr.ravel())):
            raise TypeError
        return arr.astype(float)
    except (TypeError, ValueError):
        raise InputError(f"{function}: {name} must be numbers (array_like of float), got "
                         f"{got(value)}") from None
