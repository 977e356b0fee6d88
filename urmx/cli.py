"""The ``urmx`` command line: thin subcommands over the library.

Each subcommand lives in ``urmx/commands/<name>.py`` and exposes ``register(subparsers)``;
registration must stay cheap (heavy imports go inside the handler).

Errors: a :class:`urmx.UrmxError` (bad input, a missing or unwritable file, a run that
cannot proceed) is printed as one line and exits with status 2; Ctrl-C prints one line and
exits with 130; a closed output pipe (``urmx ... | head``) ends quietly with 141 (128 +
SIGPIPE, as a shell reports it); anything else is a bug and shows its traceback.
"""

from __future__ import annotations

import argparse
import importlib
import os
import sys
from pathlib import Path

COMMANDS = ("simulate", "records", "study", "report", "bench", "fragility", "risk")


def build_parser() -> argparse.ArgumentParser:
    from . import __version__

    parser = argparse.ArgumentParser(
        prog="urmx",
        description="Rocking of cracked URM walls between flexible diaphragms.")
    parser.add_argument("--version", action="version", version=f"urmx {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name in COMMANDS:
        importlib.import_module(f"urmx.commands.{name}").register(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    from .errors import MissingFileError, UrmxError

    parser = build_parser()
    args = parser.parse_args(argv)
    if not getattr(args, "handler", None):
        parser.print_help()
        return 2
    try:
        records = getattr(args, "records", None)
        if records is not None and not Path(records).expanduser().is_dir():
            raise MissingFileError(f"--records {records!r}: no such folder")
        return int(args.handler(args) or 0)
    except KeyboardInterrupt:
        note = getattr(args, "interrupt_note", "")
        print(f"urmx {args.command}: interrupted" + (f"; {note}" if note else ""),
              file=sys.stderr)
        return 130
    except UrmxError as exc:  # bad input or a run that cannot proceed: one line
        print(f"urmx {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except BrokenPipeError:  # the reader went away (`urmx simulate ... | head -2`)
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())  # nothing more to flush at exit
        return 141


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
