"""``urmx uncertainty-report FILE.nc`` (figures and REPORT.md of a sampling-study archive):
a thin command."""

from __future__ import annotations


def register(sub) -> None:
    p = sub.add_parser(
        "uncertainty-report",
        help="figures and REPORT.md of a sampling-study archive -> reports/uncertainty/",
        description="Which sampled parameter matters most (partial rank correlations and "
                    "Sobol' indices), how wide the collapse capacity becomes, the total "
                    "dispersion against the record-to-record one, and whether the impact law "
                    "changes the paper's findings, from an archive written by `urmx run` for a "
                    "study with [study.sampling] (and [study.ida]).")
    p.add_argument("archive", metavar="FILE.nc", help="sampling-study archive")
    p.add_argument("--out", default="reports/uncertainty", metavar="DIR",
                   help="output folder (default: reports/uncertainty)")
    p.set_defaults(handler=_report)


def _report(args) -> int:
    from ..errors import check_output, writing
    from ..uncertainty_report import write_report

    check_output(args.out, "--out", folder=True)
    with writing(args.out, "report folder"):
        print(write_report(args.archive, args.out))
    return 0
