"""Collapse fragility: incremental dynamic analysis (IDA) of one cell and lognormal fits.

The collapse capacity of a wall under a record is the smallest intensity at which the
wall collapses when the record is scaled up (:func:`collapse_capacity`). Over a record
library the capacities give a lognormal collapse fragility, fitted by maximum likelihood
with censoring (:func:`fit_lognormal`), or from counts of collapses at a few intensity
levels (:func:`fit_multiple_stripe`); both follow Baker (2015), "Efficient analytical
fragility function fitting using dynamic structural analysis", Earthquake Spectra 31(1).

The search
----------
Every intensity measure here is proportional to the record's scale factor, so the search
runs on scale factors ``s`` and reports ``intensity = s * record_intensity`` (the
intensity of the record as given, :func:`record_intensity`).

1. **Hunt** upwards on the geometric grid ``s_k = s_0 * step**k`` (default ``step`` 1.05)
   from a start ``s_0`` at which the wall is expected to survive (half its
   `static_acceleration`), until the first collapse or ``max_intensity`` (whose run ends
   the hunt). Far from collapse the hunt strides over grid points: each stride aims at an
   instability ratio of 0.5, taking the ratio in proportion to the intensity, and spans
   at least one grid step and at most a factor 3; once the ratio passes 0.5 the hunt walks
   the grid step by step. If the start itself collapses, the hunt goes down in strides of
   a factor 3 to a survivor and up again from there.
2. **Bisect** (geometrically) between the last survivor ``lo`` and the first collapse
   ``hi`` until ``hi / lo - 1 <= rtol``; a collapse moves ``hi`` down, a survival ``lo`` up.

The capacity is ``hi``: an intensity at which the wall was seen to collapse, with a
survivor less than ``rtol`` below it. About 14 analyses a capacity at ``rtol = 1e-3``:
a few strides, a few grid steps, six bisections.

First-collapse convention. Rocking walls "resurrect": a wall that collapses at one
intensity may survive a slightly stronger scaling of the same record (the motion's phase
relative to the rocking changes). The capacity is the *first* collapse met on the way up;
any survival above it is ignored (Vamvatsikos & Cornell 2002, the IDA "capacity point" of
the first flat-lining). The bracket always holds a survivor below and a collapse above, so
the capacity is the lowest collapse the search saw. The search does not analyse every
intensity: a collapse window narrower than a stride below the first collapse it meets,
or inside the bisection's bracket, can be stepped over; then the capacity is a
transition from survival to collapse, but not the first one. The fine grid near collapse
keeps this rarer: on 240 cells of the FEMA P695 study a 1 % brute-force scan finds an
earlier collapse in 15 % of the cells and the capacities come out 1.6 % high on average
(mean log-bias), against 25 % and 3.9 % for a plain geometric hunt in steps of 1.5 at the
same cost (``urmx bench fragility``; most windows are too narrow for any search of ~14
analyses).
An analysis the kernel stops at its event bound counts as a survival.

Censoring. When the wall survives ``max_intensity`` the cell is *censored*: its capacity
is only known to exceed ``max_intensity``; the result carries ``capacity = max_intensity``
with ``censored = True``, and the fits use it as a right-censored observation, never
dropping it (that would bias the median low).

Intensity measures (``im``)
---------------------------
``"pga"`` [m s-2], ``"pgv"`` [m s-1] (of the record as given, `urmx.records.measures`),
``"sa_wall"`` and ``"sa_diaphragm"`` [m s-2] (5 %-damped pseudo-spectral acceleration,
`urmx.records.response_spectrum`) and ``"scale"`` [1] (the scale factor itself).

``sa_wall`` is taken at the wall's effective rocking period (:func:`rocking_period`): the
secant period of the wall's own mechanism, both supports pinned, at 60 % of its
instability displacement. A rocking wall has no fixed period: the initial branch of the
trilinear curve (``theta_a = 0.04 theta0``) gives 0.2-0.4 s for the paper's walls, which
describes a wall that has not started to rock, while the period lengthens without bound
as the wall nears instability. The secant at 0.6 of the instability displacement is the
effective period of the displacement-based assessment of one-way spanning walls (Doherty,
Griffith, Lam & Wilson 2002, EESD 31, the research line of the paper), chosen there because
it best predicts the response near collapse. The supports are left out on purpose: their
effect is what ``sa_diaphragm`` measures.

``sa_diaphragm`` is taken at the period of the top diaphragm, ``1 / f`` with the Table IV
footnote SDOF frequency ``f`` of `urmx.Wall.diaphragm_frequency` (stiffness over the
diaphragm mass plus half the wall mass). A rigid top support moves with the ground: its
period is 0 and Sa is the PGA.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .errors import InputError
from .model import PAPER_G, RIGID, Wall

IMS = ("pga", "pgv", "sa_wall", "sa_diaphragm", "scale")
#: units and long name of each intensity measure
IM_ATTRS = {
    "pga": ("m s-2", "peak ground acceleration"),
    "pgv": ("m s-1", "peak ground velocity"),
    "sa_wall": ("m s-2", "5 %-damped spectral acceleration at the wall's rocking period"),
    "sa_diaphragm": ("m s-2", "5 %-damped spectral acceleration at the top diaphragm's "
                              "period"),
    "scale": ("1", "record scale factor"),
}
DAMPING = 0.05  # of the spectral intensity measures [1]
DESIGN_FRACTION = 0.6  # effective period at this fraction of the instability rotation
#: default max_intensity per intensity measure, in its units
MAX_INTENSITY = {"pga": 5.0 * PAPER_G, "pgv": 5.0, "sa_wall": 5.0 * PAPER_G,
                 "sa_diaphragm": 5.0 * PAPER_G, "scale": 50.0}
STEP = 1.05  # default ratio of the hunt's geometric grid
MAX_STRIDE = 3.0  # longest hunt stride (whole grid steps)
RATIO_TARGET = 0.5  # a stride aims at this instability ratio
START_FRACTION = 0.5  # default start: this fraction of the wall's static acceleration


# ---- the wall's own mechanism -------------------------------------------------------------

def trilinear(segment, theta: float) -> float:
    """Trilinear resistance R(theta) of a segment case (`urmx.Wall.segment`; MODEL.md
    section 3): linear to ``theta_a``, the plateau ``Mi`` to ``theta_b``, then softening to
    zero at ``theta0``. [N m]"""
    a = abs(theta)
    s = 1.0 if theta >= 0 else -1.0
    if a <= segment.theta_a:
        return segment.Mi * theta / segment.theta_a
    if a <= segment.theta_b:
        return s * segment.Mi
    return s * segment.M0 * (1.0 - a / segment.theta0)


def _mechanism(wall: Wall):
    """(inertia, ground coupling, resistance(theta1), instability theta1, the pinned wall) of
    the wall with both supports pinned: one coordinate theta1, theta2 = -(a1/a2) theta1,
    family 2."""
    from .model import system

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
    inertia, _, restoring, theta_ins, _ = _mechanism(wall)
    theta_d = DESIGN_FRACTION * theta_ins
    return 2.0 * math.pi * math.sqrt(inertia * theta_d / restoring(theta_d))


def static_acceleration(wall: Wall) -> float:
    """Ground acceleration that holds the pinned mechanism at its strongest point: the peak
    restoring moment over the ground coupling ``m a1 / 2``. [m s-2]

    The restoring moment is piecewise linear in theta1, so its peak lies at a corner of
    one of the two trilinear curves (or at the instability rotation)."""
    _, coupling, restoring, theta_ins, pinned = _mechanism(wall)
    k = pinned.a1 / pinned.a2
    lower, upper = pinned.segment(2), pinned.segment(1)
    corners = [lower.theta_a, lower.theta_b, upper.theta_a / k, upper.theta_b / k, theta_ins]
    return max(restoring(t) for t in corners if 0.0 < t <= theta_ins) / coupling


def diaphragm_period(wall: Wall) -> float:
    """Period of the top support, ``1 / wall.diaphragm_frequency("top")``; 0 when rigid. [s]"""
    f = wall.diaphragm_frequency("top")
    return 0.0 if math.isinf(f) else 1.0 / f


# ---- records and intensities --------------------------------------------------------------

@dataclass
class Record:
    """A record as the search uses it: samples [m s-2] at step dt [s], and an id."""

    acceleration: np.ndarray
    dt: float
    id: str = ""


def as_record(record: Any, records_dir=None) -> Record:
    """A `Record` from an obspy Trace (as given), a manifest id (the record as studies use
    it: at its manifest scale factor) or an ``(array, dt)`` pair."""
    if isinstance(record, Record):
        return record
    if isinstance(record, str):
        from . import records as rec

        trace = rec.load(record, records_dir)
        factor = float(trace.stats.record.get("scale_factor") or 1.0)
        acc = np.ascontiguousarray(trace.data, dtype=np.float64) * factor
        return Record(acc, float(trace.stats.delta), record)
    if hasattr(record, "stats") and hasattr(record, "data"):
        return Record(np.ascontiguousarray(record.data, dtype=np.float64),
                      float(record.stats.delta), str(record.id))
    if isinstance(record, (tuple, list)) and len(record) == 2:
        acc, dt = record
        try:
            dt = float(dt)
        except (TypeError, ValueError):
            raise InputError(f"record: dt={dt!r} must be a number of seconds") from None
        acc = np.ascontiguousarray(acc, dtype=np.float64)
        if acc.ndim != 1 or acc.size < 2:
            raise InputError(f"record: the samples must be a 1-D array of at least 2 values "
                             f"(got shape {acc.shape})")
        if not (math.isfinite(dt) and dt > 0):
            raise InputError(f"record: dt={dt!r} must be a positive time step in seconds")
        return Record(acc, dt, "array")
    raise InputError(f"record must be an obspy Trace, a manifest id or an (array, dt) pair, "
                     f"not {type(record).__name__}")


def _check_im(im: str) -> None:
    if im not in IMS:
        raise InputError(f"im={im!r} is not an intensity measure; use one of "
                         f"{', '.join(map(repr, IMS))}")


def record_intensity(record: Any, im: str = "pga", wall: Wall | None = None) -> float:
    """Intensity of a record as given (scale factor 1).

    Parameters
    ----------
    record : obspy.Trace, str or (array, dt)
        The record (see `collapse_capacity`).
    im : {"pga", "pgv", "sa_wall", "sa_diaphragm", "scale"}
        Intensity measure (module docstring).
    wall : urmx.Wall, optional
        Required by ``"sa_wall"`` and ``"sa_diaphragm"``.

    Returns
    -------
    float
        In the measure's units (`IM_ATTRS`): m s-2, m s-1 or 1.
    """
    _check_im(im)
    if im in ("sa_wall", "sa_diaphragm") and wall is None:
        raise InputError(f"im={im!r} needs the wall (its period)")
    rec = as_record(record)
    return float(record_intensities(rec.acceleration, rec.dt, im, [wall])[0])


def record_intensities(acceleration, dt: float, im: str, walls) -> np.ndarray:
    """`record_intensity` of one record for several walls at once (one pass of the response
    spectrum over all their periods). [units of the measure]"""
    if im == "scale":
        return np.ones(len(walls))
    if im in ("pga", "pgv"):
        from .records import measures

        value = float(measures((acceleration, dt), names=[im])[im])
        return np.full(len(walls), value)
    period = rocking_period if im == "sa_wall" else diaphragm_period
    return spectral_intensities((acceleration, dt), [period(w) for w in walls])


def spectral_intensities(record: Any, periods) -> np.ndarray:
    """5 %-damped pseudo-spectral accelerations of a record at `periods` [s] (0: the PGA),
    in one pass of `urmx.records.response_spectrum`. [m s-2]"""
    from .records import response_spectrum

    rec = as_record(record)
    periods = np.asarray(periods, dtype=float)
    uniq, inv = np.unique(periods, return_inverse=True)
    rs = response_spectrum((rec.acceleration, rec.dt), periods=uniq, damping=DAMPING)
    return rs.psa.values[inv]


# ---- collapse capacity of one cell ----------------------------------------------------------

@dataclass
class CollapseCapacity:
    """Result of `collapse_capacity`.

    Attributes
    ----------
    capacity : float
        Smallest intensity at which the wall was seen to collapse; ``max_intensity``
        when censored. [units of the measure]
    censored : bool
        The wall survived ``max_intensity``: the capacity exceeds it.
    intensity, instability_ratio : ndarray
        The IDA points: every analysed intensity (ascending) and its governing instability
        ratio (1.0 at collapse). [units of the measure], [1]
    collapsed : ndarray of bool
        Whether the wall collapsed at each point.
    analyses : int
        Number of analyses run.
    im, units : str
        The intensity measure and its units.
    record_intensity : float
        Intensity of the record as given (scale factor 1); ``capacity / record_intensity``
        is the scale factor at collapse. [units of the measure]
    event_limits : int
        Analyses stopped by the kernel's event bound (counted as survivals).
    """

    capacity: float
    censored: bool
    intensity: np.ndarray
    instability_ratio: np.ndarray
    collapsed: np.ndarray
    analyses: int
    im: str
    units: str
    record_intensity: float
    event_limits: int = 0
    scale: float = field(init=False)

    def __post_init__(self) -> None:
        self.scale = self.capacity / self.record_intensity

    def to_dict(self) -> dict[str, Any]:
        return {k: getattr(self, k) for k in (
            "capacity", "censored", "intensity", "instability_ratio", "collapsed", "analyses",
            "im", "units", "record_intensity", "scale", "event_limits")}


def _positive(name: str, value: Any) -> float:
    try:
        x = float(value)
    except (TypeError, ValueError):
        raise InputError(f"{name}={value!r} must be a number") from None
    if not (math.isfinite(x) and x > 0):
        raise InputError(f"{name}={value!r} must be a positive, finite number")
    return x


def search(analyse, s_start: float, s_max: float, step: float, rtol: float,
           max_stride: float = MAX_STRIDE, target: float = RATIO_TARGET):
    """The hunt and bisection on scale factors (module docstring), model-free.

    Parameters
    ----------
    analyse : callable
        ``analyse(s) -> (collapsed, instability_ratio)`` at scale factor ``s``.
    s_start, s_max : float
        First scale factor and the largest one analysed. [1]
    step : float
        Ratio of the hunt's geometric grid ``s_start * step**k``, > 1. [1]
    rtol : float
        Relative width of the final bracket. [1]
    max_stride : float
        Largest ratio of one hunt stride (a whole number of grid steps). [1]
    target : float
        A stride aims at this instability ratio, taking the ratio proportional to the
        intensity. [1]

    Returns
    -------
    (float, bool)
        The capacity as a scale factor (``s_max`` when censored) and the censored flag.
    """
    s_start = min(s_start, s_max)
    big = max(1, int(math.floor(math.log(max_stride) / math.log(step) + 1e-9)))
    hi = None
    collapsed, ratio = analyse(s_start)
    lo, k = s_start, 0
    if collapsed:  # down in whole strides to a survivor, then up again from it
        hi = s_start
        while True:
            k -= big
            s = s_start * step ** k
            if s < s_start * 1e-6:  # collapses under a millionth of the start: report it
                return hi, False
            collapsed, ratio = analyse(s)
            if not collapsed:
                lo = s
                break
            hi = s
    while True:  # up: strides of whole grid steps, shorter as the ratio nears the target
        want = min(max_stride, max(step, target / max(ratio, 1e-9)))
        k += max(1, min(big, int(math.floor(math.log(want) / math.log(step) + 1e-9))))
        s = s_start * step ** k
        if hi is not None and s >= hi * (1.0 - 1e-12):
            break
        if s >= s_max:
            if lo >= s_max:
                return s_max, True
            s = s_max
        collapsed, ratio = analyse(s)
        if collapsed:
            hi = s
            break
        lo = s
    while hi / lo - 1.0 > rtol:
        mid = math.sqrt(lo * hi)
        if analyse(mid)[0]:
            hi = mid
        else:
            lo = mid
    return hi, False


def collapse_capacity(wall: Wall, record: Any, *, im: str = "pga", cor: float = 0.8,
                      rtol: float = 1e-3, step: float = STEP,
                      max_intensity: float | None = None, impact: str = "scale",
                      start: float | None = None, records_dir=None,
                      kernel=None) -> CollapseCapacity:
    """Collapse capacity of one wall under one record: the smallest intensity at which it
    collapses (hunt, then bisection; first-collapse convention; module docstring).

    Parameters
    ----------
    wall : urmx.Wall
        The wall and its supports.
    record : obspy.Trace, str or (array, dt)
        Ground acceleration in m s-2: a Trace as given, a manifest id (the record at its
        manifest scale factor, as studies use it), or samples and their time step [s].
    im : {"pga", "pgv", "sa_wall", "sa_diaphragm", "scale"}
        Intensity measure of the capacity (module docstring).
    cor : float
        Coefficient of restitution, in (0, 1]. [1]
    rtol : float
        Relative width of the final bracket: a survivor lies within ``rtol`` below the
        capacity. [1]
    step : float
        Ratio of the hunt's geometric grid of scale factors, > 1; far from collapse the
        hunt strides over several grid points (module docstring). [1]
    max_intensity : float, optional
        Highest intensity analysed; a wall surviving it is censored there. Default
        `MAX_INTENSITY` of the measure (5 g for accelerations, 5 m s-1, scale 50).
        [units of the measure]
    impact : {"scale", "contact"}
        Impact law (MODEL.md section 8).
    start : float, optional
        First intensity of the hunt. Default: the intensity at which the record's PGA is
        half the wall's `static_acceleration` (the lowest collapse PGA measured on the
        FEMA P695 set was 0.57 of it). [units of the measure]
    records_dir : str or path, optional
        Records folder for a manifest id.
    kernel : callable, optional
        Integrator with the signature of `urmx.kernel.run` (default).

    Returns
    -------
    CollapseCapacity
        Capacity, censored flag, IDA points, number of analyses.

    Notes
    -----
    All runs of a cell reuse the kernel's tables of the wall (cached per wall and record
    step by `urmx.kernel.run`), so only the first analysis of a wall builds them.
    """
    _check_im(im)
    if kernel is None:
        from .kernel import run as kernel
    if not isinstance(wall, Wall):
        raise InputError(f"wall must be a urmx.Wall, not {type(wall).__name__}")
    rtol = _positive("rtol", rtol)
    if rtol >= 1.0:
        raise InputError(f"rtol={rtol!r} must be below 1 (relative width of the bracket)")
    step = _positive("step", step)
    if step <= 1.0:
        raise InputError(f"step={step!r} must be greater than 1 (the ratio of the hunt's "
                         "geometric grid)")
    rec = as_record(record, records_dir)
    if not np.any(rec.acceleration):
        raise InputError(f"record {rec.id!r} is all zeros: it cannot collapse a wall")
    unit = record_intensity(rec, im, wall)
    max_intensity = _positive("max_intensity", MAX_INTENSITY[im] if max_intensity is None
                              else max_intensity)
    start = None if start is None else _positive("start", start)
    return _capacity(kernel, wall, rec.acceleration, rec.dt, unit, im, cor, impact, rtol, step,
                     max_intensity, start, rec.id)


def _capacity(kernel, wall: Wall, acc: np.ndarray, dt: float, unit: float, im: str,
              cor: float, impact: str, rtol: float, step: float, max_intensity: float,
              start: float | None = None, label: str = "") -> CollapseCapacity:
    """`collapse_capacity` on validated inputs (a study's batches call it directly)."""
    pga = float(np.max(np.abs(acc)))
    if not (unit > 0 and pga > 0):
        raise InputError(f"record {label!r} is all zeros: it cannot collapse a wall")
    if start is None:
        s_start = START_FRACTION * static_acceleration(wall) / pga
    else:
        s_start = start / unit
    points: dict[float, tuple[float, bool, str]] = {}

    def analyse(s: float) -> tuple[bool, float]:
        res = kernel(wall, acc, dt, scale=s, cor=cor, impact=impact)
        collapsed = res["status"] == "collapsed"
        points[s] = (res["instability_ratio"], collapsed, res["status"])
        return collapsed, res["instability_ratio"]

    s_cap, censored = search(analyse, s_start, max_intensity / unit, step, rtol)
    order = sorted(points)
    return CollapseCapacity(
        capacity=max_intensity if censored else s_cap * unit, censored=censored,
        intensity=np.array(order) * unit,
        instability_ratio=np.array([points[s][0] for s in order]),
        collapsed=np.array([points[s][1] for s in order], dtype=bool),
        analyses=len(points), im=im, units=IM_ATTRS[im][0], record_intensity=unit,
        event_limits=sum(1 for v in points.values() if v[2] == "event-limit"))


# ---- lognormal fragility fits ------------------------------------------------------------------

@dataclass(frozen=True)
class LognormalFit:
    """A lognormal fragility ``P(collapse | x) = Phi(ln(x / median) / dispersion)``.

    Attributes
    ----------
    median : float
        Median collapse intensity theta. [units of the intensity]
    dispersion : float
        Lognormal standard deviation beta. [1]
    n : int
        Number of observations (capacities, or analyses over all stripes).
    n_censored : int
        Censored capacities (capacity fit) or 0.
    method : str
        ``"capacities"`` or ``"multiple-stripe"``.
    """

    median: float
    dispersion: float
    n: int
    n_censored: int = 0
    method: str = "capacities"

    def probability(self, intensity) -> np.ndarray:
        """Probability of collapse at `intensity` [units of the intensity]. [1]"""
        from scipy.stats import norm

        x = np.asarray(intensity, dtype=float)
        with np.errstate(divide="ignore"):
            return norm.cdf(np.log(x / self.median) / self.dispersion)


def _minimise(nll, x0) -> np.ndarray:
    """Minimise a negative log-likelihood over (ln median, ln dispersion) with scipy."""
    from scipy.optimize import minimize

    res = minimize(nll, x0, method="Nelder-Mead",
                   options={"xatol": 1e-10, "fatol": 1e-12, "maxiter": 4000})
    if not np.isfinite(res.fun):
        raise InputError("the lognormal fit found no finite likelihood")
    return res.x


def fit_lognormal(capacities, censored=None) -> LognormalFit:
    """Median and dispersion of collapse capacities by maximum likelihood, with censoring.

    The likelihood (Baker 2015, truncated IDA) is the product of the lognormal density at
    every observed capacity and the probability of surviving the censoring intensity,
    ``1 - Phi(ln(c / theta) / beta)``, for every censored one. Without censoring it is
    maximised by the mean and the (population, 1/n) standard deviation of ``ln x``.

    Parameters
    ----------
    capacities : array_like
        Collapse intensities; for censored entries the intensity the wall survived.
        NaN entries (cells not run) are ignored. [units of the intensity]
    censored : array_like of bool, optional
        True where the capacity is a lower bound (no collapse up to it). Default: none.

    Returns
    -------
    LognormalFit

    Raises
    ------
    ValueError
        Fewer than two distinct uncensored capacities (no dispersion can be fitted), or a
        capacity that is not positive.
    """
    from scipy.stats import norm

    x = np.asarray(capacities, dtype=float).ravel()
    c = (np.zeros(x.shape, dtype=bool) if censored is None
         else np.asarray(censored, dtype=bool).ravel())
    if c.shape != x.shape:
        raise InputError(f"censored has {c.size} entries, capacities {x.size}")
    keep = np.isfinite(x)
    x, c = x[keep], c[keep]
    if np.any(x <= 0):
        raise InputError(f"capacities must be positive (intensities at collapse); got "
                         f"{float(x[x <= 0][0])!r}")
    lx = np.log(x)
    obs, cen = lx[~c], lx[c]
    if np.unique(obs).size < 2:
        raise InputError(f"a lognormal fit needs at least two distinct uncensored capacities "
                         f"(got {obs.size} uncensored of {x.size})")

    def nll(p):
        mu, beta = p[0], math.exp(p[1])
        return -(np.sum(norm.logpdf(obs, mu, beta)) + np.sum(norm.logsf(cen, mu, beta)))

    mu, lb = _minimise(nll, [obs.mean(), math.log(max(obs.std(), 1e-3))])
    return LognormalFit(float(math.exp(mu)), float(math.exp(lb)), int(x.size), int(c.sum()),
                        "capacities")


def fit_multiple_stripe(intensity, analyses, collapses) -> LognormalFit:
    """Median and dispersion from counts of collapses at a few intensity levels (multiple
    stripe analysis) by maximum likelihood with a binomial likelihood (Baker 2015).

    Parameters
    ----------
    intensity : array_like
        Intensity levels (stripes), positive. [units of the intensity]
    analyses : array_like of int
        Number of records analysed at each level (or one number for all).
    collapses : array_like of int
        Number of collapses at each level.

    Returns
    -------
    LognormalFit
        With ``method = "multiple-stripe"`` and ``n`` the total number of analyses.

    Raises
    ------
    ValueError
        Inconsistent counts, or counts that cannot fix a lognormal (no collapse at all,
        collapse everywhere).
    """
    from scipy.stats import binom, norm

    x = np.asarray(intensity, dtype=float).ravel()
    n = np.broadcast_to(np.asarray(analyses), x.shape).astype(np.int64)
    z = np.asarray(collapses).ravel().astype(np.int64)
    if z.shape != x.shape:
        raise InputError(f"collapses has {z.size} entries, intensity {x.size}")
    if np.any(x <= 0) or not np.all(np.isfinite(x)):
        raise InputError("intensity levels must be positive and finite")
    if np.any(n < 1) or np.any(z < 0) or np.any(z > n):
        raise InputError("counts need 0 <= collapses <= analyses and analyses >= 1")
    if z.sum() == 0 or np.all(z == n):
        raise InputError("a multiple-stripe fit needs some stripes with survivors and some "
                         "with collapses")
    lx = np.log(x)

    def nll(p):
        mu, beta = p[0], math.exp(p[1])
        prob = norm.cdf((lx - mu) / beta)
        return -np.sum(binom.logpmf(z, n, prob))

    frac = z / n
    mid = lx[np.argmin(np.abs(frac - 0.5))]
    spread = max(float(np.ptp(lx)) / 4.0, 0.05)
    mu, lb = _minimise(nll, [mid, math.log(spread)])
    return LognormalFit(float(math.exp(mu)), float(math.exp(lb)), int(n.sum()), 0,
                        "multiple-stripe")


def stripe_counts(capacities, censored, levels) -> tuple[np.ndarray, np.ndarray]:
    """Number of analyses and of collapses at each intensity level implied by collapse
    capacities (a wall collapses at ``x`` when its capacity is at most ``x``).

    A censored capacity ``c`` says nothing at levels above ``c``: those records are not
    counted there.

    Returns
    -------
    (ndarray, ndarray)
        ``analyses`` and ``collapses`` per level.
    """
    x = np.asarray(capacities, dtype=float).ravel()
    c = np.zeros(x.shape, bool) if censored is None else np.asarray(censored, bool).ravel()
    keep = np.isfinite(x)
    x, c = x[keep], c[keep]
    lv = np.asarray(levels, dtype=float).ravel()
    known = ~c[None, :] | (lv[:, None] <= x[None, :])
    collapsed = ~c[None, :] & (x[None, :] <= lv[:, None])
    return known.sum(axis=1), collapsed.sum(axis=1)


# ---- the IDA study kind (run by urmx.study.run_study for a study with [study.ida]) -------

#: the arrays every batch of :func:`run_ida_batch` returns (a saved part lacking one is
#: computed again)
IDA_OUTPUTS = ("capacity", "censored", "analyses", "event_limits", "intensity", "ratio",
               "unit", "predominant")
#: the outputs of an IDA archive with one value per (wall, diaphragm, record, cor) cell
IDA_CELL_OUTPUTS = ("collapse_intensity", "censored", "analyses", "event_limits",
                    "instability_ratio")
IDA_MISSING = "NaN where the study's pairs leave the cell out (not run)"


def ida_cells(task: dict) -> int:
    """Cells (collapse capacities) of an IDA batch's task: walls x cor."""
    return len(task["walls"]) * len(task["cor"])


def ida_tasks(study, records, batch_size: int = 16, kernel=None) -> list:
    """Batches of an IDA study: up to `batch_size` cells (walls x cor) of one diaphragm and
    one record, each with the hash key of everything that decides its result (the
    settings, walls, record samples, urmx version and `urmx.jitcache.SOURCE_HASH`)."""
    import hashlib
    import json

    from . import __version__, jitcache
    from .study import Batch

    per = max(1, batch_size // len(study.cor))
    settings = study.ida.to_dict()
    out = []
    for ir, rid in enumerate(study.records):
        rec = records[rid]
        for idp, d in enumerate(study.diaphragms):
            walls = [iw for iw, w in enumerate(study.walls) if study.paired(w.id, rid)]
            for i in range(0, len(walls), per):
                batch = Batch(walls[i:i + per], idp, ir)
                task = dict(walls=[study.wall(study.walls[iw], d) for iw in batch.walls],
                            dt=rec.dt, scale_factor=rec.scale_factor, cor=list(study.cor),
                            impact=study.impact, ida=settings, kernel=kernel,
                            predominant=idp == 0 and i == 0)
                ident = dict(task, walls=[w.to_dict() for w in task["walls"]], record=rec.id,
                             record_digest=rec.digest, kind="ida", urmx=__version__,
                             kernel=None if kernel is None
                             else f"{kernel.__module__}.{kernel.__qualname__}",
                             kernel_source=jitcache.SOURCE_HASH)
                batch.key = "ida-" + hashlib.sha256(json.dumps(
                    ident, sort_keys=True, default=str).encode()).hexdigest()[:20]
                out.append((batch, task))
    return out


def run_ida_batch(task: dict, acceleration: np.ndarray) -> dict[str, np.ndarray]:
    """One batch of an IDA study: the collapse capacity of every (wall, cor) cell, as numpy
    arrays (capacity, censored, analyses, event_limits of shape (walls, cor); the IDA points
    ``intensity`` and ``ratio`` of shape (walls, cor, points), NaN-padded; the record's
    intensity ``unit`` per wall; the record's
    ``predominant`` frequency when the task asks for it, else NaN). Numpy only."""
    kernel = task["kernel"]
    if kernel is None:
        from .kernel import run as kernel
    acc = np.ascontiguousarray(acceleration * task["scale_factor"], dtype=np.float64)
    ida = task["ida"]
    walls = task["walls"]
    unit = record_intensities(acc, task["dt"], ida["im"], walls)
    shape = (len(walls), len(task["cor"]))
    results = {}
    for iw, ic in np.ndindex(*shape):
        results[iw, ic] = _capacity(
            kernel, walls[iw], acc, task["dt"], float(unit[iw]), ida["im"], task["cor"][ic],
            task["impact"], ida["rtol"], ida["step"], ida["max_intensity"])
    k = max(r.analyses for r in results.values())
    out = {"capacity": np.full(shape, np.nan), "censored": np.zeros(shape, bool),
           "analyses": np.zeros(shape, np.int32), "event_limits": np.zeros(shape, np.int32),
           "intensity": np.full((*shape, k), np.nan), "ratio": np.full((*shape, k), np.nan),
           "unit": unit, "predominant": np.array(
               _predominant(acc, task["dt"]) if task["predominant"] else np.nan)}
    for (iw, ic), r in results.items():
        out["capacity"][iw, ic] = r.capacity
        out["censored"][iw, ic] = r.censored
        out["analyses"][iw, ic] = r.analyses
        out["event_limits"][iw, ic] = r.event_limits
        out["intensity"][iw, ic, :r.analyses] = r.intensity
        out["ratio"][iw, ic, :r.analyses] = r.instability_ratio
    return out


def warm_up() -> None:
    """Run every compiled function an IDA batch uses once (the kernel, the response and
    Fourier spectra), so numba compiles them or loads them from its on-disk cache now;
    ``client.run(warm_up)`` does it on every dask worker before timing."""
    from .kernel import warm_up as warm_kernel

    warm_kernel()
    wall = Wall(0.23, 3.68, 2 / 3, 20000.0, top_mass=12000.0, top_stiffness=815e3,
                top_damping=0.12)
    t = np.arange(500) * 0.01
    acc = np.sin(2 * np.pi * 1.5 * t) * np.exp(-t)
    task = dict(walls=[wall], dt=0.01, scale_factor=1.0, cor=[0.8], impact="scale",
                ida=dict(im="sa_wall", rtol=0.1, step=2.0, max_intensity=50.0), kernel=None,
                predominant=True)
    run_ida_batch(task, acc)
    record_intensities(acc, 0.01, "pgv", [wall])


def _predominant(acceleration, dt: float) -> float:
    from .records import predominant_frequency
    from .records.measures import as_trace

    return predominant_frequency(as_trace((acceleration, dt)))


def assemble_ida(study, records, tasks, results, started: str, command) -> Any:
    """The Dataset of an IDA study: capacities, censoring, IDA curves and the lognormal fits
    per (wall, diaphragm, cor), with the grid's coordinates (`urmx.study`)."""
    import xarray as xr

    from . import variables
    from .netcdf import INT_FILL
    from .study import global_attrs, grid_coords

    ida = study.ida
    ctx = variables.intensity_context(ida.im)
    shape = (len(study.walls), len(study.diaphragms), len(study.records), len(study.cor))
    k = max([results[b.key]["intensity"].shape[-1] for b, _ in tasks] or [1])
    # every cell output is float64, NaN where the cell was not run (the flag and counts
    # too, so that sums and means skip those cells; int32 with a _FillValue on disk)
    cap = np.full(shape, np.nan)
    cen = np.full(shape, np.nan)
    count = np.full(shape, np.nan)
    lim = np.full(shape, np.nan)
    inten = np.full((*shape, k), np.nan)
    ratio = np.full((*shape, k), np.nan)
    unit = np.full(shape[:3], np.nan)
    periods = np.array([[rocking_period(study.wall(w, d)) for d in study.diaphragms]
                        for w in study.walls])
    predominant = np.full(shape[2], np.nan)
    for batch, _ in tasks:
        r = results[batch.key]
        kb = r["intensity"].shape[-1]
        if np.isfinite(r["predominant"]):
            predominant[batch.record] = r["predominant"]
        for j, iw in enumerate(batch.walls):
            cell = (iw, batch.diaphragm, batch.record)
            unit[cell] = r["unit"][j]
            cap[cell] = r["capacity"][j]
            cen[cell] = r["censored"][j]
            count[cell] = r["analyses"][j]
            lim[cell] = r["event_limits"][j]
            inten[cell][..., :kb] = r["intensity"][j]
            ratio[cell][..., :kb] = r["ratio"][j]
    median = np.full((shape[0], shape[1], shape[3]), np.nan)
    disp = np.full_like(median, np.nan)
    for iw, idp, ic in np.ndindex(median.shape):
        ran = np.isfinite(cap[iw, idp, :, ic])
        try:
            f = fit_lognormal(cap[iw, idp, ran, ic], cen[iw, idp, ran, ic] == 1)
        except ValueError:
            continue
        median[iw, idp, ic], disp[iw, idp, ic] = f.median, f.dispersion

    dims = ("wall", "diaphragm", "record", "cor")
    curve = (*dims, "intensity_step")
    fit_dims = ("wall", "diaphragm", "cor")

    def attrs(name, **extra):
        a = variables.attrs(name, None, **ctx)
        a.update(extra)
        return a

    stored = f"{IDA_MISSING}; stored as int32 with _FillValue {INT_FILL}, read as float64"
    data_vars = {
        "collapse_intensity": xr.Variable(dims, cap, attrs=attrs("collapse_intensity",
                                                                 comment=IDA_MISSING)),
        "censored": xr.Variable(dims, cen, attrs=attrs(
            "censored", comment=f"1 censored, 0 not; {stored}")),
        "instability_ratio": xr.Variable(curve, ratio, attrs=attrs(
            "instability_ratio", comment="IDA curve: one value per analysis of the cell, "
            "ascending intensity; NaN after the cell's last analysis and where the cell "
            "was not run")),
        "median_collapse_intensity": xr.Variable(fit_dims, median,
                                                 attrs=attrs("median_collapse_intensity")),
        "dispersion": xr.Variable(fit_dims, disp, attrs=attrs("dispersion")),
        "analyses": xr.Variable(dims, count, attrs=attrs("analyses", comment=stored)),
        "event_limits": xr.Variable(dims, lim, attrs=attrs("event_limits", comment=stored)),
        "record_intensity": xr.Variable(dims[:3], unit, attrs=attrs("record_intensity")),
    }
    coords = grid_coords(study, records)
    coords["intensity_step"] = xr.Variable("intensity_step", np.arange(k),
                                           attrs=attrs("intensity_step"))
    coords["intensity"] = xr.Variable(curve, inten, attrs=attrs("intensity"))
    coords["rocking_period"] = xr.Variable(("wall", "diaphragm"), periods,
                                           attrs=attrs("rocking_period"))
    coords["predominant_frequency"] = xr.Variable("record", predominant, attrs=attrs(
        "predominant_frequency", comment="of each record, Konno-Ohmachi smoothed "
        "(urmx.records.predominant_frequency)"))
    gattrs = global_attrs(study, started, command)
    gattrs.update({"intensity_measure": ida.im, "ida_rtol": ida.rtol, "ida_step": ida.step,
                   "ida_max_intensity": ida.max_intensity,
                   "ida_convention": "first collapse: the lowest collapse the hunt and "
                                     "bisection saw; censored cells hold max_intensity"})
    return xr.Dataset(data_vars, coords=coords, attrs=gattrs)
