"""General reductions of a study Dataset (peaks against slenderness, instability ratios,
histories, segment stability, best-matching COR, frequency against a record's range).

The paper's own numbers, its defaults (record, wall, COR) and its findings are not here:
they live in :mod:`urmx.paper` and ``catalog/paper.toml``; every choice is an argument.

Every function takes a study Dataset (the schema of ``urmx.study``: dims ``wall``,
``diaphragm``, ``record``, ``cor`` and optional extra dims) and dimension *names*, and
returns a labelled xarray object whose variables carry ``units`` and ``long_name``.
A piece the Dataset lacks raises :class:`MissingDataError` naming what is missing.

Selection rules shared by all reductions (:func:`select`):

- ids are matched case-insensitively, then as a unique substring (``"kobe"`` finds
  ``"kobe_nis000"``);
- ``cor`` is taken nearest to the requested value (its first value when none is given, noted
  in ``attrs["selection"]``);
- any other extra dimension (``scale``, ``impact``, ...) that the caller does not keep
  is taken at its first value, and the choice is written to ``attrs["selection"]``;
- cells without a valid result (``status`` other than ok/collapsed: not run, event-limit)
  are NaN in every output (:func:`valid_cells`), so means, sums, counts and correlations
  skip them.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence

import numpy as np
import xarray as xr
from scipy.stats import rankdata

from ..errors import InputError, UrmxError
from ..model import Wall
from ..variables import SCALARS, stamp
from ..variables import attrs as registry_attrs

GRID_DIMS = ("wall", "diaphragm", "record", "cor")

class MissingDataError(UrmxError, ValueError):
    """The study Dataset lacks a variable, coordinate or cell a reduction needs."""


# ---- helpers --------------------------------------------------------------------------

def _require(ds: xr.Dataset, names: Iterable[str], what: str) -> None:
    missing = [n for n in names if n not in ds.variables]
    if missing:
        raise MissingDataError(f"{what} needs {', '.join(missing)} in the study Dataset")


VALID_STATUS = ("ok", "collapsed")  # the statuses whose outputs are results


def valid_cells(ds: xr.Dataset) -> xr.Dataset:
    """The study with every output of a cell whose ``status`` is not ok or collapsed set to
    NaN (integer outputs become float), so that reductions skip those cells.

    ``status`` may be the codes of ``urmx.study.STATUS`` (0 ok, 1 collapsed, 2 event-limit,
    3 not-run) or their names. A Dataset without ``status`` is returned as it is.
    """
    if not isinstance(ds, xr.Dataset) or "status" not in ds.variables:
        return ds
    status = ds["status"]
    if status.dtype.kind in "OUS":
        ok = status.isin(list(VALID_STATUS))
    else:
        ok = status.isin([0, 1])
    out = ds.copy()
    for name in ds.data_vars:
        if name in SCALARS and set(status.dims) <= set(ds[name].dims):
            out[name] = ds[name].where(ok).assign_attrs(ds[name].attrs)
    return out


def match_id(ds: xr.Dataset, dim: str, wanted: str) -> str:
    """The id along ``dim`` equal to ``wanted`` (case-insensitive) or containing it."""
    if dim not in ds.dims:
        raise MissingDataError(f"the study Dataset has no {dim!r} dimension")
    values = [str(v) for v in ds[dim].values]
    low = [v.lower() for v in values]
    key = str(wanted).lower()
    if key in low:
        return values[low.index(key)]
    hits = [v for v, lo in zip(values, low, strict=True) if key in lo]
    if len(hits) == 1:
        return hits[0]
    raise MissingDataError(f"no {dim} {wanted!r} in the study (it has {', '.join(values)})")


def select(ds, keep: Sequence[str] = (), cor: float | None = None, **ids: str):
    """One slice of a study: ``ids`` by name (e.g. ``record="kobe"``), ``cor`` nearest (the
    first when None), extra dimensions not in ``keep`` at their first value."""
    out = ds
    for dim, wanted in ids.items():
        out = out.sel({dim: match_id(out, dim, wanted)})
    notes = []
    if "cor" in out.dims and "cor" not in keep:
        if cor is None:
            if out.sizes["cor"] > 1:
                notes.append(f"cor={float(out['cor'].values[0]):g}")
            out = out.isel(cor=0)
        else:
            out = out.sel(cor=cor, method="nearest")
    for dim in list(out.dims):
        if dim in keep or dim in GRID_DIMS or dim in ("history", "time"):
            continue
        first = out[dim].values[0] if dim in out.coords else 0
        notes.append(f"{dim}={first}")
        out = out.isel({dim: 0})
    if notes:
        out.attrs = {**out.attrs, "selection": ", ".join(notes)}
    return out


def nearest_wall(ds: xr.Dataset, height: float, rtol: float = 0.02) -> str:
    """Id of the wall whose ``height(wall)`` is nearest ``height`` (within ``rtol``)."""
    _require(ds, ["height"], "choosing a wall by height")
    h = np.asarray(ds["height"].values, dtype=float)
    i = int(np.nanargmin(np.abs(h - height)))
    if abs(h[i] - height) > rtol * height:
        raise MissingDataError(f"no wall {height:g} m high in the study (nearest {h[i]:g} m)")
    return str(ds["wall"].values[i])


def spearman(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Spearman rank correlation along the last axis (numpy core); NaN pairs dropped."""
    x, y = np.broadcast_arrays(x, y)
    flat_x = x.reshape(-1, x.shape[-1])
    flat_y = y.reshape(-1, y.shape[-1])
    out = np.full(flat_x.shape[0], np.nan)
    for i, (a, b) in enumerate(zip(flat_x, flat_y, strict=True)):
        ok = ~(np.isnan(a) | np.isnan(b))
        if ok.sum() < 3:
            continue
        ra, rb = rankdata(a[ok]), rankdata(b[ok])
        if np.ptp(ra) == 0 or np.ptp(rb) == 0:
            continue
        out[i] = np.corrcoef(ra, rb)[0, 1]
    return out.reshape(x.shape[:-1])


# ---- reductions -----------------------------------------------------------------------

def rank_correlation(da: xr.DataArray, coord: str, dim: str) -> xr.DataArray:
    """Spearman rank correlation of ``da`` with coordinate ``coord`` along ``dim``.

    Parameters
    ----------
    da : DataArray
        A response, e.g. ``instability_ratio``.
    coord : str
        A coordinate along ``dim`` (``slenderness`` along ``wall``, ``stiffness`` along
        ``diaphragm``; an infinite stiffness ranks as the stiffest).
    dim : str
        The dimension correlated over.

    Returns
    -------
    DataArray named ``rank_correlation`` over the other dims. [1]
    """
    if coord not in da.coords:
        raise MissingDataError(f"rank correlation needs the coordinate {coord!r}")
    x, y = xr.broadcast(da.astype(float).compute(), da[coord].astype(float).compute())
    rho = xr.apply_ufunc(spearman, x, y, input_core_dims=[[dim], [dim]])
    rho = rho.rename("rank_correlation").drop_vars(coord, errors="ignore")
    rho.attrs = {**registry_attrs("rank_correlation"), "long_name": f"Spearman rank "
                 f"correlation of {da.attrs.get('long_name', da.name)} with {coord}"}
    return rho


def stiffness_trend(da: xr.DataArray, dim: str = "diaphragm") -> xr.DataArray:
    """Spearman correlation of ``da`` with ``stiffness(diaphragm)``: > 0 when the response
    rises with diaphragm stiffness (the measure of Figs. 6-7's trends)."""
    return rank_correlation(da, "stiffness", dim)


def peak_profiles(ds: xr.Dataset, quantity: str, record: str,
                  cor: float | None = None) -> xr.Dataset:
    """Absolute maxima at the wall top and at crack height against slenderness under one
    record, one column per diaphragm (``quantity`` ``"acceleration"`` or
    ``"displacement"``).

    Returns
    -------
    Dataset over (wall, diaphragm), sorted by ``slenderness``, with
    ``peak_top_<quantity>`` and ``peak_crack_<quantity>``. [m s-2] or [m]
    """
    if quantity not in ("acceleration", "displacement"):
        raise InputError(f"quantity must be 'acceleration' or 'displacement', not {quantity!r}")
    names = [f"peak_top_{quantity}", f"peak_crack_{quantity}"]
    _require(ds, [*names, "slenderness"], f"the peak {quantity} profile")
    ds = valid_cells(ds)
    out = select(ds[names], keep=("wall", "diaphragm"), cor=cor, record=record)
    out = stamp(out.sortby("slenderness"))
    out.attrs["record"] = str(out["record"].values)
    return out


def governing_instability(ds: xr.Dataset, cor: float | None = None) -> xr.DataArray:
    """The governing instability ratio over (record, diaphragm, wall), walls sorted by
    slenderness."""
    _require(ds, ["instability_ratio", "slenderness"], "the stability figure")
    ds = valid_cells(ds)
    out = select(ds["instability_ratio"], keep=("wall", "diaphragm", "record"), cor=cor)
    out = out.sortby("slenderness")
    out.attrs.update(registry_attrs("instability_ratio"))
    return out


def displacement_histories(ds: xr.Dataset, height: float, diaphragms: Sequence[str],
                           record: str, cor: float | None = None,
                           variables: Sequence[str] = ("top_displacement",
                                                       "crack_displacement")) -> xr.Dataset:
    """Time histories of the wall ``height`` high with several diaphragms under one record
    (``cor`` nearest; the first stored when None).

    Returns
    -------
    Dataset over (diaphragm, time) with ``variables`` (and ``pattern`` when stored);
    attrs ``wall``, ``height``, ``record``, ``cor``.
    """
    wall = nearest_wall(ds, height)
    return _histories(ds, "diaphragm", diaphragms, variables, cor,
                      wall=wall, record=record)


def verification_histories(ds: xr.Dataset, wall: str, cor: float | None = None,
                           variables: Sequence[str] = ("top_displacement",
                                                       "crack_displacement",
                                                       "base_displacement")) -> xr.Dataset:
    """Histories of one wall under every record stored for it, ``cor`` nearest (the first
    stored when None).

    Returns a Dataset over (record, time)."""
    wall = match_id(ds, "wall", wall)
    _require(ds, ["history_record"], "verification histories")
    records = sorted({str(r) for r, w in zip(ds["history_record"].values,
                                             ds["history_wall"].values, strict=True)
                      if str(w) == wall})
    if not records:
        raise MissingDataError(f"no time histories stored for wall {wall!r}")
    return _histories(ds, "record", records, variables, cor, wall=wall)


def _histories(ds, along, items, variables, cor, **fixed) -> xr.Dataset:
    """Pick one history per item of ``along``, the other labels ``fixed``, cor nearest."""
    keys = {"wall": "history_wall", "diaphragm": "history_diaphragm",
            "record": "history_record", "cor": "history_cor"}
    _require(ds, [*keys.values(), *variables], "time histories")
    fixed = {dim: match_id(ds, dim, value) for dim, value in fixed.items()}
    labels = {dim: np.asarray(ds[key].values).astype(str) for dim, key in keys.items()
              if dim != "cor"}
    hcor = np.asarray(ds["history_cor"].values, dtype=float)
    if cor is None:
        cor = float(hcor[0])
    index, found = [], []
    for item in items:
        item = match_id(ds, along, item)
        ok = np.ones(ds.sizes["history"], dtype=bool)
        for dim, value in {**fixed, along: item}.items():
            ok &= labels[dim] == value
        if not ok.any():
            continue
        cand = np.flatnonzero(ok)
        index.append(int(cand[np.argmin(np.abs(hcor[cand] - cor))]))
        found.append(item)
    if not index:
        raise MissingDataError(
            "no time histories stored for " + ", ".join(f"{k}={v}" for k, v in fixed.items())
            + f" and {along} in {', '.join(map(str, items))}")
    names = [v for v in (*variables, "pattern") if v in ds.variables]
    sub = ds[names].isel(history=index)
    sub = sub.drop_vars([c for c in sub.coords if c != "time"])
    sub = sub.rename_dims(history=along).assign_coords({along: found})
    sub.attrs = {**{k: str(v) for k, v in fixed.items()}, "cor": float(hcor[index[0]])}
    if "wall" in fixed and "height" in ds.variables:
        sub.attrs["height"] = float(ds["height"].sel(wall=fixed["wall"]))
    return stamp(sub)


def instability_displacements(ds: xr.Dataset) -> xr.Dataset:
    """Instability displacements of every (wall, diaphragm) from ``urmx.Wall``
    (Table I, MODEL.md section 3): upper ``a2*theta0`` of Case 1; lower ``a1*theta0`` of
    Case 2 (family 2, patterns 21/22) and of Case 3 (family 1, patterns 11/12).

    Needs the coords ``thickness(wall)``, ``height(wall)``, ``crack_ratio(wall)``,
    ``mass(wall)`` and ``diaphragm_mass(diaphragm)`` (the masses passed to ``urmx.Wall``,
    i.e. effective masses); theta0 does not depend on stiffness, damping or PMR.
    """
    need = ["thickness", "height", "crack_ratio", "mass", "diaphragm_mass"]
    _require(ds, need, "instability displacements (Table VI)")
    walls, diaphragms = ds["wall"].values, ds["diaphragm"].values
    out = {k: np.full((len(walls), len(diaphragms)), np.nan)
           for k in ("instability_displacement_upper", "instability_displacement_family2",
                     "instability_displacement_family1")}
    for i, w in enumerate(walls):
        row = {k: float(ds[k].sel(wall=w)) for k in need[:4]}
        for j, d in enumerate(diaphragms):
            wall = Wall(thickness=row["thickness"], height=row["height"],
                        crack_ratio=row["crack_ratio"], mass=row["mass"],
                        top_mass=float(ds["diaphragm_mass"].sel(diaphragm=d)))
            out["instability_displacement_upper"][i, j] = wall.a2 * wall.segment(1).theta0
            out["instability_displacement_family2"][i, j] = wall.a1 * wall.segment(2).theta0
            out["instability_displacement_family1"][i, j] = wall.a1 * wall.segment(3).theta0
    coords = {"wall": walls, "diaphragm": diaphragms}
    return xr.Dataset({k: xr.DataArray(v, coords, ("wall", "diaphragm"),
                                       attrs=registry_attrs(k)) for k, v in out.items()})


def stability_table(ds: xr.Dataset, height: float, diaphragms: Sequence[str], record: str,
                    cor: float | None = None) -> xr.Dataset:
    """Stability of the segments of one wall (``height`` high) with several diaphragms under
    one record (the columns of the paper's Table VI).

    Columns: (2) ``peak_lower_drift`` (crack height relative to the base) and, where the
    archive has it, ``peak_lower_drift_family1`` (the same while in patterns 11/12), (3)
    ``peak_upper_drift`` (differential top - crack), (4)-(5) ``instability_displacement_
    upper``/``_lower``, (6)-(8) ``instability_ratio_upper``/``_lower``/``instability_ratio``
    (the kernel's continuous-time ratios, MODEL.md section 10), plus
    ``unfavourable_fraction`` and ``lower_case``.

    The lower instability displacement is the one of the case (2 or 3) nearest, on a
    log scale, to ``peak_lower_drift / instability_ratio_lower``, i.e. the family in which
    the governing lower ratio was reached. Without the wall coords of
    :func:`instability_displacements` both are implied from the ratios
    (``attrs["instability_displacement_source"] = "implied"``).
    """
    names = ["peak_lower_drift", "peak_upper_drift", "instability_ratio_upper",
             "instability_ratio_lower", "instability_ratio", "unfavourable_fraction"]
    _require(ds, names, "Table VI")
    if "peak_lower_drift_family1" in ds:  # archives written by the kernel that outputs it
        names.append("peak_lower_drift_family1")
    ds = valid_cells(ds)
    wall = nearest_wall(ds, height)
    ids = [match_id(ds, "diaphragm", d) for d in diaphragms]
    cell = select(ds[names], keep=("diaphragm",), cor=cor, record=record, wall=wall)
    cell = cell.sel(diaphragm=ids)
    implied_lower = cell["peak_lower_drift"] / cell["instability_ratio_lower"]
    try:
        ins = instability_displacements(ds).sel(wall=wall, diaphragm=ids)
        lower2 = ins["instability_displacement_family2"]
        lower3 = ins["instability_displacement_family1"]
        nearer3 = (np.abs(np.log(implied_lower / lower3))
                   < np.abs(np.log(implied_lower / lower2)))
        upper = ins["instability_displacement_upper"]
        lower = xr.where(nearer3, lower3, lower2)
        case = xr.where(nearer3, 3, 2)
        source = "urmx.Wall"
    except MissingDataError as exc:
        upper = cell["peak_upper_drift"] / cell["instability_ratio_upper"]
        lower = implied_lower
        case = xr.full_like(lower, np.nan)
        source = f"implied (peak / ratio): {exc}"
    out = cell.assign(instability_displacement_upper=upper,
                      instability_displacement_lower=lower, lower_case=case)
    out = out.drop_vars([c for c in out.coords if c not in ("diaphragm",)])
    for name in out.data_vars:
        out[name].attrs = registry_attrs(name)
    out.attrs = {"wall": wall, "height": float(ds["height"].sel(wall=wall)),
                 "record": match_id(ds, "record", record),
                 "cor": float(cell["cor"]) if "cor" in cell.coords else float("nan"),
                 "instability_displacement_source": source}
    return out


def best_cor(da: xr.DataArray, target, dim: str = "cor") -> xr.Dataset:
    """The value of ``dim`` whose response is nearest ``target`` (a COR calibration).

    Parameters
    ----------
    da : DataArray
        A response over ``dim`` (e.g. ``peak_crack_displacement`` or ``collapse_time``);
        NaN (e.g. no collapse) never matches.
    target : float or DataArray
        The value to match, broadcast against ``da`` without ``dim``.

    Returns
    -------
    Dataset with ``best_cor`` (the matching coordinate value) and ``misfit``
    (``|response - target| / |target|`` there).
    """
    if dim not in da.dims:
        raise MissingDataError(f"best COR needs a {dim!r} dimension")
    target = xr.DataArray(target) if not isinstance(target, xr.DataArray) else target
    err = abs(da - target) / abs(target)
    filled = err.fillna(np.inf)
    i = filled.argmin(dim)
    best = da[dim].isel({dim: i}).drop_vars(dim, errors="ignore")
    miss = err.isel({dim: i})
    best = best.where(np.isfinite(filled.min(dim)))
    out = xr.Dataset({"best_cor": best, "misfit": miss.drop_vars(dim, errors="ignore")})
    for name in out.data_vars:
        out[name].attrs = registry_attrs(name)
    out.attrs["target_variable"] = str(da.name)
    return out


def frequency_ranges(ds: xr.Dataset, ranges: dict | None = None) -> xr.Dataset:
    """Significant frequency range of every record of ``ds``: coords
    ``frequency_low(record)``/``frequency_high(record)`` when the Dataset has them, else
    ``ranges`` (``{record id: (low, high)}`` [Hz], ids matched as by :func:`match_id`).

    Returns
    -------
    Dataset over record with ``frequency_low`` and ``frequency_high`` [Hz]; attr
    ``frequency_range_source``.
    """
    if "frequency_low" in ds.variables and "frequency_high" in ds.variables:
        lo, hi = ds["frequency_low"].values, ds["frequency_high"].values
        source = "record coords"
    else:
        if not ranges:
            raise MissingDataError("no significant frequency ranges (coords frequency_low/"
                                   "frequency_high, or ranges by record id)")
        lo, hi = [], []
        keys = {str(k).lower(): v for k, v in ranges.items()}
        for r in ds["record"].values:
            key = str(r).lower()
            hits = [k for k in keys if k == key] or [k for k in keys if k in key]
            if len(hits) != 1:
                raise MissingDataError(f"no significant frequency range for record {r!r}")
            lo.append(float(keys[hits[0]][0]))
            hi.append(float(keys[hits[0]][1]))
        source = "given ranges"
    coords = {"record": ds["record"].values}
    out = xr.Dataset({"frequency_low": ("record", np.asarray(lo, float)),
                      "frequency_high": ("record", np.asarray(hi, float))}, coords)
    for name in out.data_vars:
        out[name].attrs = registry_attrs(name)
    out.attrs["frequency_range_source"] = source
    return out


def resonance(ds: xr.Dataset, cor: float | None = None,
              ranges: dict | None = None) -> xr.Dataset:
    """Diaphragm frequency against each record's significant frequency range (see
    :func:`frequency_ranges` for ``ranges``), with the change in stability.

    Returns
    -------
    Dataset over (diaphragm, record): ``frequency`` (mean over walls when it varies by
    wall) [Hz], ``frequency_low``/``frequency_high`` [Hz], ``in_range`` (bool),
    ``range_distance`` (log10 of the ratio to the nearer bound, 0 inside) [1],
    ``mean_instability_ratio`` (mean over walls) [1], ``stability_change`` (that minus the
    stiffest diaphragm's) [1] and ``collapses`` (count over walls).
    """
    _require(ds, ["frequency", "stiffness", "instability_ratio"], "the resonance view")
    ds = valid_cells(ds)
    ranges = frequency_ranges(ds, ranges)
    freq = ds["frequency"]
    if "wall" in freq.dims:
        freq = freq.mean("wall")
    freq = xr.DataArray(np.asarray(freq.values, dtype=float),
                        {"diaphragm": freq["diaphragm"].values}, ("diaphragm",))
    ratio = governing_instability(ds, cor=cor)
    mean_ratio = ratio.mean("wall").reset_coords(drop=True)
    stiff = np.asarray(ds["stiffness"].values, dtype=float)
    ref = ds["diaphragm"].values[int(np.argmax(stiff))]
    change = mean_ratio - mean_ratio.sel(diaphragm=ref)
    lo, hi = ranges["frequency_low"], ranges["frequency_high"]
    with np.errstate(divide="ignore", invalid="ignore"):
        below = np.log10(lo / freq).clip(min=0)
        above = np.log10(freq / hi).clip(min=0)
    out = xr.Dataset({
        "frequency": freq,
        "frequency_low": lo,
        "frequency_high": hi,
        "in_range": (freq >= lo) & (freq <= hi),
        "range_distance": (below + above).transpose("diaphragm", "record"),
        "mean_instability_ratio": mean_ratio.transpose("diaphragm", "record"),
        "stability_change": change.transpose("diaphragm", "record"),
    })
    if "collapsed" in ds.variables:
        coll = select(ds["collapsed"], keep=("wall", "diaphragm", "record"), cor=cor)
        # count over walls with a valid result; NaN when none has one
        out["collapses"] = coll.sum("wall", min_count=1).reset_coords(drop=True).transpose(
            "diaphragm", "record")
    out = out.reset_coords(drop=True)
    for name in out.data_vars:
        out[name].attrs = registry_attrs(name)
    out.attrs = {"reference_diaphragm": str(ref),
                 "frequency_range_source": ranges.attrs["frequency_range_source"]}
    return out


def cor_matches(ds: xr.Dataset, targets: dict | None = None) -> xr.Dataset:
    """The COR that best matches a target response for each wall of a verification study.

    Parameters
    ----------
    ds : Dataset
        A verification study (dims wall, record, cor; a diaphragm dim of size 1 is
        dropped).
    targets : dict, optional
        ``{wall_id: (variable, value)}``, e.g. ``{"w1": ("peak_top_displacement", 0.045)}``
        (ids matched as by :func:`match_id`). Every data variable or coord
        ``measured_<variable>(wall)`` the Dataset carries (the measured peak of a test) is a
        target too, for the walls ``targets`` leaves out.

    Returns
    -------
    Dataset over (wall, record) with ``best_cor`` and ``misfit``, coords
    ``target_variable(wall)`` and ``target_value(wall)``; walls without a target have NaN.
    """
    ds = valid_cells(ds)
    given = {}
    for key, target in (targets or {}).items():
        try:
            given[match_id(ds, "wall", key)] = target
        except MissingDataError:
            pass
    targets = given
    for name in ds.variables:
        if str(name).startswith("measured_") and ds[name].dims == ("wall",):
            var = str(name)[len("measured_"):]
            for w in ds["wall"].values:
                value = float(ds[name].sel(wall=w))
                if math.isfinite(value):
                    targets.setdefault(str(w), (var, value))
    walls = [str(w) for w in ds["wall"].values]
    best = np.full((len(walls), ds.sizes.get("record", 1)), np.nan)
    miss = np.full_like(best, np.nan)
    tvar, tval = [], []
    for i, w in enumerate(walls):
        var, value = targets.get(w, ("", np.nan))
        tvar.append(var)
        tval.append(value)
        if not var:
            continue
        _require(ds, [var], f"the COR match of {w}")
        da = select(ds[var].sel(wall=w), keep=("record", "cor"))
        if "diaphragm" in da.dims:
            da = da.squeeze("diaphragm", drop=True)
        match = best_cor(da, value)
        best[i] = np.broadcast_to(match["best_cor"].values, best[i].shape)
        miss[i] = np.broadcast_to(match["misfit"].values, miss[i].shape)
    coords = {"wall": walls, "record": ds["record"].values,
              "target_variable": ("wall", np.asarray(tvar, dtype=str),
                                  registry_attrs("target_variable")),
              "target_value": ("wall", np.asarray(tval, float),
                               registry_attrs("target_value"))}
    return xr.Dataset({"best_cor": (("wall", "record"), best, registry_attrs("best_cor")),
                       "misfit": (("wall", "record"), miss, registry_attrs("misfit"))}, coords)


def peak_in_patterns(hist: xr.Dataset, variable: str, patterns: Sequence[int],
                     dim: str = "time") -> xr.DataArray:
    """Largest ``|variable|`` over the instants of a history spent in ``patterns``.

    Parameters
    ----------
    hist : Dataset
        Histories with ``variable`` and ``pattern`` along ``dim`` (e.g. from
        :func:`displacement_histories`).
    variable : str
        A history variable, or ``"lower_drift"``: ``crack_displacement -
        base_displacement`` (the lower segment's drift a1*theta1). [m]
    patterns : sequence of int
        Rocking patterns (e.g. family 1 is 11 and 12).

    Returns
    -------
    DataArray over the other dims; NaN where the history never is in ``patterns``. The peak
    is taken on the history's grid (continuous-time peaks of the kernel can be about 1 %
    larger).
    """
    names = ["crack_displacement", "base_displacement"] if variable == "lower_drift" \
        else [variable]
    _require(hist, [*names, "pattern"], f"the peak of {variable} in patterns")
    values = hist[names[0]] - hist[names[1]] if variable == "lower_drift" else hist[variable]
    inside = hist["pattern"].isin(list(patterns))
    out = abs(values).where(inside).max(dim)
    out.attrs = {**registry_attrs("peak_in_patterns"),
                 "comment": f"peak |{variable}| while in patterns "
                            f"{', '.join(str(p) for p in patterns)}"}
    return out.rename("peak_in_patterns")
