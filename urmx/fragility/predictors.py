"""Candidate predictors of a wall's collapse capacity, computed from the wall alone (issue
37): the quantities an engineer could rank walls by before any time-history analysis.

Each is a plain function of a `urmx.Wall` (numpy only); :func:`wall_predictors` gives all of
them at once as ``name -> value`` and `PREDICTORS` says, per name, its units, formula and
source. The masses are the effective masses of the model (Eq. 7), ``b`` the thickness,
``a1 = eta h`` and ``a2 = h - a1`` the segment heights, ``m1 = m a1 / h``, ``m2 = m a2 / h``
the segment masses, ``m_dt`` the top diaphragm mass (the overburden of Table I) and ``g``
the paper's 9.81 m s-2.

==========================  =====  ============================================================
name                        units  formula (source)
==========================  =====  ============================================================
``slenderness``             1      ``h / b`` (the criterion of the paper's Section 6.3 and of
                                   the codes it cites, [20])
``height``                  m      ``h``
``thickness``               m      ``b``
``static_acceleration``     m s-2  rigid-body acceleration that starts the pinned mechanism
                                   rocking (family 2: lower segment Case 2, upper Case 1):
                                   ``(M0_2 + (a1/a2) M0_1) / (m a1 / 2)`` with ``M0`` of the
                                   paper's Table I (specific forms); ``4 g b / h`` for a wall
                                   with no overburden cracked at mid-height (the classic
                                   one-way result, Doherty et al. 2002)
``instability_case2``       m      instability displacement at crack height in rocking family
                                   2 (Case 2 of Table I): ``theta0 a1 = b``
``instability_case3``       m      same in family 1 (Case 3): ``theta0 a1 =
                                   (b / 2) m1 / (0.5 m1 + m2 + m_dt)`` (paper Section 3.2:
                                   0.10-0.45 of Case 2)
``housner_lower``,          rad/s  Housner's frequency parameter ``p = sqrt(3 g / (4 R))`` of
``housner_upper``                  the lower and upper segment as rectangular blocks,
                                   ``R = sqrt(b^2 + a_i^2) / 2`` the half-diagonal (Housner
                                   1963, BSSA 53(2), Eq. 4 for a rectangular block)
``effective_period``        s      secant period of the pinned mechanism at 0.6 of its
                                   instability displacement (Doherty, Griffith, Lam & Wilson
                                   2002, EESD 31; `urmx.fragility.rocking_period`)
``diaphragm_frequency``     Hz     the top diaphragm's indicative frequency, stiffness over
                                   ``m_dt + m / 2`` (Table IV footnote); inf when rigid
``frequency_ratio``         1      ``diaphragm_frequency * effective_period``: the diaphragm's
                                   frequency over the wall's effective rocking frequency
==========================  =====  ============================================================

``instability_case2`` equals ``thickness`` by Table I (``theta0 = b / a1``): it is kept as
its own name because the issue names it, and a ranking reports the two as one.
"""

from __future__ import annotations

import math

from ..model import PAPER_G, Wall
from .mechanism import rocking_period

#: name -> (units, long name) of each wall-alone predictor (module docstring for formulas)
PREDICTORS: dict[str, tuple[str, str]] = {
    "slenderness": ("1", "slenderness ratio h/t"),
    "height": ("m", "wall height h"),
    "thickness": ("m", "wall thickness t"),
    "static_acceleration": ("m s-2", "static acceleration that starts rocking (rigid M0, "
                                     "family 2)"),
    "instability_case2": ("m", "instability displacement at crack height, Case 2 "
                               "(family 2)"),
    "instability_case3": ("m", "instability displacement at crack height, Case 3 "
                               "(family 1)"),
    "housner_lower": ("rad s-1", "Housner frequency parameter of the lower segment"),
    "housner_upper": ("rad s-1", "Housner frequency parameter of the upper segment"),
    "effective_period": ("s", "effective period at 0.6 of the instability displacement "
                              "(Doherty et al. 2002)"),
    "diaphragm_frequency": ("Hz", "top diaphragm frequency (Table IV footnote)"),
    "frequency_ratio": ("1", "diaphragm frequency over the wall's effective rocking "
                             "frequency"),
}


def static_acceleration(wall: Wall) -> float:
    """Rigid-body ground acceleration that starts the pinned two-segment mechanism rocking
    in family 2, from Table I's ``M0`` (module docstring). [m s-2]"""
    k = wall.a1 / wall.a2
    restoring = wall.segment(2).M0 + k * wall.segment(1).M0
    return restoring / (0.5 * wall.mass * wall.a1)


def instability_displacement(wall: Wall, case: int) -> float:
    """Instability displacement at crack height of the lower segment in Case 2 (family 2)
    or Case 3 (family 1): ``theta0 a1`` (Table I). [m]"""
    if case not in (2, 3):
        raise ValueError(f"case must be 2 or 3 (the lower segment), not {case!r}")
    return wall.segment(case).theta0 * wall.a1


def housner_parameter(thickness: float, height: float) -> float:
    """Housner's frequency parameter ``sqrt(3 g / (4 R))`` of a rectangular block of width
    `thickness` and `height` [m], ``R`` its half-diagonal (Housner 1963). [rad s-1]"""
    r = 0.5 * math.hypot(thickness, height)
    return math.sqrt(3.0 * PAPER_G / (4.0 * r))


def wall_predictors(wall: Wall) -> dict[str, float]:
    """Every wall-alone predictor of `PREDICTORS` for one wall (module docstring)."""
    tr = rocking_period(wall)
    fd = wall.diaphragm_frequency("top")
    return {
        "slenderness": wall.slenderness,
        "height": wall.height,
        "thickness": wall.thickness,
        "static_acceleration": static_acceleration(wall),
        "instability_case2": instability_displacement(wall, 2),
        "instability_case3": instability_displacement(wall, 3),
        "housner_lower": housner_parameter(wall.thickness, wall.a1),
        "housner_upper": housner_parameter(wall.thickness, wall.a2),
        "effective_period": tr,
        "diaphragm_frequency": fd,
        "frequency_ratio": fd * tr,
    }
