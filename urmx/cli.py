"""The ``urmx`` command line: thin subcommands over the library.

Each subcommand lives in ``urmx/commands/<name>.py`` and exposes ``register(subparsers)``;
registration must stay cheap (heavy imports go inside the handler).
"""

from __future__ import annotations

import argparse
import importlib
import sys

COMMANDS = ("simulate", "records", "study", "report", "bench", "fragility")


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
    parser = build_parser()
    args = parser.parse_args(argv)
    if not getattr(args, "handler", None):
        parser.print_help()
        return 2
    try:
        return int(args.handler(args) or 0)
    except KeyboardInterrupt:
        print("urmx: interrupted", file=sys.stderr)
        return 130
    except (ValueError, FileNotFoundError, KeyError, OSError) as exc:
        # user-facing errors: one clear line, never a traceback
        msg = exc.args[0] if isinstance(exc, KeyError) and exc.args else exc
        print(f"urmx {args.command}: error: {msg}", file=sys.stderr)
        return 2


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
