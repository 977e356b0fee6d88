"""Ranking candidate predictors of a log collapse capacity (issue 37): the cross-validated
share of variance each predictor and each pair explains, its bootstrap interval over walls,
and the smallest set within the ranking's uncertainty of the best; numpy only.

The model of a set of predictors ``x_1..x_k`` is the linear regression of ``y = ln C`` (the
log median collapse capacity of each wall) on ``ln x_1..ln x_k`` with an intercept: a power
law ``C = exp(a) x_1^b_1 ... x_k^b_k``. Its score is the **cross-validated share of
variance** (Hastie, Tibshirani & Friedman 2009, The Elements of Statistical Learning,
Section 7.10; also called Q^2 or predictive R^2)::

    share = 1 - sum_i (y_i - yhat_{-f(i)}(x_i))^2 / sum_i (y_i - mean(y))^2

where ``yhat_{-f}`` is fitted on every fold but fold ``f`` and ``f(i)`` is wall ``i``'s fold
(k-fold, the folds a seeded shuffle of the walls). A wall is scored only by a fit it took no
part in (:func:`folds` assigns folds by wall *identity*, so the copies of one wall that a
bootstrap draws all fall in the same fold). A share near 0 or below says the predictor
predicts no better than the mean.

The uncertainty is a nonparametric bootstrap over walls (Efron & Tibshirani 1993, An
Introduction to the Bootstrap, Ch. 6 and 13): the walls resampled with replacement, the
share of every set recomputed on each replicate (the same replicates for every set, so
differences are paired), the interval the 2.5 and 97.5 percentiles.

The recommended criterion (:func:`recommend`) is the smallest set (fewest predictors; among
those, the highest share) whose paired bootstrap difference from the best set's share has a
95 % interval reaching 0: the simplest criterion the data cannot tell from the best. urmx
chose this rule; it is the "one standard error" idea of Hastie et al. (Section 7.10) with
the bootstrap interval in place of the standard error.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, field

import numpy as np

LEVEL = 0.95  # of the bootstrap intervals


def folds(n: int, k: int = 5, seed: int = 0) -> np.ndarray:
    """Fold of each of `n` walls: a seeded shuffle cut into `k` near-equal folds."""
    if k < 2 or n < k:
        raise ValueError(f"k-fold cross-validation needs 2 <= k <= n walls (k={k}, n={n})")
    order = np.random.default_rng(seed).permutation(n)
    out = np.empty(n, dtype=np.int64)
    out[order] = np.arange(n) % k
    return out


def bootstrap_sample(fold: np.ndarray, rng: np.random.Generator) -> tuple[np.ndarray,
                                                                         np.ndarray]:
    """(walls drawn with replacement, their folds): each copy of a wall keeps the wall's
    own fold, so no wall is ever in both the fit and the score of a fold."""
    idx = rng.integers(0, len(fold), len(fold))
    return idx, fold[idx]


def leaks(walls: np.ndarray, fold: np.ndarray) -> bool:
    """Whether some wall (an id per row) sits in two folds: it would be both fitted and
    scored (the check of the tests)."""
    walls, fold = np.asarray(walls), np.asarray(fold)
    return any(len(np.unique(fold[walls == w])) > 1 for w in np.unique(walls))


def cv_predictions(x: np.ndarray, y: np.ndarray, fold: np.ndarray) -> np.ndarray:
    """Out-of-fold predictions of the linear regression of `y` on the columns of `x` with an
    intercept: each wall's prediction from the fit on the other folds.

    Parameters
    ----------
    x : ndarray, shape (n, k)
        Predictors (already log-transformed).
    y : ndarray, shape (n,)
    fold : ndarray of int, shape (n,)
        Fold of each row (:func:`folds`; copies of one wall share its fold).
    """
    x = np.asarray(x, dtype=float).reshape(len(y), -1)
    a = np.column_stack([np.ones(len(y)), x])
    out = np.empty(len(y))
    for f in np.unique(fold):
        test = fold == f
        coef = np.linalg.lstsq(a[~test], y[~test], rcond=None)[0]
        out[test] = a[test] @ coef
    return out


def cv_share(x: np.ndarray, y: np.ndarray, fold: np.ndarray) -> float:
    """Cross-validated share of the variance of `y` explained by `x` (module docstring)."""
    y = np.asarray(y, dtype=float)
    resid = y - cv_predictions(x, y, fold)
    return float(1.0 - np.sum(resid ** 2) / np.sum((y - y.mean()) ** 2))


def fit(x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, float]:
    """(intercept and slopes, residual dispersion) of the least-squares fit of `y` on `x`;
    the dispersion is the residuals' standard deviation with n - k - 1 degrees of
    freedom."""
    x = np.asarray(x, dtype=float).reshape(len(y), -1)
    a = np.column_stack([np.ones(len(y)), x])
    coef = np.linalg.lstsq(a, y, rcond=None)[0]
    resid = y - a @ coef
    return coef, float(math.sqrt(np.sum(resid ** 2) / (len(y) - a.shape[1])))


def vif(x: np.ndarray) -> np.ndarray:
    """Variance inflation factor of each column of `x`: ``1 / (1 - R_j^2)``, R_j^2 of column
    j regressed on the others (1 for a single column)."""
    x = np.asarray(x, dtype=float)
    x = x.reshape(len(x), -1)
    out = np.ones(x.shape[1])
    for j in range(x.shape[1]):
        others = np.delete(x, j, axis=1)
        if others.shape[1] == 0:
            continue
        a = np.column_stack([np.ones(len(x)), others])
        r = x[:, j] - a @ np.linalg.lstsq(a, x[:, j], rcond=None)[0]
        r2 = 1.0 - np.sum(r ** 2) / np.sum((x[:, j] - x[:, j].mean()) ** 2)
        out[j] = math.inf if r2 >= 1.0 else 1.0 / (1.0 - r2)
    return out


@dataclass
class Ranking:
    """The ranked sets of one population and one capacity measure.

    Attributes
    ----------
    sets : list of tuple of str
        Every set scored, best first.
    share : ndarray
        Cross-validated share of each set on the walls as sampled.
    lower, upper : ndarray
        Its bootstrap interval (`LEVEL`).
    boot : ndarray, shape (replicates, sets)
        The share of each set on each bootstrap replicate (paired across sets).
    vif : list of float
        Largest variance inflation factor of each set's regression.
    n : int
        Walls ranked.
    """

    sets: list[tuple[str, ...]]
    share: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    boot: np.ndarray
    vif: list[float] = field(default_factory=list)
    n: int = 0

    def index(self, names: tuple[str, ...]) -> int:
        return self.sets.index(tuple(names))

    def rank(self, names: tuple[str, ...]) -> int:
        """1-based rank of a set."""
        return self.index(names) + 1


def candidate_sets(names: list[str], pairs: bool = True) -> list[tuple[str, ...]]:
    """Every predictor alone and (with `pairs`) every pair, in `names` order."""
    out = [(n,) for n in names]
    if pairs:
        out += list(itertools.combinations(names, 2))
    return out


def rank(predictors: dict[str, np.ndarray], y: np.ndarray, *, pairs: bool = True,
         k: int = 5, replicates: int = 200, seed: int = 0,
         sets: list[tuple[str, ...]] | None = None) -> Ranking:
    """Rank every predictor alone and every pair by cross-validated share (module
    docstring).

    Parameters
    ----------
    predictors : dict of str to ndarray, shape (n,)
        Each predictor per wall, already on the scale it enters (log for a power law).
    y : ndarray, shape (n,)
        The log capacity per wall.
    pairs : bool
        Score every pair too.
    k : int
        Folds.
    replicates : int
        Bootstrap replicates over walls.
    seed : int
        Seed of the folds and the bootstrap.
    sets : list of tuple, optional
        The sets to score instead of :func:`candidate_sets`.
    """
    y = np.asarray(y, dtype=float)
    n = len(y)
    sets = sets or candidate_sets(list(predictors), pairs)
    cols = {s: np.column_stack([np.asarray(predictors[p], float) for p in s]) for s in sets}
    fold = folds(n, k, seed)
    share = np.array([cv_share(cols[s], y, fold) for s in sets])
    rng = np.random.default_rng(seed + 1)
    boot = np.empty((replicates, len(sets)))
    for b in range(replicates):
        idx, fb = bootstrap_sample(fold, rng)
        for j, s in enumerate(sets):
            boot[b, j] = cv_share(cols[s][idx], y[idx], fb)
    q = (1.0 - LEVEL) / 2.0
    lower, upper = np.quantile(boot, [q, 1.0 - q], axis=0)
    order = np.argsort(-share, kind="stable")
    return Ranking(sets=[sets[i] for i in order], share=share[order], lower=lower[order],
                   upper=upper[order], boot=boot[:, order],
                   vif=[float(np.max(vif(cols[sets[i]]))) for i in order], n=n)


def within(r: Ranking, index: int) -> bool:
    """Whether set `index` is within the ranking's uncertainty of the best: the 95 %
    interval of its paired bootstrap difference from the best's share reaches 0."""
    q = (1.0 - LEVEL) / 2.0
    return index == 0 or bool(np.quantile(r.boot[:, index] - r.boot[:, 0], 1.0 - q) >= 0.0)


def recommend(r: Ranking) -> int:
    """Index in `r.sets` of the recommended criterion: the smallest set whose paired
    bootstrap difference from the best set's share has its 95 % interval reaching 0; among
    sets of that size, the highest share (module docstring)."""
    ok = [i for i in range(len(r.sets)) if within(r, i)]
    size = min(len(r.sets[i]) for i in ok)
    return min((i for i in ok if len(r.sets[i]) == size), key=lambda i: -r.share[i])
