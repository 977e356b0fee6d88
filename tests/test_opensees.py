"""The OpenSees peer benchmark (``benchmarks/sections/opensees.py``): model A's static
moment-rotation against MODEL.md section 3's trilinear curve and its collapse verdict
against urmx's with both supports rigid (these skip without openseespy, the optional
``peers`` extra CI does not install), and the parts that need no OpenSees: the wall checks,
the decay measures, the stored calibration and the skip.

No timing is asserted.
"""

from __future__ import annotations

import sys

import numpy as np
import pytest

import benchmarks
from benchmarks.common import SectionSkipped
from benchmarks.sections import opensees as section


@pytest.fixture(scope="module")
def ops():
    try:
        return section.opensees()
    except SectionSkipped as exc:
        pytest.skip(str(exc))


@pytest.fixture(scope="module")
def bench_wall():
    return section.walls()["benchmark"]


def trilinear(seg, theta: float) -> float:
    """MODEL.md section 3, written out: R(theta) of a segment case. [N m]"""
    M0, theta0, Mi, ta, tb = seg
    a, s = abs(theta), np.sign(theta)
    if a <= ta:
        return Mi * theta / ta
    if a <= tb:
        return Mi * s
    return M0 * s * (1 - a / theta0)


@pytest.mark.parametrize("segment, case", [("lower", 2), ("upper", 1)])
def test_model_a_static_curve_is_the_trilinear_curve(ops, bench_wall, segment, case):
    seg = bench_wall.segment(case)
    M0, theta0, Mi, ta, tb = seg
    # initial branch, plateau, softening, beyond theta0 (negative), and back, both signs
    rotations = [0.5 * ta, ta, 0.5 * (ta + tb), tb, 0.6 * theta0, 1.2 * theta0, 0.3 * ta,
                 -0.7 * ta, -0.5 * (ta + tb), -0.9 * theta0]
    got = section.static_moment(ops, bench_wall, rotations, segment)
    want = np.array([trilinear(seg, t) for t in rotations])
    np.testing.assert_allclose(got, want, rtol=1e-9, atol=1e-9 * M0)
    assert got[5] < 0  # past theta0 the curve pulls the wall over


def test_model_a_collapse_verdict_matches_urmx_both_rigid(ops, bench_wall, records_dir):
    from urmx import kernel
    from urmx.guard import load_record

    wall = section.both_rigid(bench_wall)
    ag, dt, sf = load_record("p695-02-los000")
    ag = ag * sf
    stored = section.load_calibration()["walls"]["benchmark"]
    verdicts = {}
    for scale in (0.25, 1.5):  # well below and well above urmx's threshold (about 0.9)
        u = kernel.run(wall, ag, dt, scale=scale, cor=section.COR, impact="contact")
        a = section.analyse(ops, "A", wall, ag, dt, scale, sub=10,
                            dashpots=(stored["c_base"], stored["c_crack"]))
        assert not a["failed"]
        verdicts[scale] = (u["status"] == "collapsed", a["collapsed"])
        assert a["collapsed"] == (u["status"] == "collapsed"), scale
        if not a["collapsed"]:  # the joint dashpots stand in for the impacts: same size
            assert a["peak_crack_displacement"] == pytest.approx(
                u["peak_crack_displacement"], rel=0.2)
    assert verdicts == {0.25: (False, False), 1.5: (True, True)}


def test_model_a_without_dashpots_is_urmx_at_cor_1(ops, bench_wall, records_dir):
    """Both supports rigid, no impact loss: the same equations, peaks within 0.5 %."""
    from urmx import kernel
    from urmx.guard import load_record

    wall = section.both_rigid(bench_wall)
    ag, dt, _ = load_record("p695-02-los000")
    u = kernel.run(wall, ag, dt, scale=0.1, cor=1.0)
    a = section.analyse(ops, "A", wall, ag, dt, 0.1, sub=10)
    assert a["peak_crack_displacement"] == pytest.approx(u["peak_crack_displacement"],
                                                         rel=5e-3)


def test_model_b_gravity_and_a_record(ops, bench_wall, records_dir):
    from urmx.guard import load_record

    ag, dt, _ = load_record("p695-02-los000")
    res = section.analyse(ops, "B", bench_wall, ag[:500], dt, 0.3, sub=2)
    assert not res["failed"] and not res["collapsed"]
    assert 0 < res["peak_crack_displacement"] < 0.05


def test_recheck_flags_a_stale_calibration(ops, bench_wall):
    stored = dict(section.load_calibration()["walls"]["benchmark"])
    assert not section.recheck(ops, bench_wall, stored)["stale"]
    stored["beta"] *= 3.0  # dashpots three times too strong decay too fast
    assert section.recheck(ops, bench_wall, stored)["stale"]


# ---- without OpenSees -------------------------------------------------------------------

def test_walls_are_urmx_walls():
    for wid, wall in section.walls().items():
        assert section.check_wall(wall) < 1e-12, wid
    w = section.walls()["s12-D1"]
    assert w.slenderness == pytest.approx(12.0) and w.top_stiffness == 815e3
    assert w.bottom_rigid and not w.top_rigid


def test_check_wall_fails_on_a_wrong_table(monkeypatch, bench_wall):
    real = section.table1

    def off(wall):
        t = real(wall)
        t[3] = (t[3][0] * 1.01, *t[3][1:])
        return t

    monkeypatch.setattr(section, "table1", off)
    with pytest.raises(AssertionError, match="differ from urmx's"):
        section.check_wall(bench_wall)


def test_joint_inertias_are_the_contact_laws():
    from urmx.model import full_mass

    wall = section.walls()["benchmark"]
    ib, ic = section.joint_inertias(wall)
    Minv = np.linalg.inv(full_mass(wall.params, 2)[:2, :2])
    for row, inertia in (([1.0, 0.0], ib), ([-1.0, 1.0], ic)):
        J = np.array(row)
        assert inertia == pytest.approx(1.0 / (J @ Minv @ J))


def test_decay_peaks_and_misfit():
    t = np.linspace(0, 10, 10001)
    theta = 0.05 * np.exp(-0.2 * t) * np.cos(2 * np.pi * t)
    p = section.decay_peaks(theta, 0.1)
    assert len(p) > 10
    np.testing.assert_allclose(p[1:] / p[:-1], np.exp(-0.2 * 0.5), rtol=1e-3)
    assert section.decay_misfit(p, p) == pytest.approx(0.0, abs=1e-12)
    faster = 0.05 * np.exp(-0.4 * t) * np.cos(2 * np.pi * t)
    assert section.decay_misfit(section.decay_peaks(faster, 0.1), p) == pytest.approx(0.1,
                                                                                      rel=0.01)
    assert section.decay_misfit(p[:3], p) == 10.0


def test_stored_calibration_covers_the_compared_walls():
    stored = section.load_calibration()
    assert stored["cor"] == section.COR
    assert set(stored["walls"]) == set(section.WALLS)
    for wid, fit in stored["walls"].items():
        ib, ic = section.joint_inertias(section.walls()[wid])
        assert fit["c_base"] == pytest.approx(fit["beta"] * ib)
        assert fit["c_crack"] == pytest.approx(fit["beta"] * ic)


def test_the_section_is_skipped_without_openseespy(monkeypatch, tmp_path):
    monkeypatch.setitem(sys.modules, "openseespy", None)
    monkeypatch.setitem(sys.modules, "openseespy.opensees", None)
    with pytest.raises(SectionSkipped, match=r'pip install -e "\.\[peers\]"'):
        section.opensees()
    said = []
    out = benchmarks.run_sections(["opensees"], tmp_path / "performance.md", echo=said.append)
    assert said == ["urmx bench: opensees ...",
                    'urmx bench: opensees skipped: openseespy is not installed (pip install '
                    '-e ".[peers]")']
    assert not (tmp_path / "performance" / "opensees.json").exists()
    assert out.read_text().endswith("No measurements yet.\n")
