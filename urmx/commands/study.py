"""``urmx run``, ``urmx paper`` and ``urmx calibrate``: thin commands over urmx.study."""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path


def register(sub) -> None:
    p = sub.add_parser("run", help="run a study file of any kind into a netCDF archive "
                       "(resumable)")
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
    p.add_argument("--out", default=None, help="report folder (default: reports/)")
    p.set_defaults(handler=_calibrate)


def _batch_size(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a whole number") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"{text!r} must be at least 1")
    return value


def study_options(p) -> None:
    """The options every study-running command takes (scheduler, records, batch size,
    quiet, force and the size limits)."""
    p.add_argument("--scheduler", default=None,
                   help='dask scheduler address (tcp://host:8786), "threads", "processes" or '
                        '"serial"; default: the active distributed.Client if there is one, '
                        'else in-process for a study estimated under 10 s, else a local '
                        'cluster (worker processes, one per core)')
    p.add_argument("--records", default=None, help="records folder (default $URMX_RECORDS)")
    p.add_argument("--batch-size", type=_batch_size, default=16,
                   help="cells (analyses for a grid) per batch, >= 1 (default 16); batches "
                        "are cut over every dimension, and a resumed run finds finished "
                        "cells whatever the batch size was")
    p.add_argument("--worker-timeout", type=_seconds, default=None, metavar="SECONDS",
                   help="on a cluster, stop the run when no worker has been left for this "
                        "long (default 60; dask config urmx.worker-timeout)")
    p.add_argument("--quiet", action="store_true", help="no progress output")
    _size_options(p)


def _limit(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not value > 0:
        raise argparse.ArgumentTypeError(f"{text!r} must be above 0")
    return value


def _size_options(p) -> None:
    """--force, --max-cells, --max-gb (`urmx.study.engine`, `urmx.study.limits`)."""
    from ..study.limits import MAX_CELLS, MAX_GB

    p.add_argument("--force", action="store_true",
                   help="replace an --out archive that holds another study (or no urmx "
                        "study), discarding that study's finished parts in FILE.nc.parts/")
    p.add_argument("--max-cells", type=_limit, default=MAX_CELLS, metavar="N",
                   help=f"refuse, before any work, a study of more cells (default "
                        f"{MAX_CELLS:.0e})")
    p.add_argument("--max-gb", type=_limit, default=MAX_GB, metavar="G",
                   help=f"refuse, before any work, a study whose archive would pass G GB "
                        f"uncompressed (default {MAX_GB:g})")


def size_arguments(args) -> dict:
    """The run_study keywords of `_size_options`."""
    return dict(force=args.force, max_cells=args.max_cells, max_gb=args.max_gb)


def _seconds(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number of seconds") from None
    if not (value > 0 and value < float("inf")):
        raise argparse.ArgumentTypeError(f"{text!r} must be a positive number of seconds")
    return value


def apply_settings(args) -> None:
    """Put the run settings given on the command line (``--worker-timeout``) into dask's
    configuration, where the study engine reads them (`urmx.study.clients.setting`)."""
    if getattr(args, "worker_timeout", None) is not None:
        import dask.config

        dask.config.set({"urmx.worker-timeout": args.worker_timeout})


def command_line() -> str:
    """The command as typed, for an archive's ``history`` attribute."""
    return "urmx " + " ".join(sys.argv[1:])


def kept_note(out: Path) -> str:
    """What an interrupted or failed run left for the next one ('' when nothing)."""
    parts = out.with_name(out.name + ".parts")
    n = len(list(parts.glob("*.npz"))) if parts.is_dir() else 0
    if not n:
        return ""
    return (f"{n} finished batch{'es' if n > 1 else ''} kept in {parts}/: run the same "
            "command again to resume")


def run_resumable(args, out: Path, run) -> None:
    """Call `run` (a study run writing `out`); on Ctrl-C or a bug, say what is kept in
    `out`'s parts folder for the next run."""
    from ..errors import UrmxError

    try:
        run()
    except KeyboardInterrupt:
        args.interrupt_note = kept_note(out)
        raise
    except UrmxError:
        raise  # its message says what is kept
    except Exception:
        note = kept_note(out)
        if note:
            print(f"urmx {args.command}: {note}", file=sys.stderr)
        raise


def _run(args) -> int:
    return run_loaded(args, args.study)


def run_loaded(args, study) -> int:
    """Run a study of any kind (a loaded study, a file or a catalog name) into ``--out``,
    as ``urmx run`` does (its aliases call this too)."""
    from ..study import run_study

    apply_settings(args)
    run_resumable(args, Path(args.out), lambda: run_study(
        study, out=args.out, scheduler=args.scheduler, progress=not args.quiet,
        batch_size=args.batch_size, records_dir=args.records, command=command_line(),
        **size_arguments(args)))
    print(args.out)
    return 0


def _paper(args) -> int:
    from ..errors import check_output, writing
    from ..paper import run_paper
    from ..reports.paper import write_report
    from ..study import check_scheduler

    out = check_output(args.out, "--out", folder=True)
    check_output(args.report, "--report", folder=True)
    check_scheduler(args.scheduler)
    apply_settings(args)
    start = time.perf_counter()
    archives = run_paper(
        out, scheduler=args.scheduler,
        wrap=lambda path, run: run_resumable(args, path, run),
        say=lambda what: print(f"urmx paper: {what}", file=sys.stderr),
        progress=not args.quiet, batch_size=args.batch_size, records_dir=args.records,
        command=command_line(), **size_arguments(args))
    print(f"urmx paper: studies done in {time.perf_counter() - start:.1f} s", file=sys.stderr)
    with writing(args.report, "report folder"):
        report = write_report(archives, args.report)
    print(f"urmx paper: done in {time.perf_counter() - start:.1f} s: archives in {out}/, "
          f"report {report}", file=sys.stderr)
    return 0


def _calibrate(args) -> int:
    from ..errors import check_output, writing
    from ..paper import calibrate, calibration_report

    if args.out is not None:
        check_output(args.out, "--out", folder=True)
    result = calibrate()
    b = result.building
    print(f"least squares: wall_length = {b.wall_length:.4f} m, diaphragm_weight = "
          f"{b.diaphragm_weight:.4f} kPa (density {b.density:g} kg m-3), "
          f"RMS relative residual {result.rms:.4f}")
    with writing(args.out or "reports", "report folder"):
        print(calibration_report(args.out))
    return 0
