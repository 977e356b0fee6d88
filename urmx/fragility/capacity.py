"""The collapse capacity of a wall under a record: the smallest intensity at which it
collapses when the record is scaled up (hunt on a geometric grid, then bisection), numpy
only.

Every intensity measure is proportional to the record's scale factor, so the search runs on
scale factors ``s`` and reports ``intensity = s * record_intensity`` (the intensity of the
record as analysed at scale 1, `urmx.fragility.intensity.record_intensity`).

The search
----------
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

Warm start
----------
A study knows more than half a wall's static acceleration: the capacity of the same
record on the wall before it. `search` takes a ``hint`` (a scale factor near which the
wall is expected to collapse) and then hunts on a finer grid through the hint,
``hint * w**k`` with ``w = (1 + rtol) ** 2**j`` the largest such ratio not above ``step``
(1.001**32 = 1.0325 for the defaults: a bracket of one step bisects to rtol in 5
analyses, not 6). The hunt starts ``MARGIN`` (10 %) below the hint, rounded up to whole
steps (3 steps: 10.1 %), walks up with the cold hunt's ratio-guided strides but never
over the hint, and a start that collapses goes down in strides of 3, 6, 12 ... steps (at
most a factor 3) to a survivor, then up again. When the bracket ends at the hint, the
bisection first analyses ``rtol`` inside it: a wall that collapses where the hint says is
done in 5 analyses, the hint its capacity. The first-collapse convention holds as in the
cold search; what the warm start skips is the range more than the margin below the hint,
where the cold hunt strides anyway, and it walks a finer grid near collapse.

The IDA and sampling-IDA study kinds (`urmx.study.kinds.ida`) chain their cells along the
``wall`` dimension: per (diaphragm, record, cor [, sample]), the first wall the study
pairs with the record starts cold, and each next paired wall, in the study's order,
starts from the capacity of the one before it as a scale factor (its capacity over its
record intensity) times ``(A / A_before) ** HINT_EXPONENT``, A the walls' static
accelerations (`static_acceleration`). On the cold capacities of ``fema-p695-ida`` the
ratio of neighbouring walls' capacities has median 0.88 (IQR 0.82-0.94); the exponent
(0.2) and the margin were chosen on that study by measuring the search on the 240 cells of
the brute-force scan and on the whole study (no exponent: 9.95 analyses a capacity over
the study; 0.2: 9.89 and the fewest stepped windows of the exponents up to 0.3; 0.5: 10.24;
a margin of 2 warm steps, 6.6 %: fewer analyses but as many windows stepped over as the
cold search; 1.05-steps instead of the finer grid: about 0.8 more analyses and more
windows).

The hint, and so the result, depends on the whole chain before a cell: a cell's key
folds the keys of the cells before it (`urmx.study.cells`), batches never split a chain,
and a finished predecessor's result travels with its successor's batch
(`urmx.study.batches`), so a cell's result is the same whatever the workers, the
batches, a resume or a reuse from an earlier archive. Measured on ``fema-p695-ida``
(``urmx bench fragility``): 9.89 analyses a capacity against 13.58 for the cold search
(the chains' first walls 12.97, the others 9.51); against the 1 % scan on its 240 cells,
33 cells (13.8 %) step over a collapse window and the mean log-bias is +1.3 %, against 37
(15.4 %) and +1.6 % for the cold search.

Censoring. When the wall survives ``max_intensity`` the cell is *censored*: its capacity
is only known to exceed ``max_intensity``; the result carries ``capacity = max_intensity``
with ``censored = True``, and the fits use it as a right-censored observation, never
dropping it (that would bias the median low).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..errors import InputError
from ..kernel import run as run_kernel
from ..model import Wall
from ..records.readers import check_finite
from ..records.record import as_record
from .intensity import IM_ATTRS, MAX_INTENSITY, check_im, check_period_range, record_intensity
from .mechanism import static_acceleration

DEFAULT_IM = "pga"  # default intensity measure of a capacity
RTOL = 1e-3  # default relative width of the final bracket [1]
STEP = 1.05  # default ratio of the hunt's geometric grid [1]
MAX_STRIDE = 3.0  # longest hunt stride (whole grid steps)
RATIO_TARGET = 0.5  # a stride aims at this instability ratio
START_FRACTION = 0.5  # default start: this fraction of the wall's static acceleration
#: the default kernel's tracking mode for a capacity search (only the drift trackers)
TRACK = "capacity"
MARGIN = 0.1  # a warm start begins this far below its hint (whole steps of the warm grid)
#: a chained study's hint: the previous wall's capacity times the ratio of the walls' static
#: accelerations to this power (chosen on fema-p695-ida, module docstring)
HINT_EXPONENT = 0.2


def _warm_step(step: float, rtol: float) -> float:
    """The warm hunt's grid ratio: ``(1 + rtol) ** 2**j``, the largest such not above
    `step` (a bracket of one step bisects to rtol exactly; 1.001**32 = 1.0325 for the
    defaults), or `step` itself when it is finer than 1 + 2 rtol."""
    j = math.floor(math.log2(math.log(step) / math.log1p(rtol)) + 1e-12)
    return (1.0 + rtol) ** (2 ** j) if j >= 1 else step


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
        """The capacity's fields as plain data (for JSON and reports)."""
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


def _grid_steps(ratio: float, step: float) -> int:
    """Whole steps of the grid of ratio `step` that span at least `ratio` (>= 1)."""
    return max(0, int(math.ceil(math.log(ratio) / math.log(step) - 1e-9)))


def _hunt_down(analyse, anchor: float, k: int, step: float, stride: int, longest: int,
               grow: bool):
    """From a collapse at ``anchor * step**k`` down the grid in strides of `stride` steps
    (doubled after each collapse when `grow`, up to `longest`) to a survivor: (k of the
    survivor, the lowest collapse, the survivor's ratio), or (None, the lowest collapse,
    None) under a millionth of the first."""
    s0 = hi = anchor * step ** k
    while True:
        k -= stride
        s = anchor * step ** k
        if s < s0 * 1e-6:  # collapses under a millionth of the start: report it
            return None, hi, None
        collapsed, ratio = analyse(s)
        if not collapsed:
            return k, hi, ratio
        hi = s
        if grow:
            stride = max(stride, min(2 * stride, longest))


def _bisect(analyse, lo: float, hi: float, rtol: float, hint: float | None) -> float:
    """Bisect (geometrically) to ``hi / lo - 1 <= rtol``; with a `hint` at an end of the
    bracket, first the point at rtol from it inside (the hint's own transition)."""
    width = 1.0 + rtol
    if hint is not None:
        if abs(hi / hint - 1.0) < 1e-9 and hi / lo > width:
            probe = hi / width
            if analyse(probe)[0]:
                hi = probe
            else:
                lo = probe
        elif abs(lo / hint - 1.0) < 1e-9 and hi / lo > width:
            probe = lo * width
            if analyse(probe)[0]:
                hi = probe
            else:
                lo = probe
    while hi / lo > width * (1.0 + 1e-12):
        mid = math.sqrt(lo * hi)
        if analyse(mid)[0]:
            hi = mid
        else:
            lo = mid
    return hi


def _search_settings(rtol: Any, step: Any) -> tuple[float, float]:
    """`rtol` in (0, 1) and `step` above 1, as floats (else an `InputError`)."""
    rtol = _positive("rtol", rtol)
    if rtol >= 1.0:
        raise InputError(f"rtol={rtol!r} must be below 1 (relative width of the bracket)")
    step = _positive("step", step)
    if step <= 1.0:
        raise InputError(f"step={step!r} must be greater than 1 (the ratio of the hunt's "
                         "geometric grid)")
    return rtol, step


def search(analyse, s_start: float, s_max: float, step: float, rtol: float,
           max_stride: float = MAX_STRIDE, target: float = RATIO_TARGET, *,
           hint: float | None = None, margin: float = MARGIN):
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
    hint : float, optional
        Warm start (module docstring, "Warm start"): a scale factor near which the wall is
        expected to collapse (a neighbouring cell's capacity). The hunt then starts
        `margin` below it (rounded up to whole grid steps; `s_start` is not used), its
        grid passes through the hint and no stride steps over it. None, NaN or <= 0: the
        cold start at `s_start`. [1]
    margin : float
        Relative distance below the hint where a warm start begins. [1]

    Returns
    -------
    (float, bool)
        The capacity as a scale factor (``s_max`` when censored) and the censored flag.
    """
    warm = hint is not None and math.isfinite(hint) and hint > 0
    if warm:
        step = _warm_step(step, rtol)
    big = max(1, int(math.floor(math.log(max_stride) / math.log(step) + 1e-9)))
    # the grid anchor * step**k: through the hint (k = 0 there) when warm
    anchor, k = (min(hint, s_max), -_grid_steps(1.0 + margin, step)) if warm else (
        min(s_start, s_max), 0)
    first = k
    hi = None
    s = min(anchor * step ** k, s_max)
    collapsed, ratio = analyse(s)
    lo = s
    if collapsed:  # down in whole strides to a survivor, then up again from it
        k, hi, ratio = _hunt_down(analyse, anchor, k, step, max(1, -first) if warm else big,
                                  big, warm)
        if k is None:
            return hi, False
        lo = anchor * step ** k
    while True:  # up: strides of whole grid steps, shorter as the ratio nears the target
        want = min(max_stride, max(step, target / max(ratio, 1e-9)))
        stride = max(1, min(big, int(math.floor(math.log(want) / math.log(step) + 1e-9))))
        if warm and k < 0:
            stride = min(stride, -k)  # never over the hint
        k += stride
        s = anchor * step ** k
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
    return _bisect(analyse, lo, hi, rtol, anchor if warm else None), False


def collapse_capacity(wall: Wall, record: Any, *, im: str = DEFAULT_IM, cor: float = 0.8,
                      rtol: float = RTOL, step: float = STEP,
                      max_intensity: float | None = None, impact: str = "scale",
                      start: float | None = None, records_dir=None,
                      kernel=None, period_range=None,
                      hint: float | CollapseCapacity | None = None) -> CollapseCapacity:
    """Collapse capacity of one wall under one record: the smallest intensity at which it
    collapses (hunt, then bisection; first-collapse convention; module docstring).

    Parameters
    ----------
    wall : urmx.Wall
        The wall and its supports.
    record : Record, obspy.Trace, str or (array, dt)
        Ground acceleration in m s-2 (`urmx.records.as_record`): a Trace as given, a
        manifest id or record file, or samples and their time step [s]. The record is
        analysed times its own scale factor (a manifest id at the manifest's, as studies
        use it). A record with NaN or infinite samples is refused, naming the first.
    im : {"pga", "pgv", "sa_wall", "sa_diaphragm", "sa_avg", "scale"}
        Intensity measure of the capacity (`urmx.fragility.intensity`).
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
    period_range : (float, float), optional
        Periods of ``im="sa_avg"`` instead of the wall's default range
        (`urmx.fragility.sa_avg_range`). [s]
    hint : float or CollapseCapacity, optional
        Warm start (module docstring): where the wall is expected to collapse, in `im`
        for this wall, or a neighbour's `CollapseCapacity` under the same record (its
        scale factor is used). The hunt starts `MARGIN` below it. [units of the measure]

    Returns
    -------
    CollapseCapacity
        Capacity, censored flag, IDA points, number of analyses.

    Notes
    -----
    All runs of a cell reuse the kernel's tables of the wall (cached per wall and record
    step by `urmx.kernel.run`); the default kernel runs with ``track="capacity"``.
    """
    check_im(im)
    track = TRACK if kernel is None else None
    kernel = kernel or run_kernel
    if not isinstance(wall, Wall):
        raise InputError(f"wall must be a urmx.Wall, not {type(wall).__name__}")
    rtol, step = _search_settings(rtol, step)
    rec = as_record(record, records_dir)
    acc = check_finite(rec.scaled(), f"record {rec.id!r}", rec.dt)
    if not np.any(acc):
        raise InputError(f"record {rec.id!r} is all zeros: it cannot collapse a wall")
    if period_range is not None:
        period_range = check_period_range(period_range)
    unit = record_intensity(rec, im, wall, period_range)
    max_intensity = _positive("max_intensity", MAX_INTENSITY[im] if max_intensity is None
                              else max_intensity)
    start = None if start is None else _positive("start", start)
    hint_scale = hint.capacity / hint.record_intensity if isinstance(
        hint, CollapseCapacity) else None if hint is None else _positive("hint", hint) / unit
    return cell_capacity(kernel, wall, acc, rec.dt, unit, im, cor, impact, rtol, step,
                         max_intensity, start, rec.id, hint_scale=hint_scale, track=track)


def cell_capacity(kernel, wall: Wall, acc: np.ndarray, dt: float, unit: float, im: str,
                  cor: float, impact: str, rtol: float, step: float, max_intensity: float,
                  start: float | None = None, label: str = "", *,
                  hint_scale: float | None = None, track: str | None = None
                  ) -> CollapseCapacity:
    """`collapse_capacity` on validated inputs, numpy only: the samples `acc` as analysed
    [m s-2] at step `dt` [s], the record's intensity at scale 1 `unit` [units of the
    measure] (a study's batches call it directly).

    Parameters
    ----------
    kernel : callable
        Integrator with the signature of `urmx.kernel.run`.
    wall : urmx.Wall
        The wall and its supports.
    acc : ndarray of float
        The record's samples as analysed (times its scale factor). [m s-2]
    dt : float
        Their time step. [s]
    unit : float
        The record's intensity at scale 1, in the measure `im`. [units of the measure]
    im : str
        Intensity measure of the capacity (`IMS`).
    cor : float
        Coefficient of restitution, in (0, 1]. [1]
    impact : {"scale", "contact"}
        Impact law (MODEL.md section 8).
    rtol : float
        Relative width of the final bracket. [1]
    step : float
        Ratio of the hunt's geometric grid of scale factors, > 1. [1]
    max_intensity : float
        Highest intensity analysed; a wall surviving it is censored there.
        [units of the measure]
    start : float, optional
        First intensity of the hunt (default as `collapse_capacity`). [units of the measure]
    label : str
        The cell, for messages.
    hint_scale : float, optional
        Warm start: the scale factor near which the wall is expected to collapse (a
        neighbouring cell's capacity over its record intensity); None or NaN: the cold
        start. [1]
    track : str, optional
        The kernel's tracking mode (``"capacity"``: only the drift trackers the search
        needs); None: the kernel's default (a kernel that does not take it).
    """
    pga = float(np.max(np.abs(acc)))
    if not math.isfinite(pga):
        check_finite(acc, f"record {label!r}", dt)
    if not (unit > 0 and pga > 0):
        raise InputError(f"record {label!r} is all zeros: it cannot collapse a wall")
    if start is None:
        s_start = START_FRACTION * static_acceleration(wall) / pga
    else:
        s_start = start / unit
    points: dict[float, tuple[float, bool, str]] = {}
    extra = {} if track is None else {"track": track}

    def analyse(s: float) -> tuple[bool, float]:
        res = kernel(wall, acc, dt, scale=s, cor=cor, impact=impact, **extra)
        collapsed = res["status"] == "collapsed"
        points[s] = (res["instability_ratio"], collapsed, res["status"])
        return collapsed, res["instability_ratio"]

    s_cap, censored = search(analyse, s_start, max_intensity / unit, step, rtol,
                             hint=hint_scale)
    order = sorted(points)
    return CollapseCapacity(
        capacity=max_intensity if censored else s_cap * unit, censored=censored,
        intensity=np.array(order) * unit,
        instability_ratio=np.array([points[s][0] for s in order]),
        collapsed=np.array([points[s][1] for s in order], dtype=bool),
        analyses=len(points), im=im, units=IM_ATTRS[im][0], record_intensity=unit,
        event_limits=sum(1 for v in points.values() if v[2] == "event-limit"))
