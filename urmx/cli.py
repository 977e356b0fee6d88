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

COMMANDS = ("simulate", "records", "study", "report", "info", "bench", "fragility",
            "risk", "uncertainty", "export", "show", "catalog")


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


class Terminated(KeyboardInterrupt):
    """SIGTERM, raised in the main thread like Ctrl-C's KeyboardInterrupt, so that a
    terminated run cleans up as an interrupted one does (its parts kept)."""


def _terminate(signum, frame) -> None:
    raise Terminated


@contextlib.contextmanager
def _sigterm_stops():
    """While a command runs (in the main thread), SIGTERM raises :class:`Terminated`."""
    if threading.current_thread() is not threading.main_thread():
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
    try:
        with _sigterm_stops():
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
