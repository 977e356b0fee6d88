"""NZS 1170.5:2004 (incorporating Amendment 1), the parts of it the assessment procedures use:
the elastic site hazard spectrum of Section 3.1 and the parts demand of Section 8.

Where the numbers come from (the issue's rule: no number from memory). The standard itself is
a licensed document: no public copy of its text could be found. Every coefficient below is
taken from a public transcription of it, the VBA module
``NZS1170_Seismic_Coefficient.bas`` of github.com/Agent6-6-6/NZS1170.5-Seismic-Coefficient-
functions (commit 5420ec8e; the parts functions in its later version), whose comments cite
the clauses and the Commentary (NZS 1170.5 Supp 1:2004) they transcribe. The equation numbers
8.3(1)-8.3(3) of the floor height coefficient are confirmed by a public discussion of the
draft (eng-tips thread 78371, "Draft AS/NZS 1170.4 ... Floor height coeff.").

- Spectral shape factor ``C_h(T)`` (Table 3.1 / Commentary C3.1), the modal response
  spectrum form (the form the parts demand's ``C(0)`` uses, NZS 1170.5 Cl. 8.2): site
  classes A/B, C, D, E (class D without the C-D interpolation of Cl. 3.1.3).
- Elastic site spectrum ``C(T) = C_h(T) Z R N(T, D)`` (Eq. 3.1(1)), with ``Z R`` not taken
  above 0.7 (Cl. 3.1.1 as transcribed); the near-fault factor ``N(T, D)`` is an input
  (default 1: no fault within 20 km, the transcription's ``N = 1`` case).
- Floor height coefficient ``C_Hi`` (Eqs. 8.3(1)-(3)): ``1 + h_i/6`` and ``1 + 10 h_i/h_n``
  for ``h_i < 12 m``, the smaller of the two; 3.0 above (as the transcription applies them).
- Part spectral shape coefficient ``C_i(T_p)`` (Table 8.1 / Eq. 8.4): 2.0 up to 0.75 s,
  ``2 (1.75 - T_p)`` to 1.5 s, 0.5 beyond.
- Part response factor ``C_ph`` (Table 8.2 / Commentary Table C8.3): 1.0 for a part
  ductility ``mu_p = 1`` (the only value used here: a rocking wall is given no ductility).
- Horizontal design action ``F_ph = C_p(T_p) C_ph R_p W_p <= 3.6 W_p`` (Eq. 8.5(1)), with
  ``C_p(T_p) = C(0) C_Hi C_i(T_p)`` (Eq. 8.2(1)).
- The part risk factor ``R_p`` (Table 8.1) is an input (default 1.0); its table was not seen.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from ..errors import InputError
from .result import NotApplicable

G = 9.81  # m s-2 (urmx.model.PAPER_G)
SITE_CLASSES = ("A", "B", "C", "D", "E")
ZR_MAX = 0.7  # Cl. 3.1.1 (transcribed): Z R not taken above 0.7
PARTS_CAP = 3.6  # Eq. 8.5(1): F_ph <= 3.6 W_p
C_PH_MU1 = 1.0  # Table C8.3 (transcribed): C_ph at part ductility 1
SOURCE = ("NZS 1170.5:2004 + A1, Section 3.1 (Eq. 3.1(1), Table 3.1) and Section 8 (Eqs. "
          "8.2(1), 8.3(1)-(3), 8.4, 8.5(1)), coefficients as transcribed in the public "
          "github.com/Agent6-6-6/NZS1170.5-Seismic-Coefficient-functions (the standard's "
          "text was not available)")


def spectral_shape(period: float, site_class: str) -> float:
    """``C_h(T)`` of NZS 1170.5 Table 3.1, modal response spectrum form (module docstring). [1]"""
    t = float(period)
    if not math.isfinite(t) or t < 0:
        raise NotApplicable(f"NZS 1170.5 C_h(T): period {t!r} s is not a period")
    c = _site_class(site_class)
    if c in ("A", "B"):
        if t < 0.1:
            return 1.0 + 1.35 * t / 0.1
        if t < 0.3:
            return 2.35
        return _tail(t, 1.6 * (0.5 / t) ** 0.75, 1.05, 3.15)
    if c == "C":
        if t < 0.1:
            return 1.33 + 1.6 * t / 0.1
        if t < 0.3:
            return 2.93
        return min(2.93, _tail(t, 2.0 * (0.5 / t) ** 0.75, 1.32, 3.96))
    if t < 0.1:
        return 1.12 + 1.88 * t / 0.1
    if c == "D":
        if t < 0.56:
            return 3.0
        return _tail(t, 2.4 * (0.75 / t) ** 0.75, 2.14, 6.42)
    if t < 1.0:
        return 3.0
    return _tail(t, 3.0 / t ** 0.75, 3.32, 9.96)


def _tail(t: float, mid: float, a: float, b: float) -> float:
    """The three long-period branches: ``mid`` to 1.5 s, ``a / T`` to 3 s, ``b / T^2``."""
    if t <= 1.5:
        return mid
    if t <= 3.0:
        return a / t
    return b / t ** 2


def _site_class(site_class: str) -> str:
    c = str(site_class).strip().upper()
    if c not in SITE_CLASSES:
        raise InputError(f"site class {site_class!r} must be one of {', '.join(SITE_CLASSES)} "
                         "(NZS 1170.5 Cl. 3.1.3)")
    return c


def floor_height_coefficient(h_i: float, h_n: float) -> float:
    """``C_Hi`` of NZS 1170.5 Eqs. 8.3(1)-(3) at height `h_i` [m] of a structure of height
    `h_n` [m] (module docstring). [1]"""
    if h_i < 0 or h_n <= 0:
        raise InputError(f"C_Hi needs h_i >= 0 and h_n > 0 (h_i={h_i!r}, h_n={h_n!r})")
    if h_i < 12.0:
        return min(1.0 + h_i / 6.0, 1.0 + 10.0 * h_i / h_n)
    return 3.0


def part_spectral_shape(period: float) -> float:
    """``C_i(T_p)`` of NZS 1170.5 Eq. 8.4 / Table 8.1 (module docstring). [1]"""
    if period <= 0.75:
        return 2.0
    if period >= 1.5:
        return 0.5
    return 2.0 * (1.75 - period)


@dataclass(frozen=True)
class DesignSpectrum:
    """The NZS 1170.5 elastic site hazard spectrum ``C(T) = C_h(T) Z R N`` (Eq. 3.1(1)) as a
    demand (`urmx.assess.demand`): ``sa(T) = C(T) g``.

    Parameters
    ----------
    Z : float
        Hazard factor (Cl. 3.1.4). [1]
    site_class : {"A", "B", "C", "D", "E"}
        Site subsoil class (Cl. 3.1.3).
    R : float
        Return period factor (Cl. 3.1.5), 1.0 for 500 years. [1]
    N : float
        Near-fault factor N(T, D) (Cl. 3.1.6), default 1. [1]
    scale : float
        A factor on the whole spectrum (the capacity scale's currency). [1]
    """

    Z: float
    site_class: str = "C"
    R: float = 1.0
    N: float = 1.0
    scale: float = 1.0
    kind: str = "design spectrum"

    def __post_init__(self) -> None:
        for name in ("Z", "R", "N", "scale"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) \
                    or v <= 0:
                raise InputError(f"design spectrum {name}={v!r} must be a finite number > 0")
        object.__setattr__(self, "site_class", _site_class(self.site_class))

    @property
    def label(self) -> str:
        return (f"NZS 1170.5 class {self.site_class}, Z={self.Z:g}, R={self.R:g}"
                + (f", N={self.N:g}" if self.N != 1.0 else ""))

    def scaled(self, s: float) -> DesignSpectrum:
        """The same spectrum with its scale multiplied by `s`.

        Parameters
        ----------
        s : float
            Factor on the scale. [1]
        """
        return DesignSpectrum(self.Z, self.site_class, self.R, self.N, self.scale * s)

    def coefficient(self, period: float) -> float:
        """``C(T)`` at scale 1 (Eq. 3.1(1), ``Z R <= 0.7``). [1]

        Parameters
        ----------
        period : float
            Period. [s]
        """
        return spectral_shape(period, self.site_class) * min(self.Z * self.R, ZR_MAX) * self.N

    def sa(self, period: float) -> float:
        """``scale C(T) g``. [m s-2]

        Parameters
        ----------
        period : float
            Period. [s]
        """
        return self.scale * self.coefficient(period) * G

    def sd(self, period: float) -> float:
        """``sa (T / 2 pi)^2``. [m]

        Parameters
        ----------
        period : float
            Period. [s]
        """
        return self.sa(period) * (period / (2.0 * math.pi)) ** 2

    @property
    def pga(self) -> float:
        """``sa(0) = C(0) g`` (the modal spectrum at T = 0). [m s-2]"""
        return self.sa(0.0)

    def describe(self) -> str:
        """The spectrum's label and scale, for reports (``NZS 1170.5 ... x 1``)."""
        return f"{self.label} x {self.scale:g}"
