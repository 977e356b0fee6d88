"""A wall's own rocking mechanism, both supports pinned: its trilinear resistance, effective
rocking period, static collapse acceleration and the period of its top support.

``rocking_period`` is the secant period of the mechanism at 60 % of its instability
displacement. A rocking wall has no fixed period: the initial branch of the trilinear curve
(``theta_a = 0.04 theta0``) gives 0.2-0.4 s for the paper's walls, which describes a wall
that has not started to rock, while the period lengthens without bound as the wall nears
instability. The secant at 0.6 of the instability displacement is the effective period of
the displacement-based assessment of one-way spanning walls (Doherty, Griffith, Lam & Wilson
2002, EESD 31, the research line of the paper), chosen there because it best predicts the
response near collapse. The supports are left out on purpose: their effect is what the
top support's own period (:func:`diaphragm_period`) measures.
"""

from __future__ import annotations

import functools
import math

from ..errors import InputError, got
from ..model import RIGID, Wall, system

DESIGN_FRACTION = 0.6  # effective period at this fraction of the instability rotation


def wall_argument(function: str, wall: object) -> None:
    """Refuse a `wall` that is not a `urmx.Wall`, naming the function and what it got."""
    if not isinstance(wall, Wall):
        raise InputError(f"{function}: wall must be a urmx.Wall, got {got(wall)}")


def trilinear(segment, theta: float) -> float:
    """Trilinear resistance R(theta) of a segment case (`urmx.Wall.segment`; MODEL.md
    section 3): linear to ``theta_a``, the plateau ``Mi`` to ``theta_b``, then softening to
    zero at ``theta0``. [N m]

    Parameters
    ----------
    segment : urmx.model.Segment
        The segment case (`urmx.Wall.segment`): ``M0`` [N m], ``Mi`` [N m], ``theta0``,
        ``theta_a``, ``theta_b`` [rad].
    theta : float
        The segment's tilt. [rad]
    """
    a = abs(theta)
    s = 1.0 if theta >= 0 else -1.0
    if a <= segment.theta_a:
        return segment.Mi * theta / segment.theta_a
    if a <= segment.theta_b:
        return s * segment.Mi
    return s * segment.M0 * (1.0 - a / segment.theta0)


def pinned_mechanism(wall: Wall):
    """(inertia, ground coupling, resistance(theta1), instability theta1, the pinned wall) of
    the wall with both supports pinned: one coordinate theta1, theta2 = -(a1/a2) theta1,
    family 2."""
    pinned = wall.replace(bottom_stiffness=RIGID, top_stiffness=RIGID, bottom_damping=0.0,
                          top_damping=0.0)
    M, _, _, _, MinvG, _ = system(pinned.params, 2, 0, 0)
    inertia = float(M[0, 0])
    coupling = float(M[0, 0] * MinvG[0])  # T^T M_f[:, 2] = m a1 / 2
    k = pinned.a1 / pinned.a2
    lower, upper = pinned.segment(2), pinned.segment(1)

    def restoring(theta1: float) -> float:
        # virtual work of the two segments' resistances: lower Case 2, upper Case 1
        return trilinear(lower, theta1) + k * trilinear(upper, k * theta1)

    theta_ins = min(pinned.segment(2).theta0, pinned.segment(1).theta0 / k)
    return inertia, coupling, restoring, theta_ins, pinned


def rocking_period(wall: Wall) -> float:
    """Effective rocking period of a wall: the secant period of its mechanism with both
    supports pinned at 60 % of the instability rotation (module docstring). [s]

    Parameters
    ----------
    wall : urmx.Wall
        The wall; its supports do not enter (the diaphragm masses do, through the
        segments' strengths and instability rotations).

    Returns
    -------
    float
        ``2 pi sqrt(J theta_d / R(theta_d))`` with ``theta_d = 0.6 theta_ins``, ``J`` the
        mechanism's inertia and ``R`` its restoring moment (both segments' trilinear
        resistances, MODEL.md section 3). [s]
    """
    wall_argument("rocking_period", wall)
    return _rocking_period(wall)


@functools.lru_cache(maxsize=4096)
def _rocking_period(wall: Wall) -> float:
    """:func:`rocking_period` of a checked wall, kept per wall (a study asks for each
    wall's once per cell: walls are immutable and hashable)."""
    inertia, _, restoring, theta_ins, _ = pinned_mechanism(wall)
    theta_d = DESIGN_FRACTION * theta_ins
    return 2.0 * math.pi * math.sqrt(inertia * theta_d / restoring(theta_d))


def static_acceleration(wall: Wall) -> float:
    """Ground acceleration that holds the pinned mechanism at its strongest point: the peak
    restoring moment over the ground coupling ``m a1 / 2``. [m s-2]

    The restoring moment is piecewise linear in theta1, so its peak lies at a corner of
    one of the two trilinear curves (or at the instability rotation).

    Parameters
    ----------
    wall : urmx.Wall
        The wall and its supports.
    """
    wall_argument("static_acceleration", wall)
    return _static_acceleration(wall)


@functools.lru_cache(maxsize=4096)
def _static_acceleration(wall: Wall) -> float:
    """:func:`static_acceleration` of a checked wall, kept per wall (a warm-started IDA
    asks for two walls' at every cell)."""
    _, coupling, restoring, theta_ins, pinned = pinned_mechanism(wall)
    k = pinned.a1 / pinned.a2
    lower, upper = pinned.segment(2), pinned.segment(1)
    corners = [lower.theta_a, lower.theta_b, upper.theta_a / k, upper.theta_b / k, theta_ins]
    return max(restoring(t) for t in corners if 0.0 < t <= theta_ins) / coupling


def diaphragm_period(wall: Wall) -> float:
    """Period of the top support, ``1 / wall.diaphragm_frequency("top")``; 0 when rigid. [s]

    Parameters
    ----------
    wall : urmx.Wall
        The wall and its supports.
    """
    wall_argument("diaphragm_period", wall)
    f = wall.diaphragm_frequency("top")
    return 0.0 if math.isinf(f) else 1.0 / f
