"""``urmx report FILE.nc [FILE.nc ...] [--out DIR]``: each archive's report, chosen by its
study kind (`urmx.reports.REPORTS`), and the paper's report of the paper's archives."""

from __future__ import annotations


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "report", help="figures and REPORT.md of study archives, by their kind: the paper's "
                       "(Figs. 5-10, Table VI, findings), an IDA's, a sampling study's or any "
                       "other study's (tables and a figure per main output)",
        description="Write PNG figures and REPORT.md from study archives. The paper's "
                    "archives (paper-single-storey, paper-multi-storey, verification, "
                    "verification-intensity; missing ones are reported as missing) make the "
                    "paper's report in --out (default reports/paper). Any other archive gets "
                    "the report of its study kind (an IDA's fragility, measures and risk; a "
                    "sampling study's sensitivity and spread; any other: provenance, cell "
                    "counts, tables of its outputs over its dimensions, a figure per main "
                    "output): in --out when it is the only archive given, else in <--out or "
                    "reports>/<file name without .nc>.")
    p.add_argument("archives", nargs="+", metavar="FILE.nc", help="study archives")
    p.add_argument("--out", default=None, metavar="DIR",
                   help="output folder (default: reports/paper for the paper's archives, "
                        "reports/<name> for another)")
    risk_options(p, "an IDA archive's ")
    p.set_defaults(handler=run)


def risk_options(p, whose: str = "") -> None:
    """--hazard, --spectrum, --years of an IDA report's Collapse risk section."""
    p.add_argument("--hazard", metavar="CURVE.csv",
                   help=f"hazard curve of {whose}Collapse risk section (default: "
                        "catalog/hazard/illustrative-pga-hazard.csv)")
    p.add_argument("--spectrum", metavar="DESIGN.csv",
                   help=f"design spectrum of {whose}Collapse risk section (default: "
                        "catalog/hazard/illustrative-design-spectrum.csv)")
    p.add_argument("--years", type=float, default=None,
                   help="exposure time of the probabilities of collapse [yr] (default 50)")


def run(args) -> int:
    from urmx.errors import check_output, writing
    from urmx.reports import paper, report_folders, write_one

    if args.out is not None:  # a bad --out is said before any archive is read
        check_output(args.out, "--out", folder=True)
    mine, folder, own = report_folders(args.archives, args.out)
    for where in ([folder] if folder else []) + [where for _, _, where in own]:
        check_output(where, "--out", folder=True)
    if mine:
        with writing(folder, "report folder"):
            print(paper.write_report([ds for _, ds in mine], folder))
    for archive, ds, where in own:
        with writing(where, "report folder"):
            print(write_one(str(archive), ds, where, hazard=args.hazard,
                            spectrum=args.spectrum, years=args.years))
    return 0
