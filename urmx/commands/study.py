"""``urmx run``, ``urmx paper`` and ``urmx calibrate``: thin commands over urmx.study."""

from __future__ import annotations

import sys
import time
from pathlib import Path

PAPER_STUDIES = ("paper-single-storey", "paper-multi-storey", "verification",
                 "verification-intensity")


def register(sub) -> None:
    p = sub.add_parser("run", help="run a study file into a netCDF archive (resumable)")
    p.add_argument("study", help="study TOML file, or the name of a catalog study")
    p.add_argument("--out", required=True, help="netCDF archive to write (FILE.nc)")
    study_options(p)
    p.set_defaults(handler=_run)

    p = sub.add_parser("paper", help="run the paper's studies and write the reports")
    p.add_argument("--out", default="results",
                   help="folder of the netCDF archives (default: results)")
    p.add_argument("--report", default="reports/paper",
                   help="folder of the figures and REPORT.md (default: reports/paper)")
    study_options(p)
    p.set_defaults(handler=_paper)

    p = sub.add_parser("calibrate", help="fit the parametric building, write "
                       "reports/calibration.md")
    p.add_argument("--out", default=None, help="report folder (default: the checkout's reports/)")
    p.set_defaults(handler=_calibrate)


def study_options(p) -> None:
    """The options every study-running command takes (scheduler, records, batch size,
    quiet)."""
    p.add_argument("--scheduler", default=None,
                   help='dask scheduler address (tcp://host:8786), "threads" or "serial"; '
                        "default: local worker processes, one per core")
    p.add_argument("--records", default=None, help="records folder (default $URMX_RECORDS)")
    p.add_argument("--batch-size", type=int, default=16,
                   help="analyses per batch (default 16)")
    p.add_argument("--quiet", action="store_true", help="no progress bar")


def command_line() -> str:
    """The command as typed, for an archive's ``history`` attribute."""
    return "urmx " + " ".join(sys.argv[1:])


def _run(args) -> int:
    from ..study import run_study

    run_study(args.study, out=args.out, scheduler=args.scheduler, progress=not args.quiet,
              batch_size=args.batch_size, records_dir=args.records, command=command_line())
    print(args.out)
    return 0


def _paper(args) -> int:
    from ..report import write_report
    from ..study import close_client, get_client, run_study

    out = Path(args.out)
    start = time.perf_counter()
    archives = []
    client, owned = (None, False)
    if args.scheduler != "serial":
        client, owned = get_client(args.scheduler)  # one cluster for all three studies
    try:
        for name in PAPER_STUDIES:
            path = out / f"{name}.nc"
            print(f"urmx paper: {name} -> {path}", file=sys.stderr)
            run_study(name, out=path, scheduler=client if client else "serial",
                      progress=not args.quiet, batch_size=args.batch_size,
                      records_dir=args.records, command=command_line())
            archives.append(path)
    finally:
        if owned:
            close_client(client)
    print(f"urmx paper: studies done in {time.perf_counter() - start:.1f} s", file=sys.stderr)
    report = write_report(archives, args.report)
    print(f"urmx paper: done in {time.perf_counter() - start:.1f} s: archives in {out}/, "
          f"report {report}", file=sys.stderr)
    return 0


def _calibrate(args) -> int:
    from ..paper import calibrate, calibration_report

    result = calibrate()
    b = result.building
    print(f"least squares: wall_length = {b.wall_length:.4f} m, diaphragm_weight = "
          f"{b.diaphragm_weight:.4f} kPa (density {b.density:g} kg m-3), "
          f"RMS relative residual {result.rms:.4f}")
    print(calibration_report(args.out))
    return 0
