"""The old commands, kept for one release as aliases that say what replaced them: ``urmx
ida`` (now ``urmx run``), ``urmx fragility-report`` and ``urmx uncertainty-report`` (now
``urmx report``, which chooses the report by the archive's study kind)."""

from __future__ import annotations

import sys


def register(sub) -> None:
    from .report import risk_options
    from .study import study_options

    p = sub.add_parser(
        "ida", help="old name of `urmx run` for a study with [study.ida] (kept for one "
                    "release)",
        description="Replaced by `urmx run`. `urmx run` for a study whose file has an "
                    "[study.ida] table (it refuses any other).")
    p.add_argument("study", help="study TOML file with [study.ida], or the name of a catalog "
                                 "study (fema-p695-ida)")
    p.add_argument("--out", required=True, help="netCDF archive to write (FILE.nc)")
    study_options(p)
    p.set_defaults(handler=_ida)

    p = _report_alias(sub, "fragility-report", "ida", "an IDA archive", "fragility",
                      "IDA and fragility curves, intensity measures, collapse risk")
    risk_options(p)
    _report_alias(sub, "uncertainty-report", "sampling", "a sampling-study archive",
                  "uncertainty", "sensitivity, spread of the capacity, impact laws")


def _report_alias(sub, name: str, writer: str, what: str, folder: str, holds: str):
    """The parser of an old report command: `writer`'s report of `what` into
    ``reports/<folder>`` by default."""
    p = sub.add_parser(
        name, help=f"old name of `urmx report` for {what} (kept for one release) -> "
                   f"reports/{folder}/",
        description=f"Replaced by `urmx report`: the report of {what} ({holds}).")
    p.add_argument("archive", metavar="FILE.nc", help=what.split(" ", 1)[1])
    p.add_argument("--out", default=f"reports/{folder}", metavar="DIR",
                   help=f"output folder (default: reports/{folder})")
    p.set_defaults(handler=_report, writer=writer)
    return p


def replaced(old: str, new: str) -> None:
    """Say on stderr that command `old` is an alias of `new`, kept for one release."""
    print(f"urmx {old}: replaced by `urmx {new}` (this alias goes in the next release)",
          file=sys.stderr)


def _ida(args) -> int:
    from ..errors import InputError, check_output
    from ..study import check_scheduler
    from ..study.file import load_study
    from .study import run_loaded

    replaced("ida", "run")
    check_output(args.out, "--out")
    check_scheduler(args.scheduler)
    study = load_study(args.study)
    if study.kind != "ida":
        raise InputError(f"{study.path}: study {study.name!r} has no [study.ida] table (im, "
                         "rtol, step, max_intensity); add one, or run it with `urmx run`")
    return run_loaded(args, study)


def _report(args) -> int:
    from ..errors import check_output, writing
    from ..reports import REPORTS

    replaced(args.command, "report")
    check_output(args.out, "--out", folder=True)
    options = {k: getattr(args, k) for k in ("hazard", "spectrum", "years")
               if getattr(args, k, None) is not None}
    with writing(args.out, "report folder"):
        print(REPORTS[args.writer](args.archive, args.out, **options))
    return 0
