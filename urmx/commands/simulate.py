"""``urmx simulate WALL.toml RECORD``: one analysis from the command line."""

from __future__ import annotations

from .records import file_options, record_inputs


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "simulate", help="rock one wall under one record and print the peak response",
        description="Rock one wall (a TOML file of urmx.Wall fields) under one record "
                    "(a file or a manifest record id) and print the scalar outputs.")
    p.add_argument("wall", metavar="WALL.toml",
                   help="wall file: Wall fields in a [wall] table or at the top level; or "
                        "the name of a catalog example (benchmark-wall; urmx catalog list)")
    p.add_argument("record", metavar="RECORD", help="record file path or manifest record id")
    file_options(p, "the record file")
    p.add_argument("--scale", type=float, default=1.0,
                   help="record scale factor, > 0 (default 1)")
    p.add_argument("--cor", type=float, default=0.8,
                   help="coefficient of restitution in (0, 1] (default 0.8)")
    p.add_argument("--impact", choices=("scale", "contact"), default="scale",
                   help="impact law (default scale)")
    p.add_argument("--tail", type=float, default=0.0,
                   help="free-vibration tail after the record [s] (default 0)")
    p.add_argument("--method", choices=("exact", "reference"), default="exact",
                   help="exact kernel or the scipy reference solver (default exact)")
    p.add_argument("--records", metavar="DIR",
                   help="records directory for manifest ids (default $URMX_RECORDS)")
    p.add_argument("--out", metavar="FILE.nc", help="write the Dataset (with histories) here")
    p.add_argument("--plot", metavar="FILE.png",
                   help="draw displacement histories and the rocking pattern here")
    p.set_defaults(handler=_run)


def _record(args):
    """The record's checked samples (`urmx.records.readers.Samples`, m s-2): a file, or else
    a manifest id; one channel (--channel for a multi-channel file). Read without ObsPy
    (only ObsPy's own file formats import it)."""
    from pathlib import Path

    from urmx.errors import InputError, MissingFileError
    from urmx.records import load_samples, manifest
    from urmx.records.readers import read_channel

    path = Path(args.record)
    if path.is_file():
        return read_channel(path, args.format, dt=args.dt, unit=args.unit,
                            channel=args.channel, allow_unusual=args.allow_unusual,
                            response=args.response)
    try:
        ids = manifest(args.records)
    except MissingFileError:
        if args.records is not None:
            raise
        ids = {}
    if args.record not in ids:
        raise MissingFileError(f"record {args.record!r} is neither a file nor a manifest "
                               "record id")
    if args.dt is not None or args.unit is not None or args.format is not None or \
            args.response is not None:
        raise InputError(f"--dt, --unit, --format and --response apply to record files; "
                         f"{args.record!r} is a manifest record that states its own")
    return load_samples(args.record, args.records, channel=args.channel)


def scalar_table(values: dict) -> str:
    """The scalar outputs of one analysis, a line each: name, value, units."""
    from urmx.variables import INTEGER_SCALARS, SCALARS, attrs

    width = max(map(len, SCALARS))
    lines = []
    for name in SCALARS:
        value = values[name]
        text = f"{int(value):d}" if name in INTEGER_SCALARS else f"{value:.6g}"
        lines.append(f"  {name:<{width}s}  {text:>12s}  {attrs(name)['units']}")
    return "\n".join(lines)


def _run(args) -> int:
    """One analysis. Without --out or --plot the solver is called directly and nothing of
    xarray, dask or matplotlib is imported (a second or so less per command)."""
    import contextlib
    import math

    from urmx.catalog import read_wall, wall_path
    from urmx.errors import InputError, check_output, writing
    from urmx.model import allow_unusual_walls

    if not (math.isfinite(args.scale) and args.scale > 0):
        raise InputError(f"--scale: scale={args.scale!r} must be a positive factor (a record "
                         "is scaled, never reversed or zeroed)")
    args.wall = str(wall_path(args.wall))  # a catalog example by name
    read = [("the wall file", args.wall), *record_inputs(args.record, args.records)]
    for option, path in (("--out", args.out), ("--plot", args.plot)):
        if path:
            check_output(path, option, inputs=read, utf8=option == "--out")
    if args.out and args.plot and check_output(args.out) == check_output(args.plot):
        raise InputError(f"--out and --plot name the same file {args.out!r}")
    with allow_unusual_walls() if args.allow_unusual else contextlib.nullcontext():
        wall = read_wall(args.wall)
    rec = _record(args)
    kw = dict(scale=args.scale, cor=args.cor, impact=args.impact, tail=args.tail)
    if args.out or args.plot:
        from urmx.simulation import simulate

        ds = simulate(wall, rec.trace(), history=True, method=args.method, **kw)
        values = {name: ds[name].item() for name in ds.data_vars if ds[name].ndim == 0}
        values.update(ds.attrs)
    else:
        if args.method == "reference":
            from urmx.reference import run
        else:
            from urmx.kernel import run
        values = run(wall, rec.data, rec.dt, **kw)
        values.update(dt=rec.dt, method=args.method, **kw)
    print(f"wall {args.wall}  record {args.record} (dt {values['dt']:g} s, {rec.data.size} "
          f"points)  scale {values['scale']:g}  cor {values['cor']:g}  impact "
          f"{values['impact']}  method {values['method']}")
    print(f"status {values['status']}  analysed {values['duration']:.6g} s  events "
          f"{values['events']}")
    print(scalar_table(values))
    if args.out:
        from urmx.netcdf import write_netcdf

        print(f"wrote {write_netcdf(ds, args.out)}")
    if args.plot:
        from urmx.plot import plot_simulation

        with writing(args.plot, "figure"):
            plot_simulation(ds)[0].figure.savefig(args.plot, dpi=120)
        print(f"wrote {args.plot}")
    return 0
