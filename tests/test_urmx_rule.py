"""urmx.assess.urmx_rule (issue 37): the rule against its formula for one wall and a
spectrum of known shape, its scope, its errors, its registry line, and its coefficients
against the committed report's numbers.json."""

from __future__ import annotations

import importlib
import json
import math
from pathlib import Path

import numpy as np
import pytest

from urmx.assess import PROCEDURES, RecordDemand, urmx_rule
from urmx.errors import InputError
from urmx.model import RIGID, Wall

rule_module = importlib.import_module("urmx.assess.urmx_rule")  # the name is the function's
NUMBERS = Path(__file__).resolve().parent.parent / "reports" / "predictors" / "numbers.json"


@pytest.fixture(scope="module")
def wall():
    # single storey: b = 0.2, h = 4, crack at mid-height, O/W = 0.5, f_d = 2.516 Hz
    return Wall(thickness=0.2, height=4.0, crack_ratio=0.5, mass=4000.0, top_mass=2000.0,
                top_stiffness=1e6, top_damping=0.1, pmr=75.0)


def flat(pga=3.0, plateau=2.5, scale=1.0):
    """A demand whose spectrum is `plateau` times its PGA at every period."""
    periods = np.geomspace(0.01, 10.0, 50)
    return RecordDemand("flat", periods, np.full(50, plateau * pga), pga, scale)


def test_rule_by_its_formula(wall):
    from urmx.fragility.predictors import wall_predictors

    p = wall_predictors(wall)
    rel, res = rule_module.RELATIONS["single"], rule_module.RESONANCE["single"]
    c50 = math.exp(rel["intercept"]) * math.prod(
        p[n] ** b for n, b in zip(rel["predictors"], rel["exponents"], strict=True))
    factor = (2.5 / res["s_reference"]) ** res["slope"]
    a = urmx_rule(wall, flat())
    assert a.applicable and a.unit == "m s-2"
    assert a["spectral_ratio"] == pytest.approx(2.5, rel=1e-12)
    assert a["median_capacity"] == pytest.approx(c50, rel=1e-12)
    assert a.capacity == pytest.approx(c50 * factor, rel=1e-12)
    assert a.demand == pytest.approx(3.0)
    assert a.verdict == ("pass" if a.capacity >= 3.0 else "fail")
    assert a.capacity_scale == pytest.approx(a.capacity / 3.0, rel=1e-12)
    # the capacity scale is on the demand's scale: the same absolute intensity
    b = urmx_rule(wall, flat(scale=2.0))
    assert b.capacity_scale == pytest.approx(a.capacity_scale, rel=1e-12)
    # a spectrum stronger at T_d changes the capacity by the resonance factor's ratio
    c = urmx_rule(wall, flat(plateau=5.0))
    assert c.capacity / a.capacity == pytest.approx(2.0 ** res["slope"], rel=1e-12)


def test_scope(wall):
    rigid = urmx_rule(wall.replace(top_stiffness=RIGID, top_damping=0.0), flat())
    assert not rigid.applicable and "rigid top" in rigid.reason
    slender = urmx_rule(wall.replace(height=8.0), flat())
    assert not slender.applicable and "height = 8" in slender.reason
    unlike = wall.replace(bottom_stiffness=2e6, bottom_mass=2000.0, bottom_damping=0.1)
    assert "unlike" in urmx_rule(unlike, flat()).reason
    alike = wall.replace(bottom_stiffness=1e6, bottom_mass=2000.0, bottom_damping=0.1)
    assert urmx_rule(alike, flat()).applicable  # a higher-storey wall


def test_errors_and_registry(wall):
    assert PROCEDURES["urmx_rule"] is urmx_rule
    with pytest.raises(InputError, match="no options"):
        urmx_rule(wall, flat(), safety=2.0)
    with pytest.raises(InputError, match="urmx.Wall"):
        urmx_rule("wall", flat())
    with pytest.raises(InputError, match="demand"):
        urmx_rule(wall, 0.3)


def test_coefficients_are_the_reports():
    numbers = json.loads(NUMBERS.read_text())
    for storey in ("single", "higher"):
        rel = numbers["relations"][f"{storey}/pga/recommended"]
        ours = rule_module.RELATIONS[storey]
        assert ours["predictors"] == rel["predictors"]
        np.testing.assert_allclose([ours["intercept"], *ours["exponents"], ours["dispersion"]],
                                   [rel["intercept"], *rel["exponents"], rel["dispersion"]],
                                   rtol=1e-6)
        res = numbers["resonance"][storey]
        np.testing.assert_allclose([rule_module.RESONANCE[storey]["slope"],
                                    rule_module.RESONANCE[storey]["s_reference"]],
                                   [res["slope"], res["s_reference"]], rtol=1e-6)
