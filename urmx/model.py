"""The wall model of ``docs/MODEL.md`` sections 1-6.

`Wall` is the immutable, validated description of one wall and its two supports.
Everything the integrators need is packed into a flat float64 parameter vector
(`Wall.params`) so that the numba kernel and the scipy reference solver call the
*same* builders below (one matrix builder for all four rocking patterns and all four
support cases).

Conventions (MODEL.md section 1): generalised coordinates ``q = [theta1, theta2, u_b]``;
a rigid support removes a degree of freedom through ``q = T r`` (section 6).
"""

from __future__ import annotations

import contextlib
import contextvars
import difflib
import functools
import math
from dataclasses import MISSING, asdict, dataclass, field, fields
from typing import Any, NamedTuple

import numpy as np

from .errors import InputError
from .jitcache import jit

PAPER_G = 9.81  # m s-2, the paper's gravity (Table III; MODEL.md section 1); not standard
# gravity (urmx.records.STANDARD_GRAVITY = 9.80665, for records given in g)
RIGID = "rigid"
# t_rest of the rest rule v_rest = g_open/t_rest (MODEL.md section 4): a joint that an impact
# leaves slower than v_rest is held closed. A constant of the model and a setting
# (urmx.kernel.run, urmx.simulate, a study's t_rest), not the record step. [s]
T_REST = 0.01
EFFECTIVE_MASS = 8.0 / 15.0  # Eq. 7: effective over nominal mass of building walls and diaphragms


def effective_wall_mass(density: float, thickness: float, height: float,
                        wall_length: float) -> float:
    """Effective wall mass of a building, Eq. 7: 8/15 of both out-of-plane walls' mass
    (`density` [kg m-3], `thickness`, `height` and each wall's `wall_length` [m]). [kg]"""
    return EFFECTIVE_MASS * 2.0 * density * thickness * height * wall_length


def effective_diaphragm_mass(diaphragm_weight: float, plan_area: float) -> float:
    """Effective diaphragm mass, Eq. 7: 8/15 of its seismic weight (`diaphragm_weight`
    [kPa] over `plan_area` [m2]) over g. [kg]"""
    return EFFECTIVE_MASS * diaphragm_weight * 1e3 * plan_area / PAPER_G

#: plausible values of a wall (low, high, SI unit): a wall outside them is refused (its
#: numbers are nearly always in another unit: a thickness of 350 is millimetres) unless it
#: is built with ``allow_unusual=True``; a diaphragm mass may also be 0 (none) and a
#: stiffness "rigid"
WALL_RANGES = {
    "thickness": (0.02, 2.0, "m"),
    "height": (0.2, 30.0, "m"),
    "mass": (1.0, 1e7, "kg"),
    "bottom_mass": (1.0, 1e8, "kg"),
    "top_mass": (1.0, 1e8, "kg"),
    "bottom_stiffness": (1e2, 1e12, "N m-1"),
    "top_stiffness": (1e2, 1e12, "N m-1"),
}
#: largest plausible slenderness h/t of a one-way spanning URM wall: walls of the paper's
#: parametric study reach 24, and masonry codes cap h/t of loadbearing walls near 25-30
#: (e.g. AS 3700's slenderness limit of 27); above 40 a value is nearly always a
#: thickness or height in another unit. Refused unless ``allow_unusual``.
MAX_SLENDERNESS = 40.0
#: highest plausible frequency of a flexible (timber) diaphragm [Hz]: the paper's timber
#: diaphragms D1-D4 (Table IV) lie below 10 Hz; a stiffer support is a rigid one
#: (``diaphragm_stiffness = "rigid"``). Refused unless ``allow_unusual``.
MAX_DIAPHRAGM_FREQUENCY = 20.0
# units a value out of range may have been given in: (name, factor to the SI unit)
_OTHER_UNITS = {"m": (("millimetres", 1e-3), ("centimetres", 1e-2)),
                "kg": (("grams", 1e-3), ("tonnes", 1e3)),
                "N m-1": (("kN/m", 1e3),)}
_ALLOW_UNUSUAL = contextvars.ContextVar("urmx_allow_unusual_walls", default=False)


@contextlib.contextmanager
def allow_unusual_walls():
    """Within this block every `Wall` is built as with ``allow_unusual=True`` (the
    command line's ``--allow-unusual``): values outside `WALL_RANGES` are accepted, and
    the walls that have such values keep ``allow_unusual=True``."""
    token = _ALLOW_UNUSUAL.set(True)
    try:
        yield
    finally:
        _ALLOW_UNUSUAL.reset(token)


def _range_problem(name: str, value: Any) -> str | None:
    """Why a wall value lies outside `WALL_RANGES` (with the unit it was likely given
    in), or None."""
    if name not in WALL_RANGES or _is_rigid(value) or (value == 0.0 and name.endswith("_mass")):
        return None
    lo, hi, unit = WALL_RANGES[name]
    if lo <= value <= hi:
        return None
    fits = [f"in {other}? {value:g} {other} is {value * f:g} {unit}"
            for other, f in _OTHER_UNITS[unit] if lo <= value * f <= hi]
    hint = f" ({'; '.join(fits)})" if fits else ""
    zero = " (or 0: no diaphragm)" if name.endswith("_mass") and name != "mass" else ""
    rigid = ' (or "rigid")' if name.endswith("_stiffness") else ""
    return (f"Wall {name}={value:g} {unit} lies outside the plausible {lo:g}-{hi:g} "
            f"{unit}{zero}{rigid}{hint}: give SI units, or build the wall with "
            "allow_unusual=True (--allow-unusual) to run it on purpose")

# ---- layout of the parameter vector ------------------------------------------------
P_B, P_H, P_A1, P_A2, P_M1, P_M2, P_MDB, P_MDT = range(8)
P_KDB, P_KDT, P_CB, P_CT, P_G, P_RIGID_B, P_RIGID_T, P_KAPPA, P_PMR = range(8, 17)
P_CASE = 17  # case k (1, 2, 3) occupies P_CASE + 5*(k-1) .. +4: M0, theta0, Mi, theta_a, theta_b
N_PARAMS = P_CASE + 15


class Segment(NamedTuple):
    """Trilinear resistance of one segment case (Table I, Fig. 2)."""

    M0: float  # rigid bilinear strength [N m]
    theta0: float  # instability rotation [rad]
    Mi: float  # plateau strength 0.009*PMR*M0 [N m]
    theta_a: float  # end of the initial linear branch, kappa*theta0 [rad]
    theta_b: float  # start of the softening branch, theta0*(1 - Mi/M0) [rad]


def _is_rigid(value: Any) -> bool:
    return isinstance(value, str) and value.strip().lower() == RIGID


def _building_number(name: str, value: Any, zero: bool = False) -> float:
    """A building term of `Wall.in_building` as a float: a finite positive number (or
    non-negative with `zero`), else an InputError naming it."""
    ok = isinstance(value, (int, float, np.integer, np.floating)) \
        and not isinstance(value, bool) and math.isfinite(value) \
        and (value >= 0.0 if zero else value > 0.0)
    if not ok:
        sign = "non-negative" if zero else "positive"
        raise InputError(f"Wall.in_building {name}={value!r} must be a {sign} number")
    return float(value)


def _diaphragm_spring(stiffness: Any, frequency: Any, diaphragm_mass: float, wall_mass: float,
                      allow_unusual: bool) -> float | str:
    """The diaphragm's stiffness for `Wall.in_building`: as given (rigid for "rigid"), or
    from its frequency as an SDOF of the diaphragm mass plus half the wall's (Table IV
    footnote), refused above `MAX_DIAPHRAGM_FREQUENCY` unless allowed. [N m-1]"""
    if frequency is None:
        return RIGID if _is_rigid(stiffness) else stiffness
    f = _building_number("diaphragm_frequency", frequency)
    if f > MAX_DIAPHRAGM_FREQUENCY and not (allow_unusual or _ALLOW_UNUSUAL.get()):
        raise InputError(
            f"Wall.in_building diaphragm_frequency={f:g} Hz lies above the "
            f"{MAX_DIAPHRAGM_FREQUENCY:g} Hz a flexible timber diaphragm can have: "
            'for a support that stiff use a rigid one (diaphragm_stiffness = "rigid"),'
            " or pass allow_unusual=True (--allow-unusual) to run it on purpose")
    return (2.0 * math.pi * f) ** 2 * (diaphragm_mass + 0.5 * wall_mass)


@dataclass(frozen=True)
class Wall:
    """One cracked URM wall and its bottom and top supports (MODEL.md sections 1-3).

    Parameters
    ----------
    thickness : float
        Wall thickness b. [m]
    height : float
        Wall (storey) height h. [m]
    crack_ratio : float
        Crack height over wall height, eta = a1/h, in (0, 1). [1]
    mass : float
        Wall mass m (effective for building walls, nominal for test specimens). [kg]
    bottom_mass, top_mass : float
        Effective masses of the bottom and top diaphragms. [kg]
    bottom_stiffness, top_stiffness : float or "rigid"
        Effective in-plane stiffness of the supports. ``"rigid"`` removes the degree of
        freedom (a constraint, MODEL.md section 6), it is not a stiff spring. [N m-1]
    bottom_damping, top_damping : float
        Viscous damping ratios of dashpots beside the diaphragm springs. [1]
    pmr : float
        Percentage of maximum rigid resistance, in (0, 100]. [%]
    kappa : float
        theta_a / theta0 of the trilinear curve. [1]
    allow_unusual : bool, keyword only
        Accept values outside `WALL_RANGES` (a wall of 1 um or 100 km, a thickness of
        350 that is surely millimetres), which are refused otherwise. Left out of
        :meth:`to_dict` (and so of study keys) while False.

    Raises
    ------
    urmx.errors.InputError
        A field that is missing, unknown (the message lists the fields), not a number,
        out of its range (with the range and the unit it was likely given in), or a pmr
        and kappa that leave no plateau.
    """

    thickness: float
    height: float
    crack_ratio: float
    mass: float
    bottom_mass: float = 0.0
    top_mass: float = 0.0
    bottom_stiffness: float | str = RIGID
    top_stiffness: float | str = RIGID
    bottom_damping: float = 0.0
    top_damping: float = 0.0
    pmr: float = 75.0
    kappa: float = 0.04
    allow_unusual: bool = field(default=False, kw_only=True, repr=False, compare=False)
    _params: np.ndarray = field(init=False, repr=False, compare=False, hash=False)

    def __post_init__(self) -> None:
        def number(name: str, *, positive: bool = False, allow_rigid: bool = False) -> None:
            value = getattr(self, name)
            if allow_rigid and _is_rigid(value):
                object.__setattr__(self, name, RIGID)
                return
            if isinstance(value, bool) or not isinstance(value, (int, float, np.floating,
                                                                   np.integer)):
                hint = ' (a number or "rigid")' if allow_rigid else " (a number)"
                raise InputError(f"Wall {name}={value!r} is not valid{hint}")
            value = float(value)
            if not math.isfinite(value):
                raise InputError(f"Wall {name}={value!r} must be a finite number")
            if positive and value <= 0.0:
                raise InputError(f"Wall {name}={value!r} must be greater than zero")
            if not positive and value < 0.0:
                raise InputError(f"Wall {name}={value!r} must not be negative")
            object.__setattr__(self, name, value)

        for name in ("thickness", "height", "mass"):
            number(name, positive=True)
        for name in ("bottom_mass", "top_mass", "bottom_damping", "top_damping"):
            number(name)
        for name in ("bottom_damping", "top_damping"):
            if getattr(self, name) > 1.0:
                raise InputError(f"Wall {name}={getattr(self, name)!r} is a damping ratio above 1 "
                                 f"(overdamped): give it as a ratio, e.g. 0.12 for 12 %")
        for name in ("bottom_stiffness", "top_stiffness"):
            number(name, positive=True, allow_rigid=True)
        if not isinstance(self.allow_unusual, bool):
            raise InputError(f"Wall allow_unusual={self.allow_unusual!r} must be true or false")
        problems = [p for p in (_range_problem(n, getattr(self, n)) for n in WALL_RANGES) if p]
        slender = self.height / self.thickness
        if slender > MAX_SLENDERNESS and not problems:
            problems.append(f"Wall slenderness height/thickness = {self.height:g}/"
                            f"{self.thickness:g} = {slender:.3g} lies above the plausible "
                            f"{MAX_SLENDERNESS:g} of a URM wall (a thickness or height in "
                            "another unit?): check them, or build the wall with "
                            "allow_unusual=True (--allow-unusual) to run it on purpose")
        if problems:
            if not (self.allow_unusual or _ALLOW_UNUSUAL.get()):
                raise InputError(problems[0])
            object.__setattr__(self, "allow_unusual", True)  # kept by replace()
        number("crack_ratio", positive=True)
        if not 0.0 < self.crack_ratio < 1.0:
            raise InputError(f"Wall crack_ratio={self.crack_ratio!r} must lie in (0, 1)")
        number("pmr", positive=True)
        if not 0.0 < self.pmr <= 100.0:
            raise InputError(f"Wall pmr={self.pmr!r} must lie in (0, 100] (percent)")
        number("kappa", positive=True)
        limit = 1.0 - 0.009 * self.pmr
        # relative margin: 1 - 0.009*pmr is not exact in binary (pmr 75 gives 0.325 + 1 ulp)
        if self.kappa >= limit * (1.0 - 1e-12):
            raise InputError(
                f"Wall kappa={self.kappa!r} puts theta_a at or beyond theta_b "
                f"(with pmr={self.pmr:g} kappa must be below 1 - 0.009*pmr = {limit:.4g})"
            )
        object.__setattr__(self, "_params", _pack(self))

    # ---- derived quantities ---------------------------------------------------------
    @property
    def a1(self) -> float:
        """Height of the lower segment, eta*h. [m]"""
        return self.crack_ratio * self.height

    @property
    def a2(self) -> float:
        """Height of the upper segment, h - a1. [m]"""
        return self.height - self.a1

    @property
    def bottom_rigid(self) -> bool:
        return self.bottom_stiffness == RIGID

    @property
    def top_rigid(self) -> bool:
        return self.top_stiffness == RIGID

    @property
    def slenderness(self) -> float:
        return self.height / self.thickness

    @property
    def params(self) -> np.ndarray:
        """Flat float64 parameter vector used by the kernel and the reference solver."""
        return self._params

    def segment(self, case: int) -> Segment:
        """Trilinear data of segment case 1 (upper), 2 (lower, family 2) or 3 (lower,
        family 1), MODEL.md section 3 / the paper's Tables I and III.

        Parameters
        ----------
        case : {1, 2, 3}
            The segment case of the paper's Table I.
        """
        if case not in (1, 2, 3):
            raise InputError(f"segment case must be 1, 2 or 3, not {case!r}")
        i = P_CASE + 5 * (case - 1)
        return Segment(*(float(v) for v in self._params[i : i + 5]))

    def diaphragm_frequency(self, where: str = "top") -> float:
        """Indicative frequency of a diaphragm as an SDOF (Table IV footnote):
        stiffness over (diaphragm mass + half the wall mass). [Hz]

        Parameters
        ----------
        where : {"top", "bottom"}
            Which diaphragm.
        """
        k = self.top_stiffness if where == "top" else self.bottom_stiffness
        md = self.top_mass if where == "top" else self.bottom_mass
        if k == RIGID:
            return math.inf
        return math.sqrt(k / (md + 0.5 * self.mass)) / (2.0 * math.pi)

    def to_dict(self) -> dict[str, Any]:
        """The fields as a dict (``allow_unusual`` only when True: an ordinary wall's dict,
        which keys saved study batches, is what it always was)."""
        d = asdict(self)
        d.pop("_params", None)
        if not d["allow_unusual"]:
            del d["allow_unusual"]
        return d

    def replace(self, **changes: Any) -> Wall:
        """A copy of the wall with some fields changed (checked as a new `Wall`).

        Parameters
        ----------
        **changes
            `Wall` fields and their new values, in the fields' units (``thickness=0.35`` [m]).
        """
        d = self.to_dict()
        d.update(changes)
        return Wall(**d)


    @classmethod
    def in_building(cls, *, thickness: float, height: float, crack_ratio: float,
                    density: float, wall_length: float, diaphragm_weight: float,
                    plan_area: float, diaphragm_stiffness: float | str | None = None,
                    diaphragm_frequency: float | None = None, supports: str = "top",
                    damping: float = 0.12, pmr: float = 75.0, kappa: float = 0.04,
                    allow_unusual: bool = False) -> Wall:
        """A wall of a building between timber diaphragms, with the effective masses of
        Eq. 7 (MODEL.md section 2): 8/15 of the two out-of-plane walls' mass and of the
        diaphragm's seismic weight over g (the catalog's parametric walls, D1-D5).

        Parameters
        ----------
        thickness, height : float
            Wall thickness and storey height. [m]
        crack_ratio : float
            Crack height over wall height. [1]
        density : float
            Masonry density. [kg m-3]
        wall_length : float
            Length of each of the two out-of-plane walls at the diaphragm's ends. [m]
        diaphragm_weight : float
            Diaphragm seismic weight per plan area. [kPa]
        plan_area : float
            Plan area of the diaphragm. [m2]
        diaphragm_stiffness : float or "rigid", optional
            Effective in-plane stiffness of the diaphragm. [N m-1]
        diaphragm_frequency : float, optional
            Instead of the stiffness: the diaphragm's indicative frequency as the catalog
            defines it (Table IV footnote, :meth:`diaphragm_frequency`): stiffness
            ``(2 pi f)^2 (m_d + m/2)`` with the effective diaphragm and wall masses. [Hz]
        supports : {"top", "both"}
            ``"top"``: a single storey, the ground is the rigid bottom support; ``"both"``:
            a higher storey between two diaphragms alike.
        damping : float
            Damping ratio of each flexible diaphragm's dashpot (0 for a rigid one). [1]
        pmr, kappa, allow_unusual
            As for `Wall`.

        Returns
        -------
        Wall
            Bitwise the wall the catalog builds for a parametric wall on a diaphragm
            (`urmx.study.file.Study.wall`).
        """
        positive = _building_number
        density = positive("density", density)
        wall_length = positive("wall_length", wall_length)
        diaphragm_weight = positive("diaphragm_weight", diaphragm_weight, zero=True)
        plan_area = positive("plan_area", plan_area)
        if supports not in ("top", "both"):
            raise InputError(f"Wall.in_building supports={supports!r} must be 'top' (single "
                             "storey, rigid ground below) or 'both' (diaphragms below and above)")
        if (diaphragm_stiffness is None) == (diaphragm_frequency is None):
            raise InputError("Wall.in_building: give exactly one of diaphragm_stiffness= "
                             "[N m-1] and diaphragm_frequency= [Hz]")
        for name in ("thickness", "height"):
            positive(name, locals()[name])
        # Eq. 7: the one formula the catalog's building uses too
        mass = effective_wall_mass(density, thickness, height, wall_length)
        md = effective_diaphragm_mass(diaphragm_weight, plan_area)
        k = _diaphragm_spring(diaphragm_stiffness, diaphragm_frequency, md, mass,
                              allow_unusual)
        zeta = 0.0 if _is_rigid(k) else damping
        bottom = (dict(bottom_stiffness=k, bottom_mass=md, bottom_damping=zeta)
                  if supports == "both" else
                  dict(bottom_stiffness=RIGID, bottom_mass=0.0, bottom_damping=0.0))
        return cls(thickness=thickness, height=height, crack_ratio=crack_ratio, mass=mass,
                   top_stiffness=k, top_mass=md, top_damping=zeta, pmr=pmr, kappa=kappa,
                   allow_unusual=allow_unusual, **bottom)


_INIT_FIELDS = tuple(f.name for f in fields(Wall) if f.init)
_POSITIONAL = tuple(f.name for f in fields(Wall) if f.init and not f.kw_only)
_REQUIRED = tuple(f.name for f in fields(Wall) if f.init and f.default is MISSING
                  and f.default_factory is MISSING)
_dataclass_init = Wall.__init__


@functools.wraps(_dataclass_init)
def _checked_init(self, *args, **kwargs):
    """The dataclass's __init__, after checking the call: an unknown, missing or doubled
    field is an InputError naming it (and the fields), never a TypeError."""
    if len(args) > len(_POSITIONAL):
        raise InputError(f"Wall takes at most {len(_POSITIONAL)} values by position "
                         f"({', '.join(_POSITIONAL)}), not {len(args)}")
    unknown = sorted(set(kwargs) - set(_INIT_FIELDS))
    if unknown:
        close = difflib.get_close_matches(unknown[0], _INIT_FIELDS, n=2)
        hint = f" (did you mean {' or '.join(map(repr, close))}?)" if close else ""
        raise InputError(f"Wall has no field {unknown[0]!r}{hint}; its fields: "
                         f"{', '.join(_INIT_FIELDS)}")
    twice = [n for n in _POSITIONAL[:len(args)] if n in kwargs]
    if twice:
        raise InputError(f"Wall {twice[0]} is given twice (by position and by name)")
    missing = [n for n in _REQUIRED if n not in kwargs and n not in _POSITIONAL[:len(args)]]
    if missing:
        raise InputError(f"Wall needs {', '.join(missing)} (missing)")
    _dataclass_init(self, *args, **kwargs)


Wall.__init__ = _checked_init


def _pack(w: Wall) -> np.ndarray:
    p = np.zeros(N_PARAMS)
    b, h = w.thickness, w.height
    a1 = w.crack_ratio * h
    a2 = h - a1
    m1 = w.mass * a1 / h
    m2 = w.mass * a2 / h
    mdb, mdt = w.bottom_mass, w.top_mass
    rb, rt = w.bottom_stiffness == RIGID, w.top_stiffness == RIGID
    kdb = 0.0 if rb else float(w.bottom_stiffness)
    kdt = 0.0 if rt else float(w.top_stiffness)
    # dashpots beside the springs (MODEL.md section 5)
    cb = 0.0 if rb else 2.0 * w.bottom_damping * math.sqrt(kdb * (mdb + 0.5 * w.mass))
    ct = 0.0 if rt else 2.0 * w.top_damping * math.sqrt(kdt * (mdt + 0.5 * w.mass))
    p[:P_CASE] = (b, h, a1, a2, m1, m2, mdb, mdt, kdb, kdt, cb, ct, PAPER_G, float(rb), float(rt),
                  w.kappa, w.pmr)
    # Table I, specific forms (MODEL.md section 3)
    cases = (
        ((0.5 * m2 + 0.5 * mdt) * b * PAPER_G, b / (2 * a2) * (m2 + mdt) / (0.5 * m2 + mdt)),
        ((0.5 * m1 + m2 + mdt) * b * PAPER_G, b / a1),
        (0.5 * m1 * b * PAPER_G, b / (2 * a1) * m1 / (0.5 * m1 + m2 + mdt)),
    )
    for k, (M0, theta0) in enumerate(cases):
        Mi = 0.009 * w.pmr * M0
        p[P_CASE + 5 * k : P_CASE + 5 * k + 5] = (
            M0, theta0, Mi, w.kappa * theta0, theta0 * (1.0 - Mi / M0))
    return p


# ---- builders shared by the kernel and the reference solver ----------------------------
# The few functions the integration loop calls at events are compiled (numba) as part of
# the kernel's entry points, which alone are cached on disk (urmx.jitcache); the matrices
# of the pieces are built once per wall in numpy (they are not in any loop).
_compiled = jit(cache=False, no_cpython_wrapper=True, no_cfunc_wrapper=True)
_inlined = jit(cache=False, no_cpython_wrapper=True, no_cfunc_wrapper=True, forceinline=True)

@_inlined
def lower_case(family):
    """Segment case of the lower segment: Case 3 in family 1, Case 2 in family 2."""
    return 3 if family == 1 else 2


@_inlined
def curve(P, case):
    """(M0, theta0, Mi, theta_a, theta_b) of a segment case."""
    i = P_CASE + 5 * (case - 1)
    return P[i], P[i + 1], P[i + 2], P[i + 3], P[i + 4]


@_compiled
def classify(P, case, theta, rate):
    """Signed branch of theta on a curve; on a boundary the side it is moving to wins."""
    M0, theta0, Mi, ta, tb = curve(P, case)
    a = abs(theta)
    tol = 1e-13 * theta0
    s = 1 if theta > 0 else -1
    if theta == 0.0:
        return 0
    outward = rate * s > 0
    if a < ta - tol or (a <= ta + tol and not outward):
        return 0
    if a < tb - tol or (a <= tb + tol and not outward):
        return s
    return 2 * s


def _curve(P, case):
    i = P_CASE + 5 * (case - 1)
    return tuple(float(x) for x in P[i:i + 5])


def branch_coeffs(P, case, branch):
    """Resistance on a signed branch as R = k*theta + r0, each branch continued smoothly.

    branch 0: |theta| <= theta_a (slope Mi/theta_a); +-1: plateau +-Mi;
    +-2: softening M0*sign*(1 - |theta|/theta0), slope -M0/theta0 (the paper's K_G).
    """
    M0, theta0, Mi, ta, tb = _curve(P, case)
    if branch == 0:
        return Mi / ta, 0.0
    sgn = 1.0 if branch > 0 else -1.0
    if abs(branch) == 1:
        return 0.0, sgn * Mi
    return -M0 / theta0, sgn * M0


def potential(P, case, theta):
    """Strain energy of the trilinear curve, integral of R from 0 to theta. [J]"""
    M0, theta0, Mi, ta, tb = _curve(P, case)
    a = abs(theta)
    if a <= ta:
        return 0.5 * Mi * a * a / ta
    e = 0.5 * Mi * ta
    if a <= tb:
        return e + Mi * (a - ta)
    e += Mi * (tb - ta)
    return e + M0 * ((a - tb) - 0.5 * (a * a - tb * tb) / theta0)


def n_dof(P):
    """Number of reduced coordinates of the support case (MODEL.md section 6)."""
    return 3 - int(P[P_RIGID_B]) - int(P[P_RIGID_T])


# held joints (MODEL.md section 4): none, the base joint, the crack joint, both
HELD_NONE, HELD_BASE, HELD_CRACK, HELD_BOTH = 0, 1, 2, 3


def transform(P, held=HELD_NONE):
    """q = T r for the support case (MODEL.md section 6 table), times the constraint of
    the held joints (section 4): a held base joint removes theta1 (theta1 = 0), a held
    crack joint merges theta2 into theta1 (theta2 = theta1), one coordinate fewer each.
    With both supports rigid the two joints are one coordinate: any hold removes it."""
    rb = P[P_RIGID_B] > 0.5
    rt = P[P_RIGID_T] > 0.5
    a1, a2 = P[P_A1], P[P_A2]
    n = n_dof(P)
    T = np.zeros((3, n))
    if not rb and not rt:
        T[0, 0] = T[1, 1] = T[2, 2] = 1.0
    elif rb and not rt:
        T[0, 0] = T[1, 1] = 1.0
    elif rt and not rb:
        T[0, 0] = T[1, 1] = 1.0
        T[2, 0] = -a1
        T[2, 1] = -a2
    else:
        T[0, 0] = 1.0
        T[1, 0] = -a1 / a2
    return T @ held_map(P, held)


def held_map(P, held):
    """r = N y: the support-reduced coordinates r from the coordinates y of a held state."""
    n = n_dof(P)
    if n == 1:
        return np.eye(1) if held == HELD_NONE else np.zeros((1, 0))
    eye = np.eye(n)
    if held == HELD_NONE:
        return eye
    if held == HELD_BASE:
        return eye[:, 1:]
    if held == HELD_CRACK:
        N = eye[:, [0] + list(range(2, n))]
        N[1, 0] = 1.0
        return N
    return eye[:, 2:]


def full_mass(P, family):
    """M_f of Eq. 1 (family 1) or Eq. 2 (family 2), with M13 from the Lagrangian (sec. 9)."""
    b, a1, a2 = P[P_B], P[P_A1], P[P_A2]
    m1, m2, mdb, mdt = P[P_M1], P[P_M2], P[P_MDB], P[P_MDT]
    Io1 = m1 * (a1 * a1 + b * b) / 3.0
    Io2 = m2 * (a2 * a2 + b * b) / 3.0
    M = np.zeros((3, 3))
    if family == 1:
        M[0, 0] = Io1 + (m2 + mdt) * a1 * a1
        M[0, 1] = a1 * a2 * (0.5 * m2 + mdt)
    else:
        M[0, 0] = Io1 + (m2 + mdt) * (b * b + a1 * a1)
        M[0, 1] = a1 * a2 * (0.5 * m2 + mdt) - (m2 + mdt) * b * b / 2.0
    M[0, 2] = (0.5 * m1 + m2 + mdt) * a1
    M[1, 1] = Io2 + mdt * (0.25 * b * b + a2 * a2)
    M[1, 2] = (0.5 * m2 + mdt) * a2
    M[2, 2] = m1 + m2 + mdb + mdt
    M[1, 0] = M[0, 1]
    M[2, 0] = M[0, 2]
    M[2, 1] = M[1, 2]
    return M


def system(P, family, bl, bu, held=HELD_NONE):
    """Reduced matrices of one piece (family, lower branch, upper branch, held joints).

    Returns M, C, K, R0, MinvG, Minv with the reduced equation
    ``M y_dd + C y_d + K y + R0 = -G xg_dd`` (G = T^T M_f[:, 2], T of :func:`transform`)
    and MinvG = M^-1 G. While u_b is a free coordinate (both supports flexible) MinvG is
    its unit vector exactly (MODEL.md section 5: the ground drives u_b alone).
    """
    T = transform(P, held)
    n = T.shape[1]
    a1, a2 = P[P_A1], P[P_A2]
    Mf = full_mass(P, family)
    v = np.array([a1, a2, 1.0])
    e3 = np.array([0.0, 0.0, 1.0])
    KD = P[P_KDT] * np.outer(v, v) + P[P_KDB] * np.outer(e3, e3)
    Cq = P[P_CT] * np.outer(v, v) + P[P_CB] * np.outer(e3, e3)
    k1, r1 = branch_coeffs(P, 3 if family == 1 else 2, bl)
    k2, r2 = branch_coeffs(P, 1, bu)
    KD[0, 0] += k1
    KD[1, 1] += k2
    R0q = np.array([r1, r2, 0.0])
    M = T.T @ Mf @ T
    C = T.T @ Cq @ T
    K = T.T @ KD @ T
    R0 = T.T @ R0q
    Gv = T.T @ Mf[:, 2]
    Minv = np.linalg.inv(M) if n else np.zeros((0, 0))
    free_ub = P[P_RIGID_B] < 0.5 and P[P_RIGID_T] < 0.5
    if free_ub:
        MinvG = np.zeros(n)
        MinvG[n - 1] = 1.0  # u_b is the last coordinate of every held state
    else:
        MinvG = Minv @ Gv
    return M, C, K, R0, MinvG, Minv
