"""``python -m benchmarks [NAME ...] [--quick] [--out FILE] ...``: the same as ``urmx bench``."""

from __future__ import annotations

import argparse
import sys

import benchmarks
from urmx.commands.bench import add_arguments, run


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks",
                                     description=benchmarks.__doc__.splitlines()[0])
    add_arguments(parser)
    args = parser.parse_args(argv)
    try:
        return run(args, suite=benchmarks)
    except ValueError as exc:
        parser.error(str(exc))


if __name__ == "__main__":
    sys.exit(main())
