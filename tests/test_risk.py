"""From fragility to decisions (issue 26): collapse risk at a site (the integral against the
closed form of Cornell et al. 2002, hazard curve and design spectrum files), every intensity
measure from one IDA run (the archive's scale factors at collapse and records' measures),
efficiency and sufficiency, and ``urmx risk``."""

from __future__ import annotations

import math

import numpy as np
import pytest
import xarray as xr

import urmx
from urmx import fragility as F
from urmx.analysis import ida as FA
from urmx.catalog import catalog_dir
from urmx.cli import main
from urmx.errors import InputError, MissingFileError
from urmx.records.readers import STANDARD_GRAVITY

from .helpers.ida_study import ACC, IDA_STUDY, REP_IDA, stiff_kernel
from .helpers.ida_study import run as _run

HAZARD = catalog_dir() / "hazard" / "illustrative-pga-hazard.csv"
SPECTRUM = catalog_dir() / "hazard" / "illustrative-design-spectrum.csv"


def cornell(k0, k, median, beta):
    """Cornell et al. (2002): the mean annual frequency of collapse of a lognormal fragility
    over the power-law hazard k0 x^-k."""
    return k0 * median ** -k * math.exp(k * k * beta * beta / 2)


# ---- the risk integral ---------------------------------------------------------------------------

@pytest.mark.parametrize("median, beta, k", [(5.0, 0.4, 2.6), (2.0, 0.2, 3.5),
                                             (9.0, 0.6, 1.8), (0.3, 0.15, 2.2)])
def test_collapse_rate_matches_the_closed_form_for_a_power_law(median, beta, k):
    """Within 0.5 % (the integral is good to ~1e-9 here), a hazard curve that spans the
    fragility or one that ends inside it (extended along its end segments, reported)."""
    k0 = 2e-4
    x = np.geomspace(median / 50, median * 50, 30)
    risk = F.collapse_rate(F.LognormalFit(median, beta, 40), (x, k0 * x ** -k), years=50)
    exact = cornell(k0, k, median, beta)
    assert risk.rate == pytest.approx(exact, rel=0.005)
    assert risk.probability == pytest.approx(1 - math.exp(-50 * exact), rel=0.005)
    assert risk.years == 50 and risk.tail_share < 1e-6
    short = np.geomspace(median / 1.5, median * 1.5, 5)
    part = F.collapse_rate(F.LognormalFit(median, beta, 40), (short, k0 * short ** -k))
    assert part.rate == pytest.approx(exact, rel=0.005)
    assert 0.0 < part.tail_share < 1.0


def test_collapse_rate_of_a_csv_curve_in_g(tmp_path):
    """A curve in g against a fit in m s-2 (standard gravity), and the measure checked."""
    k0, k = 1e-4, 2.5
    x_g = np.geomspace(0.02, 10.0, 40)
    path = tmp_path / "curve.csv"
    path.write_text("# a power law\npga [g],annual_rate [1/yr]\n"
                    + "".join(f"{float(a)!r},{float(k0 * a ** -k)!r}\n" for a in x_g))
    fit = F.LognormalFit(0.5 * STANDARD_GRAVITY, 0.35, 40, im="pga", units="m s-2")
    risk = F.collapse_rate(fit, path, years=30)
    assert risk.rate == pytest.approx(cornell(k0, k, 0.5, 0.35), rel=0.005)
    assert risk.im == "pga" and risk.years == 30
    # the same curve, a fit in another measure: refused
    with pytest.raises(InputError, match=r"hazard curve is in pga \[m s-2\], the fragility in "
                                         r"sa_avg"):
        F.collapse_rate(F.LognormalFit(5.0, 0.3, 40, im="sa_avg", units="m s-2"), path)
    # a fit that states no measure takes the curve's
    assert F.collapse_rate(F.LognormalFit(0.5 * STANDARD_GRAVITY, 0.35, 40), path).rate == \
        pytest.approx(risk.rate, rel=1e-12)


@pytest.mark.parametrize("text, match", [
    ("0.1,0.01\n0.2,0.001\n", "header must name each column and its units"),
    ("pga,annual_rate\n0.1,0.01\n0.2,0.001\n", "header must name each column"),
    ("pgx [g],annual_rate [1/yr]\n0.1,0.01\n0.2,0.001\n", "must be an intensity measure"),
    ("pgv [g],annual_rate [1/yr]\n0.1,0.01\n0.2,0.001\n", "units 'g' of 'pgv': use 'm s-1'"),
    ("pga [g],annual_rate [%]\n0.1,0.01\n0.2,0.001\n", "in '1/yr'"),
    ("pga [g],annual_rate [1/yr]\n0.1,0.01\n0.1,0.001\n", r"curve.csv:3: intensity must rise"),
    ("pga [g],annual_rate [1/yr]\n0.1,0.01\n0.2,0.02\n", r"curve.csv:3: annual rate must fall"),
    ("pga [g],annual_rate [1/yr]\n0.1,0.01\n0.2,x\n", r"curve.csv:3: '0.2,x' is not two"),
    ("pga [g],annual_rate [1/yr]\n0.1,0.01\n", "at least two rows"),
    ("pga [g],annual_rate [1/yr]\n-0.1,0.01\n0.2,0.001\n", "must be positive"),
])
def test_bad_hazard_curves_are_refused_by_file_and_line(tmp_path, text, match):
    path = tmp_path / "curve.csv"
    path.write_text(text)
    with pytest.raises(InputError, match=match):
        F.collapse_rate(F.LognormalFit(1.0, 0.3, 10), path)


def test_bad_risk_arguments():
    fit = F.LognormalFit(1.0, 0.3, 10)
    x = np.array([0.5, 1.0, 2.0])
    with pytest.raises(InputError, match="years=0"):
        F.collapse_rate(fit, (x, 1e-3 * x ** -2), years=0)
    with pytest.raises(InputError, match="same length"):
        F.collapse_rate(fit, (x, [1e-3, 1e-4]))
    with pytest.raises(InputError, match="must be a CSV file or a pair"):
        F.collapse_rate(fit, 3.0)
    with pytest.raises(MissingFileError, match="does not exist"):
        F.collapse_rate(fit, "no-such-curve.csv")
    with pytest.raises(InputError, match="positive median and dispersion"):
        F.collapse_rate(F.LognormalFit(math.nan, 0.3, 10), (x, 1e-3 * x ** -2))


def test_the_catalog_site_is_what_its_header_says():
    """The illustrative hazard curve is k0 PGA^-k with k0 = 1.13e-4 and k = 2.61 (PGA in g),
    within 0.3 % of the NZS 1170.5 class D, Z = 0.3 PGA (1.12 Z R g) at 500 years; the
    design spectrum is Ch(T) Z R g for class D, Z = 0.3, R = 1."""
    curve = F.read_hazard(HAZARD)
    pga_g = curve.intensity / STANDARD_GRAVITY
    np.testing.assert_allclose(curve.rate, 1.13e-4 * pga_g ** -2.61, rtol=1e-5)
    assert curve.im == "pga" and curve.units == "m s-2"
    assert 1.13e-4 * (1.12 * 0.3) ** -2.61 == pytest.approx(1 / 500, rel=0.03)
    spec = F.read_spectrum(SPECTRUM)
    g = STANDARD_GRAVITY
    for t, ch in ((0.0, 1.12), (0.3, 3.0), (1.0, 2.4 * 0.75 ** 0.75), (2.0, 2.14 / 2.0),
                  (4.0, 6.42 / 16.0)):
        assert float(F.design_sa(spec, t)) == pytest.approx(ch * 0.3 * g, rel=2e-4)
    assert float(F.design_sa(spec, 0.8)) == pytest.approx(2.4 * (0.75 / 0.8) ** 0.75 * 0.3 * g,
                                                          rel=2e-3)
    with pytest.raises(InputError, match="period 6.0 s is outside the design spectrum"):
        F.design_sa(spec, 6.0)


def test_bad_design_spectra(tmp_path):
    path = tmp_path / "spec.csv"
    path.write_text("period [s],psa [g]\n0,0.3\n1,0.5\n")
    with pytest.raises(InputError, match="header must be 'period \\[s\\],sa \\[g\\]'"):
        F.read_spectrum(path)
    path.write_text("period [s],sa [g]\n0,0.3\n0,0.5\n")
    with pytest.raises(InputError, match="spec.csv:3: periods must be >= 0 and rise"):
        F.read_spectrum(path)
    path.write_text("period [s],sa [m s-2]\n0,3\n1,0\n")
    with pytest.raises(InputError, match="spec.csv:3: sa 0.0 must be positive"):
        F.read_spectrum(path)


# ---- every measure from one IDA run ---------------------------------------------------------

def test_one_ida_run_gives_the_capacities_in_every_measure(ida_records, make_study):
    """The archive holds the scale factor at collapse and each record's intensity in every
    measure; a run in pga and a run in sa_avg give the same capacities in sa_avg (the search
    runs on scale factors): to 1e-12 for the first wall of each chain (a cold start in both
    runs), within the bracket's rtol for the wall after it, whose warm start comes from the
    first wall's capacity, censored at another intensity in either run
    (`urmx.fragility.capacity`, "Warm start")."""
    in_pga = _run(make_study, IDA_STUDY, "pga.toml")
    np.testing.assert_allclose(in_pga.collapse_scale,
                               in_pga.collapse_intensity / in_pga.record_intensity, rtol=1e-15)
    assert in_pga.record_pga.dims == ("record",)
    assert in_pga.record_sa_avg.dims == ("wall", "diaphragm", "record")
    np.testing.assert_allclose(in_pga.record_pga, in_pga.record_intensity.isel(
        wall=0, diaphragm=0))
    spec = urmx.study.load_study(make_study(IDA_STUDY, "again.toml"))
    wall = spec.wall(spec.walls[1], spec.diaphragms[0])
    for rid in ACC:  # the record as analysed: scale factor 2 on "shake"
        acc = ACC[rid] * (2.0 if rid == "shake" else 1.0)
        for im in ("pgv", "sa_avg"):
            v = in_pga[f"record_{im}"].sel(record=rid)
            v = v.isel(wall=1, diaphragm=0) if v.ndim else v
            assert float(v) == pytest.approx(F.record_intensity((acc, 0.01), im, wall),
                                             rel=1e-12)
    in_avg = _run(make_study, IDA_STUDY.replace('im = "pga"', 'im = "sa_avg"').replace(
        "max_intensity = 4.5", "max_intensity = 40.0"), "avg.toml")
    assert in_avg.attrs["intensity_measure"] == "sa_avg"
    assert in_avg.collapse_intensity.attrs["units"] == "m s-2"
    collapsed = (in_pga.censored == 0) & (in_avg.censored == 0)
    first = dict(wall=in_pga.wall.values[0])  # the chains' first wall: cold in both runs
    np.testing.assert_allclose(FA.capacities(in_pga, "sa_avg").where(collapsed).sel(first),
                               in_avg.collapse_intensity.where(collapsed).sel(first),
                               rtol=1e-12)
    np.testing.assert_allclose(FA.capacities(in_pga, "sa_avg").where(collapsed),
                               in_avg.collapse_intensity.where(collapsed), rtol=2e-3)
    assert int(collapsed.sum()) >= 8  # 10 of 16: the pga run censors 6 at 4.5 m s-2
    # the archive's intervals: NaN with two records (too few to resample)
    assert np.isnan(in_pga.median_collapse_intensity_lower).all()
    assert in_pga.attrs["confidence_level"] == 0.9


def test_sa_avg_range_in_a_study_file(ida_records, make_study):
    ds = _run(make_study, IDA_STUDY.replace('im = "pga"', 'im = "sa_avg"\nsa_avg_range = '
                                            '[0.2, 1.5]').replace("max_intensity = 4.5",
                                                                  "max_intensity = 40.0"),
              "rng.toml")
    np.testing.assert_allclose(ds.sa_avg_period_low, 0.2)
    np.testing.assert_allclose(ds.sa_avg_period_high, 1.5)
    acc = ACC["quake"]
    assert float(ds.record_intensity.sel(record="quake").isel(wall=0, diaphragm=0)) == \
        pytest.approx(F.record_intensity((acc, 0.01), "sa_avg", period_range=(0.2, 1.5)),
                      rel=1e-12)
    bad = make_study(IDA_STUDY.replace('im = "pga"', 'im = "pga"\nsa_avg_range = [1.5, 0.2]'),
                     "bad.toml")
    with pytest.raises(ValueError, match=r"bad.toml:\d+: study.ida.sa_avg_range: .*0 < low"):
        urmx.study.load_study(bad)


def test_efficiency_and_risk_of_a_stand_in_archive(ida_records, make_study, tmp_path):
    """With two records and a kernel that collapses at a PGA threshold, the dispersion in
    pga is half the log-ratio of the thresholds; the rate of collapse is the closed form of
    the fit over a power-law curve; stiffening D1 -> D4 raises every median 1.478 times,
    so the rate falls by 1.478^-k exp(0) (same dispersion)."""
    ds = _run(make_study, REP_IDA, "rep.toml", kernel=stiff_kernel)
    eff = FA.efficiency(ds)
    np.testing.assert_allclose(eff.dispersion.sel(measure="pga").transpose("wall", "diaphragm"),
                               FA.first_cor(ds).dispersion.transpose("wall", "diaphragm"),
                               rtol=1e-9)
    assert set(eff.best.values) <= set(FA.MEASURES)
    k0, k = 1e-3, 2.4
    x = np.geomspace(0.1, 100.0, 30)
    curve = tmp_path / "curve.csv"
    curve.write_text("pga [m s-2],annual_rate [1/yr]\n" + "".join(
        f"{float(a)!r},{float(k0 * a ** -k)!r}\n" for a in x))
    risk = FA.collapse_risk(ds, curve, years=50, resamples=0)
    d = FA.first_cor(ds)
    for w in ("s08", "s24"):
        c = d.sel(wall=w, diaphragm="D1")
        assert float(risk.rate.sel(wall=w, diaphragm="D1")) == pytest.approx(
            cornell(k0, k, float(c.median_collapse_intensity), float(c.dispersion)), rel=0.005)
    change = FA.risk_change(risk)
    ratio = (40360e3 / 815e3) ** 0.1
    np.testing.assert_allclose(change["top"]["ratio"], ratio ** -k, rtol=0.005)
    np.testing.assert_allclose(change["both"]["ratio"], ratio ** -k, rtol=0.005)
    mg = FA.margins(ds, SPECTRUM)
    assert float(mg.margin.sel(wall="s16", diaphragm="D1")) == pytest.approx(
        float(FA.fits_in(ds, "sa_wall", 0).median_collapse_intensity.sel(
            wall="s16", diaphragm="D1"))
        / float(F.design_sa(SPECTRUM, float(d.rocking_period.sel(wall="s16",
                                                                   diaphragm="D1")))),
        rel=1e-12)
    # a hazard curve in a measure the fits are made in: refitted from the scale factors
    avg = tmp_path / "avg.csv"
    avg.write_text(curve.read_text().replace("pga [m s-2]", "sa_avg [m s-2]"))
    assert FA.collapse_risk(ds, avg, resamples=0).attrs["im"] == "sa_avg"


def test_sufficiency_finds_a_trend_with_magnitude():
    """Capacities in pga that rise with magnitude (0.4 per unit) and carry no trend in the
    other measures: the regression finds the slope and a small p-value only for pga."""
    rng = np.random.default_rng(2)
    n = 40
    mag = rng.uniform(6.0, 7.6, n)
    dist = rng.uniform(5.0, 30.0, n)
    noise = 0.1 * rng.standard_normal(n)
    pga = np.exp(0.3 * rng.standard_normal(n))  # each record's PGA at scale 1
    scale = np.exp(0.4 * (mag - 7) + noise) / pga  # capacity in pga ~ exp(0.4 M)
    other = 1.0 / scale * np.exp(0.1 * rng.standard_normal(n))  # no trend
    ds = xr.Dataset(
        {"collapse_scale": (("wall", "diaphragm", "record", "cor"), scale[None, None, :, None]),
         "censored": (("wall", "diaphragm", "record", "cor"), np.zeros((1, 1, n, 1))),
         "record_pga": ("record", pga),
         **{f"record_{im}": (("wall", "diaphragm", "record"), other[None, None, :])
            for im in ("pgv", "sa_wall", "sa_diaphragm", "sa_avg")}},
        coords={"wall": ["w"], "diaphragm": ["D1"], "record": [f"r{i}" for i in range(n)],
                "cor": [0.8]})
    s = FA.sufficiency(ds, mag, dist)
    assert s.slope_magnitude.sel(measure="pga").item() == pytest.approx(0.4, abs=0.05)
    assert s.p_magnitude.sel(measure="pga").item() < 1e-6
    assert s.p_magnitude.sel(measure="sa_avg").item() > 0.01
    assert abs(s.slope_magnitude.sel(measure="sa_avg").item()) < 0.05


def test_archives_without_the_measures_are_refused_by_risk():
    ds = xr.Dataset({"collapse_intensity": ("record", [1.0])})
    with pytest.raises(InputError, match="lacks collapse_scale"):
        FA.capacities(ds, "pga")


def test_magnitude_and_distance_of_the_fema_records(records_dir):
    """From the manifest (magnitude) and the library's catalog.tsv (rupture distance)."""
    ds = xr.Dataset(coords={"record": ["p695-01-mul009", "p695-07-nis000", "p695-20-tcu045090"]})
    mag, dist = FA.record_magnitude_distance(ds, records_dir)
    np.testing.assert_allclose(mag, [6.7, 6.9, 7.6])
    np.testing.assert_allclose(dist, [17.2, 7.1, 26.0])


# ---- urmx risk ---------------------------------------------------------------------------------

def test_urmx_risk_prints_the_tables(ida_records, make_study, tmp_path, capsys):
    ds = _run(make_study, REP_IDA, "rep.toml", kernel=stiff_kernel)
    archive = tmp_path / "rep.nc"
    urmx.netcdf.write_netcdf(ds, archive)
    assert main(["risk", str(archive), "--hazard", str(HAZARD), "--spectrum", str(SPECTRUM),
                 "--years", "30"]) == 0
    out = capsys.readouterr().out
    assert "# Collapse risk: rep-ida" in out and "30 years" in out
    assert "## Single storey" in out and "## Higher storey" in out
    assert "## Stiffening the diaphragm: D1 -> D4" in out
    assert "## Margin over the design spectrum" in out
    risk = FA.collapse_risk(ds, HAZARD, years=30, resamples=0)
    rate = float(risk.rate.sel(wall="s16", diaphragm="D1"))
    assert f"{rate:.2g}" in out
    assert main(["risk", str(archive), "--hazard", str(SPECTRUM)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "must be an intensity measure" in err
