"""Physics tests of the exact event-driven kernel (MODEL.md sections 4-11).

Every hard case of MODEL.md section 10 asserts numbers: rest, mirror symmetry, energy,
simultaneous contacts, a 1e9 N/m spring, a collapse bracket, a long fine record, the
closed-form linear oscillator, agreement with the scipy reference on the Table II walls,
continuous-time peaks, the impact window and the two impact laws.

The sections after the section 10 cases: held joints and contact functions that start at
zero (MODEL.md section 4, "Details of holding", and section 11), the start rule, the rest
time t_rest of held joints and records sampled more finely (issue 32); each opens with what
it shows.
"""

from __future__ import annotations

import math
import re
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from multiprocessing import get_context

import numpy as np
import pytest

import urmx
from urmx import kernel, model, reference
from urmx.catalog import load_catalog
from urmx.errors import InputError

from .fixtures import held_cases
from .fixtures.random_cases import SUPPORTS as RANDOM_SUPPORTS
from .fixtures.random_cases import held_case, random_wall, reversing_record
from .helpers.kernel import (
    C9,
    SCALAR_PEAKS,
    SUPPORTS,
    WALL12_RIGID,
    WALL12_SPRING,
    WEST,
    bigbear,
    c9_chatter,
    differences,
    elcentro,
    nahanni,
    worst_peak_difference,
)

EV_BASE_IMPACT, EV_CRACK_IMPACT = 0, 1
MIRROR_PATTERN = {11: 12, 12: 11, 21: 22, 22: 21, 0: 0}  # 0: after a stop


def half_sine_pulse(amplitude: float, duration: float, dt: float, length: float) -> np.ndarray:
    """A half-sine acceleration pulse [m s-2] followed by zeros up to ``length`` [s]."""
    t = np.arange(int(round(length / dt)) + 1) * dt
    return np.where(t < duration, amplitude * np.sin(np.pi * t / duration), 0.0)


def rigid_energy(wall, hist) -> np.ndarray:
    """Kinetic + strain energy of a wall with both supports rigid, on the history grid [J].

    r = [theta1]; the family stays 2, so the lower segment is Case 2 and the reduced
    mass matrix is the family-2 one."""
    P = wall.params
    M = model.system(P, 2, 0, 0)[0]
    r, v = hist["r"], hist["r_dot"]
    kinetic = 0.5 * np.einsum("ti,ij,tj->t", v, M, v)
    strain = np.array([model.potential(P, 2, a) + model.potential(P, 1, b)
                       for a, b in zip(hist["theta_lower"], hist["theta_upper"], strict=True)])
    np.testing.assert_allclose(hist["theta_lower"], r[:, 0], rtol=0, atol=0)
    return kinetic + strain


# ---- 1. zero input ---------------------------------------------------------------------

@pytest.mark.parametrize("support", list(SUPPORTS))
def test_zero_input_stays_exactly_at_rest(support):
    wall = SUPPORTS[support]
    res = kernel.run(wall, np.zeros(501), 0.02, history=True, max_log=10)
    assert res["status"] == "ok"
    assert res["events"] == 0 and res["event_log"].shape == (0, 4)
    assert res["base_impacts"] == 0 and res["crack_impacts"] == 0
    assert res["collapsed"] == 0 and math.isnan(res["collapse_time"])
    for name in SCALAR_PEAKS:
        assert res[name] == 0.0, name
    assert res["unfavourable_fraction"] == 0.0
    assert res["duration"] == pytest.approx(10.0, rel=1e-12)
    h = res["history"]
    for name in ("theta_lower", "theta_upper", "base_displacement", "crack_displacement",
                 "top_displacement", "base_acceleration", "crack_acceleration",
                 "top_acceleration", "r", "r_dot"):
        assert np.all(h[name] == 0.0), name
    assert set(np.unique(h["pattern"])) <= {21, 22}


# ---- 2. mirrored input -----------------------------------------------------------------

@pytest.mark.parametrize("support", list(SUPPORTS))
def test_mirrored_input_gives_mirrored_output(support):
    wall = SUPPORTS[support]
    ag, dt = elcentro()
    ag = ag[:1501]  # 30 s
    a = kernel.run(wall, ag, dt, scale=1.0, history=True)
    b = kernel.run(wall, -ag, dt, scale=1.0, history=True)
    # rigid/flex holds its crack joint near 5.45 s (see test_sliding_crack_chatter_is_held)
    assert a["status"] == b["status"] == "ok"
    assert a["base_impacts"] > 10 and a["instability_ratio"] > 0.05  # it really rocks
    for name in SCALAR_PEAKS + ("unfavourable_fraction", "duration"):
        assert b[name] == pytest.approx(a[name], rel=1e-12, abs=1e-300), name
    assert (a["base_impacts"], a["crack_impacts"], a["events"]) == \
        (b["base_impacts"], b["crack_impacts"], b["events"])
    ha, hb = a["history"], b["history"]
    for name in ("theta_lower", "theta_upper", "base_displacement", "crack_displacement",
                 "top_displacement", "base_acceleration", "crack_acceleration",
                 "top_acceleration", "r", "r_dot"):
        scale = np.nanmax(np.abs(ha[name])) or 1.0
        np.testing.assert_allclose(hb[name], -ha[name], rtol=1e-12, atol=1e-12 * scale,
                                   err_msg=name)
    mirrored = np.vectorize(MIRROR_PATTERN.get)(ha["pattern"])
    np.testing.assert_array_equal(hb["pattern"], mirrored)


def test_sliding_crack_chatter_ends_in_a_held_joint():
    """C9 with a rigid base under El Centro x 0.6: near 5.44 s both pattern families pull
    the crack gap back to zero (a sticking joint, which is not one of the model's four
    patterns). Crack impacts accumulate geometrically until one leaves the joint slower
    than v_rest; the joint is then held closed (theta2 = theta1 exactly) until a family
    would accelerate it open on its own side (MODEL.md section 4), and the run ends
    normally instead of on the event bound."""
    wall = SUPPORTS["rigid/flex"]
    ag, dt = elcentro()
    res = kernel.run(wall, ag[:301], dt, scale=0.6, max_log=2000, history=True)
    assert res["status"] == "ok" and res["duration"] == pytest.approx(6.0, rel=1e-12)
    assert res["holds"] == 1
    log = res["event_log"]
    kinds = log[:, 1].astype(int)
    released = np.flatnonzero(kinds == kernel.EV_CRACK_RELEASE)
    assert released.size == 1
    release_t = log[released[0], 0]
    # the accumulating impacts: intervals shrink geometrically before the hold
    burst = log[(kinds == EV_CRACK_IMPACT) & (log[:, 0] > 5.40) & (log[:, 0] < release_t)]
    gaps = np.diff(burst[:, 0])
    assert len(burst) > 30 and gaps[-1] < 1e-3 * gaps[0]
    held_from = burst[-1, 0]
    assert held_from == pytest.approx(5.4377, abs=1e-3)
    assert 5.5 < release_t < 5.6
    # while held, the crack gap is exactly zero on the grid; afterwards it opens
    h = res["history"]
    t = h["time"]
    gap = h["theta_upper"] - h["theta_lower"]
    inside = (t > held_from + 1e-9) & (t < release_t)
    assert inside.sum() >= 5 and np.all(gap[inside] == 0.0)
    assert np.abs(gap[t > release_t + 0.03]).max() > 1e-4
    # the reference solver, sharing the event logic, agrees on every peak
    ref = reference.run(wall, ag[:301], dt, scale=0.6, rtol=1e-11)
    assert ref["status"] == "ok" and ref["holds"] == 1
    worst, name = worst_peak_difference(res, ref)
    assert worst < 1e-8, name


# ---- 3. energy -------------------------------------------------------------------------

def test_energy_conserved_in_free_vibration_with_cor_1():
    """Both supports rigid, cor = 1, no damping: after a 0.3 s pulse the kinetic plus
    trilinear strain energy stays constant to 1e-9 over 6 s of free rocking."""
    wall = WALL12_RIGID
    dt = 0.005
    ag = half_sine_pulse(3.0, 0.3, dt, 0.5)
    res = kernel.run(wall, ag, dt, cor=1.0, tail=6.0, history=True)
    assert res["status"] == "ok"
    assert res["base_impacts"] >= 10  # many impacts in free rocking
    assert 0.3 < res["instability_ratio"] < 1.0  # well into the softening branch
    h = res["history"]
    assert set(np.unique(h["pattern"])) <= {21, 22}  # family 2 throughout
    energy = rigid_energy(wall, h)[h["time"] >= 0.3]
    drift = np.max(np.abs(energy - energy[0])) / energy[0]
    assert energy[0] > 0.0
    assert drift < 1e-9, drift


# ---- 4. both supports rigid: one impact per crossing, rate ratio cor ------------------

def test_rigid_supports_one_impact_per_crossing_and_rate_ratio_cor():
    wall = WALL12_RIGID
    dt = 0.001
    cor = 0.8
    ag = half_sine_pulse(3.0, 0.3, dt, 0.5)
    res = kernel.run(wall, ag, dt, cor=cor, tail=2.0, history=True, max_log=1000)
    assert res["status"] == "ok"
    log = res["event_log"]
    h = res["history"]
    impacts = log[log[:, 1] == EV_BASE_IMPACT, 0]
    assert not np.any(log[:, 1] == EV_CRACK_IMPACT)  # never a second impact
    th1 = h["theta_lower"]
    crossings = int(np.count_nonzero(np.sign(th1[1:]) * np.sign(th1[:-1]) < 0))
    assert res["base_impacts"] == res["crack_impacts"] == impacts.size == crossings
    assert impacts.size >= 8
    # between impacts the energy is constant; across one it drops by cor**2 exactly
    # (rate ratio cor; cor**2 would give cor**4), the strain energy being 0 at theta1 = 0
    energy = rigid_energy(wall, h)
    t = h["time"]
    plateaus = []
    for t0, t1 in zip(impacts[:-1], impacts[1:], strict=True):
        inside = (t > t0) & (t < t1) & (t >= 0.3)
        if inside.sum() >= 3:
            e = energy[inside]
            assert np.ptp(e) / e[0] < 1e-9
            plateaus.append(e.mean())
    ratios = np.array(plateaus[1:]) / np.array(plateaus[:-1])
    assert ratios.size >= 5
    np.testing.assert_allclose(ratios, cor**2, rtol=1e-9)


# ---- 5. a 1e9 N/m spring with no diaphragm mass ----------------------------------------

@pytest.mark.parametrize("damping", [0.0, 0.12])
def test_stiff_spring_without_diaphragm_mass_runs_stably(damping):
    """Table II Wall 12 with its supports literally 1e9 N/m springs and m_db = m_dt = 0."""
    wall = WALL12_SPRING.replace(bottom_damping=damping, top_damping=damping)
    ag, dt = nahanni()
    kernel.run(wall, ag[:11], dt)  # compile and fill the mode tables
    t0 = time.perf_counter()
    res = kernel.run(wall, ag, dt, scale=0.5)
    t_spring = time.perf_counter() - t0
    t0 = time.perf_counter()
    rig = kernel.run(WALL12_RIGID, ag, dt, scale=0.5)
    t_rigid = time.perf_counter() - t0
    soft = wall.replace(bottom_stiffness=1e6, top_stiffness=1e6)
    kernel.run(soft, ag[:11], dt)
    t0 = time.perf_counter()
    kernel.run(soft, ag, dt, scale=0.5)
    t_soft = time.perf_counter() - t0
    print(f"\n1e9 N/m spring, damping {damping}: {t_spring:.4f} s; rigid supports "
          f"{t_rigid:.4f} s (ratio {t_spring / t_rigid:.0f}); 1e6 N/m springs {t_soft:.4f} s "
          f"(ratio {t_spring / t_soft:.0f})")
    assert res["status"] == "ok"
    for name in SCALAR_PEAKS:
        assert math.isfinite(res[name]), name
    # the springs barely move: the wall rocks as if its supports were rigid
    assert res["peak_base_displacement"] < 1e-6 and res["peak_top_displacement"] < 1e-6
    assert res["peak_crack_displacement"] == pytest.approx(rig["peak_crack_displacement"],
                                                           rel=1e-3)
    assert res["instability_ratio"] == pytest.approx(rig["instability_ratio"], rel=1e-3)


@pytest.mark.slow
def test_stiff_spring_agrees_with_reference():
    """First 3 s of Nahanni x 0.5 (the reference needs ~20 s for them at rtol 1e-10)."""
    ag, dt = nahanni()
    ag = ag[:601]
    a = kernel.run(WALL12_SPRING, ag, dt, scale=0.5)
    b = reference.run(WALL12_SPRING, ag, dt, scale=0.5)
    assert a["status"] == b["status"] == "ok"
    assert a["base_impacts"] >= 20
    worst, name = worst_peak_difference(a, b)
    assert worst < 1e-6, (name, worst)
    assert (a["base_impacts"], a["crack_impacts"]) == (b["base_impacts"], b["crack_impacts"])


# ---- 6. a scale factor bracketing collapse ---------------------------------------------

@pytest.fixture(scope="module")
def collapse_bracket():
    """Bisect the Nahanni scale that collapses Wall 12 (rigid supports) to 1e-4."""
    ag, dt = nahanni()
    lo, hi = 0.5, 1.0
    assert not kernel.run(WALL12_RIGID, ag, dt, scale=lo)["collapsed"]
    assert kernel.run(WALL12_RIGID, ag, dt, scale=hi)["collapsed"]
    while hi - lo > 1e-4 * hi:
        mid = 0.5 * (lo + hi)
        if kernel.run(WALL12_RIGID, ag, dt, scale=mid)["collapsed"]:
            hi = mid
        else:
            lo = mid
    return lo, hi


def test_scale_bracketing_collapse_flips_collapsed(collapse_bracket):
    lo, hi = collapse_bracket
    ag, dt = nahanni()
    below = kernel.run(WALL12_RIGID, ag, dt, scale=lo)
    above = kernel.run(WALL12_RIGID, ag, dt, scale=hi)
    end = (ag.size - 1) * dt
    assert below["status"] == "ok" and below["collapsed"] == 0
    assert math.isnan(below["collapse_time"])
    assert 0.5 < below["instability_ratio"] < 1.0
    assert below["duration"] == pytest.approx(end, rel=1e-12)
    assert above["status"] == "collapsed" and above["collapsed"] == 1
    assert 0.0 < above["collapse_time"] <= end
    assert above["duration"] == above["collapse_time"]
    assert above["instability_ratio"] == 1.0
    assert max(above["instability_ratio_lower"], above["instability_ratio_upper"]) == 1.0


# ---- 7. a long fine record -------------------------------------------------------------

def test_sixty_second_record_at_one_millisecond_finishes():
    rng = np.random.default_rng(20260101)
    dt = 0.001
    n = 60001
    from scipy.signal import butter, sosfiltfilt

    noise = sosfiltfilt(butter(4, [0.5, 8.0], btype="band", fs=1 / dt, output="sos"),
                        rng.standard_normal(n))
    t = np.arange(n) * dt
    envelope = np.minimum(1.0, t / 5.0) * np.exp(-np.maximum(0.0, t - 20.0) / 15.0)
    ag = noise * envelope
    ag *= 0.25 * 9.81 / np.max(np.abs(ag))
    t0 = time.perf_counter()
    res = kernel.run(WEST, ag, dt)
    elapsed = time.perf_counter() - t0
    print(f"\n60 s at 0.001 s, West wall: {elapsed:.2f} s, {res['events']} events")
    assert res["status"] == "ok"
    assert res["duration"] == pytest.approx(60.0, rel=1e-12)
    assert res["base_impacts"] > 50
    for name in SCALAR_PEAKS:
        assert math.isfinite(res[name]), name
        if name != "peak_base_displacement":
            assert res[name] > 0.0, name
    # a rigid base is exact: no base displacement, base acceleration = the ground's
    assert res["peak_base_displacement"] == 0.0
    assert res["peak_base_acceleration"] == np.max(np.abs(ag))


# ---- 8. closed-form linear oscillator --------------------------------------------------

def test_linear_branch_matches_closed_form_oscillator():
    """Both supports rigid, cor = 1, |theta| inside theta_a: M th'' + K th = -G A sin(w t).

    From rest th(t) = B (sin w t - (w/wn) sin wn t), B = -(G/M) A / (wn^2 - w^2). Impacts
    at cor = 1 leave the rate unchanged and the family stays 2, so the motion is linear."""
    wall = WALL12_RIGID
    P = wall.params
    M, C, K, R0, MinvG, Minv = model.system(P, 2, 0, 0)
    assert np.all(R0 == 0.0) and np.all(C == 0.0)
    wn = math.sqrt(K[0, 0] / M[0, 0])
    w = 0.6 * wn
    a1, a2 = wall.a1, wall.a2
    limit = min(wall.segment(2).theta_a, wall.segment(1).theta_a * a2 / a1)
    B_unit = -MinvG[0] / (wn**2 - w**2)
    amplitude = 0.5 * limit / (abs(B_unit) * (1 + w / wn))  # |theta1| <= half the limit
    dt = 1e-4
    t = np.arange(int(round(2.0 / dt)) + 1) * dt
    ag = amplitude * np.sin(w * t)
    res = kernel.run(wall, ag, dt, cor=1.0, history=True)
    h = res["history"]
    exact = amplitude * B_unit * (np.sin(w * t) - (w / wn) * np.sin(wn * t))
    assert np.max(np.abs(h["theta_lower"])) < limit
    assert res["base_impacts"] >= 4  # it crosses zero, impacts change nothing at cor = 1
    err = np.max(np.abs(h["theta_lower"] - exact)) / np.max(np.abs(exact))
    assert err < 1e-6, err
    rate = amplitude * B_unit * w * (np.cos(w * t) - np.cos(wn * t))
    err_v = np.max(np.abs(h["r_dot"][:, 0] - rate)) / np.max(np.abs(rate))
    assert err_v < 1e-6, err_v
    assert res["peak_lower_drift"] == pytest.approx(a1 * np.max(np.abs(exact)), rel=1e-6)


# ---- 9. exact vs reference on the Table II walls ---------------------------------------

AGREEMENT = {
    # wall, record, scale, seconds (None: the full record)
    "wall12-nahanni": (WALL12_RIGID, nahanni, 0.5, None),
    "west-bigbear": (WEST, bigbear, 5.0, None),
    # C9 x 1.5 meets a knife-edge at 51.64 s (a crack re-closure decided by the v_rest
    # rule at 1e-6 rad: the reference itself flips with rtol), so its first 40 s
    "c9-elcentro": (C9, elcentro, 1.5, 40.0),
}


def _agreement_case(case: str) -> tuple:
    wall, record, scale, seconds = AGREEMENT[case]
    ag, dt = record()
    if seconds is not None:
        ag = ag[:int(round(seconds / dt)) + 1]
    return wall, ag, dt, scale


def _reference_of(args: tuple) -> dict:
    wall, ag, dt, scale = args
    return reference.run(wall, ag, dt, scale=scale)


@pytest.fixture(scope="module")
def table2_references() -> dict:
    """The reference's runs of the AGREEMENT cases, in two processes (west-bigbear alone
    takes about 20 s)."""
    cases = {case: _agreement_case(case) for case in AGREEMENT}
    with ProcessPoolExecutor(2, mp_context=get_context("spawn")) as pool:
        return dict(zip(cases, pool.map(_reference_of, cases.values()), strict=True))


@pytest.mark.parametrize("case", list(AGREEMENT))
def test_exact_agrees_with_reference_on_table2_walls(case, table2_references):
    wall, ag, dt, scale = _agreement_case(case)
    a = kernel.run(wall, ag, dt, scale=scale)
    b = table2_references[case]
    assert a["status"] == b["status"] == "ok"
    assert a["base_impacts"] > 50 and a["instability_ratio"] > 0.1
    worst, name = worst_peak_difference(a, b)
    print(f"\n{case}: worst peak difference {worst:.1e} ({name})")
    assert worst < 1e-6, (name, worst)
    assert a["unfavourable_fraction"] == pytest.approx(b["unfavourable_fraction"], rel=1e-6,
                                                       abs=1e-9)
    assert (a["base_impacts"], a["crack_impacts"], a["events"]) == \
        (b["base_impacts"], b["crack_impacts"], b["events"])


def test_reference_finds_a_grazing_crack_impact():
    """C9 with a rigid base, El Centro x 0.6: the crack joint closes again 14 ms after an
    impact at 1.5438 s (a shallow dip of theta2 - theta1 through zero). The exact kernel
    finds it at 1.5577541691 s. solve_ivp looks for sign changes only at its step ends, so
    the reference caps its steps at dt/8 (DOP853 at rtol 1e-10 stepped over it without)."""
    wall = SUPPORTS["rigid/flex"]
    ag, dt = elcentro()
    ag = ag[:86]  # 1.7 s
    a = kernel.run(wall, ag, dt, scale=0.6, max_log=100)
    b = reference.run(wall, ag, dt, scale=0.6)
    t_a = a["event_log"][a["event_log"][:, 1] == EV_CRACK_IMPACT, 0]
    assert np.any(np.abs(t_a - 1.5577541691) < 1e-9)
    assert a["crack_impacts"] == b["crack_impacts"]
    worst, name = worst_peak_difference(a, b)
    assert worst < 1e-6, (name, worst)


def test_exact_agrees_with_reference_on_collapse_time():
    ag, dt = nahanni()
    ag = ag[:2401]  # 12 s; Wall 12 x 1.0 collapses near 9.6 s
    a = kernel.run(WALL12_RIGID, ag, dt, scale=1.0)
    b = reference.run(WALL12_RIGID, ag, dt, scale=1.0)
    assert a["status"] == b["status"] == "collapsed"
    assert abs(a["collapse_time"] - b["collapse_time"]) < dt
    assert a["collapse_time"] == pytest.approx(b["collapse_time"], abs=1e-8)
    assert a["instability_ratio"] == b["instability_ratio"] == 1.0


# ---- 10. peaks are continuous-time maxima ----------------------------------------------

def test_peaks_are_continuous_time_maxima():
    ag, dt = elcentro()
    ag = ag[:1001]  # 20 s
    a = kernel.run(C9, ag, dt, scale=1.5, history=True)
    b = reference.run(C9, ag, dt, scale=1.5)
    h = a["history"]
    grid = {
        "peak_crack_displacement": h["crack_displacement"],
        "peak_top_displacement": h["top_displacement"],
        "peak_base_displacement": h["base_displacement"],
        "peak_lower_drift": C9.a1 * h["theta_lower"],
        "peak_upper_drift": C9.a2 * h["theta_upper"],
        "peak_top_acceleration": h["top_acceleration"],
        "peak_crack_acceleration": h["crack_acceleration"],
        "peak_base_acceleration": h["base_acceleration"],
    }
    gaps = {}
    for name, series in grid.items():
        gm = np.max(np.abs(series))
        assert a[name] >= gm, name
        assert a[name] == pytest.approx(b[name], rel=1e-6), name
        gaps[name] = (a[name] - gm) / a[name]
    print("\ncontinuous over grid peaks:", {k: f"{v:.2e}" for k, v in gaps.items()})
    # the grid misses the true maxima by far more than the agreement level
    assert max(gaps.values()) > 1e-2
    assert sum(g > 1e-4 for g in gaps.values()) >= 4


# ---- 11. the impact window -------------------------------------------------------------

def _impact_entries(res):
    log = res["event_log"]
    return int(np.count_nonzero(log[:, 1] <= EV_CRACK_IMPACT))


def test_impact_window_merges_close_impacts():
    ag, dt = elcentro()
    ag = ag[:1501]
    d = kernel.run(C9, ag, dt, scale=1.5, max_log=5000)
    finer = kernel.run(C9, ag, dt, scale=1.5, window=1e-7, max_log=5000)
    wide = kernel.run(C9, ag, dt, scale=1.5, window=1e-2, max_log=5000)
    # a soft wall never closes its two joints within 1e-6 s: no merges, and the default
    # window gives the same counts as a smaller one
    assert _impact_entries(d) == d["base_impacts"] + d["crack_impacts"]
    for name in SCALAR_PEAKS + ("base_impacts", "crack_impacts", "events"):
        assert finer[name] == d[name], name
    # a 10 ms window merges: one logged impact counts on both joints
    merged = wide["base_impacts"] + wide["crack_impacts"] - _impact_entries(wide)
    assert merged > 0
    assert _impact_entries(wide) < _impact_entries(d)


def test_stiff_springs_merge_impacts_within_default_window():
    """1e9 N/m springs: the two joints close 1e-9 .. 1e-4 s apart (MODEL.md section 7)."""
    ag, dt = nahanni()
    res = kernel.run(WALL12_SPRING, ag, dt, scale=0.5, max_log=5000)
    merged = res["base_impacts"] + res["crack_impacts"] - _impact_entries(res)
    assert merged > 0


# ---- 12. contact and scale laws with both supports rigid -------------------------------

def test_contact_and_scale_laws_agree_with_both_supports_rigid():
    ag, dt = nahanni()
    a = kernel.run(WALL12_RIGID, ag, dt, scale=0.5, impact="scale", history=True)
    b = kernel.run(WALL12_RIGID, ag, dt, scale=0.5, impact="contact", history=True)
    assert a["base_impacts"] > 50
    for name in SCALAR_PEAKS + ("unfavourable_fraction",):
        assert b[name] == pytest.approx(a[name], rel=1e-12), name
    assert (a["base_impacts"], a["crack_impacts"], a["events"], a["status"]) == \
        (b["base_impacts"], b["crack_impacts"], b["events"], b["status"])
    # round-off of the contact law's impulse solve, carried through ~150 impacts
    th = a["history"]["theta_lower"]
    np.testing.assert_allclose(b["history"]["theta_lower"], th, rtol=0,
                               atol=1e-10 * np.max(np.abs(th)))


# ---- 13. bounded work ------------------------------------------------------------------

@pytest.mark.parametrize("dt", [1e300, 2.0, 1e-7])
def test_a_record_step_outside_the_accepted_range_is_refused(dt):
    """dt = 1e300 ended in an overflow in the propagator; every step outside 1e-6 .. 1 s is
    an InputError that names it and the range."""
    with pytest.raises(InputError, match=rf"^dt={re.escape(repr(dt))} s .* must lie in "
                                         r"\[1e-06, 1\] s$"):
        kernel.run(WALL12_RIGID, np.ones(5), dt)
    kernel.run(WALL12_RIGID, np.ones(5), 1.0)  # the bounds themselves run
    kernel.run(WALL12_RIGID, np.ones(5), 1e-6, window=1e-7)


def test_a_spring_needing_too_many_substeps_is_refused():
    """A spring whose sub-step count passes MAX_SUBSTEPS is refused when the tables are
    built, naming its stiffness, the count and the bound and advising `rigid`: the 1e9 N/m
    springs of Wall 12 (no diaphragm mass) need 101 sub-steps at dt = 0.02 s and 2,525 at
    0.5 s; Wall(top_stiffness=1e30) needed 2.3e12 and ran without end (a value only
    allow_unusual lets through the wall's plausibility check)."""
    assert int(kernel.tables(WALL12_SPRING, 0.02).nsub.max()) == 101
    with pytest.raises(InputError, match=r"^(bottom|top)_stiffness=1e\+09 N/m needs 2\.5\de\+03 "
                                         r"sub-steps per record step of 0\.5 s, above the bound "
                                         r"of 1000: .* declare the support rigid"):
        kernel.run(WALL12_SPRING, np.ones(5), 0.5)
    stiff = WALL12_RIGID.replace(top_stiffness=1e30, allow_unusual=True)
    with pytest.raises(InputError, match=r"^top_stiffness=1e\+30 N/m needs 2\.\d+e\+12 sub-steps"
                                         r".*top_stiffness = \"rigid\""):
        kernel.run(stiff, np.ones(5), 0.02)


def test_every_catalog_wall_stays_within_the_substep_bound():
    """Every catalog cell (the statuses benchmark's: parametric walls on every diaphragm,
    single- and higher-storey, and the Table II walls) at the paper's record steps."""
    from benchmarks.sections.statuses import cells

    worst = max(int(kernel.tables(w, dt).nsub.max()) for _, _, w in cells()
                for dt in (0.005, 0.01, 0.02))
    assert worst <= kernel.MAX_SUBSTEPS
    assert worst == 6  # D5, the 1e9 N/m spring with the building's diaphragm mass


# ---- held joints (MODEL.md section 4, "Details of holding", and section 11) ------------

# Held joints and contact functions that start at zero (MODEL.md section 4, "Details of
# holding", and section 11).
#
# After an event a contact function can sit at zero and move away (the joint that has just
# impacted, or one released from a hold, whose gap, rate and acceleration are all zero);
# it may come back and cross zero again within the same sub-step, and comparing the signs
# at the sub-step's ends misses an even number of crossings. The exact kernel searches the
# series of such a sub-step for its first fall; the reference samples its dense output
# (geometrically near the start of a piece). The constructed cases below lose crossings
# with the sign test at the ends (the kernel at 8b38483); the randomised comparison covers
# the four support cases and both impact laws with holds counted.

HELD_TOL, HELD_TOL_CHAOTIC = 1e-6, 1e-3
N_RANDOM = 200  # seeded random cases of the comparison
SEED = 20261124


def _agree(a: dict, b: dict, tol: float = HELD_TOL) -> None:
    d = differences(a, b)
    worst = max(d, key=d.get)
    assert d[worst] <= tol, (worst, a[worst] if worst != "status" else a["status"],
                             b[worst] if worst != "status" else b["status"])


def test_released_joint_that_comes_back_within_a_substep_is_found():
    """A rigid base and a flexible top, scale law: the base joint is held at an impact at
    1.04697 s and released at once; it moves off and comes back 1.45 ms later, inside the
    same 20 ms sub-step (the wall needs one sub-step a record step). The sign test at the
    sub-step's ends lost that impact and the chatter after it: 24 events and 2 holds
    instead of 33 and 6, unfavourable_fraction 0.132 instead of 0.0185."""
    w, ag, dt, cor = (held_cases.RETURN_WALL, held_cases.RETURN_RECORD, held_cases.RETURN_DT,
                      held_cases.RETURN_COR)
    res = kernel.run(w, ag, dt, cor=cor, tail=0.74, max_log=100)
    log = res["event_log"]
    i = int(np.flatnonzero(log[:, 1] == kernel.EV_BASE_RELEASE)[0])
    t_release, t_back = log[i, 0], log[i + 1, 0]
    assert t_release == pytest.approx(1.0469678607, abs=1e-9)
    assert log[i - 1, 0] == t_release and log[i - 1, 1] == kernel.EV_BASE_IMPACT  # held at once
    assert log[i + 1, 1] == kernel.EV_BASE_IMPACT
    assert t_back - t_release == pytest.approx(1.44756e-3, rel=1e-4)
    tab = kernel.tables(w, dt)
    h = dt / int(tab.nsub[tab.ready].max())
    assert math.floor(t_release / h) == math.floor(t_back / h)  # one sub-step
    assert (res["events"], res["holds"], res["base_impacts"]) == (33, 6, 12)
    assert res["unfavourable_fraction"] == pytest.approx(0.0185011, rel=1e-5)
    _agree(res, reference.run(w, ag, dt, cor=cor, tail=0.74))


def test_c9_chatter_under_the_contact_law_is_found():
    """C9 on a rigid base under El Centro x 0.6 with the contact law: after the crack joint
    is released near 5.5353 s its gap crosses zero an even number of times within one
    20 ms sub-step; the six chatter impacts between 5.5439 s and 5.5471 s were lost
    (124 crack impacts instead of 130, unfavourable_fraction 0.2708 instead of 0.2697).
    The reference (which also fired a contact function sitting exactly at zero again at
    once, 31 crack impacts at one instant near 3.7576 s, before it searched for first
    falls) agrees. (Pinned again for t_rest = 0.01 s, issue 32: with v_rest = g_open/dt,
    dt = 0.02 s, it had 130 crack impacts and unfavourable_fraction 0.2696855, which
    t_rest = 0.02 s still gives.)"""
    wall = SUPPORTS["rigid/flex"]
    ag, dt = elcentro()
    res = kernel.run(wall, ag[:301], dt, scale=0.6, impact="contact", max_log=3000)
    log = res["event_log"]
    crack = log[log[:, 1] == kernel.EV_CRACK_IMPACT, 0]
    assert np.count_nonzero((crack > 5.5438) & (crack < 5.5472)) == 6
    assert (res["crack_impacts"], res["base_impacts"], res["holds"]) == (132, 15, 1)
    assert res["unfavourable_fraction"] == pytest.approx(0.2696874, rel=1e-6)
    old = kernel.run(wall, ag[:301], dt, scale=0.6, impact="contact", t_rest=dt)
    assert (old["crack_impacts"], old["holds"]) == (130, 1)
    assert old["unfavourable_fraction"] == pytest.approx(0.2696855, rel=1e-6)
    ref = reference.run(wall, ag[:301], dt, scale=0.6, impact="contact", rtol=1e-11)
    _agree(res, ref)


def test_both_sides_qualifying_release_the_current_familys_side():
    """A rigid base and a flexible top: the crack joint is held at an impact at 2.0296 s
    (pattern 12, family 1) and both sides qualify for its release at once. The side whose
    family is the current one, its own (-1), opens: the pattern stays 12 (the side tried
    first before, +1, gave 22), and the reference, which shares the rule, agrees."""
    w, ag, dt, cor = (held_cases.TIE_WALL, held_cases.TIE_RECORD, held_cases.TIE_DT,
                      held_cases.TIE_COR)
    res = kernel.run(w, ag, dt, cor=cor, tail=1.6, max_log=100)
    log = res["event_log"]
    i = int(np.flatnonzero(np.isclose(log[:, 0], 2.02960045, atol=1e-8)
                           & (log[:, 1] == kernel.EV_CRACK_RELEASE))[0])
    assert log[i - 1, 1] == kernel.EV_CRACK_IMPACT and log[i - 1, 0] == log[i, 0]
    assert log[i - 1, 3] == 12 and log[i, 2] == -1 and log[i, 3] == 12
    _agree(res, reference.run(w, ag, dt, cor=cor, tail=1.6))


REF_TIGHT = 1e-12  # rtol of the reference run that checks its own convergence


def _compare(case: dict) -> tuple:
    """(support, impact law, holds, the sensitivity of the case: per output, the largest of
    the kernel's own difference when the scale factor moves by one unit in the last place
    and, where kernel and reference differ by more than HELD_TOL, the reference's own difference
    between its tolerance and REF_TIGHT; differences kernel - reference) of one random
    case."""
    support = case.pop("support")
    a = kernel.run(**case)
    own = differences(a, kernel.run(**case, scale=np.nextafter(1.0, 2.0)))
    ref = reference.run(**case)
    diff = differences(a, ref)
    if max(diff.values()) > HELD_TOL:
        yard = differences(ref, reference.run(**case, rtol=REF_TIGHT))
        own = {k: max(own[k], yard[k]) for k in own}
    return support, case["impact"], a["holds"], own, diff


@pytest.mark.slow
def test_exact_agrees_with_reference_on_random_held_cases():
    """200 seeded random walls on the four support cases under both impact laws, each a
    short decaying pulse and a 2 s free-vibration tail at COR 0.3-0.8 (chatter that ends in
    held joints): every output of the exact kernel within 1e-6 of the reference's. A case
    is chaotic when a change of its scale factor by one unit in the last place moves the
    kernel's own outputs by more than 1e-6; its outputs must agree within 1e-3, or within
    that own change where it is larger (the hold decisions of a chaotic chatter flip on
    the last bit: counts of impacts and holds move by several per cent). At least 40 cases
    hold joints, some on every support case and law. Two processes (the reference takes
    about 0.3 s a case).

    Since event times are polished to the last ulps (issue 32) the kernel's 1-ulp change
    no longer reveals every chaotic chatter: in one case (a flexible base and a rigid top,
    scale law, 47 holds) perturbations of event times grow about 1e4-fold in 20 impacts,
    the kernel's 1-ulp change is 3.5e-9, yet the reference at its tolerance and at 1e-12
    disagrees with itself by 20 % (unfavourable_fraction; 50 and 41 holds). Where kernel
    and reference differ by more than 1e-6 the reference's own change between the two
    tolerances is therefore part of the case's sensitivity too: a case whose yardstick is
    not converged to 1e-6 is screened as chaotic."""
    rng = np.random.default_rng(SEED)
    cases = [held_case(rng) for _ in range(N_RANDOM)]
    with ProcessPoolExecutor(2, mp_context=get_context("spawn")) as pool:
        rows = list(pool.map(_compare, cases, chunksize=10))
    held = [r for r in rows if r[2] > 0]
    chaotic = [r for r in rows if max(r[3].values()) > HELD_TOL]
    beyond = [r for r in chaotic if max(r[4].values()) > HELD_TOL_CHAOTIC]
    bad = [(r[0], r[1], k, r[4][k], r[3][k]) for r in rows for k in r[4]
           if r[4][k] > (max(HELD_TOL_CHAOTIC, r[3][k]) if r in chaotic else HELD_TOL)]
    print(f"\n{len(rows)} random cases, {len(held)} with holds ({sum(r[2] for r in rows)} "
          f"holds), {len(chaotic)} screened chaotic ({len(beyond)} beyond 1e-3, within "
          f"their own one-ulp change); worst difference of the others "
          f"{max(max(r[4].values()) for r in rows if r not in chaotic):.1e}")
    assert len(rows) >= 200 and len(held) >= 40
    assert {(r[0], r[1]) for r in held} == {(s, law) for s in RANDOM_SUPPORTS
                                            for law in ("scale", "contact")}
    assert not bad, bad


# ---- the start rule (MODEL.md section 4) -----------------------------------------------

# The start rule and held joints of MODEL.md section 4.
#
# A closed (or held) joint has no side of its own: when one joint opens while the other is
# still closed, the closed one's side is re-set so that the pattern is family 2; family 1
# needs both joints open. The records here begin with one tiny sample of one sign and then
# the other sign at full strength, so the provisional sides (against the first non-zero
# sample) are wrong and a joint opens against its provisional side: the case where the old
# rule counted family-1 time that the kinematics of a wall on two rigid supports rule out.

OPENINGS = (kernel.EV_BASE_OPEN, kernel.EV_CRACK_OPEN)


def _family(pattern: float) -> int:
    return int(pattern) // 10


def _side(pattern: float) -> int:
    """Side of the base pivot s of a pattern code (second digit 1: +1, 2: -1)."""
    return 1 if int(pattern) % 10 == 1 else -1


def _provisional(ag: np.ndarray) -> tuple[int, int]:
    """(s, c): provisional sides, against the first non-zero ground acceleration."""
    s = -1 if ag[np.flatnonzero(ag)[0]] > 0 else 1
    return s, -s


@pytest.fixture(scope="module")
def rigid_cases():
    """200 random walls on two rigid supports under 200 reversing records (seeded)."""
    rng = np.random.default_rng(20261123)
    return [(random_wall(rng), *reversing_record(rng)) for _ in range(200)]


@pytest.fixture(scope="module")
def rigid_results(rigid_cases):
    return [kernel.run(w, ag, dt, max_log=50) for w, ag, dt in rigid_cases]


def test_both_supports_rigid_never_count_family_1(rigid_cases, rigid_results):
    """theta2 = -(a1/a2) theta1: the crack always opens first, and the kinematics allow
    family 2 only. Every one of the 200 records opens the crack against its provisional
    side (the old rule then counted family-1 time until the base opened: 200 of these 200
    walls reported unfavourable_fraction > 0 with the kernel before this rule)."""
    against = 0
    for (_, ag, _), res in zip(rigid_cases, rigid_results, strict=True):
        assert res["status"] in ("ok", "collapsed")
        assert res["unfavourable_fraction"] == 0.0
        log = res["event_log"]
        assert log.shape[0] >= 2
        first = log[0]
        assert first[1] == kernel.EV_CRACK_OPEN
        against += first[2] != _provisional(ag)[1]
        assert np.all(log[:, 3] // 10 == 2)  # every pattern after every event: family 2
    assert against == 200


def _reference(case: tuple) -> dict:
    return reference.run(*case, rtol=1e-11)


def test_reference_agrees_on_the_random_rigid_walls(rigid_cases, rigid_results):
    """The reference solver shares the event logic (the start rule included): every peak
    of every one of the 200 walls within 1e-8. Two processes (the reference takes about
    0.15 s a wall)."""
    with ProcessPoolExecutor(2, mp_context=get_context("spawn")) as pool:
        refs = list(pool.map(_reference, rigid_cases, chunksize=20))
    worst = 0.0
    for res, ref in zip(rigid_results, refs, strict=True):
        assert ref["unfavourable_fraction"] == 0.0
        assert ref["events"] == res["events"]
        worst = max(worst, worst_peak_difference(res, ref)[0])
    assert worst < 1e-8


def test_the_check_fails_with_the_old_rule():
    """The same walls with the other joint's side left provisional at an opening (the
    rule before) would spend time in family 1: the family after the first opening would
    be 1, because the crack opened against its provisional side while s kept its own."""
    rng = np.random.default_rng(20261123)
    w, ag, dt = random_wall(rng), *reversing_record(rng)
    s, c = _provisional(ag)
    res = kernel.run(w, ag, dt, max_log=5)
    opened = int(res["event_log"][0, 2])
    assert opened == -c  # against the provisional side
    old_family = 1 if s == opened else 2
    assert old_family == 1 and _family(res["event_log"][0, 3]) == 2


@pytest.mark.parametrize("support", list(SUPPORTS))
def test_sides_and_family_at_both_openings(support):
    """For every support case: the first joint opens against its provisional side; the
    closed one's side is re-set so that the pattern is family 2; at the second opening
    that joint takes the side of its own g (the logged target) and the family follows from
    the two sides."""
    wall = SUPPORTS[support]
    rng = np.random.default_rng(7)
    ag, dt = reversing_record(rng)
    prov = dict(zip(OPENINGS, _provisional(ag), strict=True))
    res = kernel.run(wall, ag, dt, max_log=40)
    log = res["event_log"]
    opens = log[np.isin(log[:, 1], OPENINGS)]
    assert len(opens) == 2 and opens[0, 1] != opens[1, 1]
    (k1, t1, p1), (k2, t2, p2) = opens[0, 1:], opens[1, 1:]
    assert t1 == -prov[k1]  # the old failure mode: against the provisional side
    # first opening: family 2, the closed joint's side re-set to match
    assert _family(p1) == 2
    s1 = t1 if k1 == kernel.EV_BASE_OPEN else -t1
    assert _side(p1) == s1
    # second opening: the joint takes its own side; the family follows from (s, c)
    s, c = (t2, -s1) if k2 == kernel.EV_BASE_OPEN else (s1, t2)
    assert _side(p2) == s and _family(p2) == (1 if s == c else 2)
    if support == "rigid/rigid":
        assert res["unfavourable_fraction"] == 0.0


# ---- t_rest, the rest time of held joints (MODEL.md section 4; issue 32) ---------------

def test_the_default_is_a_hundredth_of_a_second_and_decides_holds():
    assert kernel.T_REST == urmx.model.T_REST == 0.01
    case = c9_chatter()
    default = kernel.run(**case)
    assert max(differences(default, kernel.run(**case, t_rest=0.01)).values()) == 0.0
    other = kernel.run(**case, t_rest=0.02)
    assert (default["crack_impacts"], other["crack_impacts"]) == (132, 130)


@pytest.mark.parametrize("bad", [0.0, -0.01, math.nan, math.inf, "soon", None])
def test_a_bad_t_rest_is_refused_in_one_line_naming_it(bad):
    ag, dt = elcentro()
    for run in (kernel.run, urmx.simulate):
        with pytest.raises(InputError) as err:
            run(SUPPORTS["rigid/flex"], ag[:11], dt, t_rest=bad)
        assert str(err.value).startswith(f"t_rest={bad!r} must be") and "\n" not in str(err.value)


# ---- records sampled more finely (issue 32) --------------------------------------------

# The answer depends on the ground motion, not on how finely it is sampled (issue 32,
# MODEL.md section 4: ``v_rest = g_open/t_rest``, ``t_rest`` a constant of the model).
#
# A record is a piecewise-linear function of time: sampled again at dt/2, dt/5 and dt/10
# (``np.interp`` at the finer times) it describes the same motion, and every output of the
# kernel must stay within 1e-7, with the same counts of impacts and holds. A case is screened
# as chaotic when a change of its scale factor by one unit in the last place moves its own
# outputs by more than 1e-6; its outputs must then agree within 1e-3 or three times that own
# change, whichever is larger.
#
# The cases were found by scanning (``python -m tests.test_kernel scan``): the parametric
# walls of the catalog building on a rigid base under a top diaphragm of 0.6-1.5 Hz, C9's
# geometry on the four support cases, under El Centro (its first 10 s, then a 2 s tail) at
# scale factors 0.3-1.4, both impact laws; and the seeded short pulses of
# `tests.fixtures.random_cases.held_case` on both supports rigid or both flexible (chatter
# that ends in held joints). The walls with holds are those the scan found with ``holds > 0``
# (their counts are asserted, so a case that stops holding is noticed); the others are walls
# without holds. With ``v_rest = g_open/dt`` the soft-diaphragm cases with holds moved by up
# to 1e-1 when resampled (the README's kernel section has the table).

FACTORS = (2, 5, 10)
RESAMPLED_TOL, RESAMPLED_TOL_CHAOTIC, CHAOS = 1e-7, 1e-3, 1e-6
COUNTS = ("base_impacts", "crack_impacts", "holds", "events")
SECONDS = 10.0  # of El Centro, then a 2 s tail


def soft(wall_id: str, frequency: float):
    """A parametric wall of the catalog building (5 % damping) on a rigid base under a top
    diaphragm of `frequency` [Hz] (the building's diaphragm mass)."""
    cat = load_catalog()
    base = cat.building.wall(cat.walls[wall_id], cat.diaphragms["D1"], "top", 0.05)
    k = (2.0 * np.pi * frequency) ** 2 * (base.top_mass + 0.5 * base.mass)
    return base.replace(top_stiffness=k)


def _elcentro(wall, scale: float, impact: str) -> dict:
    ag, dt = elcentro()
    return dict(wall=wall, ground_acceleration=ag[:int(round(SECONDS / dt)) + 1], dt=dt,
                scale=scale, impact=impact, tail=2.0)


def _pulse(seed: int, support: str) -> dict:
    case = held_case(np.random.default_rng(seed), support)
    del case["support"]
    return case


# label: (how to build the case, holds it must have; None: none)
CASES = {
    "C9 rigid/flex (0.78 Hz) x0.45 contact": (lambda: _elcentro(SUPPORTS["rigid/flex"], 0.45,
                                                                "contact"), 8),
    "C9 rigid/flex (0.78 Hz) x0.6 contact": (lambda: _elcentro(SUPPORTS["rigid/flex"], 0.6,
                                                               "contact"), 4),
    "C9 rigid/flex (0.78 Hz) x0.45 scale": (lambda: _elcentro(SUPPORTS["rigid/flex"], 0.45,
                                                              "scale"), 1),
    "s08 on 0.6 Hz x0.5 scale": (lambda: _elcentro(soft("s08", 0.6), 0.5, "scale"), 2),
    "s08 on 0.6 Hz x0.3 contact": (lambda: _elcentro(soft("s08", 0.6), 0.3, "contact"), 1),
    "s10 on 1.0 Hz x1.0 scale": (lambda: _elcentro(soft("s10", 1.0), 1.0, "scale"), 1),
    "s16 on 0.6 Hz x0.3 contact": (lambda: _elcentro(soft("s16", 0.6), 0.3, "contact"), 1),
    "pulse 0 rigid/rigid contact": (lambda: _pulse(0, "rigid/rigid"), 1),
    "pulse 33 rigid/rigid scale": (lambda: _pulse(33, "rigid/rigid"), 1),
    "pulse 8 flex/flex scale": (lambda: _pulse(8, "flex/flex"), 23),
    "pulse 37 flex/flex contact": (lambda: _pulse(37, "flex/flex"), 4),
    "s12 on 0.8 Hz x1.0 scale": (lambda: _elcentro(soft("s12", 0.8), 1.0, "scale"), None),
    "s24 on 1.5 Hz x0.3 contact": (lambda: _elcentro(soft("s24", 1.5), 0.3, "contact"), None),
    "s18 rigid/rigid x0.7 scale": (lambda: _elcentro(load_catalog().walls["s18"].wall, 0.7,
                                                     "scale"), None),
    "C9 rigid/rigid x0.6 contact": (lambda: _elcentro(SUPPORTS["rigid/rigid"], 0.6,
                                                      "contact"), None),
}


def resampled(ag: np.ndarray, dt: float, k: int) -> tuple[np.ndarray, float]:
    """The same piecewise-linear motion sampled k times as finely (np.interp at the finer
    times; the last sample at the record's last time)."""
    t = np.arange(ag.size) * dt
    fine = np.arange((ag.size - 1) * k + 1) * (dt / k)
    fine[-1] = t[-1]
    return np.interp(fine, t, ag), dt / k


def spread(case: dict, run=kernel.run) -> dict[str, float]:
    """The 1-ulp spread: relative change of each output when the scale moves by 1 ulp."""
    scale = case.get("scale", 1.0)
    return differences(run(**case), run(**{**case, "scale": np.nextafter(scale, 2 * scale)}))


def compare(case: dict, run=kernel.run) -> tuple[dict, dict, dict]:
    """(the result at the record's own step, its 1-ulp spread, {k: the differences of the
    result at dt/k})."""
    a = run(**case)
    out = {}
    for k in FACTORS:
        ag, dt = resampled(case["ground_acceleration"], case["dt"], k)
        out[k] = differences(a, run(**{**case, "ground_acceleration": ag, "dt": dt}))
    return a, spread(case, run), out


@pytest.mark.parametrize("label", list(CASES))
def test_resampled_record_gives_the_same_answer(label):
    """Every output within 1e-7 at dt/2, dt/5, dt/10 and equal counts of impacts and holds
    (chaotic cases, screened by their 1-ulp spread: within max(1e-3, 3 x that spread))."""
    build, holds = CASES[label]
    case = build()
    a, own, diffs = compare(case)
    assert a["status"] == "ok"
    assert a["holds"] == (holds or 0)
    chaotic = max(own.values()) > CHAOS
    for k, d in diffs.items():
        if chaotic:
            bad = {n: v for n, v in d.items() if v > max(RESAMPLED_TOL_CHAOTIC, 3.0 * own[n])}
        else:
            bad = {n: v for n, v in d.items() if v > RESAMPLED_TOL or (n in COUNTS and v != 0.0)}
        assert not bad, (label, k, bad)
    print(f"\n{label}: holds {a['holds']}, 1-ulp spread {max(own.values()):.1e}, worst at "
          + ", ".join(f"dt/{k} {max(d.values()):.1e}" for k, d in diffs.items()))


def test_the_check_fails_on_the_sampling_dependent_rule():
    """With v_rest = g_open/dt (t_rest = the record step, the rule before issue 32) the
    same motion resampled is another problem: the first case's holds and impacts move."""
    case = CASES["C9 rigid/flex (0.78 Hz) x0.45 contact"][0]()
    ag, dt = resampled(case["ground_acceleration"], case["dt"], 10)
    coarse = kernel.run(**case, t_rest=case["dt"])
    fine = kernel.run(**{**case, "ground_acceleration": ag, "dt": dt}, t_rest=dt)
    d = differences(coarse, fine)
    assert d["holds"] > 0.0 and max(d.values()) > 1e-3


def scan() -> None:
    """Print the scan the cases were chosen from (holds and impacts of each)."""
    cat = load_catalog()
    for wid in cat.parametric_walls:
        for f in (0.6, 0.8, 1.0, 1.2, 1.5):
            for scale in (0.3, 0.5, 0.7, 1.0, 1.4):
                for law in ("scale", "contact"):
                    r = kernel.run(**_elcentro(soft(wid, f), scale, law))
                    print(wid, f, scale, law, r["holds"], r["crack_impacts"], r["base_impacts"])
    for sup, wall in SUPPORTS.items():
        for scale in (0.3, 0.45, 0.6, 0.8, 1.0):
            for law in ("scale", "contact"):
                r = kernel.run(**_elcentro(wall, scale, law))
                print("C9", sup, scale, law, r["holds"], r["crack_impacts"], r["base_impacts"])
    for seed in range(40):
        for sup in ("rigid/rigid", "flex/flex"):
            r = kernel.run(**_pulse(seed, sup))
            print("pulse", seed, sup, r["holds"], r["crack_impacts"], r["base_impacts"])


if __name__ == "__main__":
    if sys.argv[1:] == ["scan"]:
        scan()


# ---- tracking mode ---------------------------------------------------------------------

@pytest.mark.parametrize("support", list(SUPPORTS))
def test_capacity_tracking_gives_the_drifts_and_ratios_of_a_full_run_bit_for_bit(support):
    """track="capacity" follows only the drifts: every output a capacity search reads
    (ratios, drifts, collapse, its time) and every event count equal those of a full run
    exactly, at scales from far below to above collapse; the untracked peaks are NaN."""
    ag, dt = elcentro()
    wall = SUPPORTS[support]
    collapsed = set()
    for scale in (0.3, 0.8, 1.5, 3.0, 6.0):
        full = kernel.run(wall, ag, dt, scale=scale)
        cap = kernel.run(wall, ag, dt, scale=scale, track="capacity")
        for key, value in full.items():
            if key in kernel.UNTRACKED:
                assert math.isnan(cap[key]), key
            elif key == "series":  # (fewer: no acceleration peak asks for a series)
                assert cap[key] <= value
            elif isinstance(value, float) and math.isnan(value):
                assert math.isnan(cap[key]), key
            else:
                assert cap[key] == value, (key, scale, cap[key], value)
        assert full["events"] > 0
        collapsed.add(full["collapsed"])
    assert collapsed == {0, 1}  # both sides of collapse were compared


@pytest.mark.parametrize("support", list(SUPPORTS))
def test_capacity_tracking_on_a_finely_sampled_record_equals_a_full_run(support):
    """The same on El Centro resampled at dt/4 (the same piecewise-linear motion): long runs
    of plain steps between events, which a capacity search's analysis integrates in a loop
    of its own (state in locals, vectorised); each of its steps must give the bits of the
    general loop, or the drifts, ratios and the time in family 1 part from a full run's."""
    ag, dt = elcentro()
    fine = np.interp(np.arange(4 * (len(ag) - 1) + 1) / 4.0, np.arange(len(ag)), ag)
    wall = SUPPORTS[support]
    for scale, tail in ((0.5, 3.0), (1.2, 0.0)):  # (and steps of free vibration after it)
        full = kernel.run(wall, fine, dt / 4, scale=scale, tail=tail)
        cap = kernel.run(wall, fine, dt / 4, scale=scale, tail=tail, track="capacity")
        assert full["substeps"] > 4 * full["events"]  # mostly plain steps
        for key in ("instability_ratio_lower", "instability_ratio_upper", "peak_lower_drift",
                    "peak_upper_drift", "peak_lower_drift_family1", "collapsed",
                    "unfavourable_fraction", "events", "substeps"):
            assert cap[key] == full[key], (key, scale, cap[key], full[key])


def test_an_unknown_tracking_mode_is_refused():
    ag, dt = elcentro()
    with pytest.raises(InputError, match="track='drift' is not a tracking mode"):
        kernel.run(WEST, ag, dt, track="drift")


# ---- tables at a second record step -------------------------------------------------------

@pytest.mark.parametrize("support", list(SUPPORTS))
def test_tables_taken_from_another_step_equal_tables_built_anew(support):
    """A wall's tables at a second record step copy what does not depend on the step from
    its tables at the first (geometry, piece matrices, release rows, eigenvalues) and
    compute only the propagators: every array equals that of tables built from nothing,
    and so does an analysis (pieces added later are computed, not copied)."""
    from urmx.kernel import pieces

    wall = SUPPORTS[support]
    first = pieces.Tables(wall, 0.02)
    like = pieces.Tables(wall, 0.005, first)
    anew = pieces.Tables(wall, 0.005)
    assert first.ready.any() and (like.ready == anew.ready).all()
    for name in ("nsub", "mats", "vecs", "prop", "pvec", "rel", "nu"):
        np.testing.assert_array_equal(getattr(like, name), getattr(anew, name), err_msg=name)
    for a, b in zip(like.geo, anew.geo, strict=True):
        np.testing.assert_array_equal(a, b)
    assert not np.array_equal(like.prop, first.prop)  # (the step's own propagators)
    ag, dt = elcentro()
    fine = np.interp(np.arange(4 * (len(ag) - 1) + 1) / 4.0, np.arange(len(ag)), ag)
    pieces.clear_cache()
    kernel.run(wall, ag, dt, scale=1.2)  # its tables at 0.02 s: taken at dt / 4 below
    shared = kernel.run(wall, fine, dt / 4, scale=1.2)
    pieces.clear_cache()
    anew = kernel.run(wall, fine, dt / 4, scale=1.2)
    assert {k: repr(v) for k, v in shared.items()} == {k: repr(v) for k, v in anew.items()}
    assert shared["events"] > 0
