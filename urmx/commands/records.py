"""``urmx records list|show|plot|report``: the record manifest from the command line."""

from __future__ import annotations


def register(subparsers) -> None:
    p = subparsers.add_parser("records", help="list, measure and plot ground-motion records")
    p.add_argument("--records", metavar="DIR", help="records directory (default $URMX_RECORDS)")
    sub = p.add_subparsers(dest="action", metavar="ACTION", required=True)
    s = sub.add_parser("list", help="list the manifest's records")
    s.add_argument("--set", help="only this set (paper, verification, fema-p695-far-field)")
    s = sub.add_parser("show", help="measures of one record as a table")
    s.add_argument("id", help="record id or a record file path")
    s.add_argument("--scaled", action="store_true", help="apply the manifest scale_factor")
    s = sub.add_parser("plot", help="acceleration, Fourier and response spectrum figure")
    s.add_argument("id", help="record id or a record file path")
    s.add_argument("--out", required=True, help="image file to write (PNG)")
    s = sub.add_parser("report", help="write reports/records.md and its figures")
    s.add_argument("--out", help="Markdown file (default reports/records.md)")
    p.set_defaults(handler=_run)


def _trace(arg: str, records_dir):
    from pathlib import Path

    from urmx.records import load, manifest, read

    if arg in manifest(records_dir) or not Path(arg).exists():
        return load(arg, records_dir)
    st = read(arg)
    return st[0]


def _run(args) -> int:
    if args.action == "list":
        from urmx.records import manifest

        rows = [e for e in manifest(args.records).values() if not args.set or e["set"] == args.set]
        print(f"{'id':22s} {'set':20s} {'PGA g':>6s} {'scale':>7s}  event / station / component")
        for e in rows:
            print(f"{e['id']:22s} {e['set']:20s} {e['expected_pga_g']:6.3f} "
                  f"{e['scale_factor']:7.4g}  {e['event']} {e.get('date', '')} / "
                  f"{e.get('station', '')} / {e.get('component', '')}"
                  + ("  [substitute]" if e.get("substitute") else ""))
        return 0
    if args.action == "show":
        from urmx.records import STANDARD_GRAVITY, measures, scale

        tr = _trace(args.id, args.records)
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
    if args.action == "plot":
        from urmx.records.plot import plot_record

        tr = _trace(args.id, args.records)
        plot_record(tr, args.out, title=args.id)
        print(f"wrote {args.out}")
        return 0
    from urmx.records.report import write_report

    print(f"wrote {write_report(args.out, args.records)}")
    return 0
