"""Coverage of the fits' 90 % intervals by simulation (issue 38): sets of lognormal
capacities with a known median, dispersion and collapse rate, fitted as urmx fits them
(`urmx.fragility.fit_lognormal`, studentized bootstrap; the rate's interval by
`urmx.fragility.fits.function_interval` over a power-law hazard curve integrated by
`urmx.fragility.risk.rates`). The figures are quoted in the README ("Collapse fragility").

Seeded: the same sets and resamples every run, so the figures are exact numbers of this
code, not a tolerance on a random draw. A coverage measured over SETS sets has a standard
error of about sqrt(0.09 / SETS) (1.1 points at 800, 1.7 at 300)."""

from __future__ import annotations

import math
from concurrent.futures import ProcessPoolExecutor
from multiprocessing import get_context

import numpy as np
import pytest

from urmx.fragility import fit_lognormal
from urmx.fragility.fits import function_interval
from urmx.fragility.risk import HazardCurve, rates

MEDIAN, BETA = 0.5, 0.4  # [g], [1]
K0, K = 1.13e-4, 2.61  # the illustrative power-law hazard curve (catalog/hazard)
SETS, RESAMPLES = 800, 1000  # RESAMPLES: the fits' default (urmx.fragility.RESAMPLES)
#: the power law over a range wide enough that no rate needs extending beyond it
CURVE = HazardCurve(np.geomspace(1e-3, 1e3, 60), K0 * np.geomspace(1e-3, 1e3, 60) ** -K)
TRUE_RATE = K0 * MEDIAN ** -K * math.exp(K * K * BETA * BETA / 2)  # Cornell et al. 2002


def rate(median, beta):
    """The collapse rate over the power-law curve in closed form (what `rates` integrates:
    `test_rates_is_the_closed_form` holds them together), vectorised."""
    return K0 * np.asarray(median) ** -K * np.exp(K * K * np.asarray(beta) ** 2 / 2)


def test_rates_is_the_closed_form():
    m, b = np.array([0.3, 0.5, 0.9]), np.array([0.2, 0.4, 0.6])
    np.testing.assert_allclose(rates(CURVE, m, b)[0], rate(m, b), rtol=1e-4)


def _one_set(item: tuple) -> tuple[np.ndarray, np.ndarray]:
    """One simulated set (x, censored, its seed): which intervals hold the truth, and which
    miss it low."""
    x, cen, k = item
    hits, low = np.zeros(3), np.zeros(3)
    if np.sum(~cen) < 2:
        return hits, low
    f = fit_lognormal(x, cen, resamples=RESAMPLES, seed=k)
    r = function_interval(x, cen, rate, resamples=RESAMPLES, seed=k)
    for j, ((lo, hi), true) in enumerate(((f.median_ci, MEDIAN),
                                          (f.dispersion_ci, BETA), (r, TRUE_RATE))):
        hits[j] += lo <= true <= hi
        low[j] += hi < true
    return hits, low


def coverage(n: int, censored_share: float = 0.0, sets: int = SETS, seed: int = 38):
    """Share of `sets` simulated sets of `n` capacities whose 90 % intervals hold the true
    median, beta and collapse rate, and the shares missing low (interval below the truth).
    With `censored_share`, capacities above the matching quantile are censored there. The
    sets are drawn here in order and fitted in two processes (each fit is seeded by its
    set's number, so the counts do not depend on where it runs)."""
    from scipy.stats import norm

    rng = np.random.default_rng(seed)
    cap = MEDIAN * math.exp(BETA * norm.ppf(1 - censored_share)) if censored_share else None
    items = []
    for k in range(sets):
        x = MEDIAN * np.exp(BETA * rng.standard_normal(n))
        cen = np.zeros(n, bool) if cap is None else x > cap
        if cap is not None:
            x = np.where(cen, cap, x)
        items.append((x, cen, k))
    with ProcessPoolExecutor(2, mp_context=get_context("spawn")) as pool:
        counts = list(pool.map(_one_set, items, chunksize=25))
    hits = np.sum([c[0] for c in counts], axis=0)
    low = np.sum([c[1] for c in counts], axis=0)
    return hits / sets, low / sets


@pytest.mark.slow
def test_coverage_at_40_records_is_nominal():
    hits, low = coverage(40)
    # median, beta, rate: measured 0.904, 0.870, 0.884 (README); missing low 0.054, 0.070,
    # 0.056: the misses fall on both sides (the percentile interval of beta missed low 16 %
    # of the time, high 1 %)
    np.testing.assert_allclose(hits, [0.90375, 0.87, 0.88375], atol=1e-12)
    assert np.all((hits >= 0.87) & (hits <= 0.93)), hits
    assert np.all(low <= 0.08), low


@pytest.mark.slow
def test_coverage_at_10_records_and_with_censoring_is_stated():
    hits10, _ = coverage(10, sets=300)
    hits_c, _ = coverage(40, censored_share=0.2, sets=300)
    # measured (README), median, beta, rate over 300 sets each
    np.testing.assert_allclose(hits10, [0.91666667, 0.86666667, 0.87], atol=5e-9)
    np.testing.assert_allclose(hits_c, [0.89, 0.87333333, 0.89333333], atol=5e-9)


def test_the_percentile_interval_of_beta_misses_low():
    """The check the studentized interval answers: the percentile interval of the MLE of
    beta (biased low) misses the true beta low far more often than high at n = 40 (issue
    38: 15.9 % low, 1.4 % high); measured here 12.0 % low, 1.3 % high, coverage 86.7 %."""
    rng = np.random.default_rng(5)
    low = high = 0
    for k in range(300):
        x = MEDIAN * np.exp(BETA * rng.standard_normal(40))
        lo, hi = fit_lognormal(x, resamples=RESAMPLES, seed=k,
                               interval="percentile").dispersion_ci
        low += hi < BETA
        high += lo > BETA
    assert (low, high) == (36, 4)
    assert low > 3 * high
