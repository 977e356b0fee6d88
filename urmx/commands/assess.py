"""``urmx assess WALL.toml`` (each assessment procedure's verdict for one wall) and
``urmx assess-report FILE.nc`` (the procedures against an IDA archive -> reports/assessment/):
thin commands over `urmx.assess` and `urmx.reports.assessment`."""

from __future__ import annotations

POSITIONS = ("one-storey", "first", "top", "other")


def register(sub) -> None:
    p = sub.add_parser(
        "assess", help="assessment procedures (NZSEE C8, h/t table, NTC kinematic, Doherty) "
                       "for one wall under a design spectrum or a record",
        description="Runs every registered procedure of urmx.assess on the wall of WALL.toml "
                    "(a [wall] table or Wall fields; the format of catalog/examples/) under "
                    "the NZS 1170.5 design spectrum (--z, --site-class, --return-factor) or a "
                    "record (--record ID_OR_FILE --scale S), and prints each verdict, "
                    "capacity, demand, capacity scale and intermediate value (--json: as "
                    "JSON).")
    p.add_argument("wall", metavar="WALL.toml", help="wall file")
    p.add_argument("--z", type=float, metavar="Z", help="NZS 1170.5 hazard factor Z")
    p.add_argument("--site-class", default="C", metavar="CLASS",
                   help="NZS 1170.5 site subsoil class A-E (default C)")
    p.add_argument("--return-factor", type=float, default=1.0, metavar="R",
                   help="NZS 1170.5 return period factor R (default 1.0)")
    p.add_argument("--record", metavar="ID_OR_FILE",
                   help="a record: a manifest id or a record file (instead of --z)")
    p.add_argument("--scale", type=float, default=1.0, metavar="S",
                   help="scale factor on the record (default 1)")
    p.add_argument("--records", metavar="DIR", help="records folder (default $URMX_RECORDS)")
    p.add_argument("--position", choices=POSITIONS,
                   help="the wall's storey (default: what its supports imply)")
    p.add_argument("--json", action="store_true", help="print the results as JSON")
    p.set_defaults(handler=_assess)
    r = sub.add_parser(
        "assess-report", help="the assessment procedures against an IDA archive -> "
                              "reports/assessment/",
        description="Compares every procedure of urmx.assess with the IDA collapse scales "
                    "of an archive (`urmx run fema-p695-ida --out FILE.nc`): shares of "
                    "unconservative and conservative (wall, record) pairs per diaphragm, "
                    "median and dispersion of the capacity ratio, figures and findings, in "
                    "REPORT.md.")
    r.add_argument("archive", metavar="FILE.nc", help="IDA archive")
    r.add_argument("--out", default="reports/assessment", metavar="DIR",
                   help="output folder (default: reports/assessment)")
    r.add_argument("--records", metavar="DIR", help="records folder (default $URMX_RECORDS)")
    r.set_defaults(handler=_report)


def _demand(args):
    from ..errors import InputError

    if (args.z is None) == (args.record is None):
        raise InputError("give either --z (the NZS 1170.5 design spectrum) or --record "
                         "ID_OR_FILE (a record), not both or neither")
    if args.record is not None:
        from ..assess import record_demand

        return record_demand(args.record, args.scale, records_dir=args.records)
    if args.scale != 1.0:
        raise InputError("--scale applies to --record only")
    from ..assess import DesignSpectrum

    return DesignSpectrum(args.z, args.site_class, args.return_factor)


def _assess(args) -> int:
    import json

    from ..assess import PROCEDURES, position_of
    from ..catalog import read_wall

    wall = read_wall(args.wall)
    demand = _demand(args)
    pos = position_of(wall, args.position)
    results = [fn(wall, demand, position=pos) for fn in PROCEDURES.values()]
    if args.json:
        print(json.dumps({"wall": args.wall, "demand": demand.describe(),
                          "position": pos.storey,
                          "results": [r.to_dict() for r in results]}, indent=1))
        return 0
    print(f"{args.wall} under {demand.describe()} ({pos.storey} wall)")
    for r in results:
        print(f"\n{r.summary()}")
        if r.reason and r.applicable:
            print(f"  note: {r.reason}")
        for name, q in r.quantities.items():
            print(f"  {name} = {q.value:.5g} {q.unit}  ({q.description}"
                  f"{'; ' + q.ref if q.ref else ''})")
    return 0


def _report(args) -> int:
    from ..errors import check_output, writing
    from ..reports.assessment import write_report

    check_output(args.out, "--out", folder=True)
    with writing(args.out, "report folder"):
        print(write_report(args.archive, args.out, records_dir=args.records))
    return 0
