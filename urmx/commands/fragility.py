"""``urmx ida STUDY --out FILE.nc`` (an alias of ``urmx run`` for IDA studies) and ``urmx
fragility-report FILE.nc`` (figures and tables of an IDA archive): thin commands."""

from __future__ import annotations


def register(sub) -> None:
    from .study import study_options

    p = sub.add_parser(
        "ida", help="alias of `urmx run` for a study with [study.ida]: collapse capacities "
                    "into a netCDF archive (resumable)",
        description="`urmx run` for a study whose file has an [study.ida] table (it refuses "
                    "any other): one collapse capacity (hunt and bisection on the record's "
                    "scale factor) per (wall, diaphragm, record, cor) cell, and the archive "
                    "with the lognormal fits. Interrupted runs resume: run the same command "
                    "again.")
    p.add_argument("study", help="study TOML file with [study.ida], or the name of a catalog "
                                 "study (fema-p695-ida)")
    p.add_argument("--out", required=True, help="netCDF archive to write (FILE.nc)")
    study_options(p)
    p.set_defaults(handler=_ida)

    p = sub.add_parser(
        "fragility-report", help="figures and tables of an IDA archive -> reports/fragility/",
        description="IDA curves, fragility curves with their confidence bands, median "
                    "collapse intensity against slenderness and diaphragm frequency, the effect "
                    "of stiffening the diaphragm, the efficiency and sufficiency of every "
                    "intensity measure and the collapse risk at a site, from an archive "
                    "written by `urmx ida`.")
    p.add_argument("archive", metavar="FILE.nc", help="IDA archive")
    p.add_argument("--out", default="reports/fragility", metavar="DIR",
                   help="output folder (default: reports/fragility)")
    p.add_argument("--hazard", metavar="CURVE.csv",
                   help="hazard curve of the Collapse risk section (default: "
                        "catalog/hazard/illustrative-pga-hazard.csv)")
    p.add_argument("--spectrum", metavar="DESIGN.csv",
                   help="design spectrum of the Collapse risk section (default: "
                        "catalog/hazard/illustrative-design-spectrum.csv)")
    p.add_argument("--years", type=float, default=50.0,
                   help="exposure time of the probabilities of collapse [yr] (default 50)")
    p.set_defaults(handler=_report)


def _ida(args) -> int:
    from ..catalog import load_study
    from ..errors import InputError, check_output
    from ..study import check_scheduler
    from .study import run_loaded

    check_output(args.out, "--out")
    check_scheduler(args.scheduler)
    study = load_study(args.study)
    if study.kind != "ida":
        raise InputError(f"{study.path}: study {study.name!r} has no [study.ida] table (im, "
                         "rtol, step, max_intensity); add one, or run it with `urmx run`")
    return run_loaded(args, study)


def _report(args) -> int:
    from ..errors import check_output, writing
    from ..fragility_report import write_report

    check_output(args.out, "--out", folder=True)
    with writing(args.out, "report folder"):
        print(write_report(args.archive, args.out, hazard=args.hazard,
                           spectrum=args.spectrum, years=args.years))
    return 0
