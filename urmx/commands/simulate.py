"""``urmx simulate WALL.toml RECORD``: one analysis from the command line."""

from __future__ import annotations

UNITS = ("g", "m/s2", "cm/s2", "mm/s2")


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "simulate", help="rock one wall under one record and print the peak response",
        description="Rock one wall (a TOML file of urmx.Wall fields) under one record "
                    "(a file or a manifest record id) and print the scalar outputs.")
    p.add_argument("wall", metavar="WALL.toml",
                   help="wall file: Wall fields in a [wall] table or at the top level")
    p.add_argument("record", metavar="RECORD", help="record file path or manifest record id")
    p.add_argument("--dt", type=float, help="time step [s] for record files without one")
    p.add_argument("--unit", choices=UNITS, help="unit of a record file that does not state it")
    p.add_argument("--scale", type=float, default=1.0, help="record scale factor (default 1)")
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


def _trace(arg: str, dt: float | None, unit: str | None, records_dir):
    """The record as an ObsPy Trace in m s-2: a file, or else a manifest id."""
    from pathlib import Path

    from urmx.records import load, manifest, read

    path = Path(arg)
    if path.is_file():
        stream = read(path, dt=dt, unit=unit)
        if len(stream) != 1:
            ids = ", ".join(tr.id for tr in stream)
            raise ValueError(f"record file {arg!r} holds {len(stream)} channels ({ids}); "
                             f"give a file with one channel")
        return stream[0]
    try:
        ids = manifest(records_dir)
    except FileNotFoundError:
        ids = {}
    if arg not in ids:
        raise FileNotFoundError(f"record {arg!r} is neither a file nor a manifest record id")
    if dt is not None or unit is not None:
        raise ValueError(f"--dt and --unit apply to record files; {arg!r} is a manifest "
                         f"record that states its own")
    return load(arg, records_dir)


def _table(ds) -> str:
    from urmx.variables import INTEGER_SCALARS, SCALARS

    width = max(map(len, SCALARS))
    lines = []
    for name in SCALARS:
        value = ds[name].item()
        text = f"{value:d}" if name in INTEGER_SCALARS else f"{value:.6g}"
        lines.append(f"  {name:<{width}s}  {text:>12s}  {ds[name].attrs['units']}")
    return "\n".join(lines)


def _run(args) -> int:
    from urmx.simulation import read_wall, simulate, write_netcdf

    wall = read_wall(args.wall)
    trace = _trace(args.record, args.dt, args.unit, args.records)
    history = bool(args.out or args.plot)
    ds = simulate(wall, trace, scale=args.scale, cor=args.cor, impact=args.impact,
                  tail=args.tail, history=history, method=args.method)
    a = ds.attrs
    print(f"wall {args.wall}  record {args.record} (dt {a['dt']:g} s, {trace.stats.npts} "
          f"points)  scale {a['scale']:g}  cor {a['cor']:g}  impact {a['impact']}  "
          f"method {a['method']}")
    print(f"status {a['status']}  analysed {a['duration']:.6g} s  events {a['events']}")
    print(_table(ds))
    if args.out:
        print(f"wrote {write_netcdf(ds, args.out)}")
    if args.plot:
        print(f"wrote {plot_simulation(ds, args.plot)}")
    return 0


def plot_simulation(ds, out):
    """Two panels over time: top, crack and base displacement [mm]; the rocking pattern."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    t = ds["time"].values
    fig, (ax1, ax2) = plt.subplots(2, 1, sharex=True, figsize=(8, 5.5),
                                   gridspec_kw={"height_ratios": (3, 1)})
    for name, colour in (("top_displacement", "C0"), ("crack_displacement", "C1"),
                         ("base_displacement", "C2")):
        ax1.plot(t, 1e3 * ds[name].values, color=colour, lw=0.9,
                 label=ds[name].attrs["long_name"])
    ax1.set_ylabel("displacement relative to ground [mm]")
    ax1.legend(loc="upper right", fontsize="small")
    ax1.grid(alpha=0.3)
    levels = np.array([0, 11, 12, 21, 22])  # 0 after a stop
    ax2.step(t, np.searchsorted(levels, ds["pattern"].values), where="post", color="k", lw=0.9)
    ax2.set_yticks(range(levels.size), [str(v) for v in levels])
    ax2.set_ylabel(ds["pattern"].attrs["long_name"])
    ax2.set_xlabel(f"{ds['time'].attrs['long_name']} [{ds['time'].attrs['units']}]")
    ax2.grid(alpha=0.3)
    if int(ds["collapsed"]):
        for ax in (ax1, ax2):
            ax.axvline(float(ds["collapse_time"]), color="r", ls="--", lw=0.8)
    fig.suptitle(f"status {ds.attrs['status']}, scale {ds.attrs['scale']:g}, "
                 f"cor {ds.attrs['cor']:g}, peak u_t "
                 f"{1e3 * float(ds['peak_top_displacement']):.1f} mm")
    fig.tight_layout()
    fig.savefig(out, dpi=120)
    plt.close(fig)
    return out
