"""Issue 37: the candidate predictors of a wall against hand calculations, the ranking's
cross-validation and recommendation on a synthetic population, and walls drawn in
geometry by the sampler."""

from __future__ import annotations

import math

import numpy as np
import pytest

from urmx.fragility import predictors as pr
from urmx.fragility import ranking
from urmx.model import RIGID, Wall

G = 9.81


@pytest.fixture(scope="module")
def wall():
    # b = 0.2, h = 4, crack at mid-height: a1 = a2 = 2, m1 = m2 = 2000, m_dt = 2000
    return Wall(thickness=0.2, height=4.0, crack_ratio=0.5, mass=4000.0, top_mass=2000.0,
                top_stiffness=1e6, top_damping=0.1, pmr=75.0)


def test_predictors_by_hand(wall):
    p = pr.wall_predictors(wall)
    assert p["slenderness"] == pytest.approx(20.0)
    assert p["height"] == 4.0 and p["thickness"] == 0.2
    # Table I: M0_2 = (m1/2 + m2 + m_dt) b g = 5000 * 0.2 * 9.81 = 9810,
    # M0_1 = (m2/2 + m_dt/2) b g = 2000 * 0.2 * 9.81 = 3924; (9810 + 3924) / (m a1 / 2)
    assert p["static_acceleration"] == pytest.approx((9810.0 + 3924.0) / 4000.0, rel=1e-12)
    # theta0 a1: Case 2 b / a1 * a1 = b; Case 3 b/2 m1 / (m1/2 + m2 + m_dt) = 0.1 * 0.4
    assert p["instability_case2"] == pytest.approx(0.2, rel=1e-12)
    assert p["instability_case3"] == pytest.approx(0.04, rel=1e-12)
    # Housner: R = sqrt(0.2^2 + 2^2) / 2 = 1.0049876; p = sqrt(3 g / 4 R)
    assert p["housner_lower"] == pytest.approx(2.705732, rel=1e-6)
    assert p["housner_upper"] == pytest.approx(2.705732, rel=1e-6)
    # Table IV footnote: sqrt(1e6 / (2000 + 2000)) / 2 pi
    assert p["diaphragm_frequency"] == pytest.approx(math.sqrt(250.0) / (2 * math.pi))
    # effective period: theta_ins = min(0.1, Case 1 0.05 * 4000/3000), theta_d = 0.6 of it
    # = 0.04; R = lower softening 9810 (1 - 0.4) + upper softening 3924 (1 - 0.6) = 7455.6;
    # J = M11 - 2 M12 + M22 (theta2 = -theta1; MODEL.md section 5, family 2)
    #   = (2693.33 + 4000 * 4.04) - 2 (4 * 3000 - 4000 * 0.02) + (2693.33 + 2000 * 4.01)
    j = (2000 * 4.04 / 3 + 4000 * 4.04) - 2 * (12000 - 80) + (2000 * 4.04 / 3 + 2000 * 4.01)
    period = 2 * math.pi * math.sqrt(j * 0.04 / 7455.6)
    assert p["effective_period"] == pytest.approx(period, rel=1e-9)
    assert p["effective_period"] == pytest.approx(1.10134, rel=1e-5)
    assert p["frequency_ratio"] == pytest.approx(p["diaphragm_frequency"] * period, rel=1e-9)
    assert set(p) == set(pr.PREDICTORS)


def test_static_acceleration_classic_one_way_result():
    # no overburden, crack at mid-height: 4 g t / h (the classic one-way wall)
    w = Wall(thickness=0.23, height=3.5, crack_ratio=0.5, mass=3000.0)
    assert pr.static_acceleration(w) == pytest.approx(4 * G * 0.23 / 3.5, rel=1e-12)


def test_rigid_top_has_infinite_frequency(wall):
    p = pr.wall_predictors(wall.replace(top_stiffness=RIGID, top_damping=0.0))
    assert math.isinf(p["diaphragm_frequency"]) and math.isinf(p["frequency_ratio"])
    with pytest.raises(ValueError, match="case must be 2 or 3"):
        pr.instability_displacement(wall, 1)


def _synthetic(n=240, seed=3):
    rng = np.random.default_rng(seed)
    x = {"good": rng.normal(size=n), "weak": rng.normal(size=n),
         "irrelevant": rng.normal(size=n)}
    y = 1.0 - 0.8 * x["good"] + 0.2 * x["weak"] + 0.15 * rng.normal(size=n)
    return x, y


def test_ranking_recovers_the_known_best_and_ranks_the_irrelevant_last():
    x, y = _synthetic()
    r = ranking.rank(x, y, pairs=False, replicates=100)
    assert r.sets[0] == ("good",)
    assert r.sets[-1] == ("irrelevant",)
    assert r.share[-1] < 0.02  # cross-validated: no better than the mean
    # the true share of "good" alone: 0.64 / (0.64 + 0.04 + 0.0225)
    assert r.share[0] == pytest.approx(0.64 / 0.7025, abs=0.04)
    assert r.lower[0] < r.share[0] < r.upper[0]
    pairs = ranking.rank(x, y, replicates=100)
    assert pairs.sets[0] == ("good", "weak")
    # the pair adds a real term: the recommended set is the pair, not "good" alone
    assert pairs.sets[ranking.recommend(pairs)] == ("good", "weak")


def test_recommend_takes_the_smallest_set_within_the_uncertainty():
    x, y = _synthetic()
    y = 1.0 - 0.8 * x["good"] + 0.15 * np.random.default_rng(9).normal(size=len(y))
    r = ranking.rank(x, y, replicates=100)
    # the pairs with "good" fit noise: no better than "good" alone within the bootstrap
    assert r.sets[ranking.recommend(r)] == ("good",)


def test_cross_validation_scores_each_wall_by_a_fit_without_it():
    x, y = _synthetic(60)
    fold = ranking.folds(60, 5, seed=1)
    pred = ranking.cv_predictions(x["good"], y, fold)
    a = np.column_stack([np.ones(60), x["good"]])
    for f in range(5):
        test = fold == f
        coef = np.linalg.lstsq(a[~test], y[~test], rcond=None)[0]
        np.testing.assert_allclose(pred[test], a[test] @ coef, rtol=1e-12)
        # and not the fit that includes the fold's walls
        full = np.linalg.lstsq(a, y, rcond=None)[0]
        assert not np.allclose(pred[test], a[test] @ full)


def test_bootstrap_copies_of_a_wall_share_its_fold():
    fold = ranking.folds(50, 5, seed=2)
    rng = np.random.default_rng(0)
    for _ in range(20):
        idx, fb = ranking.bootstrap_sample(fold, rng)
        assert len(np.unique(idx)) < len(idx)  # there are copies
        assert not ranking.leaks(idx, fb)
    # the check fails on folds cut by row, which put copies of a wall in two folds
    idx, _ = ranking.bootstrap_sample(fold, np.random.default_rng(0))
    assert ranking.leaks(idx, ranking.folds(len(idx), 5, seed=2))


def test_vif():
    rng = np.random.default_rng(0)
    a = rng.normal(size=500)
    b = 0.9 * a + math.sqrt(1 - 0.81) * rng.normal(size=500)
    v = ranking.vif(np.column_stack([a, b]))
    r = np.corrcoef(a, b)[0, 1]
    np.testing.assert_allclose(v, 1 / (1 - r ** 2), rtol=1e-9)
    assert ranking.vif(a[:, None])[0] == 1.0


# ---- walls drawn in geometry (urmx.uncertainty.sampler) ----------------------------------

def _sampling(params, **extra):
    from urmx.uncertainty import parse_sampling

    return parse_sampling({"samples": 64, "seed": 5, "parameters": params, **extra})


def test_wall_drawn_in_geometry_is_the_building_wall():
    from urmx.uncertainty import apply

    base = Wall.in_building(thickness=0.23, height=3.68, crack_ratio=2 / 3, density=1800.0,
                            wall_length=12.51, diaphragm_weight=0.455, plan_area=520.26,
                            diaphragm_stiffness=815e3, supports="top", damping=0.12)
    values = {"thickness": 0.35, "height": 5.0, "overburden_ratio": 0.5,
              "diaphragm_frequency": 2.0, "rigid_top": 0.0, "damping": 0.09,
              "storey": "higher"}
    w = apply(base, values)
    mass = base.mass / (0.23 * 3.68) * 0.35 * 5.0  # Eq. 7 mass per unit of t h
    assert w.mass == pytest.approx(mass) and w.top_mass == pytest.approx(0.5 * mass)
    assert w.diaphragm_frequency("top") == pytest.approx(2.0)
    assert w.diaphragm_frequency("bottom") == pytest.approx(2.0)  # two diaphragms alike
    assert w.bottom_mass == w.top_mass and w.top_damping == w.bottom_damping == 0.09
    # the same wall Wall.in_building builds with a plan area giving that diaphragm mass
    area = 0.5 * mass * G / (8 / 15 * 1e3 * 1.2)
    ref = Wall.in_building(thickness=0.35, height=5.0, crack_ratio=2 / 3, density=1800.0,
                           wall_length=12.51, diaphragm_weight=1.2, plan_area=area,
                           diaphragm_frequency=2.0, supports="both", damping=0.09)
    for f in ("mass", "top_mass", "bottom_mass", "top_stiffness", "bottom_stiffness"):
        assert getattr(w, f) == pytest.approx(getattr(ref, f), rel=1e-12)
    single = apply(base, {**values, "storey": "single", "rigid_top": 1.0})
    assert single.top_rigid and single.bottom_rigid and single.top_damping == 0.0


def test_max_slenderness_leaves_out_slender_walls():
    s = _sampling({"thickness": {"distribution": "uniform", "low": 0.11, "high": 0.47},
                   "height": {"distribution": "uniform", "low": 2.5, "high": 7.0}},
                  max_slenderness=35)
    _, v = s.draw()
    assert len(v["height"]) == 64 and np.all(v["height"] / v["thickness"] <= 35)
    _, free = _sampling({"thickness": {"distribution": "uniform", "low": 0.11, "high": 0.47},
                         "height": {"distribution": "uniform", "low": 2.5, "high": 7.0}}
                        ).draw()
    assert np.any(free["height"] / free["thickness"] > 35)  # the filter is not idle


def test_loguniform_and_bernoulli():
    s = _sampling({"diaphragm_frequency": {"distribution": "loguniform", "low": 0.8,
                                           "high": 8.0},
                   "rigid_top": {"distribution": "bernoulli", "p": 0.25}})
    u, v = s.draw()
    np.testing.assert_allclose(np.log(v["diaphragm_frequency"]),
                               math.log(0.8) + u[:, 0] * math.log(10.0), rtol=1e-12)
    assert v["rigid_top"].sum() == 16  # a Latin hypercube: exactly a quarter below 0.25


@pytest.mark.parametrize("params, extra, key", [
    ({"diaphragm_weight": {"distribution": "uniform", "low": 0.75, "high": 2.1}}, {},
     "parameters.diaphragm_weight"),
    ({"thickness": {"distribution": "uniform", "low": 0.1, "high": 0.4}},
     {"max_slenderness": 35}, "max_slenderness"),
    ({"diaphragm_frequency": {"distribution": "loguniform", "low": 0.0, "high": 8.0}}, {},
     "parameters.diaphragm_frequency.low"),
    ({"rigid_top": {"distribution": "bernoulli", "p": 1.5}}, {}, "parameters.rigid_top.p"),
    ({"storey": {"distribution": "choice", "values": ["ground", "higher"]}}, {},
     "parameters.storey.values"),
    ({"diaphragm_frequency": {"distribution": "uniform", "low": 1, "high": 2},
      "frequency": {"distribution": "uniform", "low": 0.9, "high": 1.1}}, {},
     "parameters.frequency"),
])
def test_bad_geometry_tables_are_refused(params, extra, key):
    from urmx.uncertainty import ParameterError

    with pytest.raises(ParameterError) as exc:
        _sampling(params, **extra)
    assert exc.value.key == key


def test_a_frequency_bin_no_replicate_fills_has_no_interval_and_no_warning():
    """A bin of the frequency ratio that no cell falls in (here the last two) has a NaN mean
    and a NaN interval, which the report shows as "-", and says nothing on stderr (numpy's
    all-NaN warning is not the user's business); the filled bins keep finite intervals."""
    import warnings

    from urmx.analysis.predictors import _resonance_boot

    rng = np.random.default_rng(3)
    walls, recs = np.repeat(np.arange(6), 5), np.tile(np.arange(5), 6)
    cells = {"e": rng.normal(0.0, 0.3, 30), "x": rng.uniform(-1.0, 0.9, 30),
             "s": rng.normal(0.5, 0.2, 30), "record": recs, "wall": walls}
    edges = np.array([-1.0, 0.0, 1.0, 2.0, 3.0])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        out = _resonance_boot(cells, edges, 50, 1)
    assert np.isfinite(out["lower"][:2]).all() and np.isnan(out["lower"][2:]).all()
    assert (out["lower"][:2] <= out["upper"][:2]).all() and np.isnan(out["upper"][2:]).all()
