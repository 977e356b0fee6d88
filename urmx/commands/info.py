"""``urmx info ARCHIVE`` (what an archive holds and how it was made) and ``urmx diff A B``
(what differs between two archives, exit 0 / 1 / 2 like ``diff``): thin commands over
`urmx.study.summary`."""

from __future__ import annotations

import json


def register(sub) -> None:
    p = sub.add_parser(
        "info", help="an archive's kind, dimensions, cell counts and provenance",
        description="Print an archive's kind, file size, dimensions and their sizes, how many "
                    "cells ended in each way (a grid: ok, collapsed, event-limit, not-run; an "
                    "IDA study: collapsed, censored, missing), its variables, every global "
                    "attribute (urmx version, command, study definition, ...) and the items' "
                    "properties along each dimension (walls, diaphragms, records).")
    p.add_argument("archive", metavar="ARCHIVE", help="netCDF archive (urmx run, ida, simulate)")
    p.add_argument("--json", action="store_true", help="print the same as JSON")
    p.set_defaults(handler=_info)

    p = sub.add_parser(
        "diff", help="what differs between two archives (exit 0: nothing, 1: some, 2: error)",
        description="List the dimensions, coordinates and variables in which two archives "
                    "differ, and the cells whose values differ by more than atol + rtol * |B| "
                    "(NaN equals NaN), over the labels both have. Global attributes (the time, "
                    "the command, the urmx version) are listed but not counted. Exit status: 0 "
                    "no differences, 1 differences, 2 an error (as diff).")
    p.add_argument("a", metavar="A", help="netCDF archive")
    p.add_argument("b", metavar="B", help="netCDF archive to compare it with")
    p.add_argument("--rtol", type=float, default=1e-9,
                   help="relative tolerance (default 1e-9)")
    p.add_argument("--atol", type=float, default=0.0,
                   help="absolute tolerance, in each variable's units (default 0)")
    p.add_argument("--json", action="store_true", help="print the same as JSON")
    p.set_defaults(handler=_diff)


def _info(args) -> int:
    from ..study.summary import format_info, info

    found = info(args.archive)
    print(json.dumps(found, indent=1, default=str) if args.json else format_info(found))
    return 0


def _diff(args) -> int:
    from ..study.summary import diff, format_diff

    found = diff(args.a, args.b, rtol=args.rtol, atol=args.atol)
    print(json.dumps(found, indent=1, default=str) if args.json else format_diff(found))
    return 1 if found["differ"] else 0
