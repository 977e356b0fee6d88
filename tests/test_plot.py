"""Each plot function draws the expected panels and lines (cheap artist checks)."""

import numpy as np
import pytest
from matplotlib.figure import Figure

from urmx import plot as P
from urmx.analysis import grid as A

RANGES = {"elcentro": (0.2, 7.0), "nahanni": (7.0, 9.0), "christchurch": (0.2, 3.0)}


def test_label_from_attrs(single):
    assert P.label(single["peak_top_acceleration"]) == (
        "peak absolute acceleration at wall top [m s-2]")


def test_peak_profiles_two_panels_one_line_per_diaphragm(single):
    axes = P.plot_peak_profiles(A.peak_profiles(single, "acceleration", "christchurch", cor=0.8))
    assert len(axes) == 2 and axes[0].figure is axes[1].figure
    for ax in axes:
        # a diaphragm's legend entry carries its frequency (rigid: "pinned")
        assert [ln.get_label() for ln in ax.get_lines()] == ["D1 (1 Hz)", "D3 (5 Hz)",
                                                             "D5 (pinned)"]
        assert ax.get_xlabel() == "slenderness h/t [1]"
    assert axes[0].get_ylabel() == "peak absolute acceleration at wall top [m s-2]"
    np.testing.assert_allclose(axes[0].get_lines()[0].get_xdata(), [8, 12, 18, 24])
    np.testing.assert_allclose(axes[0].get_lines()[1].get_ydata(), [5.0, 5.2, 5.4, 5.6])


def test_plot_vs_slenderness_draws_on_given_ax(single):
    ax = Figure().subplots()
    out = P.plot_vs_slenderness(A.governing_instability(single).sel(record="nahanni"), ax=ax)
    assert out is ax and len(ax.get_lines()) == 3


def test_stability_one_panel_per_record(single):
    axes = P.plot_stability(A.governing_instability(single))
    assert [ax.get_title() for ax in axes] == ["(a) elcentro", "(b) nahanni",
                                               "(c) christchurch"]
    # three diaphragm lines plus the ratio-1 reference line
    assert all(len(ax.get_lines()) == 4 for ax in axes)
    np.testing.assert_allclose(axes[1].get_lines()[0].get_ydata(), [0.5, 0.2, 0.35, 0.3])


def test_histories_panels_and_lines(single):
    axes = P.plot_histories(A.displacement_histories(single, 4.14, ("D1", "D5"), "christchurch"))
    assert len(axes) == 2  # top and crack displacement, pattern not drawn
    assert [ln.get_label() for ln in axes[0].get_lines()] == ["diaphragm D1", "diaphragm D5"]
    assert axes[1].get_ylabel() == "displacement at crack height [m]"
    assert axes[0].get_xlabel() == "time [s]"


def test_given_axes_too_few_is_an_error(single):
    with pytest.raises(ValueError, match="needs 2 axes"):
        P.plot_peak_profiles(A.peak_profiles(single, "acceleration", "christchurch"),
                             axes=[Figure().subplots()])


def test_resonance_bands_and_markers(multi):
    res = A.resonance(multi, ranges=RANGES)
    ax = P.plot_resonance(res)
    assert len(ax.collections) == 6  # a band and a marker set per record
    offsets = ax.collections[1].get_offsets()
    np.testing.assert_allclose(offsets[:, 0], [1.0, 1.6, 5.0, 6.8])
    assert ax.get_xscale() == "log"
    assert [t.get_text() for t in ax.get_yticklabels()] == ["elcentro", "nahanni",
                                                            "christchurch"]


def test_resonance_places_rigid_diaphragm_at_right_edge(single):
    ax = P.plot_resonance(A.resonance(single, ranges=RANGES))
    x = ax.collections[1].get_offsets()[:, 0]
    assert np.isfinite(x).all() and x[-1] > x[:-1].max()


def test_cor_match_lines_target_and_paper_cor(verif):
    ds = verif
    da = A.select(ds["collapse_time"].sel(wall="west"), keep=("record", "cor"))
    da = da.squeeze("diaphragm", drop=True).reset_coords(drop=True)
    ax = P.plot_cor_match(da, target=5.3, paper_cor=0.83)
    labels = [ln.get_label() for ln in ax.get_lines()]
    assert labels == ["nahanni", "elcentro", "target", "paper's COR"]
    assert ax.get_xlabel() == "coefficient of restitution [1]"
