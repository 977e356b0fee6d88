"""Reductions of sampling-study archives (`urmx.study.kinds.sampling`): the output each
sample gives per wall and diaphragm, its sensitivity to the sampled parameters, how the
spread of the results splits into record-to-record and modelling parts, and the paper's
findings (the D1 -> D4 stiffening, the slenderness trend, the resonance) per impact law
(reported by `urmx.reports.sampling`).

The output of a sample is, with collapse capacities, the log of its median collapse
intensity over the records (``ln median_collapse_intensity``); with time histories, the
mean instability ratio over the records.
"""

from __future__ import annotations

import math

import numpy as np
import xarray as xr

from ..errors import InputError
from ..study.archive import open_archive
from ..uncertainty import (
    R2_THRESHOLD,
    coordinate_name,
    prcc,
    sobol_indices,
    variance_shares,
    variance_split,
)
from . import ida as FA

LAWS = ("scale", "contact")  # the impact laws, in the order shown


def open_sampling(archive) -> xr.Dataset:
    """A sampling-study archive (path or Dataset), loaded; a clear error for any other."""
    ds = open_archive(archive, "sampling-study archive")
    if "sample" not in ds.dims or "sample_unit" not in ds.coords:
        where = archive if not isinstance(archive, xr.Dataset) else "Dataset"
        raise InputError(f"{where}: not a sampling-study archive (no sample dimension); "
                         "write one with `urmx run STUDY --out FILE.nc` for a study with "
                         "[study.sampling]")
    return ds


def sampled(ds: xr.Dataset, parameter: str) -> xr.DataArray:
    """A sampled parameter's values over the samples (``<parameter>_factor`` for a
    factor)."""
    return ds[coordinate_name(parameter)]


def capacities(ds: xr.Dataset) -> bool:
    """Whether the archive holds collapse capacities (``[study.ida]``)."""
    return "collapse_intensity" in ds.data_vars


def output(ds: xr.Dataset) -> xr.DataArray:
    """Each sample's output per (wall, diaphragm, sample) (module docstring)."""
    if capacities(ds):
        y = np.log(ds.median_collapse_intensity)
        y.attrs = {"long_name": "log of the median collapse intensity over the records",
                   "units": "1"}
        return y
    y = ds.instability_ratio.mean("record")
    y.attrs = {"long_name": "mean instability ratio over the records", "units": "1"}
    return y


def design_values(ds: xr.Dataset) -> np.ndarray:
    """The sampled values, (sample, parameter): a number as drawn, a ``choice`` as the index
    of its value among the sorted values (0/1 for two)."""
    cols = []
    for name in [str(p) for p in ds.parameter.values]:
        v = sampled(ds, name).values
        if v.dtype.kind in "OUS":
            levels = sorted({str(x) for x in v})
            v = np.array([levels.index(str(x)) for x in v], dtype=float)
        cols.append(np.asarray(v, dtype=float))
    return np.stack(cols, axis=1)


def sensitivity(ds: xr.Dataset, seed: int = 0) -> xr.Dataset:
    """The sensitivity of :func:`output` to each sampled parameter, per wall and diaphragm:
    partial rank correlations with their 95 % interval (``prcc``, ``prcc_low``,
    ``prcc_high``), the Sobol' indices with the half widths of their 95 % intervals
    (``s1``, ``s1_conf``, ``st``, ``st_conf``; ``st`` only from a ``saltelli`` design),
    all on the design's points (`urmx.uncertainty.sensitivity`), and the linear model's
    ``r2`` (``r2_ranks`` of the ranks', ``ranks`` 1 where that one is used) with the
    variance shares (``share``, ``share_low``, ``share_high``, ``rank_held``) on the
    sampled values (`urmx.uncertainty.variance_shares`)."""
    y = output(ds).transpose("wall", "diaphragm", "sample")
    unit = ds.sample_unit.transpose("sample", "parameter").values
    method = ds.attrs.get("sampling_method", "lhs")
    names = ("prcc", "prcc_low", "prcc_high", "s1", "s1_conf", "st", "st_conf")
    shape = (ds.wall.size, ds.diaphragm.size, ds.parameter.size)
    out = {k: np.full(shape, np.nan) for k in names}
    values = design_values(ds)
    lin = {k: np.full(shape[:2], np.nan) for k in ("r2", "r2_ranks", "ranks")}
    shares = {k: np.full(shape, np.nan) for k in ("share", "share_low", "share_high",
                                                   "rank_held")}
    for iw, idp in np.ndindex(*shape[:2]):
        v = y.values[iw, idp]
        vs = variance_shares(values, v, seed=seed)
        for k in lin:
            lin[k][iw, idp] = float(vs[k])
        for k in shares:
            shares[k][iw, idp] = vs[k]
        r = prcc(unit, v)
        out["prcc"][iw, idp], out["prcc_low"][iw, idp] = r["prcc"], r["low"]
        out["prcc_high"][iw, idp] = r["high"]
        if np.all(np.isfinite(v)) and np.ptp(v) > 0:
            si = sobol_indices(unit, v, method, seed=seed)
            for k in ("s1", "s1_conf", "st", "st_conf"):
                out[k][iw, idp] = si[k.upper().replace("_CONF", "_conf")]
    dims = ("wall", "diaphragm", "parameter")
    res = xr.Dataset({k: (dims, v) for k, v in {**out, **shares}.items()},
                     coords={"wall": ds.wall.values, "diaphragm": ds.diaphragm.values,
                             "parameter": ds.parameter.values})
    for k, v in lin.items():
        res[k] = (("wall", "diaphragm"), v)
    return res.assign_attrs(r2_threshold=R2_THRESHOLD)


def importance(sens: xr.Dataset) -> xr.DataArray:
    """Per wall and diaphragm, the measure that ranks the parameters: ``"share"`` (the
    variance shares) where the linear model's R^2 reaches `R2_THRESHOLD`, else ``"prcc"``
    (|PRCC|)."""
    return xr.where(sens.r2 >= sens.attrs.get("r2_threshold", R2_THRESHOLD), "share", "prcc")


def strongest(sens: xr.Dataset, by: str = "prcc") -> xr.DataArray:
    """The parameter of largest magnitude of `by` per wall and diaphragm ("" where none)."""
    a = np.abs(sens[by]).fillna(-1.0)
    idx = a.argmax("parameter")
    names = np.asarray(sens.parameter.values, dtype=object)[idx.values]
    return xr.DataArray(np.where(a.max("parameter").values >= 0, names, ""),
                        dims=idx.dims, coords=idx.coords)


def spread(ds: xr.Dataset) -> xr.Dataset:
    """Per wall and diaphragm: the random-effects split of the variance of the cells'
    results over (sample, record) (``ln collapse_intensity``, or the instability ratio) into
    ``model_share``, ``record_share`` and ``interaction_share`` (`variance_split`); with
    capacities also the fits' dispersions and the 5 %-95 % range of the samples' medians
    (``median_p05``, ``median_p95``)."""
    cells = np.log(ds.collapse_intensity) if capacities(ds) else ds.instability_ratio
    cells = cells.transpose("wall", "diaphragm", "sample", "record")
    keys = ("model", "record", "interaction", "total", "model_share", "record_share",
            "interaction_share")
    out = {k: np.full((ds.wall.size, ds.diaphragm.size), np.nan) for k in keys}
    for iw, idp in np.ndindex(ds.wall.size, ds.diaphragm.size):
        v = variance_split(cells.values[iw, idp])
        for k in keys:
            out[k][iw, idp] = v[k]
    res = xr.Dataset({k: (("wall", "diaphragm"), v) for k, v in out.items()},
                     coords={"wall": ds.wall.values, "diaphragm": ds.diaphragm.values})
    if capacities(ds):
        for k in ("total_median_collapse_intensity", "total_dispersion",
                  "record_dispersion", "model_dispersion"):
            res[k] = ds[k]
        med = ds.median_collapse_intensity
        res["median_p05"] = med.quantile(0.05, "sample").drop_vars("quantile")
        res["median_p95"] = med.quantile(0.95, "sample").drop_vars("quantile")
        res["record_median"] = np.exp(np.log(med).mean("sample"))
    return res


# ---- the paper's findings per impact law ------------------------------------------------------

def as_ida(ds: xr.Dataset, j: int) -> xr.Dataset:
    """Sample `j` as an IDA archive of one COR (what `urmx.analysis.ida` reads): its
    capacities, fits and cell frequencies over (wall, diaphragm, record, cor)."""
    sub = ds.isel(sample=[j])
    drop = [n for n in sub.coords if "sample" in sub[n].dims and n not in (
        "sample", "cell_frequency")]
    sub = sub.drop_vars(drop).rename({"sample": "cor"})
    return sub.assign_coords(cor=[float(ds.cor.values[j])])


def laws(ds: xr.Dataset) -> list[str]:
    """The impact laws the samples ran with, in `LAWS` order."""
    present = {str(v) for v in ds.impact.values}
    return [law for law in LAWS if law in present]


def findings(ds: xr.Dataset) -> dict[str, dict]:
    """The paper's findings computed for each sample as `urmx.reports.ida` computes
    them for one model, gathered per impact law: ``stiffening`` (group -> (sample, wall)
    ratios of the D4 to the D1 median), ``slenderness`` ((sample, diaphragm) Spearman rho of
    the median with h/t over the walls), ``resonance`` (the pooled resonance table)."""
    out: dict[str, dict] = {}
    for law in laws(ds):
        picks = [j for j in range(ds.sample.size) if str(ds.impact.values[j]) == law]
        stf: dict[str, list] = {}
        rho, tables = [], []
        for j in picks:
            d = as_ida(ds, j)
            for g, v in FA.stiffening(d).items():
                stf.setdefault(g, []).append(v["ratio"].values)
            rho.append(FA.slenderness_ranks(FA.first_cor(d))["rho"])
            tables.append(FA.resonance_table(d))
        out[law] = {"samples": picks,
                    "stiffening": {g: np.array(v) for g, v in stf.items()},
                    "slenderness": np.array(rho),
                    "resonance": xr.concat(tables, "cell") if tables else None}
    return out


def law_effect(ds: xr.Dataset) -> xr.DataArray:
    """Per wall and diaphragm: the geometric mean of the samples' medians under the
    ``contact`` law over that under ``scale`` (NaN unless both ran)."""
    if laws(ds) != list(LAWS):
        return xr.full_like(ds.total_dispersion, math.nan)
    y = np.log(ds.median_collapse_intensity)
    by = {law: y.where(ds.impact == law).mean("sample") for law in LAWS}
    return np.exp(by["contact"] - by["scale"])
