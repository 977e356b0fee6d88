"""``urmx export ARCHIVE --format csv|parquet [--out FILE] [--where wall=s12,record=elcentro]``:
a study archive as one table, one row per cell (`urmx.study.table`)."""

from __future__ import annotations

import sys


def register(sub) -> None:
    p = sub.add_parser(
        "export", help="an archive as a table (CSV or Parquet): one row per cell",
        description="Write a study archive as one table a spreadsheet or pandas opens: one "
                    "row per cell, with every label (wall, diaphragm, record, cor, ...) and "
                    "every scalar output and item property, units in the header "
                    "(`name [units]`; in Parquet also each field's metadata), the analysis "
                    "status as text. Time histories are left out (urmx show draws one "
                    "cell's). In Python: urmx.study.to_dataframe(archive).")
    p.add_argument("archive", metavar="ARCHIVE", help="study archive (netCDF)")
    p.add_argument("--format", choices=("csv", "parquet"), default="csv",
                   help="csv (default) or parquet (needs pyarrow: pip install urmx[parquet])")
    p.add_argument("--out", metavar="FILE", default=None,
                   help="file to write (default: the archive's file name with .csv or .parquet, "
                        "in the current folder; "
                        "'-' writes CSV to standard output)")
    p.add_argument("--where", metavar="DIM=LABEL,...", default=None,
                   help="only these cells, e.g. wall=s12,record=elcentro (a dimension "
                        "named twice keeps both labels)")
    p.set_defaults(handler=_export)


def _export(args) -> int:
    from pathlib import Path

    from ..errors import InputError, check_output, writing
    from ..study.table import need_pyarrow, parse_where, to_dataframe, write_table

    where = parse_where(args.where)  # a bad --where is said before the archive is read
    if args.format == "parquet":
        need_pyarrow()
        if args.out == "-":
            raise InputError("--out -: standard output takes CSV only; give a file for "
                             "parquet")
    if args.out == "-":
        to_dataframe(args.archive, where).to_csv(sys.stdout, index=False)
        return 0
    out = args.out or str(Path(args.archive).with_suffix(f".{args.format}").name)
    check_output(out, "--out", inputs=[("the archive", args.archive)])
    with writing(out, "table"):
        n = write_table(args.archive, out, args.format, where)
    print(f"wrote {out}: {n} rows", file=sys.stderr)
    print(out)
    return 0
