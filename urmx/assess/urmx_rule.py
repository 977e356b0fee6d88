"""Procedure urmx_rule: urmx's own resonance-aware rule for out-of-plane URM walls on flexible
timber diaphragms, fitted to the ``wall-population`` study (issue 37;
``reports/predictors/REPORT.md``).

The rule, by hand:

1. The wall's median collapse PGA from its recommended criterion (the smallest set of
   wall-alone predictors within the ranking's uncertainty of the best, by storey; formulas of
   the predictors in `urmx.fragility.predictors`)::

       C_50 = exp(a) * x_1^b_1 * x_2^b_2          [m s-2]

2. The resonance factor from the demand's 5 %-damped spectrum at the diaphragm's period
   ``T_d = 1 / f_d`` (Table IV footnote frequency)::

       S = Sa(T_d) / PGA,      F = (S / S_ref)^c

   ``c < 0``: a spectrum strong at the diaphragm's period (the record's dominant frequency
   near the diaphragm's, Section 6.3.2 of the paper) lowers the capacity.

3. Capacity ``C = C_50 F`` against the demand's PGA: pass when ``C >= PGA``; the capacity
   scale ``scale C / PGA`` (F depends on the spectrum's shape, not its scale).

The coefficients (`RELATIONS`, `RESONANCE`) are the ones ``reports/predictors/numbers.json``
holds (the test suite checks they agree); the population they were fitted on bounds the
rule's scope (`SCOPE`): a wall outside it, a rigid top diaphragm (the rule is fitted on
flexible ones) or a demand with no spectrum at ``T_d`` is "not applicable". ``C_50`` is a
median: the walls scatter about it with the residual dispersion (``dispersion``), and the
records about ``C`` with the spread the report states; the check is a median check, with no
safety factor.
"""

from __future__ import annotations

import math

from ..errors import InputError
from ..fragility.predictors import PREDICTORS, wall_predictors
from ..model import Wall
from .demand import position_of
from .result import Assessment, NotApplicable, Quantity, linear_capacity_scale, verdict

SOURCE = ("urmx wall-population study (issue 37), reports/predictors/REPORT.md: recommended "
          "criterion and resonance rule fitted on 512 walls x 40 FEMA P695 far-field records")

#: storey -> the recommended criterion's power law in PGA (numbers.json
#: ``relations["<storey>/pga/recommended"]``): ln C_50 = intercept + sum b ln x [m s-2]
RELATIONS: dict[str, dict] = {
    "single": {"predictors": ["static_acceleration", "effective_period"],
               "intercept": 0.4059809559180881,
               "exponents": [0.8962250402885564, 0.9749207895658785],
               "dispersion": 0.11755047919044556},
    "higher": {"predictors": ["static_acceleration", "effective_period"],
               "intercept": 0.2621392142609747,
               "exponents": [0.8989782262447095, 0.9598541834994312],
               "dispersion": 0.1850915835365741},
}
#: storey -> resonance slope c and S_ref (numbers.json ``resonance["<storey>"]``)
RESONANCE: dict[str, dict] = {
    "single": {"slope": -0.22530805715281768, "s_reference": 1.8066048248945341},
    "higher": {"slope": -0.266999261887911, "s_reference": 1.7783766446107696},
}
#: the population's ranges (catalog/studies/wall-population.toml): name -> (low, high)
SCOPE = {"thickness": (0.11, 0.47), "height": (2.5, 7.0), "slenderness": (0.0, 35.0),
         "crack_ratio": (0.5, 0.8), "overburden_ratio": (0.0, 2.0), "pmr": (65.0, 85.0),
         "diaphragm_frequency": (0.8, 8.0), "damping": (0.08, 0.12)}
TOLERANCE = 1e-9  # relative slack at the ends of SCOPE


def _scope_values(wall: Wall) -> dict[str, float]:
    return {"thickness": wall.thickness, "height": wall.height,
            "slenderness": wall.slenderness, "crack_ratio": wall.crack_ratio,
            "overburden_ratio": wall.top_mass / wall.mass, "pmr": wall.pmr,
            "diaphragm_frequency": wall.diaphragm_frequency("top"),
            "damping": wall.top_damping}


def _check_scope(wall: Wall) -> None:
    if wall.top_rigid:
        raise NotApplicable("a rigid top diaphragm: the rule is fitted on flexible "
                            "diaphragms (0.8-8 Hz)")
    if not wall.bottom_rigid and (wall.bottom_stiffness != wall.top_stiffness
                                  or wall.bottom_mass != wall.top_mass):
        raise NotApplicable("a higher-storey wall between unlike diaphragms: the rule is "
                            "fitted on two diaphragms alike")
    for name, value in _scope_values(wall).items():
        lo, hi = SCOPE[name]
        if not lo * (1 - TOLERANCE) <= value <= hi * (1 + TOLERANCE):
            raise NotApplicable(f"{name} = {value:.4g} lies outside the fitted population's "
                                f"{lo:g}-{hi:g}")


def urmx_rule(wall: Wall, demand, position=None, **options) -> Assessment:
    """urmx's resonance-aware rule (module docstring): the wall's median collapse PGA from
    its recommended criterion times the resonance factor, against the demand's PGA.

    Parameters
    ----------
    wall : urmx.Wall
        The wall on its supports: a rigid bottom is a single storey, a flexible one a
        higher storey (between two diaphragms alike).
    demand : RecordDemand or DesignSpectrum
        Anything with ``sa(T)``, ``pga`` and ``scale`` (`urmx.assess.demand`).
    position : Position or str, optional
        Checked as for every procedure; the storey is the supports'.
    **options
        None (an option is refused).
    """
    if options:
        raise InputError(f"urmx_rule takes no options (got {', '.join(sorted(options))})")
    if not isinstance(wall, Wall):
        raise InputError(f"urmx_rule needs a urmx.Wall, not {type(wall).__name__}")
    if not all(hasattr(demand, k) for k in ("sa", "pga", "scale")):
        raise InputError("urmx_rule needs a demand with sa(T), pga and scale "
                         "(urmx.assess.record_demand or a DesignSpectrum)")
    position_of(wall, position)
    storey = "single" if wall.bottom_rigid else "higher"
    q: dict[str, Quantity] = {}
    try:
        _check_scope(wall)
        p = wall_predictors(wall)
        rel, res = RELATIONS[storey], RESONANCE[storey]
        log_c = rel["intercept"]
        for name, b in zip(rel["predictors"], rel["exponents"], strict=True):
            q[name] = Quantity(p[name], _unit(name), f"predictor {name}",
                               "urmx.fragility.predictors")
            log_c += b * math.log(p[name])
        c50 = math.exp(log_c)
        q["median_capacity"] = Quantity(c50, "m s-2", "C_50, median collapse PGA of the "
                                        f"{storey}-storey criterion", "step 1")
        q["dispersion"] = Quantity(rel["dispersion"], "1", "residual dispersion of C_50 "
                                   "over walls", "step 1")
        td = 1.0 / p["diaphragm_frequency"]
        pga = demand.pga
        s = demand.sa(td) / pga
        factor = (s / res["s_reference"]) ** res["slope"]
    except NotApplicable as exc:
        return Assessment.not_applicable("urmx_rule", SOURCE, str(exc), q)
    q["diaphragm_period"] = Quantity(td, "s", "T_d = 1 / f_d", "step 2")
    q["spectral_ratio"] = Quantity(s, "1", "S = Sa(T_d) / PGA", "step 2")
    q["resonance_factor"] = Quantity(factor, "1", f"F = (S / {res['s_reference']:.3g})^"
                                     f"{res['slope']:.3g}", "step 2")
    capacity = c50 * factor
    q["capacity"] = Quantity(capacity, "m s-2", "C = C_50 F", "step 3")
    return Assessment(procedure="urmx_rule", source=SOURCE, verdict=verdict(capacity, pga),
                      capacity=capacity, demand=pga, unit="m s-2",
                      capacity_scale=linear_capacity_scale(demand.scale, capacity, pga),
                      quantities=q)


def _unit(name: str) -> str:
    return PREDICTORS[name][0] if name in PREDICTORS else "1"
