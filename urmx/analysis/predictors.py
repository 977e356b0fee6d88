"""Which wall parameter predicts collapse (issue 37): the analysis of a ``wall-population``
archive (a sampling-IDA study of walls drawn in geometry, `urmx.uncertainty.sampler`).

- :func:`population`: per wall, the sampled inputs, the candidate predictors
  (`urmx.fragility.predictors`) and the median collapse capacity in PGA and in ``sa_avg``
  (the lognormal fit over the records, censored walls as lower bounds);
- :func:`correlations`: the design's check (the correlation matrices of the sampled inputs
  and of the log predictors);
- :func:`rankings`: the cross-validated share of each predictor and pair
  (`urmx.fragility.ranking`), single- and higher-storey walls on flexible diaphragms
  separately, in PGA and in ``sa_avg``;
- :func:`resonance`: the capacity's dependence on the record's dominant frequency over the
  diaphragm's and on ``Sa(T_d) / PGA``, and the by-hand rule fitted to it.

The report (`urmx.reports.predictors`) draws and writes them.
"""

from __future__ import annotations

import math
import warnings
from typing import Any

import numpy as np

from ..fragility.predictors import PREDICTORS
from ..fragility.ranking import fit, rank, vif
from ..uncertainty.spread import lognormal_fit

#: the sampled inputs of the design, in report order (``storey`` as 1 for higher storey)
INPUTS = ("thickness", "height", "crack_ratio", "overburden_ratio", "diaphragm_weight",
          "pmr", "diaphragm_frequency", "rigid_top", "damping", "storey")
#: the predictors ranked (log of each); ``instability_case2`` is ``thickness`` by Table I
#: and ``diaphragm_weight`` is an input the model's dynamics cannot see once O/W and the
#: frequency are drawn (`urmx.uncertainty.sampler`): the ranking's built-in irrelevant input
RANKED = ("slenderness", "height", "thickness", "static_acceleration", "instability_case3",
          "housner_lower", "housner_upper", "effective_period", "diaphragm_frequency",
          "frequency_ratio", "diaphragm_weight")
STOREYS = ("single", "higher")
MEASURES = ("pga", "sa_avg")
#: half-width of the resonance band: the record's dominant frequency within this factor of
#: the diaphragm's (half an octave either side)
BAND = math.sqrt(2.0)


def _sel(ds, name: str) -> np.ndarray:
    """A (wall, diaphragm, ...) variable of the one-cell template as its other axes."""
    return np.asarray(ds[name].isel(wall=0, diaphragm=0).values)


def population(ds) -> dict[str, Any]:
    """Per-wall arrays of a wall-population archive: each sampled input, each predictor,
    ``storey`` (str), ``rigid`` (bool), ``median_pga`` and ``median_sa_avg`` (m s-2), the
    (record, wall) tables ``capacity`` (PGA) and ``censored``, the records' measures
    ``measure_<im>`` and ``predominant_frequency`` (record)."""
    pop: dict[str, Any] = {}
    for name in INPUTS:
        if name in ds.coords:
            pop[name] = np.asarray(ds[name].values)
    pop["storey"] = np.asarray(ds["storey"].values).astype(str)
    pop["rigid"] = np.asarray(ds["rigid_top"].values) > 0.5
    for name in PREDICTORS:
        pop[f"p_{name}"] = _sel(ds, f"predictor_{name}")
    cap = _sel(ds, "collapse_intensity")  # (record, sample)
    cen = _sel(ds, "censored") == 1
    pop["capacity"], pop["censored"] = cap, cen
    for im in ("pga", "pgv", "sa_avg", "sa_diaphragm"):
        pop[f"measure_{im}"] = _sel(ds, f"measure_{im}")
    pop["predominant_frequency"] = np.asarray(ds["predominant_frequency"].values)
    pop["median_pga"] = _sel(ds, "median_collapse_intensity")
    in_sa = cap * pop["measure_sa_avg"] / pop["measure_pga"]
    pop["median_sa_avg"] = np.array([lognormal_fit(in_sa[:, j], cen[:, j])[0]
                                     for j in range(cap.shape[1])])
    pop["n_walls"], pop["n_records"] = cap.shape[1], cap.shape[0]
    return pop


def log_predictors(pop: dict[str, Any], mask: np.ndarray) -> dict[str, np.ndarray]:
    """The natural log of each ranked predictor over the walls of `mask`."""
    out = {}
    for name in RANKED:
        values = pop[name] if name in INPUTS else pop[f"p_{name}"]
        out[name] = np.log(np.asarray(values, dtype=float)[mask])
    return out


def correlations(pop: dict[str, Any]) -> dict[str, Any]:
    """The design check: Pearson correlation matrices of the sampled inputs (all walls;
    ``diaphragm_frequency`` in log, as drawn) and of the log predictors (walls on flexible
    diaphragms), with the largest off-diagonal magnitude of each."""
    flex = ~pop["rigid"]
    every = np.ones(len(flex), bool)
    cols = {}
    for name in INPUTS:
        v = pop[name]
        if name == "storey":
            v = (v == "higher").astype(float)
        elif name == "diaphragm_frequency":
            v = np.log(v)
        cols[name] = np.asarray(v, dtype=float)[every]
    out = {}
    for key, table in (("inputs", cols), ("predictors", log_predictors(pop, flex))):
        names = list(table)
        r = np.corrcoef(np.vstack([table[n] for n in names]))
        off = np.abs(r - np.eye(len(names)))
        i, j = np.unravel_index(np.argmax(off), off.shape)
        out[key] = {"names": names, "r": r, "max": float(off[i, j]),
                    "pair": (names[i], names[j])}
    return out


def rankings(pop: dict[str, Any], replicates: int = 200, k: int = 5,
             seed: int = 37) -> dict[tuple[str, str], Any]:
    """(storey, measure) -> `urmx.fragility.ranking.Ranking` of the walls on flexible
    diaphragms of that storey, the log median capacity in that measure; with ``n`` walls
    and the ranked data kept on the ranking as ``x`` and ``y``."""
    out = {}
    for storey in STOREYS:
        mask = (pop["storey"] == storey) & ~pop["rigid"]
        x = log_predictors(pop, mask)
        for im in MEASURES:
            y = np.log(pop[f"median_{im}"][mask])
            keep = np.isfinite(y)
            xs = {n: v[keep] for n, v in x.items()}
            r = rank(xs, y[keep], k=k, replicates=replicates, seed=seed)
            r.x, r.y = xs, y[keep]
            out[storey, im] = r
    return out


def rigid_reference(pop: dict[str, Any], replicates: int = 200, seed: int = 37):
    """The walls with rigid diaphragms (both storeys together): each wall-alone predictor
    alone, in PGA (a `urmx.fragility.ranking.Ranking`; None with fewer than 10 such
    walls)."""
    mask = pop["rigid"]
    if mask.sum() < 10:
        return None
    x = {n: v for n, v in log_predictors(pop, mask).items()
         if n not in ("diaphragm_frequency", "frequency_ratio")}
    y = np.log(pop["median_pga"][mask])
    return rank(x, y, pairs=False, replicates=replicates, seed=seed, k=5)


def relation(r, index: int) -> dict[str, Any]:
    """The fitted power law of a ranked set: ``C = exp(a) prod x_i^b_i`` with its residual
    dispersion (log standard deviation) and VIF."""
    names = r.sets[index]
    x = np.column_stack([r.x[n] for n in names])
    coef, beta = fit(x, r.y)
    return {"names": names, "intercept": float(coef[0]), "exponents": coef[1:].tolist(),
            "dispersion": beta, "share": float(r.share[index]),
            "interval": (float(r.lower[index]), float(r.upper[index])),
            "vif": [float(v) for v in vif(x)], "n": len(r.y)}


def resonance(pop: dict[str, Any], replicates: int = 200, seed: int = 37,
              edges=None) -> dict[str, Any]:
    """The capacity's dependence on resonance, per storey (walls on flexible diaphragms,
    uncensored capacities in PGA): the residual ``e = ln C_ij - ln median_i`` of wall i under
    record j against ``ln(f_j / f_d,i)`` (binned means) and against
    ``s = ln(Sa_j(T_d,i) / PGA_j)`` (the slope ``b`` of ``e = b (s - mean s)``), with
    bootstrap intervals over walls and records together (both resampled, each replicate's
    statistics on the cells of the drawn walls and records).

    Returns
    -------
    dict
        Per storey: ``edges``, ``mean`` (per bin) and its ``lower``/``upper``,
        ``mean_adjusted`` (per bin, each record's mean e over the walls taken out); ``factor``
        the capacity factor ``exp(mean e)`` of the cells within `BAND` of resonance (the
        capacity in resonance over the wall's median) and its interval;
        ``factor_adjusted`` the same with each record's mean ``e`` over the walls taken
        out (resonance beyond the record's own severity per unit PGA); ``slope``,
        ``slope_interval``, ``slope_within`` and its interval (the slope within each
        record: the walls' S differing by their diaphragm's period alone), ``s_mean``
        (mean of s), ``spread`` and
        ``spread_rule`` (standard deviation of e before and after the slope rule); and the
        cells ``x`` (log ratio), ``s``, ``e``.
    """
    edges = np.linspace(-2.5, 2.5, 11) if edges is None else np.asarray(edges)
    out = {}
    for storey in STOREYS:
        mask = (pop["storey"] == storey) & ~pop["rigid"]
        cells = _resonance_cells(pop, mask)
        out[storey] = {**_resonance_stats(cells, edges), "edges": edges,
                       **_resonance_boot(cells, edges, replicates, seed), **cells}
    return out


def _resonance_cells(pop: dict[str, Any], mask: np.ndarray) -> dict[str, np.ndarray]:
    """(record, wall) cells of the walls of `mask`: e, the log frequency ratio and s, with
    the record and wall index of each (uncensored cells only)."""
    cap = pop["capacity"][:, mask]
    ok = (pop["censored"][:, mask] == 0) & np.isfinite(cap)
    e = np.log(cap) - np.log(pop["median_pga"][mask])[None, :]
    fd = pop["p_diaphragm_frequency"][mask]
    x = np.log(pop["predominant_frequency"][:, None] / fd[None, :])
    s = np.log(pop["measure_sa_diaphragm"][:, mask] / pop["measure_pga"][:, mask])
    rec, wall = np.nonzero(ok)
    return {"e": e[ok], "x": x[ok], "s": s[ok], "record": rec, "wall": wall}


def _resonance_stats(c: dict[str, np.ndarray], edges: np.ndarray) -> dict[str, Any]:
    """The binned means, the band factor and the slope of one set of cells."""
    e, x, s = c["e"], c["x"], c["s"]
    b = np.digitize(x, edges) - 1
    mean = np.array([e[b == i].mean() if np.any(b == i) else np.nan
                     for i in range(len(edges) - 1)])
    band = np.abs(x) <= math.log(BAND)
    sc = s - s.mean()
    slope = float(np.sum(sc * e) / np.sum(sc * sc))
    # the record's own severity per unit PGA taken out: each record's mean over the walls
    rec = c["record"]
    own = np.bincount(rec, weights=e) / np.maximum(np.bincount(rec), 1)
    adjusted = e - own[rec]
    s_rec = np.bincount(rec, weights=s) / np.maximum(np.bincount(rec), 1)
    sw = s - s_rec[rec]
    within = float(np.sum(sw * adjusted) / np.sum(sw * sw))
    mean_adjusted = np.array([adjusted[b == i].mean() if np.any(b == i) else np.nan
                              for i in range(len(edges) - 1)])
    inside = b[(b >= 0) & (b < len(edges) - 1)]
    return {"mean": mean, "mean_adjusted": mean_adjusted,
            "count": np.bincount(inside, minlength=len(edges) - 1),
            "factor": float(math.exp(e[band].mean())),
            "factor_adjusted": float(math.exp(adjusted[band].mean())),
            "band_cells": int(band.sum()), "slope": slope, "slope_within": within,
            "s_mean": float(s.mean()),
            "spread": float(e.std()), "spread_rule": float((e - slope * sc).std())}


def _resonance_boot(c: dict[str, np.ndarray], edges: np.ndarray, replicates: int,
                    seed: int) -> dict[str, Any]:
    """Bootstrap intervals (walls and records resampled together) of the binned means, the
    band factor and the slope."""
    rng = np.random.default_rng(seed)
    walls, recs = np.unique(c["wall"]), np.unique(c["record"])
    by_wall = {w: np.flatnonzero(c["wall"] == w) for w in walls}
    means, factors, slopes, adjusted, withins = [], [], [], [], []
    for _ in range(replicates):
        w = rng.choice(walls, len(walls))
        r_count = np.bincount(rng.choice(recs, len(recs)), minlength=recs.max() + 1)
        idx = np.concatenate([by_wall[i] for i in w])
        idx = np.repeat(idx, r_count[c["record"][idx]])  # each drawn record as often drawn
        st = _resonance_stats({k: v[idx] for k, v in c.items()}, edges)
        means.append(st["mean"])
        factors.append(st["factor"])
        adjusted.append(st["factor_adjusted"])
        slopes.append(st["slope"])
        withins.append(st["slope_within"])
    q = [0.025, 0.975]
    with warnings.catch_warnings():  # a bin no replicate fills has no interval (NaN: "-")
        warnings.simplefilter("ignore", RuntimeWarning)
        lo, hi = np.nanquantile(np.array(means), q, axis=0)
    return {"lower": lo, "upper": hi, "factor_interval": tuple(np.quantile(factors, q)),
            "factor_adjusted_interval": tuple(np.quantile(adjusted, q)),
            "slope_interval": tuple(np.quantile(slopes, q)),
            "slope_within_interval": tuple(np.quantile(withins, q))}
