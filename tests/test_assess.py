"""urmx.assess: the assessment procedures (hand calculations with their sources' equation
numbers, units), the invariants the issue asks (doubling a record halves every spectral
capacity scale, a thicker wall never has a lower capacity, the h/t table's limits at its bin
edges), bad input (one-line errors or "not applicable", never a silent number), the
comparison with an IDA archive (a small synthetic one) and the ``urmx assess`` commands."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
import xarray as xr

import urmx
from urmx.analysis.assessment import compare
from urmx.assess import (
    PROCEDURES,
    DesignSpectrum,
    Position,
    asce41_ht,
    doherty,
    ntc_kinematic,
    nzsee_c8,
    record_demand,
)
from urmx.assess.asce41_ht import HtTable
from urmx.assess.nzs1170 import floor_height_coefficient, part_spectral_shape, spectral_shape
from urmx.assess.result import NOT_APPLICABLE, Assessment
from urmx.errors import InputError, MissingFileError

G = 9.81
UNITS = {"m", "s", "1", "%", "g", "N", "N m", "N m rad-1", "kg", "kg m", "kg m2", "rad",
         "m s-2"}


def hand_wall() -> urmx.Wall:
    """b 0.2 m, h 3 m, crack at mid-height, 1000 kg, both supports rigid, no diaphragm
    masses: the wall of the hand calculations."""
    return urmx.Wall(0.2, 3.0, 0.5, 1000.0)


def building_wall(thickness: float, supports: str = "top") -> urmx.Wall:
    return urmx.Wall.in_building(thickness=thickness, height=3.5, crack_ratio=2 / 3,
                                 density=1800.0, wall_length=8.0, diaphragm_weight=0.5,
                                 plan_area=80.0, diaphragm_stiffness=815e3, supports=supports)


def synthetic_record(factor: float = 1.0, periods=None):
    """A 20 s synthetic record (a 1.3 Hz pulse train in noise), times `factor`."""
    rng = np.random.default_rng(1)
    dt = 0.01
    t = np.arange(0.0, 20.0, dt)
    acc = (3.0 * np.sin(2 * np.pi * 1.3 * t) * np.exp(-(((t - 6) / 4) ** 2))
           + rng.normal(0.0, 0.5, t.size) * np.exp(-(((t - 6) / 5) ** 2)))
    return record_demand((factor * acc, dt), label="syn", periods=periods)


# ---- NZS 1170.5 (public transcription: urmx/assess/nzs1170.py) ---------------------------

def test_nzs1170_coefficients_as_transcribed():
    # Table 3.1 (modal form), class C: 1.33 at T = 0, the 2.93 plateau, 2 (0.5/T)^0.75 to
    # 1.5 s, 1.32/T to 3 s, 3.96/T^2 beyond
    assert spectral_shape(0.0, "C") == pytest.approx(1.33)
    assert spectral_shape(0.05, "C") == pytest.approx(1.33 + 1.6 * 0.5)
    assert spectral_shape(0.2, "C") == pytest.approx(2.93)
    assert spectral_shape(1.0, "C") == pytest.approx(2.0 * 0.5 ** 0.75)
    assert spectral_shape(2.0, "C") == pytest.approx(0.66)
    assert spectral_shape(4.0, "C") == pytest.approx(3.96 / 16.0)
    assert spectral_shape(0.0, "A") == pytest.approx(1.0)
    assert spectral_shape(0.0, "E") == pytest.approx(1.12)
    # Eqs. 8.3(1)-(3): C_Hi; Eq. 8.4: C_i(T_p)
    assert floor_height_coefficient(0.0, 7.0) == 1.0
    assert floor_height_coefficient(3.0, 6.0) == pytest.approx(1.5)  # 1 + 3/6 < 1 + 10*0.5
    assert floor_height_coefficient(1.0, 100.0) == pytest.approx(1.1)  # 1 + 10/100 < 1 + 1/6
    assert floor_height_coefficient(12.5, 20.0) == 3.0
    assert [part_spectral_shape(t) for t in (0.5, 0.75, 1.0, 1.5, 3.0)] == \
        pytest.approx([2.0, 2.0, 1.5, 0.5, 0.5])
    # Eq. 3.1(1) with Z R not above 0.7: Z 0.5, R 1.8 -> 0.7
    d = DesignSpectrum(0.5, "C", 1.8)
    assert d.coefficient(0.0) == pytest.approx(1.33 * 0.7)
    assert d.pga == pytest.approx(1.33 * 0.7 * G)
    assert d.sd(1.0) == pytest.approx(d.sa(1.0) / (2 * math.pi) ** 2)


# ---- doherty: hand calculation --------------------------------------------------------------

def test_doherty_hand_calculation():
    """Doherty et al. (2002) on the hand wall under NZS 1170.5 class C, Z = 0.4."""
    r = doherty(hand_wall(), DesignSpectrum(0.4, "C", 1.0))
    b, a1, a2, m1, m2, g = 0.2, 1.5, 1.5, 500.0, 500.0, G
    # MODEL.md section 3 (the paper's Table I): Case 2 (lower) and Case 1 (upper)
    M0_2, th0_2 = (0.5 * m1 + m2) * b * g, b / a1
    M0_1, th0_1 = 0.5 * m2 * b * g, b / (2 * a2) * m2 / (0.5 * m2)
    theta_ins = min(th0_2, th0_1 / (a1 / a2))
    assert r["theta_ins"] == pytest.approx(theta_ins) == pytest.approx(2 / 15)
    assert r["delta_ins"] == pytest.approx(a1 * theta_ins) == pytest.approx(0.2)  # = b
    # substitute structure at 0.6 Delta_ins, on the softening branch of both curves
    theta_d = 0.6 * theta_ins
    R_d = M0_2 * (1 - theta_d / th0_2) + (a1 / a2) * M0_1 * (1 - theta_d / th0_1)
    assert r["R_d"] == pytest.approx(R_d) == pytest.approx(784.8)
    # inertia of the pinned mechanism (MODEL.md section 5, T = [1, -1, 0]) and coupling
    Io = 500.0 * (a1 ** 2 + b ** 2) / 3
    M11 = Io + m2 * (b ** 2 + a1 ** 2)
    M12 = a1 * a2 * 0.5 * m2 - m2 * b ** 2 / 2
    J = M11 - 2 * M12 + Io
    assert r["J"] == pytest.approx(J) == pytest.approx(803.3333333)
    assert r["L"] == pytest.approx(1000.0 * a1 / 2)
    T = 2 * math.pi * math.sqrt(J / (R_d / theta_d))
    assert r["T_eff"] == pytest.approx(T) == pytest.approx(1.798015, rel=1e-6)
    gamma = a1 * 750.0 / J
    assert r["Gamma"] == pytest.approx(gamma) == pytest.approx(1.400415, rel=1e-6)
    # demand: C(T) = C_h(T) Z (Eq. 3.1(1)), C_h = 1.32/T between 1.5 and 3 s
    sd = 1.32 / T * 0.4 * g * (T / (2 * math.pi)) ** 2
    assert r["S_d"] == pytest.approx(sd) == pytest.approx(0.235905, rel=1e-5)
    assert r.demand == pytest.approx(gamma * sd)
    assert r.capacity == pytest.approx(0.12)
    assert r.verdict == "fail"
    assert r.capacity_scale == pytest.approx(0.12 / (gamma * sd)) == pytest.approx(0.363235,
                                                                                 rel=1e-5)
    assert r.unit == "m"


def test_nzsee_c8_hand_calculation():
    """NZSEE C8 (its NZS 1170.5 Section 8 basis) on the hand wall, one storey."""
    r = nzsee_c8(hand_wall(), DesignSpectrum(0.4, "C", 1.0))
    T = r["T_p"]
    assert T == pytest.approx(1.798015, rel=1e-6)
    assert r["C0"] == pytest.approx(1.33 * 0.4)  # C(0) = C_h(0) Z R
    # mean of C_Hi at the base (0 m) and the top (3 m) of a 3 m building: Eqs. 8.3(1)-(2)
    assert r["C_Hi"] == pytest.approx(0.5 * (1.0 + (1 + 3.0 / 6)))
    assert r["C_i"] == pytest.approx(0.5)  # Eq. 8.4 beyond 1.5 s
    coeff = 0.532 * 1.25 * 0.5 * 1.0 * 1.0  # C(0) C_Hi C_i C_ph R_p (Eq. 8.2(1), 8.5(1))
    assert r["C_p_Cph_Rp"] == pytest.approx(coeff)
    d_ph = 1.400415 * coeff * G * (T / (2 * math.pi)) ** 2
    assert r["D_ph"] == pytest.approx(d_ph, rel=1e-6) == pytest.approx(0.374062, rel=1e-5)
    assert r["NBS"] == pytest.approx(100 * 0.12 / d_ph, rel=1e-6)
    assert r.capacity_scale == pytest.approx(r["NBS"] / 100)
    assert r.quantities["NBS"].unit == "%"


def test_nzsee_c8_parts_cap_makes_the_capacity_scale_infinite():
    # Eq. 8.5(1): C_p C_ph R_p <= 3.6. D_ph / Delta_m = 3.6 g L / R_d at the cap, so only a
    # block that resists more than 3.6 g at 0.6 Delta_i (b/h > 3) passes at every scale
    w = urmx.Wall(1.8, 0.5, 0.5, 3000.0)
    r = nzsee_c8(w, DesignSpectrum(0.4, "C", 1.0).scaled(100.0))
    assert r["C_p_Cph_Rp"] == pytest.approx(3.6)
    assert r.passed and math.isinf(r.capacity_scale)
    assert math.isinf(nzsee_c8(w, DesignSpectrum(0.4)).capacity_scale)
    slender = nzsee_c8(hand_wall(), DesignSpectrum(0.4, "C", 1.0).scaled(100.0))
    assert slender["C_p_Cph_Rp"] == pytest.approx(3.6) and slender.verdict == "fail"
    assert slender.capacity_scale == pytest.approx(0.320802, rel=1e-5)  # the same factor


def test_ntc_kinematic_capacity_side_and_not_available():
    r = ntc_kinematic(hand_wall(), DesignSpectrum(0.4))
    assert r.verdict == NOT_APPLICABLE and "not available" in r.reason
    assert math.isnan(r.capacity_scale)
    # virtual work on the rigid blocks: alpha0 = (M0_2 + M0_1) / (g m a1 / 2)
    M0 = (0.5 * 500 + 500) * 0.2 * G + 0.5 * 500 * 0.2 * G
    assert r["alpha0"] == pytest.approx(M0 / (G * 1000 * 0.75)) == pytest.approx(4 * 0.2 / 3)
    # M* with both centroids moving a1/2 theta: the whole mass; e* = 1; a0* = alpha0 g / FC
    assert r["M_star"] == pytest.approx(1000.0)
    assert r["e_star"] == pytest.approx(1.0)
    assert r["a0_star"] == pytest.approx(4 * 0.2 / 3 * G / 1.35)
    assert r.quantities["a0_star"].unit == "m s-2"


# ---- asce41_ht --------------------------------------------------------------------------

LIMITS = {"one-storey": 13.0, "first": 15.0, "top": 9.0, "other": 13.0}


@pytest.mark.parametrize("s_x1", [0.0, 0.3, 1.0, 5.0])
def test_asce41_ht_table_a1f_limits_at_every_s_x1(s_x1):
    # Table No. A1-F has one bin: its limits hold at every S_X1, edges 0 and above included
    for position, limit in LIMITS.items():
        r = asce41_ht(urmx.Wall(0.2, 2.6, 0.5, 900.0), s_x1, position)
        assert r.capacity == limit and r.demand == pytest.approx(13.0)
        assert r.verdict == ("pass" if 13.0 <= limit else "fail")
    cross = asce41_ht(hand_wall(), s_x1, "first", cross_walls=True)
    assert cross.capacity == 16.0
    tested = asce41_ht(hand_wall(), s_x1, "top", cross_walls=True, tested_mortar=True)
    assert tested.capacity == 14.0


def test_asce41_ht_bins_edges_and_capacity_scale():
    """The bin machinery on a three-bin table (made up for this test, not a code's)."""
    t = HtTable(((0.2, dict.fromkeys(LIMITS, 20.0)), (0.5, dict.fromkeys(LIMITS, 15.0)),
                 (math.inf, dict.fromkeys(LIMITS, 10.0))), "test table")
    wall = hand_wall()  # h/t 15
    for s_x1, limit in ((0.0, 20.0), (0.2, 20.0), (0.2000001, 15.0), (0.5, 15.0),
                        (0.5000001, 10.0), (3.0, 10.0)):
        assert asce41_ht(wall, s_x1, "other", table=t).capacity == limit
    # met up to S_X1 0.5: at 0.25 the scale reaching 0.5 is 2
    assert asce41_ht(wall, 0.25, "other", table=t).capacity_scale == pytest.approx(2.0)
    assert asce41_ht(urmx.Wall(0.2, 4.2, 0.5, 900.0), 0.1, "other", table=t
                     ).capacity_scale == 0.0  # h/t 21 fails the first bin
    assert math.isinf(asce41_ht(urmx.Wall(0.4, 3.0, 0.5, 900.0), 0.1, "other", table=t
                                ).capacity_scale)


# ---- invariants --------------------------------------------------------------------------

def test_doubling_a_record_halves_every_spectral_capacity_scale():
    one, two = synthetic_record(1.0), synthetic_record(2.0)
    t = HtTable(((0.2, dict.fromkeys(LIMITS, 20.0)), (math.inf, dict.fromkeys(LIMITS, 5.0))),
                "test table")
    checked = 0
    for wall in (hand_wall(), building_wall(0.23), building_wall(0.35, "both")):
        for fn in (nzsee_c8, doherty, lambda w, d: asce41_ht(w, d, table=t)):
            a, b = fn(wall, one), fn(wall, two)
            assert b.capacity_scale == pytest.approx(a.capacity_scale / 2, rel=1e-12)
            # and the same record at scale 2 has the same (absolute) capacity scale
            assert fn(wall, one.scaled(2.0)).capacity_scale == pytest.approx(a.capacity_scale)
            checked += 1
    assert checked == 9


@pytest.mark.parametrize("demand", [DesignSpectrum(0.4, "C"), DesignSpectrum(0.3, "E"),
                                    synthetic_record()], ids=["C", "E", "record"])
@pytest.mark.parametrize("supports", ["top", "both"])
def test_a_thicker_wall_never_has_a_lower_capacity(demand, supports):
    for name, fn in PROCEDURES.items():
        scales = [fn(building_wall(b, supports), demand).capacity_scale
                  for b in np.linspace(0.1, 0.6, 11)]
        if name == "ntc_kinematic":
            assert np.isnan(scales).all()
            a0 = [ntc_kinematic(building_wall(b, supports), demand)["a0_star"]
                  for b in np.linspace(0.1, 0.6, 11)]
            assert all(y >= x for x, y in zip(a0, a0[1:], strict=False))
            continue
        # a wall outside a procedure's scope is not applicable (NaN): compare the others
        fin = [x for x in scales if np.isfinite(x)]
        assert len(fin) >= 2, name
        assert all(y >= x for x, y in zip(fin, fin[1:], strict=False)), name


def test_units_of_every_quantity():
    for fn in PROCEDURES.values():
        r = fn(building_wall(0.23), DesignSpectrum(0.4))
        assert r.quantities
        for name, q in r.quantities.items():
            assert q.unit in UNITS, (name, q.unit)
        assert r.unit in ("m", "1", "", "m s-2")
    # lengths in metres, periods in seconds: a wall given in mm is refused by urmx.Wall
    with pytest.raises(InputError, match="millimetres"):
        urmx.Wall(230.0, 3500.0, 0.5, 1000.0)


# ---- bad input ---------------------------------------------------------------------------

def test_bad_input_is_a_one_line_error():
    wall, d = hand_wall(), DesignSpectrum(0.4)
    cases = [
        (lambda: doherty("wall", d), "must be a urmx.Wall"),
        (lambda: nzsee_c8(wall, 0.4), "demand must be"),
        (lambda: nzsee_c8(wall, d, R_p=-1), "R_p"),
        (lambda: asce41_ht(wall, -0.1), "S_X1"),
        (lambda: asce41_ht(wall, 0.3, "basement"), "position"),
        (lambda: DesignSpectrum(0.4, "F"), "site class"),
        (lambda: DesignSpectrum(0.0), "must be a finite number > 0"),
        (lambda: record_demand((np.ones(100), 0.01), scale=0.0), "scale"),
        (lambda: Position("top", 5.0, 4.0), "below building_height"),
    ]
    for call, message in cases:
        with pytest.raises(InputError, match=message) as exc:
            call()
        assert "\n" not in str(exc.value)


def test_no_spectrum_at_the_needed_period_is_not_applicable():
    short = synthetic_record(periods=np.geomspace(0.02, 0.5, 30))
    wall = hand_wall()  # T_eff 1.8 s, beyond 0.5 s
    for fn in (doherty, asce41_ht):  # asce41_ht needs Sa at 1 s
        r = fn(wall, short)
        assert r.verdict == NOT_APPLICABLE and "no spectrum" in r.reason
        assert math.isnan(r.capacity_scale) and math.isnan(r.capacity)
    # nzsee_c8 needs C(0) only: applicable
    assert nzsee_c8(wall, short).applicable


def test_a_wall_outside_the_procedures_scope_is_not_applicable():
    # a position whose building is lower than the wall's top: C_Hi undefined
    r = nzsee_c8(hand_wall(), DesignSpectrum(0.4), Position("one-storey", 0.0, 2.0))
    assert r.verdict == NOT_APPLICABLE and "above the building height" in r.reason
    # the kinematic check's demand side is out of reach for every wall
    assert not ntc_kinematic(hand_wall(), DesignSpectrum(0.4)).applicable


def test_assessment_to_json():
    r = nzsee_c8(building_wall(0.23), DesignSpectrum(0.4))
    d = json.loads(json.dumps(r.to_dict()))
    assert d["procedure"] == "nzsee_c8" and d["quantities"]["T_p"]["unit"] == "s"
    na = json.loads(json.dumps(ntc_kinematic(hand_wall(), DesignSpectrum(0.4)).to_dict()))
    assert na["capacity_scale"] is None and na["verdict"] == NOT_APPLICABLE
    with pytest.raises(ValueError):
        Assessment("x", "", "maybe")


# ---- compare on a small synthetic archive -------------------------------------------------

def synthetic_archive(walls, ida):
    w_ids, d_ids, r_ids = ["w1", "w2"], ["D1", "D1/both"], ["r1", "r2"]
    censored = np.zeros_like(ida)
    censored[1, 1, 1] = 1.0
    ds = xr.Dataset({"collapse_scale": (("wall", "diaphragm", "record", "cor"), ida[..., None]),
                     "censored": (("wall", "diaphragm", "record", "cor"), censored[..., None])},
                    coords={"wall": w_ids, "diaphragm": d_ids, "record": r_ids, "cor": [0.8]},
                    attrs={"urmx_git_commit": "abc", "kernel_source_hash": "k"})
    return ds


def test_compare_on_a_synthetic_archive():
    walls = {("w1", "D1"): building_wall(0.23), ("w1", "D1/both"): building_wall(0.23, "both"),
             ("w2", "D1"): building_wall(0.35), ("w2", "D1/both"): building_wall(0.35, "both")}
    rng = np.random.default_rng(0)
    dt, t = 0.01, np.arange(0.0, 20.0, 0.01)
    base = np.sin(2 * np.pi * 1.3 * t) * np.exp(-(((t - 6) / 4) ** 2)) * 3
    records = {"r1": (base + rng.normal(0, 0.1, t.size), dt), "r2": (2 * base, dt)}
    # the IDA: 2 x doherty's capacity on every cell but one, 0.5 x on (w1, D1, r1)
    cap = np.array([[[doherty(walls[(w, d)], record_demand(records[r])).capacity_scale
                      for r in ("r1", "r2")] for d in ("D1", "D1/both")] for w in ("w1", "w2")])
    ida = 2.0 * cap
    ida[0, 0, 0] = 0.5 * cap[0, 0, 0]
    c = compare(synthetic_archive(walls, ida), walls=walls, records=records)
    assert dict(c.sizes) == {"procedure": len(PROCEDURES), "wall": 2, "diaphragm": 2, "record": 2}
    assert list(c.procedure.values) == list(PROCEDURES)
    dh = c.sel(procedure="doherty")
    assert dh.capacity_scale.values == pytest.approx(cap)
    assert dh.ratio.values.ravel() == pytest.approx([2.0, 0.5, 0.5, 0.5, 0.5, 0.5, 0.5, 0.5])
    assert dh.unconservative.values.ravel().tolist() == [1, 0, 0, 0, 0, 0, 0, 0]
    assert c.ida_censored.values[1, 1, 1] == 1.0
    # not available: NaN everywhere, the reason kept
    nk = c.sel(procedure="ntc_kinematic")
    assert np.isnan(nk.capacity_scale).all() and np.isnan(nk.unconservative).all()
    assert "not available" in str(nk.reason.item())
    assert c.attrs["archive_urmx_git_commit"] == "abc"


def test_assessment_report_on_a_synthetic_archive(tmp_path):
    from urmx.reports.assessment import write_report

    walls = {("w1", "D1"): building_wall(0.23), ("w1", "D1/both"): building_wall(0.23, "both"),
             ("w2", "D1"): building_wall(0.35), ("w2", "D1/both"): building_wall(0.35, "both")}
    dt, t = 0.01, np.arange(0.0, 20.0, 0.01)
    records = {"r1": (np.sin(2 * np.pi * 1.3 * t), dt), "r2": (np.sin(2 * np.pi * 0.7 * t), dt)}
    ida = np.array([[[d.capacity_scale for d in (doherty(walls[(w, x)], record_demand(
        records[r])) for r in ("r1", "r2"))] for x in ("D1", "D1/both")] for w in ("w1", "w2")])
    ida = ida * np.array([0.5, 4.0])  # r1: doherty unconservative (x2), r2: conservative
    path = write_report(synthetic_archive(walls, ida), tmp_path, walls=walls, records=records)
    text = path.read_text(encoding="utf-8")
    assert "made by urmx commit `abc`" in text and "kernel source hash `k`" in text
    # doherty: 2 of 4 (wall, record) pairs unconservative on each diaphragm, ratio 2 there
    assert "| single storey | D1 | 4 | 4 | 50 % | 50 % |" in text
    assert "**doherty** is unconservative for 50.0 % of all" in text
    assert "there its capacity scale is 2 times the IDA's" in text
    assert "**ntc_kinematic** is not applicable to any pair" in text
    assert (tmp_path / "doherty.png").stat().st_size > 1000
    assert not (tmp_path / "ntc_kinematic.png").exists()
    csv = (tmp_path / "comparison.csv").read_text(encoding="utf-8").splitlines()
    assert csv[0].startswith("procedure,diaphragm,group,pairs")
    assert len(csv) == 1 + len(PROCEDURES) * 2


def test_compare_iterates_the_registry_and_refuses_a_non_ida_archive(tmp_path):
    walls = {(w, d): building_wall(0.23) for w in ("w1", "w2") for d in ("D1", "D1/both")}
    records = {"r1": synthetic_record(), "r2": synthetic_record(2.0)}
    ida = np.ones((2, 2, 2))

    def always(wall, demand, position=None):
        return Assessment("always", "test", "pass", 1.0, 0.5, "1", 7.0)

    c = compare(synthetic_archive(walls, ida), procedures={"always": always}, walls=walls,
                records={k: (np.ones(10), 0.01) for k in records})
    assert (c.capacity_scale.values == 7.0).all() and (c.unconservative.values[0, :, :, 0]
                                                        == 1).all()
    # censored cell where the procedure accepts more: unknown
    assert np.isnan(c.unconservative.values[0, 1, 1, 1])
    with pytest.raises(InputError, match="not an IDA archive"):
        compare(xr.Dataset({"x": ("a", [1.0])}))
    with pytest.raises(MissingFileError):
        compare(tmp_path / "none.nc")
    text = tmp_path / "text.nc"
    text.write_text("not netCDF\n", encoding="utf-8")
    with pytest.raises(InputError, match="not a netCDF archive") as exc:
        compare(text)
    assert "\n" not in str(exc.value)
    with pytest.raises(InputError, match="lacks the archive's record"):
        compare(synthetic_archive(walls, ida), walls=walls, records={"r1": (np.ones(9), 0.01)})


# ---- the commands ------------------------------------------------------------------------

def test_urmx_assess_command(tmp_path, capsys):
    from urmx.cli import main

    wall = tmp_path / "wall.toml"
    wall.write_text("thickness = 0.2\nheight = 3.0\ncrack_ratio = 0.5\nmass = 1000.0\n",
                    encoding="utf-8")
    rec = tmp_path / "rec.txt"
    assert main(["assess", str(wall), "--z", "0.4", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    by = {r["procedure"]: r for r in out["results"]}
    assert by["doherty"]["capacity_scale"] == pytest.approx(0.363235, rel=1e-5)
    assert by["nzsee_c8"]["quantities"]["NBS"]["value"] == pytest.approx(32.0802, rel=1e-5)
    assert main(["assess", str(wall), "--z", "0.4"]) == 0
    text = capsys.readouterr().out
    assert "doherty: fail" in text and "T_eff = 1.798 s" in text
    assert main(["assess", str(wall)]) == 2
    assert "give either --z" in capsys.readouterr().err
    assert main(["assess", str(wall), "--record", str(rec)]) == 2  # no such record file
    assert len(capsys.readouterr().err.strip().splitlines()) == 1


def test_compare_rebuilds_the_walls_and_checks_the_records(use_records, monkeypatch):
    """Walls from the study file an archive holds, records from the manifest (served in
    memory), each checked against the archive: a changed catalog or record is refused."""
    from urmx.study.file import load_study

    study = load_study("fema-p695-ida")
    dt = 0.01
    t = np.arange(0.0, 10.0, dt)
    acc = {"p695-01-mul009": 2.0 * np.sin(2 * np.pi * t), "p695-01-mul279": np.cos(3 * t)}
    use_records(acc, dict.fromkeys(acc, 1.0), dt)
    ds = xr.Dataset(
        {"collapse_scale": (("wall", "diaphragm", "record", "cor"), np.ones((1, 2, 2, 1))),
         "censored": (("wall", "diaphragm", "record", "cor"), np.zeros((1, 2, 2, 1)))},
        coords={"wall": ["s16"], "diaphragm": ["D1", "D1/both"], "record": list(acc),
                "cor": [0.8], "thickness": ("wall", [0.23]), "height": ("wall", [3.68]),
                "scale_factor": ("record", [1.0, 1.0]),
                "scaled_pga": ("record", [float(np.abs(a).max()) for a in acc.values()])},
        attrs={"study": study.text, "study_name": "fema-p695-ida"})
    c = compare(ds, procedures={"doherty": doherty})
    want = doherty(study.wall(study.walls[4], study.diaphragms[0]),
                   record_demand((acc["p695-01-mul009"], dt))).capacity_scale
    assert c.capacity_scale.sel(wall="s16", diaphragm="D1", record="p695-01-mul009"
                                ).item() == pytest.approx(want)
    with pytest.raises(InputError, match="the record changed"):
        compare(ds.assign_coords(scaled_pga=("record", [1.0, 1.0])),
                procedures={"doherty": doherty})
    with pytest.raises(InputError, match="the catalog changed"):
        compare(ds.assign_coords(thickness=("wall", [0.35])), procedures={"doherty": doherty})
