"""The sampler of a sampling study: which model parameters can be sampled and what each
does to a cell (`PARAMETERS`, :func:`apply`), the ``[study.sampling]`` settings
(:func:`parse_sampling`) and their seeded draw (:meth:`Sampling.draw`: a Latin hypercube or
Sobol' sequence of scipy.stats.qmc, Saltelli's design of SALib, or numpy's random points).

The parameters
--------------
======================  =========  ========================================================
parameter               as         replaces
======================  =========  ========================================================
``cor``                 value      the study's coefficient of restitution, in (0, 1]
``impact``              value      the study's impact law (``scale``, ``contact``; a
                                   ``choice``)
``pmr``                 value      the wall's PMR, in (0, 100] [%], with the wall's
                                   ``kappa < 1 - 0.009 pmr``
``crack_ratio``         value      the wall's crack height over its height, in (0, 1)
``kappa``               value      the wall's theta_a / theta0, in (0, 1)
``mass``                factor     the wall's mass times the factor, > 0
``stiffness``           factor     each flexible support's stiffness times the factor, > 0
``frequency``           factor     each flexible support's stiffness set so that its
                                   frequency (Table IV footnote: stiffness over the
                                   support's mass plus half the wall's) is the factor
                                   times the study's, > 0
``damping``             value      each flexible support's damping ratio, in [0, 1]
``thickness``           value      the wall's thickness [m] (a *wall drawn in geometry*)
``height``              value      the wall's height [m]
``overburden_ratio``    value      O/W: the top diaphragm's effective mass (the overburden
                                   of Table I) over the wall's effective mass, >= 0
``diaphragm_weight``    value      the diaphragm's seismic weight [kPa] (paper Section
                                   3.2); with ``overburden_ratio`` it sets the tributary
                                   plan area only (below)
``diaphragm_frequency`` value      each flexible support's frequency [Hz] (Table IV
                                   footnote), absolute rather than a factor
``rigid_top``           value      1: the diaphragms are rigid (a ``bernoulli``: a share of
                                   rigid tops), 0: flexible
``storey``              value      ``single`` (rigid ground below, a diaphragm above) or
                                   ``higher`` (between two diaphragms alike; a ``choice``)
======================  =========  ========================================================

A *wall drawn in geometry* (any of the last seven parameters sampled) is rebuilt from the
cell's wall as `urmx.Wall.in_building` builds a building's wall: its effective mass is the
cell's mass per unit of thickness times height (the building's density, wall length and the
8/15 of Eq. 7) times the sampled ``thickness * height``; the top diaphragm's effective
mass is ``overburden_ratio`` times that mass (Table I's psi = O/W of the whole wall; the
cell's own diaphragm mass when not sampled); a flexible diaphragm's stiffness is
``(2 pi f)^2 (m_d + m/2)`` for the sampled ``diaphragm_frequency`` ``f`` (the cell's own
stiffness when not sampled); ``storey`` sets the bottom support (a higher storey's bottom
diaphragm is the top's: same mass, stiffness and damping); ``rigid_top = 1`` makes both
diaphragms rigid. In this model the diaphragm's effective mass is both its inertia and
the wall's overburden, and every force scales with the masses (the spring's stiffness with
them, for a sampled frequency), so once O/W and the frequency are drawn the diaphragm's
seismic weight changes nothing in the analysis: it sets the tributary plan area
``A = m_d g / (8/15 q)`` an engineer would read the wall from, kept as a sampled input.
``[study.sampling] max_slenderness`` leaves out the walls with ``height / thickness``
above it: the design is drawn larger until ``samples`` walls pass, and the first
``samples`` that pass are kept, in the design's order.

A *factor* multiplies the cell's own value (the walls and diaphragms of a study differ, so
one absolute value could not serve them all): ``frequency = 1.1`` makes every flexible
diaphragm 10 % stiffer in frequency, 21 % in stiffness. ``stiffness`` and ``frequency``
are two ways to say the same and cannot both be sampled. A rigid support stays rigid.

The design
----------
``method`` ``"lhs"`` (default: scipy's Latin hypercube, one stratum of each parameter per
sample), ``"sobol"`` (scipy's scrambled Sobol' sequence; ``samples`` a power of 2),
``"random"`` (numpy's default generator), or ``"saltelli"`` (SALib's extension of the
Sobol' sequence for first-order and total Sobol' indices: ``samples`` = N, a power of 2,
gives N (D + 2) samples for D parameters, in SALib's order). Every design is drawn on the
unit hypercube (one column per parameter, in the order of the study file's table) from the
``seed`` and mapped through each parameter's distribution
(`urmx.uncertainty.distributions`): the same settings give the same samples, bit for bit.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..errors import InputError
from ..model import RIGID, Wall
from .distributions import Distribution, ParameterError, parse_distribution

IMPACT_LAWS = ("scale", "contact")  # as urmx.catalog.IMPACT_LAWS (MODEL.md section 8)


@dataclass(frozen=True)
class Target:
    """What a sampled parameter changes.

    Attributes
    ----------
    on : str
        ``"kernel"`` (an argument of the analysis), ``"wall"`` (a wall field) or
        ``"support"`` (each flexible support of the wall).
    factor : bool
        A multiplier of the cell's own value (else the value itself).
    low, high : float
        Its valid range; ``closed`` says which ends belong to it (``"[]"``, ``"(]"``,
        ``"()"``).
    units : str
        Units of the value (``"1"`` for factors). [UDUNITS]
    long_name : str
        What it is, for coordinates and reports.
    """

    on: str
    factor: bool
    low: float
    high: float
    closed: str
    units: str
    long_name: str

    def problem(self, value: Any) -> str | None:
        """Why `value` lies outside the valid range (None when inside)."""
        if isinstance(value, str) or value is None:
            return None
        lo_ok = value >= self.low if self.closed[0] == "[" else value > self.low
        hi_ok = value <= self.high if self.closed[1] == "]" else value < self.high
        if lo_ok and hi_ok and math.isfinite(value):
            return None
        hi = "inf" if math.isinf(self.high) else f"{self.high:g}"
        return f"{value:g} lies outside its valid range {self.closed[0]}{self.low:g}, {hi}" \
               f"{self.closed[1]}"


#: the parameters a sampling study can sample, in the order of the module docstring
PARAMETERS: dict[str, Target] = {
    "cor": Target("kernel", False, 0.0, 1.0, "(]", "1", "coefficient of restitution"),
    "impact": Target("kernel", False, math.nan, math.nan, "[]", "", "impact law"),
    "pmr": Target("wall", False, 0.0, 100.0, "(]", "%", "percentage of maximum rigid "
                  "resistance"),
    "crack_ratio": Target("wall", False, 0.0, 1.0, "()", "1", "crack height over wall "
                          "height"),
    "kappa": Target("wall", False, 0.0, 1.0, "()", "1", "theta_a over theta0 of the "
                    "trilinear curve"),
    "mass": Target("wall", True, 0.0, math.inf, "()", "1", "factor on the wall's mass"),
    "stiffness": Target("support", True, 0.0, math.inf, "()", "1", "factor on each "
                        "flexible support's stiffness"),
    "frequency": Target("support", True, 0.0, math.inf, "()", "1", "factor on each "
                        "flexible support's frequency"),
    "damping": Target("support", False, 0.0, 1.0, "[]", "1", "damping ratio of each "
                      "flexible support"),
    "thickness": Target("geometry", False, 0.0, math.inf, "()", "m", "wall thickness"),
    "height": Target("geometry", False, 0.0, math.inf, "()", "m", "wall height"),
    "overburden_ratio": Target("geometry", False, 0.0, math.inf, "[)", "1",
                               "overburden over wall weight O/W (top diaphragm effective "
                               "mass over wall effective mass)"),
    "diaphragm_weight": Target("geometry", False, 0.0, math.inf, "()", "kPa",
                               "diaphragm seismic weight per plan area"),
    "diaphragm_frequency": Target("geometry", False, 0.0, math.inf, "()", "Hz",
                                  "frequency of each flexible diaphragm (Table IV "
                                  "footnote)"),
    "rigid_top": Target("geometry", False, 0.0, 1.0, "[]", "1",
                        "1 where the diaphragms are rigid, else 0"),
    "storey": Target("geometry", False, math.nan, math.nan, "[]", "",
                     "single storey or higher storey between two diaphragms alike"),
}
#: the parameters that draw a wall in geometry (module docstring)
GEOMETRY = tuple(k for k, t in PARAMETERS.items() if t.on == "geometry")
STOREYS = ("single", "higher")
METHODS = ("lhs", "sobol", "random", "saltelli")
#: the keys of the [study.sampling] table
KEYS = ("samples", "seed", "method", "parameters", "max_slenderness")


def coordinate_name(parameter: str) -> str:
    """The name of a sampled parameter's coordinate in an archive: the parameter's, with
    ``_factor`` for a factor (``frequency_factor``: a wall's ``mass`` and a diaphragm's
    ``frequency`` are coordinates of their own).

    Parameters
    ----------
    parameter : str
        A sampled parameter's name (`PARAMETERS`).
    """
    return f"{parameter}_factor" if PARAMETERS[parameter].factor else parameter


def _check_parameter(name: str, dist: Distribution) -> None:
    """A distribution's bounds (where it has them) within the parameter's valid range."""
    target = PARAMETERS[name]
    if name == "storey":
        if dist.kind != "choice" or any(v not in STOREYS for v in dist.values):
            raise ParameterError("values" if dist.kind == "choice" else "distribution",
                                 "storey is drawn as a choice of "
                                 f"{', '.join(STOREYS)} (values = [\"single\", "
                                 "\"higher\"])")
        return
    if name == "impact":
        if dist.kind != "choice" or any(v not in IMPACT_LAWS for v in dist.values):
            raise ParameterError("values" if dist.kind == "choice" else "distribution",
                                 f"impact is drawn as a choice of the impact laws "
                                 f"{', '.join(IMPACT_LAWS)} (values = [\"scale\", "
                                 "\"contact\"])")
        return
    if dist.kind == "choice" and any(isinstance(v, str) for v in dist.values):
        raise ParameterError("values", f"{name} takes numbers, not {list(dist.values)!r}")
    low, high = dist.bounds
    for key, value in (("low", low), ("high", high)):
        if dist.kind == "lognormal" and value == 0.0:  # it never draws 0
            continue
        if value is not None and math.isfinite(value):
            problem = target.problem(value)
            if problem:
                raise ParameterError("values" if dist.kind == "choice" else key,
                                     f"{name}: {key}={problem}")


@dataclass(frozen=True)
class Sampling:
    """The ``[study.sampling]`` table: the design and the parameters' distributions.

    Parameters
    ----------
    samples : int
        Number of samples (``saltelli``: N, drawing N (D + 2) samples).
    seed : int
        Seed of the design. [1]
    method : str
        ``lhs``, ``sobol``, ``random`` or ``saltelli``.
    parameters : dict of str to Distribution
        Each sampled parameter's distribution, in the study file's order.
    max_slenderness : float, optional
        Leave out the walls with ``height / thickness`` above it (module docstring).
    """

    samples: int
    seed: int
    method: str = "lhs"
    parameters: dict[str, Distribution] = field(default_factory=dict)
    max_slenderness: float | None = None

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(self.parameters)

    @property
    def size(self) -> int:
        """Number of samples drawn (the archive's ``sample`` dimension)."""
        if self.method == "saltelli":
            return self.samples * (len(self.parameters) + 2)
        return self.samples

    def unit(self) -> np.ndarray:
        """The design on the unit hypercube, shape (:attr:`size`, parameters). [1]"""
        return unit_design(self.samples, len(self.parameters), self.method, self.seed)

    def draw(self) -> tuple[np.ndarray, dict[str, np.ndarray]]:
        """(the unit design, each parameter's values over the samples); with
        ``max_slenderness`` the first `samples` walls of a larger design that pass it."""
        n = self.samples
        while True:
            u = unit_design(n, len(self.parameters), self.method, self.seed)
            values = {name: dist.ppf(u[:, i]) for i, (name, dist)
                      in enumerate(self.parameters.items())}
            if self.max_slenderness is None:
                return u, values
            keep = np.flatnonzero(values["height"] / values["thickness"]
                                  <= self.max_slenderness)
            if len(keep) >= self.samples:
                keep = keep[:self.samples]
                return u[keep], {k: v[keep] for k, v in values.items()}
            n = 2 * n if self.method == "sobol" else n + max(1, n // 16)

    def to_dict(self) -> dict[str, Any]:
        """The settings as the ``[study.sampling]`` table they were read from."""
        out = {"samples": self.samples, "seed": self.seed, "method": self.method,
               "parameters": {k: d.to_dict() for k, d in self.parameters.items()}}
        if self.max_slenderness is not None:
            out["max_slenderness"] = self.max_slenderness
        return out


def unit_design(n: int, d: int, method: str, seed: int) -> np.ndarray:
    """`n` points (``saltelli``: n (d + 2)) of the unit hypercube of dimension `d`, drawn
    by `method` from `seed` (module docstring). [1]

    Parameters
    ----------
    n : int
        Number of points (``saltelli``: base samples).
    d : int
        Dimension: the number of sampled parameters.
    method : str
        The design (`METHODS`).
    seed : int
        Seed of the design.
    """
    if method == "saltelli":
        from SALib.sample import sobol as saltelli

        problem = {"num_vars": d, "names": [f"x{i}" for i in range(d)],
                   "bounds": [[0.0, 1.0]] * d}
        return np.asarray(saltelli.sample(problem, n, calc_second_order=False, seed=seed),
                          dtype=np.float64)
    rng = np.random.default_rng(seed)
    if method == "random":
        return rng.random((n, d))
    from scipy.stats import qmc

    if method == "sobol":
        return qmc.Sobol(d, scramble=True, seed=rng).random_base2(int(math.log2(n)))
    return qmc.LatinHypercube(d, seed=rng).random(n)


def parse_sampling(table: Any) -> Sampling:
    """The `Sampling` settings of a ``[study.sampling]`` table (module docstring).

    Parameters
    ----------
    table : dict
        The ``[study.sampling]`` table of a study file.

    Raises
    ------
    ParameterError
        With ``key`` the dotted key within the table (``samples``,
        ``parameters.pmr.high``): a missing or unknown key, a bad number, an unknown
        parameter or method, a distribution that is not valid or whose bounds lie outside
        the parameter's valid range, ``stiffness`` and ``frequency`` together.
    """
    if not isinstance(table, dict):
        raise ParameterError("", "must be a table (samples, seed, method, parameters)")
    for k in table:
        if k not in KEYS:
            raise ParameterError(k, f"unknown key (known: {', '.join(KEYS)})")
    for k in ("samples", "seed", "parameters"):
        if k not in table:
            raise ParameterError(k, "missing")
    samples, seed = table["samples"], table["seed"]
    for k, v, low in (("samples", samples, 1), ("seed", seed, 0)):
        if isinstance(v, bool) or not isinstance(v, int) or v < low:
            raise ParameterError(k, f"{v!r} must be a whole number >= {low}")
    method = table.get("method", "lhs")
    if method not in METHODS:
        raise ParameterError("method", f"{method!r} is not one of {', '.join(METHODS)}")
    if method in ("sobol", "saltelli") and samples & (samples - 1):
        raise ParameterError("samples", f"{samples} must be a power of 2 for the "
                             f"{method} method (the Sobol' sequence's balance)")
    params = table["parameters"]
    if not isinstance(params, dict) or not params:
        raise ParameterError("parameters", "must be a table of one inline table per "
                             f"parameter (known: {', '.join(PARAMETERS)})")
    out = {}
    for name, t in params.items():
        if name not in PARAMETERS:
            raise ParameterError(f"parameters.{name}", f"{name!r} cannot be sampled "
                                 f"(known: {', '.join(PARAMETERS)})")
        try:
            dist = parse_distribution(t)
            _check_parameter(name, dist)
        except ParameterError as exc:
            raise ParameterError(f"parameters.{name}" + (f".{exc.key}" if exc.key else ""),
                                 str(exc)) from None
        out[name] = dist
    if "stiffness" in out and "frequency" in out:
        raise ParameterError("parameters.frequency", "stiffness and frequency both set the "
                             "diaphragm's stiffness: sample one of them")
    _check_geometry(out)
    return Sampling(samples=samples, seed=seed, method=method, parameters=out,
                    max_slenderness=_max_slenderness(table, out, method))


def _check_geometry(out: dict[str, Distribution]) -> None:
    """The geometry parameters sampled together as they can be: a frequency set once, the
    diaphragm weight only beside the overburden ratio."""
    if "diaphragm_frequency" in out:
        for other in ("frequency", "stiffness"):
            if other in out:
                raise ParameterError(f"parameters.{other}", f"{other} and "
                                     "diaphragm_frequency both set the diaphragm's "
                                     "stiffness: sample one of them")
    if "diaphragm_weight" in out and "overburden_ratio" not in out:
        raise ParameterError("parameters.diaphragm_weight", "diaphragm_weight is sampled "
                             "beside overburden_ratio (it sets the tributary plan area of "
                             "the diaphragm mass O/W gives)")


def _max_slenderness(table: dict, out: dict[str, Distribution], method: str) -> float | None:
    """``max_slenderness`` of the table: a number above 0, with thickness and height
    sampled and a design that can be drawn larger (not ``saltelli``)."""
    if "max_slenderness" not in table:
        return None
    v = table["max_slenderness"]
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not v > 0:
        raise ParameterError("max_slenderness", f"{v!r} must be a number above 0")
    if "thickness" not in out or "height" not in out:
        raise ParameterError("max_slenderness", "leaves out walls by height / thickness: "
                             "sample both thickness and height")
    if method == "saltelli":
        raise ParameterError("max_slenderness", "a saltelli design cannot leave samples "
                             "out (its points come in blocks): use lhs, sobol or random")
    return float(v)


# ---- a sample applied to a cell ---------------------------------------------------------------

def apply(wall: Wall, values: dict[str, Any]) -> Wall:
    """The wall of a cell with a sample's values (module docstring): wall fields replaced
    or scaled, then each flexible support's stiffness and damping.

    Parameters
    ----------
    wall : Wall
        The study's wall of the cell, on its supports.
    values : dict
        One sample's value of each sampled parameter (``cor`` and ``impact``, which are no
        wall fields, are ignored here).

    Raises
    ------
    urmx.errors.InputError
        The sample makes no valid wall (a PMR that leaves no plateau with the wall's
        kappa, ...): the message of `Wall`.
    """
    if any(k in values for k in GEOMETRY):
        wall = _geometry(wall, values)
    changes: dict[str, Any] = {k: float(values[k]) for k in ("pmr", "crack_ratio", "kappa")
                               if k in values}
    mass = wall.mass * float(values["mass"]) if "mass" in values else wall.mass
    if "mass" in values:
        changes["mass"] = mass
    for side in ("bottom", "top"):
        k = getattr(wall, f"{side}_stiffness")
        if k == RIGID:
            continue
        if "stiffness" in values:
            changes[f"{side}_stiffness"] = k * float(values["stiffness"])
        elif "frequency" in values:
            md = getattr(wall, f"{side}_mass")
            changes[f"{side}_stiffness"] = (k * float(values["frequency"]) ** 2
                                            * (md + 0.5 * mass) / (md + 0.5 * wall.mass))
        if "damping" in values:
            changes[f"{side}_damping"] = float(values["damping"])
    return wall.replace(**changes) if changes else wall


def _geometry(wall: Wall, values: dict[str, Any]) -> Wall:
    """The cell's wall drawn in geometry (module docstring): thickness, height, overburden
    ratio, diaphragm frequency, rigid diaphragms and storey; the other fields the cell's."""
    t = float(values.get("thickness", wall.thickness))
    h = float(values.get("height", wall.height))
    mass = wall.mass / (wall.thickness * wall.height) * t * h
    md = float(values["overburden_ratio"]) * mass if "overburden_ratio" in values \
        else wall.top_mass
    rigid = float(values.get("rigid_top", 0.0)) >= 0.5 or (
        wall.top_rigid and "diaphragm_frequency" not in values)
    zeta = float(values.get("damping", wall.top_damping))
    if rigid:
        k: float | str = RIGID
        zeta = 0.0
    elif "diaphragm_frequency" in values:
        k = (2.0 * math.pi * float(values["diaphragm_frequency"])) ** 2 * (md + 0.5 * mass)
    else:
        k = wall.top_stiffness
    higher = values["storey"] == "higher" if "storey" in values else not wall.bottom_rigid
    top = dict(top_stiffness=k, top_mass=md, top_damping=zeta)
    bottom = dict(bottom_stiffness=k, bottom_mass=md, bottom_damping=zeta) if higher else \
        dict(bottom_stiffness=RIGID, bottom_mass=0.0, bottom_damping=0.0)
    return wall.replace(thickness=t, height=h, mass=mass, **top, **bottom)


def sample_values(values: dict[str, np.ndarray], j: int) -> dict[str, Any]:
    """Sample `j`'s value of each parameter (plain floats and strings).

    Parameters
    ----------
    values : dict of str to ndarray
        Each parameter's values over the samples (its own units: ``cor`` [1], ``pmr`` [%],
        a factor [1], ...).
    j : int
        The sample's index.
    """
    return {k: (v[j] if isinstance(v[j], str) else float(v[j])) for k, v in values.items()}


def check_samples(values: dict[str, np.ndarray], walls: dict[str, Wall]) -> None:
    """Refuse, before any work, a sample outside a parameter's valid range or whose wall
    is not valid on any of `walls` (label -> the study's wall of a cell).

    Parameters
    ----------
    values : dict of str to ndarray
        Each parameter's values over the samples (its own units).
    walls : dict of str to urmx.Wall
        The study's wall of each cell, by its label.

    Raises
    ------
    ParameterError
        ``key`` is ``parameters.<name>`` of the first parameter at fault; the message names
        the sample, its value and, for a wall, the cell and why.
    """
    names = list(values)
    n = len(next(iter(values.values()))) if values else 0
    for name in names:
        target = PARAMETERS[name]
        for j in range(n):
            problem = target.problem(values[name][j])
            if problem:
                raise ParameterError(f"parameters.{name}", f"sample {j}: {name}={problem} "
                                     "(the study is refused before any work)")
    for j in range(n):
        sample = sample_values(values, j)
        for label, wall in walls.items():
            try:
                apply(wall, sample)
            except InputError as exc:
                at_fault = [k for k in names if k in str(exc)] or names
                shown = ", ".join(f"{k}={sample[k]:.6g}" for k in at_fault
                                  if not isinstance(sample[k], str))
                raise ParameterError(f"parameters.{at_fault[0]}", f"sample {j} ({shown}) "
                                     f"makes no valid wall {label}: {exc}") from None
