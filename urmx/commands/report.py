"""``urmx report FILE.nc [FILE.nc ...] [--out DIR]``: the paper's report of the paper's
archives, and a generic report of any other study archive."""

from __future__ import annotations


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "report", help="figures and REPORT.md: the paper's (Figs. 5-10, Table VI, findings) "
                       "or any study's (tables and a figure per main output)",
        description="Write PNG figures and REPORT.md from study archives. The paper's "
                    "archives (paper-single-storey, paper-multi-storey, verification, "
                    "verification-intensity; missing ones are reported as missing) make the "
                    "paper's report in --out (default reports/paper). Any other archive gets "
                    "a generic report (provenance, cell counts, tables of its outputs over its "
                    "dimensions, a figure per main output): in --out when it is the only "
                    "archive given, else in <--out or reports>/<file name without .nc>.")
    p.add_argument("archives", nargs="+", metavar="FILE.nc", help="study archives")
    p.add_argument("--out", default=None, metavar="DIR",
                   help="output folder (default: reports/paper for the paper's archives, "
                        "reports/<name> for another)")
    p.set_defaults(handler=run)


def run(args) -> int:
    from urmx import generic_report
    from urmx.errors import check_output, writing
    from urmx.report import report_folders, write_report

    if args.out is not None:  # a bad --out is said before any archive is read
        check_output(args.out, "--out", folder=True)
    paper, folder, own = report_folders(args.archives, args.out)
    for where in ([folder] if folder else []) + [where for _, _, where in own]:
        check_output(where, "--out", folder=True)
    if paper:
        with writing(folder, "report folder"):
            print(write_report([ds for _, ds in paper], folder))
    for archive, ds, where in own:
        with writing(where, "report folder"):
            print(generic_report.write_report(ds, where, name=str(archive)))
    return 0
