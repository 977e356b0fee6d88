"""Kinematic analysis of local mechanisms, Eurocode 8-3 / Italian NTC 2018 with its
Circolare (21 January 2019, n. 7, C8.7.1): the vertical flexure mechanism of a wall
restrained at top and bottom (three hinges: base, crack, top).

What could be read. The Circolare 2019 text and EN 1998-3 could not be found in a searchable
public copy. The earlier edition's capacity side was found, described in words: Circolare
617/2009, relations C8A.4.3 and C8A.4.4 ("Massa partecipante ed accelerazione spettrale di
attivazione del meccanismo", edificiinmuratura.it/Pagina/49): the participating mass ``M*``
is evaluated "considering the virtual displacements of the points of application of the
weights, associated with the mechanism, as a modal shape", ``d_x,i`` being the horizontal
virtual displacement of the point of application of the i-th weight ``P_i`` and ``g`` the
gravity; the fraction of participating mass ``e*`` follows from it; the spectral activation
acceleration ``a0*`` "is obtained multiplying the multiplier alpha0 by g and dividing it by
the fraction of participating mass and by the confidence factor", for which that text takes
the knowledge level LC1's value ``FC = 1.35``. urmx computes (every quantity is reported):

- ``alpha0``, the collapse multiplier, by virtual work on the rigid blocks (horizontal forces
  ``alpha P_i`` at the blocks' centroids against the weights, the top diaphragm's weight
  acting on the upper block): ``alpha0 = R_0 / (g sum m_i d_x,i)`` with ``R_0`` the rigid
  (bilinear) restoring moment of the two segments at zero rotation, Table I's ``M0`` of
  Case 2 and Case 1 (MODEL.md section 3);
- ``M* = (sum P_i d_x,i)^2 / (g sum P_i d_x,i^2)`` (the modal participating mass of the
  shape ``d_x``; C8A.4.3's words), ``e* = g M* / sum P_i`` (the fraction of the weights'
  mass; C8A.4.4's words), ``a0* = alpha0 g / (e* FC)`` (C8A.4.4's words);
  the top support's weight has ``d_x = 0`` (pinned top) and counts in ``sum P_i``.

What could not be read, so is **not available**: the demand side of the linear check (the
comparison of ``a0*`` with the ground spectrum for an element at ground level and with the
spectrum at the element's height, ``Se(T1) psi(Z) gamma``, and the value of the behaviour
factor ``q``: their names appear in a public worked example of Circolare 617 C8A.4.9-10, but
not their expressions or values), and the nonlinear check (the ultimate and secant
displacement fractions of the capacity curve and the spectral displacement demand). So
`ntc_kinematic` returns ``verdict = "not applicable"`` with ``a0*`` and its ingredients among
the quantities, and the comparison leaves it out, rather than guessing those numbers.
"""

from __future__ import annotations

from ..model import PAPER_G, Wall
from .demand import check_demand, check_wall
from .result import Assessment, Quantity

NAME = "ntc_kinematic"
SOURCE = ("NTC 2018 / Circolare 21.1.2019 n. 7 C8.7.1 (not available); capacity side as "
          "Circolare 617/2009 C8A.4.3-C8A.4.4 describe it (edificiinmuratura.it/Pagina/49)")
FC_LC1 = 1.35  # the confidence factor the C8A.4.4 text found takes (knowledge level LC1)
NOT_AVAILABLE = ("demand side not available: the linear check's spectral comparison "
                 "(C8.7.1 / C8A.4.9-10: ground level and Se(T1) psi(Z) gamma at height, "
                 "behaviour factor q) and the nonlinear check's displacement fractions could "
                 "not be found in a public text; a0* is reported, no verdict")


def ntc_kinematic(wall: Wall, demand, position=None, FC: float = FC_LC1) -> Assessment:
    """Capacity side of the kinematic analysis of the vertical flexure mechanism (module
    docstring); the verdict is not available.

    Parameters
    ----------
    wall : urmx.Wall
        The wall: two rigid blocks hinged at the base, the crack and the top.
    demand : RecordDemand or DesignSpectrum
        Checked for form only (the demand side is not available).
    position : ignored
        Accepted for the common interface.
    FC : float
        Confidence factor (default 1.35, the LC1 value of the C8A.4.4 text). [1]

    Returns
    -------
    Assessment
        Not applicable, with ``alpha0`` [1], ``M*`` [kg], ``e*`` [1] and ``a0*`` [m s-2].
    """
    check_wall(wall, NAME)
    check_demand(demand, NAME)
    return Assessment.not_applicable(NAME, SOURCE, NOT_AVAILABLE, capacity_side(wall, FC))


def capacity_side(wall: Wall, FC: float = FC_LC1) -> dict[str, Quantity]:
    """``alpha0``, ``M*``, ``e*`` and ``a0*`` of the vertical flexure mechanism (module
    docstring), per unit rotation ``theta1`` of the lower block."""
    g = PAPER_G
    a1, a2 = wall.a1, wall.a2
    m1, m2 = wall.mass * a1 / wall.height, wall.mass * a2 / wall.height
    # horizontal virtual displacements of the blocks' centroids, pinned top: the lower block
    # rotates by theta1 about its base, the upper by -(a1/a2) theta1 about the top
    dx = (0.5 * a1, a1 - 0.5 * a2 * (a1 / a2))  # both a1/2
    masses = (m1, m2)
    r0 = wall.segment(2).M0 + (a1 / a2) * wall.segment(1).M0  # rigid restoring moment
    work = sum(m * d for m, d in zip(masses, dx, strict=True))
    alpha0 = r0 / (g * work)
    m_star = work ** 2 / sum(m * d * d for m, d in zip(masses, dx, strict=True))
    total = wall.mass + wall.top_mass  # sum P_i / g: the top support's weight included
    e_star = m_star / total
    a0 = alpha0 * g / (e_star * FC)
    return {
        "alpha0": Quantity(alpha0, "1", "collapse multiplier by virtual work (rigid blocks)"),
        "R_0": Quantity(r0, "N m", "rigid restoring moment M0(Case 2) + (a1/a2) M0(Case 1)"),
        "M_star": Quantity(m_star, "kg", "participating mass M*", "Circolare 617 C8A.4.3"),
        "e_star": Quantity(e_star, "1", "fraction of participating mass e* = g M* / sum P",
                           "Circolare 617 C8A.4.4"),
        "FC": Quantity(float(FC), "1", "confidence factor"),
        "a0_star": Quantity(a0, "m s-2", "spectral activation acceleration alpha0 g/(e* FC)",
                            "Circolare 617 C8A.4.4"),
    }
