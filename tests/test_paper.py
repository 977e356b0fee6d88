"""urmx.paper: every finding's criterion agrees on a synthetic study built to satisfy it and
fails on one that violates it; the paper's tables come from catalog/paper.toml."""

import copy

import numpy as np
import pytest
import xarray as xr

from urmx import paper as P

from .fixtures import paper_studies as F

CC = {"record": "christchurch"}
S18 = {"wall": "s18", "record": "christchurch", "cor": 0.8}


def _set(ds, var, where, values):
    da = ds[var].copy()
    da.loc[where] = values
    ds[var] = da
    return ds


def _ratio(ds, where, values):
    for v in ("instability_ratio", "instability_ratio_lower"):
        _set(ds, v, where, values)
    return ds


def _flexible_first(ds, where):
    """The single-storey ratio pattern of elcentro/christchurch (less stable when more
    flexible) put on ``where``."""
    src = ds["instability_ratio"].sel(record="elcentro")
    return _ratio(ds, where, src.sel(**{k: v for k, v in where.items() if k != "record"}).values)


def _single(fn):
    def run():
        s = F.single()
        return fn(s) or s, F.multi(), F.verification()
    return run


def _multi(fn):
    def run():
        m = F.multi()
        return F.single(), fn(m) or m, F.verification()
    return run


def _w():
    return np.arange(9.0)[:, None]


# one mutation per finding: it violates that statement (and may break others)
BREAK = {
    "top-acceleration-rises": _single(lambda s: _set(
        s, "peak_top_acceleration", CC, 3.0 - 0.4 * np.arange(6.0)[None, :, None])),
    "crack-acceleration-rises": _single(lambda s: _set(
        s, "peak_crack_acceleration", CC, 3.0 - 0.3 * np.arange(6.0)[None, :, None])),
    "crack-acceleration-magnitude": _single(lambda s: _set(
        s, "peak_crack_acceleration", {"wall": "s08", "diaphragm": "D4", **CC}, 4.0)),
    "crack-acceleration-where": _single(lambda s: _set(
        s, "peak_crack_acceleration", {"wall": "s14", "diaphragm": "D4", **CC}, 3.1)),
    "top-acceleration-particularly": _single(lambda s: _set(
        s, "peak_top_acceleration", {"diaphragm": "D4", **CC}, 1.1)),
    "stiffening-connections": _single(lambda s: _set(
        s, "peak_top_acceleration", {"diaphragm": "D4", **CC}, 1.4)),
    "top-displacement-falls": _single(lambda s: _set(
        s, "peak_top_displacement", CC, 0.01 * (1 + np.arange(6.0)[None, :, None]))),
    "top-displacement-constant": _single(lambda s: _set(
        s, "peak_top_displacement", CC, 0.01 * (1 + 0.3 * _w()[:, :, None]) + 0 *
        np.arange(6.0)[None, :, None])),
    "crack-displacement-irregular": _single(lambda s: _set(
        s, "peak_crack_displacement", CC, 0.01 * (1 + _w()[:, :, None]) *
        (1 + np.arange(6.0)[None, :, None]))),
    "d5-unfavourable-share": _single(lambda s: _set(
        s, "unfavourable_fraction", {"diaphragm": "D5", **S18}, 0.2)),
    "d5-lower-ratio": _single(lambda s: _set(
        s, "instability_ratio_lower", {"diaphragm": "D5", **S18}, 0.5)),
    "d1-unfavourable-share": _single(lambda s: _set(
        s, "unfavourable_fraction", {"diaphragm": "D1", **S18}, 0.4)),
    "d1-crack-smaller": _single(lambda s: s.drop_dims("history").merge(
        F._histories(family1_peak=0.04))),
    "d1-lower-less-stable": _single(lambda s: _set(
        s, "instability_ratio_lower", {"diaphragm": "D1", **S18}, 0.1)),
    "d1-less-stable": _single(lambda s: _set(
        s, "instability_ratio", {"diaphragm": "D1", **S18}, 0.1)),
    "destabilises-with-flexibility": _single(lambda s: [
        _ratio(s, {"record": r}, s["instability_ratio"].sel(record="nahanni").values)
        for r in ("elcentro", "christchurch")] and s),
    "stabilises-often": _single(lambda s: _flexible_first(s, {"record": "nahanni"})),
    "nahanni-d3-to-d2": _single(lambda s: _ratio(
        s, {"wall": "s24", "diaphragm": "D2", "record": "nahanni"}, 0.9)),
    "stiff-rises-with-slenderness": _single(lambda s: _ratio(
        s, {"diaphragm": ["D3", "D4", "D5"]}, 0.5 - 0.01 * _w()[:, :, None, None])),
    "flexible-chaotic": _single(lambda s: _ratio(
        s, {"diaphragm": ["D1", "D2"], "record": ["elcentro", "christchurch"]},
        0.3 + 0.02 * _w()[:, :, None, None])),
    "converges-to-pinned": _single(lambda s: _ratio(
        s, {"diaphragm": "D4"}, s["instability_ratio"].sel(diaphragm="D5").values + 0.5)),
    "multi-both-effects": _multi(lambda m: _set(
        m, "instability_ratio", {"record": "nahanni"},
        m["instability_ratio"].sel(record="christchurch").values)),
    "multi-nahanni-stiffer-worse": _multi(lambda m: _set(
        m, "instability_ratio", {"record": "nahanni"}, 0.5 - 0.1 * np.arange(4.0)[None, :, None])),
    "multi-christchurch-flexible-worse": _multi(lambda m: _set(
        m, "instability_ratio", {"record": "christchurch"},
        0.1 + 0.1 * np.arange(4.0)[None, :, None])),
    "multi-elcentro-no-relation": _multi(lambda m: _set(
        m, "instability_ratio", {"record": "elcentro"}, 0.3 + 0.1 * np.arange(4.0)[None, :, None])),
    "multi-slenderness-none": _multi(lambda m: _set(
        m, "instability_ratio", {}, m["instability_ratio"].values
        + 0.2 * _w()[:, :, None, None])),
    "resonance": _multi(lambda m: _set(
        m, "instability_ratio", {"record": "nahanni"},
        0.6 - 0.1 * np.arange(4.0)[None, :, None])),
    "ground-motion-dependent": _single(lambda s: _flexible_first(s, {"record": "nahanni"})),
    "slenderness-not-a-criterion": lambda: (
        _ratio(F.single(), {}, F.single()["instability_ratio"].values
               + 0.2 * _w()[:, :, None, None]),
        _set(F.multi(), "instability_ratio", {}, F.multi()["instability_ratio"].values
             + 0.2 * _w()[:, :, None, None]),
        F.verification()),
    "verification-cor": lambda: (F.single(), F.multi(), F.verification(collapse=[np.nan] * 5)),
}


def _rows(single, multi, verification, paper=None):
    return {r["key"]: r for r in P.findings(single, multi, verification, paper=paper,
                                            ranges=F.RANGES, manifest={})}


@pytest.fixture(scope="module")
def agreed():
    return _rows(F.single(), F.multi(), F.verification())


def test_every_finding_agrees_on_data_built_to_satisfy_it(agreed):
    assert len(agreed) >= 16
    assert {k: r["measured"] for k, r in agreed.items() if r["agree"] is not True} == {}
    assert all(r["cause"] == "" for r in agreed.values())


def test_every_finding_has_a_violating_case():
    assert set(BREAK) == {f.key for f in P.statements(P.load_paper())}


@pytest.mark.parametrize("key", sorted(BREAK))
def test_finding_fails_on_data_that_violate_it(key):
    rows = _rows(*BREAK[key]())
    assert rows[key]["agree"] is False, rows[key]["measured"]
    assert rows[key]["cause"]  # measured cause or "not known", never blank


def test_magnitudes_are_checked_not_just_signs(agreed):
    row = agreed["crack-acceleration-magnitude"]
    assert "+50%" in row["measured"] and "(h/t 8)" in row["measured"]
    rows = _rows(*BREAK["crack-acceleration-magnitude"]())
    assert "+100%" in rows["crack-acceleration-magnitude"]["measured"]
    # the sign alone still agrees: the crack acceleration still rises with stiffness
    assert rows["crack-acceleration-rises"]["agree"] is True


def test_disagreement_is_remeasured_with_the_other_d5_model():
    s = F.single()
    _set(s, "instability_ratio_lower", {"diaphragm": "D5", **S18}, 0.5)
    _set(s, "instability_ratio_lower", {"diaphragm": "D5-pinned", **S18}, 0.15)
    row = _rows(s, F.multi(), F.verification())["d5-lower-ratio"]
    assert row["agree"] is False
    assert row["cause"].startswith("measured: the criterion holds with D5-pinned in place of D5")
    assert "0.150" in row["cause"]


def test_unknown_cause_says_so():
    row = _rows(*BREAK["nahanni-d3-to-d2"]())["nahanni-d3-to-d2"]
    assert row["cause"].startswith("not known")


def test_statements_are_generated_from_the_paper_file():
    paper = P.load_paper()
    data = copy.deepcopy(paper.data)
    data["table6"]["D5"]["ratio_lower"] = 0.5
    data["unfavourable"]["D5"] = 0.02
    other = P.Paper(data)
    rows = _rows(F.single(), F.multi(), F.verification(), paper=other)
    assert "within 50 % of its instability" in rows["d5-lower-ratio"]["statement"]
    assert rows["d5-lower-ratio"]["agree"] is False  # 0.14 is not within a factor 2 of 0.5
    assert "only 2 % of the duration" in rows["d5-unfavourable-share"]["statement"]


def test_missing_archives_are_not_computable():
    rows = P.findings(None, None, None, ranges=F.RANGES, manifest={})
    assert all(r["agree"] is None and r["measured"].startswith("not available") for r in rows)


def test_table3_has_45_numbers_beside_the_paper():
    rows = P.table3()
    assert len(rows) == 45
    w12 = {(r["case"], r["quantity"]): r for r in rows if r["wall"] == "wall12"}
    assert w12[(1, "M0 [kN m]")]["paper"] == 0.080
    assert w12[(1, "M0 [kN m]")]["urmx"] == pytest.approx(0.080, rel=0.015)
    rel = np.array([abs(r["relative"]) for r in rows])
    # MODEL.md section 3: most match within 1.5 %; the largest is the misprint (West wall,
    # Case 3 theta1: 0.0001 printed, 0.0004 by the formula); the others differ by rounding
    # of 3-decimal prints (at most one unit in the last digit)
    assert (rel <= 0.015).sum() >= 30
    worst = rows[int(np.argmax(rel))]
    assert (worst["wall"], worst["case"], worst["quantity"]) == ("west", 3, "theta1 [rad]")
    others = [r for r in rows if r is not worst]
    assert all(abs(r["difference"]) <= 1.5e-3 or abs(r["relative"]) <= 0.015 for r in others)


def test_table4_d5_spring_frequency_in_paper_range():
    rows = {r["diaphragm"]: r for r in P.table4()}
    lo, hi = rows["D5"]["range"]
    assert rows["D5"]["stiffness"] == 1e9 and rows["D5"]["fitted"]
    assert 0.9 * 30 < lo < hi < 40  # Table IV: 30-40 Hz
    for d in ("D1", "D2", "D3", "D4"):
        plo, phi = rows[d]["paper_range"]
        assert abs(rows[d]["range"][0] / plo - 1) < 0.1 and abs(rows[d]["range"][1] / phi - 1) < 0.1


def test_table6_like_for_like_column_from_history():
    tab = P.table6(F.single())
    assert list(tab["diaphragm"].values) == ["D5", "D5-pinned", "D1"]
    # D1 rocks in patterns 11/12 with a 22 mm peak, its overall peak comes later in 21/22
    assert float(tab["peak_lower_drift_family1"].sel(diaphragm="D1")) == pytest.approx(0.022)
    assert np.isnan(float(tab["peak_lower_drift_family1"].sel(diaphragm="D5")))
    assert tab["peak_lower_drift_family1"].attrs["units"] == "m"


def test_table6_column2_from_the_kernel():
    """An archive with the kernel's continuous-time peak_lower_drift_family1 gives Table VI's
    column (2) from it, not from the histories on the record grid."""
    single = F.single()
    fam1 = xr.zeros_like(single["peak_lower_drift"])
    fam1.loc[{"diaphragm": "D1"}] = 0.0235
    single["peak_lower_drift_family1"] = fam1
    tab = P.table6(single)
    assert tab.attrs["family1_source"].startswith("kernel")
    assert float(tab["peak_lower_drift_family1"].sel(diaphragm="D1")) == pytest.approx(0.0235)
    assert float(tab["peak_lower_drift_family1"].sel(diaphragm="D5")) == 0.0


def test_significant_frequency_is_the_manifests():
    ranges = P.significant_frequency()
    assert ranges["nahanni"] == (7.0, 9.0) and ranges["christchurch"] == (0.2, 3.0)


def test_verification_rows_state_intensity_and_source():
    manifest = {"bigbear": {"shake_table_source": "paper Fig. 5b", "shake_table_pga_g": 0.5}}
    rows = {r["wall"]: r for r in P.verification(F.verification(), manifest=manifest)}
    west = rows["west"]
    assert west["best_cor"] == pytest.approx(0.82) and west["target"] == "collapse_time = 5.3"
    assert west["stated_pga_g"] == 0.5 and west["source"] == "paper Fig. 5b"
    assert west["scaled_pga_g"] == pytest.approx(0.6 / 9.81)
    assert rows["c9"]["target"] == "" and np.isnan(rows["c9"]["best_cor"])
