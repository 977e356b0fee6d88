"""Sensitivity of a model output to sampled parameters, and how the spread of a table of
results over (sample, record) splits into modelling and record-to-record parts; numpy
and scipy, with SALib for the Sobol' indices.

- :func:`prcc`: partial rank correlation coefficients, with a confidence interval from
  Fisher's z (Marino et al. 2008, "A methodology for performing global uncertainty and
  sensitivity analysis in systems biology", J. Theor. Biol. 254); any design.
- :func:`sobol_indices`: first-order (``S1``) and total (``ST``) Sobol' indices with their
  bootstrap confidence, by SALib: Saltelli's estimators on a ``saltelli`` design
  (Saltelli et al. 2010), else the first-order index alone by RBD-FAST (Tarantola et al.
  2006, with the bias correction of Tissot & Prieur 2012), which reads any design.
- :func:`variance_shares`: the R^2 of a linear model of the output on the inputs (their
  ranks when the linear model explains too little) and the squared standardised
  regression coefficients as the inputs' shares of the output's variance, with bootstrap
  intervals over the runs (Saltelli et al. 2008, Global Sensitivity Analysis: The Primer,
  Section 1.2.5: for a linear model of independent inputs the squared SRCs sum to R^2 and
  each is the share of the variance its input explains).
- :func:`variance_split`: the random-effects analysis of variance of a (sample, record)
  table: the variance of the records' effect, of the samples' (the model's) and of their
  interaction, each an unbiased estimate from the mean squares.

The indices are computed on the design's points of the unit hypercube (each parameter's
``u``), not on its values: both are invariant under a monotone map of one input, and a
``choice`` parameter is a step function of its ``u`` (no ties).
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import InputError

CONF_LEVEL = 0.95  # of every confidence interval here
RESAMPLES = 1000  # bootstrap resamples of the Sobol' indices
#: R^2 from which the linear model's variance shares rank the inputs (below it the
#: model leaves too much of the variance unexplained and PRCC ranks them): the value
#: commonly used with standardised regression coefficients (Saltelli et al. 2004,
#: Sensitivity Analysis in Practice, Section 1.2, use SRCs when the linear model's R^2 is
#: high; 0.7 is our choice of "high", the section gives no single number we could find)
R2_THRESHOLD = 0.7


def _src(x: np.ndarray, y: np.ndarray, w: np.ndarray | None = None):
    """R^2 and standardised regression coefficients of least squares of y (n,) on the
    columns of x (n, d), for rows of bootstrap weights `w` (B, n) or once."""
    w = np.ones((1, y.size)) if w is None else w
    sw = w.sum(1, keepdims=True)
    mx = (w @ x) / sw
    my = (w @ y)[:, None] / sw
    xc = x[None, :, :] - mx[:, None, :]
    yc = y[None, :] - my
    sx = np.sqrt(np.einsum("bn,bnd->bd", w, xc ** 2) / sw)
    sy = np.sqrt(np.sum(w * yc ** 2, 1) / sw[:, 0])
    a = np.einsum("bn,bnd,bne->bde", w, xc, xc)
    c = np.einsum("bn,bnd,bn->bd", w, xc, yc)
    with np.errstate(invalid="ignore", divide="ignore"):
        coef = np.linalg.solve(a + 1e-12 * np.eye(x.shape[1]), c[..., None])[..., 0]
        fitted = np.einsum("bnd,bd->bn", xc, coef)
        r2 = 1.0 - np.sum(w * (yc - fitted) ** 2, 1) / np.sum(w * yc ** 2, 1)
        src = coef * sx / sy[:, None]
    return r2, src


def variance_shares(x, y, conf_level: float = CONF_LEVEL, resamples: int = RESAMPLES,
                    seed: int = 0, threshold: float = R2_THRESHOLD) -> dict:
    """How much of the variance of `y` each column of `x` explains by a linear model.

    Least squares of `y` on the columns of `x` (the inputs' values: a ``choice`` input as
    its level's index) gives ``r2``; when it is below `threshold` and the model of the
    ranks (of both) explains more, the ranks' model is used instead (``ranks`` True).
    The squared standardised regression coefficients ``share = (b_j s_j / s_y)^2`` are the
    inputs' shares of the variance (they sum to R^2 for uncorrelated inputs, as a Latin
    hypercube's nearly are), with their `conf_level` percentile intervals over `resamples`
    bootstrap resamples of the runs (``share_low``, ``share_high``) and, for each input,
    the share of resamples in which it keeps its place in the ranking by share
    (``rank_held``). Runs with a NaN output are left out.

    Parameters
    ----------
    x : array_like of float, shape (n, d)
        The inputs' values of `n` runs (a ``choice`` input as its level's index). [each
        input's own units]
    y : array_like of float, shape (n,)
        The output of each run. [the output's units]
    conf_level : float
        Confidence of the intervals. [1]
    resamples : int
        Bootstrap resamples of the runs.
    seed : int
        Seed of the bootstrap.
    threshold : float
        The R^2 below which the ranks' model is tried. [1]

    Returns
    -------
    dict
        ``r2`` and ``r2_ranks`` (float), ``ranks`` (bool), ``share``, ``share_low``,
        ``share_high``, ``rank_held`` (arrays of shape (d,)).
    """
    x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    keep = np.isfinite(y)
    x, y = x[keep], y[keep]
    d = x.shape[1]
    nan = np.full(d, np.nan)
    if y.size <= d + 2 or np.ptp(y) == 0:
        return {"r2": math.nan, "r2_ranks": math.nan, "ranks": False, "share": nan,
                "share_low": nan, "share_high": nan, "rank_held": nan}
    r2, _ = _src(x, y)
    xr_, yr = _ranks(x), _ranks(y[:, None])[:, 0]
    r2r, _ = _src(xr_, yr)
    use_ranks = bool(r2[0] < threshold and r2r[0] > r2[0])
    xx, yy = (xr_, yr) if use_ranks else (x, y)
    _, src = _src(xx, yy)
    share = src[0] ** 2
    rng = np.random.default_rng(seed)
    w = rng.multinomial(y.size, np.full(y.size, 1.0 / y.size), size=resamples).astype(float)
    _, bsrc = _src(xx, yy, w)
    bshare = bsrc ** 2
    a = (1.0 - conf_level) / 2.0
    order = np.argsort(-share)
    place = np.empty(d, int)
    place[order] = np.arange(d)
    bplace = np.argsort(np.argsort(-np.nan_to_num(bshare, nan=-1.0), axis=1), axis=1)
    return {"r2": float(r2[0]), "r2_ranks": float(r2r[0]), "ranks": use_ranks,
            "share": share, "share_low": np.nanquantile(bshare, a, axis=0),
            "share_high": np.nanquantile(bshare, 1.0 - a, axis=0),
            "rank_held": np.mean(bplace == place[None, :], axis=0)}


def _ranks(a: np.ndarray) -> np.ndarray:
    from scipy.stats import rankdata

    return rankdata(a, axis=0)


def prcc(x, y, conf_level: float = CONF_LEVEL) -> dict[str, np.ndarray]:
    """Partial rank correlation of `y` with each column of `x`.

    Parameters
    ----------
    x : array_like, shape (n, d)
        The inputs of `n` runs (or their points of the unit hypercube). [each input's own
        units, or 1 in the unit hypercube]
    y : array_like, shape (n,)
        The output of each run. Runs with a NaN output are left out. [the output's units]
    conf_level : float
        Confidence of the intervals. [1]

    Returns
    -------
    dict
        ``prcc``, ``low``, ``high`` (the interval, Fisher's z with ``n - 2 - d`` degrees
        of freedom) and ``p`` (two-sided p-value of zero correlation), each of shape (d,);
        NaN for a constant input, or intervals NaN when ``n <= d + 2``.
    """
    from scipy.stats import norm

    x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    if x.ndim != 2 or y.shape != x.shape[:1]:
        raise InputError(f"prcc needs x of shape (n, d) and y of shape (n,), got "
                         f"{x.shape} and {y.shape}")
    keep = np.isfinite(y)
    x, y = x[keep], y[keep]
    n, d = x.shape
    rx, ry = _ranks(x), _ranks(y)
    r = np.full(d, np.nan)
    for i in range(d):
        if np.ptp(rx[:, i]) == 0 or np.ptp(ry) == 0:
            continue
        others = np.column_stack([np.ones(n), np.delete(rx, i, axis=1)])
        res_x = rx[:, i] - others @ np.linalg.lstsq(others, rx[:, i], rcond=None)[0]
        res_y = ry - others @ np.linalg.lstsq(others, ry, rcond=None)[0]
        den = math.sqrt(float(res_x @ res_x) * float(res_y @ res_y))
        r[i] = float(res_x @ res_y) / den if den > 0 else np.nan
    dof = n - 2 - d  # n - 3 - (d - 1) controlled variables
    if dof <= 0:
        nan = np.full(d, np.nan)
        return {"prcc": r, "low": nan, "high": nan.copy(), "p": nan.copy()}
    z = np.arctanh(np.clip(r, -1 + 1e-15, 1 - 1e-15))
    half = norm.ppf(0.5 + conf_level / 2) / math.sqrt(dof)
    p = 2 * norm.sf(np.abs(z) * math.sqrt(dof))
    return {"prcc": r, "low": np.tanh(z - half), "high": np.tanh(z + half), "p": p}


def _problem(d: int) -> dict:
    return {"num_vars": d, "names": [f"x{i}" for i in range(d)], "bounds": [[0.0, 1.0]] * d}


def harmonics(n: int) -> int:
    """RBD-FAST's number of harmonics for `n` runs: SALib's 10, fewer for small designs
    (at most n / 8, so that the bias correction's 2M/n stays at or below 1/4)."""
    return int(max(1, min(10, n // 8)))


def sobol_indices(unit, y, method: str, seed: int = 0, conf_level: float = CONF_LEVEL,
                  resamples: int = RESAMPLES) -> dict[str, np.ndarray]:
    """First-order and total Sobol' indices of `y` with their confidence (SALib).

    Parameters
    ----------
    unit : array_like, shape (n, d)
        The design's points of the unit hypercube (`urmx.uncertainty.Sampling.unit`) [1], in
        its order.
    y : array_like, shape (n,)
        The output of each point. [the output's units]
    method : str
        The design's method: ``saltelli`` gives ``S1`` and ``ST`` by Saltelli's
        estimators; any other ``S1`` by RBD-FAST and ``ST`` NaN.
    seed : int
        Seed of the bootstrap. [1]
    conf_level : float
        Confidence of the intervals. [1]
    resamples : int
        Bootstrap resamples.

    Returns
    -------
    dict
        ``S1``, ``S1_conf``, ``ST``, ``ST_conf`` of shape (d,): each index and the half
        width of its confidence interval (``S1 +- S1_conf``). [1]

    Raises
    ------
    urmx.errors.InputError
        A NaN output (a design needs every point: a saltelli design is read in blocks) or
        shapes that do not match.
    """
    unit, y = np.asarray(unit, dtype=float), np.asarray(y, dtype=float)
    if unit.ndim != 2 or y.shape != unit.shape[:1]:
        raise InputError(f"sobol_indices needs unit of shape (n, d) and y of shape (n,), "
                         f"got {unit.shape} and {y.shape}")
    if not np.all(np.isfinite(y)):
        raise InputError(f"sobol_indices needs an output at every point "
                         f"({int(np.sum(~np.isfinite(y)))} of {y.size} are NaN)")
    n, d = unit.shape
    nan = np.full(d, np.nan)
    if method == "saltelli":
        from SALib.analyze import sobol

        si = sobol.analyze(_problem(d), y, calc_second_order=False, num_resamples=resamples,
                           conf_level=conf_level, seed=seed)
        return {k: np.asarray(si[k], dtype=float) for k in ("S1", "S1_conf", "ST", "ST_conf")}
    from SALib.analyze import rbd_fast

    with np.errstate(divide="ignore", invalid="ignore"):  # a bootstrap of a constant output
        si = rbd_fast.analyze(_problem(d), unit, y, M=harmonics(n), num_resamples=resamples,
                              conf_level=conf_level, seed=seed)
    return {"S1": np.asarray(si["S1"], dtype=float),
            "S1_conf": np.asarray(si["S1_conf"], dtype=float), "ST": nan,
            "ST_conf": nan.copy()}


def variance_split(table) -> dict[str, float]:
    """The random-effects analysis of variance of a (sample, record) table of results (one
    per cell, e.g. log collapse capacities).

    With ``S`` samples and ``R`` records, the mean squares of the samples (``MS_S``), of
    the records (``MS_R``) and of the residual interaction (``MS_E``) estimate the
    variance components ``model = (MS_S - MS_E) / R``, ``record = (MS_R - MS_E) / S`` and
    ``interaction = MS_E`` without bias; a negative estimate is set to 0. Samples or
    records with a NaN cell are left out.

    Parameters
    ----------
    table : array_like of float, shape (samples, records)
        One result per cell (e.g. log collapse capacities). [the results' units]

    Returns
    -------
    dict
        ``model``, ``record``, ``interaction``, ``total`` (their sum) [units of the table,
        squared], ``model_share``, ``record_share``, ``interaction_share`` [1], and the
        ``samples`` and ``records`` used.
    """
    t = np.asarray(table, dtype=float)
    if t.ndim != 2:
        raise InputError(f"variance_split needs a (sample, record) table, got shape {t.shape}")
    t = t[np.all(np.isfinite(t), axis=1)]
    t = t[:, np.all(np.isfinite(t), axis=0)]
    s, r = t.shape
    out = {"samples": s, "records": r}
    if s < 2 or r < 2:
        return {**out, **{k: math.nan for k in ("model", "record", "interaction", "total",
                                                "model_share", "record_share",
                                                "interaction_share")}}
    grand = t.mean()
    by_sample, by_record = t.mean(axis=1), t.mean(axis=0)
    ms_s = r * float(np.sum((by_sample - grand) ** 2)) / (s - 1)
    ms_r = s * float(np.sum((by_record - grand) ** 2)) / (r - 1)
    resid = t - by_sample[:, None] - by_record[None, :] + grand
    ms_e = float(np.sum(resid ** 2)) / ((s - 1) * (r - 1))
    comp = {"model": max(0.0, (ms_s - ms_e) / r), "record": max(0.0, (ms_r - ms_e) / s),
            "interaction": ms_e}
    total = sum(comp.values())
    out.update(comp, total=total)
    for k, v in comp.items():
        out[f"{k}_share"] = v / total if total > 0 else math.nan
    return out
