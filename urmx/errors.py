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
from pathlib import Path


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


def check_output(path: str | os.PathLike, what: str = "--out", *,
                 folder: bool = False) -> Path:
    """Check, before any work, that an output file (or folder) can be written.

    Parameters
    ----------
    path : str or path-like
        The output file (``folder=False``) or folder (``folder=True``).
    what : str
        How the user named it (an option or argument), for the message.
    folder : bool
        Whether `path` is a folder to create or reuse.

    Returns
    -------
    pathlib.Path

    Raises
    ------
    OutputError
        `path` is a folder where a file is wanted (or the reverse), a parent of it is a
        file, or its nearest existing parent folder is not writable.
    """
    p = Path(path).expanduser()
    if folder and p.exists() and not p.is_dir():
        raise OutputError(f"{what} {str(p)!r} is a file, not a folder")
    if not folder and p.is_dir():
        raise OutputError(f"{what} {str(p)!r} is a folder; give a file name")
    base = p if folder else p.parent
    while not base.exists() and base != base.parent:
        base = base.parent
    if not base.is_dir():
        raise OutputError(f"{what} {str(p)!r} cannot be written: {str(base)!r} is a file, "
                          "not a folder")
    if not os.access(base, os.W_OK | os.X_OK):
        raise OutputError(f"{what} {str(p)!r} cannot be written: no permission to write in "
                          f"{str(base)!r}")
    return p


@contextlib.contextmanager
def writing(path: str | os.PathLike, what: str = "output"):
    """Turn an operating-system error while writing a user-named output (disk full, folder
    removed meanwhile) into an :class:`OutputError` naming it."""
    try:
        yield
    except UrmxError:
        raise
    except OSError as exc:
        reason = exc.strerror or str(exc)
        raise OutputError(f"cannot write {what} {str(path)!r}: {reason}") from exc
