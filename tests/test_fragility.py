"""Collapse fragility: the capacity search, intensity measures, lognormal fits, the IDA study
kind (schema, censoring, resume) and the brute-force check of capacities on real cells.

The search and the study machinery are tested on stand-in kernels whose collapse intensity
is known exactly; the real kernel enters only where physics or the search's own guarantees
decide the expected answer (collapse at the capacity, survival within rtol below it, and
a fine brute-force scan of sampled cells of the catalog study).
"""

from __future__ import annotations

import math
import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
from scipy.stats import norm

import urmx.records
import urmx.variables
from urmx import fragility as F
from urmx import study as st
from urmx.catalog import CatalogError
from urmx.model import RIGID, Wall
from urmx.study.file import load_study

from .fixtures.records import records_file
from .fixtures.signals import interruptible
from .helpers.ida_study import (
    ACC,
    CALLS,
    FAIL_AT,
    IDA_STUDY,
    REP_IDA,
    SMALL_IDA,
    Interrupt,
    stiff_kernel,
    study_kernel,
    threshold,
)


@pytest.fixture(scope="module")
def library(records_dir) -> Path:
    """The records folder with the FEMA P695 far-field library (fails under CI, skips
    elsewhere when it is missing)."""
    records_file("library/catalog.tsv")
    return records_dir


def wall(slenderness: float = 16.0, **changes) -> Wall:
    """A parametric-like wall (230 mm, crack at 2/3) on a D1-like top diaphragm."""
    h = slenderness * 0.23
    w = Wall(0.23, h, 2 / 3, 5524.0 * h, top_mass=12869.5, top_stiffness=815e3,
             top_damping=0.12)
    return w.replace(**changes) if changes else w


# ---- the search on known collapse sets ---------------------------------------------------------

def predicate(collapse, ratio=lambda s: 0.0):
    """``analyse`` of a known collapse set; the instability ratio of a survivor is
    `ratio` (0: the hunt strides as far as it may)."""
    calls = []

    def analyse(s):
        calls.append(s)
        c = bool(collapse(s))
        return c, 1.0 if c else float(ratio(s))
    return analyse, calls


def on_grid(x, start=1.0, step=1.05):
    k = math.log(x / start) / math.log(step)
    return abs(k - round(k)) < 1e-9


@pytest.mark.parametrize("threshold", [0.37, 1.0, 1.93, 12.5])
def test_search_brackets_a_threshold_to_rtol(threshold):
    """A wall whose instability ratio grows in proportion to the intensity and that
    collapses at `threshold`: the hunt strides (at most x3) to a ratio of 0.5, walks the
    1.05 grid to the first collapse and bisects that one grid step to rtol."""
    analyse, calls = predicate(lambda s: s >= threshold, lambda s: s / threshold)
    cap, censored = F.search(analyse, 1.0, 100.0, 1.05, 1e-3)
    assert not censored
    assert threshold <= cap <= threshold * (1 + 1e-3)
    survivors = [s for s in calls if s < threshold]
    assert max(survivors) >= cap / (1 + 1e-3)  # a survivor within rtol below
    n_bisect = math.ceil(math.log2(math.log(1.05) / math.log(1 + 1e-3)))
    hunt = calls[:len(calls) - n_bisect]
    assert all(on_grid(s) for s in hunt)  # the hunt stays on the grid 1.05**k
    up = [b / a for a, b in zip(hunt, hunt[1:], strict=False) if b > a]
    assert max(up) <= 3.0 * (1 + 1e-12)
    # from ratio 0.5 on, the hunt walks the grid step by step (no window skipped there)
    near = [b / a for a, b in zip(hunt, hunt[1:], strict=False)
            if a / threshold >= 0.5 and b > a]
    assert all(r == pytest.approx(1.05) for r in near)
    # about log(2)/log(1.05) = 14 grid steps between ratio 0.5 and collapse, 6 bisections
    assert len(calls) <= 3 + math.ceil(math.log(2) / math.log(1.05)) + 1 + n_bisect


def test_search_strides_far_from_collapse():
    """A survivor with a small ratio is followed by a stride of x3 (the largest), one with
    ratio 0.25 by x2 (to ratio 0.5, taking the ratio proportional), one above 0.5 by one
    grid step."""
    for r, expected in ((0.01, 1.05 ** 22), (0.25, 1.05 ** 14), (0.6, 1.05)):
        analyse, calls = predicate(lambda s: s > 1.0, lambda s, r=r: r)
        F.search(analyse, 1.0, 100.0, 1.05, 1e-3)
        assert calls[1] == pytest.approx(expected, rel=1e-12)


def test_search_is_censored_at_the_largest_scale():
    analyse, calls = predicate(lambda s: s >= 7.0)
    cap, censored = F.search(analyse, 1.0, 5.0, 2.0, 1e-3)
    assert censored and cap == 5.0
    assert calls == [1.0, 2.0, 4.0, 5.0]  # the cap itself is analysed, then the hunt stops


def test_search_first_collapse_convention():
    """A collapse window inside the bracket is found (the bracket keeps a collapse above
    and a survivor below); survival above the capacity is ignored; a window narrower than
    a stride, where the ratio gave no warning, is stepped over (the documented limit of the
    convention)."""
    window_in_bracket = lambda s: 1.3 <= s < 1.4 or s >= 1.45  # noqa: E731
    cap, _ = F.search(predicate(window_in_bracket)[0], 1.0, 100.0, 1.5, 1e-4)
    assert cap == pytest.approx(1.3, rel=1e-4)
    resurrects = lambda s: 1.2 <= s < 1.6 or s >= 3.0  # noqa: E731
    cap, _ = F.search(predicate(resurrects, lambda s: 0.8)[0], 1.0, 100.0, 1.5, 1e-4)
    assert cap == pytest.approx(1.2, rel=1e-4)
    narrow_below = lambda s: 1.10 <= s < 1.12 or s >= 2.0  # noqa: E731
    cap, _ = F.search(predicate(narrow_below)[0], 1.0, 100.0, 1.05, 1e-4)
    assert cap == pytest.approx(2.0, rel=1e-4)
    # the same window, walked on the grid because the ratio says the wall is near collapse
    cap, _ = F.search(predicate(narrow_below, lambda s: 0.8)[0], 1.0, 100.0, 1.05, 1e-4)
    assert cap == pytest.approx(1.10, rel=1e-4)


def test_search_hunts_down_then_up_when_the_start_collapses():
    analyse, calls = predicate(lambda s: s >= 0.2, lambda s: s / 0.2)
    cap, censored = F.search(analyse, 1.0, 100.0, 1.05, 1e-3)
    assert not censored and 0.2 <= cap <= 0.2 * 1.001
    down = 1.05 ** -22  # strides of a whole number of grid steps, at most a factor 3
    assert calls[:3] == pytest.approx([1.0, down, down**2])
    assert all(on_grid(s) for s in calls[:3])
    assert calls[3] > calls[2]  # then up again from the survivor


# ---- collapse_capacity with a stand-in kernel ---------------------------------------------------

def threshold_kernel(threshold):
    """Collapses iff the scaled record's PGA reaches `threshold` [m s-2]."""
    calls = []

    def kernel(w, ag, dt, *, scale=1.0, cor=0.8, impact="scale", **kw):
        pga = scale * float(np.max(np.abs(ag)))
        calls.append(pga)
        ratio = min(1.0, pga / threshold)
        return {"status": "collapsed" if ratio >= 1.0 else "ok", "instability_ratio": ratio}
    kernel.calls = calls
    return kernel


def test_capacity_in_intensity_units_and_ida_points():
    acc = np.sin(np.linspace(0, 20, 1001)) * 1.7
    k = threshold_kernel(4.2)
    res = F.collapse_capacity(wall(), (acc, 0.01), im="pga", kernel=k)
    assert not res.censored and res.im == "pga" and res.units == "m s-2"
    assert 4.2 <= res.capacity <= 4.2 * 1.001
    assert res.record_intensity == pytest.approx(np.max(np.abs(acc)), rel=1e-12)
    assert res.scale == pytest.approx(res.capacity / res.record_intensity, rel=1e-12)
    assert res.analyses == len(k.calls) == res.intensity.size
    assert np.all(np.diff(res.intensity) > 0)
    np.testing.assert_allclose(res.intensity, sorted(k.calls), rtol=1e-12)
    np.testing.assert_allclose(res.instability_ratio, np.minimum(1, res.intensity / 4.2))
    assert res.collapsed.tolist() == [x >= 4.2 for x in res.intensity]
    # the same threshold in scale factors
    sc = F.collapse_capacity(wall(), (acc, 0.01), im="scale", kernel=threshold_kernel(4.2))
    assert sc.capacity == pytest.approx(res.scale, rel=2e-3)
    # censored: the capacity is max_intensity, flagged
    cen = F.collapse_capacity(wall(), (acc, 0.01), max_intensity=3.0, kernel=k)
    assert cen.censored and cen.capacity == 3.0 and not cen.collapsed.any()
    assert cen.intensity[-1] == pytest.approx(3.0)


@pytest.mark.parametrize("kw, match", [
    (dict(im="sa"), "im='sa' is not an intensity measure"),
    (dict(step=1.0), "step=1.0 must be greater than 1"),
    (dict(rtol=0), "rtol=0 must be a positive"),
    (dict(max_intensity=-1), "max_intensity=-1"),
])
def test_capacity_rejects_bad_arguments(kw, match):
    acc = np.sin(np.linspace(0, 20, 1001))
    with pytest.raises(ValueError, match=match):
        F.collapse_capacity(wall(), (acc, 0.01), kernel=threshold_kernel(1.0), **kw)


def test_capacity_rejects_bad_records():
    with pytest.raises(ValueError, match="all zeros"):
        F.collapse_capacity(wall(), (np.zeros(100), 0.01), kernel=threshold_kernel(1.0))
    with pytest.raises(ValueError, match="dt=-0.01 must be a positive"):
        F.collapse_capacity(wall(), (np.ones(100), -0.01), kernel=threshold_kernel(1.0))
    with pytest.raises(ValueError, match="record must be an obspy Trace"):
        F.collapse_capacity(wall(), 3.0, kernel=threshold_kernel(1.0))


# ---- intensity measures and the wall's periods --------------------------------------------------

def test_rocking_period_from_the_pinned_mechanism_by_hand():
    """J = T^T M_f T with T = [1, -a1/a2] (MODEL.md sections 5-6, family 2) and the two
    segments on their softening branches at 0.6 theta_ins (Table I strengths)."""
    for s in (8.0, 16.0, 24.0):
        w = wall(s)
        b, a1, a2, m, mdt = w.thickness, w.a1, w.a2, w.mass, w.top_mass
        m1, m2 = m * a1 / w.height, m * a2 / w.height
        k = a1 / a2
        M11 = m1 * (a1**2 + b**2) / 3 + (m2 + mdt) * (b**2 + a1**2)
        M12 = a1 * a2 * (0.5 * m2 + mdt) - (m2 + mdt) * b**2 / 2
        M22 = m2 * (a2**2 + b**2) / 3 + mdt * (0.25 * b**2 + a2**2)
        J = M11 - 2 * k * M12 + k * k * M22
        g = 9.81
        M0_2, th0_2 = (0.5 * m1 + m2 + mdt) * b * g, b / a1
        M0_1, th0_1 = (0.5 * m2 + 0.5 * mdt) * b * g, b / (2 * a2) * (m2 + mdt) / (0.5 * m2 + mdt)
        th_ins = min(th0_2, th0_1 / k)
        thd = 0.6 * th_ins
        assert thd > th0_2 * (1 - 0.675) and k * thd > th0_1 * (1 - 0.675)  # softening
        R = M0_2 * (1 - thd / th0_2) + k * M0_1 * (1 - k * thd / th0_1)
        assert F.rocking_period(w) == pytest.approx(2 * math.pi * math.sqrt(J * thd / R),
                                                    rel=1e-12)
        # the plateau of both segments holds the most: Mi = 0.675 M0 each, over m a1 / 2
        assert F.static_acceleration(w) == pytest.approx(
            0.675 * (M0_2 + k * M0_1) / (0.5 * m * a1), rel=1e-9)
        # and no rotation up to instability holds more (a dense scan of the curve)
        _, coupling, restoring, th_max, _ = F.mechanism.pinned_mechanism(w)
        dense = max(restoring(t) for t in np.linspace(0, th_max, 2001)) / coupling
        assert dense <= F.static_acceleration(w) * (1 + 1e-12)
    periods = [F.rocking_period(wall(s)) for s in (8, 12, 16, 20, 24)]
    assert np.all(np.diff(periods) > 0)  # slender walls rock more slowly
    # the supports do not enter, only the masses on the wall
    assert F.rocking_period(wall(16)) == F.rocking_period(wall(16, top_stiffness=RIGID))


def test_intensity_measures_of_a_record():
    rng = np.random.default_rng(3)
    acc = rng.normal(0.0, 1.0, 3000) * np.hanning(3000)
    dt = 0.01
    w = wall(16)
    ms = urmx.records.measures((acc, dt))
    assert F.record_intensity((acc, dt), "pga") == pytest.approx(np.max(np.abs(acc)), rel=1e-15)
    assert F.record_intensity((acc, dt), "pgv") == float(ms.pgv)
    assert F.record_intensity((acc, dt), "scale") == 1.0
    rs = urmx.records.response_spectrum((acc, dt), periods=[F.rocking_period(w),
                                                             F.diaphragm_period(w)])
    assert F.record_intensity((acc, dt), "sa_wall", w) == pytest.approx(float(rs.psa[0]),
                                                                        rel=1e-12)
    assert F.record_intensity((acc, dt), "sa_diaphragm", w) == pytest.approx(
        float(rs.psa[1]), rel=1e-12)
    assert F.diaphragm_period(w) == pytest.approx(1 / w.diaphragm_frequency(), rel=1e-15)
    # a rigid top moves with the ground: Sa at period 0 is the PGA
    rigid = w.replace(top_stiffness=RIGID, top_damping=0.0)
    assert F.record_intensity((acc, dt), "sa_diaphragm", rigid) == pytest.approx(
        np.max(np.abs(acc)), rel=1e-15)
    # every measure is proportional to the scale factor
    for im in ("pga", "pgv", "sa_wall", "sa_diaphragm"):
        assert F.record_intensity((2.5 * acc, dt), im, w) == pytest.approx(
            2.5 * F.record_intensity((acc, dt), im, w), rel=1e-12)
    with pytest.raises(ValueError, match="needs the wall"):
        F.record_intensity((acc, dt), "sa_wall")
    # measures(periods=) adds psa(period), the same numbers as response_spectrum
    m2 = urmx.records.measures((acc, dt), periods=[0.0, 0.5])
    np.testing.assert_allclose(m2.psa, urmx.records.response_spectrum(
        (acc, dt), periods=[0.0, 0.5]).psa, rtol=0)
    assert m2.psa.attrs["units"] == "m s-2" and float(m2.psa[0]) == float(ms.pga)


def sdof_psa_fft(acc, dt, period, damping=0.05):
    """Pseudo-spectral acceleration of a linear SDOF by the frequency domain (an
    independent computation: the transfer function of the relative displacement applied to
    the record's FFT, padded with ten times its length of zeros for the free vibration)."""
    n = acc.size * 11
    w = 2 * np.pi * np.fft.rfftfreq(n, dt)
    wn = 2 * np.pi / period
    u = np.fft.irfft(-np.fft.rfft(acc, n) / (wn ** 2 - w ** 2 + 2j * damping * wn * w), n)
    return wn ** 2 * np.max(np.abs(u))


def smooth_record(seed=7, n=4000, dt=0.005):
    """Band-limited noise under a bell envelope (sampled finely: the piecewise-linear
    recursion and the FFT see the same motion)."""
    rng = np.random.default_rng(seed)
    raw = rng.standard_normal(n)
    kernel = np.hanning(9) / np.hanning(9).sum()
    return np.convolve(raw, kernel, "same") * np.hanning(n) * 3.0, dt


def test_sa_avg_equals_an_independent_frequency_domain_computation():
    """sa_avg of a record is the geometric mean of the 5 %-damped Sa at its 10 periods, here
    computed again by the FFT, within 1 %, for a wall's default range and a range given."""
    acc, dt = smooth_record()
    w = wall(16)
    for rng, periods in ((None, F.sa_avg_periods(w)),
                         ((0.3, 2.0), np.geomspace(0.3, 2.0, 10))):
        expected = math.exp(np.mean([math.log(sdof_psa_fft(acc, dt, t)) for t in periods]))
        got = F.record_intensity((acc, dt), "sa_avg", w, period_range=rng)
        assert got == pytest.approx(expected, rel=0.01)
        assert len(periods) == F.SA_AVG_PERIODS == 10
    # proportional to the record, like every measure
    assert F.record_intensity((2.5 * acc, dt), "sa_avg", w) == pytest.approx(
        2.5 * F.record_intensity((acc, dt), "sa_avg", w), rel=1e-12)
    # the same number through urmx.records.measures and collapse_capacity's measure
    lo, hi = F.sa_avg_range(w)
    ms = urmx.records.measures((acc, dt), names=["pga"], sa_avg_range=(lo, hi))
    assert float(ms.sa_avg) == pytest.approx(F.record_intensity((acc, dt), "sa_avg", w),
                                             rel=1e-12)
    assert ms.sa_avg.attrs["units"] == "m s-2" and ms.sa_avg.attrs["periods"] == 10
    all_ims = F.record_measures(acc, dt, [w, wall(8)])
    for im in F.RECORD_IMS:
        assert all_ims[im][0] == pytest.approx(F.record_intensity((acc, dt), im, w),
                                               rel=1e-12)
    with pytest.raises(ValueError, match="needs the wall"):
        F.record_intensity((acc, dt), "sa_avg")
    with pytest.raises(ValueError, match="0 < low <= high"):
        F.record_intensity((acc, dt), "sa_avg", w, period_range=(2.0, 1.0))


def test_sa_avg_default_range_spans_both_periods():
    """[max(min(T_d, T_r) / sqrt 2, T_r / 2), sqrt 2 max(T_d, T_r)]: both periods inside,
    half an octave to spare; a stiff or rigid top gives the rocking period's
    neighbourhood."""
    w = wall(16)  # D1-like: T_d 1.06 s, T_r 1.04 s
    tr, td = F.rocking_period(w), F.diaphragm_period(w)
    lo, hi = F.sa_avg_range(w)
    assert lo == pytest.approx(min(tr, td) / math.sqrt(2), rel=1e-12)
    assert hi == pytest.approx(max(tr, td) * math.sqrt(2), rel=1e-12)
    rigid = w.replace(top_stiffness=RIGID, top_damping=0.0)
    assert F.sa_avg_range(rigid) == pytest.approx((tr / 2, tr * math.sqrt(2)), rel=1e-12)
    stiff = w.replace(top_stiffness=100 * w.top_stiffness)
    assert F.sa_avg_range(stiff)[0] == pytest.approx(tr / 2, rel=1e-12)
    periods = F.sa_avg_periods(w)
    assert periods[0] == pytest.approx(lo) and periods[-1] == pytest.approx(hi)
    assert np.allclose(np.diff(np.log(periods)), np.log(hi / lo) / 9)


def test_a_record_with_nan_samples_is_named_as_such():
    """Today's code called such a record "all zeros" (NaN compares false) or returned NaN."""
    acc = np.r_[np.zeros(5), 1.0, np.nan, np.sin(np.arange(100.0))]
    with pytest.raises(urmx.records.RecordError, match="1 NaN or infinite samples.*index 6"):
        F.collapse_capacity(wall(16), (acc, 0.01))
    with pytest.raises(urmx.records.RecordError, match="NaN"):
        F.record_intensity((acc, 0.01), "pga")
    with pytest.raises(ValueError, match="all zeros"):
        F.collapse_capacity(wall(16), (np.zeros(100), 0.01))


# ---- lognormal fits -----------------------------------------------------------------------------

THETA, BETA = 0.6, 0.4


def synthetic(n=400, seed=1, censor_at=None):
    x = THETA * np.exp(BETA * np.random.default_rng(seed).standard_normal(n))
    if censor_at is None:
        return x, np.zeros(n, bool)
    c = x > censor_at
    return np.where(c, censor_at, x), c


def test_fit_without_censoring_is_the_moments_of_ln_x():
    x, _ = synthetic(50)
    fit = F.fit_lognormal(x)
    assert fit.median == pytest.approx(math.exp(np.mean(np.log(x))), rel=1e-6)
    assert fit.dispersion == pytest.approx(np.std(np.log(x)), rel=1e-6)
    assert fit.n == 50 and fit.n_censored == 0
    assert fit.probability(fit.median) == pytest.approx(0.5)


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_fit_recovers_median_and_dispersion_with_censoring(seed):
    """Censoring a fifth of the records at 0.85 (above it they survive): the censored MLE
    recovers theta and beta within 3 standard errors; dropping the censored records (the
    error the censoring avoids) biases the median low by far more."""
    n = 400
    censor_at = THETA * math.exp(BETA * norm.ppf(0.8))
    x, c = synthetic(n, seed, censor_at)
    assert 0.12 < c.mean() < 0.28
    fit = F.fit_lognormal(x, c)
    se_mu, se_beta = BETA / math.sqrt(n), BETA / math.sqrt(2 * n)
    assert abs(math.log(fit.median / THETA)) < 3 * 1.2 * se_mu  # 1.2: information lost
    assert abs(fit.dispersion - BETA) < 3 * 1.3 * se_beta
    assert fit.n == n and fit.n_censored == int(c.sum())
    dropped = F.fit_lognormal(x[~c])
    assert math.log(THETA / dropped.median) > 6 * se_mu
    # NaN cells (not run) are ignored
    nan = F.fit_lognormal(np.r_[x, np.nan], np.r_[c, False])
    assert nan.median == pytest.approx(fit.median, rel=1e-9)


@pytest.mark.parametrize("seed", [4, 5])
def test_multiple_stripe_fit_agrees_with_capacity_fit(seed):
    """Stripes at 12 intensity levels counted from the same capacities (censored records
    are counted only up to their censoring intensity): both MLEs agree within the
    sampling error of either."""
    n = 400
    censor_at = THETA * math.exp(BETA * norm.ppf(0.9))
    x, c = synthetic(n, seed, censor_at)
    levels = np.geomspace(0.3, 1.3, 12)
    analyses, collapses = F.stripe_counts(x, c, levels)
    assert analyses[0] == n and analyses[-1] == n - c.sum()
    cap = F.fit_lognormal(x, c)
    msa = F.fit_multiple_stripe(levels, analyses, collapses)
    assert msa.method == "multiple-stripe" and msa.n == analyses.sum()
    se_mu, se_beta = BETA / math.sqrt(n), BETA / math.sqrt(2 * n)
    assert abs(math.log(msa.median / cap.median)) < 2 * se_mu
    assert abs(msa.dispersion - cap.dispersion) < 3 * se_beta
    assert abs(math.log(msa.median / THETA)) < 3 * 1.3 * se_mu


def test_multiple_stripe_fit_of_exact_fractions():
    """Counts that are exactly a lognormal's probabilities at each stripe (many records)
    give its parameters back."""
    levels = np.array([0.2, 0.35, 0.5, 0.7, 1.0, 1.4])
    n = 10**6
    z = np.round(n * norm.cdf(np.log(levels / 0.55) / 0.35)).astype(int)
    fit = F.fit_multiple_stripe(levels, n, z)
    assert fit.median == pytest.approx(0.55, rel=1e-4)
    assert fit.dispersion == pytest.approx(0.35, rel=1e-3)


@pytest.mark.parametrize("args, match", [
    (([1.0, 2.0], [True, True]), "at least two distinct uncensored"),
    (([1.0],), "at least two distinct uncensored"),
    (([1.0, -2.0],), "must be positive"),
    (([1.0, 2.0], [True]), "censored has 1 entries"),
])
def test_fit_lognormal_rejects(args, match):
    with pytest.raises(ValueError, match=match):
        F.fit_lognormal(*args)


def test_fit_multiple_stripe_rejects():
    with pytest.raises(ValueError, match="some stripes with survivors"):
        F.fit_multiple_stripe([1, 2], 10, [0, 0])
    with pytest.raises(ValueError, match="0 <= collapses <= analyses"):
        F.fit_multiple_stripe([1, 2], 10, [3, 11])


@pytest.mark.parametrize("call, match", [
    # today an infinite capacity was dropped silently
    (lambda: F.fit_lognormal([0.5, 0.7, np.inf, 0.9]), "infinite"),
    # today a NaN flag was read as censored
    (lambda: F.fit_lognormal([0.5, 0.7, 0.9], [0, np.nan, 0]), "censored is NaN at index 1"),
    # today 2.5 collapses were truncated to 2
    (lambda: F.fit_multiple_stripe([0.3, 0.6, 0.9], 10, [1, 2.5, 8]), "whole numbers; got 2.5"),
    (lambda: F.fit_multiple_stripe([0.3, 0.6], [10, 9.5], [1, 5]), "whole numbers; got 9.5"),
    # today one stripe gave an arbitrary median and a dispersion near zero
    (lambda: F.fit_multiple_stripe([0.5], 20, [7]), "at least two intensity levels"),
    (lambda: F.fit_multiple_stripe([0.5, 0.5], 20, [7, 9]), "at least two intensity levels"),
    # stripes perfectly separated: none collapse up to 0.4, all from 0.6
    (lambda: F.fit_multiple_stripe([0.2, 0.4, 0.6, 0.8], 10, [0, 0, 10, 10]),
     r"perfectly separated \(all survive up to 0.4, all collapse from 0.6\)"),
    (lambda: F.fit_multiple_stripe([0.2, 0.4, 0.6], 10, [0, 4, 10]), "perfectly separated"),
    # a collapse fraction that falls with intensity has no maximum with beta > 0
    (lambda: F.fit_multiple_stripe([0.2, 0.4, 0.6], 10, [6, 5, 3]), "does not rise"),
    # today a negative intensity gave NaN
    (lambda: F.LognormalFit(0.5, 0.4, 10).probability([0.1, -0.2]), "-0.2 is negative"),
])
def test_inputs_the_fits_refuse(call, match):
    with pytest.raises(urmx.errors.InputError, match=match):
        call()


def test_what_the_fits_still_accept():
    """NaN capacities (cells not run) with NaN flags are left out; whole-number floats are
    counts; zero intensity has probability 0; stripes whose collapses and survivors overlap
    over two levels fit."""
    x, _ = synthetic(30)
    fit = F.fit_lognormal(np.r_[x, np.nan], np.r_[np.zeros(30), np.nan])
    assert fit.median == pytest.approx(F.fit_lognormal(x).median, rel=1e-12)
    a = F.fit_multiple_stripe([0.3, 0.6, 0.9], 10.0, [1.0, 5.0, 8.0], resamples=0)
    b = F.fit_multiple_stripe([0.3, 0.6, 0.9], 10, [1, 5, 8], resamples=0)
    assert a.median == b.median and a.dispersion == b.dispersion
    assert F.LognormalFit(0.5, 0.4, 10).probability(0.0) == 0.0
    assert np.isnan(F.LognormalFit(0.5, 0.4, 10).probability(np.nan))
    overlap = F.fit_multiple_stripe([0.2, 0.4, 0.6], 10, [1, 3, 10], resamples=0)
    assert 0.2 < overlap.median < 0.6 and overlap.dispersion > 0


def test_fits_match_the_maximum_likelihood_of_scipy():
    """Newton's method on the concave likelihood reaches the maximum Nelder-Mead finds (the
    fit before this change), with and without censoring, to 1e-7."""
    from scipy.optimize import minimize

    censor_at = THETA * math.exp(BETA * norm.ppf(0.8))
    x, c = synthetic(60, 9, censor_at)
    lx = np.log(x)

    def nll(p):
        return -(np.sum(norm.logpdf(lx[~c], p[0], math.exp(p[1])))
                 + np.sum(norm.logsf(lx[c], p[0], math.exp(p[1]))))
    ref = minimize(nll, [lx.mean(), math.log(lx.std())], method="Nelder-Mead",
                   options={"xatol": 1e-12, "fatol": 1e-14, "maxiter": 8000}).x
    fit = F.fit_lognormal(x, c, resamples=0)
    assert fit.median == pytest.approx(math.exp(ref[0]), rel=1e-7)
    assert fit.dispersion == pytest.approx(math.exp(ref[1]), rel=1e-7)


@pytest.mark.parametrize("censor", [False, True])
def test_bootstrap_intervals_cover_the_true_median_at_their_level(censor):
    """200 seeded synthetic record sets of 40 capacities (theta 0.6, beta 0.4; with a fifth
    censored): the 90 % percentile interval of the median holds theta in 0.84-0.95 of
    them (a percentile bootstrap of 40 runs a little under its level)."""
    censor_at = THETA * math.exp(BETA * norm.ppf(0.8)) if censor else None
    hits = 0
    for trial in range(200):
        x, c = synthetic(40, 1000 + trial, censor_at)
        fit = F.fit_lognormal(x, c, resamples=400, seed=trial)
        assert fit.confidence == 0.9 and fit.resamples == 400
        hits += fit.median_ci[0] <= THETA <= fit.median_ci[1]
    assert 0.84 <= hits / 200 <= 0.95


def test_multiple_stripe_bootstrap_covers_the_true_median():
    """Stripes with their own 20 records each at 6 levels (an MSA): the 90 % interval of the
    median holds theta in 0.82-0.96 of 150 seeded trials."""
    levels = np.array([0.3, 0.4, 0.5, 0.65, 0.8, 1.0])
    p = norm.cdf(np.log(levels / THETA) / BETA)
    rng = np.random.default_rng(5)
    hits = done = 0
    for trial in range(150):
        z = rng.binomial(20, p)
        try:
            fit = F.fit_multiple_stripe(levels, 20, z, resamples=400, seed=trial)
        except urmx.errors.InputError:
            continue
        done += 1
        hits += fit.median_ci[0] <= THETA <= fit.median_ci[1]
    assert done >= 140 and 0.82 <= hits / done <= 0.96


def test_bootstrap_is_seeded():
    x, _ = synthetic(40)
    a, b = F.fit_lognormal(x, seed=3), F.fit_lognormal(x, seed=3)
    assert a.median_ci == b.median_ci and a.dispersion_ci == b.dispersion_ci
    assert F.fit_lognormal(x, seed=4).median_ci != a.median_ci
    assert a.median_ci[0] < a.median < a.median_ci[1]
    assert a.dispersion_ci[0] < a.dispersion < a.dispersion_ci[1]
    assert math.isnan(F.fit_lognormal(x, resamples=0).median_ci[0])
    assert math.isnan(F.fit_lognormal(x[:4]).median_ci[0])  # too few records
    with pytest.raises(ValueError, match="confidence=1.5"):
        F.fit_lognormal(x, confidence=1.5)
    med, disp = F.bootstrap_lognormal(x, resamples=50, seed=3)
    assert med.shape == disp.shape == (50,) and np.isfinite(med).all()


# ---- the IDA study kind on a stand-in kernel ----------------------------------------------------

def _ida(path, **kw):
    kw.setdefault("scheduler", "serial")
    return st.run_study(path, kernel=study_kernel, progress=False, batch_size=2, **kw)


@pytest.fixture
def tiny(make_study):
    return make_study(IDA_STUDY, "tiny.toml")


def test_ida_archive_schema_values_and_fits(ida_records, tiny, tmp_path):
    out = tmp_path / "tiny.nc"
    ds = _ida(tiny, out=out)
    dims = ("wall", "diaphragm", "record", "cor")
    assert ds.collapse_intensity.dims == dims and ds.censored.dims == dims
    assert ds.instability_ratio.dims == (*dims, "intensity_step")
    assert ds.intensity.dims == (*dims, "intensity_step") and "intensity" in ds.coords
    assert ds.median_collapse_intensity.dims == ds.dispersion.dims == ("wall", "diaphragm",
                                                                       "cor")
    assert list(ds.supports.values) == ["top", "both"]
    assert list(ds.diaphragm.values) == ["D1", "D2/both"]
    for name in ("collapse_intensity", "intensity", "median_collapse_intensity",
                 "record_intensity"):
        assert ds[name].attrs["units"] == "m s-2"
        assert "peak ground acceleration" in ds[name].attrs["long_name"]
    for name in ds.data_vars:
        assert ds[name].attrs["units"] and ds[name].attrs["long_name"]
    assert ds.dispersion.attrs["units"] == "1" and ds.attrs["intensity_measure"] == "pga"
    # the record as analysed: scale factor 2 on "shake" (PGA 3 -> 6 m s-2)
    np.testing.assert_allclose(ds.record_intensity.sel(record="shake"), 6.0)
    for s, wid in ((8.0, "s08"), (18.0, "s18")):
        for rec in ACC:
            for cor in (0.8, 1.0):
                cell = ds.sel(wall=wid, record=rec, cor=cor)
                thr = threshold(s, rec, cor)
                if thr > 4.5:  # s08 under quake at COR 1.0: 5.33 m s-2 > max_intensity
                    assert cell.censored.all() and (cell.collapse_intensity == 4.5).all()
                else:
                    assert not cell.censored.any()
                    assert ((cell.collapse_intensity >= thr)
                            & (cell.collapse_intensity <= thr * 1.001)).all()
                n = int(cell.analyses[0])
                x = cell.intensity[0].values
                assert np.isfinite(x[:n]).all() and np.isnan(x[n:]).all()
                np.testing.assert_allclose(cell.instability_ratio[0, :n], np.minimum(
                    1, x[:n] / thr))
    # fits over the two records: geometric mean and half the log-distance (hand MLE)
    for wid, s in (("s18", 18.0), ("s08", 8.0)):
        for cor in (0.8, 1.0):
            med = float(ds.median_collapse_intensity.sel(wall=wid, diaphragm="D1", cor=cor))
            disp = float(ds.dispersion.sel(wall=wid, diaphragm="D1", cor=cor))
            q, sh = threshold(s, "quake", cor), threshold(s, "shake", cor)
            if q > 4.5:  # one uncensored capacity: no fit
                assert math.isnan(med) and math.isnan(disp)
                continue
            assert med == pytest.approx(math.sqrt(q * sh), rel=1.5e-3)
            assert disp == pytest.approx(abs(math.log(q / sh)) / 2, abs=1.5e-3)
    stamped = urmx.variables.stamp(ds.copy())  # the registry's templates filled, not raw
    assert stamped.collapse_intensity.attrs == ds.collapse_intensity.attrs
    bare = xr.Dataset({"intensity": ("x", [1.0])})
    assert "units" not in urmx.variables.stamp(bare).intensity.attrs
    back = st.open_study(out)
    assert back.collapse_intensity.chunks is not None
    xr.testing.assert_identical(ds, back.load())
    assert not (tmp_path / "tiny.nc.parts").exists()


def test_ida_study_with_another_measure(ida_records, make_study):
    p = make_study(IDA_STUDY.replace('im = "pga"', 'im = "scale"').replace(
        "max_intensity = 4.5", "max_intensity = 20.0"), "scale.toml")
    ds = _ida(p)
    assert ds.attrs["intensity_measure"] == "scale"
    assert ds.collapse_intensity.attrs["units"] == "1"
    np.testing.assert_allclose(ds.record_intensity, 1.0)
    # the capacity as a scale factor on the record as analysed (PGA 6 m s-2 for "shake")
    c = float(ds.collapse_intensity.sel(wall="s18", diaphragm="D1", record="shake", cor=0.8))
    assert threshold(18, "shake", 0.8) / 6.0 <= c <= threshold(18, "shake", 0.8) / 6.0 * 1.001


def test_interrupted_ida_resumes_without_recomputing(ida_records, tiny, tmp_path):
    reference = _ida(tiny, out=tmp_path / "ref.nc")
    total = len(CALLS)
    CALLS.clear()
    FAIL_AT.append(total // 2)
    out = tmp_path / "run.nc"
    try:
        with pytest.raises(Interrupt):
            _ida(tiny, out=out)
    finally:
        FAIL_AT.clear()
    parts = list((tmp_path / "run.nc.parts").glob("*.npz"))
    assert 0 < len(parts) < 8 and not out.exists()
    first = list(CALLS)
    CALLS.clear()
    ds = _ida(tiny, out=out)
    # the finished batches are not run again: the second run did less than the whole
    assert len(CALLS) < total and len(first) + len(CALLS) >= total
    a, b = ds.copy(), reference.copy()
    for x in (a, b):
        x.attrs["history"] = x.attrs["history"].split(" ", 1)[1]
    xr.testing.assert_identical(a, b)


@pytest.mark.parametrize("body, needle", [
    ('[study.ida]\nim = "sa"', "study.ida.im: 'sa' is not an intensity measure"),
    ('[study.ida]\nstep = 1.0', "study.ida.step: 1.0 must be a number above 1"),
    ('[study.ida]\nrtol = 2.0', "study.ida.rtol: 2.0 must be below 1"),
    ('[study.ida]\nsteps = 2.0', "study.ida.steps: unknown key"),
])
def test_bad_ida_table_fails_with_file_line_and_key(make_study, body, needle):
    head = IDA_STUDY.split("[study.ida]")[0]
    p = make_study(head + body + "\n", "bad.toml")
    with pytest.raises(CatalogError) as err:
        load_study(p)
    assert needle in str(err.value) and f"{p}:" in str(err.value)


def test_ida_refuses_scale_dimension_and_bad_supports(make_study):
    p = make_study(IDA_STUDY.replace("cor = [0.8, 1.0]", "cor = [0.8, 1.0]\nscale = [1.0, 2.0]"),
                   "bad.toml")
    with pytest.raises(CatalogError, match="scale cannot be a dimension here"):
        load_study(p)
    p = make_study(IDA_STUDY.replace('"D2/both"', '"D2/roof"'), "bad.toml")
    with pytest.raises(CatalogError, match=r"bad\.toml:4: study\.diaphragms: 'D2/roof'"):
        load_study(p)


def test_diaphragm_with_its_own_supports():
    s = load_study("fema-p695-ida")
    assert s.kind == "ida" and s.settings.im == "pga" and s.settings.rtol == 1e-3
    assert len(s.walls) == 9 and len(s.diaphragms) == 9 and len(s.records) == 40
    d1 = s.diaphragms[0]
    d1b = s.diaphragms[5]
    assert (d1.id, d1b.id) == ("D1", "D1/both")
    top, both = s.wall(s.walls[0], d1), s.wall(s.walls[0], d1b)
    assert top.bottom_stiffness == RIGID and top.top_stiffness == 815e3
    assert both.bottom_stiffness == both.top_stiffness == 815e3
    assert both.bottom_mass == both.top_mass > 0


def test_cli_ida_needs_an_ida_table(capsys):
    from urmx.cli import main

    assert main(["ida", "paper-single-storey", "--out", "x.nc"]) == 2
    assert "has no [study.ida] table" in capsys.readouterr().err


def test_urmx_run_runs_an_ida_study_and_urmx_ida_is_its_alias(ida_records, tiny, tmp_path,
                                                              capsys):
    """`urmx run` runs a study of any kind; `urmx ida` writes the same archive (real
    kernel, on the small synthetic records)."""
    from urmx.cli import main

    archives = []
    for command in ("run", "ida"):
        out = tmp_path / f"{command}.nc"
        assert main([command, str(tiny), "--out", str(out), "--scheduler", "serial",
                     "--quiet"]) == 0
        ds = st.open_study(out).load()
        ds.attrs["history"] = ""  # the start time and the command line
        archives.append(ds)
    assert int(archives[0].analyses.sum()) > 16
    xr.testing.assert_identical(*archives)


# ---- real kernel: brute force, Ctrl-C -----------------------------------------------------------

def test_capacities_against_a_brute_force_scan(library):
    """Sampled cells of the catalog study, real kernel. Per cell, exactly: the wall
    collapses at the capacity and survives within rtol below it. Against a brute-force scan
    on a 1 % grid from half the wall's static acceleration to the capacity: rocking walls
    "resurrect", and a fifth to a third of the cells have collapse windows below their
    permanent collapse, some narrower than 1 %, that a search of ~14 analyses can step
    over; so the scan finds no collapse below the capacity in most cells (about five in
    six; `urmx bench fragility` measures it on 240 cells), and where it finds one the
    IDA curve is non-monotonic there (a survivor lies between that collapse and the
    capacity). A search that skipped the fine grid near collapse (plain steps of 1.5)
    misses one cell in four."""
    from urmx.kernel import run

    s = load_study("fema-p695-ida")
    rng = np.random.default_rng(2024)
    n, clean, analyses = 24, 0, []
    for _ in range(n):
        spec = s.walls[rng.integers(len(s.walls))]
        d = s.diaphragms[rng.integers(len(s.diaphragms))]
        rid = s.records[rng.integers(len(s.records))]
        w = s.wall(spec, d)
        rec = F.as_record(rid, library)  # unscaled, the manifest's scale factor beside
        res = F.collapse_capacity(w, rec, im="pga", rtol=1e-3)
        analyses.append(res.analyses)
        assert not res.censored
        acc = rec.scaled()  # as the search analyses it
        pga = float(np.max(np.abs(acc)))

        def collapses(x, w=w, acc=acc, dt=rec.dt, pga=pga):
            return run(w, acc, dt, scale=x / pga, cor=0.8)["status"] == "collapsed"
        assert collapses(res.capacity)
        below = res.intensity[~res.collapsed]
        assert below.max() >= res.capacity / (1 + 1e-3) and not collapses(below.max())
        lo = 0.5 * F.static_acceleration(w)
        grid = np.geomspace(lo, res.capacity / (1 + 1e-3), max(2, int(
            math.log(res.capacity / lo) / math.log(1.01))))
        hit = next((x for x in grid if collapses(x)), None)
        if hit is None:
            clean += 1
        else:  # non-monotonic: a survivor between the earlier collapse and the capacity
            assert any(not c for x, c in zip(res.intensity, res.collapsed,
                                                  strict=True) if x > hit)
    assert clean >= 0.6 * n
    assert np.mean(analyses) <= 16


def _wait_for_parts(parts: Path, proc, timeout: float = 240.0) -> int:
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        n = len(list(parts.glob("*.npz"))) if parts.is_dir() else 0
        if n >= 2 or proc.poll() is not None:
            return n
        time.sleep(0.05)
    return 0


def test_ctrl_c_then_rerun_loses_no_cell(library, make_study, tmp_path):
    """`urmx ida` interrupted by SIGINT (Ctrl-C) after some batches, then run again:
    the archive equals an uninterrupted run's (every cell present, same values)."""
    study = make_study(SMALL_IDA, "small.toml")
    env = dict(os.environ, URMX_RECORDS=str(library), MPLBACKEND="Agg")
    cmd = [sys.executable, "-m", "urmx.cli", "ida", str(study), "--scheduler", "serial",
           "--batch-size", "1", "--quiet", "--out"]
    ref = tmp_path / "ref.nc"
    st.run_study(study, out=ref, scheduler="serial", progress=False, records_dir=library)
    out = tmp_path / "run.nc"
    proc = subprocess.Popen([*cmd, str(out)], env=env, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, preexec_fn=interruptible)
    n = _wait_for_parts(tmp_path / "run.nc.parts", proc)
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=120)
    assert n >= 2, err.decode()
    assert proc.returncode == 130 and b"interrupted" in err, (proc.returncode, err.decode())
    assert not out.exists()
    kept = len(list((tmp_path / "run.nc.parts").glob("*.npz")))
    assert 2 <= kept < 60
    subprocess.run([*cmd, str(out)], env=env, check=True, capture_output=True)
    a, b = xr.load_dataset(out), xr.load_dataset(ref)
    assert a.attrs["history"].split(" ", 1)[1].startswith("urmx ") and "ida" in \
        a.attrs["history"]
    for x in (a, b):
        x.attrs["history"] = ""  # the command line differs (a shell against a call)
    xr.testing.assert_identical(a, b)
    assert int(a.analyses.min()) > 0 and a.collapse_intensity.notnull().all()


# ---- the report ---------------------------------------------------------------------------------

def test_fragility_report_numbers_and_figures(ida_records, make_study, tmp_path):
    from urmx.reports.ida import write_report

    p = make_study(REP_IDA, "rep.toml")
    ds = st.run_study(p, kernel=stiff_kernel, scheduler="serial", progress=False)
    assert np.isfinite(ds.predominant_frequency).all()
    path = write_report(ds, tmp_path / "rep")
    text = path.read_text()
    for name in ("ida_D1.png", "ida_D4-both.png", "fragility_curves.png",
                 "median_vs_slenderness.png", "median_vs_frequency.png", "resonance.png",
                 "stiffening.png", "efficiency.png", "collapse_risk.png"):
        assert (tmp_path / "rep" / name).read_bytes()[:4] == b"\x89PNG"
        assert f"]({name})" in text
    assert "falls with h/t on 4 of 4 diaphragms (Spearman rho -1 to -1)" in text
    # s08 / s24: thresholds 40/8 and 40/24 -> 3x, whatever the record
    assert "the stockiest wall's median is 3 to 3 times the most slender's" in text
    k = (40360e3 / 815e3) ** 0.1
    assert f"The median changes by a factor {k:.3g} to {k:.3g}; it rises for 3 of 3 walls" \
        in text
    # the s16/D1 median in g: geometric mean of the two records' thresholds at COR 0.8
    med = math.sqrt(threshold(16, "quake", 0.8) * threshold(16, "shake", 0.8)) / 9.81
    row = re.search(r"\| s16 \| 16 \| ([0-9.]+) \(([0-9.]+)\)", text)
    assert float(row.group(1)) == pytest.approx(med, abs=1.5e-3)
    assert float(row.group(2)) == pytest.approx(math.log(200 / 150) / 2, abs=0.01)
    # issue 26: the measures and the risk, from the same run (the stand-in kernel collapses
    # at a PGA threshold: pga is the efficient measure here)
    assert "## Which intensity measure predicts collapse best?" in text
    # two records: below urmx.reporting.MIN_RECORDS, so no measure is recommended (issue 39)
    assert "urmx recommends" not in text and "## Collapse risk" in text
    assert "**Recommendation.** None: a recommendation needs at least 10 records" in text
    assert "### Stiffening the diaphragm: D1 -> D4" in text
    with pytest.raises(ValueError, match="not an IDA archive"):
        write_report(xr.Dataset({"x": ("a", [1.0])}), tmp_path / "bad")


# ---- warm starts (issue 41): a hint from a neighbouring cell ----------------------------------

WARM = 1.001 ** 32  # the warm grid's ratio for step 1.05, rtol 1e-3 (5 bisections a step)


def test_a_hint_at_the_capacity_repeats_it_in_five_analyses():
    """Hinted with the capacity a cold search found, the warm search walks up its grid of
    ratio 1.001**32 from three steps below (the margin, 10 %: survivals), analyses the
    hint (collapses) and rtol below it (survives): the same capacity, bit for bit, in 5
    analyses instead of the cold search's 23."""
    thr = 1.2345
    analyse, cold = predicate(lambda s: s >= thr, lambda s: s / thr)
    cap, _ = F.search(analyse, 0.5, 100.0, 1.05, 1e-3)
    analyse, warm = predicate(lambda s: s >= thr, lambda s: s / thr)
    again, censored = F.search(analyse, 0.5, 100.0, 1.05, 1e-3, hint=cap)
    assert again == cap and not censored
    assert len(cold) == 23 and len(warm) == 5
    assert warm == pytest.approx([cap / WARM ** 3, cap / WARM ** 2, cap / WARM, cap,
                                  cap / 1.001], rel=1e-13)


@pytest.mark.parametrize("factor", [1.02, 1.5, 4.0, 0.3, 0.97])
def test_a_wrong_hint_still_finds_the_capacity(factor):
    """A hint above the capacity (the start collapses: down the grid in strides that
    double, then up) or below it: the capacity lies within rtol above the threshold, with a
    survivor within rtol below it; the search never strides over the hint."""
    thr = 2.0
    analyse, calls = predicate(lambda s: s >= thr, lambda s: s / thr)
    cap, censored = F.search(analyse, 0.5, 100.0, 1.05, 1e-3, hint=factor * thr)
    assert not censored and thr <= cap <= thr * 1.001
    assert max(s for s in calls if s < thr) >= cap / 1.001
    assert calls[0] == pytest.approx(factor * thr / WARM ** 3, rel=1e-13)  # the margin
    if calls[0] < thr:  # the start survives: the walk up never strides over the hint
        assert any(s == pytest.approx(factor * thr, rel=1e-13) for s in calls)
    else:  # the start collapses: then 3, 6, 12 ... grid steps down to a survivor
        down = [s for s in calls[:calls.index(min(calls)) + 1]]
        steps = [round(math.log(a / b) / math.log(WARM)) for a, b in zip(down, down[1:],
                                                                             strict=False)]
        assert steps == [3 * 2 ** i for i in range(len(steps))] and steps


def test_no_hint_nan_hint_and_cold_search_are_the_same():
    for hint in (None, float("nan"), 0.0, -1.0):
        analyse, calls = predicate(lambda s: s >= 1.7, lambda s: s / 1.7)
        cap, _ = F.search(analyse, 1.0, 100.0, 1.05, 1e-3, hint=hint)
        analyse, cold = predicate(lambda s: s >= 1.7, lambda s: s / 1.7)
        assert (cap, calls) == (F.search(analyse, 1.0, 100.0, 1.05, 1e-3)[0], cold)


def test_collapse_capacity_takes_a_neighbours_capacity_as_hint():
    acc = np.sin(np.linspace(0, 20, 1001)) * 1.7
    w = wall(16.0)
    first = F.collapse_capacity(w, (acc, 0.01), kernel=threshold_kernel(3.0))
    k = threshold_kernel(3.0)
    warm = F.collapse_capacity(w, (acc, 0.01), kernel=k, hint=first)
    assert warm.capacity == first.capacity and warm.analyses == 5 < first.analyses
    k = threshold_kernel(3.0)
    by_value = F.collapse_capacity(w, (acc, 0.01), kernel=k, hint=first.capacity)
    assert 3.0 <= by_value.capacity <= 3.003 and by_value.analyses <= 6
    with pytest.raises(urmx.errors.InputError, match="hint=-1"):
        F.collapse_capacity(w, (acc, 0.01), kernel=threshold_kernel(3.0), hint=-1.0)


CHAIN_IDA = IDA_STUDY.replace('walls = ["s08", "s18"]', 'walls = ["s08", "s12", "s18"]')


def _capacities(ds):
    return {k: np.asarray(ds[k].values).tobytes() for k in (
        "collapse_intensity", "analyses", "intensity", "instability_ratio")}


def test_chained_capacities_by_hand_and_whatever_the_batches(ida_records, make_study,
                                                             tmp_path):
    """Each wall starts from the wall before it on the same diaphragm, record and cor:
    its capacity equals `cell_capacity` hinted with the previous wall's capacity (over its
    record intensity, times the ratio of the walls' static accelerations to the power
    `HINT_EXPONENT`); the numbers are the same, bit for bit, for batches of 1, 3 and 100
    cells."""
    from urmx.study.kinds import ida

    path = make_study(CHAIN_IDA, "chain.toml")
    runs = [_capacities(st.run_study(path, kernel=study_kernel, progress=False,
                                     scheduler="serial", batch_size=n)) for n in (1, 3, 100)]
    assert runs[0] == runs[1] == runs[2]
    ds = st.run_study(path, kernel=study_kernel, progress=False, scheduler="serial")
    study = load_study(path)
    d = study.diaphragms[0]
    walls = [study.wall(spec, d) for spec in study.walls]
    rec = ACC["shake"] * 2.0
    prev = None
    for iw, w in enumerate(walls):
        hint = math.nan if prev is None else ida.warm_hint(
            prev.capacity / prev.record_intensity, F.static_acceleration(walls[iw - 1]),
            F.static_acceleration(w))
        prev = F.cell_capacity(study_kernel, w, rec, 0.01, 6.0, "pga", 0.8, "scale", 1e-3,
                               1.5, 4.5, hint_scale=hint)
        cell = ds.sel(wall=study.walls[iw].id, diaphragm=d.id, record="shake", cor=0.8)
        assert float(cell.collapse_intensity) == prev.capacity
        assert int(cell.analyses) == prev.analyses
        cold = F.cell_capacity(study_kernel, w, rec, 0.01, 6.0, "pga", 0.8, "scale", 1e-3,
                               1.5, 4.5)
        # the hint decides which intensities are analysed (the first wall starts cold)
        assert (prev.intensity.tobytes() == cold.intensity.tobytes()) == (iw == 0)


def test_a_study_extended_by_a_wall_reuses_the_chain_before_it(ida_records, make_study,
                                                               tmp_path):
    """The same study with a wall added at the end of its list takes the first walls'
    cells from the earlier archive and starts the new wall from them (their results
    travel with its batch): the archive equals a fresh run's, bit for bit. A wall inserted
    in the middle changes the hints of the walls after it: their keys differ, so they are
    computed again (only the first wall is taken over)."""
    from urmx.study import engine

    fresh = _capacities(st.run_study(make_study(CHAIN_IDA, "fresh.toml"),
                                     kernel=study_kernel, progress=False, scheduler="serial"))
    def rerun(walls: str, name: str):
        """The study with only `walls` into an archive, then the whole study into it: the
        archive and the cells of the second run (taken over, computed)."""
        out = tmp_path / f"{name}.nc"
        first = CHAIN_IDA.replace('walls = ["s08", "s12", "s18"]', f"walls = {walls}")
        st.run_study(make_study(first, f"{name}.toml"), out=out, kernel=study_kernel,
                     progress=False, scheduler="serial")
        ds = st.run_study(make_study(CHAIN_IDA, f"{name}.toml"), out=out,
                          kernel=study_kernel, progress=False, scheduler="serial")
        run = engine.last_run()
        return _capacities(ds), (run.from_archive, run.computed)

    assert rerun('["s08", "s12"]', "grow") == (fresh, (16, 8))
    assert rerun('["s08", "s18"]', "insert") == (fresh, (8, 16))

def test_capacities_are_the_same_bit_for_bit_with_the_capacity_tracking(library):
    """`collapse_capacity` and the IDA kind run the kernel with ``track="capacity"`` (only
    the drift trackers): on real cells of the FEMA P695 study, cold and warm-started, the
    capacities, IDA points and ratios equal those of full runs (``track="all"``) bit for
    bit."""
    import functools

    from urmx.kernel import run

    s = load_study("fema-p695-ida")
    full = functools.partial(run, track="all")
    for rid, (wid, did) in (("p695-12-clwln", ("s20", "D1")), ("p695-01-mul009", ("s08", "D3")),
                            ("p695-18-rio270", ("s16", "D2/both"))):
        spec = next(w for w in s.walls if w.id == wid)
        w = s.wall(spec, next(d for d in s.diaphragms if d.id == did))
        rec = F.as_record(rid, library)
        fast = F.collapse_capacity(w, rec)
        slow = F.collapse_capacity(w, rec, kernel=full)
        warm = F.collapse_capacity(w, rec, hint=fast.capacity * 1.03)
        warm_slow = F.collapse_capacity(w, rec, kernel=full, hint=fast.capacity * 1.03)
        for a, b in ((fast, slow), (warm, warm_slow)):
            assert a.capacity == b.capacity and a.analyses == b.analyses
            assert a.intensity.tobytes() == b.intensity.tobytes()
            assert a.instability_ratio.tobytes() == b.instability_ratio.tobytes()
        assert warm.analyses < fast.analyses
        assert fast.capacity / 1.001 <= warm.capacity <= fast.capacity * 1.001 or \
            warm.capacity < fast.capacity  # the same transition, or an earlier collapse
