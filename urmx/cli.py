"""The ``urmx`` command line: thin subcommands over the library.

Each subcommand lives in ``urmx/commands/<name>.py`` and exposes ``register(subparsers)``;
registration must stay cheap (heavy imports go inside the handler).

Errors: a :class:`urmx.UrmxError` (bad input, a missing or unwritable file, a run that
cannot proceed) is printed as one line and exits with status 2; Ctrl-C prints one line and
exits with 130; SIGTERM (``kill PID``, a batch system ending a job) stops the command the
same way, with its own line (``terminated``) and status 143 (128 + SIGTERM); a closed
output pipe (``urmx ... | head``) ends quietly with 141 (128 +
SIGPIPE, as a shell reports it); anything else is a bug and shows its traceback.
"""

from __future__ import annotations

import argparse
import contextlib
import importlib
import os
import signal
import sys
import threading
from pathlib import Path

from .errors import STOPS as _STOPS  # the Ctrl-C and SIGTERM received while a command runs
from .errors import Terminated

COMMANDS = ("simulate", "records", "study", "report", "info", "bench", "risk", "assess",
            "export", "show", "catalog", "aliases")


class _Version(argparse.Action):
    """``--version``: the code that runs (`urmx.provenance.code_version`: the version with
    the git commit in a checkout), found only when asked."""

    def __init__(self, option_strings, dest=argparse.SUPPRESS, **kw):
        super().__init__(option_strings, dest, nargs=0, default=argparse.SUPPRESS, **kw)

    def __call__(self, parser, namespace, values, option_string=None):
        from .provenance import code_version

        print(f"urmx {code_version()}")
        parser.exit()


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="urmx",
        description="Rocking of cracked URM walls between flexible diaphragms.")
    parser.add_argument("--version", action=_Version,
                        help="show the version (with the git commit in a checkout) and exit")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name in COMMANDS:
        importlib.import_module(f"urmx.commands.{name}").register(sub)
    return parser


def _terminate(signum, frame) -> None:
    raise Terminated


def _again(command: str, out: str | None = None):
    """The handler of Ctrl-C and SIGTERM in the ``urmx`` command: the first raises
    (KeyboardInterrupt, `Terminated`), so the command stops its cluster and says what is
    kept; any further one ends the process at once, its worker processes killed, with one
    line and no traceback (nothing of atexit either)."""
    def handler(signum, frame) -> None:
        _STOPS.append(signum)
        if len(_STOPS) == 1:
            raise Terminated if signum == signal.SIGTERM else KeyboardInterrupt
        _exit_now(command, signum, out)

    return handler


def _quiet_stops(hook):
    """An unraisable-exception hook that drops a stop (KeyboardInterrupt, `Terminated`)
    raised where Python cannot propagate it (a GC callback, a ``__del__``) without a word:
    the run's loops raise it again (`urmx.errors.stop_if_asked`); anything else goes to
    `hook`."""
    def hook_(unraisable) -> None:
        if isinstance(unraisable.exc_value, KeyboardInterrupt):
            return
        hook(unraisable)

    return hook_


def _exit_now(command: str, signum: int, out: str | None = None) -> None:
    """End the process now: kill its worker processes, say so in one line (with the
    finished batches kept for `out`, counted on disk now: only this process writes them,
    and it writes no more), exit with 128 + the signal's number."""
    from .study.clients import end_quietly

    with contextlib.suppress(BaseException):
        end_quietly()
        what = "SIGTERM" if signum == signal.SIGTERM else "Ctrl-C"
        note = ""
        if out is not None:
            from .commands.study import kept_note

            note = kept_note(Path(out))
        sys.stderr.write(f"urmx {command}: {what} again: stopped at once"
                         + (f"; {note}" if note else "") + "\n")
        sys.stderr.flush()
    os._exit(128 + signum)


def _end(code: int) -> None:
    """End the process now with `code` (no atexit: see `main`)."""
    if "urmx.study.clients" in sys.modules:
        with contextlib.suppress(BaseException):
            sys.modules["urmx.study.clients"].end_quietly()
    os._exit(code)


@contextlib.contextmanager
def _sigterm_stops(command: str | None = None, out: str | None = None):
    """While a command runs (in the main thread), SIGTERM raises :class:`Terminated`; in
    the ``urmx`` command itself (`command` given) a second Ctrl-C or SIGTERM ends it at
    once (:func:`_again`)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    if command is not None:  # kept until the process ends: it ends with the command
        sys.unraisablehook = _quiet_stops(sys.unraisablehook)
        signal.signal(signal.SIGTERM, _again(command, out))
        if signal.getsignal(signal.SIGINT) is signal.default_int_handler:
            signal.signal(signal.SIGINT, _again(command, out))
        yield
        return
    previous = signal.signal(signal.SIGTERM, _terminate)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)


def main(argv: list[str] | None = None) -> int:
    from .errors import MissingFileError, UrmxError

    parser = build_parser()
    args = parser.parse_args(argv)
    if not getattr(args, "handler", None):
        parser.print_help()
        return 2
    command = args.command if argv is None else None  # the urmx command itself
    try:
        out = getattr(args, "out", None)
        with _sigterm_stops(command, out if isinstance(out, str) and out.endswith(".nc")
                            else None):
            records = getattr(args, "records", None)
            if records is not None and not Path(records).expanduser().is_dir():
                raise MissingFileError(f"--records {records!r}: no such folder")
            return int(args.handler(args) or 0)
    except KeyboardInterrupt as exc:
        note = getattr(args, "interrupt_note", "")
        what, code = ("terminated", 143) if isinstance(exc, Terminated) else \
            ("interrupted", 130)
        print(f"urmx {args.command}: {what}" + (f"; {note}" if note else ""),
              file=sys.stderr)
        if command is not None:  # its cluster is stopped, its parts saved: nothing is left
            sys.stdout.flush()  # to do, and dask's atexit handlers must not wait or speak
            sys.stderr.flush()
            _end(code)
        return code
    except UrmxError as exc:  # bad input or a run that cannot proceed: one line
        print(f"urmx {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except BrokenPipeError:  # the reader went away (`urmx simulate ... | head -2`)
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())  # nothing more to flush at exit
        return 141


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
