"""Lognormal collapse fragility fits: from collapse capacities by maximum likelihood with
censoring (:func:`fit_lognormal`), or from counts of collapses at a few intensity levels
(:func:`fit_multiple_stripe`); both follow Baker (2015), "Efficient analytical fragility
function fitting using dynamic structural analysis", Earthquake Spectra 31(1).

Censoring. When a wall survives ``max_intensity`` its capacity is only known to exceed it;
the fits use it as a right-censored observation, never dropping it (that would bias the
median low).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import InputError


@dataclass(frozen=True)
class LognormalFit:
    """A lognormal fragility ``P(collapse | x) = Phi(ln(x / median) / dispersion)``.

    Attributes
    ----------
    median : float
        Median collapse intensity theta. [units of the intensity]
    dispersion : float
        Lognormal standard deviation beta. [1]
    n : int
        Number of observations (capacities, or analyses over all stripes).
    n_censored : int
        Censored capacities (capacity fit) or 0.
    method : str
        ``"capacities"`` or ``"multiple-stripe"``.
    """

    median: float
    dispersion: float
    n: int
    n_censored: int = 0
    method: str = "capacities"

    def probability(self, intensity) -> np.ndarray:
        """Probability of collapse at `intensity` [units of the intensity]. [1]"""
        from scipy.stats import norm

        x = np.asarray(intensity, dtype=float)
        with np.errstate(divide="ignore"):
            return norm.cdf(np.log(x / self.median) / self.dispersion)


def _minimise(nll, x0) -> np.ndarray:
    """Minimise a negative log-likelihood over (ln median, ln dispersion) with scipy."""
    from scipy.optimize import minimize

    res = minimize(nll, x0, method="Nelder-Mead",
                   options={"xatol": 1e-10, "fatol": 1e-12, "maxiter": 4000})
    if not np.isfinite(res.fun):
        raise InputError("the lognormal fit found no finite likelihood")
    return res.x


def fit_lognormal(capacities, censored=None) -> LognormalFit:
    """Median and dispersion of collapse capacities by maximum likelihood, with censoring.

    The likelihood (Baker 2015, truncated IDA) is the product of the lognormal density at
    every observed capacity and the probability of surviving the censoring intensity,
    ``1 - Phi(ln(c / theta) / beta)``, for every censored one. Without censoring it is
    maximised by the mean and the (population, 1/n) standard deviation of ``ln x``.

    Parameters
    ----------
    capacities : array_like
        Collapse intensities; for censored entries the intensity the wall survived.
        NaN entries (cells not run) are ignored. [units of the intensity]
    censored : array_like of bool, optional
        True where the capacity is a lower bound (no collapse up to it). Default: none.

    Returns
    -------
    LognormalFit

    Raises
    ------
    ValueError
        Fewer than two distinct uncensored capacities (no dispersion can be fitted), or a
        capacity that is not positive.
    """
    from scipy.stats import norm

    x = np.asarray(capacities, dtype=float).ravel()
    c = (np.zeros(x.shape, dtype=bool) if censored is None
         else np.asarray(censored, dtype=bool).ravel())
    if c.shape != x.shape:
        raise InputError(f"censored has {c.size} entries, capacities {x.size}")
    keep = np.isfinite(x)
    x, c = x[keep], c[keep]
    if np.any(x <= 0):
        raise InputError(f"capacities must be positive (intensities at collapse); got "
                         f"{float(x[x <= 0][0])!r}")
    lx = np.log(x)
    obs, cen = lx[~c], lx[c]
    if np.unique(obs).size < 2:
        raise InputError(f"a lognormal fit needs at least two distinct uncensored capacities "
                         f"(got {obs.size} uncensored of {x.size})")

    def nll(p):
        mu, beta = p[0], math.exp(p[1])
        return -(np.sum(norm.logpdf(obs, mu, beta)) + np.sum(norm.logsf(cen, mu, beta)))

    mu, lb = _minimise(nll, [obs.mean(), math.log(max(obs.std(), 1e-3))])
    return LognormalFit(float(math.exp(mu)), float(math.exp(lb)), int(x.size), int(c.sum()),
                        "capacities")


def fit_multiple_stripe(intensity, analyses, collapses) -> LognormalFit:
    """Median and dispersion from counts of collapses at a few intensity levels (multiple
    stripe analysis) by maximum likelihood with a binomial likelihood (Baker 2015).

    Parameters
    ----------
    intensity : array_like
        Intensity levels (stripes), positive. [units of the intensity]
    analyses : array_like of int
        Number of records analysed at each level (or one number for all).
    collapses : array_like of int
        Number of collapses at each level.

    Returns
    -------
    LognormalFit
        With ``method = "multiple-stripe"`` and ``n`` the total number of analyses.

    Raises
    ------
    ValueError
        Inconsistent counts, or counts that cannot fix a lognormal (no collapse at all,
        collapse everywhere).
    """
    from scipy.stats import binom, norm

    x = np.asarray(intensity, dtype=float).ravel()
    n = np.broadcast_to(np.asarray(analyses), x.shape).astype(np.int64)
    z = np.asarray(collapses).ravel().astype(np.int64)
    if z.shape != x.shape:
        raise InputError(f"collapses has {z.size} entries, intensity {x.size}")
    if np.any(x <= 0) or not np.all(np.isfinite(x)):
        raise InputError("intensity levels must be positive and finite")
    if np.any(n < 1) or np.any(z < 0) or np.any(z > n):
        raise InputError("counts need 0 <= collapses <= analyses and analyses >= 1")
    if z.sum() == 0 or np.all(z == n):
        raise InputError("a multiple-stripe fit needs some stripes with survivors and some "
                         "with collapses")
    lx = np.log(x)

    def nll(p):
        mu, beta = p[0], math.exp(p[1])
        prob = norm.cdf((lx - mu) / beta)
        return -np.sum(binom.logpmf(z, n, prob))

    frac = z / n
    mid = lx[np.argmin(np.abs(frac - 0.5))]
    spread = max(float(np.ptp(lx)) / 4.0, 0.05)
    mu, lb = _minimise(nll, [mid, math.log(spread)])
    return LognormalFit(float(math.exp(mu)), float(math.exp(lb)), int(n.sum()), 0,
                        "multiple-stripe")


def stripe_counts(capacities, censored, levels) -> tuple[np.ndarray, np.ndarray]:
    """Number of analyses and of collapses at each intensity level implied by collapse
    capacities (a wall collapses at ``x`` when its capacity is at most ``x``).

    A censored capacity ``c`` says nothing at levels above ``c``: those records are not
    counted there.

    Returns
    -------
    (ndarray, ndarray)
        ``analyses`` and ``collapses`` per level.
    """
    x = np.asarray(capacities, dtype=float).ravel()
    c = np.zeros(x.shape, bool) if censored is None else np.asarray(censored, bool).ravel()
    keep = np.isfinite(x)
    x, c = x[keep], c[keep]
    lv = np.asarray(levels, dtype=float).ravel()
    known = ~c[None, :] | (lv[:, None] <= x[None, :])
    collapsed = ~c[None, :] & (x[None, :] <= lv[:, None])
    return known.sum(axis=1), collapsed.sum(axis=1)
