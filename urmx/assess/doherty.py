"""The displacement-based method of Doherty, Griffith, Lam & Wilson (2002) / Griffith, Magenes,
Melis & Picchi (2003), applied to urmx's own trilinear curve.

Source: K. Doherty, M.C. Griffith, N. Lam, J. Wilson, "Displacement-based seismic analysis
for out-of-plane bending of unreinforced masonry walls", Earthquake Engineering and
Structural Dynamics 31 (2002) 833-850 (DOI 10.1002/eqe.126): "a simplified linearized
displacement-based procedure ... with recommendations for the selection of an appropriate
substitute structure"; "a trilinear relationship is used to characterize the real nonlinear
force-displacement relationship" (its abstract, the part of the paper that could be read);
M.C. Griffith, G. Magenes, G. Melis, L. Picchi, "Evaluation of out-of-plane stability of
unreinforced masonry walls subjected to seismic excitation", Journal of Earthquake
Engineering 7 (2003) special issue 1, 141-169 (not read).

The procedure, as urmx implements it (`doherty`):

1. The wall's trilinear curve and instability displacement ``Delta_ins`` with both supports
   pinned (`urmx.assess.mechanism`: MODEL.md section 3, the paper's Table I).
2. The substitute structure: the secant stiffness at ``0.6 Delta_ins`` (the fraction the
   issue and `urmx.fragility.mechanism` state for Doherty et al. 2002) and its effective
   period ``T_eff = 2 pi sqrt(J / K_eff)``.
3. The demand: the 5 %-damped elastic spectral displacement ``S_d(T_eff)`` of the demand,
   taken to the crack by the mechanism's participation ``Gamma = a1 L / J``.
4. The check: the wall passes while ``Gamma S_d(T_eff) <= 0.6 Delta_ins`` (the displacement
   at which the substitute structure is defined). Capacity and demand in metres at the
   crack; capacity scale ``scale * capacity / demand``.

What could not be read and what urmx chose: the paper's own statement of the failure
criterion and of its equivalent-SDOF transformation (beyond the abstract) was not available;
urmx compares at the substitute-structure displacement and uses exact rigid-body dynamics for
the participation, rather than a coefficient from memory. Supports: the method has no
provision for flexible diaphragms; urmx applies its rigid-support (pinned) mechanism to the
ground motion, as practice does, and says so in the result.
"""

from __future__ import annotations

from ..model import Wall
from .demand import check_demand, check_wall
from .mechanism import substitute_structure
from .result import Assessment, NotApplicable, Quantity, linear_capacity_scale, verdict

NAME = "doherty"
SOURCE = ("Doherty, Griffith, Lam & Wilson (2002), EESD 31:833-850 (substitute structure at "
          "0.6 Delta_ins on the trilinear curve); Griffith et al. (2003), JEE 7(S1):141-169")


def doherty(wall: Wall, demand, position=None) -> Assessment:
    """Displacement-based check of Doherty et al. (2002) (module docstring).

    Parameters
    ----------
    wall : urmx.Wall
        The wall; its supports enter only through the masses they add (rigid-support method).
    demand : RecordDemand or DesignSpectrum
        Its 5 %-damped spectrum (`urmx.assess.demand`).
    position : ignored
        Accepted for the common interface (the method has no height provision).

    Returns
    -------
    Assessment
        Capacity ``0.6 Delta_ins`` and demand ``Gamma S_d(T_eff)`` [m] at the crack, the
        capacity scale, and every intermediate quantity; not applicable when the demand has
        no spectrum at ``T_eff``.
    """
    check_wall(wall, NAME)
    check_demand(demand, NAME)
    q = substitute_structure(wall)
    try:
        sd = demand.sd(q["T_eff"].value)
    except NotApplicable as exc:
        return Assessment.not_applicable(NAME, SOURCE, str(exc), q)
    q["S_d"] = Quantity(sd, "m", "5 %-damped spectral displacement S_d(T_eff) of the demand")
    demand_m = q["Gamma"].value * sd
    capacity = q["delta_d"].value
    q["Delta_demand"] = Quantity(demand_m, "m", "displacement demand at the crack Gamma S_d")
    note = ("" if wall.top_rigid and wall.bottom_rigid else
            "flexible support(s): no provision in the method; its rigid-support (pinned) "
            "mechanism applied to the ground motion")
    return Assessment(NAME, SOURCE, verdict(capacity, demand_m), capacity, demand_m, "m",
                      linear_capacity_scale(demand.scale, capacity, demand_m), q, note)
