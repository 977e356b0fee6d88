"""NZSEE (2017) *The Seismic Assessment of Existing Buildings*, Part C8 (unreinforced masonry),
displacement-based out-of-plane assessment of vertically spanning face-loaded walls, giving
%NBS.

What could be read. The 2017 Guidelines (ISBN 978-0-478-43366-1, www.EQ-Assess.org.nz) are
public, but no searchable copy of Part C8's text was found: its section and equation numbers,
its maximum-usable-displacement factor and its own period equation could not be read. What
was read is the basis its out-of-plane procedure states in the NZSEE generic procedure that
preceded it ("Generic Procedure for Seismic Assessment of Out-of-plane Loaded URM Walls",
NZSEE 2011, its notation and basis page): the procedure "is based upon research by
Derakhshan (2011) and Griffith et al. (2003) and includes the use of response spectrum method
for Parts in buildings as per Section 8 of the NZS1170.5 (2004)", with "a specifically
defined equivalent period" (Griffith et al. 2003), the instability displacement
``Delta_ins``, the part period ``T_p``, the horizontal coefficient ``C_p(T_p)``, the return
period factor and %NBS; it "assumes adequate stiffening of timber diaphragm and adequate
wall-diaphragm connections". urmx therefore implements C8's procedure as that basis defines
it, and says where it chose:

1. Instability displacement ``Delta_i`` of the wall with both supports pinned, from urmx's
   trilinear curves (`urmx.assess.mechanism`; C8 derives it from the wall's free-body
   diagram, as urmx's Table I does).
2. Maximum usable displacement ``Delta_m = 0.6 Delta_i`` and the part period ``T_p`` as the
   secant period there (the substitute structure of Doherty et al. 2002 / Griffith et al.
   2003; C8's own factor could not be read: **urmx's choice**).
3. Parts demand of NZS 1170.5 Section 8 (`urmx.assess.nzs1170`):
   ``C_p(T_p) = C(0) C_Hi C_i(T_p)`` (Eq. 8.2(1)), ``C_ph = 1`` (part ductility 1),
   ``R_p`` (part risk factor, an input, default 1), ``C_p C_ph R_p <= 3.6`` (Eq. 8.5(1)).
   ``C(0)`` is the demand's spectrum at period 0 over g: the design spectrum's ``C(0)``, or
   a record's PGA over g. ``C_Hi`` (Eqs. 8.3(1)-(3)) is the mean of its values at the wall's
   two supports, at heights ``base`` and ``base + h`` of a building ``h_n`` high
   (`urmx.assess.demand.Position`): **urmx's choice** for a part spanning two levels.
4. Displacement demand at the crack ``D_ph = Gamma C_p(T_p) C_ph R_p g (T_p / 2 pi)^2`` with
   the mechanism's participation ``Gamma = a1 L / J`` (`urmx.assess.mechanism`).
5. ``%NBS = 100 Delta_m / D_ph``; the wall passes at %NBS >= 100. Capacity scale:
   ``scale * Delta_m / D_ph`` while the 3.6 cap does not bind, inf when the capped demand
   is below ``Delta_m``.

Flexible diaphragms: C8's basis assumes stiff diaphragms; NZS 1170.5 Section 8 amplifies the
demand by height (``C_Hi``) only. urmx applies that rigid-support method to walls on flexible
diaphragms too, as practice does, and notes it in the result.
"""

from __future__ import annotations

import math

from ..errors import InputError
from ..model import PAPER_G, Wall
from .demand import Position, check_demand, check_wall, position_of
from .mechanism import substitute_structure
from .nzs1170 import (
    C_PH_MU1,
    PARTS_CAP,
    floor_height_coefficient,
    part_spectral_shape,
)
from .nzs1170 import SOURCE as NZS_SOURCE
from .result import Assessment, NotApplicable, Quantity, verdict

NAME = "nzsee_c8"
SOURCE = ("NZSEE (2017) Seismic Assessment of Existing Buildings, Part C8, out-of-plane "
          "face-loaded walls, as its basis states it (NZSEE 2011 generic out-of-plane "
          "procedure: Griffith et al. 2003 equivalent period + NZS 1170.5 Section 8 parts "
          "spectrum); C8's own text not available; " + NZS_SOURCE)


def nzsee_c8(wall: Wall, demand, position: Position | str | None = None,
             R_p: float = 1.0) -> Assessment:
    """%NBS of a face-loaded wall by NZSEE C8's displacement-based procedure (module
    docstring).

    Parameters
    ----------
    wall : urmx.Wall
        The wall (its supports: rigid-support method, noted for flexible ones).
    demand : RecordDemand or DesignSpectrum
        ``C(0)`` is its ``sa(0) / g``.
    position : Position or str, optional
        Heights of the wall's supports in the building (`urmx.assess.demand.position_of`).
    R_p : float
        Part risk factor of NZS 1170.5 Table 8.1 (not read: give the table's value). [1]

    Returns
    -------
    Assessment
        Capacity ``Delta_m`` and demand ``D_ph`` [m] at the crack, ``%NBS`` among the
        quantities, the capacity scale.
    """
    check_wall(wall, NAME)
    check_demand(demand, NAME)
    if isinstance(R_p, bool) or not isinstance(R_p, (int, float)) or not R_p > 0 \
            or not math.isfinite(R_p):
        raise InputError(f"nzsee_c8: R_p={R_p!r} must be a finite number > 0")
    pos = position_of(wall, position)
    q = substitute_structure(wall)
    q["Delta_i"] = Quantity(q["delta_ins"].value, "m", "instability displacement Delta_i")
    q["Delta_m"] = Quantity(q["delta_d"].value, "m", "maximum usable displacement "
                            "0.6 Delta_i (urmx's choice: C8's factor not read)")
    q["T_p"] = Quantity(q["T_eff"].value, "s", "part period: secant period at Delta_m")
    top = pos.base_height + wall.height
    if top > pos.building_height * (1 + 1e-9):
        return Assessment.not_applicable(
            NAME, SOURCE, f"wall top at {top:g} m lies above the building height "
            f"h_n = {pos.building_height:g} m (position {pos.storey})", q)
    try:
        c0 = demand.sa(0.0) / PAPER_G
    except NotApplicable as exc:
        return Assessment.not_applicable(NAME, SOURCE, str(exc), q)
    c_hi = 0.5 * (floor_height_coefficient(pos.base_height, pos.building_height)
                  + floor_height_coefficient(top, pos.building_height))
    c_i = part_spectral_shape(q["T_p"].value)
    coeff = c0 * c_hi * c_i * C_PH_MU1 * R_p
    capped = min(coeff, PARTS_CAP)
    spectral = PAPER_G * (q["T_p"].value / (2.0 * math.pi)) ** 2
    d_ph = q["Gamma"].value * capped * spectral
    q.update({
        "C0": Quantity(c0, "1", "C(0): the demand's spectrum at T = 0 over g"),
        "C_Hi": Quantity(c_hi, "1", "floor height coefficient, mean at the two supports",
                         "NZS 1170.5 Eqs. 8.3(1)-(3)"),
        "C_i": Quantity(c_i, "1", "part spectral shape coefficient C_i(T_p)",
                        "NZS 1170.5 Eq. 8.4"),
        "C_ph": Quantity(C_PH_MU1, "1", "part response factor at ductility 1",
                         "NZS 1170.5 Table 8.2"),
        "R_p": Quantity(float(R_p), "1", "part risk factor (input)", "NZS 1170.5 Table 8.1"),
        "C_p_Cph_Rp": Quantity(capped, "1", "C(0) C_Hi C_i(T_p) C_ph R_p, at most 3.6",
                               "NZS 1170.5 Eqs. 8.2(1), 8.5(1)"),
        "D_ph": Quantity(d_ph, "m", "displacement demand at the crack Gamma C g (T_p/2pi)^2"),
    })
    capacity = q["Delta_m"].value
    nbs = math.inf if d_ph <= 0 else 100.0 * capacity / d_ph
    q["NBS"] = Quantity(nbs, "%", "%NBS = 100 Delta_m / D_ph")
    if q["Gamma"].value * PARTS_CAP * spectral <= capacity or coeff <= 0:
        cap_scale = math.inf  # even the capped demand (Eq. 8.5(1)) stays below Delta_m
    else:  # the demand is linear in the scale below the cap, where the limit lies
        cap_scale = demand.scale * capacity / (q["Gamma"].value * coeff * spectral)
    note = ("" if wall.top_rigid and wall.bottom_rigid else
            "flexible support(s): C8's basis assumes stiff diaphragms; NZS 1170.5 Section 8 "
            "height amplification applied as for rigid supports")
    return Assessment(NAME, SOURCE, verdict(capacity, d_ph), capacity, d_ph, "m",
                      cap_scale, q, note)
