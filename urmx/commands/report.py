"""``urmx report FILE.nc [FILE.nc ...] --out reports/paper/``."""

from __future__ import annotations


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "report", help="figures and REPORT.md (the paper's Figs. 5-10, Table VI, findings)",
        description="Write PNG figures and REPORT.md from study archives (kinds "
                    "paper-single-storey, paper-multi-storey, verification; missing kinds "
                    "are reported as missing).")
    p.add_argument("archives", nargs="+", metavar="FILE.nc", help="study archives")
    p.add_argument("--out", default="reports/paper", metavar="DIR",
                   help="output folder (default: reports/paper)")
    p.set_defaults(handler=run)


def run(args) -> int:
    from urmx.errors import check_output, writing
    from urmx.report import write_report

    check_output(args.out, "--out", folder=True)
    with writing(args.out, "report folder"):
        path = write_report(args.archives, args.out)
    print(path)
    return 0
