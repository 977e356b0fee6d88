"""The kernel's compiled loop and its helpers (numba, compiled lazily by urmx.jitcache).

The constants that size its arrays, the event semantics shared with the scipy reference
(:mod:`urmx.reference`), the Taylor series and root finding, and the integration loop
:func:`_march` that :mod:`urmx.native` compiles once into a native object. The method is
described in :mod:`urmx.kernel`; the host-side tables the loop reads are built in
:mod:`urmx.kernel.pieces`.
"""

from __future__ import annotations

import math

import numpy as np

from .. import jitcache, native
from ..model import (
    HELD_BASE,
    HELD_BOTH,
    HELD_CRACK,
    HELD_NONE,
    P_RIGID_B,
    P_RIGID_T,
    classify,
    curve,
    lower_case,
)

KMAX = 48  # most Taylor terms a sub-step may need
_INV12 = np.array([1.0 / ((j + 1.0) * (j + 2.0)) for j in range(KMAX)])
_INV2 = np.array([1.0 / (j + 2.0) for j in range(KMAX)])
RHO = 1.0  # nu*h bound of a sub-step
GATE = 0.05  # refine an interior extremum when the Hermite estimate is within 5 % of the peak
TIME_TOL = 1e-12  # event time tolerance [s]
# the event bound: at most MAX_EVENTS events in one span of EVENT_SPAN seconds (spans of
# fixed length from t = 0, not record steps: the bound does not depend on the sampling)
MAX_EVENTS = 200
EVENT_SPAN = 0.01  # [s]
WINDOW = 1e-6  # merged-impact window w [s]
DT_RANGE = (1e-6, 1.0)  # record steps the kernel accepts [s]
# most sub-steps a record step may need: a support whose spring needs more is refused
# (declared rigid it is a constraint and needs none); 1e9 N/m springs without diaphragm
# mass, the stiffest the catalog and the tests use, need 101 at dt = 0.02 s
MAX_SUBSTEPS = 1000
G_OPEN_FACTOR = 1e-6

# every numba array over the reduced coordinates is padded to NP entries: the unused
# trailing ones stay exactly zero (padded matrices have zero rows and columns there), so
# every small loop has a constant trip count the compiler unrolls
NP = 3
# rows over the coordinates y of the quantities the kernel watches
ROW_T1, ROW_T2, ROW_UB, ROW_UC, ROW_UT, ROW_GC = range(6)
# peak trackers (the first N_DISP act on y, the rest on y_dd plus the ground): u_b, u_c,
# u_t, the lower drift a1*theta1 while in family 1 (zero row in family 2) and while in
# family 2, the upper drift a2*theta2, and the three absolute accelerations. The
# instability ratios are drift peaks over a*theta0 (theta0 of each family's lower case),
# so the lower ratio, whose theta0 changes with the family, and the drift while in
# patterns 11/12 both come exactly.
TR_UB, TR_UC, TR_UT, TR_D1F1, TR_D1F2, TR_D2, TR_AB, TR_AC, TR_AT = range(9)
N_TRACK = 9
N_DISP = 6
# integer state: family, sides, joint states, branches of the lower curve, the upper
# curve and the lower curve of the other family (held crack joint), held state
I_FAM, I_S, I_C, I_BOPEN, I_COPEN, I_BL, I_BU, I_BLA, I_H = range(9)
N_IST = 9
JOINT_CLOSED, JOINT_OPEN, JOINT_HELD = 0, 1, 2
# event kinds
EV_BASE_IMPACT, EV_CRACK_IMPACT, EV_BASE_OPEN, EV_CRACK_OPEN = 0, 1, 2, 3
EV_LOWER, EV_UPPER, EV_COLLAPSE_LOWER, EV_COLLAPSE_UPPER = 4, 5, 6, 7
EV_BASE_RELEASE, EV_CRACK_RELEASE, EV_HELD_BRANCH = 8, 9, 10
EVENT_NAMES = ("base impact", "crack impact", "base opens", "crack opens", "lower branch",
               "upper branch", "lower collapse", "upper collapse", "base released",
               "crack released", "held branch")
MAX_EV = 8
# the event functions a piece of two open joints has (two impacts, two branches of each
# curve): the hot loops run over KE of them when a piece has no more, else over MAX_EV
KE = 6
# status codes (ST_NEED_PIECE is internal: a piece's tables are missing, see run)
ST_OK, ST_COLLAPSED, ST_EVENT_LIMIT, ST_NEED_PIECE = 0, 1, 2, 3
STATUS = ("ok", "collapsed", "event-limit")
LAWS = {"scale": 0, "contact": 1}
# scalar outputs of _march (index order)
O_COLLAPSE_T, O_FAM1_TIME, O_DURATION, O_BASE_IMP, O_CRACK_IMP, O_EVENTS = range(6)
O_SUBSTEPS, O_SERIES, O_HOLDS, O_NEED, O_COLLAPSE_SEG = 6, 7, 8, 9, 10
N_OUT = 11
# pieces: held state x family x branches (module docstring); see mode_index
NPIECE = 312
REL_W = 2 * NP + 2  # a release row: coefficients on y, on y_d, on xg_dd, constant
# the arrays of _march, in the order of their slots in its argument block (urmx.native),
# as (name, dtype, number of dimensions): the wall's parameters, the record, the geometry,
# piece and work arrays of Tables, and the outputs. The native call is compiled for this
# table and every Tables checks its arrays against it.
_F, _I, _B = "<f8", "<i8", "|b1"
ARRAYS = (
    ("P", _F, 1), ("ag", _F, 1),
    ("GL", _F, 3), ("GN", _F, 3), ("GX", _F, 4), ("GMI", _F, 4), ("GROT", _F, 2),
    ("GNN", _I, 1), ("GTR", _F, 4),
    ("ready", _B, 1), ("nsub", _I, 1), ("mats", _F, 4), ("vecs", _F, 3), ("prop", _F, 3),
    ("pvec", _F, 3), ("rel", _F, 4),
    ("D", _F, 2), ("cf", _F, 1), ("ist", _I, 1), ("rows", _F, 2), ("vrows", _F, 2),
    ("agc", _F, 1), ("sig", _F, 1), ("kap", _F, 1), ("kind", _I, 1), ("tgt", _I, 1),
    ("e_a", _F, 1), ("ed_a", _F, 1), ("e_b", _F, 1), ("ed_b", _F, 1), ("RT", _F, 2),
    ("RVT", _F, 2), ("AGT", _F, 1), ("KP", _F, 1), ("OPN", _F, 1), ("val_a", _F, 1),
    ("der_a", _F, 1), ("val_b", _F, 1), ("der_b", _F, 1), ("r", _F, 1), ("v", _F, 1),
    ("rb", _F, 1), ("vb", _F, 1), ("sacc", _F, 1), ("sjerk", _F, 1), ("tmp", _F, 1),
    ("counts", _I, 1),
    ("peaks", _F, 1), ("outs", _F, 1), ("hist", _F, 2), ("evlog", _F, 2),
)
# _march's parameters in order: names of ARRAYS, of the integer arguments (INTS; want_hist
# a boolean) and of the real ones (REALS), and tuples of array names (passed as tuples)
INTS = ("ntail", "law", "want_hist", "capacity")
REALS = ("dt", "cor", "window", "t_rest")
LOOP_ARGS = ("P", "ag", "dt", "ntail", "cor", "law", "window", "t_rest",
             tuple(x[0] for x in ARRAYS[2:9]), tuple(x[0] for x in ARRAYS[9:16]),
             tuple(x[0] for x in ARRAYS[16:47]), "peaks", "outs", "hist", "want_hist",
             "evlog", "capacity")

# Compiled functions (urmx.jitcache: numba is imported only when one is compiled). The
# integration loop _march is compiled once into a native object that later processes load
# without numba (urmx.native); the helpers are compiled as part of it, with no Python
# wrapper and no cache of their own: that halves what a cold start compiles and writes.
# The reference solver's entry points are cached by numba (urmx.jitcache). No function
# allocates (``_nrt=False``: numba's reference counting of
# every array argument cost more than the arithmetic); the kernel guards its own divisions
# (``error_model="numpy"``: no zero-divisor test before each one).
_FLAGS = dict(_nrt=False, error_model="numpy")
entry = jitcache.jit(cache=True, **_FLAGS)
inner = jitcache.jit(cache=False, no_cpython_wrapper=True, no_cfunc_wrapper=True, **_FLAGS)
inline = jitcache.jit(cache=False, no_cpython_wrapper=True, no_cfunc_wrapper=True,
                      forceinline=True, **_FLAGS)


# ---- shared event semantics -----------------------------------------------------------

@inline
def _rowdot(A, i, x):
    """Row i of a padded matrix times a padded vector (no array view is created)."""
    out = 0.0
    for k in range(NP):
        out += A[i, k] * x[k]
    return out


@inline
def mode_index(h, fam, bl, bu, bla):
    """Index of a piece's tables: held state h, family, lower, upper and other-family
    lower branch (the last only with a held crack joint)."""
    if h == 0:
        return (fam - 1) * 25 + (bl + 2) * 5 + (bu + 2)
    if h == 1:
        return 50 + (fam - 1) * 5 + (bu + 2)
    if h == 2:
        return 60 + (fam - 1) * 125 + (bl + 2) * 25 + (bu + 2) * 5 + (bla + 2)
    return 310 + (fam - 1)


def piece_index(h: int, fam: int, bl: int, bu: int, bla: int) -> int:
    """:func:`mode_index` for Python callers (the compiled one has no Python wrapper)."""
    return mode_index.py_func(h, fam, bl, bu, bla)


def piece_key(mid: int) -> tuple[int, int, int, int, int]:
    """(h, fam, bl, bu, bla) of a piece index (the inverse of :func:`mode_index`)."""
    if mid < 50:
        return 0, mid // 25 + 1, (mid % 25) // 5 - 2, mid % 5 - 2, 0
    if mid < 60:
        return 1, (mid - 50) // 5 + 1, 0, (mid - 50) % 5 - 2, 0
    if mid < 310:
        m = mid - 60
        return 2, m // 125 + 1, (m % 125) // 25 - 2, (m % 25) // 5 - 2, m % 5 - 2
    return 3, mid - 310 + 1, 0, 0, 0


@inline
def _put(L, lrow, k, rows, vrows, agc, sig, kap, kind, tgt, s, kp, kd, tg):
    """Event function k: e = s*(L[lrow] . y) + kp, falling through zero fires event kd."""
    for j in range(NP):
        rows[k, j] = L[lrow, j]
        vrows[k, j] = 0.0
    agc[k] = 0.0
    sig[k] = s
    kap[k] = kp
    kind[k] = kd
    tgt[k] = tg
    return k + 1


@inner
def _branch_bounds(P, case, b, collapse):
    """Interval of theta of the signed branch b: (low, high); the softening branch ends at
    theta0 when `collapse`, else it is continued without end."""
    M0, th0, Mi, ta, tb = curve(P, case)
    far = th0 if collapse else np.inf
    if b == 0:
        return -ta, ta
    if b == 1:
        return ta, tb
    if b == -1:
        return -tb, -ta
    if b == 2:
        return tb, far
    return -far, -tb


@inner
def _branch_events(P, case, b, L, lrow, kind_branch, kind_collapse, k, rows, vrows, agc,
                   sig, kap, kind, tgt):
    """The two event functions bounding the signed branch b of a curve on row L[lrow]:
    rising to its upper and falling to its lower boundary (theta0 at the ends: collapse).
    Signed boundaries, so passing through zero is never missed (MODEL.md section 11)."""
    lo, hi = _branch_bounds(P, case, b, True)
    th0 = curve(P, case)[1]
    k = _put(L, lrow, k, rows, vrows, agc, sig, kap, kind, tgt, -1.0, hi,
             kind_collapse if hi == th0 else kind_branch, b + 1)
    return _put(L, lrow, k, rows, vrows, agc, sig, kap, kind, tgt, 1.0, -lo,
                kind_collapse if lo == -th0 else kind_branch, b - 1)


@inner
def _held_branch_events(P, ist, L, k, rows, vrows, agc, sig, kap, kind, tgt):
    """With the crack joint held (theta2 = theta1) the lower curve, the upper curve and
    the other family's lower curve (its release test needs it) all follow theta1: two
    event functions bound the intersection of their three branches; reaching a bound
    re-classifies all three (coincident boundaries are one event), or is a collapse when
    the bound is theta0 of the lower (current family) or the upper segment."""
    fam = ist[I_FAM]
    hi = np.inf
    lo = -np.inf
    kd_hi = EV_HELD_BRANCH
    kd_lo = EV_HELD_BRANCH
    for which in range(3):
        if which == 0:
            a, b = _branch_bounds(P, lower_case(fam), ist[I_BL], True)
            kc = EV_COLLAPSE_LOWER
            th0 = curve(P, lower_case(fam))[1]
        elif which == 1:
            a, b = _branch_bounds(P, 1, ist[I_BU], True)
            kc = EV_COLLAPSE_UPPER
            th0 = curve(P, 1)[1]
        else:
            a, b = _branch_bounds(P, lower_case(3 - fam), ist[I_BLA], False)
            kc = EV_HELD_BRANCH
            th0 = np.inf
        collapse_hi = b == th0
        if b < hi or (b == hi and collapse_hi):
            hi = b
            kd_hi = kc if collapse_hi else EV_HELD_BRANCH
        collapse_lo = a == -th0
        if a > lo or (a == lo and collapse_lo):
            lo = a
            kd_lo = kc if collapse_lo else EV_HELD_BRANCH
    if hi < np.inf:
        k = _put(L, ROW_T1, k, rows, vrows, agc, sig, kap, kind, tgt, -1.0, hi, kd_hi, 1)
    if lo > -np.inf:
        k = _put(L, ROW_T1, k, rows, vrows, agc, sig, kap, kind, tgt, 1.0, -lo, kd_lo, -1)
    return k


@inline
def active_events(P, L, REL, ist, g_open, rows, vrows, agc, sig, kap, kind, tgt):
    """The event functions of the current piece, ``e = sig*(rows.y + vrows.y_d +
    agc*xg_dd) + kap`` (an event when e falls through zero); returns how many.

    L: watch rows of the current held state; REL: the piece's release rows, the
    unconstrained acceleration of each joint's gap under each family."""
    k = 0
    rr = P[P_RIGID_B] > 0.5 and P[P_RIGID_T] > 0.5
    for which in range(2):
        lrow = ROW_T1 if which == 0 else ROW_GC
        side = ist[I_S] if which == 0 else ist[I_C]
        state = ist[I_BOPEN] if which == 0 else ist[I_COPEN]
        if state == JOINT_OPEN:  # impact when side*g falls to zero
            k = _put(L, lrow, k, rows, vrows, agc, sig, kap, kind, tgt, float(side), 0.0,
                     EV_BASE_IMPACT if which == 0 else EV_CRACK_IMPACT, 0)
        elif state == JOINT_CLOSED:  # opening when |g| exceeds g_open
            kd = EV_BASE_OPEN if which == 0 else EV_CRACK_OPEN
            k = _put(L, lrow, k, rows, vrows, agc, sig, kap, kind, tgt, -1.0, g_open, kd, 1)
            k = _put(L, lrow, k, rows, vrows, agc, sig, kap, kind, tgt, 1.0, g_open, kd, -1)
        elif not (rr and which == 1):  # held (both rigid: one coordinate, the base's test)
            other_open = (ist[I_COPEN] if which == 0 else ist[I_BOPEN]) == JOINT_OPEN
            other_side = ist[I_C] if which == 0 else ist[I_S]
            for sg in (1, -1):
                # released to side sg when sg*g_dd of the family it would then be in
                # turns positive (family 2 while the other joint is not open)
                f = (1 if sg == other_side else 2) if other_open else 2
                for j in range(NP):
                    rows[k, j] = REL[which, f - 1, j]
                    vrows[k, j] = REL[which, f - 1, NP + j]
                agc[k] = REL[which, f - 1, 2 * NP]
                sig[k] = -sg
                kap[k] = -sg * REL[which, f - 1, 2 * NP + 1]
                kind[k] = EV_BASE_RELEASE if which == 0 else EV_CRACK_RELEASE
                tgt[k] = sg
                k += 1
    if ist[I_BOPEN] == JOINT_OPEN and ist[I_COPEN] == JOINT_OPEN and rr:
        k -= 1  # both supports rigid: the two contacts are one coordinate, one impact
    h = ist[I_H]
    if h == HELD_NONE:
        k = _branch_events(P, lower_case(ist[I_FAM]), ist[I_BL], L, ROW_T1, EV_LOWER,
                           EV_COLLAPSE_LOWER, k, rows, vrows, agc, sig, kap, kind, tgt)
        k = _branch_events(P, 1, ist[I_BU], L, ROW_T2, EV_UPPER, EV_COLLAPSE_UPPER, k, rows,
                           vrows, agc, sig, kap, kind, tgt)
    elif h == HELD_BASE:
        k = _branch_events(P, 1, ist[I_BU], L, ROW_T2, EV_UPPER, EV_COLLAPSE_UPPER, k, rows,
                           vrows, agc, sig, kap, kind, tgt)
    elif h == HELD_CRACK:
        k = _held_branch_events(P, ist, L, k, rows, vrows, agc, sig, kap, kind, tgt)
    return k


@inner
def release_tie(ist, kind, tgt, k_ev, k):
    """True when event k should replace event k_ev due at the same instant: both release
    the same held joint, and k to the side whose family is the current one (its own side:
    the family the hold is in), which opens when both sides qualify (MODEL.md section 4).
    Any other tie keeps the event found first."""
    if kind[k] != kind[k_ev] or not (kind[k] == EV_BASE_RELEASE or kind[k] == EV_CRACK_RELEASE):
        return False
    return tgt[k] == (ist[I_S] if kind[k] == EV_BASE_RELEASE else ist[I_C])


@inner
def set_family(P, ist, r, v, L):
    """Family from the pivot sides; branches re-classified where the family or the held
    state asks for it. Returns True when |theta1| is at or beyond the new case's theta0
    (an immediate collapse)."""
    fam = 1 if ist[I_S] == ist[I_C] else 2
    th1 = _rowdot(L, ROW_T1, r)
    rate = _rowdot(L, ROW_T1, v)
    changed = fam != ist[I_FAM]
    ist[I_FAM] = fam
    h = ist[I_H]
    if h == HELD_BASE or h == HELD_BOTH:
        ist[I_BL] = 0
        ist[I_BLA] = 0
        if h == HELD_BOTH:
            ist[I_BU] = 0
    elif h == HELD_CRACK:
        ist[I_BL] = classify(P, lower_case(fam), th1, rate)
        ist[I_BU] = classify(P, 1, th1, rate)
        ist[I_BLA] = classify(P, lower_case(3 - fam), th1, rate)
    else:
        ist[I_BLA] = 0
        if changed:
            ist[I_BL] = classify(P, lower_case(fam), th1, rate)
    return changed and abs(th1) >= curve(P, lower_case(fam))[1]


@inline
def _quad(Minv, L, i, j):
    """L[i] . Minv . L[j] over padded coordinates."""
    out = 0.0
    for k in range(NP):
        s = 0.0
        for q in range(NP):
            s += L[i, q] * Minv[q, k]
        out += s * L[j, k]
    return out


@inner
def impact_velocity(L, v, base, crack, cor, law, Minv, rot):
    """Velocity jump of an impact in padded coordinates.

    scale: every rotational component (rot[i] = 1) times cor; an independent u_b is
    unchanged.
    contact: v+ = v- + Minv J^T lam with J v+ = cor * J v- (generalised Newton law),
    Minv of the pattern after the impact; parallel rows (both supports rigid) use one.
    With cor = 0 and the contact law this is the plastic impulse that holds a joint."""
    if law == 0:
        for i in range(NP):
            if rot[i] > 0.5:
                v[i] *= cor
        return
    ja = ROW_T1 if base else ROW_GC
    jb = ROW_GC
    two = base and crack
    Aaa = _quad(Minv, L, ja, ja)
    det = 1.0
    Aab = 0.0
    Aba = 0.0
    Abb = 0.0
    if two:
        Aab = _quad(Minv, L, ja, jb)
        Aba = _quad(Minv, L, jb, ja)
        Abb = _quad(Minv, L, jb, jb)
        det = Aaa * Abb - Aab * Aba
        if abs(det) <= 1e-12 * abs(Aaa * Abb):
            two = False
    if Aaa == 0.0:
        return
    ra = (cor - 1.0) * _rowdot(L, ja, v)
    if two:
        rb = (cor - 1.0) * _rowdot(L, jb, v)
        lam_a = (ra * Abb - Aab * rb) / det
        lam_b = (Aaa * rb - Aba * ra) / det
    else:
        lam_a = ra / Aaa
        lam_b = 0.0
    for i in range(NP):
        s = 0.0
        for k in range(NP):
            s += Minv[i, k] * (L[ja, k] * lam_a + L[jb, k] * lam_b)
        v[i] += s


@inline
def _row_acc(L, lrow, MK, MC, MR, MG, r, v, ag):
    """Relative acceleration of the quantity of row L[lrow] (padded arrays)."""
    out = 0.0
    for i in range(NP):
        s = -MR[i] - MG[i] * ag
        for k in range(NP):
            s -= MK[i, k] * r[k] + MC[i, k] * v[k]
        out += L[lrow, i] * s
    return out


@inner
def _held_state(ist):
    return (1 if ist[I_BOPEN] == JOINT_HELD else 0) + (2 if ist[I_COPEN] == JOINT_HELD else 0)


@inner
def _change_coords(GX, h_old, h_new, r, v, tmp):
    """Map a state to the coordinates of another held state (exact: selections)."""
    if h_old == h_new:
        return
    X = GX[h_old, h_new]
    for which in range(2):
        x = r if which == 0 else v
        for i in range(NP):
            tmp[i] = x[i]
        for i in range(NP):
            s = 0.0
            for k in range(NP):
                s += X[i, k] * tmp[k]
            x[i] = s


@inner
def _reset_other(ist, which):
    """A closed or held joint has no side of its own: when joint `which` (0 base, 1 crack)
    opens, is released or changes side while the other is not open, the other's side is
    re-set so that the pattern is family 2 (MODEL.md section 4)."""
    if which == 0 and ist[I_COPEN] != JOINT_OPEN:
        ist[I_C] = -ist[I_S]
    elif which == 1 and ist[I_BOPEN] != JOINT_OPEN:
        ist[I_S] = -ist[I_C]


@inline
def handle_event(P, GL, GX, GMI, GROT, ist, kd, target, r, v, cor, law, window, ag_now, MK,
                 MC, MR, MG, v_rest, counts, tmp):
    """Carry out one event at the current state (shared by both solvers; padded arrays).

    GL, GX, GMI, GROT: watch rows, coordinate maps, inverse masses and rotation masks of
    the held states (:func:`geometry`). Updates the integer state ist, the velocities v
    (impacts) and, when a joint is held or released, the coordinates of r and v in place.
    Counts impacts in counts[0:2] and holds in counts[2].
    Returns 0, or 1 / 2 when the lower / upper segment collapses (terminal)."""
    if kd == EV_COLLAPSE_LOWER:
        return 1
    if kd == EV_COLLAPSE_UPPER:
        return 2
    if kd == EV_LOWER:
        ist[I_BL] = target
        return 0
    if kd == EV_UPPER:
        ist[I_BU] = target
        return 0
    h = ist[I_H]
    L = GL[h]
    if kd == EV_HELD_BRANCH:  # re-classify the three branches that follow theta1
        return 1 if set_family(P, ist, r, v, L) else 0
    rr = P[P_RIGID_B] > 0.5 and P[P_RIGID_T] > 0.5
    if kd == EV_BASE_OPEN or kd == EV_CRACK_OPEN or kd == EV_BASE_RELEASE \
            or kd == EV_CRACK_RELEASE:
        # a closed joint opens on the side of g, a held one on the side it is released
        # to, without an impact (MODEL.md section 4)
        base = kd == EV_BASE_OPEN or kd == EV_BASE_RELEASE
        if base:
            ist[I_BOPEN] = JOINT_OPEN
            ist[I_S] = target
        else:
            ist[I_COPEN] = JOINT_OPEN
            ist[I_C] = target
        if rr and kd == EV_BASE_RELEASE:  # one coordinate: both joints are released
            ist[I_COPEN] = JOINT_OPEN
            ist[I_C] = -target
        _reset_other(ist, 0 if base else 1)
        h_new = _held_state(ist)
        _change_coords(GX, h, h_new, r, v, tmp)
        ist[I_H] = h_new
        return 1 if set_family(P, ist, r, v, GL[h_new]) else 0
    base = kd == EV_BASE_IMPACT
    crack = kd == EV_CRACK_IMPACT
    if rr:
        base = True  # both supports rigid: the two joints close together, one impact
        crack = True
    else:
        # merged impact: the other open joint, continued on the motion before the
        # impact, closes within the window w (MODEL.md section 7)
        other_open = (ist[I_COPEN] if base else ist[I_BOPEN]) == JOINT_OPEN
        if other_open:
            lrow = ROW_GC if base else ROW_T1
            side = ist[I_C] if base else ist[I_S]
            eo = side * _rowdot(L, lrow, r)
            edo = side * _rowdot(L, lrow, v)
            eddo = side * _row_acc(L, lrow, MK, MC, MR, MG, r, v, ag_now)
            if edo < 0.0 and eo + edo * window + 0.5 * eddo * window * window <= 0.0:
                base = True
                crack = True
    # the pivots move to the other faces; the contact law uses the pattern after
    if base:
        ist[I_S] = -ist[I_S]
        counts[0] += 1
    if crack:
        ist[I_C] = -ist[I_C]
        counts[1] += 1
    if not (base and crack):
        _reset_other(ist, 0 if base else 1)
    fam_after = 1 if ist[I_S] == ist[I_C] else 2
    Minv = GMI[h, fam_after - 1]
    impact_velocity(L, v, base, crack, cor, law, Minv, GROT[h])
    # a joint left slower than v_rest is held closed, in the family after the impact
    hold_b = base and abs(_rowdot(L, ROW_T1, v)) < v_rest
    hold_c = crack and abs(_rowdot(L, ROW_GC, v)) < v_rest
    if rr:
        hold_c = hold_b
    if hold_b or hold_c:
        counts[2] += 1
        # the residual rate of the held gap is removed by a plastic impulse
        impact_velocity(L, v, hold_b, hold_c and not rr, np.float64(0.0), np.int64(1), Minv,
                        GROT[h])
        if hold_b:
            ist[I_BOPEN] = JOINT_HELD
        if hold_c:
            ist[I_COPEN] = JOINT_HELD
        h_new = _held_state(ist)
        _change_coords(GX, h, h_new, r, v, tmp)
        ist[I_H] = h_new
    return 1 if set_family(P, ist, r, v, GL[ist[I_H]]) else 0


# ---- numerics: Taylor series, scalar polynomials, roots --------------------------------

@inline
def _taylor_n(MK, MC, MR, MG, r0, v0, a0, beta, h, D, nn):
    """:func:`_taylor` over the first nn coordinates (nn a constant where inlined)."""
    big = 0.0
    for i in range(nn):
        D[0, i] = r0[i]
        D[1, i] = v0[i] * h
        big = max(big, abs(D[0, i]), abs(D[1, i]))
    # the forcing enters the first two terms only
    hh = h * h
    for i in range(nn):
        acc = -(MR[i] + MG[i] * a0)
        acc2 = -MG[i] * beta * h
        for k in range(nn):
            acc -= MK[i, k] * D[0, k] + (1.0 / h) * MC[i, k] * D[1, k]
        D[2, i] = 0.5 * hh * acc
        big = max(big, abs(D[2, i]))
        D[3, i] = acc2  # completed below, once D[2] is known
    for i in range(nn):
        acc = D[3, i]
        for k in range(nn):
            acc -= MK[i, k] * D[1, k] + (2.0 / h) * MC[i, k] * D[2, k]
        D[3, i] = (hh / 6.0) * acc
        big = max(big, abs(D[3, i]))
    if nn == 2:
        return _tail2(MK, MC, h, D, big)
    m = 4
    for j in range(2, KMAX - 2):
        c = hh / ((j + 1.0) * (j + 2.0))
        q = (j + 1.0) / h
        mx = 0.0
        for i in range(nn):
            acc = 0.0
            for k in range(nn):
                acc -= MK[i, k] * D[j, k] + q * MC[i, k] * D[j + 1, k]
            val = c * acc
            D[j + 2, i] = val
            mx = max(mx, abs(val))
        m = j + 3
        big = max(big, mx)
        if j >= 3:
            prev = 0.0
            for i in range(nn):
                prev = max(prev, abs(D[j + 1, i]))
            # the tail is below round-off in values, rates and accelerations
            w = j + 2.0
            if (mx + prev) * (w * w) <= 1e-17 * big:
                break
    return m


@inline
def _tail2(MK, MC, h, D, big):
    """The terms D[4:] of :func:`_taylor_n` for two coordinates, two terms a pass.

    The recurrence D[j+2] = c1_j MK D[j] + c2_j MC D[j+1] (c1_j = -h^2/((j+1)(j+2)),
    c2_j = -h/(j+2)) is a chain of dependent products, so its speed is its latency.
    Substituting it into the next term gives D[j+3] = c1_{j+1} MK D[j+1]
    + c2_{j+1} c2_j MC^2 D[j+1] + c2_{j+1} c1_j MC MK D[j]: both new terms come from
    the two before them, which halves the chain. Matrices and the last two terms stay
    in registers (D is only written); the stopping test is that of :func:`_taylor_n`,
    applied to each term in turn."""
    k00, k01, k10, k11 = MK[0, 0], MK[0, 1], MK[1, 0], MK[1, 1]
    c00, c01, c10, c11 = MC[0, 0], MC[0, 1], MC[1, 0], MC[1, 1]
    # MC^2 and MC MK
    q00 = c00 * c00 + c01 * c10
    q01 = c00 * c01 + c01 * c11
    q10 = c10 * c00 + c11 * c10
    q11 = c10 * c01 + c11 * c11
    p00 = c00 * k00 + c01 * k10
    p01 = c00 * k01 + c01 * k11
    p10 = c10 * k00 + c11 * k10
    p11 = c10 * k01 + c11 * k11
    a0, a1 = D[2, 0], D[2, 1]  # D[j]
    b0, b1 = D[3, 0], D[3, 1]  # D[j + 1]
    hh = h * h
    m = 4
    for j in range(2, KMAX - 3, 2):
        c1 = -hh * _INV12[j]
        c2 = -h * _INV2[j]
        d1 = -hh * _INV12[j + 1]  # c1_{j+1}
        e2 = -h * _INV2[j + 1]  # c2_{j+1}
        bb = e2 * c2
        gg = e2 * c1
        n0 = c2 * (c00 * b0 + c01 * b1) + c1 * (k00 * a0 + k01 * a1)
        n1 = c2 * (c10 * b0 + c11 * b1) + c1 * (k10 * a0 + k11 * a1)
        o0 = (d1 * (k00 * b0 + k01 * b1) + gg * (p00 * a0 + p01 * a1)) \
            + bb * (q00 * b0 + q01 * b1)
        o1 = (d1 * (k10 * b0 + k11 * b1) + gg * (p10 * a0 + p11 * a1)) \
            + bb * (q10 * b0 + q11 * b1)
        D[j + 2, 0] = n0
        D[j + 2, 1] = n1
        mx = max(abs(n0), abs(n1))
        m = j + 3
        big = max(big, mx)
        if j >= 3:
            w = j + 2.0
            if (mx + max(abs(b0), abs(b1))) * (w * w) <= 1e-17 * big:
                break
        D[j + 3, 0] = o0
        D[j + 3, 1] = o1
        mo = max(abs(o0), abs(o1))
        m = j + 4
        big = max(big, mo)
        w = j + 3.0
        if (mo + mx) * (w * w) <= 1e-17 * big:
            break
        a0, a1 = n0, n1
        b0, b1 = o0, o1
    return m


@inner
def _taylor(MK, MC, MR, MG, r0, v0, a0, beta, h, D, n):
    """Taylor coefficients D[j] = r^(j)(0) h^j / j! of the exact solution on [0, h] of
    r_dd = -MK r - MC r_d - MR - MG (a0 + beta*t) (padded arrays; n reduced coordinates,
    the padding columns of D stay zero). Returns the number of terms.

    The loops are specialised to n = 2 (the paper's walls on a rigid floor: this is the
    kernel's most-run arithmetic, two series per event, and padded loops do 9 products
    per term where n = 2 needs 4); every other n runs the padded loops (exact zeros)."""
    if n == 2:
        return _taylor_n(MK, MC, MR, MG, r0, v0, a0, beta, h, D, 2)
    return _taylor_n(MK, MC, MR, MG, r0, v0, a0, beta, h, D, NP)


@inline
def _sum_state_n(D, m, s, h, r, v, nn):
    """:func:`_sum_state` over the first nn coordinates (a constant where inlined): the
    coordinates' Horner chains run side by side (each is latency-bound; the arithmetic of
    each is unchanged); the padding coordinate is set to zero."""
    p0, p1, p2 = D[m - 1, 0], D[m - 1, 1], 0.0
    if nn > 2:
        p2 = D[m - 1, 2]
    d0 = 0.0
    d1 = 0.0
    d2 = 0.0
    if s == 1.0:  # the same sums without the products by 1 (half the latency)
        for k in range(m - 1):  # j = m - 2 - k, unsigned: no negative-index handling
            j = np.uint64(m - 2 - k)
            d0 = d0 + p0
            p0 = p0 + D[j, 0]
            d1 = d1 + p1
            p1 = p1 + D[j, 1]
            if nn > 2:
                d2 = d2 + p2
                p2 = p2 + D[j, 2]
    else:
        for k in range(m - 1):
            j = np.uint64(m - 2 - k)
            d0 = d0 * s + p0
            p0 = p0 * s + D[j, 0]
            d1 = d1 * s + p1
            p1 = p1 * s + D[j, 1]
            if nn > 2:
                d2 = d2 * s + p2
                p2 = p2 * s + D[j, 2]
    r[0] = p0
    v[0] = d0 / h
    r[1] = p1
    v[1] = d1 / h
    r[2] = p2
    v[2] = d2 / h


@inline
def _sum_state(D, m, s, h, r, v, n):
    """r(s h) and r_d(s h) from the Taylor coefficients of n coordinates (specialised to
    n = 2 like :func:`_taylor`)."""
    if n == 2:
        _sum_state_n(D, m, s, h, r, v, 2)
    else:
        _sum_state_n(D, m, s, h, r, v, NP)


@inline
def _scalar_poly(R, ri, D, m, acc_kind, h, a0, beta, sig, kap, cf):
    """Coefficients in s = t/h of sig*row.y + kap (displacement kind) or of
    row.y_dd + xg_dd (acceleration kind), row = R[ri]. Returns their number."""
    if not acc_kind:
        for j in range(m):
            s = 0.0
            for i in range(NP):
                s += R[ri, i] * D[j, i]
            cf[j] = sig * s
        cf[0] += kap
        return m
    for j in range(m - 2):
        s = 0.0
        for i in range(NP):
            s += R[ri, i] * D[j + 2, i]
        cf[j] = (j + 2.0) * (j + 1.0) * s / (h * h)
    cf[0] += a0
    cf[1] += beta * h
    return m - 2


@inner
def _release_poly(rows, vrows, agc, k, D, m, h, a0, beta, sig, kap, cf):
    """Coefficients in s = t/h of a release function sig*(row.y + vrow.y_d + agc*xg_dd)
    + kap on the Taylor series D of one sub-step. Returns their number."""
    for j in range(m):
        s = 0.0
        for i in range(NP):
            s += rows[k, i] * D[j, i]
            if j + 1 < m:
                s += vrows[k, i] * (j + 1.0) * D[j + 1, i] / h
        cf[j] = sig * s
    cf[0] += sig * agc[k] * a0 + kap
    if m > 1:
        cf[1] += sig * agc[k] * beta * h
    return m


@inline
def _event_poly(rows, vrows, agc, sig, kap, kind, k, D, m, h, a0, beta, cf):
    """Coefficients in s = t/h of event function k on the Taylor series D of a sub-step."""
    if kind[k] == EV_BASE_RELEASE or kind[k] == EV_CRACK_RELEASE:
        return _release_poly(rows, vrows, agc, k, D, m, h, a0, beta, sig[k], kap[k], cf)
    return _scalar_poly(rows, k, D, m, False, h, 0.0, 0.0, sig[k], kap[k], cf)


@inline
def _peval(cf, m, s):
    p = cf[m - 1]
    dp = 0.0
    ddp = 0.0
    for k in range(m - 1):
        j = np.uint64(m - 2 - k)
        ddp = ddp * s + dp
        dp = dp * s + p
        p = p * s + cf[j]
    return p, dp, 2.0 * ddp


@inline
def _peval1(cf, m, s):
    """Polynomial value and first derivative, summed as even and odd parts in s^2
    (four Horner chains of half the length: the evaluation is latency-bound)."""
    u = s * s
    top = (m - 1) // 2
    e = cf[2 * top]
    o = cf[2 * top + 1] if 2 * top + 1 < m else 0.0
    de = 0.0
    do = 0.0
    for k in range(top):  # i = top - 1 - k, unsigned: no negative-index handling
        i = np.uint64(2 * (top - 1 - k))
        de = de * u + e
        e = e * u + cf[i]
        do = do * u + o
        o = o * u + cf[i + np.uint64(1)]
    return e + s * o, 2.0 * s * de + o + 2.0 * u * do


EPS = 2.220446049250313e-16


@inner
def _polish(cf, m, a, b, x, steps):
    """The root of a polynomial in a bracket (a, b) of :func:`_newton` (positive at a, at
    or below zero at b) to the last few ulps of s, from x: the point of a Newton step of
    less than half the bracket's tolerance (steps = 0: Newton's iteration converges
    quadratically, so x is the root to round-off, whatever path the bracket took), or
    any point of a bracket that closed first (then up to `steps` Newton steps, until one
    is within 4 ulps of 1 or stops shrinking: round-off). If the polynomial has not
    crossed there yet, steps towards b, from twice the distance Newton's step gives (at
    least an ulp) and doubling, find the crossed point next to it. So an event's time is a
    function of its series, not of the bracket (whose width, 1e-12 s, made event times
    jitter by about 1e-13 s from run to run of nearly identical inputs, which chatter
    amplifies). Returns (a, x), p(x) <= 0."""
    x = min(max(x, a), b)
    p, dp = _peval1(cf, m, x)
    last = np.inf
    for _ in range(steps):
        if p == 0.0 or dp == 0.0:
            break
        xn = min(max(x - p / dp, a), b)
        step = abs(xn - x)
        if step <= 4.0 * EPS or step >= last:
            break
        last = step
        x = xn
        p, dp = _peval1(cf, m, x)
    d = max(EPS * abs(x) + 5e-324, -2.0 * p / dp if dp < 0.0 else 0.0)
    for _ in range(64):
        if p <= 0.0:
            return a, x
        x = x + d
        d *= 2.0
        if x >= b:
            break
        p = _peval1(cf, m, x)[0]
    return a, b


@inner
def _newton(cf, m, lo, hi, tol, guess, order):
    """Bracketed Newton for a sign change of the polynomial (order 0, positive at lo, on
    value and slope by :func:`_peval1`) or of its slope (order 1, an extremum, on slope
    and curvature by :func:`_peval`) over [lo, hi]; stops on the bracket width. Returns
    (a, b), |b - a| <= tol: the function has at a the sign it has at lo, at b the other.
    A root (order 0) is instead polished to the last few ulps once a Newton step is below
    the tolerance (:func:`_polish`), b the polished crossed point."""
    # oriented f: negative on the lo side
    if order == 0:
        orient = -1.0
    else:
        orient = 1.0 if _peval(cf, m, lo)[1] < 0.0 else -1.0
    a, b = lo, hi
    x = guess if lo < guess < hi else 0.5 * (lo + hi)
    xn = x
    for _ in range(100):
        if order == 0:
            v, dv = _peval1(cf, m, x)
        else:
            _, v, dv = _peval(cf, m, x)
        f = orient * v
        df = orient * dv
        if f == 0.0:
            return x, x
        if f < 0.0:
            a = x
        else:
            b = x
        if b - a <= tol:
            break
        xn = x - f / df if df != 0.0 else 0.5 * (a + b)
        if not (a < xn < b):
            xn = 0.5 * (a + b)
        if abs(xn - x) < 0.5 * tol:
            if order == 0:  # converged: to the last ulps from Newton's point
                return _polish(cf, m, a, b, xn, 0)
            # close the bracket from the other side
            xn = x + 0.5 * tol if f < 0.0 else x - 0.5 * tol
            xn = min(max(xn, a), b)
        x = xn
    if order == 0:  # (the bracket closed before a Newton step was that short)
        xn = x - f / df if df != 0.0 else 0.5 * (a + b)
        if not (a < xn < b):
            xn = 0.5 * (a + b)
        return _polish(cf, m, a, b, xn, 3)
    return a, b


@inner
def _hermite_root(p0, p1, m0, m1):
    """A starting point for :func:`_newton`: the root in (0, 1] of the cubic Hermite
    interpolant of p0 > 0 >= p1 with end slopes m0, m1 (a few safeguarded Newton steps
    from the secant point)."""
    A = 2.0 * p0 + m0 - 2.0 * p1 + m1
    B = -3.0 * p0 - 2.0 * m0 + 3.0 * p1 - m1
    s = p0 / (p0 - p1)
    for _ in range(2):
        f = ((A * s + B) * s + m0) * s + p0
        df = (3.0 * A * s + 2.0 * B) * s + m0
        if df >= 0.0:
            break
        sn = s - f / df
        if not (0.0 < sn <= 1.0):
            break
        s = sn
    return s


@inline
def _lower_bound(cf, m):
    """A rigorous lower bound of the polynomial on [0, 1]: c0 - sum_j>=1 |c_j|."""
    out = cf[0]
    for j in range(1, m):
        out -= abs(cf[j])
    return out


@inner
def _scan(cf, m, first_max, single_min):
    """Scans of a polynomial on [0, 1] at 16 points, extrema between them located exactly.

    first_max: the polynomial starts at or below zero with a positive slope and ends at or
    below zero; returns the point of its first maximum if that maximum is positive, else -1.
    Otherwise the polynomial is positive at 0; returns a point in (0, 1] where it is <= 0,
    at or before its first interior minimum that reaches zero, 2.0 when it stays positive
    (single_min: the Hermite test found one interior minimum, located directly)."""
    if not first_max and single_min:
        a, b = _newton(cf, m, 0.0, 1.0, 1e-14, 0.5, 1)
        s = 0.5 * (a + b)
        return s if _peval(cf, m, s)[0] <= 0.0 else 2.0
    ns = 16
    d_prev = _peval(cf, m, 0.0)[1]
    s_prev = 0.0
    for i in range(1, ns + 1):
        s = i / ns
        p, d, _ = _peval(cf, m, s)
        if not first_max and p <= 0.0:
            return s
        if (first_max and d_prev > 0.0 and d <= 0.0) or \
                (not first_max and d_prev < 0.0 and d > 0.0):
            a, b = _newton(cf, m, s_prev, s, 1e-14, 0.5 * (s_prev + s), 1)
            sm = 0.5 * (a + b)
            pm = _peval(cf, m, sm)[0]
            if first_max:
                return sm if pm > 0.0 else -1.0
            if pm <= 0.0:
                return sm
        d_prev, s_prev = d, s
    return -1.0 if first_max else 2.0


@inner
def _no_extra_fall(cf, m):
    """True when a polynomial on [0, 1] that starts at zero (to round-off) or behind it
    provably falls through zero at most once, the fall its end values show: it stays
    positive on (0, 1] (``c_0 .. c_(d-1) >= 0`` and ``c_d > sum_(j>d) |c_j|`` for d = 1, 2
    or 3: the orders of a rate, of a released joint's zero rate and zero acceleration), or
    it is concave (its positive set is one interval)."""
    t1 = 0.0  # sum_(j>=2) |c_j|
    t2 = 0.0  # sum_(j>=3) |c_j|
    t3 = 0.0  # sum_(j>=4) |c_j|
    curv = 0.0  # sum_(j>=3) j (j-1) |c_j|: e''/2 <= c_2 + curv/2 on [0, 1]
    for j in range(2, m):
        a = abs(cf[j])
        t1 += a
        if j >= 3:
            t2 += a
            curv += j * (j - 1.0) * a
        if j >= 4:
            t3 += a
    c0, c1, c2, c3 = cf[0], cf[1], cf[2], cf[3]  # (m >= 4: every series has 4 terms)
    if c0 >= 0.0 and (c1 > t1 or (c1 >= 0.0 and (c2 > t2 or (c2 >= 0.0 and c3 > t3)))):
        return True
    return 2.0 * c2 + curv < 0.0


N_GEOM = 33  # samples of _first_fall growing geometrically, s_cap * 2^-36 .. s_cap/16


@inner
def _first_fall(cf, m, s_cap):
    """The first fall through zero on (0, s_cap] of a polynomial on [0, 1] that starts at
    zero (to round-off), or behind it, as a bracket (lo, hi) with p(lo) > 0 >= p(hi);
    hi = 2.0 when it does not fall there.

    A contact function at zero after an event (an impact, a release that leaves its value,
    rate and acceleration zero) may leave and come back at any time, however soon: it is
    sampled at N_GEOM points growing geometrically from s_cap * 2^-36 to s_cap/16 and then
    at 15 even points up to s_cap, and the extrema between two samples are located
    exactly. Before it has been positive a fall is no event (it has not left zero yet)."""
    armed = cf[0] > 0.0
    s_prev = 0.0
    d_prev = cf[1]
    s = s_cap * 2.0 ** -(N_GEOM + 4)
    for i in range(N_GEOM + 15):
        s = 2.0 * s if i < N_GEOM else s_cap * (i - N_GEOM + 2) / 16.0
        p, d = _peval1(cf, m, s)
        if armed:
            if p <= 0.0:
                return s_prev, s
            if d_prev < 0.0 and d > 0.0:  # a minimum between the samples
                a, b = _newton(cf, m, s_prev, s, 1e-14, 0.5 * (s_prev + s), 1)
                sm = 0.5 * (a + b)
                if _peval(cf, m, sm)[0] <= 0.0:
                    return s_prev, sm
        elif p > 0.0:
            armed = True
        elif d_prev >= 0.0 and d < 0.0:  # a maximum between samples both at or below zero
            a, b = _newton(cf, m, s_prev, s, 1e-14, 0.5 * (s_prev + s), 1)
            sm = 0.5 * (a + b)
            if _peval(cf, m, sm)[0] > 0.0:
                return sm, s
        s_prev = s
        d_prev = d
    return 0.0, 2.0


@inline
def _rising(zero, rows, sig, kind, e_a, D, m):
    """The functions at zero (bits of `zero`) left once those are taken out that rise from
    zero faster than the rest of their series (D, m terms) can pull them back: e(s) >= c0
    + s (c1 - sum_(j>=2) |c_j|) > 0 on (0, 1] when c0 >= 0. Release functions (their rows
    include rates) are always left. (It runs after most events: four partial sums, so that
    the additions do not wait for each other.)"""
    for k in range(MAX_EV):
        if (zero >> k) & 1 and e_a[k] >= 0.0 and kind[k] != EV_BASE_RELEASE \
                and kind[k] != EV_CRACK_RELEASE:
            r0, r1, r2 = rows[k, 0], rows[k, 1], rows[k, 2]
            s0 = 0.0
            s1 = 0.0
            s2 = 0.0
            s3 = 0.0
            for j in range(2, m - 3, 4):
                s0 += abs(r0 * D[j, 0] + r1 * D[j, 1] + r2 * D[j, 2])
                s1 += abs(r0 * D[j + 1, 0] + r1 * D[j + 1, 1] + r2 * D[j + 1, 2])
                s2 += abs(r0 * D[j + 2, 0] + r1 * D[j + 2, 1] + r2 * D[j + 2, 2])
                s3 += abs(r0 * D[j + 3, 0] + r1 * D[j + 3, 1] + r2 * D[j + 3, 2])
            for j in range(m - (m - 2) % 4, m):
                s0 += abs(r0 * D[j, 0] + r1 * D[j, 1] + r2 * D[j, 2])
            c1 = sig[k] * (r0 * D[1, 0] + r1 * D[1, 1] + r2 * D[1, 2])
            if c1 > (s0 + s1) + (s2 + s3):
                zero &= ~(1 << k)
    return zero


@inner
def _first_falls(rows, vrows, agc, sig, kap, kind, ne, zero, D, m, H, a0, beta, cf, s_ev,
                 k_ev):
    """The earliest fall on a sub-step (series D of m terms, length H) of the event
    functions at zero (bits of `zero`), by :func:`_first_fall` unless
    :func:`_no_extra_fall` rules it out, if earlier than s_ev (function k_ev, -1 for none)
    by more than the time tolerance. Returns (s_ev, k_ev)."""
    tol = TIME_TOL / H if H > 1e3 * TIME_TOL else 1e-3
    for k in range(ne):
        if not (zero >> k) & 1:
            continue
        mc = _event_poly(rows, vrows, agc, sig, kap, kind, k, D, m, H, a0, beta, cf)
        if _no_extra_fall(cf, mc):
            continue
        cap = min(s_ev, 1.0)
        f_lo, f_hi = _first_fall(cf, mc, cap)
        if f_hi > cap:
            continue
        s_root = _newton(cf, mc, f_lo, f_hi, tol, 0.5 * (f_lo + f_hi), 0)[1]
        if k_ev < 0 or s_root < s_ev - tol:
            s_ev = s_root
            k_ev = k
    return s_ev, k_ev


@inner
def _hermite_ext(p0, p1, m0, m1):
    """Interior extrema of the cubic Hermite interpolant on [0, 1]: (min, max, s_min,
    s_max); +inf/-inf when none."""
    A = 6.0 * p0 + 3.0 * m0 - 6.0 * p1 + 3.0 * m1
    B = -6.0 * p0 - 4.0 * m0 + 6.0 * p1 - 2.0 * m1
    C = m0
    lo, hi, slo, shi = np.inf, -np.inf, 0.5, 0.5
    r0 = -1.0
    r1 = -1.0
    if abs(A) < 1e-300:
        if B != 0.0:
            r0 = -C / B
    else:
        disc = B * B - 4.0 * A * C
        if disc >= 0.0:
            sq = math.sqrt(disc)
            qq = -0.5 * (B + (sq if B >= 0 else -sq))
            if qq != 0.0:
                r0 = qq / A
                r1 = C / qq
    for i in range(2):
        s = r0 if i == 0 else r1
        if 0.0 < s < 1.0:
            s2 = s * s
            s3 = s2 * s
            val = ((2 * s3 - 3 * s2 + 1) * p0 + (s3 - 2 * s2 + s) * m0
                   + (-2 * s3 + 3 * s2) * p1 + (s3 - s2) * m1)
            if val < lo:
                lo, slo = val, s
            if val > hi:
                hi, shi = val, s
    return lo, hi, slo, shi


# ---- the integrator ---------------------------------------------------------------------

@inline
def _point_n(MK, MC, MR, MG, TR, r, v, ag, beta, val, der, acc, jerk, nn, t_lo, t_hi):
    """:func:`_point` over the first nn coordinates and the trackers t_lo .. t_hi - 1
    (constants where inlined: without an acceleration tracker the accelerations are not
    computed). The state, accelerations and jerks are held in locals: the compiler cannot
    know that the output arrays do not alias the inputs and would reload the inputs after
    every store."""
    r0, r1, r2 = r[0], r[1], r[2]
    v0, v1, v2 = v[0], v[1], v[2]
    a0 = -MR[0] - MG[0] * ag - (MK[0, 0] * r0 + MC[0, 0] * v0) - (MK[0, 1] * r1 + MC[0, 1] * v1)
    a1 = -MR[1] - MG[1] * ag - (MK[1, 0] * r0 + MC[1, 0] * v0) - (MK[1, 1] * r1 + MC[1, 1] * v1)
    a2 = 0.0
    if nn > 2:
        a0 -= MK[0, 2] * r2 + MC[0, 2] * v2
        a1 -= MK[1, 2] * r2 + MC[1, 2] * v2
        a2 = -MR[2] - MG[2] * ag - (MK[2, 0] * r0 + MC[2, 0] * v0) \
            - (MK[2, 1] * r1 + MC[2, 1] * v1) - (MK[2, 2] * r2 + MC[2, 2] * v2)
    j0 = -MG[0] * beta - (MK[0, 0] * v0 + MC[0, 0] * a0) - (MK[0, 1] * v1 + MC[0, 1] * a1)
    j1 = -MG[1] * beta - (MK[1, 0] * v0 + MC[1, 0] * a0) - (MK[1, 1] * v1 + MC[1, 1] * a1)
    j2 = 0.0
    if nn > 2:
        j0 -= MK[0, 2] * v2 + MC[0, 2] * a2
        j1 -= MK[1, 2] * v2 + MC[1, 2] * a2
        j2 = -MG[2] * beta - (MK[2, 0] * v0 + MC[2, 0] * a0) \
            - (MK[2, 1] * v1 + MC[2, 1] * a1) - (MK[2, 2] * v2 + MC[2, 2] * a2)
    if t_hi > N_DISP:
        acc[0] = a0
        acc[1] = a1
        acc[2] = a2
        jerk[0] = j0
        jerk[1] = j1
        jerk[2] = j2
    for t in range(t_lo, t_hi):
        p0, p1, p2 = (r0, r1, r2) if t < N_DISP else (a0, a1, a2)
        q0, q1, q2 = (v0, v1, v2) if t < N_DISP else (j0, j1, j2)
        a = TR[t, 0] * p0 + TR[t, 1] * p1
        b = TR[t, 0] * q0 + TR[t, 1] * q1
        if nn > 2:
            a += TR[t, 2] * p2
            b += TR[t, 2] * q2
        if t < N_DISP:
            val[t] = a
            der[t] = b
        else:
            val[t] = a + ag
            der[t] = b + beta


@inline
def _point_fast(MK, MC, MR, MG, TR, r, v, ag, beta, val, der, acc, jerk, n, t_lo, t_hi):
    """Tracker values and rates at one instant (accelerations absolute) of the trackers
    t_lo .. t_hi - 1; acc and jerk are scratch arrays. Specialised to n = 2 like
    :func:`_taylor`."""
    if n == 2:
        _point_n(MK, MC, MR, MG, TR, r, v, ag, beta, val, der, acc, jerk, 2, t_lo, t_hi)
    else:
        _point_n(MK, MC, MR, MG, TR, r, v, ag, beta, val, der, acc, jerk, NP, t_lo, t_hi)


@inner
def _point(MK, MC, MR, MG, TR, r, v, ag, beta, val, der, acc, jerk):
    """:func:`_point_fast` on the padded loops and every tracker, for the instants off the
    hot path."""
    _point_n(MK, MC, MR, MG, TR, r, v, ag, beta, val, der, acc, jerk, NP, 0, N_TRACK)


@inline
def _propagate_n(E, PV, r, v, a0, beta, rb, vb, nn):
    r0, r1, r2 = r[0], r[1], r[2]
    v0, v1, v2 = v[0], v[1], v[2]
    for i in range(nn):
        s1 = PV[0, i] + a0 * PV[1, i] + beta * PV[2, i]
        s2 = PV[0, NP + i] + a0 * PV[1, NP + i] + beta * PV[2, NP + i]
        s1 += E[i, 0] * r0
        s1 += E[i, 1] * r1
        s2 += E[NP + i, 0] * r0
        s2 += E[NP + i, 1] * r1
        if nn > 2:
            s1 += E[i, 2] * r2
            s2 += E[NP + i, 2] * r2
        s1 += E[i, NP] * v0
        s1 += E[i, NP + 1] * v1
        s2 += E[NP + i, NP] * v0
        s2 += E[NP + i, NP + 1] * v1
        if nn > 2:
            s1 += E[i, NP + 2] * v2
            s2 += E[NP + i, NP + 2] * v2
        rb[i] = s1
        vb[i] = s2


@inline
def _propagate(E, PV, r, v, a0, beta, rb, vb, n):
    """The state after a whole sub-step by the exact propagator (rb, vb must not be r, v)."""
    if n == 2:
        _propagate_n(E, PV, r, v, a0, beta, rb, vb, 2)
    else:
        _propagate_n(E, PV, r, v, a0, beta, rb, vb, NP)


@inner
def _event_table(rows, vrows, agc, sig, kap, kind, ne, RT, RVT, AGT, KP, OPN):
    """The event functions of a piece as signed rows stored by column (RT[i, k] =
    sig[k]*rows[k, i]), offsets KP and opening flags OPN, padded to MAX_EV with inert
    functions (e = 1, rate 0) so that all are evaluated in fixed-length loops. Returns
    whether a release function (with rate and ground terms) is among them, and whether an
    opening function is (a closed joint: no step is plain)."""
    rel = False
    opens = False
    for k in range(MAX_EV):
        live = k < ne
        for i in range(NP):
            RT[i, k] = sig[k] * rows[k, i] if live else 0.0
            RVT[i, k] = sig[k] * vrows[k, i] if live else 0.0
        AGT[k] = sig[k] * agc[k] if live else 0.0
        KP[k] = kap[k] if live else 1.0
        OPN[k] = 1.0 if live and (kind[k] == EV_BASE_OPEN or kind[k] == EV_CRACK_OPEN) \
            else 0.0
        if live and (kind[k] == EV_BASE_RELEASE or kind[k] == EV_CRACK_RELEASE):
            rel = True
        if OPN[k] != 0.0:
            opens = True
    return rel, opens


@inline
def _events_at_n(RT, KP, r, v, e, ed, nn, kk):
    r0, r1, r2 = r[0], r[1], r[2]
    v0, v1, v2 = v[0], v[1], v[2]
    for k in range(kk):
        a = RT[0, k] * r0 + RT[1, k] * r1
        b = RT[0, k] * v0 + RT[1, k] * v1
        if nn > 2:
            a += RT[2, k] * r2
            b += RT[2, k] * v2
        e[k] = a + KP[k]
        ed[k] = b


@inline
def _events_at(RT, KP, r, v, e, ed, n, ke):
    """Values and rates of the first ke (KE or MAX_EV) event functions at state (r, v),
    on n coordinates (specialised to n = 2 like :func:`_taylor`)."""
    if n == 2:
        if ke == KE:
            _events_at_n(RT, KP, r, v, e, ed, 2, KE)
        else:
            _events_at_n(RT, KP, r, v, e, ed, 2, MAX_EV)
    elif ke == KE:
        _events_at_n(RT, KP, r, v, e, ed, NP, KE)
    else:
        _events_at_n(RT, KP, r, v, e, ed, NP, MAX_EV)


@inner
def _events_now(RT, KP, r, v, e, ed):
    """:func:`_events_at` on the padded loops, for the instants off the hot path."""
    _events_at_n(RT, KP, r, v, e, ed, NP, MAX_EV)


@inner
def _events_rel(RVT, AGT, MK, MC, MR, MG, r, v, ag, beta, e, ed):
    """The rate and ground terms of release functions, added to e and ed (held pieces)."""
    for k in range(MAX_EV):
        a = AGT[k] * ag
        b = AGT[k] * beta
        for i in range(NP):
            acc = -MR[i] - MG[i] * ag
            for j in range(NP):
                acc -= MK[i, j] * r[j] + MC[i, j] * v[j]
            a += RVT[i, k] * v[i]
            b += RVT[i, k] * acc
        e[k] += a
        ed[k] += b


@inline
def _may_fire_k(OPN, e_a, ed_a, e_b, ed_b, H, kk):
    """False when no event function can have an event on the sub-step of length H: none
    ends at or below zero, no closed contact may open, none dips towards zero (a rate
    turning upward whose Hermite cubic may come within a quarter of the smaller end
    value of zero: the test of the event search itself, so that only the sub-steps it
    would look at closer pass)."""
    flag = False
    for k in range(kk):
        ea, eb, eda, edb = e_a[k], e_b[k], ed_a[k], ed_b[k]
        dip = (eda < 0.0) & (edb > 0.0) & \
            (min(ea, eb) - (4.0 / 27.0) * H * (edb - eda) < 0.25 * max(ea, eb))
        flag |= (eb <= 0.0) | (OPN[k] * ea > 0.0) | dip
    return flag


@inline
def _may_fire(OPN, e_a, ed_a, e_b, ed_b, H, ke):
    """:func:`_may_fire_k` over the first ke (KE or MAX_EV) event functions."""
    if ke == KE:
        return _may_fire_k(OPN, e_a, ed_a, e_b, ed_b, H, KE)
    return _may_fire_k(OPN, e_a, ed_a, e_b, ed_b, H, MAX_EV)


@inline
def _peaks_over(TR, peaks, val_a, der_a, val_b, der_b, s_end, m_taylor, D, cf, MK, MC, MR,
                MG, r, v, a0, beta, H, n, t_lo, t_hi):
    """Peak update of trackers t_lo .. t_hi - 1 over [0, s_end*H] of a sub-step of length
    H from the end values and rates; interior extrema that may beat the running peak are
    located on the exact series about the sub-step start (computed here if m_taylor is
    0). Each tracker's peak is found by the same operations whichever others are tracked."""
    Hs = s_end * H
    for t in range(t_lo, t_hi):
        vb = abs(val_b[t])
        if vb > peaks[t]:
            peaks[t] = vb
        if der_a[t] * der_b[t] >= 0.0:
            continue
        # |Hermite cubic| <= max(|p0|, |p1|) + 4/27 (|m0| + |m1|) on [0, 1]: most extrema
        # are far below the running peak and need no closer look
        bound = max(vb, abs(val_a[t])) + (4.0 / 27.0) * Hs * (abs(der_a[t]) + abs(der_b[t]))
        if bound * (1.0 + 1e-12) < peaks[t] * (1.0 - GATE):
            continue
        lo, hi, slo, shi = _hermite_ext(val_a[t], val_b[t], der_a[t] * Hs, der_b[t] * Hs)
        est = max(abs(lo) if lo != np.inf else 0.0, abs(hi) if hi != -np.inf else 0.0)
        if est < peaks[t] * (1.0 - GATE):
            continue
        if m_taylor == 0:
            m_taylor = _taylor(MK, MC, MR, MG, r, v, a0, beta, H, D, n)
        mc = _scalar_poly(TR, t, D, m_taylor, t >= N_DISP, H, a0, beta, 1.0, 0.0, cf)
        guess = s_end * (slo if abs(lo) >= abs(hi) else shi)
        lo_, hi_ = _newton(cf, mc, 0.0, s_end, 1e-13, guess, 1)
        x = abs(_peval(cf, mc, 0.5 * (lo_ + hi_))[0])
        if x > peaks[t]:
            peaks[t] = x
    return m_taylor


# ---- runs of plain steps (capacity tracking) --------------------------------------------

def _plain_state(nn: int, trackers: tuple) -> list[tuple[str, str, str, str | None]]:
    """The state a run of plain steps carries in locals: (local at the step's start, local
    at its end, the array it is read from and written back to, the array the end of a
    step handed over is written to)."""
    return ([(f"r{i}", f"rb{i}", f"r[{i}]", f"rb[{i}]") for i in range(nn)]
            + [(f"v{i}", f"vb{i}", f"v[{i}]", f"vb[{i}]") for i in range(nn)]
            + [(f"e{k}", f"eb{k}", f"e_a[{k}]", f"e_b[{k}]") for k in range(KE)]
            + [(f"ed{k}", f"edb{k}", f"ed_a[{k}]", f"ed_b[{k}]") for k in range(KE)]
            + [(f"p{t}", f"pb{t}", f"val_a[{t}]", None) for t in trackers]
            + [(f"d{t}", f"db{t}", f"der_a[{t}]", None) for t in trackers])


def _plain_row(put, nn: int, coef: list[str]) -> None:
    """``x`` and ``y``: a row of coefficients `coef` times the end state and its rates, in
    the order of :func:`_events_at_n` and :func:`_point_n`."""
    put(2, f"x = {coef[0]} * rb0 + {coef[1]} * rb1")
    put(2, f"y = {coef[0]} * vb0 + {coef[1]} * vb1")
    if nn > 2:
        put(2, f"x += {coef[2]} * rb2")
        put(2, f"y += {coef[2]} * vb2")


def _plain_step(put, nn: int, trackers: tuple) -> None:
    """The body of :func:`_plain_source`'s loop that computes a step's end and leaves the
    loop (``handed``) when something may happen on it."""
    co = range(nn)
    ks = range(KE)
    put(2, "a0 = alpha + beta * 0.0")
    # the exact propagator (_propagate_n)
    for i in co:
        for x, row in (("rb", i), ("vb", NP + i)):
            put(2, f"{x}{i} = PV[0, {row}] + a0 * PV[1, {row}] + beta * PV[2, {row}]")
        for c, j in [("r", j) for j in co] + [("v", j) for j in co]:
            col = j if c == "r" else NP + j
            put(2, f"rb{i} += E[{i}, {col}] * {c}{j}")
            put(2, f"vb{i} += E[{NP + i}, {col}] * {c}{j}")
    # the event functions at the end (_events_at_n)
    for k in ks:
        _plain_row(put, nn, [f"RT[{i}, {k}]" for i in co])
        put(2, f"eb{k} = x + KP[{k}]")
        put(2, f"edb{k} = y")
    # _may_fire_k's comparisons, branching (on a plain step none holds); with no opening
    # function live, its OPN[k] * e > 0 is false
    put(2, "if " + " or ".join(f"eb{k} <= 0.0" for k in ks) + ":")
    put(3, "handed = True")
    put(3, "break")
    for k in ks:
        put(2, f"if ed{k} < 0.0 and edb{k} > 0.0 and min(e{k}, eb{k}) - (4.0 / 27.0) * H * "
               f"(edb{k} - ed{k}) < 0.25 * max(e{k}, eb{k}):")
        put(3, "handed = True")
        put(3, "break")
    # the trackers at the end (_point_n) and their peaks over the step (_peaks_over)
    put(2, "closer = False")
    for t in trackers:
        _plain_row(put, nn, [f"TR[{t}, {i}]" for i in co])
        put(2, f"pb{t} = x")
        put(2, f"db{t} = y")
        put(2, f"u = abs(pb{t})")
        put(2, f"if u > pk{t}:")
        put(3, f"pk{t} = u")
        # (both tests evaluated and combined: one branch, rarely taken)
        put(2, f"bound = max(u, abs(p{t})) + (4.0 / 27.0) * Hs * (abs(d{t}) + abs(db{t}))")
        put(2, f"if (not d{t} * db{t} >= 0.0) & (not bound * (1.0 + 1e-12) < "
               f"pk{t} * (1.0 - GATE)):")
        put(3, f"lo, hi, slo, shi = _hermite_ext(p{t}, pb{t}, d{t} * Hs, db{t} * Hs)")
        put(3, "est = max(abs(lo) if lo != np.inf else 0.0, abs(hi) if hi != -np.inf "
               "else 0.0)")
        put(3, f"if not est < pk{t} * (1.0 - GATE):")
        put(4, "closer = True")
    put(2, "if closer:")
    put(3, "handed = True")
    put(3, "break")


def _plain_end(put, nn: int, trackers: tuple) -> None:
    """The end of :func:`_plain_source`'s loop (a step done: its end is the next one's
    start) and what the function writes back and returns."""
    state = _plain_state(nn, trackers)
    put(2, "n_plain += 1")
    put(2, "if fam1:")
    put(3, "fam1_time += 1.0 * H")
    for start, end, _, _ in state:
        put(2, f"{start} = {end}")
    put(2, "beta_prev = beta")
    put(2, "step += 1")
    for start, _, array, _ in state:
        put(1, f"{array} = {start}")
    for t in trackers:
        put(1, f"peaks[{t}] = pk{t}")
    put(1, "if handed:")  # the step left undone: its end state and event functions
    for _, end, _, handed in state:
        if handed is not None:
            put(2, f"{handed} = {end}")
    put(1, "return step, n_plain, fam1_time, beta_prev, handed")


def _plain_source(nn: int, trackers: tuple) -> str:
    """Source of the loop that a capacity search's analysis (``track="capacity"``) runs over
    whole record steps on which nothing happens: one sub-step a step (``nsub == 1``), no
    function near zero, no release or opening function, the KE event functions. Its state
    (coordinates, event functions, the displacement-type trackers given and their peaks)
    lives in locals, which the compiler keeps in registers or on the stack, where the
    general loop keeps it in arrays that it cannot prove apart and reloads after every
    store; and it is optimised with LLVM's SLP vectorizer (``native.Loop.vectorize``),
    which packs the independent rows of the propagator and of the event functions (the
    order of each sum unchanged). Every value is computed by the operations of the general
    loop (:func:`_propagate_n`, :func:`_events_at_n`, :func:`_may_fire_k`,
    :func:`_point_n`, :func:`_peaks_over` with ``s_end = 1``) in their order, so a step
    gives the same bits either way. A step on which an event function may fire or an
    interior extremum needs the series is handed over undone: the general loop takes it
    from the end state and event functions written to rb, vb, e_b and ed_b.

    Generated per number of coordinates (the loops over coordinates, functions and
    trackers unrolled into named locals). The benchmark analysis, tracking all 9 outputs
    with a few steps between events, ran 0.93x as fast with such a loop (and 0.96x with one
    in the code, unused: the loop's own code grew), so full tracking keeps the general
    loop."""
    assert all(t < N_DISP for t in trackers)  # (no ground or jerk terms)
    lines = []

    def put(indent, line):
        lines.append("    " * indent + line)

    put(0, f"def _plain_{nn}(ag, step, nsteps, N, dt, inv_dt, beta_prev, fam1, fam1_time, E, "
           "PV, RT, KP, TR, r, v, e_a, ed_a, val_a, der_a, peaks, rb, vb, e_b, ed_b):")
    for start, _, array, _ in _plain_state(nn, trackers):
        put(1, f"{start} = {array}")
    for t in trackers:
        put(1, f"pk{t} = peaks[{t}]")
    put(1, "H = dt - 0.0")  # tb - tau of the general loop, and s_end * H
    put(1, "Hs = 1.0 * H")
    put(1, "n_plain = 0")
    put(1, "handed = False")
    put(1, "while step < nsteps and step != N - 2:")
    put(2, "if step < N - 1:")
    put(3, "alpha = ag[step]")
    put(3, "beta = (ag[step + 1] - ag[step]) * inv_dt")
    put(2, "else:")
    put(3, "alpha = 0.0")
    put(3, "beta = 0.0")
    _plain_step(put, nn, trackers)
    _plain_end(put, nn, trackers)
    return "\n".join(lines) + "\n"


CAPACITY_TRACKERS = (TR_D1F1, TR_D1F2, TR_D2)  # what a collapse capacity search reads


def _plain_run(nn: int):
    """The run of plain steps on nn coordinates, compiled (inlined into the loop)."""
    made: dict = {}
    exec(_plain_source(nn, CAPACITY_TRACKERS), globals(), made)  # (its names: this module's)
    return inline(made[f"_plain_{nn}"])


_plain_2 = _plain_run(2)
_plain_3 = _plain_run(NP)
PLAIN_RUNS = ("_plain_2", "_plain_3")  # compiled with the SLP vectorizer (native.Loop)


@inline
def _no_plain(ag, step, nsteps, N, dt, inv_dt, beta_prev, fam1, fam1_time, E, PV, RT, KP,
              TR, r, v, e_a, ed_a, val_a, der_a, peaks, rb, vb, e_b, ed_b):
    """No run of plain steps (the loop :data:`LOOP` has no capacity loop compiled in):
    the general loop takes every step."""
    return step, 0, fam1_time, beta_prev, False


@inner
def record_row(hist, k, L, N, ist, r, v, val, nfull):
    """One row of the histories: tilts, displacements, accelerations, pattern and the
    support-reduced coordinates r = N y and their rates."""
    hist[k, 0] = _rowdot(L, ROW_T1, r)
    hist[k, 1] = _rowdot(L, ROW_T2, r)
    hist[k, 2] = val[TR_UB]
    hist[k, 3] = val[TR_UC]
    hist[k, 4] = val[TR_UT]
    hist[k, 5] = val[TR_AB]
    hist[k, 6] = val[TR_AC]
    hist[k, 7] = val[TR_AT]
    hist[k, 8] = ist[I_FAM] * 10 + (1 if ist[I_S] > 0 else 2)
    for i in range(nfull):
        hist[k, 9 + i] = _rowdot(N, i, r)
        hist[k, 9 + nfull + i] = _rowdot(N, i, v)


@inner
def _march(P, ag, dt, ntail, cor, law, window, t_rest, geo, pieces, work, peaks, outs, hist,
           want_hist, evlog, capacity):
    """Integrate one analysis. ag: scaled ground acceleration [m/s2] (N samples).

    geo: the held states' watch rows, coordinate maps, inverse masses, rotation masks,
    sizes and tracker rows (:func:`geometry`); pieces: the piece tables (:class:`Tables`);
    work: scratch arrays. Fills peaks (N_TRACK), outs (N_OUT) and, when want_hist,
    hist[k, :] at every grid point k (theta1, theta2, u_b, u_c, u_t, a_b, a_c, a_t,
    pattern, then r, r_d). With `capacity` only the drift trackers (TR_D1F1, TR_D1F2,
    TR_D2: what a collapse capacity search reads) are followed through the sub-steps, by the
    same operations, so their peaks are those of a full run bit for bit; the other peaks
    are then meaningless. Returns a status code; ST_NEED_PIECE (with the piece in
    outs[O_NEED]) when a piece's tables are missing (the caller builds them, runs again).

    Compiled without numba's reference counting (``_nrt=False``): it never allocates. It has
    no Python wrapper: :mod:`urmx.native` calls it through a shim from two argument blocks
    (``ARRAYS``, ``INTS``, ``REALS``; the shim passes them in the order of ``LOOP_ARGS``,
    as ``LOOP`` describes)."""
    GL, GN, GX, GMI, GROT, GNN, GTR = geo
    ready, nsub, mats, vecs, prop, pvec, REL = pieces
    (D, cf, ist, rows, vrows, agc, sig, kap, kind, tgt, e_a, ed_a, e_b, ed_b, RT, RVT, AGT,
     KP, OPN, val_a, der_a, val_b, der_b, r, v, rb, vb, sacc, sjerk, tmp, counts) = work
    nfull = 3 - int(P[P_RIGID_B]) - int(P[P_RIGID_T])
    N = ag.shape[0]
    nsteps = N - 1 + ntail
    g_open = G_OPEN_FACTOR * curve(P, 2)[3]  # theta_a of Case 2
    v_rest = g_open / t_rest  # a constant of the model, not the record step
    inv_dt = 1.0 / dt  # a product per step instead of a division (its latency showed)
    # start: at rest, family 2, provisional sides against the first ground motion
    first = 0.0
    for k in range(N):
        if ag[k] != 0.0:
            first = ag[k]
            break
    ist[I_S] = -1 if first > 0 else 1
    ist[I_C] = -ist[I_S]
    ist[I_FAM] = 2
    ist[I_BOPEN] = JOINT_CLOSED
    ist[I_COPEN] = JOINT_CLOSED
    ist[I_BL] = 0
    ist[I_BU] = 0
    ist[I_BLA] = 0
    ist[I_H] = HELD_NONE
    for i in range(NP):
        r[i] = 0.0
        v[i] = 0.0
    for i in range(3):
        counts[i] = 0
    for t in range(N_TRACK):
        peaks[t] = 0.0
    for k in range(N_OUT):
        outs[k] = 0.0
    outs[O_COLLAPSE_T] = np.nan
    status = ST_OK
    fam1_time = 0.0
    n_events = 0
    n_sub = 0
    n_series = 0
    t_end = nsteps * dt
    h = HELD_NONE
    n = GNN[h]
    L = GL[h]
    TR = GTR[h, ist[I_FAM] - 1]
    mid = mode_index(h, ist[I_FAM], ist[I_BL], ist[I_BU], ist[I_BLA])
    if not ready[mid]:
        outs[O_NEED] = mid
        return ST_NEED_PIECE
    ne = active_events(P, L, REL[mid], ist, g_open, rows, vrows, agc, sig, kap, kind, tgt)
    ke = KE if ne <= KE else MAX_EV  # event functions the hot loops evaluate
    rel, opens = _event_table(rows, vrows, agc, sig, kap, kind, ne, RT, RVT, AGT, KP, OPN)
    MK, MC, MR, MG, E, PV = mats[mid, 0], mats[mid, 1], vecs[mid, 0], vecs[mid, 1], \
        prop[mid], pvec[mid]
    a_now = ag[0] if N > 0 else 0.0
    beta0 = (ag[1] - ag[0]) / dt if N > 1 else 0.0
    _events_now(RT, KP, r, v, e_a, ed_a)
    _point(MK, MC, MR, MG, TR, r, v, a_now, beta0, val_a, der_a, sacc, sjerk)
    for t in range(N_TRACK):
        peaks[t] = max(peaks[t], abs(val_a[t]))
    if want_hist:
        record_row(hist, 0, L, GN[h], ist, r, v, val_a, nfull)
    duration = t_end
    done = False
    beta_prev = beta0
    near = 0  # bit k: event function k may have just left zero (set at events)
    ev_here = 0  # events in the current span of EVENT_SPAN seconds, which ends at span_end
    span_end = -1.0
    step = 0
    handed = False  # True: a run of plain steps computed the first sub-step (rb, vb, e_b, ed_b)
    while step < nsteps:
        if capacity and nsub[mid] == 1 and near == 0 and not rel and not opens \
                and ke == KE and not want_hist:
            # a run of plain steps, state in locals (until something may happen)
            fam1 = ist[I_FAM] == 1
            if n == 2:
                step, n_plain, fam1_time, beta_prev, handed = _plain_2(
                    ag, step, nsteps, N, dt, inv_dt, beta_prev, fam1, fam1_time, E, PV, RT, KP,
                    TR, r, v, e_a, ed_a, val_a, der_a, peaks, rb, vb, e_b, ed_b)
            else:
                step, n_plain, fam1_time, beta_prev, handed = _plain_3(
                    ag, step, nsteps, N, dt, inv_dt, beta_prev, fam1, fam1_time, E, PV, RT, KP,
                    TR, r, v, e_a, ed_a, val_a, der_a, peaks, rb, vb, e_b, ed_b)
            n_sub += n_plain
            if step >= nsteps:
                break
        if step < N - 1:
            alpha = ag[step]
            beta = (ag[step + 1] - ag[step]) * inv_dt
        else:
            alpha = 0.0
            beta = 0.0
        t0 = step * dt
        tau = 0.0
        # the rates of the absolute accelerations jump with the slope of the record:
        # d(rate)/d(beta) = 1 - row . M^-1 G (values and other rates are continuous);
        # so do the rates of release functions (their ground term)
        if step > 0:
            dbeta = beta - beta_prev
            if not capacity:
                for t in range(N_DISP, N_TRACK):
                    der_a[t] += dbeta * (1.0 - _rowdot(TR, t, MG))
            if rel:
                for k in range(MAX_EV):
                    ed_a[k] += AGT[k] * dbeta
        beta_prev = beta
        while True:
            ns = nsub[mid]
            h_sub = dt
            tb = dt
            if ns > 1:
                h_sub = dt / ns
                # end of this sub-step: the next multiple of h_sub (the step end at most)
                j = int(math.floor(tau / h_sub + 1e-9)) + 1
                if j < ns:
                    tb = j * h_sub
            H = tb - tau
            if H <= 1e-15 * dt:
                break
            n_sub += 1
            a0 = alpha + beta * tau
            full = (tau == 0.0 and ns == 1) or abs(H - h_sub) <= 1e-12 * h_sub
            m_taylor = 0
            if handed:  # (computed by the run of plain steps, by the same operations)
                handed = False
            else:
                if full:
                    _propagate(E, PV, r, v, a0, beta, rb, vb, n)
                else:
                    m_taylor = _taylor(MK, MC, MR, MG, r, v, a0, beta, H, D, n)
                    _sum_state(D, m_taylor, 1.0, H, rb, vb, n)
                _events_at(RT, KP, rb, vb, e_b, ed_b, n, ke)
            if rel:
                _events_rel(RVT, AGT, MK, MC, MR, MG, rb, vb, alpha + beta * tb, beta, e_b,
                            ed_b)
            # earliest event on [tau, tb]
            s_ev = 2.0
            k_ev = -1
            for k in range(ne if _may_fire(OPN, e_a, ed_a, e_b, ed_b, H, ke) else 0):
                opening = kind[k] == EV_BASE_OPEN or kind[k] == EV_CRACK_OPEN
                ea, eb, eda, edb = e_a[k], e_b[k], ed_a[k], ed_b[k]
                crossing = ea > 0.0 and eb <= 0.0
                # started on (or just behind) zero moving inward, and ends at or behind
                # it again: it rose and fell back (after an impact, a merged impact)
                rebound = ea <= 0.0 and eda > 0.0 and eb <= 0.0
                dip = False
                if opening:
                    # a tiny threshold (g_open) can be crossed and recrossed within a
                    # sub-step, with zero rate at the start (at rest): scan the series
                    dip = not crossing and ea > 0.0
                elif not crossing and ea > 0.0 and eb > 0.0 and eda < 0.0 and edb > 0.0 \
                        and min(ea, eb) - (4.0 / 27.0) * H * (edb - eda) < 0.25 * max(ea, eb):
                    # (the Hermite cubic stays above min(ends) - 4/27 (|m0| + |m1|))
                    lo, hi, slo, shi = _hermite_ext(ea, eb, eda * H, edb * H)
                    dip = lo < 0.25 * max(ea, eb)
                if not (crossing or dip or rebound):
                    continue
                if m_taylor == 0:
                    m_taylor = _taylor(MK, MC, MR, MG, r, v, a0, beta, H, D, n)
                mc = _event_poly(rows, vrows, agc, sig, kap, kind, k, D, m_taylor, H, a0, beta,
                                 cf)
                s_lo = 0.0
                s_hi = 1.0
                if rebound:
                    s_lo = _scan(cf, mc, True, False)
                    if s_lo < 0.0 or s_lo >= s_ev:
                        continue
                if dip:
                    if opening and _lower_bound(cf, mc) > 0.0:
                        continue  # e(s) >= c0 - sum|c_j| > 0 on [0, 1]: no crossing
                    # the exact first point where e <= 0 on the sub-step, if any
                    s_hi = _scan(cf, mc, False, eda < 0.0 and not opening)
                    if s_hi > 1.0:
                        continue
                if s_hi > s_ev:
                    # only an earlier root matters: has e already crossed at s_ev?
                    if _peval(cf, mc, s_ev)[0] > 0.0:
                        continue
                    s_hi = s_ev
                tol = TIME_TOL / H if H > 1e3 * TIME_TOL else 1e-3
                if crossing and s_hi == 1.0:
                    guess = _hermite_root(ea, eb, eda * H, edb * H)
                else:
                    guess = 0.5 * (s_lo + s_hi)
                lo_, hi_ = _newton(cf, mc, s_lo, s_hi, tol, guess, 0)
                s_root = hi_  # the side where the event function has crossed
                if s_root < s_ev or k_ev < 0 or (s_root == s_ev and release_tie(
                        ist, kind, tgt, k_ev, k)):
                    s_ev = s_root
                    k_ev = k
            if near:
                # a function at zero after an event (an impact, a release, a boundary
                # crossed) can come back at once, even twice, which the ends' signs do not
                # show: unless it provably rises through this sub-step, its first fall is
                # searched for (MODEL.md section 4, last detail of holding). A second pass,
                # so that the events of the first are found as before, and calls, to keep
                # this loop small.
                if m_taylor == 0:
                    m_taylor = _taylor(MK, MC, MR, MG, r, v, a0, beta, H, D, n)
                zero = _rising(near, rows, sig, kind, e_a, D, m_taylor)
                if zero:
                    s_ev, k_ev = _first_falls(rows, vrows, agc, sig, kap, kind, ne, zero, D,
                                              m_taylor, H, a0, beta, cf, s_ev, k_ev)
                if H >= h_sub / 16.0:
                    near = 0  # (left zero a sixteenth of a sub-step ago at least)
            s_end = 1.0
            t_end = tb
            if k_ev >= 0:
                # an event at tau + s_ev*H: the state there, summed from the series
                if m_taylor == 0:
                    m_taylor = _taylor(MK, MC, MR, MG, r, v, a0, beta, H, D, n)
                _sum_state(D, m_taylor, s_ev, H, rb, vb, n)
                s_end = s_ev
                t_end = tau + s_ev * H
            a_end = alpha + beta * t_end
            if capacity:  # (two copies, each with constant tracker bounds)
                _point_fast(MK, MC, MR, MG, TR, rb, vb, a_end, beta, val_b, der_b, sacc,
                            sjerk, n, TR_D1F1, TR_D2 + 1)
            else:
                _point_fast(MK, MC, MR, MG, TR, rb, vb, a_end, beta, val_b, der_b, sacc,
                            sjerk, n, 0, N_TRACK)
            if s_end > 0.0:
                # peaks over [tau, t_end], the one-sided values before an event included
                if capacity:
                    m_taylor = _peaks_over(TR, peaks, val_a, der_a, val_b, der_b, s_end,
                                           m_taylor, D, cf, MK, MC, MR, MG, r, v, a0, beta, H,
                                           n, TR_D1F1, TR_D2 + 1)
                else:
                    m_taylor = _peaks_over(TR, peaks, val_a, der_a, val_b, der_b, s_end,
                                           m_taylor, D, cf, MK, MC, MR, MG, r, v, a0, beta, H,
                                           n, 0, N_TRACK)
            if m_taylor:
                n_series += 1
            if ist[I_FAM] == 1:
                fam1_time += s_end * H
            tau = t_end
            for i in range(NP):
                r[i] = rb[i]
                v[i] = vb[i]
            if k_ev < 0:  # no event: on to the next sub-step
                for t in range(N_TRACK):
                    val_a[t] = val_b[t]
                    der_a[t] = der_b[t]
                for k in range(MAX_EV):
                    e_a[k] = e_b[k]
                    ed_a[k] = ed_b[k]
                if tb >= dt:
                    break
                continue
            # handle this event and every other one due at the same instant
            while k_ev >= 0:
                if n_events < evlog.shape[0]:
                    evlog[n_events, 0] = t0 + tau
                    evlog[n_events, 1] = kind[k_ev]
                    evlog[n_events, 2] = tgt[k_ev]
                n_events += 1
                if t0 + tau >= span_end:  # a new span (t >= 0: int() is floor)
                    span_end = (int((t0 + tau) * (1.0 / EVENT_SPAN)) + 1) * EVENT_SPAN
                    ev_here = 0
                ev_here += 1
                if ev_here > MAX_EVENTS:
                    status = ST_EVENT_LIMIT
                    break
                code = handle_event(P, GL, GX, GMI, GROT, ist, kind[k_ev], tgt[k_ev], r, v,
                                    cor, law, window, alpha + beta * tau, MK, MC, MR, MG,
                                    v_rest, counts, tmp)
                if n_events <= evlog.shape[0]:  # the pattern after the event
                    evlog[n_events - 1, 3] = ist[I_FAM] * 10 + (1 if ist[I_S] > 0 else 2)
                if code != 0:
                    outs[O_COLLAPSE_SEG] = code  # 1: lower, 2: upper segment
                    status = ST_COLLAPSED
                    break
                # new piece
                h = ist[I_H]
                n = GNN[h]
                L = GL[h]
                TR = GTR[h, ist[I_FAM] - 1]
                mid = mode_index(h, ist[I_FAM], ist[I_BL], ist[I_BU], ist[I_BLA])
                if not ready[mid]:
                    outs[O_NEED] = mid
                    status = ST_NEED_PIECE
                    break
                ne = active_events(P, L, REL[mid], ist, g_open, rows, vrows, agc, sig, kap,
                                   kind, tgt)
                ke = KE if ne <= KE else MAX_EV
                rel, opens = _event_table(rows, vrows, agc, sig, kap, kind, ne, RT, RVT, AGT, KP,
                                          OPN)
                MK, MC, MR, MG, E, PV = mats[mid, 0], mats[mid, 1], vecs[mid, 0], \
                    vecs[mid, 1], prop[mid], pvec[mid]
                # (on the piece's coordinates: the padding ones have zero rows)
                _point_fast(MK, MC, MR, MG, TR, r, v, alpha + beta * tau, beta, val_a, der_a,
                            sacc, sjerk, n, 0, N_TRACK)
                for t in range(N_TRACK):  # the one-sided values after the event
                    peaks[t] = max(peaks[t], abs(val_a[t]))
                _events_at(RT, KP, r, v, e_a, ed_a, n, ke)
                if rel:
                    _events_rel(RVT, AGT, MK, MC, MR, MG, r, v, alpha + beta * tau, beta, e_a,
                                ed_a)
                # the functions at zero (MODEL.md section 4): searched for a fall on this
                # sub-step and the next
                h_next = dt / nsub[mid]
                near = 0
                for k in range(ne):
                    if kind[k] != EV_BASE_OPEN and kind[k] != EV_CRACK_OPEN \
                            and e_a[k] <= (h_next / 16.0) * max(ed_a[k], 0.0):
                        near |= 1 << k
                # a boundary reached at the same instant and moving outward fires now; a
                # held joint whose release test is already positive is released now (to
                # the side of the current family when both sides qualify)
                k_ev = -1
                for k in range(ne):
                    if kind[k] == EV_BASE_RELEASE or kind[k] == EV_CRACK_RELEASE:
                        now = e_a[k] < 0.0 or (e_a[k] == 0.0 and ed_a[k] < 0.0)
                    else:
                        now = e_a[k] <= 0.0 and ed_a[k] < 0.0
                    if now and (k_ev < 0 or release_tie(ist, kind, tgt, k_ev, k)):
                        k_ev = k
            if status == ST_NEED_PIECE:
                return status
            if status != ST_OK:
                done = True
                duration = t0 + tau
                if status == ST_COLLAPSED:
                    outs[O_COLLAPSE_T] = t0 + tau
                break
        if done:
            break
        if step == N - 2:
            # the record ends: the right-hand limit of the absolute accelerations (xg_dd = 0)
            _point(MK, MC, MR, MG, TR, r, v, 0.0, 0.0, val_b, der_b, sacc, sjerk)
            for t in range(N_DISP, N_TRACK):
                peaks[t] = max(peaks[t], abs(val_b[t]))
        if want_hist:
            a_grid = ag[step + 1] if step + 1 < N else 0.0
            _point(MK, MC, MR, MG, TR, r, v, a_grid, 0.0, val_b, der_b, sacc, sjerk)
            record_row(hist, step + 1, L, GN[h], ist, r, v, val_b, nfull)
        step += 1
    outs[O_FAM1_TIME] = fam1_time
    outs[O_DURATION] = duration
    outs[O_BASE_IMP] = counts[0]
    outs[O_CRACK_IMP] = counts[1]
    outs[O_HOLDS] = counts[2]
    outs[O_EVENTS] = n_events
    outs[O_SUBSTEPS] = n_sub
    outs[O_SERIES] = n_series
    return status


# the loop as urmx.native compiles and calls it, as two native objects, each compiled on
# first use: LOOP_CAPACITY, with the runs of plain steps of a capacity search, and LOOP,
# _march without them, for every other analysis (the runs cost about 5 s of first compile,
# and a full-tracking analysis never enters them)
LOOP_CAPACITY = native.Loop(_march, LOOP_ARGS, INTS, REALS, flags=("want_hist",),
                            vectorize=PLAIN_RUNS, name="march-capacity")
LOOP = native.Loop(jitcache.Variant(_march, "_march_full", _plain_2=_no_plain,
                                    _plain_3=_no_plain),
                   LOOP_ARGS, INTS, REALS, flags=("want_hist",), name="march")
LOOPS = (LOOP, LOOP_CAPACITY)  # by capacity (False, True)


# The event semantics as the scipy reference solver calls them from Python: the same
# functions compiled with Python wrappers (and cached), only when the reference is used;
# the kernel calls the wrapper-less ones above.
active_events_py = entry(active_events.py_func)
handle_event_py = entry(handle_event.py_func)
release_tie_py = entry(release_tie.py_func)
record_row_py = entry(record_row.py_func)

