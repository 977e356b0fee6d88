"""The rigid-support mechanism every procedure here starts from: the wall's trilinear curve
and instability displacement (MODEL.md section 3, `urmx.Wall.segment`) with both supports
pinned, as `urmx.fragility.mechanism.pinned_mechanism` builds it, and its substitute
structure at a fraction of the instability displacement (Doherty et al. 2002).

The mechanism has one coordinate, the lower segment's tilt ``theta1``; the crack moves by
``Delta = a1 theta1``. Its equation of motion is ``J theta1'' + R(theta1) = -L a_g(t)``
(``J`` the inertia, ``L`` the ground coupling, ``R`` both segments' trilinear resistances by
virtual work), so a linear substitute structure of secant stiffness ``K = R(theta_d) /
theta_d`` has the period ``T = 2 pi sqrt(J / K)`` and moves the crack by ``a1 (L / J) S_d(T)``
under a spectrum ``S_d``: ``a1 L / J`` is the mechanism's participation factor at the crack
(1.5 for a uniform wall cracked at mid-height without top mass; exact rigid-body dynamics,
not a coefficient of any source).
"""

from __future__ import annotations

import math

from ..fragility.mechanism import DESIGN_FRACTION, pinned_mechanism
from ..model import PAPER_G, Wall
from .result import Quantity


def substitute_structure(wall: Wall, fraction: float = DESIGN_FRACTION) -> dict[str, Quantity]:
    """The pinned mechanism of `wall` and its substitute structure at `fraction` of the
    instability displacement, every quantity with its unit (module docstring)."""
    inertia, coupling, restoring, theta_ins, pinned = pinned_mechanism(wall)
    a1 = pinned.a1
    theta_d = fraction * theta_ins
    moment = restoring(theta_d)
    stiffness = moment / theta_d
    period = 2.0 * math.pi * math.sqrt(inertia / stiffness)
    gamma = a1 * coupling / inertia
    weight = wall.mass * PAPER_G
    return {
        "b": Quantity(wall.thickness, "m", "wall thickness b"),
        "h": Quantity(wall.height, "m", "wall height h"),
        "h_over_t": Quantity(wall.slenderness, "1", "slenderness h/t"),
        "a1": Quantity(a1, "m", "crack height a1 = eta h"),
        "W": Quantity(weight, "N", "effective wall weight m g"),
        "J": Quantity(inertia, "kg m2", "inertia of the pinned mechanism about theta1"),
        "L": Quantity(coupling, "kg m", "ground coupling of the pinned mechanism"),
        "theta_ins": Quantity(theta_ins, "rad", "instability rotation of theta1 (MODEL.md 3)"),
        "delta_ins": Quantity(a1 * theta_ins, "m",
                              "instability displacement at the crack, Delta_ins = a1 theta_ins"),
        "fraction": Quantity(fraction, "1", "substitute-structure displacement over Delta_ins "
                             "(Doherty et al. 2002)"),
        "delta_d": Quantity(a1 * theta_d, "m", "substitute-structure displacement at the crack"),
        "R_d": Quantity(moment, "N m", "restoring moment of the trilinear curves at theta_d"),
        "K_eff": Quantity(stiffness, "N m rad-1", "secant rotational stiffness R_d / theta_d"),
        "T_eff": Quantity(period, "s", "effective period 2 pi sqrt(J / K_eff)"),
        "Gamma": Quantity(gamma, "1", "participation at the crack a1 L / J (rigid-body "
                          "dynamics)"),
    }
