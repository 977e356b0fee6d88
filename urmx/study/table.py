"""A study archive as one tidy table: one row per cell, every label and scalar output
(``urmx export``, :func:`to_dataframe`).

The cells are those of the archive's largest output over the study's dimensions (``wall``,
``diaphragm``, ``record``, ``cor`` and any of ``scale``, ``impact``, ``damping``,
``sample``); a cell's kept time history and a cell's curve over steps (variables along
``history``, ``time`` or an ``..._step`` dimension) are not scalars and are left out. The
columns are the labels of those dimensions, then every coordinate and data variable over
some of them (an item's property, such as a wall's slenderness or a record's PGA, repeated
on each of its cells; a per-wall result, such as a fitted median, on each of the wall's
cells), each named ``name [units]`` when it has units; ``status`` (a grid's analysis
status) is the text of its ``flag_meanings`` (``ok``, ``collapsed``, ``event_limit``,
``not_run``). An empty text (a record without a channel) is a missing value, as a CSV
reader reads it back.
"""

from __future__ import annotations

import os
from typing import Any

import numpy as np
import xarray as xr

from ..errors import InputError, path_argument
from .archive import open_archive

#: dimensions of what a cell keeps beside its scalars (not rows of the table)
PER_CELL = ("history", "time")


def _per_cell(dim: Any) -> bool:
    return str(dim) in PER_CELL or str(dim).endswith("_step")


def cell_dims(ds: xr.Dataset) -> list[str]:
    """The dimensions of the archive's cells: those of its output over the most study
    dimensions (``status`` for a grid), in the archive's order."""
    scalars = [v for v in ds.data_vars.values() if v.ndim and not any(map(_per_cell, v.dims))]
    if not scalars:
        raise InputError("the archive holds no output over study dimensions: nothing to "
                         "tabulate")
    widest = max(scalars, key=lambda v: (v.ndim, v.name == "status"))
    return [str(d) for d in widest.dims]


def select(ds: xr.Dataset, where: dict[str, list[str]] | None) -> xr.Dataset:
    """The cells whose labels match `where` ({dimension: [labels as text]}); a number
    label matches its value (``cor=0.8``). An unknown dimension or label is an
    `InputError` naming the known ones."""
    if not where:
        return ds
    picked = {}
    for dim, wanted in where.items():
        if dim not in ds.dims or dim not in ds.coords:
            raise InputError(f"--where {dim}=...: the archive has no dimension {dim!r} "
                             f"(it has {', '.join(map(str, ds.dims))})")
        labels = ds[dim].values
        idx = []
        for text in wanted:
            hit = [i for i, v in enumerate(labels) if _same(v, text)]
            if not hit:
                shown = ", ".join(str(v) for v in labels[:12])
                raise InputError(f"--where {dim}={text}: no such {dim} in the archive "
                                 f"({shown}{', ...' if labels.size > 12 else ''})")
            idx += hit
        picked[dim] = sorted(set(idx))
    return ds.isel(picked)


def _same(label: Any, text: str) -> bool:
    if isinstance(label, (float, np.floating, int, np.integer)):
        try:
            return float(label) == float(text)
        except ValueError:
            return False
    return str(label) == text


def parse_where(text: str | None) -> dict[str, list[str]]:
    """``wall=s12,record=elcentro`` as {dimension: [labels]}; a dimension named twice
    keeps both labels (``wall=s12,wall=s16``)."""
    out: dict[str, list[str]] = {}
    for part in (text or "").split(","):
        if not part.strip():
            continue
        key, sep, value = part.partition("=")
        if not sep or not key.strip() or not value.strip():
            raise InputError(f"--where {text!r}: {part.strip()!r} is not DIMENSION=LABEL "
                             "(e.g. --where wall=s12,record=elcentro)")
        out.setdefault(key.strip(), []).append(value.strip())
    return out


def column_name(da: xr.DataArray, name: str) -> str:
    """``name [units]``, or the name of a quantity without units."""
    units = str(da.attrs.get("units", "")).strip()
    return f"{name} [{units}]" if units else name


def _values(da: xr.DataArray) -> np.ndarray:
    """A column's values: status codes as their text, empty text as missing (NaN)."""
    values = np.asarray(da.values)
    meanings = str(da.attrs.get("flag_meanings", "")).split()
    if da.name == "status" and meanings:
        codes = np.asarray(da.attrs.get("flag_values", np.arange(len(meanings)))).tolist()
        lookup = dict(zip(codes, meanings, strict=False))
        return np.array([lookup.get(int(v), np.nan) if np.isfinite(v) else np.nan
                         for v in values.astype(float).ravel()], dtype=object
                        ).reshape(values.shape)
    if values.dtype.kind in "OUS":
        return np.array([np.nan if str(v) == "" else str(v) for v in values.ravel()],
                        dtype=object).reshape(values.shape)
    return values


def to_dataframe(archive: str | os.PathLike | xr.Dataset, where: Any = None):
    """The cells of a study archive as a `pandas.DataFrame`: one row per cell (the
    module's docstring says which columns), what ``urmx export`` writes.

    Parameters
    ----------
    archive : path or Dataset
        A study archive of any kind (`urmx.open_study`).
    where : str or dict, optional
        Cells to keep: ``"wall=s12,record=elcentro"`` or {dimension: [labels]}.

    Returns
    -------
    pandas.DataFrame
        Labels first (in the archive's dimension order, the last varying fastest), then
        coordinates and outputs in the archive's order; a default RangeIndex.
    """
    import pandas as pd


    if not isinstance(archive, xr.Dataset):
        path_argument("to_dataframe", "archive", archive)
    ds = open_archive(archive)
    ds = select(ds, parse_where(where) if isinstance(where, str) or where is None else where)
    dims = cell_dims(ds)
    grid = xr.Dataset(coords={d: ds[d] for d in dims if d in ds.coords})
    columns: dict[str, np.ndarray] = {}
    for d in dims:
        labels = ds[d] if d in ds.coords else xr.DataArray(np.arange(ds.sizes[d]), dims=d)
        columns[column_name(labels, d)] = _flat(labels, dims, grid)
    names = [n for n in ds.coords if n not in ds.dims] + list(ds.data_vars)
    for n in names:
        da = ds[n]
        if not da.ndim or not set(da.dims) <= set(dims):
            continue
        columns[column_name(da, str(n))] = _flat(da, dims, grid)
    for name, values in columns.items():
        if values.dtype == object and pd.isna(values).all():  # no text at all: missing
            columns[name] = values.astype(np.float64)
    return pd.DataFrame(columns)


def _flat(da: xr.DataArray, dims: list[str], grid: xr.Dataset) -> np.ndarray:
    """`da` broadcast over the cells (`dims`, C order) and flattened."""
    values = _values(da)
    full = xr.DataArray(values, dims=da.dims)
    shape = {d: grid.sizes.get(d, da.sizes.get(d)) for d in dims}
    out = full.expand_dims({d: n for d, n in shape.items() if d not in da.dims})
    return np.asarray(out.transpose(*dims).values).ravel()


def write_table(archive: Any, out: str | os.PathLike, fmt: str = "csv", where: Any = None
                ) -> int:
    """Write :func:`to_dataframe` of `archive` to `out` as CSV (units in the header,
    a missing value as an empty field, floats as Python writes them: exactly read back)
    or Parquet (units in each field's metadata and the column name; needs pyarrow: ``pip
    install urmx[parquet]``). Returns the number of rows."""
    df = to_dataframe(archive, where)
    if fmt == "csv":
        df.to_csv(out, index=False, float_format=None)
    elif fmt == "parquet":
        _write_parquet(df, out)
    else:
        raise InputError(f"--format {fmt!r}: csv or parquet")
    return len(df)


def need_pyarrow() -> Any:
    """pyarrow, or a one-line `InputError` saying how to install it."""
    try:
        import pyarrow
        import pyarrow.parquet  # noqa: F401
    except ImportError:
        raise InputError("--format parquet needs pyarrow: pip install 'urmx[parquet]' (or "
                         "pip install pyarrow), or use --format csv") from None
    return pyarrow


def _write_parquet(df, out: str | os.PathLike) -> None:
    pa = need_pyarrow()
    table = pa.Table.from_pandas(df, preserve_index=False)
    fields = []
    for f in table.schema:
        name, _, units = f.name.partition(" [")
        meta = {"units": units.rstrip("]")} if units else {}
        fields.append(f.with_metadata(meta) if meta else f)
    table = table.cast(pa.schema(fields, metadata=table.schema.metadata))
    pa.parquet.write_table(table, out)
