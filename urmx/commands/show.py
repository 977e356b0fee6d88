"""``urmx show ARCHIVE --wall W --diaphragm D --record R [--cor C --scale S] --plot FILE.png
[--out cell.nc]``: one cell of a study archive computed again with its histories and drawn
(`urmx.analysis.recompute`)."""

from __future__ import annotations


def register(sub) -> None:
    p = sub.add_parser(
        "show", help="compute one cell of an archive again, with its time histories, and "
                     "draw it",
        description="Compute one cell of a study archive again (milliseconds), with its time "
                    "histories, from the study the archive carries: first checking that this "
                    "urmx's kernel is the archive's (kernel_source_hash) and that the "
                    "record's file is the one the archive was computed from (SHA-256, "
                    "scale factor, time step), refusing otherwise. Prints the cell's "
                    "scalars and whether they equal the archive's bit for bit; --plot draws "
                    "the displacements at crack height and top, the rocking pattern, the "
                    "ground motion beneath and the instability ratio; --out keeps the "
                    "histories. Exit 1 when a scalar differs from the archive's.")
    p.add_argument("archive", metavar="ARCHIVE", help="study archive (urmx run)")
    p.add_argument("--wall", required=True, help="the cell's wall")
    p.add_argument("--diaphragm", required=True, help="the cell's diaphragm")
    p.add_argument("--record", required=True, help="the cell's record")
    p.add_argument("--cor", default=None, help="the cell's COR (needed when the archive has "
                                               "several)")
    p.add_argument("--scale", default=None,
                   help="the cell's scale (a grid's scale dimension); for an IDA archive the "
                        "factor on the record (default: its scale factor at collapse)")
    p.add_argument("--impact", default=None, help="the cell's impact law (when a dimension)")
    p.add_argument("--damping", default=None, help="the cell's damping (when a dimension)")
    p.add_argument("--study", default=None, metavar="STUDY.toml",
                   help="the study file, when the archive's own study text cannot find its "
                        "record files from the archive's folder")
    p.add_argument("--records", metavar="DIR",
                   help="records directory for manifest ids (default $URMX_RECORDS)")
    p.add_argument("--plot", metavar="FILE.png", help="draw the cell here")
    p.add_argument("--out", metavar="FILE.nc", help="write the cell's Dataset (with "
                                                    "histories) here")
    p.set_defaults(handler=_show)


def _show(args) -> int:
    from ..analysis.recompute import compare, compared, not_run, recompute
    from ..errors import InputError, check_output

    for option, path in (("--out", args.out), ("--plot", args.plot)):
        if path:
            check_output(path, option, inputs=[("the archive", args.archive)],
                         utf8=option == "--out")
    if args.out and args.plot and check_output(args.out) == check_output(args.plot):
        raise InputError(f"--out and --plot name the same file {args.out!r}")
    ds, cell = recompute(args.archive, args.wall, args.diaphragm, args.record, cor=args.cor,
                         scale=args.scale, impact=args.impact, damping=args.damping,
                         records_dir=args.records, study_file=args.study)
    where = " ".join(f"{k} {v}" for k, v in cell.items())
    print(f"{args.archive}: {where}: status {ds.attrs['status']}, "
          f"{ds.attrs['events']} events, analysed {ds.attrs['duration']:.6g} s")
    from .simulate import scalar_table

    values = {n: ds[n].item() for n in ds.data_vars if ds[n].ndim == 0}
    print(scalar_table(values))
    skipped = not_run(args.archive, cell)
    differ = {} if skipped else compare(args.archive, cell, ds)
    n = 0 if skipped else compared(args.archive, cell)
    if skipped:
        print("the study did not run this cell (not among its pairs): nothing to compare")
    if n:
        print(f"the archive's {n} scalars of this cell: " + (
            "reproduced bit for bit" if not differ else
            f"{len(differ)} differ: " + ", ".join(f"{k} (archive {a!r}, now {b!r})"
                                                  for k, (a, b) in differ.items())))
    if args.out:
        from ..netcdf import write_netcdf

        print(f"wrote {write_netcdf(ds, args.out)}")
    if args.plot:
        _plot(ds, cell, args)
    return 1 if differ else 0


def _plot(ds, cell: dict, args) -> None:
    from ..errors import writing
    from ..plot import plot_cell

    title = (f"{ds.attrs.get('study_name', '')}: wall {cell['wall']} on {cell['diaphragm']}, "
             f"record {cell['record']}" + "".join(f", {k} {v}" for k, v in cell.items()
                                                  if k not in ("wall", "diaphragm", "record"))
             + f" (scale {ds.attrs['scale']:.4g} on the record file); status "
             f"{ds.attrs['status']}")
    with writing(args.plot, "figure"):
        plot_cell(ds, title)[0].figure.savefig(args.plot, dpi=110)
    print(f"wrote {args.plot}")
