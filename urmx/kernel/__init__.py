"""The exact event-driven integrator (MODEL.md sections 4-10), numpy/numba only.

Method
------
Between two events the reduced system ``M y_dd + C y_d + K y + R0 = -G xg_dd(t)`` is
linear with constant coefficients, and inside one record step the forcing is linear in
time. Its solution is an entire function of time, so:

* Each piece (held joints, family, lower branch, upper branch) gets a *mode*: ``M^-1 K``,
  ``M^-1 C``, ``M^-1 R0``, ``M^-1 G`` and the exact propagator over a sub-step
  ``h = dt/nsub`` (state-transition matrix plus the responses to the resistance, constant
  and ramp forcing: one matrix exponential of the augmented first-order system). They are
  built in numpy for every piece a wall can reach, before its first analysis at a record
  step (a few ms), and kept for the next analysis of the same wall and step.
  ``nsub`` is the smallest integer with ``nu*h <= 1``, ``nu`` the spectral radius of the
  first-order system (1 for soft walls; a 1e9 N/m spring needs more).
* Whole sub-steps are stepped by one matrix-vector product (exact to round-off).
* Where an event function changes sign on a sub-step, or may dip through zero between
  its ends (a cubic Hermite estimate from the exact values and rates at both ends says it
  might), or starts at zero, or where a peak output may have an interior extremum above
  its running peak, the exact solution on that sub-step is expanded in its Taylor series
  about the sub-step start. With ``nu*h <= 1`` the series converges to round-off in 10-30
  terms and the roots of event functions, their times, and the states there are found on
  it by a bracketed Newton iteration that stops on the bracket width (TIME_TOL), and a
  root is then polished to the last few ulps (:func:`loop._polish`).
  The state at an event is the series summed at the event time, not an interpolant.
* A function at zero after an event (the joint that has just impacted, a joint released
  from a hold with gap, rate and acceleration zero, a branch boundary just crossed: its
  value is below what its rate covers in 1/16 of a sub-step) can come back within the
  sub-step, even twice, which the signs at the sub-step's ends do not show. On the
  sub-step after the event (and on the next one too when that was shorter than 1/16 of a
  sub-step) its series is searched for its first fall (:func:`loop._first_fall`: samples
  growing geometrically from the start, then even ones, extrema between samples located
  exactly), unless the series proves that it rises throughout (:func:`loop._rising`, after
  most events) or that it is concave (:func:`loop._no_extra_fall`). This search runs after the
  one above and only an earlier fall replaces what that found, so a sub-step without
  such a fall gives the same bits as before it existed.

The package: this face (:func:`run`, :func:`warm_up`, :data:`STATUS`, :data:`LAWS`,
:func:`scalars`), :mod:`urmx.kernel.loop` (the compiled loop, its helpers and the constants
that size its arrays), :mod:`urmx.kernel.pieces` (the host-side piece tables and their
cache) and :mod:`urmx.kernel.checks` (what a wall and a record must satisfy).

The integration loop (:func:`loop._march`) is one compiled function that never allocates
(``_nrt=False``: numba's reference counting of every array passed to every helper cost
more than the arithmetic); :func:`run` allocates its work arrays once per wall. What made
it fast, and what each choice costs in compile time, is measured in
``reports/performance.md``.

Event semantics (contacts, the opening rule, held joints, impacts and their laws, merged
impacts, branch changes, collapse) live in the small functions of :mod:`urmx.kernel.loop`
and are shared with the scipy reference solver in :mod:`urmx.reference`.

Documented choices (MODEL.md section 4)
---------------------------------------
* Event times are bracketed to ``TIME_TOL = 1e-12 s`` and then polished to the last few
  ulps of the time (:func:`loop._polish`): an event's time is the root of its function's series
  as round-off allows, not a point of the bracket that the search happened to leave.
* Both joints start closed; a closed joint opens when ``|g|`` exceeds
  ``g_open = 1e-6 * theta_a(Case 2)``, taking the side of ``g``. A closed (or held) joint
  has no side of its own: whenever one joint opens, is released or changes side at an
  impact while the other is not open, the other's side is re-set so that the pattern is
  family 2; family 1 needs both joints open. With a flexible base the side on which the
  wall departs is decided by high-order terms, and in a few percent of walls the result
  depends on this rule.
* Held joints. A joint that an impact leaves with ``|g_d| < v_rest = g_open/t_rest`` (``t_rest``
  a constant of the model, default ``T_REST = 0.01 s``, a setting; not the record step,
  which made the answer depend on how finely the same motion is sampled) is *held*
  closed: its gap is kept at zero by a constraint (``theta1 = 0`` for the base joint,
  ``theta2 = theta1`` for the crack joint, one coordinate fewer; its small residual rate is
  removed by a perfectly plastic impulse), with the mass matrix and curves of the family
  after that impact. It is released when the constraint would have to pull: when the
  unconstrained motion of a family, at the current state, accelerates the gap away from
  zero on that family's side (``sigma * g_dd(family(sigma)) > 0``, family 2 while the
  other joint is not open; when both sides qualify at once, the side whose family is the
  current one: :func:`loop.release_tie`). A hold may last no time (released at once). While
  both families drive the gap back to zero (a sticking joint, which none of the four
  patterns describes) it stays held. Physically: a joint that an impact leaves slower than
  it would open g_open in t_rest is closed until the opening rule opens it again. This ends Zeno
  chatter (impacts accumulating at a point) in a held joint instead of in the event bound.
* Impacts closer than the window ``w`` (default 1e-6 s) are merged (section 7).
* At most ``MAX_EVENTS`` (200) events in one span of ``EVENT_SPAN`` (0.01 s; spans from
  t = 0, not record steps); beyond that the run stops with status ``event-limit`` (a guard
  against a hang; no catalog wall reaches it).
* Bounded work: the record step must lie in ``DT_RANGE`` (1e-6 to 1 s), and a support
  whose spring needs more than ``MAX_SUBSTEPS`` (1000) sub-steps a record step is refused
  when the wall's tables are built, with the advice to declare it rigid (1e9 N/m springs
  without diaphragm mass, the stiffest the catalog and the tests use, need 101 at
  dt = 0.02 s).
"""


from __future__ import annotations

import math

import numpy as np

from ..model import P_A1, P_A2, T_REST, Wall
from .checks import TRACKS, check_inputs, check_t_rest, check_track
from .loop import (
    DT_RANGE,
    EV_BASE_IMPACT,
    EV_BASE_OPEN,
    EV_BASE_RELEASE,
    EV_COLLAPSE_LOWER,
    EV_COLLAPSE_UPPER,
    EV_CRACK_IMPACT,
    EV_CRACK_OPEN,
    EV_CRACK_RELEASE,
    EV_HELD_BRANCH,
    EV_LOWER,
    EV_UPPER,
    EVENT_NAMES,
    EVENT_SPAN,
    LAWS,
    LOOPS,
    MAX_EVENTS,
    MAX_SUBSTEPS,
    O_BASE_IMP,
    O_COLLAPSE_SEG,
    O_COLLAPSE_T,
    O_CRACK_IMP,
    O_DURATION,
    O_EVENTS,
    O_FAM1_TIME,
    O_HOLDS,
    O_NEED,
    O_SERIES,
    O_SUBSTEPS,
    ST_COLLAPSED,
    ST_EVENT_LIMIT,
    ST_NEED_PIECE,
    ST_OK,
    STATUS,
    TR_AB,
    TR_AC,
    TR_AT,
    TR_D1F1,
    TR_D1F2,
    TR_D2,
    TR_UB,
    TR_UC,
    TR_UT,
    WINDOW,
    piece_key,
)
from .pieces import NO_HIST, NO_LOG, Tables, clear_cache, tables, theta0

__all__ = [
    "DT_RANGE", "EVENT_NAMES", "EVENT_SPAN", "EV_BASE_IMPACT", "EV_BASE_OPEN",
    "EV_BASE_RELEASE", "EV_COLLAPSE_LOWER", "EV_COLLAPSE_UPPER", "EV_CRACK_IMPACT",
    "EV_CRACK_OPEN", "EV_CRACK_RELEASE", "EV_HELD_BRANCH", "EV_LOWER", "EV_UPPER", "LAWS",
    "MAX_EVENTS", "MAX_SUBSTEPS", "STATUS", "ST_COLLAPSED", "ST_EVENT_LIMIT",
    "ST_NEED_PIECE", "ST_OK", "TRACKS", "T_REST", "Tables", "UNTRACKED", "WINDOW",
    "check_inputs", "check_t_rest", "check_track",
    "clear_cache", "history_dict", "run", "scalars", "tables", "warm_up", "warm_up_capacity",
]


#: the peaks a ``track="capacity"`` run does not follow (NaN in its result)
UNTRACKED = ("peak_crack_displacement", "peak_top_displacement", "peak_base_displacement",
             "peak_top_acceleration", "peak_crack_acceleration", "peak_base_acceleration")


def scalars(peaks, outs, status, P, track="all"):
    """The result dict of one analysis (shared by both solvers): tracker peaks scaled to
    drifts and instability ratios (a ratio is 1.0 at a collapse of its segment); with
    ``track="capacity"`` the peaks of `UNTRACKED` are NaN."""
    pk = peaks.tolist()  # Python floats in one call (this runs once per analysis)
    out = outs.tolist()
    duration = out[O_DURATION]
    a1, a2 = float(P[P_A1]), float(P[P_A2])
    d1_f1, d1_f2 = pk[TR_D1F1], pk[TR_D1F2]
    lower = max(d1_f1 / (a1 * theta0(P, 3)), d1_f2 / (a1 * theta0(P, 2)))
    upper = pk[TR_D2] / (a2 * theta0(P, 1))
    if status == ST_COLLAPSED:
        seg = int(out[O_COLLAPSE_SEG])
        lower = 1.0 if seg == 1 else min(lower, 1.0)
        upper = 1.0 if seg == 2 else min(upper, 1.0)
    res = {
        "peak_crack_displacement": pk[TR_UC],
        "peak_top_displacement": pk[TR_UT],
        "peak_base_displacement": pk[TR_UB],
        "peak_lower_drift": max(d1_f1, d1_f2),
        "peak_upper_drift": pk[TR_D2],
        "peak_top_acceleration": pk[TR_AT],
        "peak_crack_acceleration": pk[TR_AC],
        "peak_base_acceleration": pk[TR_AB],
        "instability_ratio_lower": lower,
        "instability_ratio_upper": upper,
        "instability_ratio": max(lower, upper),
        "peak_lower_drift_family1": d1_f1,
        "collapsed": int(status == ST_COLLAPSED),
        "collapse_time": out[O_COLLAPSE_T],
        "unfavourable_fraction": out[O_FAM1_TIME] / duration if duration > 0 else 0.0,
        "base_impacts": int(out[O_BASE_IMP]),
        "crack_impacts": int(out[O_CRACK_IMP]),
        "status": STATUS[status],
        "duration": duration,
        "events": int(out[O_EVENTS]),
        "holds": int(out[O_HOLDS]),
        "substeps": int(out[O_SUBSTEPS]),
        "series": int(out[O_SERIES]),
    }
    if track == "capacity":
        for key in UNTRACKED:
            res[key] = math.nan
    return res



def run(wall: Wall, ground_acceleration, dt: float, *, scale: float = 1.0, cor: float = 0.8,
        impact: str = "scale", tail: float = 0.0, window: float = WINDOW,
        t_rest: float = T_REST, history: bool = False, max_log: int = 0, track: str = "all"
        ) -> dict:
    """One analysis with the exact kernel: the array-level entry point studies call.

    Parameters
    ----------
    wall : urmx.Wall
        The wall and its supports.
    ground_acceleration : array_like
        Ground acceleration samples. [m s-2]
    dt : float
        Record time step. [s]
    scale : float
        Factor applied to the record. [1]
    cor : float
        Coefficient of restitution, in (0, 1]. [1]
    impact : {"scale", "contact"}
        Impact law (MODEL.md section 8).
    tail : float
        Free-vibration tail after the record, rounded to whole steps. [s]
    window : float
        Merged-impact window w. [s]
    t_rest : float
        A joint that an impact leaves with a rate below ``v_rest = g_open/t_rest`` is held
        closed (MODEL.md section 4); a constant of the model, not the record step: the
        answer does not depend on how finely the record is sampled. [s]
    history : bool
        Also return the histories on the record grid under ``"history"``.
    max_log : int
        Keep the first `max_log` events as ``"event_log"`` rows: time [s], kind (an index
        of ``EVENT_NAMES``), target (a side or branch) and the pattern after the event
        (11, 12, 21 or 22).
    track : {"all", "capacity"}
        ``"capacity"`` follows only the drifts (a quarter less work, for capacity searches):
        the other outputs as ``"all"`` bit for bit but `UNTRACKED` (NaN) and ``series``.

    Returns
    -------
    dict
        The scalars of ``urmx.variables.SCALARS`` as floats/ints, ``status`` ("ok",
        "collapsed" or "event-limit"), ``duration`` (analysed, s), ``events`` and
        ``holds`` (joints held closed after an impact).
    """
    ag, dt, ntail, law = check_inputs(wall, ground_acceleration, dt, scale, cor, impact, tail,
                                      window, t_rest)
    capacity = check_track(track) == "capacity"  # (two native loops, each compiled once)
    tab = tables(wall, dt)
    n = tab.nfull
    args = tab.args
    # without history or a log the kernel never writes them (placeholders in the block)
    hist = np.full((ag.size + ntail, 9 + 2 * n), np.nan) if history else None
    evlog = np.zeros((max_log, 4)) if max_log else None
    with args.lock:  # the wall's blocks serve one analysis at a time
        try:
            if hist is not None:
                args.put("hist", hist)
            if evlog is not None:
                args.put("evlog", evlog)
            while True:
                status = args.run(ag, (ntail, law, int(history), int(capacity)),
                                  (cor, window, float(t_rest)), LOOPS[capacity])
                if status != ST_NEED_PIECE:
                    break
                # a piece not foreseen as reachable: add it, run again
                tab.build([piece_key(int(args["outs"][O_NEED]))])
                if hist is not None:
                    hist[:] = np.nan
            res = scalars(args["peaks"], args["outs"], status, tab.P, track)
        finally:
            if hist is not None:
                args.put("hist", NO_HIST)
            if evlog is not None:
                args.put("evlog", NO_LOG)
    if hist is not None:
        res["history"] = history_dict(hist, dt, n)
    if evlog is not None:
        res["event_log"] = evlog[:min(max_log, res["events"])]
    return res


def history_dict(hist: np.ndarray, dt: float, n: int) -> dict:
    """Histories on the grid (NaN and pattern 0 after a stop)."""
    pattern = hist[:, 8].copy()
    pattern[~np.isfinite(pattern)] = 0
    return {
        "time": np.arange(hist.shape[0]) * dt,
        "theta_lower": hist[:, 0], "theta_upper": hist[:, 1],
        "base_displacement": hist[:, 2], "crack_displacement": hist[:, 3],
        "top_displacement": hist[:, 4], "base_acceleration": hist[:, 5],
        "crack_acceleration": hist[:, 6], "top_acceleration": hist[:, 7],
        "pattern": pattern.astype(np.int8),
        "r": hist[:, 9:9 + n], "r_dot": hist[:, 9 + n:9 + 2 * n],
    }



def warm_up(track: str = "all") -> None:
    """Compile the kernel for a tracking mode (or load it from the on-disk cache) with a
    tiny analysis: ``"all"`` and ``"capacity"`` run two native loops (the capacity one has
    the runs of plain steps compiled in).

    Called before local worker processes start, so that they load the compiled kernel
    from the cache instead of each compiling it on the same cores."""
    wall = Wall(0.2, 2.0, 0.5, 100.0, top_mass=10.0, top_stiffness=1e5)
    run(wall, np.array([0.0, 1.0, 0.0]), 0.01, impact="contact", track=track)


def warm_up_capacity() -> None:
    """:func:`warm_up` of the capacity loop (what a collapse-capacity study's workers run)."""
    warm_up("capacity")

