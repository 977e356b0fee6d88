"""``urmx catalog list`` (the catalog's walls, diaphragms, examples and studies by name) and
``urmx catalog copy NAME [DEST]`` (an example or study copied to edit): thin commands over
`urmx.catalog`."""

from __future__ import annotations


def register(sub) -> None:
    p = sub.add_parser(
        "catalog", help="the catalog by name: list it, copy an example or study to edit",
        description="The catalog urmx carries (also in an installed wheel): its walls, "
                    "diaphragms, example wall files and study files. An example's name "
                    "stands for a wall file (`urmx simulate benchmark-wall elcentro`), a "
                    "study's for a study file (`urmx run verification --out v.nc`).")
    actions = p.add_subparsers(dest="action", metavar="ACTION")
    q = actions.add_parser("list", help="list the walls, diaphragms, examples and studies")
    q.add_argument("--json", action="store_true", help="print the same as JSON")
    q.set_defaults(handler=_list)
    q = actions.add_parser("copy", help="copy an example or a study to edit",
                           description="Copy the catalog's example wall file or study file "
                                       "NAME into DEST (a folder or a file name; default "
                                       "NAME.toml here). An existing file is never "
                                       "overwritten.")
    q.add_argument("name", metavar="NAME", help="an example or study name (urmx catalog list)")
    q.add_argument("dest", metavar="DEST", nargs="?", default=None,
                   help="folder or file to copy to (default: ./NAME.toml)")
    q.set_defaults(handler=_copy)
    p.set_defaults(handler=lambda args: p.print_help() or 2)


def _list(args) -> int:
    import json

    from ..catalog import catalog_entries

    found = catalog_entries()
    if args.json:
        print(json.dumps(found, indent=1))
        return 0
    for section, rows in found.items():
        print(f"{section}:")
        width = max((len(n) for n, _ in rows), default=0)
        for name, what in rows:
            print(f"  {name:<{width}s}  {what}".rstrip())
    return 0


def _copy(args) -> int:
    from ..catalog import copy_entry
    from ..errors import writing

    with writing(args.dest or f"{args.name}.toml", "copy"):
        print(copy_entry(args.name, args.dest))
    return 0
