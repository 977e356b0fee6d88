"""``urmx records list|show|plot|report``: the record manifest from the command line."""

from __future__ import annotations

import argparse

UNITS = ("g", "m/s2", "cm/s2", "mm/s2")


def _records_option(p, default) -> None:
    p.add_argument("--records", metavar="DIR", default=default,
                   help="records directory (default $URMX_RECORDS)")


def _file_options(s) -> None:
    s.add_argument("--dt", type=float, help="time step [s] of a record file without one")
    s.add_argument("--unit", choices=UNITS, help="unit of a record file that does not state it")


def register(subparsers) -> None:
    p = subparsers.add_parser("records", help="list, measure and plot ground-motion records")
    _records_option(p, None)
    sub = p.add_subparsers(dest="action", metavar="ACTION", required=True)
    s = sub.add_parser("list", help="list the manifest's records")
    s.add_argument("--set", help="only this set (paper, verification, fema-p695-far-field)")
    _records_option(s, argparse.SUPPRESS)  # also accepted after the action
    s = sub.add_parser("show", help="measures of one record as a table")
    s.add_argument("id", help="record id or a record file path")
    s.add_argument("--scaled", action="store_true", help="apply the manifest scale_factor")
    _file_options(s)
    _records_option(s, argparse.SUPPRESS)
    s = sub.add_parser("plot", help="acceleration, Fourier and response spectrum figure")
    s.add_argument("id", help="record id or a record file path")
    s.add_argument("--out", required=True, help="image file to write (PNG)")
    _file_options(s)
    _records_option(s, argparse.SUPPRESS)
    s = sub.add_parser("report", help="write reports/records.md and its figures")
    s.add_argument("--out", help="Markdown file (default reports/records.md)")
    _records_option(s, argparse.SUPPRESS)
    p.set_defaults(handler=_run)


def _trace(args):
    """The record of ``args.id``: a record file (with --dt/--unit) or a manifest id."""
    from pathlib import Path

    from urmx.errors import InputError, MissingFileError
    from urmx.records import load, manifest, read

    path = Path(args.id)
    if path.is_file():
        st = read(path, dt=args.dt, unit=args.unit)
        if len(st) > 1:
            print(f"{args.id}: {len(st)} channels ({', '.join(tr.id for tr in st)}); "
                  f"the first, {st[0].id}, is used")
        return st[0]
    try:
        known = manifest(args.records)
    except MissingFileError:
        if args.records is not None:
            raise
        known = {}
    if args.id not in known:
        if path.exists():
            raise InputError(f"{args.id!r} is a folder, not a record file")
        return load(args.id, args.records)  # unknown ids: the manifest's "did you mean"
    if args.dt is not None or args.unit is not None:
        raise InputError(f"--dt and --unit apply to record files; {args.id!r} is a manifest "
                         "record that states its own")
    return load(args.id, args.records)


def _run(args) -> int:
    if args.action == "list":
        from urmx.errors import InputError
        from urmx.records import manifest

        entries = manifest(args.records)
        sets = sorted({e["set"] for e in entries.values()})
        if args.set is not None and args.set not in sets:
            raise InputError(f"--set {args.set!r} is not a record set (sets: "
                             f"{', '.join(sets)})")
        rows = [e for e in entries.values() if not args.set or e["set"] == args.set]
        print(f"{'id':22s} {'set':20s} {'PGA g':>6s} {'scale':>7s}  event / station / component")
        for e in rows:
            print(f"{e['id']:22s} {e['set']:20s} {e['expected_pga_g']:6.3f} "
                  f"{e['scale_factor']:7.4g}  {e['event']} {e.get('date', '')} / "
                  f"{e.get('station', '')} / {e.get('component', '')}"
                  + ("  [substitute]" if e.get("substitute") else ""))
        return 0
    if args.action == "show":
        from urmx.records import STANDARD_GRAVITY, measures, scale

        tr = _trace(args)
        if args.scaled:
            tr = scale(tr, tr.stats.record.get("scale_factor") or 1.0)
        ds = measures(tr)
        print(f"{args.id}: {tr.stats.record.file} ({tr.stats.record.format}), "
              f"dt {tr.stats.delta:g} s, {tr.stats.npts} points")
        for name, var in ds.data_vars.items():
            in_g = var.attrs["units"] == "m s-2"
            extra = f"  ({float(var) / STANDARD_GRAVITY:.4f} g)" if in_g else ""
            print(f"  {name:28s} {float(var):12.5g} {var.attrs['units']:6s}{extra}")
        print("processing:")
        for step in tr.stats.processing:
            print(f"  - {step}")
        return 0
    from urmx.errors import check_output, writing

    if args.action == "plot":
        from urmx.records.plot import plot_record

        check_output(args.out)
        tr = _trace(args)
        with writing(args.out, "figure"):
            plot_record(tr, args.out, title=args.id)
        print(f"wrote {args.out}")
        return 0
    from urmx.records.report import write_report

    if args.out is not None:
        check_output(args.out)
    with writing(args.out or "reports/records.md", "report"):
        path = write_report(args.out, args.records)
    print(f"wrote {path}")
    return 0
