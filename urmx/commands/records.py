"""``urmx records list|show|plot|index|report``: the record manifest from the command line."""

from __future__ import annotations

import argparse
from pathlib import Path

UNITS = ("g", "m/s2", "cm/s2", "mm/s2")


def _records_option(p, default) -> None:
    p.add_argument("--records", metavar="DIR", default=default,
                   help="records directory: yours wins for the records it holds (default "
                        "$URMX_RECORDS or urmx.toml, else the records urmx ships)")


def file_options(s, what: str = "a record file") -> None:
    """--dt, --unit, --channel and --allow-unusual: how to read a record file (shared by
    `urmx simulate`)."""
    s.add_argument("--dt", type=float, help=f"time step [s] of {what} without one")
    s.add_argument("--unit", choices=UNITS, help=f"unit of {what} that does not state it")
    s.add_argument("--channel", metavar="NAME",
                   help="channel of a multi-channel file (GeoNet, CDMG, ...): required there")
    s.add_argument("--format", metavar="FORMAT",
                   help="what the file is, when its first bytes do not say: peer, geonet, "
                        "cosmos, dmg, smc, knet, columns, or an ObsPy format (MSEED, SAC, ...)")
    s.add_argument("--response", metavar="FILE.xml",
                   help="StationXML whose instrument response turns the counts of a MiniSEED "
                        "(or other ObsPy-format) file into acceleration")
    s.add_argument("--allow-unusual", action="store_true",
                   help="read a record whose time step is outside 0.0001-0.1 s, whose PGA "
                        "is outside 0.001-10 g, whose PGV or PGD is beyond strong motion, "
                        "or whose header says it is no acceleration (refused otherwise: "
                        "nearly always a mistake; the override is recorded)")


def record_inputs(name: str, records_dir=None) -> list[tuple[str, object]]:
    """The files a record named on the command line is read from (the file, or a manifest
    record's file and its manifest), as `urmx.errors.check_output` takes them: an output
    is never one of them."""
    from pathlib import Path

    if Path(name).is_file():
        return [("the record file", Path(name))]
    try:
        from urmx.records import manifest

        entry = manifest(records_dir).get(name, {})
    except Exception:  # noqa: BLE001 - an unreadable manifest is said when it is read
        return []
    return [(label, Path(entry[key])) for key, label in
            (("path", f"the file of record {name!r}"), ("manifest", "the records manifest"))
            if entry.get(key)]


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
    file_options(s)
    _records_option(s, argparse.SUPPRESS)
    s = sub.add_parser("plot", help="acceleration, Fourier and response spectrum figure")
    s.add_argument("id", help="record id or a record file path")
    s.add_argument("--out", required=True, help="image file to write (PNG)")
    file_options(s)
    _records_option(s, argparse.SUPPRESS)
    s = sub.add_parser("index", help="write a manifest of a folder of record files",
                       description="Read every record file of FOLDER once and write a "
                                   "manifest of them (ids from the file names, one per "
                                   "channel of a multi-channel file, SHA-256, format, unit, "
                                   "dt, points, PGA) in the schema of records/manifest.toml. "
                                   "Written as FOLDER/manifest.toml, the records load by id "
                                   "with URMX_RECORDS=FOLDER (or --records FOLDER).")
    s.add_argument("folder", metavar="FOLDER", help="folder of record files")
    s.add_argument("--out", metavar="FILE",
                   help="manifest to write (default FOLDER/manifest.toml)")
    s.add_argument("--pattern", metavar="GLOB",
                   help="only these files, e.g. '*.AT2' or '**/*.V2A' (default: every file; "
                        "files that are not records are then skipped and listed)")
    s.add_argument("--dt", type=float, help="time step [s] of the plain number files")
    s.add_argument("--unit", choices=UNITS,
                   help="unit of the plain number (and ObsPy-format) files")
    s.add_argument("--set", default="own", help="the records' set (default own)")
    s.add_argument("--allow-unusual", action="store_true",
                   help="also index records outside 0.0001-0.1 s or 0.001-10 g")
    s = sub.add_parser("report", help="write reports/records.md and its figures")
    s.add_argument("--out", help="Markdown file (default reports/records.md)")
    _records_option(s, argparse.SUPPRESS)
    p.set_defaults(handler=_run)


def _trace(args):
    """The record of ``args.id``: a record file (with --dt/--unit/--channel) or a manifest
    id (with --channel for a multi-channel file its entry does not choose)."""
    from pathlib import Path

    from urmx.errors import InputError, MissingFileError
    from urmx.records import load, manifest, read_channel

    path = Path(args.id)
    if path.is_file():
        return read_channel(path, args.format, dt=args.dt, unit=args.unit,
                            channel=args.channel, allow_unusual=args.allow_unusual,
                            response=args.response).trace()
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
    if args.dt is not None or args.unit is not None or args.allow_unusual or \
            args.format is not None or args.response is not None:
        raise InputError(f"--dt, --unit, --format, --response and --allow-unusual apply to "
                         f"record files; {args.id!r} is a manifest record that states its own")
    return load(args.id, args.records, channel=args.channel)


def _index(args) -> int:
    from pathlib import Path

    from urmx.errors import check_output
    from urmx.records.manifest import index, write_manifest

    folder = Path(args.folder)
    read = [("the record file", f) for f in folder.glob(args.pattern or "*") if f.is_file()
            and f.name != "manifest.toml"] if folder.is_dir() else []
    out = check_output(args.out or folder / "manifest.toml", inputs=read)
    entries, skipped = index(folder, pattern=args.pattern or "*", dt=args.dt, unit=args.unit,
                             record_set=args.set, allow_unusual=args.allow_unusual,
                             skip_unknown=args.pattern is None)
    for line in skipped:
        print(f"skipped {line}")
    if not entries:
        from urmx.errors import InputError

        raise InputError(f"no record file in {str(folder)!r} (every file was skipped)")
    base = folder.resolve()
    how = ("load them with URMX_RECORDS=" + str(base) if out.resolve().parent == base else
           f"their files are relative to {base}: load them with --records {base} and this "
           "manifest")
    write_manifest(entries, out, comment=(
        f"urmx record manifest of {base}, written by `urmx records index`;\n{how}.\n"
        "Fields as in records/manifest.toml; scale_factor 1.0: edit it (and event, site, "
        "notes) as needed,\nbut not sha256, which checks the file is the one indexed."))
    width = max(len(e["id"]) for e in entries)
    for e in entries:
        print(f"{e['id']:{width}s}  {e['format']:8s} {e['unit']:6s} dt {e['dt']:<8g} "
              f"{e['npts']:7d} points  PGA {e['expected_pga_g']:.4f} g  {e['file']}")
    print(f"wrote {out} ({len(entries)} records)")
    return 0


def _from(entry: dict) -> str:
    """Where a listed record's file is read from: ``shipped`` (the records urmx ships) or
    ``yours`` (the folder the user named)."""
    from urmx.config import shipped_records

    return "shipped" if Path(entry["folder"]) == shipped_records() else "yours"


def _folders(rows: list[dict]) -> None:
    """The folders the listed records come from, one line each with how many."""
    for tag in ("yours", "shipped"):
        held = [e for e in rows if _from(e) == tag]
        if held:
            what = "your records folder" if tag == "yours" else "shipped with urmx"
            print(f"{tag}: {len(held)} records from {held[0]['folder']} ({what})")


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
        w = max([22] + [len(e["id"]) for e in rows])
        _folders(rows)
        print(f"{'id':{w}s} {'from':7s} {'set':20s} {'PGA g':>6s} {'scale':>7s}  event / "
              "station / component")
        for e in rows:
            print(f"{e['id']:{w}s} {_from(e):7s} {e['set']:20s} {e['expected_pga_g']:6.3f} "
                  f"{e['scale_factor']:7.4g}  {e['event']} {e.get('date', '')} / "
                  f"{e.get('station', '')} / {e.get('component', '')}"
                  + ("  [substitute]" if e.get("substitute") else ""))
        return 0
    if args.action == "index":
        return _index(args)
    if args.action == "show":
        from urmx.records import STANDARD_GRAVITY, measures, scale

        tr = _trace(args)
        if args.scaled:
            tr = scale(tr, tr.stats.record.get("scale_factor") or 1.0)
        ds = measures(tr)
        channel = f" channel {tr.stats.channel}" if tr.stats.channel else ""
        print(f"{args.id}: {tr.stats.record.file} ({tr.stats.record.format}{channel}), "
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

        check_output(args.out, inputs=record_inputs(args.id, args.records))
        tr = _trace(args)
        with writing(args.out, "figure"):
            plot_record(tr, args.out, title=args.id + (f" {tr.stats.channel}"
                                                       if args.channel else ""))
        print(f"wrote {args.out}")
        return 0
    from urmx.reports.records import write_report

    if args.out is not None:
        from urmx.records import manifest

        read = {(f"the file of record {rid!r}", e["path"]) for rid, e in
                manifest(args.records).items() if e.get("path")}
        read |= {("the records manifest", e["manifest"]) for e in
                 manifest(args.records).values()}
        check_output(args.out, inputs=sorted(read))
    with writing(args.out or "reports/records.md", "report"):
        path = write_report(args.out, args.records)
    print(f"wrote {path}")
    return 0
