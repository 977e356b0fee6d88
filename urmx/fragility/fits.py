"""Lognormal collapse fragility fits: from collapse capacities by maximum likelihood with
censoring (:func:`fit_lognormal`), or from counts of collapses at a few intensity levels
(:func:`fit_multiple_stripe`); both follow Baker (2015), "Efficient analytical fragility
function fitting using dynamic structural analysis", Earthquake Spectra 31(1).

Censoring. When a wall survives ``max_intensity`` its capacity is only known to exceed it;
the fits use it as a right-censored observation, never dropping it (that would bias the
median low).

The maximum. Both likelihoods are concave in ``(delta, theta) = (ln median / beta,
1 / beta)`` (the censored normal: Olsen 1978, Econometrica 46; the probit of the stripes),
so Newton's method with a backtracking line search finds their one maximum, vectorised over
bootstrap resamples. Without censoring the maximum is the mean and the population (1/n)
standard deviation of ``ln x``, which the iteration starts from.

Confidence. Each fit carries intervals for its median and dispersion at `CONFIDENCE`
(90 %, two-sided) from `RESAMPLES` bootstrap resamples drawn with a seeded generator
(`SEED`). Capacity fits use by default the studentized (bootstrap-t) interval (Efron &
Tibshirani 1993, An Introduction to the Bootstrap, Section 12.5; Davison & Hinkley 1997,
Bootstrap Methods, eq. 5.7) on the log scale of the median and of beta, each resample
standardised by its own sandwich (robust) standard error (`sandwich_cov`): the MLE of beta
is biased low (uncensored, it is the 1/n standard deviation) and its spread depends on the
sample's tails, both of which the pivot ``(ln b* - ln b) / se*`` carries over. The
bias-corrected and accelerated (BCa) interval of Efron (1987, "Better bootstrap confidence
intervals", JASA 82(397), eq. 2.3; `bca_interval`) and the plain percentile interval are
options (``interval=``). Measured by simulation (``tests/test_fits.py``; README,
"Collapse fragility"): at n = 40 the percentile interval covered the true beta in 83 % of
sets (issue 38's check found 82.7 %), BCa in 85 %, the studentized interval in about
90 %. With groups (``groups=``: records of one station or event), whole groups are
resampled, the jackknife (BCa) leaves out one group at a time and the sandwich sums the
scores over each group first (the cluster bootstrap, Davison & Hinkley 1997, Section
3.8), since two components of one station are not independent records.
``unbiased=True`` multiplies the dispersion, its resamples and its interval by
``sqrt(n / (n - 1))`` (the 1/(n - 1) variance; exact for uncensored capacities, a
first-order correction with censoring). Stripe counts keep
percentile intervals (binomial resampling of each stripe's collapses). Resamples that
admit no fit (fewer than two distinct uncensored capacities; stripes perfectly separated)
are left out and counted (``LognormalFit.resamples`` is the number kept). With fewer than
`MIN_BOOTSTRAP` observations (or groups) the intervals are NaN.

Refused inputs (an `urmx.errors.InputError` naming the value): an infinite capacity, a NaN
``censored`` flag of a capacity that is there, a capacity that is not positive, a count
that is not a whole number, stripes whose likelihood has no maximum (one intensity level,
or stripes perfectly separated: none collapse up to some level and all collapse above it),
and a negative intensity in :meth:`LognormalFit.probability`. A NaN capacity is a cell not
run and is left out, with its flag.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import InputError, numbers_argument

CONFIDENCE = 0.90  # two-sided level of the bootstrap intervals [1]
RESAMPLES = 1000  # bootstrap resamples of a fit
SEED = 0  # seed of the bootstrap's generator (numpy default_rng)
INTERVALS = ("studentized", "bca", "percentile")  # the bootstrap intervals of a fit
MIN_BOOTSTRAP = 5  # fewer observations (records or stripes x records) give no interval
_NAN2 = (math.nan, math.nan)


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
    median_ci, dispersion_ci : (float, float)
        Bootstrap interval (BCa, or percentile: `interval`) at `confidence` (NaN when not computed).
        [units of the intensity], [1]
    confidence : float
        Two-sided level of the intervals. [1]
    resamples : int
        Bootstrap resamples the intervals come from (those that admit a fit).
    im, units : str or None
        The intensity measure and its units, when known (`urmx.fragility.collapse_rate`
        checks a hazard curve's against them).
    interval : str
        How the intervals were made: ``"studentized"``, ``"bca"`` or ``"percentile"``.
    groups : int
        Number of record groups resampled (0: records resampled one by one).
    """

    median: float
    dispersion: float
    n: int
    n_censored: int = 0
    method: str = "capacities"
    median_ci: tuple[float, float] = _NAN2
    dispersion_ci: tuple[float, float] = _NAN2
    confidence: float = CONFIDENCE
    resamples: int = 0
    im: str | None = None
    units: str | None = None
    interval: str = "studentized"
    groups: int = 0

    def probability(self, intensity) -> np.ndarray:
        """Probability of collapse at `intensity` (>= 0; NaN stays NaN) [units of the
        intensity]. [1]

        Parameters
        ----------
        intensity : float or array_like of float
            Intensity levels, >= 0. [units of the intensity]
        """
        from scipy.stats import norm

        x = np.asarray(intensity, dtype=float)
        if np.any(x < 0):
            raise InputError(f"intensity {float(x[x < 0].flat[0])!r} is negative: a "
                             "probability of collapse needs an intensity >= 0")
        with np.errstate(divide="ignore"):
            return norm.cdf(np.log(x / self.median) / self.dispersion)


# ---- Newton's method on concave log-likelihoods, vectorised over resamples -----------------

def _newton(loglik, delta, theta, iters: int = 200, tol: float = 1e-13):
    """Maximise ``loglik(delta, theta) -> (value, gradient (2, B), hessian (3, B))`` per
    row from the start (delta, theta) by Newton steps with step halving; rows that do not
    converge (no maximum) come back NaN."""
    delta, theta = np.array(delta, float), np.array(theta, float)
    value, g, h = loglik(delta, theta)
    done = ~np.isfinite(value)
    for _ in range(iters):
        det = h[0] * h[2] - h[1] ** 2
        with np.errstate(divide="ignore", invalid="ignore"):
            sd = -(h[2] * g[0] - h[1] * g[1]) / det
            st = -(h[0] * g[1] - h[1] * g[0]) / det
        sd, st = np.where(done, 0.0, sd), np.where(done, 0.0, st)
        t = np.ones_like(delta)
        for _ in range(60):  # halve the step until the likelihood does not fall
            nd, nt = delta + t * sd, theta + t * st
            new, ng, nh = loglik(nd, nt)
            ok = np.isfinite(new) & (new >= value - 1e-12 * np.abs(value))
            if ok.all():
                break
            t = np.where(ok, t, t / 2)
        ok = ok & ~done
        delta, theta = np.where(ok, nd, delta), np.where(ok, nt, theta)
        value = np.where(ok, new, value)
        g = np.where(ok, ng, g)
        h = np.where(ok, nh, h)
        small = (np.abs(t * sd) <= tol * (1 + np.abs(delta))) & \
            (np.abs(t * st) <= tol * (1 + np.abs(theta)))
        done |= small | ~ok
        if done.all():
            break
    bad = ~done | ~np.isfinite(value)
    return np.where(bad, np.nan, delta), np.where(bad, np.nan, theta)


def _censored_loglik(y, cen, w):
    """Log-likelihood of ``ln x`` (`y`) with right-censoring (`cen`), weights `w` (B, n),
    in (delta, theta); value (B,), gradient (2, B), hessian entries (dd, dt, tt) (3, B)."""
    from scipy.special import log_ndtr

    def f(delta, theta):
        d, t = delta[:, None], theta[:, None]
        with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
            z = t * y - d
            logsf = log_ndtr(-z)
            haz = np.exp(-0.5 * z * z - 0.5 * math.log(2 * math.pi) - logsf)
            curv = haz * (haz - z)
            lv = np.where(cen, logsf, np.log(t) - 0.5 * z * z)
            value = np.sum(w * lv, axis=1)
            value = np.where(theta > 0, value, -np.inf)
            gd = np.where(cen, haz, z)
            gt = np.where(cen, -haz * y, 1.0 / t - z * y)
            hdd = np.where(cen, -curv, -1.0)
            hdt = np.where(cen, curv * y, y)
            htt = np.where(cen, -curv * y * y, -1.0 / t ** 2 - y * y)
            grad = np.array([np.sum(w * gd, 1), np.sum(w * gt, 1)])
            hess = np.array([np.sum(w * hdd, 1), np.sum(w * hdt, 1), np.sum(w * htt, 1)])
        return value, grad, hess
    return f


def _lognormal_mle(y: np.ndarray, cen: np.ndarray, w: np.ndarray):
    """(median, dispersion) per row of weights `w` (B, n) by censored maximum likelihood;
    NaN for rows with fewer than two distinct uncensored values."""
    wo = w * ~cen
    so = wo.sum(1)
    with np.errstate(invalid="ignore", divide="ignore"):
        mu0 = (wo * y).sum(1) / so
        var0 = (wo * (y - mu0[:, None]) ** 2).sum(1) / so
        theta0 = 1.0 / np.sqrt(var0)
    # two distinct uncensored values at least (a spread above rounding)
    distinct = (so > 0) & (var0 > (1e-12 * np.maximum(1.0, np.abs(mu0))) ** 2)
    median, dispersion = np.full(w.shape[0], np.nan), np.full(w.shape[0], np.nan)
    if distinct.any():  # rows without a spread have no maximum: not iterated
        rows = w[distinct]
        delta, theta = _newton(_censored_loglik(y, cen, rows), mu0[distinct] * theta0[distinct],
                               theta0[distinct])
        ok = np.isfinite(theta) & (theta > 0)
        median[distinct] = np.where(ok, np.exp(delta / theta), np.nan)
        dispersion[distinct] = np.where(ok, 1.0 / theta, np.nan)
    return median, dispersion


def sandwich_cov(y: np.ndarray, cen: np.ndarray, w: np.ndarray, median, dispersion,
                 codes: np.ndarray | None = None) -> np.ndarray:
    """The sandwich (robust) covariance of ``(ln median, ln dispersion)`` of censored
    lognormal fits, one per row of weights `w` (B, n): ``I^-1 J I^-1`` with ``I`` the
    observed information and ``J`` the weighted sum of the observations' score products
    (Huber 1967; Freedman 2006, Am. Stat. 60(4)), so a sample with heavier tails than the
    lognormal's gets a wider standard error. With group `codes` the scores are summed over
    each group first (the cluster-robust form: records of one station are not independent).
    Shape (B, 2, 2); NaN where the fit is."""
    from scipy.special import log_ndtr

    m = np.asarray(median, dtype=float)
    b = np.asarray(dispersion, dtype=float)
    t, d = 1.0 / b, np.log(m) / b
    tt, dd = t[:, None], d[:, None]
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
        z = tt * y - dd
        haz = np.exp(-0.5 * z * z - 0.5 * math.log(2 * math.pi) - log_ndtr(-z))
        curv = haz * (haz - z)
        gd = np.where(cen, haz, z)
        gt = np.where(cen, -haz * y, 1.0 / tt - z * y)
        info = -np.array([[np.sum(w * np.where(cen, -curv, -1.0), 1),
                           np.sum(w * np.where(cen, curv * y, y), 1)],
                          [np.sum(w * np.where(cen, curv * y, y), 1),
                           np.sum(w * np.where(cen, -curv * y * y, -1.0 / tt ** 2 - y * y),
                                  1)]])
        if codes is None:
            score = np.array([[np.sum(w * gd * gd, 1), np.sum(w * gd * gt, 1)],
                              [np.sum(w * gd * gt, 1), np.sum(w * gt * gt, 1)]])
        else:  # group sums of the scores, each group counted as often as it was drawn
            onehot = (codes[:, None] == np.arange(int(codes.max()) + 1)[None, :]).astype(float)
            count = (w @ onehot) / onehot.sum(0)
            sd, st = np.nan_to_num(gd) @ onehot, np.nan_to_num(gt) @ onehot
            score = np.array([[np.sum(count * sd * sd, 1), np.sum(count * sd * st, 1)],
                              [np.sum(count * sd * st, 1), np.sum(count * st * st, 1)]])
        info = np.moveaxis(info, -1, 0)
        score = np.moveaxis(score, -1, 0)
        inv = np.linalg.inv(np.where(np.isfinite(info), info, np.eye(2)))
        cov = inv @ score @ inv
        # (ln median, ln beta) = (delta / theta, -ln theta): the Jacobian of (delta, theta)
        jac = np.zeros((m.size, 2, 2))
        jac[:, 0, 0], jac[:, 0, 1], jac[:, 1, 1] = t ** -1, -d / t ** 2, -1.0 / t
        out = jac @ cov @ np.swapaxes(jac, 1, 2)
    bad = ~(np.isfinite(m) & np.isfinite(b))
    out[bad] = np.nan
    return out


def studentized_interval(estimate: float, se: float, boot, boot_se,
                         confidence: float = CONFIDENCE) -> tuple[float, float]:
    """The studentized (bootstrap-t) interval (Efron & Tibshirani 1993, Section 12.5;
    Davison & Hinkley 1997, eq. 5.7) of a statistic on a scale where it is roughly
    pivotal: ``estimate - se t*_(1-a), estimate - se t*_(a)`` with ``t* = (boot -
    estimate) / boot_se`` over the resamples. NaN with fewer than 2 resamples."""
    b = np.asarray(boot, dtype=float)
    s = np.asarray(boot_se, dtype=float)
    ok = np.isfinite(b) & np.isfinite(s) & (s > 0)
    if ok.sum() < 2 or not (math.isfinite(estimate) and math.isfinite(se)):
        return _NAN2
    t = (b[ok] - estimate) / s[ok]
    lo, hi = np.quantile(t, [(1.0 - confidence) / 2.0, (1.0 + confidence) / 2.0])
    return float(estimate - se * hi), float(estimate - se * lo)


def _interval(values: np.ndarray, confidence: float) -> tuple[float, float]:
    a = (1.0 - confidence) / 2.0
    return float(np.quantile(values, a)), float(np.quantile(values, 1.0 - a))


def _check_bootstrap(confidence, resamples) -> int:
    if not (isinstance(confidence, (int, float)) and 0.0 < confidence < 1.0):
        raise InputError(f"confidence={confidence!r} must be a level in (0, 1), e.g. 0.9")
    if isinstance(resamples, bool) or not isinstance(resamples, (int, np.integer)) \
            or resamples < 0:
        raise InputError(f"resamples={resamples!r} must be a whole number >= 0")
    return int(resamples)


def bca_interval(estimate: float, boot, jack, confidence: float = CONFIDENCE
                 ) -> tuple[float, float]:
    """The BCa bootstrap interval (Efron 1987, eq. 2.3; Efron & Tibshirani 1993, eqs.
    14.9-14.15) of a statistic from its `estimate`, its bootstrap replicates `boot` (NaN
    left out) and its jackknife values `jack` (leave one record, or one group, out).

    ``z0 = Phi^-1((#{boot < estimate} + #{boot == estimate} / 2) / B)``,
    ``a = sum (m - j_i)^3 / (6 (sum (m - j_i)^2)^1.5)`` with ``m`` the jackknife mean, and
    the interval is the bootstrap quantiles at ``Phi(z0 + (z0 + z) / (1 - a (z0 + z)))`` for
    ``z = Phi^-1((1 -+ confidence) / 2)``. NaN when fewer than 2 replicates."""
    from scipy.stats import norm

    b = np.asarray(boot, dtype=float)
    b = b[np.isfinite(b)]
    j = np.asarray(jack, dtype=float)
    j = j[np.isfinite(j)]
    if b.size < 2 or not math.isfinite(estimate):
        return _NAN2
    share = (np.sum(b < estimate) + 0.5 * np.sum(b == estimate)) / b.size
    share = min(max(share, 0.5 / b.size), 1.0 - 0.5 / b.size)
    z0 = float(norm.ppf(share))
    dev = j.mean() - j if j.size > 2 else np.zeros(1)
    den = 6.0 * float(np.sum(dev ** 2)) ** 1.5
    acc = float(np.sum(dev ** 3)) / den if den > 0 else 0.0
    out = []
    for alpha in ((1.0 - confidence) / 2.0, (1.0 + confidence) / 2.0):
        z = z0 + float(norm.ppf(alpha))
        level = float(norm.cdf(z0 + z / (1.0 - acc * z)))
        out.append(float(np.quantile(b, min(max(level, 0.0), 1.0))))
    return out[0], out[1]


def _group_codes(groups, keep: np.ndarray, size: int) -> np.ndarray:
    """Integer group codes of the kept observations (each its own group without `groups`)."""
    if groups is None:
        return np.arange(size)
    g = np.asarray(groups, dtype=object).ravel()
    if g.size != keep.size:
        raise InputError(f"groups has {g.size} entries, capacities {keep.size}")
    return np.unique(g[keep].astype(str), return_inverse=True)[1].ravel()


def resample_weights(codes: np.ndarray, resamples: int, rng) -> np.ndarray:
    """Bootstrap weights (resamples, n) of observations with group `codes`: whole groups
    drawn with replacement, as many as there are groups."""
    n_groups = int(codes.max()) + 1 if codes.size else 0
    counts = rng.multinomial(n_groups, np.full(n_groups, 1.0 / n_groups), size=resamples)
    return counts[:, codes].astype(float)


def jackknife_weights(codes: np.ndarray) -> np.ndarray:
    """Weights (groups, n) leaving one group out at a time."""
    n_groups = int(codes.max()) + 1 if codes.size else 0
    return (codes[None, :] != np.arange(n_groups)[:, None]).astype(float)


def _unbiased_factor(n: int, unbiased: bool) -> float:
    return math.sqrt(n / (n - 1.0)) if unbiased and n > 1 else 1.0


def bootstrap_lognormal(capacities, censored=None, resamples: int = RESAMPLES,
                        seed: int | None = SEED, groups=None, unbiased: bool = False,
                        jackknife: bool = False):
    """Medians and dispersions of `fit_lognormal` on records resampled with replacement
    (whole groups when `groups` is given; the same inputs and refusals), NaN where a
    resample admits no fit.

    Parameters
    ----------
    capacities : array_like of float
        Collapse intensities, as for `fit_lognormal`. [units of the intensity]
    censored : array_like of bool, optional
        True where the capacity is a lower bound.
    resamples : int
        Bootstrap resamples.
    seed : int or None
        Seed of the resampling.
    groups : array_like of str or int, optional
        A label per capacity: whole groups are resampled.
    unbiased : bool
        Scale the dispersions by ``sqrt(n / (n - 1))``.
    jackknife : bool
        Also return the leave-one-group-out estimates (for BCa intervals).

    Returns
    -------
    (ndarray, ndarray) or (ndarray, ndarray, ndarray, ndarray)
        Shape ``(resamples,)`` each [units of the intensity], [1]; with ``jackknife=True``
        also the leave-one-group-out medians and dispersions (shape ``(groups,)``).
    """
    x, cen = _capacities(capacities, censored, "bootstrap_lognormal")
    raw = np.asarray(capacities, dtype=float).ravel()
    codes = _group_codes(groups, ~np.isnan(raw), x.size)
    y = np.log(x)
    rng = np.random.default_rng(seed)
    f = _unbiased_factor(x.size, unbiased)
    bm, bd = _lognormal_mle(y, cen, resample_weights(codes, int(resamples), rng))
    if not jackknife:
        return bm, bd * f
    jm, jd = _lognormal_mle(y, cen, jackknife_weights(codes))
    return bm, bd * f, jm, jd * f


def _capacities(capacities, censored, function: str = "fit_lognormal"
                ) -> tuple[np.ndarray, np.ndarray]:
    """The capacities that are there and their censored flags (refusing what the module
    docstring lists)."""
    x = numbers_argument(function, "capacities", capacities).ravel()
    raw = (np.zeros(x.shape) if censored is None
           else numbers_argument(function, "censored", censored).ravel())
    if raw.shape != x.shape:
        raise InputError(f"censored has {raw.size} entries, capacities {x.size}")
    if np.any(np.isinf(x)):
        raise InputError(f"capacity {float(x[np.isinf(x)][0])!r} at index "
                         f"{int(np.argmax(np.isinf(x)))} is infinite: give the intensity "
                         "the wall survived, flagged censored, instead")
    keep = ~np.isnan(x)
    if np.any(np.isnan(raw[keep])):
        k = int(np.flatnonzero(keep & np.isnan(raw))[0])
        raise InputError(f"censored is NaN at index {k}, where the capacity is {x[k]!r}: "
                         "say whether the wall collapsed (0) or survived (1)")
    x, c = x[keep], raw[keep] != 0
    if np.any(x <= 0):
        raise InputError(f"capacities must be positive (intensities at collapse); got "
                         f"{float(x[x <= 0][0])!r}")
    return x, c


def _intervals(y, cen, codes, w, point, factor, interval, confidence):
    """(median interval, dispersion interval, resamples kept) of a capacity fit from the
    bootstrap weights `w` (module docstring)."""
    med, disp = point
    bm, bd = _lognormal_mle(y, cen, w)
    ok = np.isfinite(bm)
    kept = int(ok.sum())
    if not kept:
        return _NAN2, _NAN2, 0
    if interval == "percentile":
        return _interval(bm[ok], confidence), _interval(bd[ok] * factor, confidence), kept
    if interval == "bca":
        jm, jd = _lognormal_mle(y, cen, jackknife_weights(codes))
        return (bca_interval(med, bm[ok], jm, confidence),
                bca_interval(disp, bd[ok] * factor, jd * factor, confidence), kept)
    grouped = codes if codes.max() + 1 < codes.size else None
    cov = sandwich_cov(y, cen, np.ones((1, y.size)), np.array([med]),
                       np.array([disp / factor]), grouped)[0]
    bcov = sandwich_cov(y, cen, w[ok], bm[ok], bd[ok], grouped)
    lm = studentized_interval(math.log(med), math.sqrt(cov[0, 0]), np.log(bm[ok]),
                              np.sqrt(bcov[:, 0, 0]), confidence)
    ld = studentized_interval(math.log(disp), math.sqrt(cov[1, 1]), np.log(bd[ok] * factor),
                              np.sqrt(bcov[:, 1, 1]), confidence)
    return (math.exp(lm[0]), math.exp(lm[1])), (math.exp(ld[0]), math.exp(ld[1])), kept


def fit_lognormal(capacities, censored=None, *, confidence: float = CONFIDENCE,
                  resamples: int = RESAMPLES, seed: int | None = SEED,
                  im: str | None = None, units: str | None = None, groups=None,
                  unbiased: bool = False, interval: str = "studentized") -> LognormalFit:
    """Median and dispersion of collapse capacities by maximum likelihood, with censoring,
    and their bootstrap intervals (studentized by default; module docstring).

    The likelihood (Baker 2015, truncated IDA) is the product of the lognormal density at
    every observed capacity and the probability of surviving the censoring intensity,
    ``1 - Phi(ln(c / theta) / beta)``, for every censored one. Without censoring it is
    maximised by the mean and the (population, 1/n) standard deviation of ``ln x``.

    Parameters
    ----------
    capacities : array_like
        Collapse intensities; for censored entries the intensity the wall survived.
        NaN entries (cells not run) are left out; an infinite one is refused.
        [units of the intensity]
    censored : array_like of bool or 0/1, optional
        True (1) where the capacity is a lower bound (no collapse up to it). Default: none.
        NaN where the capacity is NaN (a cell not run); NaN elsewhere is refused.
    confidence : float
        Two-sided level of the bootstrap intervals. [1]
    resamples : int
        Bootstrap resamples of the records (0: no intervals).
    seed : int or None
        Seed of the resampling (the same seed gives the same intervals).
    im, units : str, optional
        The intensity measure and its units, kept on the fit.
    groups : array_like of str or int, optional
        A label per capacity (station or event): the bootstrap resamples whole groups.
    unbiased : bool
        Scale the dispersion (and its interval) by ``sqrt(n / (n - 1))``.
    interval : {"studentized", "bca", "percentile"}
        The bootstrap interval (module docstring).

    Returns
    -------
    LognormalFit

    Raises
    ------
    urmx.errors.InputError
        Fewer than two distinct uncensored capacities (no dispersion can be fitted), a
        capacity that is not positive or is infinite, a NaN flag of a capacity.
    """
    resamples = _check_bootstrap(confidence, resamples)
    if interval not in INTERVALS:
        raise InputError(f"interval={interval!r}: use one of {', '.join(INTERVALS)}")
    x, cen = _capacities(capacities, censored)
    raw = np.asarray(capacities, dtype=float).ravel()
    codes = _group_codes(groups, ~np.isnan(raw), x.size)
    y = np.log(x)
    obs = y[~cen]
    if obs.size < 2 or np.ptp(obs) <= 1e-12 * max(1.0, float(np.max(np.abs(obs)))):
        # values that differ by rounding alone are not distinct: beta would be ~1e-16
        raise InputError(f"a lognormal fit needs at least two distinct uncensored capacities "
                         f"(got {obs.size} uncensored of {y.size})")
    med, disp = _lognormal_mle(y, cen, np.ones((1, y.size)))
    f = _unbiased_factor(y.size, unbiased)
    med, disp = float(med[0]), float(disp[0]) * f
    ci_m, ci_d, kept = _NAN2, _NAN2, 0
    n_groups = int(codes.max()) + 1
    if resamples and n_groups >= MIN_BOOTSTRAP:
        w = resample_weights(codes, resamples, np.random.default_rng(seed))
        ci_m, ci_d, kept = _intervals(y, cen, codes, w, (med, disp), f, interval,
                                      confidence)
    return LognormalFit(med, disp, int(y.size), int(cen.sum()), "capacities", ci_m, ci_d,
                        float(confidence), kept, im, units, interval,
                        n_groups if groups is not None else 0)


def function_interval(capacities, censored, func, *, groups=None,
                      confidence: float = CONFIDENCE, resamples: int = RESAMPLES,
                      seed: int | None = SEED, step: float = 1e-3) -> tuple[float, float]:
    """The studentized bootstrap interval of a positive function of a capacity fit,
    ``func(median, dispersion)`` (vectorised over arrays; e.g. a collapse rate), on its log
    scale: each resample (whole groups with `groups`) standardised by the delta-method
    standard error ``sqrt(g' V g)`` with ``V`` its sandwich covariance of
    ``(ln median, ln dispersion)`` (`sandwich_cov`) and ``g`` the gradient of ``ln func``
    by central differences of `step` in both logs. NaN bounds when there are fewer than
    `MIN_BOOTSTRAP` records (or groups) or no resample fits."""
    resamples = _check_bootstrap(confidence, resamples)
    x, cen = _capacities(capacities, censored, "function_interval")
    raw = np.asarray(capacities, dtype=float).ravel()
    codes = _group_codes(groups, ~np.isnan(raw), x.size)
    y = np.log(x)
    if not resamples or int(codes.max()) + 1 < MIN_BOOTSTRAP:
        return _NAN2
    med, disp = _lognormal_mle(y, cen, np.ones((1, y.size)))
    w = resample_weights(codes, resamples, np.random.default_rng(seed))
    bm, bd = _lognormal_mle(y, cen, w)
    ok = np.isfinite(bm)
    if not ok.any() or not np.isfinite(med[0]):
        return _NAN2
    grouped = codes if codes.max() + 1 < codes.size else None
    m, b = np.r_[med, bm[ok]], np.r_[disp, bd[ok]]
    cov = sandwich_cov(y, cen, np.vstack([np.ones((1, y.size)), w[ok]]), m, b, grouped)
    e = math.exp(step)

    def lf(mm, bb):
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.log(np.asarray(func(mm, bb), dtype=float))

    val = lf(m, b)
    grad = np.array([(lf(m * e, b) - lf(m / e, b)) / (2 * step),
                     (lf(m, b * e) - lf(m, b / e)) / (2 * step)]).T
    se = np.sqrt(np.einsum("bi,bij,bj->b", grad, cov, grad))
    lo, hi = studentized_interval(float(val[0]), float(se[0]), val[1:], se[1:], confidence)
    return math.exp(lo), math.exp(hi)


# ---- multiple stripes -------------------------------------------------------------------------

def _counts(name: str, values, shape) -> np.ndarray:
    """Whole-number counts (refusing fractions, NaN and infinities) broadcast to `shape`."""
    v = numbers_argument("fit_multiple_stripe", name, values)
    bad = ~np.isfinite(v) | (v != np.round(v))
    if np.any(bad):
        raise InputError(f"{name} must be whole numbers; got {float(v[bad].flat[0])!r}")
    try:
        return np.broadcast_to(v, shape).astype(np.int64)
    except ValueError:
        raise InputError(f"{name} has {v.size} entries, intensity {shape[0]}") from None


def _probit_loglik(lx, n, z):
    """Binomial log-likelihood of collapses `z` (B, k) of `n` (k,) at ln-levels `lx` (k,)
    in (delta, theta), ``P = Phi(theta lx - delta)``; as `_censored_loglik`."""
    from scipy.special import log_ndtr

    def f(delta, theta):
        with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
            eta = theta[:, None] * lx - delta[:, None]
            lp, lq = log_ndtr(eta), log_ndtr(-eta)
            logphi = -0.5 * eta * eta - 0.5 * math.log(2 * math.pi)
            r1, r0 = np.exp(logphi - lp), np.exp(logphi - lq)  # phi/Phi, phi/(1 - Phi)
            value = np.sum(np.where(z > 0, z * lp, 0.0) + np.where(n > z, (n - z) * lq, 0.0),
                           1)
            d1 = z * r1 - (n - z) * r0
            d2 = -z * r1 * (eta + r1) - (n - z) * r0 * (r0 - eta)
            grad = np.array([-np.sum(d1, 1), np.sum(d1 * lx, 1)])
            hess = np.array([np.sum(d2, 1), -np.sum(d2 * lx, 1), np.sum(d2 * lx * lx, 1)])
        return value, grad, hess
    return f


def _separated(lx: np.ndarray, n: np.ndarray, z: np.ndarray) -> np.ndarray:
    """Rows of collapses `z` (B, k) with no overlap of collapses and survivors: every level
    with a collapse at or above every level with a survivor (no maximum)."""
    lowest_collapse = np.where(z > 0, lx, np.inf).min(1)
    highest_survivor = np.where(z < n, lx, -np.inf).max(1)
    return lowest_collapse >= highest_survivor


def _stripe_mle(lx, n, z, mid, spread):
    """(median, dispersion) per row of collapses `z` (B, k); NaN where separated or not
    rising."""
    fit = ~_separated(lx, n, z)  # separated rows have no maximum: not iterated
    median, dispersion = np.full(z.shape[0], np.nan), np.full(z.shape[0], np.nan)
    if fit.any():
        b = int(fit.sum())
        delta, theta = _newton(_probit_loglik(lx, n, z[fit]), np.full(b, mid / spread),
                               np.full(b, 1.0 / spread))
        ok = np.isfinite(theta) & (theta > 0)
        with np.errstate(invalid="ignore", divide="ignore"):
            median[fit] = np.where(ok, np.exp(delta / theta), np.nan)
            dispersion[fit] = np.where(ok, 1.0 / theta, np.nan)
    return median, dispersion


def fit_multiple_stripe(intensity, analyses, collapses, *, confidence: float = CONFIDENCE,
                        resamples: int = RESAMPLES, seed: int | None = SEED,
                        im: str | None = None, units: str | None = None) -> LognormalFit:
    """Median and dispersion from counts of collapses at a few intensity levels (multiple
    stripe analysis) by maximum likelihood with a binomial likelihood (Baker 2015), and
    their bootstrap intervals (the records of each stripe resampled: binomial counts).

    Parameters
    ----------
    intensity : array_like
        Intensity levels (stripes), positive. [units of the intensity]
    analyses : array_like of int
        Number of records analysed at each level (or one number for all); whole numbers.
    collapses : array_like of int
        Number of collapses at each level; whole numbers.
    confidence, resamples, seed, im, units
        As `fit_lognormal`. The intervals take the stripes as independent (a
        multiple-stripe analysis with its own records at each level); counts made from one
        set of capacities (`stripe_counts`) are not, and their intervals come out too
        narrow: bootstrap the capacities (`fit_lognormal`) instead.

    Returns
    -------
    LognormalFit
        With ``method = "multiple-stripe"`` and ``n`` the total number of analyses.

    Raises
    ------
    urmx.errors.InputError
        Counts that are not whole numbers or are inconsistent, or counts whose likelihood
        has no maximum: no collapse at all, collapse everywhere, one intensity level, or
        stripes perfectly separated (none collapse up to a level, all collapse above it),
        or a collapse fraction that does not rise with intensity.
    """
    resamples = _check_bootstrap(confidence, resamples)
    x = numbers_argument("fit_multiple_stripe", "intensity", intensity).ravel()
    n = _counts("analyses", analyses, x.shape)
    z = _counts("collapses", collapses, np.shape(np.asarray(collapses).ravel())).ravel()
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
    if np.unique(lx).size < 2:
        raise InputError(f"a multiple-stripe fit needs at least two intensity levels: one "
                         f"level ({x[0]:g}) cannot fix both the median and the dispersion "
                         "(the likelihood has no maximum)")
    if _separated(lx, n, z[None, :])[0]:
        lo = float(np.exp(np.where(z < n, lx, -np.inf).max()))
        hi = float(np.exp(np.where(z > 0, lx, np.inf).min()))
        raise InputError(f"the stripes are perfectly separated (all survive up to {lo:g}, "
                         f"all collapse from {hi:g}): the likelihood has no maximum (the "
                         "dispersion tends to 0); add stripes where some records collapse "
                         "and some survive")
    frac = z / n
    mid = lx[np.argmin(np.abs(frac - 0.5))]
    spread = max(float(np.ptp(lx)) / 4.0, 0.05)
    med, disp = _stripe_mle(lx, n, z[None, :], mid, spread)
    if not np.isfinite(med[0]):
        raise InputError("the collapse fraction does not rise with intensity over these "
                         "stripes: the likelihood has no maximum with a positive dispersion")
    ci_m, ci_d, kept = _NAN2, _NAN2, 0
    if resamples and n.sum() >= MIN_BOOTSTRAP:
        rng = np.random.default_rng(seed)
        zb = rng.binomial(n, frac, size=(resamples, x.size))
        bm, bd = _stripe_mle(lx, n, zb, mid, spread)
        ok = np.isfinite(bm)
        kept = int(ok.sum())
        if kept:
            ci_m, ci_d = _interval(bm[ok], confidence), _interval(bd[ok], confidence)
    return LognormalFit(float(med[0]), float(disp[0]), int(n.sum()), 0, "multiple-stripe",
                        ci_m, ci_d, float(confidence), kept, im, units, "percentile")


def stripe_counts(capacities, censored, levels) -> tuple[np.ndarray, np.ndarray]:
    """Number of analyses and of collapses at each intensity level implied by collapse
    capacities (a wall collapses at ``x`` when its capacity is at most ``x``).

    A censored capacity ``c`` says nothing at levels above ``c``: those records are not
    counted there. Refuses what `fit_lognormal` refuses.

    Parameters
    ----------
    capacities : array_like of float
        Collapse capacities, one per record. [units of the intensity]
    censored : array_like of bool
        True where the capacity is a lower bound.
    levels : array_like of float
        The intensity levels (stripes). [units of the intensity]

    Returns
    -------
    (ndarray, ndarray)
        ``analyses`` and ``collapses`` per level.
    """
    x, c = _capacities(capacities, censored, "stripe_counts")
    lv = numbers_argument("stripe_counts", "levels", levels).ravel()
    known = ~c[None, :] | (lv[:, None] <= x[None, :])
    collapsed = ~c[None, :] & (x[None, :] <= lv[:, None])
    return known.sum(axis=1), collapsed.sum(axis=1)
