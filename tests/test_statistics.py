"""Statistics that hold up in review (issue 38): record groups (the FEMA P695 stations) in
the manifest and in every resampling, the studentized and BCa intervals' parts, the cluster
bootstrap of the sufficiency slope, hazard curves in any measure (the OpenQuake engine's
``hazard_curve-*.csv``, ``sa(T)``), the deaggregation of a rate and its extrapolated share,
the pga / sa_avg comparison, the variance shares beside PRCC and the reports' provenance
line. The coverage of the intervals is `tests/test_fits.py`."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

import urmx
from urmx import fragility as F
from urmx.analysis import ida as FA
from urmx.catalog import catalog_dir
from urmx.cli import main
from urmx.errors import InputError
from urmx.fragility import fits
from urmx.fragility.risk import (
    HazardCurve,
    deaggregate,
    read_hazard,
    scaled_curve,
)
from urmx.records.readers import STANDARD_GRAVITY

from .helpers.ida_study import REP_IDA, stiff_kernel
from .helpers.ida_study import run as _run

OQ = Path(__file__).parent / "fixtures" / "openquake" / "hazard_curve-mean-PGA_27.csv"
HAZARD = catalog_dir() / "hazard" / "illustrative-pga-hazard.csv"
SPECTRUM = catalog_dir() / "hazard" / "illustrative-design-spectrum.csv"


# ---- record groups ---------------------------------------------------------------------------

def test_the_fema_records_come_in_20_station_groups_of_two():
    man = urmx.records.manifest()
    fema = {k: e for k, e in man.items() if e["set"] == "fema-p695-far-field"}
    groups = {}
    for rid, e in fema.items():
        groups.setdefault(e["group"], []).append(rid)
    assert len(fema) == 40 and len(groups) == 20
    for g, ids in groups.items():
        assert len(ids) == 2 and all(i.startswith(g + "-") for i in ids)
        assert len({fema[i]["station"] for i in ids}) == 1  # one station, two components
    ds = xr.Dataset(coords={"record": sorted(fema)})
    got = FA.record_groups(ds)
    assert [g for g in got] == [fema[r]["group"] for r in sorted(fema)]
    assert "20 groups of 40 records" in FA.grouping_sentence(got)
    assert FA.record_groups(xr.Dataset(coords={"record": ["no-such-record"]})) is None


def test_a_bad_group_is_refused_naming_the_record(tmp_path):
    text = Path(urmx.records.manifest.__module__.replace(".", "/")).name  # noqa: F841
    src = tmp_path / "m.toml"
    src.write_text('[[record]]\nid = "a"\nset = "s"\ngroup = 3\nevent = "e"\nfile = "f"\n'
                   'format = "columns"\ndt = 0.01\nunit = "g"\nsha256 = "' + "0" * 64 + '"\n'
                   'expected_pga_g = 0.1\nscale_factor = 1.0\nsource = "s"\nnotes = ""\n')
    with pytest.raises(urmx.records.ManifestError, match="record a: group must be a "
                                                         "non-empty string"):
        urmx.records.manifest(path=src)


def test_resampling_stations_widens_the_intervals_of_copied_components():
    """Twenty stations whose two components are identical: resampled as 40 independent
    records the intervals are too narrow by about sqrt 2; resampled by station they are
    those of the 20 distinct values."""
    rng = np.random.default_rng(3)
    x20 = np.exp(0.4 * rng.standard_normal(20))
    x = np.repeat(x20, 2)
    g = np.repeat([f"st{i}" for i in range(20)], 2)
    by_record = F.fit_lognormal(x)
    by_station = F.fit_lognormal(x, groups=g)
    alone = F.fit_lognormal(x20)
    assert by_station.groups == 20 and by_record.groups == 0
    assert by_station.median == by_record.median
    w = [math.log(f.median_ci[1] / f.median_ci[0]) for f in (by_record, by_station, alone)]
    assert 1.3 < w[1] / w[0] < 1.8  # about sqrt 2, and the t* quantiles of 20 not 40
    assert w[1] / w[2] == pytest.approx(1.0, abs=0.15)


def test_the_cluster_bootstrap_p_value_counts_stations_not_records():
    """A slope fitted to pairs of identical points: the t-test counts 40 points and its
    p-value falls; the cluster bootstrap-t resamples the 20 stations and gives exactly the
    p-value of the 20 distinct points (copies of a group add no information)."""
    from scipy.stats import linregress

    rng = np.random.default_rng(4)
    x20 = rng.uniform(6, 7.5, 20)
    y20 = 0.05 * (x20 - 6.75) + 0.3 * rng.standard_normal(20)
    x, y = np.repeat(x20, 2), np.repeat(y20, 2)
    g = np.repeat(np.arange(20), 2)
    assert linregress(x, y).pvalue < 0.2 * linregress(x20, y20).pvalue
    p_g = FA.group_slope_p(x, y, g)
    assert p_g == FA.group_slope_p(x20, y20, np.arange(20))
    assert 0.005 < p_g < 0.2
    # the studentized slope is the least-squares one, its se the robust (HC0) form
    b, se = FA._slopes(x20, y20, np.ones((1, 20)), np.eye(20))
    r = linregress(x20, y20)
    xc = x20 - x20.mean()
    e = y20 - y20.mean() - r.slope * xc
    assert b[0] == pytest.approx(r.slope, rel=1e-12)
    assert se[0] == pytest.approx(math.sqrt(np.sum(xc ** 2 * e ** 2)) / np.sum(xc ** 2),
                                  rel=1e-12)


# ---- the intervals' parts --------------------------------------------------------------------

def test_the_sandwich_of_an_uncensored_sample_is_its_moments():
    """Uncensored: var(ln median) = s^2 / n (1/n variance s^2, so se = beta / sqrt n) and
    var(ln beta) = (m4 / s^4 - 1) / (4 n) (the delta method on the variance's sandwich)."""
    rng = np.random.default_rng(1)
    y = rng.standard_normal(30) * 0.5 + 1.0
    n = y.size
    cen = np.zeros(n, bool)
    m, b = fits._lognormal_mle(y, cen, np.ones((1, n)))
    cov = fits.sandwich_cov(y, cen, np.ones((1, n)), m, b)[0]
    s2 = np.var(y)
    m4 = np.mean((y - y.mean()) ** 4)
    assert cov[0, 0] == pytest.approx(s2 / n, rel=1e-8)
    assert cov[1, 1] == pytest.approx((m4 / s2 ** 2 - 1) / (4 * n), rel=1e-8)
    # one group per record is the per-record form
    grouped = fits.sandwich_cov(y, cen, np.ones((1, n)), m, b, np.arange(n))[0]
    np.testing.assert_allclose(grouped, cov, rtol=1e-10)


def test_bca_without_bias_or_skew_is_the_percentile_interval():
    boot = np.linspace(-1, 1, 2001)
    jack = np.linspace(-1, 1, 21)  # symmetric: acceleration 0
    lo, hi = fits.bca_interval(0.0, boot, jack, 0.9)
    assert (lo, hi) == pytest.approx((np.quantile(boot, 0.05), np.quantile(boot, 0.95)))
    # an estimate above most replicates (biased low replicates): the interval moves up
    lo2, hi2 = fits.bca_interval(0.5, boot, jack, 0.9)
    assert lo2 > lo and hi2 > hi


def test_the_unbiased_option_is_the_n_minus_1_standard_deviation():
    x = np.exp(np.random.default_rng(2).standard_normal(12) * 0.3)
    f = F.fit_lognormal(x, unbiased=True, resamples=200)
    assert f.dispersion == pytest.approx(np.std(np.log(x), ddof=1), rel=1e-10)
    plain = F.fit_lognormal(x, resamples=200)
    k = math.sqrt(12 / 11)
    assert f.dispersion_ci == pytest.approx(tuple(v * k for v in plain.dispersion_ci))
    with pytest.raises(InputError, match="interval='t'"):
        F.fit_lognormal(x, interval="t")


# ---- hazard curves in any measure ------------------------------------------------------------

def test_an_openquake_hazard_curve_is_read_as_the_engine_writes_it():
    """The engine's per-IMT layout: probabilities of exceedance in 50 years become annual
    rates; levels at probability 1 are left out; the last level is the last computed."""
    c = read_hazard(OQ)
    lines = OQ.read_text().splitlines()
    levels = np.array([float(h[4:]) for h in lines[1].split(",")[3:]])
    poe = np.array([float(v) for v in lines[2].split(",")[3:]])
    keep = poe < 1
    assert c.im == "pga" and c.units == "m s-2"
    np.testing.assert_allclose(c.intensity, levels[keep] * STANDARD_GRAVITY)
    np.testing.assert_allclose(c.rate, -np.log1p(-poe[keep]) / 50.0, rtol=1e-12)
    assert c.computed_to == pytest.approx(2.13 * STANDARD_GRAVITY)
    # the file was made from 1.13e-4 PGA^-2.61 (g): the rates within its 7 digits
    mid = (c.intensity / STANDARD_GRAVITY > 0.1)
    np.testing.assert_allclose(c.rate[mid], 1.13e-4 * (c.intensity[mid] / STANDARD_GRAVITY)
                               ** -2.61, rtol=1e-4)
    other = read_hazard(OQ, site=1)
    assert other.rate[-1] < c.rate[-1]
    with pytest.raises(InputError, match="site 2 is not a row"):
        read_hazard(OQ, site=2)


@pytest.mark.parametrize("imt, im, factor", [("SA(0.3)", "sa(0.3)", STANDARD_GRAVITY),
                                             ("AvgSA", "sa_avg", STANDARD_GRAVITY),
                                             ("PGV", "pgv", 0.01)])
def test_openquake_measures(tmp_path, imt, im, factor):
    path = tmp_path / f"hazard_curve-mean-{imt}_3.csv"
    path.write_text(OQ.read_text().replace("imt='PGA'", f"imt='{imt}'"))
    c = read_hazard(path)
    assert c.im == im
    assert c.intensity[-1] == pytest.approx(2.13 * factor)


def test_bad_openquake_files_are_refused_in_one_line(tmp_path):
    path = tmp_path / "hazard_curve-mean-X_1.csv"
    path.write_text(OQ.read_text().replace("imt='PGA'", "imt='MMI'"))
    with pytest.raises(InputError, match="imt 'MMI' is not one urmx computes"):
        read_hazard(path)
    path.write_text(OQ.read_text().replace("poe-", "p-"))
    with pytest.raises(InputError, match="poe-<level> columns"):
        read_hazard(path)


def test_a_plain_curve_states_its_last_computed_intensity():
    c = read_hazard(HAZARD)
    assert c.computed_to == pytest.approx(0.6 * STANDARD_GRAVITY)
    c2 = read_hazard(Path(__file__).parent.parent / "catalog" / "hazard"
                     / "illustrative-pga-hazard.csv")
    assert c2.computed_to == c.computed_to


def test_sa_at_a_period_is_a_measure_of_a_curve(tmp_path):
    path = tmp_path / "sa.csv"
    path.write_text("sa(0.30) [g],annual_rate [1/yr]\n0.1,0.01\n1,0.0001\n")
    c = read_hazard(path)
    assert c.im == "sa(0.3)" and c.units == "m s-2" and c.computed_to is None
    path.write_text("sa(x) [g],annual_rate [1/yr]\n0.1,0.01\n1,0.0001\n")
    with pytest.raises(InputError):
        read_hazard(path)


def test_the_deaggregation_is_the_hazard_integral_band_by_band():
    """Against scipy's quadrature of P(C | x) |d lambda / dx| over a power law: the share
    beyond a point and the bands; the shares add to 1."""
    from scipy.integrate import quad
    from scipy.stats import norm

    k0, k, med, beta = 1.13e-4, 2.61, 0.5, 0.4
    x = np.geomspace(0.05, 2.5, 17)
    curve = HazardCurve(x, k0 * x ** -k, "pga", "g", "arrays", 0.6)

    def dens(a):
        return norm.cdf(math.log(a / med) / beta) * k * k0 * a ** (-k - 1)

    total = quad(dens, 1e-6, 50, points=[0.1, 0.5, 1, 2], limit=200)[0]
    beyond = quad(dens, 0.6, 50, points=[1, 2], limit=200)[0]
    bands, extrapolated = deaggregate(curve, med, beta)
    assert extrapolated == pytest.approx(beyond / total, rel=2e-3)
    assert sum(s for _, _, s in bands) == pytest.approx(1.0, abs=1e-9)
    lo, hi, share = bands[2]  # 500-2500 years
    assert lo == pytest.approx((k0 * 500) ** (1 / k), rel=1e-9)
    assert share == pytest.approx(quad(dens, lo, hi)[0] / total, rel=2e-3)
    r = F.collapse_rate(fits.LognormalFit(med, beta, 40, im="pga", units="g"), curve)
    assert r.extrapolated_share == extrapolated and r.bands == bands


def test_a_fragility_in_another_measure_is_refused_in_one_line(capsys):
    fit = fits.LognormalFit(5.0, 0.4, 40, im="sa_avg", units="m s-2")
    with pytest.raises(InputError, match="hazard curve is in pga .* fragility in sa_avg"):
        F.collapse_rate(fit, OQ)
    assert main(["risk", "--median", "0.5", "--dispersion", "0.4", "--im", "sa(0.3)",
                 "--hazard", str(OQ)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "must be the same measure" in err
    assert main(["risk", "--median", "0.5", "--dispersion", "0.4", "--im", "pga",
                 "--hazard", str(OQ)]) == 0
    out = capsys.readouterr().out
    r = F.collapse_rate(fits.LognormalFit(0.5 * STANDARD_GRAVITY, 0.4, 40, im="pga",
                                          units="m s-2"), OQ)
    assert f"{r.rate:.3g} per year" in out and "| intensity band [g] |" in out
    assert f"{100 * r.extrapolated_share:.3g} %" in out


def test_urmx_risk_reads_an_openquake_curve_for_an_archive(ida_records, make_study,
                                                           tmp_path, capsys):
    ds = _run(make_study, REP_IDA, "rep.toml", kernel=stiff_kernel)
    archive = tmp_path / "rep.nc"
    urmx.netcdf.write_netcdf(ds, archive)
    assert main(["risk", str(archive), "--hazard", str(OQ)]) == 0
    out = capsys.readouterr().out
    assert "## Where the rate comes from" in out
    assert "marks 2.13 g as the last computed intensity" in out
    risk = FA.collapse_risk(ds, OQ, resamples=0)
    c = risk.sel(wall="s16", diaphragm="D1")
    assert f"| D1 | s16 | {float(c.rate):.2g} |" in out
    assert float(c.band_share.sum()) == pytest.approx(1.0, abs=1e-9)


def test_the_sa_avg_curve_is_the_pga_curve_scaled_by_the_spectrum_shape(ida_records,
                                                                        make_study):
    """NZS 1170.5 scales every ordinate by R: the sa_avg curve's intensity at a return
    period is the spectrum's geometric mean over the periods over its PGA times the PGA
    curve's. The ratio of the two rates is exactly shape x spread over a power law."""
    from urmx.reports.ida_risk import im_comparison, risk_numbers, sa_avg_factor

    ds = _run(make_study, REP_IDA, "rep.toml", kernel=stiff_kernel)
    f = sa_avg_factor(ds, SPECTRUM)
    d = FA.first_cor(ds)
    tr = float(d.rocking_period.sel(wall="s16", diaphragm="D1"))
    td = 1 / float(d.cell_frequency.sel(wall="s16", diaphragm="D1"))
    periods = np.geomspace(max(min(td, tr) / math.sqrt(2), tr / 2), math.sqrt(2) * max(td, tr),
                           10)
    want = math.exp(np.mean(np.log(F.design_sa(SPECTRUM, periods)))) / (0.336 * STANDARD_GRAVITY)
    assert float(f.sel(wall="s16", diaphragm="D1")) == pytest.approx(want, rel=1e-12)
    c = read_hazard(HAZARD)
    s = scaled_curve(c, 2.0, "sa_avg")
    np.testing.assert_allclose(s.intensity, 2 * c.intensity)
    assert s.computed_to == 2 * c.computed_to and s.im == "sa_avg"
    power = HazardCurve(np.geomspace(0.01, 500, 40), 1e-3 * np.geomspace(0.01, 500, 40) ** -2.4,
                        "pga", "m s-2", "power law")
    r = risk_numbers(ds, power, SPECTRUM, 50.0)
    cmp = im_comparison(ds, r, SPECTRUM)
    np.testing.assert_allclose(cmp.ratio, cmp.shape * cmp.spread, rtol=5e-3)


# ---- provenance and variance shares ------------------------------------------------------------

def test_a_report_says_when_its_archive_has_another_kernel():
    from urmx.jitcache import SOURCE_HASH
    from urmx.reports.common import made_from

    same = xr.Dataset(attrs={"urmx_git_commit": "a" * 40, "urmx_git_dirty": 0,
                             "kernel_source_hash": SOURCE_HASH})
    assert made_from(same) == (f"The archive was made at commit `{'a' * 12}`, kernel source "
                               f"hash `{SOURCE_HASH[:16]}`; the current kernel is the same.")
    other = same.assign_attrs(kernel_source_hash="0" * 16, urmx_git_dirty=1)
    text = made_from(other)
    assert "with local changes" in text and "**the current kernel differs**" in text
    assert "not known" in made_from(xr.Dataset())


def test_variance_shares_of_a_linear_model_and_their_rank_fallback():
    from urmx.uncertainty import variance_shares

    rng = np.random.default_rng(0)
    n = 200
    x = (np.argsort(rng.random((n, 3)), axis=0) + rng.random((n, 3))) / n  # a Latin hypercube
    y = 3 * x[:, 0] + 1 * x[:, 1] + 0.1 * rng.standard_normal(n)
    r = variance_shares(x, y)
    total = 9 / 12 + 1 / 12 + 0.01
    assert not r["ranks"] and r["r2"] == pytest.approx((total - 0.01) / total, abs=0.01)
    np.testing.assert_allclose(r["share"][:2], [0.75 / total, (1 / 12) / total], atol=0.02)
    assert r["share"].sum() == pytest.approx(r["r2"], abs=0.02)
    assert np.all(r["share_low"] <= r["share"]) and np.all(r["share"] <= r["share_high"])
    assert r["rank_held"][0] == 1.0
    # monotone but far from linear: the values' model explains little, the ranks' more
    z = np.exp(12 * x[:, 0]) + 0.05 * np.exp(12 * x[:, 1])
    rz = variance_shares(x, z)
    assert rz["r2"] < 0.7 and rz["ranks"] and rz["r2_ranks"] > rz["r2"]


def test_capacities_in_sa_at_a_period_come_from_the_records(ida_records,
                                                            make_study):
    """sa(T): the scale factor at collapse times the record's 5 %-damped Sa at T as
    analysed (its scale factor: 2 on "shake"); a measure urmx cannot compute is refused."""
    from urmx.records.measures import pseudo_spectral_acceleration

    from .helpers.ida_study import ACC

    ds = _run(make_study, REP_IDA, "rep.toml", kernel=stiff_kernel)
    cap = FA.capacities(ds, "sa(0.30)")
    for rid in ACC:
        acc = ACC[rid] * (2.0 if rid == "shake" else 1.0)
        unit = float(pseudo_spectral_acceleration(acc, 0.01, np.array([0.3]), 0.05)[0])
        np.testing.assert_allclose(cap.sel(record=rid), ds.collapse_scale.sel(record=rid)
                                   * unit, rtol=1e-12)
    assert cap.attrs["units"] == "m s-2"


def test_urmx_risk_needs_an_archive_or_a_whole_fragility(capsys):
    assert main(["risk", "--hazard", str(OQ), "--median", "0.5"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--median, --dispersion and --im" in err
