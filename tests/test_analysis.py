"""Reductions of urmx.analysis on small synthetic studies with hand-computed answers."""

import numpy as np
import pytest
import xarray as xr
from numpy.testing import assert_allclose

from urmx.analysis import grid as A

from .fixtures.studies import single_storey

RANGES = {"elcentro": (0.2, 7.0), "nahanni": (7.0, 9.0), "christchurch": (0.2, 3.0)}


def test_rank_correlation_hand_computed():
    # ranks of y: [1, 3, 2, 4] against x = [1, 2, 3, 4]: sum d^2 = 2, rho = 1 - 6*2/(4*15)
    da = xr.DataArray([1.0, 3.0, 2.0, 4.0], dims="wall",
                      coords={"slenderness": ("wall", [8.0, 12.0, 18.0, 24.0])},
                      attrs={"long_name": "x", "units": "1"})
    rho = A.rank_correlation(da, "slenderness", "wall")
    assert rho.name == "rank_correlation" and rho.attrs["units"] == "1"
    assert_allclose(float(rho), 0.8)


def test_rank_correlation_keeps_other_dims_and_drops_nan():
    data = np.array([[1.0, 2.0, 3.0, 4.0], [4.0, 3.0, np.nan, 1.0]])
    da = xr.DataArray(data, dims=("record", "wall"), coords={
        "record": ["a", "b"], "slenderness": ("wall", [8.0, 12.0, 18.0, 24.0])})
    rho = A.rank_correlation(da, "slenderness", "wall")
    assert rho.dims == ("record",)
    assert_allclose(rho.values, [1.0, -1.0])


def test_stiffness_trend_ranks_infinite_stiffness_last(single):
    pk = A.peak_profiles(single, "displacement", "christchurch")
    rho = A.stiffness_trend(pk["peak_top_displacement"])
    # 0.05/(1+d) + 0.001 w falls with D1 < D3 < D5 (inf) for every wall
    assert_allclose(rho.values, [-1.0] * 4)


def test_peak_profiles_selects_record_and_cor(single):
    pk = A.peak_profiles(single, "acceleration", record="Christchurch", cor=0.8)
    assert set(pk.data_vars) == {"peak_top_acceleration", "peak_crack_acceleration"}
    assert pk["peak_top_acceleration"].dims == ("wall", "diaphragm")
    assert pk["peak_top_acceleration"].attrs["units"] == "m s-2"
    assert pk["peak_top_acceleration"].attrs["long_name"]
    # (1 + d) * (1 + 0.1 w) + r + c with w18 (w=2), D3 (d=1), christchurch (r=2), cor 0.8 (c=1)
    assert_allclose(float(pk["peak_top_acceleration"].sel(wall="w18", diaphragm="D3")),
                    2 * 1.2 + 2 + 1)
    assert list(pk["slenderness"].values) == sorted(pk["slenderness"].values)
    # the nearest cor is taken: 0.72 -> 0.7 (c=0)
    pk7 = A.peak_profiles(single, "acceleration", "christchurch", cor=0.72)
    assert_allclose(float(pk7["peak_top_acceleration"].sel(wall="w08", diaphragm="D1")), 3.0)


def test_missing_record_is_a_clear_error(single):
    with pytest.raises(A.MissingDataError, match="no record 'kobe'"):
        A.peak_profiles(single, "acceleration", record="kobe")


def test_select_takes_first_value_of_extra_dims(single):
    ds = single[["peak_top_acceleration"]].expand_dims(scale=[1.0, 2.0])
    out = A.select(ds, keep=("wall", "diaphragm"), cor=0.8, record="nahanni")
    assert "scale" not in out.dims and out.attrs["selection"] == "scale=1.0"


def test_stability_table_matches_hand_computed_instability_displacements(single):
    tab = A.stability_table(single, 4.14, ("D5", "D1"), "christchurch", cor=0.8)
    assert list(tab["diaphragm"].values) == ["D5", "D1"]
    d5, d1 = tab.sel(diaphragm="D5"), tab.sel(diaphragm="D1")
    # m = 3000 kg, eta = 2/3: m1 = 2000, m2 = 1000; b = 0.23 m
    # D5 (m_dt = 0): upper a2*theta0 = b/2*(m2)/(0.5 m2) = b; lower Case 2 = b
    assert_allclose(float(d5["instability_displacement_upper"]), 0.23)
    assert_allclose(float(d5["instability_displacement_lower"]), 0.23)
    assert int(d5["lower_case"]) == 2  # 0.033/0.14 = 0.236 is nearest Case 2's 0.23
    # D1 (m_dt = 1000): upper b/2*(1000+1000)/(500+1000); Case 3: b/2*2000/(1000+1000+1000)
    assert_allclose(float(d1["instability_displacement_upper"]), 0.115 * 4 / 3)
    assert_allclose(float(d1["instability_displacement_lower"]), 0.115 * 2 / 3)
    assert int(d1["lower_case"]) == 3  # 0.022/0.35 = 0.063 is nearest Case 3's 0.077
    assert_allclose(tab["instability_ratio"].values, [0.20, 0.35])
    assert_allclose(tab["peak_upper_drift"].values, [0.047, 0.016])
    assert_allclose(tab["unfavourable_fraction"].values, [0.015, 0.6])
    assert tab["instability_displacement_lower"].attrs["units"] == "m"
    assert tab.attrs["wall"] == "w18"


def test_stability_table_implies_displacements_without_wall_coords(single):
    ds = single.drop_vars(["crack_ratio", "mass", "diaphragm_mass"])
    tab = A.stability_table(ds, 4.14, ("D5", "D1"), "christchurch", cor=0.8)
    assert tab.attrs["instability_displacement_source"].startswith("implied")
    assert_allclose(tab["instability_displacement_upper"].values, [0.047 / 0.20, 0.016 / 0.07])
    assert_allclose(tab["instability_displacement_lower"].values, [0.033 / 0.14, 0.022 / 0.35])


def test_displacement_histories_pick_wall_diaphragm_and_cor(single):
    hist = A.displacement_histories(single, 4.14, ("D1", "D5"), "christchurch", cor=0.8)
    assert hist["top_displacement"].dims == ("diaphragm", "time")
    assert list(hist["diaphragm"].values) == ["D1", "D5"]
    # cells a (D1, cor 0.8, amp 1) and b (D5, amp 2), not c (D1, cor 0.7, amp 3)
    assert_allclose(hist["crack_displacement"].isel(time=-1).values, [0.001, 0.002])
    assert hist.attrs["wall"] == "w18" and hist.attrs["record"] == "christchurch"
    assert hist["top_displacement"].attrs["units"] == "m"
    hist7 = A.displacement_histories(single, 4.14, ("D1",), "christchurch", cor=0.7)
    assert_allclose(hist7["crack_displacement"].isel(time=-1).values, [0.003])


def test_histories_missing_is_a_clear_error():
    with pytest.raises(A.MissingDataError, match="history_wall"):
        A.displacement_histories(single_storey(histories=False), 4.14, ("D1",), "christchurch")


def test_verification_histories_over_records(single):
    hist = A.verification_histories(single, "w08", cor=0.8)
    assert list(hist["record"].values) == ["nahanni"]
    assert_allclose(hist["crack_displacement"].isel(time=-1).values, [0.004])


def test_governing_instability_dims(single):
    ratio = A.governing_instability(single, cor=0.8)
    assert set(ratio.dims) == {"wall", "diaphragm", "record"}
    assert_allclose(ratio.sel(record="nahanni", diaphragm="D1").values, [0.5, 0.2, 0.35, 0.3])


def test_best_cor_nearest_and_nan_never_matches():
    da = xr.DataArray([np.nan, 7.0, 5.4, 4.0, 3.0], dims="cor",
                      coords={"cor": [0.7, 0.75, 0.8, 0.85, 0.9]}, name="collapse_time")
    out = A.best_cor(da, 5.3)
    assert_allclose(float(out["best_cor"]), 0.8)
    assert_allclose(float(out["misfit"]), 0.1 / 5.3)
    assert out["best_cor"].attrs["units"] == "1"


def test_cor_matches_uses_given_and_measured_targets(verif):
    m = A.cor_matches(verif, {"west": ("collapse_time", 5.3)})
    assert_allclose(m["best_cor"].sel(wall="west").values, [0.8, 0.8])
    # 0.01 + 0.1 (cor - 0.7) = 0.023 at cor 0.83, nearest grid 0.85 (0.025)
    assert_allclose(m["best_cor"].sel(wall="c9").values, [0.85, 0.85])
    assert np.isnan(m["best_cor"].sel(wall="wall12").values).all()
    assert "paper_best_cor" not in m.coords  # the paper's values are urmx.paper's
    assert np.isnan(A.cor_matches(verif)["best_cor"].sel(wall="west")).all()


def test_frequency_ranges_from_given_ranges_and_coords(multi):
    r = A.frequency_ranges(multi, RANGES)
    assert_allclose(r["frequency_low"].values, [0.2, 7.0, 0.2])
    assert_allclose(r["frequency_high"].values, [7.0, 9.0, 3.0])
    with pytest.raises(A.MissingDataError, match="no significant frequency ranges"):
        A.frequency_ranges(multi)
    ds = multi.assign_coords(frequency_low=("record", [1.0, 2.0, 3.0]),
                             frequency_high=("record", [4.0, 5.0, 6.0]))
    assert A.frequency_ranges(ds).attrs["frequency_range_source"] == "record coords"


def test_peak_in_patterns_takes_only_those_instants():
    t = np.arange(6.0)
    hist = xr.Dataset({"crack_displacement": ("time", [0.0, 0.01, -0.03, 0.02, 0.05, 0.0]),
                       "base_displacement": ("time", [0.0, 0.0, 0.0, 0.005, 0.0, 0.0]),
                       "pattern": ("time", [21, 11, 12, 11, 21, 22])}, {"time": t})
    assert_allclose(float(A.peak_in_patterns(hist, "lower_drift", (11, 12))), 0.03)
    assert_allclose(float(A.peak_in_patterns(hist, "crack_displacement", (21, 22))), 0.05)
    assert np.isnan(float(A.peak_in_patterns(hist, "crack_displacement", (99,))))


def test_no_paper_defaults_in_analysis():
    import inspect
    text = inspect.getsource(A)
    for word in ("christchurch", "nahanni", "elcentro", "4.14", "0.78", "0.83", "PAPER_"):
        assert word not in text.lower() if word.islower() else word not in text, word


def test_resonance(multi):
    res = A.resonance(multi, cor=0.8, ranges=RANGES)
    assert res["in_range"].dims == ("diaphragm", "record")
    assert res["in_range"].sel(record="christchurch").values.tolist() == [
        True, True, False, False]
    # D4 6.8 Hz below nahanni's 7 Hz: log10(7/6.8)
    assert_allclose(float(res["range_distance"].sel(diaphragm="D4", record="nahanni")),
                    np.log10(7 / 6.8))
    # christchurch mean ratio over walls: 0.5 - 0.1 d + mean wobble 0.0175; change vs D4
    assert_allclose(res["mean_instability_ratio"].sel(record="christchurch").values,
                    [0.5175, 0.4175, 0.3175, 0.2175])
    assert_allclose(res["stability_change"].sel(record="christchurch").values,
                    [0.3, 0.2, 0.1, 0.0], atol=1e-12)
    assert res.attrs["reference_diaphragm"] == "D4"
