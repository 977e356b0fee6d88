"""A look at any study archive: what it holds and how it was made (:func:`info`, ``urmx
info``), and what differs between two archives beyond a tolerance (:func:`diff`, ``urmx
diff``), for every study kind and for ``urmx simulate`` archives.

Both are kind-blind: an archive's kind is read from the study definition it carries (its
``[study.<table>]`` tables, as `urmx.study.kinds.select` reads a study file), and its cell
counts come from the kind's ``counts`` (`urmx.study.kinds`). Provenance is every global
attribute the archive has and every coordinate along one dimension (the items'
properties: a record's file and checksum where the archive holds them), printed as found.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from ..errors import InputError
from ..markdown import number
from . import kinds
from .archive import open_archive

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib
from ..errors import got

#: cells listed per differing variable by `format_diff`
LISTED = 10
#: rows of an item table `format_info` prints per dimension
ROWS = 60


def _open(archive: Any) -> tuple[xr.Dataset, str]:
    """(the loaded Dataset, its name) of a path or a Dataset."""
    if isinstance(archive, xr.Dataset):
        return archive, "(Dataset)"
    if not isinstance(archive, (str, os.PathLike)):
        raise InputError(f"archive must be a study archive's file name or an "
                         f"xarray.Dataset, got {got(archive)}")
    return open_archive(archive, "archive"), str(archive)


def kind_of(ds: xr.Dataset) -> str | None:
    """The kind of a study archive: from the ``[study.<table>]`` tables of the study
    definition it carries (attribute ``study``), else the first kind whose ``counts``
    recognises it; None for an archive of no study (``urmx simulate``)."""
    registered = kinds.registered()
    try:
        study = tomllib.loads(str(ds.attrs.get("study", ""))).get("study", {})
    except tomllib.TOMLDecodeError:
        study = {}
    if isinstance(study, dict) and study:
        present = {k for k, v in study.items() if isinstance(v, dict) and k in kinds.tables()}
        found = kinds.fitting(present) if present else [k for k in registered
                                                        if k.table is None]
        if found:
            return found[0].name
    found = [k for k in registered if k.counts is not None and k.counts(ds) is not None]
    return found[0].name if found else None


def cell_counts(ds: xr.Dataset, kind: str | None) -> dict[str, int]:
    """How many cells end in each way (the kind's ``counts``; empty when the kind has
    none or `ds` is not a study archive)."""
    if kind is None:
        return {}
    counter = kinds.get(kind).counts
    found = counter(ds) if counter is not None else None
    return dict(found) if found else {}


def _no_value(values: np.ndarray) -> bool:
    """A coordinate that holds no value at all (every entry NaN: a diaphragm property of
    the ``specimen`` diaphragm, whose walls bring their own)."""
    return values.dtype.kind == "f" and bool(np.isnan(values).all())


def _item_coords(ds: xr.Dataset) -> dict[str, dict[str, list]]:
    """dimension -> {coordinate -> values} of the coordinates along that dimension alone
    (its labels first), for dimensions that have more than their labels; then ``wall,
    diaphragm`` -> the coordinates over both (each wall's supports on each diaphragm:
    its frequency, and on its own supports their stiffness, mass and damping), a row
    per cell. Coordinates with no value at all are left out."""
    out: dict[str, dict[str, list]] = {}
    for dim in ds.dims:
        names = [n for n, c in ds.coords.items() if c.dims == (dim,) and n != dim
                 and not _no_value(np.asarray(c.values))]
        if names:
            labels = ds[dim].values.tolist() if dim in ds.coords else list(range(ds.sizes[dim]))
            out[str(dim)] = {str(dim): labels, **{n: ds[n].values.tolist() for n in names}}
    pair = ("wall", "diaphragm")
    names = [n for n, c in ds.coords.items() if c.dims == pair]
    if names and all(d in ds.coords for d in pair):
        grid = ds[names[0]]
        rows = {d: np.broadcast_to(grid[d].values[:, None] if d == "wall" else
                                   grid[d].values[None, :], grid.shape).ravel().tolist()
                for d in pair}
        out["wall, diaphragm"] = {**rows, **{n: np.asarray(ds[n].transpose(*pair).values)
                                             .ravel().tolist() for n in names}}
    return out


def info(archive: str | os.PathLike | xr.Dataset) -> dict[str, Any]:
    """What an archive holds and how it was made.

    Parameters
    ----------
    archive : path or Dataset
        A study archive (any kind) or an ``urmx simulate`` archive.

    Returns
    -------
    dict
        ``path``; ``file_size`` [bytes] (None for a Dataset); ``kind`` (the registered
        kind's name, ``grid`` ..., None for no study); ``study_name``, ``title``; ``dims``
        {name: size}; ``cells`` {way: count} (the kind's ``counts``: ``ok``,
        ``collapsed``, ``event-limit``, ``not-run`` for a grid) and ``total_cells``;
        ``variables`` {name: {dims, dtype, units, long_name}};
        ``items`` {dimension: {coordinate: values}} (the items' properties, per-record
        provenance among them where the archive has it); ``attrs`` (every global
        attribute: the provenance the archive carries).
    """
    ds, name = _open(archive)
    kind = kind_of(ds)
    cells = cell_counts(ds, kind)
    variables = {str(n): {"dims": [str(d) for d in v.dims], "dtype": str(v.dtype),
                          "units": str(v.attrs.get("units", "")),
                          "long_name": str(v.attrs.get("long_name", ""))}
                 for n, v in ds.data_vars.items()}
    return {
        "path": name,
        "file_size": None if isinstance(archive, xr.Dataset) else Path(archive).stat().st_size,
        "kind": kind,
        "study_name": ds.attrs.get("study_name"),
        "title": ds.attrs.get("title"),
        "dims": {str(d): int(n) for d, n in ds.sizes.items()},
        "cells": cells,
        "total_cells": sum(cells.values()),
        "variables": variables,
        "items": _item_coords(ds),
        "attrs": {str(k): _plain(v) for k, v in ds.attrs.items()},
    }


def _plain(value: Any) -> Any:
    """An attribute as a plain Python value (numpy scalars and arrays unwrapped)."""
    if isinstance(value, np.ndarray):
        return value.tolist()
    return value.item() if isinstance(value, np.generic) else value


def _size(n: int | None) -> str:
    if n is None:
        return "in memory"
    return f"{n / 2**20:.3g} MiB" if n >= 2**20 else f"{n / 2**10:.3g} KiB"


def _cell(value: Any) -> str:
    """A value for a line of text: numbers to 6 significant digits, NaN as ``nan``."""
    if isinstance(value, float):
        return "nan" if np.isnan(value) else number(value, 6)
    return str(value)


def format_info(found: dict[str, Any]) -> str:
    """`info` as the text ``urmx info`` prints.

    Parameters
    ----------
    found : dict
        What :func:`info` returned.
    """
    kind = f"{found['kind']} archive" if found["kind"] else "archive of no study"
    head = f"{found['path']}: {kind}"
    if found["study_name"]:
        head += f" of study {found['study_name']!r}"
    lines = [head + f" ({_size(found['file_size'])})"]
    if found["title"] and found["title"] != found["study_name"]:
        lines.append(f"title: {found['title']}")
    lines.append("dimensions: " + ", ".join(f"{d} {n}" for d, n in found["dims"].items()))
    if found["cells"]:
        lines.append(f"cells: {found['total_cells']} (" + ", ".join(
            f"{k} {v}" for k, v in found["cells"].items()) + ")")
    lines.append("variables:")
    for name, v in found["variables"].items():
        unit = f" [{v['units']}]" if v["units"] else ""
        lines.append(f"  {name}({', '.join(v['dims'])}) {v['dtype']}{unit} {v['long_name']}")
    lines.append("provenance:")
    for key, value in found["attrs"].items():
        text = str(value)
        if "\n" in text:
            lines.append(f"  {key}: ({len(text.splitlines())} lines)")
            lines += [f"    | {line}".rstrip() for line in text.splitlines()]
        else:
            lines.append(f"  {key}: {text}")
    for dim, coords in found["items"].items():
        lines.append(f"{dim}:")
        names = list(coords)
        rows = list(zip(*coords.values(), strict=True))
        lines.append("  " + " | ".join(names))
        lines += ["  " + " | ".join(_cell(c) for c in r) for r in rows[:ROWS]]
        if len(rows) > ROWS:
            lines.append(f"  ... {len(rows) - ROWS} more")
    return "\n".join(lines)


# ---- diff --------------------------------------------------------------------------------------

def _labels(ds: xr.Dataset, dim: str) -> list:
    return ds[dim].values.tolist() if dim in ds.coords else list(range(ds.sizes[dim]))


def _dims_diff(a: xr.Dataset, b: xr.Dataset) -> list[dict]:
    """The dimensions that differ: present in one archive only, or labels present in one
    only (a dimension without labels: its size)."""
    out = []
    for dim in [*a.dims, *(d for d in b.dims if d not in a.dims)]:
        if dim not in b.dims or dim not in a.dims:
            out.append({"dimension": str(dim), "only_in": "A" if dim in a.dims else "B"})
            continue
        la, lb = _labels(a, dim), _labels(b, dim)
        if la == lb:
            continue
        sa, sb = set(map(str, la)), set(map(str, lb))
        out.append({"dimension": str(dim), "only_in_a": [x for x in la if str(x) not in sb],
                    "only_in_b": [x for x in lb if str(x) not in sa],
                    "order": sa == sb})
    return out


def _differs(x: np.ndarray, y: np.ndarray, rtol: float, atol: float) -> np.ndarray:
    """Where two arrays differ: numbers beyond ``atol + rtol*|y|`` (NaN equals NaN, NaN
    differs from a number), anything else by equality."""
    if x.dtype.kind in "fiub" and y.dtype.kind in "fiub":
        x, y = x.astype(np.float64), y.astype(np.float64)
        same = (x == y) | (np.isnan(x) & np.isnan(y))  # infinities of one sign too
        with np.errstate(invalid="ignore"):
            close = np.abs(x - y) <= atol + rtol * np.abs(y)
        return ~(close | same)
    return np.asarray(x != y)


def _var_diff(name: str, a: xr.DataArray, b: xr.DataArray, rtol: float, atol: float,
              listed: int) -> dict | None:
    """How a variable differs over the labels both archives have (None: it does not)."""
    if a.dims != b.dims:
        return {"name": name, "dims": ([str(d) for d in a.dims], [str(d) for d in b.dims])}
    x, y = np.asarray(a.values), np.asarray(b.values)
    mask = _differs(x, y, rtol, atol)
    n = int(mask.sum())
    if not n:
        return None
    out: dict[str, Any] = {"name": name, "cells": n, "of": int(mask.size),
                           "units": str(a.attrs.get("units", b.attrs.get("units", "")))}
    if x.dtype.kind in "fiub" and y.dtype.kind in "fiub":
        xs, ys = x[mask].astype(np.float64), y[mask].astype(np.float64)
        with np.errstate(invalid="ignore", divide="ignore"):
            d = np.abs(xs - ys)
            out["max_abs"] = float(np.nanmax(d)) if np.isfinite(d).any() else np.nan
            rel = d / np.abs(ys)
            out["max_rel"] = float(np.nanmax(rel)) if np.isfinite(rel).any() else np.nan
    out["listed"] = []
    for idx in np.argwhere(mask)[:listed]:
        where = {str(dim): _labels_at(a, dim, i) for dim, i in zip(a.dims, idx, strict=True)}
        out["listed"].append({"at": where, "a": _plain(x[tuple(idx)]),
                              "b": _plain(y[tuple(idx)])})
    return out


def _labels_at(da: xr.DataArray, dim: str, i: int) -> Any:
    return _plain(da[dim].values[i]) if dim in da.coords else int(i)


def diff(a: str | os.PathLike | xr.Dataset, b: str | os.PathLike | xr.Dataset,
         rtol: float = 1e-9, atol: float = 0.0, listed: int = LISTED) -> dict[str, Any]:
    """What differs between two archives beyond a tolerance.

    Variables and coordinates are compared over the labels both archives have; a number
    differs when ``|a - b| > atol + rtol * |b|`` (NaN equals NaN), anything else when it is
    not equal. Global attributes (the time, the command line, the urmx version) are listed
    when they differ but do not count as a difference.

    Parameters
    ----------
    a, b : path or Dataset
        Archives (any study kind, or ``urmx simulate`` archives).
    rtol : float
        Relative tolerance. [1]
    atol : float
        Absolute tolerance. [each variable's own units]
    listed : int
        Differing cells listed per variable (all are counted).

    Returns
    -------
    dict
        ``a``, ``b`` (names), ``rtol``, ``atol``; ``dimensions`` (dimensions or labels in
        one archive only), ``only_in_a``, ``only_in_b`` (variable and coordinate names),
        ``variables`` (per differing variable or coordinate: ``name``, ``cells`` differing
        of ``of``, ``max_abs``, ``max_rel``, ``units`` and the first `listed` cells with
        their labels and both values, or ``dims`` when its dimensions differ),
        ``attributes`` (global attributes that differ, not counted) and ``differ`` (bool).
    """
    if not (rtol >= 0 and atol >= 0):
        raise InputError(f"rtol={rtol!r} and atol={atol!r} must be numbers >= 0")
    (da, na), (db, nb) = _open(a), _open(b)
    dims = _dims_diff(da, db)
    names_a = [str(n) for n in (*da.data_vars, *da.coords) if n not in da.dims]
    names_b = [str(n) for n in (*db.data_vars, *db.coords) if n not in db.dims]
    shared = [n for n in names_a if n in names_b]
    ia, ib = xr.align(da, db, join="inner")  # the labels both have
    variables = [d for d in (_var_diff(n, ia[n], ib[n], rtol, atol, listed) for n in shared)
                 if d is not None]
    attributes = sorted(str(k) for k in {*da.attrs, *db.attrs}
                        if str(_plain(da.attrs.get(k))) != str(_plain(db.attrs.get(k))))
    only_a = [n for n in names_a if n not in names_b]
    only_b = [n for n in names_b if n not in names_a]
    return {"a": na, "b": nb, "rtol": rtol, "atol": atol, "dimensions": dims,
            "only_in_a": only_a, "only_in_b": only_b, "variables": variables,
            "attributes": attributes,
            "differ": bool(dims or only_a or only_b or variables)}


def _where(at: dict) -> str:
    return " ".join(f"{k}={_cell(v)}" for k, v in at.items())


def format_diff(found: dict[str, Any]) -> str:
    """`diff` as the text ``urmx diff`` prints.

    Parameters
    ----------
    found : dict
        What :func:`diff` returned.
    """
    lines = [f"A {found['a']}", f"B {found['b']}",
             f"tolerance: |A - B| <= {found['atol']:g} + {found['rtol']:g} * |B|"]
    for d in found["dimensions"]:
        if "only_in" in d:
            lines.append(f"dimension {d['dimension']}: only in {d['only_in']}")
        elif d["order"]:
            lines.append(f"dimension {d['dimension']}: the same labels in another order")
        else:
            lines.append(f"dimension {d['dimension']}: only in A {_short(d['only_in_a'])}, "
                         f"only in B {_short(d['only_in_b'])}")
    for side in ("a", "b"):
        if found[f"only_in_{side}"]:
            lines.append(f"only in {side.upper()}: {', '.join(found[f'only_in_{side}'])}")
    for v in found["variables"]:
        lines += _variable_lines(v)
    if found["attributes"]:
        lines.append(f"attributes that differ (not compared): {', '.join(found['attributes'])}")
    counted = [(len(found["dimensions"]), "dimension"), (len(found["variables"]), "variable"),
               (len(found["only_in_a"]) + len(found["only_in_b"]), "unpaired name")]
    lines.append("differ: " + ", ".join(f"{n} {what}" + ("s" if n > 1 else "")
                                        for n, what in counted if n)
                 if found["differ"] else "no differences beyond the tolerance")
    return "\n".join(lines)


def _short(values: list) -> str:
    return "[" + ", ".join(map(_cell, values[:8])) + (", ...]" if len(values) > 8 else "]")


def _variable_lines(v: dict) -> list[str]:
    if "dims" in v:
        return [f"{v['name']}: dimensions ({', '.join(v['dims'][0])}) in A, "
                f"({', '.join(v['dims'][1])}) in B"]
    unit = f" {v['units']}" if v["units"] and v["units"] != "1" else ""
    size = ""
    if "max_abs" in v:
        size = f" (max |A - B| {number(v['max_abs'], 3)}{unit}, max relative " \
               f"{number(v['max_rel'], 3)})"
    lines = [f"{v['name']}: {v['cells']} of {v['of']} cells differ{size}"]
    lines += [f"  {_where(c['at'])}: A {_cell(c['a'])}, B {_cell(c['b'])}" for c in v["listed"]]
    if v["cells"] > len(v["listed"]):
        lines.append(f"  ... {v['cells'] - len(v['listed'])} more")
    return lines
