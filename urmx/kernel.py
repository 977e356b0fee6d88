"""The exact event-driven integrator (MODEL.md sections 4-10), numpy/numba only.

Method
------
Between two events the reduced system ``M r_dd + C r_d + K r + R0 = -G xg_dd(t)`` is
linear with constant coefficients, and inside one record step the forcing is linear in
time. Its solution is an entire function of time, so:

* Each piece (family, lower branch, upper branch) gets a *mode*: ``M^-1 K``, ``M^-1 C``,
  ``M^-1 R0``, ``M^-1 G`` and the exact propagator over a sub-step ``h = dt/nsub``
  (state-transition matrix plus the responses to the constant, ramp and resistance
  forcing), built for all 50 pieces before the first step of a wall and record step
  (about 3 ms) and cached for the next analysis of the same wall.
  ``nsub`` is the smallest integer with ``nu*h <= 1``, ``nu = sqrt(|M^-1 K|) + |M^-1 C|``
  bounding the piece's frequencies (1 for soft walls; a 1e9 N/m spring needs more).
* Whole sub-steps are stepped by one matrix-vector product (exact to round-off).
* Where an event function changes sign on a sub-step, or may dip through zero between
  its ends (a cubic Hermite estimate from the exact values and rates at both ends says it
  might), or where a peak output may have an interior extremum above its running peak,
  the exact solution on that sub-step is expanded in its Taylor series about the
  sub-step start. With ``nu*h <= 1`` the series converges to round-off in 10-30 terms
  and the roots of event functions, their times, and the states there are found on it
  by a bracketed Newton iteration that stops on the bracket width (TIME_TOL).
  The state at an event is the series summed at the event time, not an interpolant.

Speed (measured on the benchmark wall, 592 events, 2688 steps: 3.0 ms an analysis at
first, about 0.5 ms now on a quiet moment of a noisy 2-core host). What paid, largest first:

* The integration loop (:func:`_march`) and every helper it calls are compiled with
  ``_nrt=False``: numba's reference counting incremented and decremented every array
  argument of every helper call (an atomic operation each), which cost more than the
  arithmetic. Code compiled that way cannot allocate, so :func:`_integrate` allocates the
  work arrays and builds the piece tables before the loop; the loop takes views of them.
* Arrays over the reduced coordinates are padded to NP = 3 (unused entries exactly zero),
  so the small loops have constant trip counts the compiler unrolls; the propagation, the
  event functions, the trackers and the Taylor series are further specialised to the
  true n (1, 2 or 3), which removes the padded products (about 9 % of the run for n=2).
* Event roots start from the root of the cubic Hermite interpolant of the exact end
  values and rates and use Newton on value and slope, evaluated as even and odd parts in
  s^2 (four Horner chains of half the length): about 3.4 evaluations a root.
* The Taylor recurrence is a chain of dependent products, so its cost is its latency:
  for n = 2 the matrices and last terms are kept in registers and two terms are computed
  a pass from the two before them (see :func:`_tail2`).
* ``error_model="numpy"`` on the loop's functions: numba's default tests every float
  division for a zero divisor to raise ZeroDivisionError (a compare and branch each);
  the kernel guards its divisions itself, and results are bitwise the same (about 2 %).
* Small things the profile (perf with a JIT symbol map) showed: a division chain per
  sub-step, signed-index handling in descending loops, copying piece tables.

Event semantics (contacts, the opening rule, impacts and their laws, merged impacts,
branch changes, collapse) live in the small functions below and are shared with the
scipy reference solver in :mod:`urmx.reference`.

Documented choices
------------------
* Event times are located to ``TIME_TOL = 1e-12 s`` (bracket width).
* Opening rule (MODEL.md section 4): both contacts start closed; a closed contact opens
  when ``|g|`` exceeds ``g_open = 1e-6 * theta_a(Case 2)``, taking the side of ``g``.
  With a flexible base the side on which the wall departs is decided by high-order
  terms, and in a few percent of walls the result depends on this rule.
* A contact that an impact leaves with ``|g_d| < v_rest = g_open/dt`` is closed again.
* Impacts closer than the window ``w`` (default 1e-6 s) are merged (section 7).
* At most ``MAX_EVENTS_PER_STEP`` events in one record step; beyond that the run stops
  with status ``event-limit``.
"""

from __future__ import annotations

import math
from collections import OrderedDict

import numpy as np
from numba import njit

from .model import (
    P_A1,
    P_A2,
    P_RIGID_B,
    P_RIGID_T,
    Wall,
    classify,
    curve,
    lower_case,
    n_dof,
    system,
    transform,
)

KMAX = 48  # most Taylor terms a sub-step may need
_INV12 = np.array([1.0 / ((j + 1.0) * (j + 2.0)) for j in range(KMAX)])
_INV2 = np.array([1.0 / (j + 2.0) for j in range(KMAX)])
RHO = 1.0  # nu*h bound of a sub-step
GATE = 0.05  # refine an interior extremum when the Hermite estimate is within 5 % of the peak
TIME_TOL = 1e-12  # event time tolerance [s]
MAX_EVENTS_PER_STEP = 200
WINDOW = 1e-6  # merged-impact window w [s]
G_OPEN_FACTOR = 1e-6

NMODES = 50
# every numba array over the reduced coordinates r is padded to NP entries: the unused
# trailing ones stay exactly zero (padded matrices have zero rows and columns there), so
# every small loop has a constant trip count the compiler unrolls (measured: about 6x
# faster than loops of run-time length 1-3 at these sizes)
NP = 3
# rows over q = [theta1, theta2, u_b] of the quantities the kernel watches
ROW_T1, ROW_T2, ROW_UB, ROW_UC, ROW_UT, ROW_GC = range(6)
# peak trackers (the first N_DISP act on r, the rest on r_dd plus the ground)
TR_UB, TR_UC, TR_UT, TR_D1, TR_D2, TR_RL, TR_RU, TR_AB, TR_AC, TR_AT = range(10)
N_TRACK = 10
N_DISP = 7
# integer state
I_FAM, I_S, I_C, I_BOPEN, I_COPEN, I_BL, I_BU = range(7)
N_IST = 7
# event kinds
EV_BASE_IMPACT, EV_CRACK_IMPACT, EV_BASE_OPEN, EV_CRACK_OPEN = 0, 1, 2, 3
EV_LOWER, EV_UPPER, EV_COLLAPSE_LOWER, EV_COLLAPSE_UPPER = 4, 5, 6, 7
MAX_EV = 8
# status codes
ST_OK, ST_COLLAPSED, ST_EVENT_LIMIT = 0, 1, 2
STATUS = ("ok", "collapsed", "event-limit")
LAWS = {"scale": 0, "contact": 1}
# scalar outputs of _integrate (index order)
O_COLLAPSE_T, O_FAM1_TIME, O_DURATION, O_BASE_IMP, O_CRACK_IMP, O_EVENTS = range(6)
O_SUBSTEPS, O_SERIES = 6, 7
N_OUT = 8


# ---- shared event semantics -----------------------------------------------------------

@njit(cache=True, _nrt=False, error_model="numpy", inline='always')
def _rowdot(A, i, x):
    """Row i of a padded matrix times a padded vector (no array view is created)."""
    out = 0.0
    for k in range(NP):
        out += A[i, k] * x[k]
    return out


@njit(cache=True, _nrt=False, error_model="numpy", inline='always')
def _copy_row(src, i, dst, k):
    for j in range(NP):
        dst[k, j] = src[i, j]


@njit(cache=True)
def watch_rows(P):
    """Rows over the padded reduced coordinates r of theta1, theta2, u_b, u_c, u_t, g_crack.

    Outputs fixed by a constraint get exactly zero rows (MODEL.md section 6)."""
    a1, a2 = P[P_A1], P[P_A2]
    Lq = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [a1, 0.0, 1.0],
                   [a1, a2, 1.0], [-1.0, 1.0, 0.0]])
    Ln = Lq @ transform(P)
    L = np.zeros((6, NP))
    L[:, :Ln.shape[1]] = Ln
    if P[P_RIGID_B] > 0.5:
        L[ROW_UB, :] = 0.0
    if P[P_RIGID_T] > 0.5:
        L[ROW_UT, :] = 0.0
    return L


@njit(cache=True, _nrt=False, error_model="numpy")
def tracker_rows(P, L, fam, out):
    """Rows of the ten peak trackers; the lower instability ratio depends on the family."""
    a1, a2 = P[P_A1], P[P_A2]
    th0l = curve(P, lower_case(fam))[1]
    th01 = curve(P, 1)[1]
    for k in range(NP):
        out[TR_UB, k] = L[ROW_UB, k]
        out[TR_UC, k] = L[ROW_UC, k]
        out[TR_UT, k] = L[ROW_UT, k]
        out[TR_D1, k] = a1 * L[ROW_T1, k]
        out[TR_D2, k] = a2 * L[ROW_T2, k]
        out[TR_RL, k] = L[ROW_T1, k] / th0l
        out[TR_RU, k] = L[ROW_T2, k] / th01
        out[TR_AB, k] = L[ROW_UB, k]
        out[TR_AC, k] = L[ROW_UC, k]
        out[TR_AT, k] = L[ROW_UT, k]


@njit(cache=True, _nrt=False, error_model="numpy", inline='always')
def mode_index(fam, bl, bu):
    return (fam - 1) * 25 + (bl + 2) * 5 + (bu + 2)


@njit(cache=True, _nrt=False, error_model="numpy")
def _branch_events(P, case, b, L, lrow, kind_branch, kind_collapse, k, rows, sig, kap, kind,
                   tgt):
    """Event functions e = sig*(L[lrow].r) + kap (event when e falls through 0) bounding
    the signed branch b; signed boundaries, so passing through zero is never missed."""
    M0, th0, Mi, ta, tb = curve(P, case)
    if b == 0:
        for sg in (1, -1):  # reaching +theta_a, -theta_a
            _copy_row(L, lrow, rows, k)
            sig[k] = -sg
            kap[k] = ta
            kind[k] = kind_branch
            tgt[k] = sg
            k += 1
        return k
    sg = 1 if b > 0 else -1
    inner = ta if abs(b) == 1 else tb
    outer = tb if abs(b) == 1 else th0
    _copy_row(L, lrow, rows, k)
    sig[k] = sg
    kap[k] = -inner
    kind[k] = kind_branch
    tgt[k] = 0 if abs(b) == 1 else sg
    k += 1
    _copy_row(L, lrow, rows, k)
    sig[k] = -sg
    kap[k] = outer
    kind[k] = kind_branch if abs(b) == 1 else kind_collapse
    tgt[k] = 2 * sg
    k += 1
    return k


@njit(cache=True, _nrt=False, error_model="numpy")
def active_events(P, L, ist, g_open, rows, sig, kap, kind, tgt):
    """The event functions of the current piece; returns how many."""
    k = 0
    for which in range(2):
        lrow = ROW_T1 if which == 0 else ROW_GC
        side = ist[I_S] if which == 0 else ist[I_C]
        is_open = ist[I_BOPEN] if which == 0 else ist[I_COPEN]
        if is_open:
            _copy_row(L, lrow, rows, k)  # impact when side*g falls to zero
            sig[k] = side
            kap[k] = 0.0
            kind[k] = EV_BASE_IMPACT if which == 0 else EV_CRACK_IMPACT
            tgt[k] = 0
            k += 1
        else:
            for sg in (1, -1):  # opening when |g| exceeds g_open
                _copy_row(L, lrow, rows, k)
                sig[k] = -sg
                kap[k] = g_open
                kind[k] = EV_BASE_OPEN if which == 0 else EV_CRACK_OPEN
                tgt[k] = sg
                k += 1
    if ist[I_BOPEN] and ist[I_COPEN] and P[P_RIGID_B] > 0.5 and P[P_RIGID_T] > 0.5:
        k -= 1  # both supports rigid: the two contacts are one coordinate, one impact
    k = _branch_events(P, lower_case(ist[I_FAM]), ist[I_BL], L, ROW_T1, EV_LOWER,
                       EV_COLLAPSE_LOWER, k, rows, sig, kap, kind, tgt)
    k = _branch_events(P, 1, ist[I_BU], L, ROW_T2, EV_UPPER, EV_COLLAPSE_UPPER, k, rows,
                       sig, kap, kind, tgt)
    return k


@njit(cache=True, _nrt=False, error_model="numpy")
def set_family(P, ist, r, v, L):
    """Family from the pivot sides; a family change reclassifies the lower branch.
    Returns True when |theta1| is at or beyond the new case's theta0 (immediate collapse)."""
    fam = 1 if ist[I_S] == ist[I_C] else 2
    th1 = _rowdot(L, ROW_T1, r)
    if fam != ist[I_FAM]:
        ist[I_FAM] = fam
        case = lower_case(fam)
        ist[I_BL] = classify(P, case, th1, _rowdot(L, ROW_T1, v))
        if abs(th1) >= curve(P, case)[1]:
            return True
    return False


@njit(cache=True)
def mass_inverses(P, law):
    """Padded M^-1 of family 1 and 2 (the mass depends on the family only), built once per
    analysis for the contact law; the scale law needs none (zeros)."""
    n = n_dof(P)
    out = np.zeros((2, NP, NP))
    if law == 1:
        for fam in (1, 2):
            out[fam - 1, :n, :n] = system(P, fam, 0, 0)[5]
    return out


@njit(cache=True, _nrt=False, error_model="numpy", inline='always')
def _quad(Minv, f, L, i, j):
    """L[i] . Minv[f] . L[j] over padded coordinates."""
    out = 0.0
    for k in range(NP):
        s = 0.0
        for q in range(NP):
            s += L[i, q] * Minv[f, q, k]
        out += s * L[j, k]
    return out


@njit(cache=True, _nrt=False, error_model="numpy")
def impact_velocity(L, v, base, crack, cor, law, Minv, f):
    """Velocity jump of an impact in padded reduced coordinates.

    scale: every rotational component times cor. The rotations are the first two padded
    entries (theta1 and theta2, or theta1 and a zero pad), an independent u_b the third,
    which is unchanged.
    contact: v+ = v- + Minv J^T lam with J v+ = cor * J v- (generalised Newton law),
    Minv = Minv[f] of the pattern after the impact; parallel rows (both supports rigid)
    use one."""
    if law == 0:
        v[0] *= cor
        v[1] *= cor
        return
    ja = ROW_T1 if base else ROW_GC
    jb = ROW_GC
    two = base and crack
    Aaa = _quad(Minv, f, L, ja, ja)
    if two:
        Aab = _quad(Minv, f, L, ja, jb)
        Aba = _quad(Minv, f, L, jb, ja)
        Abb = _quad(Minv, f, L, jb, jb)
        det = Aaa * Abb - Aab * Aba
        if abs(det) <= 1e-12 * abs(Aaa * Abb):
            two = False
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
            s += Minv[f, i, k] * (L[ja, k] * lam_a + L[jb, k] * lam_b)
        v[i] += s


@njit(cache=True, _nrt=False, error_model="numpy")
def handle_event(P, L, ist, kd, target, r, v, cor, law, window, ag_now, MK, MC, MR, MG,
                 Minv_fam, v_rest, counts):
    """Carry out one event at the current state (shared by both solvers; padded arrays).

    Minv_fam: padded M^-1 per family (:func:`mass_inverses`), used by the contact law.

    Updates the integer state ist and the velocities v in place and counts impacts.
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
    if kd == EV_BASE_OPEN or kd == EV_CRACK_OPEN:
        # a closed joint opens on the side of g, without an impact (MODEL.md section 4)
        if kd == EV_BASE_OPEN:
            ist[I_BOPEN] = 1
            ist[I_S] = target
        else:
            ist[I_COPEN] = 1
            ist[I_C] = target
        return 1 if set_family(P, ist, r, v, L) else 0
    base = kd == EV_BASE_IMPACT
    crack = kd == EV_CRACK_IMPACT
    if P[P_RIGID_B] > 0.5 and P[P_RIGID_T] > 0.5:
        base = True  # both supports rigid: the two joints close together, one impact
        crack = True
    else:
        # merged impact: the other open joint, continued on the motion before the
        # impact, closes within the window w (MODEL.md section 7)
        other_open = ist[I_COPEN] if base else ist[I_BOPEN]
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
    fam_after = 1 if ist[I_S] == ist[I_C] else 2
    impact_velocity(L, v, base, crack, cor, law, Minv_fam, fam_after - 1)
    # a joint left slower than v_rest is closed again, under the opening rule
    if base and abs(_rowdot(L, ROW_T1, v)) < v_rest:
        ist[I_BOPEN] = 0
    if crack and abs(_rowdot(L, ROW_GC, v)) < v_rest:
        ist[I_COPEN] = 0
    return 1 if set_family(P, ist, r, v, L) else 0


@njit(cache=True, _nrt=False, error_model="numpy", inline='always')
def _row_acc(L, lrow, MK, MC, MR, MG, r, v, ag):
    """Relative acceleration of the quantity of row L[lrow] (padded arrays)."""
    out = 0.0
    for i in range(NP):
        s = -MR[i] - MG[i] * ag
        for k in range(NP):
            s -= MK[i, k] * r[k] + MC[i, k] * v[k]
        out += L[lrow, i] * s
    return out


# ---- numerics: modes, Taylor series, scalar polynomials -------------------------------

@njit(cache=True, _nrt=False, error_model="numpy")
def _norm_inf(A):
    best = 0.0
    for i in range(A.shape[0]):
        s = 0.0
        for j in range(A.shape[1]):
            s += abs(A[i, j])
        best = max(best, s)
    return best


@njit(cache=True, _nrt=False, error_model="numpy", inline='always')
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


@njit(cache=True, _nrt=False, error_model="numpy", inline='always')
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


@njit(cache=True, _nrt=False, error_model="numpy")
def _taylor(MK, MC, MR, MG, r0, v0, a0, beta, h, D, n):
    """Taylor coefficients D[j] = r^(j)(0) h^j / j! of the exact solution on [0, h] of
    r_dd = -MK r - MC r_d - MR - MG (a0 + beta*t) (padded arrays; n reduced coordinates,
    the padding columns of D stay zero). Returns the number of terms.

    The loops are specialised to n = 1, 2, 3: this is the kernel's most-run arithmetic
    (two series per event), and padded loops did 9 products per term where n = 2 needs 4."""
    if n == 2:
        return _taylor_n(MK, MC, MR, MG, r0, v0, a0, beta, h, D, 2)
    if n == 3:
        return _taylor_n(MK, MC, MR, MG, r0, v0, a0, beta, h, D, 3)
    return _taylor_n(MK, MC, MR, MG, r0, v0, a0, beta, h, D, 1)


@njit(cache=True, _nrt=False, error_model="numpy", inline='always')
def _sum_state(D, m, s, h, r, v):
    """r(s h) and r_d(s h) from the Taylor coefficients."""
    if s == 1.0:  # the same sums without the products by 1 (half the latency)
        for i in range(NP):
            p = D[m - 1, i]
            dp = 0.0
            for k in range(m - 1):  # j = m - 2 - k, unsigned: no negative-index handling
                j = np.uint64(m - 2 - k)
                dp = dp + p
                p = p + D[j, i]
            r[i] = p
            v[i] = dp / h
        return
    for i in range(NP):
        p = D[m - 1, i]
        dp = 0.0
        for k in range(m - 1):
            j = np.uint64(m - 2 - k)
            dp = dp * s + p
            p = p * s + D[j, i]
        r[i] = p
        v[i] = dp / h


@njit(cache=True, _nrt=False, error_model="numpy", inline='always')
def _scalar_poly(R, ri, D, m, acc_kind, h, a0, beta, sig, kap, cf):
    """Coefficients in s = t/h of sig*row.r + kap (displacement kind) or of
    row.r_dd + xg_dd (acceleration kind), row = R[ri]. Returns their number."""
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


@njit(cache=True, _nrt=False, error_model="numpy", inline='always')
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


@njit(cache=True, _nrt=False, error_model="numpy", inline='always')
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


@njit(cache=True, _nrt=False, error_model="numpy", inline='always')
def _newton(cf, m, lo, hi, tol, guess, order):
    """Bracketed Newton for a sign change of the polynomial (order 0, positive at lo, on
    value and slope by :func:`_peval1`) or of its slope (order 1, an extremum, on slope
    and curvature by :func:`_peval`) over [lo, hi]; stops on the bracket width. Returns
    (a, b), |b - a| <= tol: the function has at a the sign it has at lo, at b the other."""
    # oriented f: negative on the lo side
    if order == 0:
        orient = -1.0
    else:
        orient = 1.0 if _peval(cf, m, lo)[1] < 0.0 else -1.0
    a, b = lo, hi
    x = guess if lo < guess < hi else 0.5 * (lo + hi)
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
        if abs(xn - x) < 0.5 * tol:  # close the bracket from the other side
            xn = x + 0.5 * tol if f < 0.0 else x - 0.5 * tol
            xn = min(max(xn, a), b)
        x = xn
    return a, b


@njit(cache=True, _nrt=False, error_model="numpy")
def _root(cf, m, lo, hi, tol, guess):
    """A root of an event function's polynomial, positive at lo and not at hi:
    (a, b), f(a) > 0 >= f(b), b - a <= tol (one two-chain evaluation an iteration)."""
    return _newton(cf, m, lo, hi, tol, guess, 0)


@njit(cache=True, _nrt=False, error_model="numpy")
def _solve(cf, m, lo, hi, tol, guess):
    """An extremum of the polynomial: a root of its slope, which changes sign on
    [lo, hi]. Returns (a, b) as :func:`_newton` does."""
    return _newton(cf, m, lo, hi, tol, guess, 1)


@njit(cache=True, _nrt=False, error_model="numpy")
def _hermite_root(p0, p1, m0, m1):
    """A starting point for :func:`_root`: the root in (0, 1] of the cubic Hermite
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


@njit(cache=True, _nrt=False, error_model="numpy", inline='always')
def _lower_bound(cf, m):
    """A rigorous lower bound of the polynomial on [0, 1]: c0 - sum_j>=1 |c_j|."""
    out = cf[0]
    for j in range(1, m):
        out -= abs(cf[j])
    return out


@njit(cache=True, _nrt=False, error_model="numpy")
def _positive_max(cf, m):
    """For a polynomial starting at or below zero with a positive slope and ending at or
    below zero: the point of its first maximum if that maximum is positive, else -1."""
    ns = 16
    d_prev = _peval(cf, m, 0.0)[1]
    s_prev = 0.0
    for i in range(1, ns + 1):
        s = i / ns
        d = _peval(cf, m, s)[1]
        if d_prev > 0.0 and d <= 0.0:
            a, b = _solve(cf, m, s_prev, s, 1e-14, 0.5 * (s_prev + s))
            sm = 0.5 * (a + b)
            return sm if _peval(cf, m, sm)[0] > 0.0 else -1.0
        d_prev, s_prev = d, s
    return -1.0


@njit(cache=True, _nrt=False, error_model="numpy")
def _first_nonpositive(cf, m, single_min):
    """A point s in (0, 1] where the polynomial (positive at 0) is <= 0, at or before
    its first interior minimum that reaches zero; 2.0 when it stays positive.

    single_min: the Hermite test found one interior minimum; otherwise the interval is
    scanned at 16 points and every local minimum between them is located exactly."""
    if single_min:
        a, b = _solve(cf, m, 0.0, 1.0, 1e-14, 0.5)
        s = 0.5 * (a + b)
        return s if _peval(cf, m, s)[0] <= 0.0 else 2.0
    ns = 16
    d_prev = _peval(cf, m, 0.0)[1]
    s_prev = 0.0
    for i in range(1, ns + 1):
        s = i / ns
        p, d, _ = _peval(cf, m, s)
        if p <= 0.0:
            return s
        if d_prev < 0.0 and d > 0.0:
            a, b = _solve(cf, m, s_prev, s, 1e-14, 0.5 * (s_prev + s))
            sm = 0.5 * (a + b)
            if _peval(cf, m, sm)[0] <= 0.0:
                return sm
        d_prev, s_prev = d, s
    return 2.0


@njit(cache=True, _nrt=False, error_model="numpy")
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


@njit(cache=True)
def _build_mode(P, fam, bl, bu, dt, idx, ready, nsub, mats, vecs, prop, pvec, D):
    """Fill the cached tables of one piece (padded): M^-1 K, M^-1 C, M^-1 R0, M^-1 G and
    the exact propagator over h = dt/nsub (state transition E and the responses to the
    resistance, constant and ramp forcing), each column summed from its Taylor series."""
    M, C, K, R0, MinvG, Minv = system(P, fam, bl, bu)
    n = M.shape[0]
    MKn = Minv @ K
    MCn = Minv @ C
    MRn = Minv @ R0
    MK = np.zeros((NP, NP))
    MC = np.zeros((NP, NP))
    MR = np.zeros(NP)
    MG = np.zeros(NP)
    MK[:n, :n] = MKn
    MC[:n, :n] = MCn
    MR[:n] = MRn
    MG[:n] = MinvG
    mats[idx, 0] = MK
    mats[idx, 1] = MC
    vecs[idx, 0] = MR
    vecs[idx, 1] = MG
    # nu: the spectral radius of the first-order matrix [[0, I], [-M^-1 K, -M^-1 C]]
    # (the norm bound sqrt|M^-1 K| + |M^-1 C| is about twice as large for stiff springs)
    A = np.zeros((2 * n, 2 * n), np.complex128)
    for i in range(n):
        A[i, n + i] = 1.0
        for j in range(n):
            A[n + i, j] = -MKn[i, j]
            A[n + i, n + j] = -MCn[i, j]
    nu = np.max(np.abs(np.linalg.eigvals(A)))
    if not np.isfinite(nu):
        nu = math.sqrt(_norm_inf(MKn)) + _norm_inf(MCn)
    ns = max(1, int(math.ceil(nu * dt / RHO)))
    nsub[idx] = ns
    h = dt / ns
    z = np.zeros(NP)
    e = np.zeros(NP)
    r = np.zeros(NP)
    v = np.zeros(NP)
    prop[idx] = 0.0
    for col in range(2 * NP):
        i = col if col < NP else col - NP
        if i >= n:
            continue  # a padding coordinate: zero column
        e[:] = 0.0
        e[i] = 1.0
        if col < NP:
            m = _taylor(MK, MC, z, z, e, z, 0.0, 0.0, h, D, n)
        else:
            m = _taylor(MK, MC, z, z, z, e, 0.0, 0.0, h, D, n)
        _sum_state(D, m, 1.0, h, r, v)
        prop[idx, :NP, col] = r
        prop[idx, NP:, col] = v
    for which in range(3):
        if which == 0:
            m = _taylor(MK, MC, MR, z, z, z, 0.0, 0.0, h, D, n)
        elif which == 1:
            m = _taylor(MK, MC, z, MG, z, z, 1.0, 0.0, h, D, n)
        else:
            m = _taylor(MK, MC, z, MG, z, z, 0.0, 1.0, h, D, n)
        _sum_state(D, m, 1.0, h, r, v)
        pvec[idx, which, :NP] = r
        pvec[idx, which, NP:] = v
    ready[idx] = True


@njit(cache=True, _nrt=False, error_model="numpy", inline='always')
def _mode_tables(mats, vecs, prop, pvec, mid):
    """Views of the cached tables of piece mid: M^-1 K, M^-1 C, M^-1 R0, M^-1 G, the
    propagator E and its forcing responses."""
    return mats[mid, 0], mats[mid, 1], vecs[mid, 0], vecs[mid, 1], prop[mid], pvec[mid]


# ---- the integrator ---------------------------------------------------------------------

@njit(cache=True, _nrt=False, error_model="numpy", inline='always')
def _point_n(MK, MC, MR, MG, TR, r, v, ag, beta, val, der, acc, jerk, nn):
    """:func:`_point` over the first nn coordinates (a constant where inlined)."""
    for i in range(nn):
        s = -MR[i] - MG[i] * ag
        for k in range(nn):
            s -= MK[i, k] * r[k] + MC[i, k] * v[k]
        acc[i] = s
    for i in range(nn):
        s = -MG[i] * beta
        for k in range(nn):
            s -= MK[i, k] * v[k] + MC[i, k] * acc[k]
        jerk[i] = s
    for t in range(N_DISP):
        a = 0.0
        b = 0.0
        for k in range(nn):
            a += TR[t, k] * r[k]
            b += TR[t, k] * v[k]
        val[t] = a
        der[t] = b
    for t in range(N_DISP, N_TRACK):
        a = 0.0
        b = 0.0
        for k in range(nn):
            a += TR[t, k] * acc[k]
            b += TR[t, k] * jerk[k]
        val[t] = a + ag
        der[t] = b + beta


@njit(cache=True, _nrt=False, error_model="numpy", inline='always')
def _point(MK, MC, MR, MG, TR, r, v, ag, beta, val, der, acc, jerk, n):
    """Tracker values and rates at one instant (accelerations absolute); acc and jerk
    are scratch arrays. Specialised to n = 1, 2, 3 like :func:`_taylor`."""
    if n == 2:
        _point_n(MK, MC, MR, MG, TR, r, v, ag, beta, val, der, acc, jerk, 2)
    elif n == 3:
        _point_n(MK, MC, MR, MG, TR, r, v, ag, beta, val, der, acc, jerk, 3)
    else:
        _point_n(MK, MC, MR, MG, TR, r, v, ag, beta, val, der, acc, jerk, 1)


@njit(cache=True, _nrt=False, error_model="numpy", inline='always')
def _propagate_n(E, PV, r, v, a0, beta, rb, vb, nn):
    for i in range(nn):
        s1 = PV[0, i] + a0 * PV[1, i] + beta * PV[2, i]
        s2 = PV[0, NP + i] + a0 * PV[1, NP + i] + beta * PV[2, NP + i]
        for k in range(nn):
            s1 += E[i, k] * r[k]
            s2 += E[NP + i, k] * r[k]
        for k in range(nn):
            s1 += E[i, NP + k] * v[k]
            s2 += E[NP + i, NP + k] * v[k]
        rb[i] = s1
        vb[i] = s2


@njit(cache=True, _nrt=False, error_model="numpy", inline='always')
def _propagate(E, PV, r, v, a0, beta, rb, vb, n):
    """The state after a whole sub-step by the exact propagator (rb, vb must not be r, v)."""
    if n == 2:
        _propagate_n(E, PV, r, v, a0, beta, rb, vb, 2)
    elif n == 3:
        _propagate_n(E, PV, r, v, a0, beta, rb, vb, 3)
    else:
        _propagate_n(E, PV, r, v, a0, beta, rb, vb, 1)


@njit(cache=True, _nrt=False, error_model="numpy", inline='always')
def _event_table(rows, sig, kap, kind, ne, RT, KP, OPN):
    """The event functions of a piece as signed rows stored by column (RT[i, k] =
    sig[k]*rows[k, i]), offsets KP and opening flags OPN, padded to MAX_EV with inert
    functions (e = 1, rate 0) so that all are evaluated in fixed-length loops."""
    for k in range(MAX_EV):
        live = k < ne
        for i in range(NP):
            RT[i, k] = sig[k] * rows[k, i] if live else 0.0
        KP[k] = kap[k] if live else 1.0
        OPN[k] = 1.0 if live and (kind[k] == EV_BASE_OPEN or kind[k] == EV_CRACK_OPEN) \
            else 0.0


@njit(cache=True, _nrt=False, error_model="numpy", inline='always')
def _events_at_n(RT, KP, r, v, e, ed, nn):
    for k in range(MAX_EV):
        a = RT[0, k] * r[0]
        b = RT[0, k] * v[0]
        for i in range(1, nn):
            a += RT[i, k] * r[i]
            b += RT[i, k] * v[i]
        e[k] = a + KP[k]
        ed[k] = b


@njit(cache=True, _nrt=False, error_model="numpy", inline='always')
def _events_at(RT, KP, r, v, e, ed, n):
    """Values and rates of all MAX_EV event functions at state (r, v)."""
    if n == 2:
        _events_at_n(RT, KP, r, v, e, ed, 2)
    elif n == 3:
        _events_at_n(RT, KP, r, v, e, ed, 3)
    else:
        _events_at_n(RT, KP, r, v, e, ed, 1)


@njit(cache=True, _nrt=False, error_model="numpy", inline='always')
def _may_fire(OPN, e_a, ed_a, e_b, ed_b):
    """False when no event function can have an event on the sub-step: none ends at
    or below zero, no closed contact may open, none dips towards zero."""
    flag = False
    for k in range(MAX_EV):
        # (a superset: a rate turning upward is flagged whatever the values)
        flag |= (e_b[k] <= 0.0) | (OPN[k] * e_a[k] > 0.0) | ((ed_a[k] < 0.0) & (ed_b[k] > 0.0))
    return flag


@njit(cache=True)
def _integrate(P, ag, dt, ntail, cor, law, window, ready, nsub, mats, vecs, prop, pvec,
               peaks, outs, hist, want_hist, evlog):
    """Integrate one analysis. ag: scaled ground acceleration [m/s2] (N samples).
    Fills peaks (N_TRACK), outs (N_OUT) and, when want_hist, hist[k, :] at every grid
    point k (theta1, theta2, u_b, u_c, u_t, a_b, a_c, a_t, pattern, then r, v).
    Returns a status code."""
    L = watch_rows(P)
    TRF = np.zeros((2, N_TRACK, NP))  # tracker rows of families 1 and 2
    D = np.zeros((KMAX, NP))
    cf = np.zeros(KMAX)
    ist = np.zeros(N_IST, np.int64)
    rows = np.zeros((MAX_EV, NP))
    sig = np.zeros(MAX_EV)
    kap = np.zeros(MAX_EV)
    kind = np.zeros(MAX_EV, np.int64)
    tgt = np.zeros(MAX_EV, np.int64)
    e_a = np.zeros(MAX_EV)
    ed_a = np.zeros(MAX_EV)
    e_b = np.zeros(MAX_EV)
    ed_b = np.zeros(MAX_EV)
    RT = np.zeros((NP, MAX_EV))
    KP = np.zeros(MAX_EV)
    OPN = np.zeros(MAX_EV)
    val_a = np.zeros(N_TRACK)
    der_a = np.zeros(N_TRACK)
    val_b = np.zeros(N_TRACK)
    der_b = np.zeros(N_TRACK)
    r = np.zeros(NP)
    v = np.zeros(NP)
    rb = np.zeros(NP)
    vb = np.zeros(NP)
    sacc = np.zeros(NP)
    sjerk = np.zeros(NP)
    Minv_fam = mass_inverses(P, law)
    counts = np.zeros(2, np.int64)  # base, crack impacts
    tracker_rows(P, L, 1, TRF[0])
    tracker_rows(P, L, 2, TRF[1])
    # every piece's tables, built once per wall and record step (_march cannot allocate)
    for fam in (1, 2):
        for bl in range(-2, 3):
            for bu in range(-2, 3):
                mid = mode_index(fam, bl, bu)
                if not ready[mid]:
                    _build_mode(P, fam, bl, bu, dt, mid, ready, nsub, mats, vecs, prop, pvec, D)
    return _march(P, ag, dt, ntail, cor, law, window, nsub, mats, vecs, prop, pvec,
                  peaks, outs, hist, want_hist, evlog, L, TRF, D, cf, ist, rows, kind, tgt,
                  Minv_fam, counts, (sig, kap, e_a, ed_a, e_b, ed_b, RT, KP, OPN),
                  (val_a, der_a, val_b, der_b), (r, v, rb, vb, sacc, sjerk))


@njit(cache=True, _nrt=False, error_model="numpy")
def _march(P, ag, dt, ntail, cor, law, window, nsub, mats, vecs, prop, pvec, peaks,
           outs, hist, want_hist, evlog, L, TRF, D, cf, ist, rows, kind, tgt, Minv_fam,
           counts, evbuf, trbuf, vecbuf):
    """The integration loop of :func:`_integrate`, on the work arrays it allocated.

    Compiled without numba's reference counting (``_nrt=False``): it never allocates, and
    the counting of every array passed to every helper cost more than the arithmetic."""
    sig, kap, e_a, ed_a, e_b, ed_b, RT, KP, OPN = evbuf
    val_a, der_a, val_b, der_b = trbuf
    r, v, rb, vb, sacc, sjerk = vecbuf
    n = n_dof(P)
    N = ag.shape[0]
    nsteps = N - 1 + ntail
    g_open = G_OPEN_FACTOR * curve(P, 2)[3]  # theta_a of Case 2
    v_rest = g_open / dt
    # start: at rest, family 2, provisional sides against the first ground motion
    first = 0.0
    for k in range(N):
        if ag[k] != 0.0:
            first = ag[k]
            break
    ist[I_S] = -1 if first > 0 else 1
    ist[I_C] = -ist[I_S]
    ist[I_FAM] = 2
    ist[I_BOPEN] = 0
    ist[I_COPEN] = 0
    ist[I_BL] = 0
    ist[I_BU] = 0
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
    TR = TRF[ist[I_FAM] - 1]
    mid = mode_index(ist[I_FAM], ist[I_BL], ist[I_BU])
    ne = active_events(P, L, ist, g_open, rows, sig, kap, kind, tgt)
    _event_table(rows, sig, kap, kind, ne, RT, KP, OPN)
    _events_at(RT, KP, r, v, e_a, ed_a, n)
    MK, MC, MR, MG, E, PV = _mode_tables(mats, vecs, prop, pvec, mid)
    a_now = ag[0] if N > 0 else 0.0
    beta0 = (ag[1] - ag[0]) / dt if N > 1 else 0.0
    _point(MK, MC, MR, MG, TR, r, v, a_now, beta0, val_a, der_a, sacc, sjerk, n)
    for t in range(N_TRACK):
        peaks[t] = max(peaks[t], abs(val_a[t]))
    if want_hist:
        _record(hist, 0, L, ist, r, v, val_a, n)
    duration = t_end
    done = False
    beta_prev = beta0
    for step in range(nsteps):
        if step < N - 1:
            alpha = ag[step]
            beta = (ag[step + 1] - ag[step]) / dt
        else:
            alpha = 0.0
            beta = 0.0
        t0 = step * dt
        tau = 0.0
        ev_here = 0
        # the rates of the absolute accelerations jump with the slope of the record:
        # d(rate)/d(beta) = 1 - row . M^-1 G (values and other rates are continuous)
        if step > 0:
            dbeta = beta - beta_prev
            for t in range(N_DISP, N_TRACK):
                der_a[t] += dbeta * (1.0 - _rowdot(TR, t, MG))
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
            if full:
                _propagate(E, PV, r, v, a0, beta, rb, vb, n)
            else:
                m_taylor = _taylor(MK, MC, MR, MG, r, v, a0, beta, H, D, n)
                _sum_state(D, m_taylor, 1.0, H, rb, vb)
            _events_at(RT, KP, rb, vb, e_b, ed_b, n)
            # earliest event on [tau, tb]
            s_ev = 2.0
            k_ev = -1
            for k in range(ne if _may_fire(OPN, e_a, ed_a, e_b, ed_b) else 0):
                opening = kind[k] == EV_BASE_OPEN or kind[k] == EV_CRACK_OPEN
                crossing = e_a[k] > 0.0 and e_b[k] <= 0.0
                # started on (or just behind) zero moving inward, and ends at or behind
                # it again: it rose and fell back (after an impact, a merged impact)
                rebound = e_a[k] <= 0.0 and ed_a[k] > 0.0 and e_b[k] <= 0.0
                dip = False
                if opening:
                    # a tiny threshold (g_open) can be crossed and recrossed within a
                    # sub-step, with zero rate at the start (at rest): scan the series
                    dip = not crossing and e_a[k] > 0.0
                elif not crossing and e_a[k] > 0.0 and e_b[k] > 0.0 and ed_a[k] < 0.0 \
                        and ed_b[k] > 0.0 and min(e_a[k], e_b[k]) - (4.0 / 27.0) * H * (
                            ed_b[k] - ed_a[k]) < 0.25 * max(e_a[k], e_b[k]):
                    # (the Hermite cubic stays above min(ends) - 4/27 (|m0| + |m1|))
                    lo, hi, slo, shi = _hermite_ext(e_a[k], e_b[k], ed_a[k] * H, ed_b[k] * H)
                    dip = lo < 0.25 * max(e_a[k], e_b[k])
                if not (crossing or dip or rebound):
                    continue
                if m_taylor == 0:
                    m_taylor = _taylor(MK, MC, MR, MG, r, v, a0, beta, H, D, n)
                mc = _scalar_poly(rows, k, D, m_taylor, False, H, 0.0, 0.0, sig[k], kap[k],
                                  cf)
                s_lo = 0.0
                s_hi = 1.0
                if rebound:
                    s_lo = _positive_max(cf, mc)
                    if s_lo < 0.0 or s_lo >= s_ev:
                        continue
                if dip:
                    if opening and _lower_bound(cf, mc) > 0.0:
                        continue  # e(s) >= c0 - sum|c_j| > 0 on [0, 1]: no crossing
                    # the exact first point where e <= 0 on the sub-step, if any
                    s_hi = _first_nonpositive(cf, mc, ed_a[k] < 0.0 and not opening)
                    if s_hi > 1.0:
                        continue
                if s_hi > s_ev:
                    # only an earlier root matters: has e already crossed at s_ev?
                    if _peval(cf, mc, s_ev)[0] > 0.0:
                        continue
                    s_hi = s_ev
                tol = TIME_TOL / H if H > 1e3 * TIME_TOL else 1e-3
                if crossing and s_hi == 1.0:
                    guess = _hermite_root(e_a[k], e_b[k], ed_a[k] * H, ed_b[k] * H)
                else:
                    guess = 0.5 * (s_lo + s_hi)
                lo_, hi_ = _root(cf, mc, s_lo, s_hi, tol, guess)
                s_root = hi_  # the side where the event function has crossed
                if s_root < s_ev or k_ev < 0:
                    s_ev = s_root
                    k_ev = k
            if k_ev < 0:
                # no event: peaks over the sub-step, then advance
                _point(MK, MC, MR, MG, TR, rb, vb, alpha + beta * tb, beta, val_b, der_b, sacc,
                       sjerk, n)
                m_taylor = _peaks_over(TR, peaks, val_a, der_a, val_b, der_b, 1.0, m_taylor, D,
                                       cf, MK, MC, MR, MG, r, v, a0, beta, H, n)
                if m_taylor:
                    n_series += 1
                if ist[I_FAM] == 1:
                    fam1_time += H
                tau = tb
                for i in range(NP):
                    r[i] = rb[i]
                    v[i] = vb[i]
                for t in range(N_TRACK):
                    val_a[t] = val_b[t]
                    der_a[t] = der_b[t]
                for k in range(MAX_EV):
                    e_a[k] = e_b[k]
                    ed_a[k] = ed_b[k]
                if tb >= dt:
                    break
                continue
            # ---- an event at tau + s_ev*H ----
            n_series += 1
            if m_taylor == 0:
                m_taylor = _taylor(MK, MC, MR, MG, r, v, a0, beta, H, D, n)
            He = s_ev * H
            _sum_state(D, m_taylor, s_ev, H, rb, vb)
            te_loc = tau + He
            _point(MK, MC, MR, MG, TR, rb, vb, alpha + beta * te_loc, beta, val_b, der_b, sacc,
                   sjerk, n)
            if He > 0.0:
                # peaks on [tau, te], the one-sided values before the event included
                _peaks_over(TR, peaks, val_a, der_a, val_b, der_b, s_ev, m_taylor, D, cf, MK,
                            MC, MR, MG, r, v, a0, beta, H, n)
            if ist[I_FAM] == 1:
                fam1_time += He
            tau = te_loc
            for i in range(NP):
                r[i] = rb[i]
                v[i] = vb[i]
            # handle this event and every other one due at the same instant
            while k_ev >= 0:
                if n_events < evlog.shape[0]:
                    evlog[n_events, 0] = t0 + tau
                    evlog[n_events, 1] = kind[k_ev]
                    evlog[n_events, 2] = tgt[k_ev]
                n_events += 1
                ev_here += 1
                if ev_here > MAX_EVENTS_PER_STEP:
                    status = ST_EVENT_LIMIT
                    break
                code = handle_event(P, L, ist, kind[k_ev], tgt[k_ev], r, v, cor, law, window,
                                    alpha + beta * tau, MK, MC, MR, MG, Minv_fam, v_rest,
                                    counts)
                collapse_now = code != 0
                if code == 1:
                    peaks[TR_RL] = 1.0
                elif code == 2:
                    peaks[TR_RU] = 1.0
                if collapse_now:
                    status = ST_COLLAPSED
                    break
                # new piece
                TR = TRF[ist[I_FAM] - 1]
                mid = mode_index(ist[I_FAM], ist[I_BL], ist[I_BU])
                ne = active_events(P, L, ist, g_open, rows, sig, kap, kind, tgt)
                _event_table(rows, sig, kap, kind, ne, RT, KP, OPN)
                MK, MC, MR, MG, E, PV = _mode_tables(mats, vecs, prop, pvec, mid)
                _point(MK, MC, MR, MG, TR, r, v, alpha + beta * tau, beta, val_a, der_a, sacc,
                       sjerk, n)
                for t in range(N_TRACK):  # the one-sided values after the event
                    peaks[t] = max(peaks[t], abs(val_a[t]))
                _events_at(RT, KP, r, v, e_a, ed_a, n)
                # a boundary reached at the same instant and moving outward fires now
                k_ev = -1
                for k in range(ne):
                    if e_a[k] <= 0.0 and ed_a[k] < 0.0:
                        k_ev = k
                        break
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
            _point(MK, MC, MR, MG, TR, r, v, 0.0, 0.0, val_b, der_b, sacc, sjerk, n)
            for t in range(N_DISP, N_TRACK):
                peaks[t] = max(peaks[t], abs(val_b[t]))
        if want_hist:
            a_grid = ag[step + 1] if step + 1 < N else 0.0
            b_grid = 0.0
            _point(MK, MC, MR, MG, TR, r, v, a_grid, b_grid, val_b, der_b, sacc, sjerk, n)
            _record(hist, step + 1, L, ist, r, v, val_b, n)
    if status == ST_COLLAPSED:
        peaks[TR_RL] = min(peaks[TR_RL], 1.0)
        peaks[TR_RU] = min(peaks[TR_RU], 1.0)
    outs[O_FAM1_TIME] = fam1_time
    outs[O_DURATION] = duration
    outs[O_BASE_IMP] = counts[0]
    outs[O_CRACK_IMP] = counts[1]
    outs[O_EVENTS] = n_events
    outs[O_SUBSTEPS] = n_sub
    outs[O_SERIES] = n_series
    return status


@njit(cache=True, _nrt=False, error_model="numpy")
def _record(hist, k, L, ist, r, v, val, n):
    hist[k, 0] = _rowdot(L, ROW_T1, r)
    hist[k, 1] = _rowdot(L, ROW_T2, r)
    hist[k, 2] = val[TR_UB]
    hist[k, 3] = val[TR_UC]
    hist[k, 4] = val[TR_UT]
    hist[k, 5] = val[TR_AB]
    hist[k, 6] = val[TR_AC]
    hist[k, 7] = val[TR_AT]
    hist[k, 8] = ist[I_FAM] * 10 + (1 if ist[I_S] > 0 else 2)
    for i in range(n):
        hist[k, 9 + i] = r[i]
        hist[k, 9 + n + i] = v[i]


@njit(cache=True, _nrt=False, error_model="numpy", inline='always')
def _peaks_over(TR, peaks, val_a, der_a, val_b, der_b, s_end, m_taylor, D, cf, MK, MC, MR,
                MG, r, v, a0, beta, H, n):
    """Peak update over [0, s_end*H] of a sub-step of length H from the end values and
    rates; interior extrema that may beat the running peak are located on the exact
    series about the sub-step start (computed here if m_taylor is 0)."""
    Hs = s_end * H
    for t in range(N_TRACK):
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
        lo_, hi_ = _solve(cf, mc, 0.0, s_end, 1e-13, guess)
        x = abs(_peval(cf, mc, 0.5 * (lo_ + hi_))[0])
        if x > peaks[t]:
            peaks[t] = x
    return m_taylor


# ---- the Python entry point -------------------------------------------------------------

_TABLES: OrderedDict = OrderedDict()
_TABLES_MAX = 128


def _tables(wall: Wall, dt: float):
    """Mode tables of a wall at a record step, filled lazily by the kernel and kept for
    the next analysis of the same wall (studies run each wall many times)."""
    key = (wall.params.tobytes(), float(dt))
    tab = _TABLES.get(key)
    if tab is None:
        tab = (np.zeros(NMODES, np.bool_), np.zeros(NMODES, np.int64),
               np.zeros((NMODES, 2, NP, NP)), np.zeros((NMODES, 2, NP)),
               np.zeros((NMODES, 2 * NP, 2 * NP)), np.zeros((NMODES, 3, 2 * NP)))
        _TABLES[key] = tab
        if len(_TABLES) > _TABLES_MAX:
            _TABLES.popitem(last=False)
    else:
        _TABLES.move_to_end(key)
    return tab


def warm_up() -> None:
    """Compile the kernel (or load it from numba's on-disk cache) with a tiny analysis.

    Called before local worker processes start, so that they load the compiled kernel
    from the cache instead of each compiling it on the same cores."""
    wall = Wall(0.2, 2.0, 0.5, 100.0, top_mass=10.0, top_stiffness=1e5)
    run(wall, np.array([0.0, 1.0, 0.0]), 0.01, impact="contact")


def clear_cache() -> None:
    """Forget the cached mode tables (benchmarks measure cold runs with it)."""
    _TABLES.clear()


def check_inputs(wall, ground_acceleration, dt, scale, cor, impact, tail, window=WINDOW):
    """Validate the arguments shared by every solver; returns (ag, dt, ntail, law)."""
    if not isinstance(wall, Wall):
        raise ValueError(f"wall must be a urmx.Wall, not {type(wall).__name__}")
    try:
        dt = float(dt)
    except (TypeError, ValueError):
        raise ValueError(f"dt={dt!r} must be a number of seconds") from None
    if not (math.isfinite(dt) and dt > 0.0):
        raise ValueError(f"dt={dt!r} must be a positive, finite time step in seconds")
    ag = np.asarray(ground_acceleration, dtype=float)
    if ag.ndim != 1 or ag.size < 2:
        raise ValueError(f"ground_acceleration must be a 1-D array of at least 2 samples "
                         f"(got shape {ag.shape})")
    if not np.isfinite(ag).all():
        bad = ~np.isfinite(ag)
        i = int(np.flatnonzero(bad)[0])
        raise ValueError(f"ground_acceleration has {int(bad.sum())} NaN/inf sample(s), the "
                         f"first at index {i} (t = {i * dt:g} s)")
    try:
        scale = float(scale)
    except (TypeError, ValueError):
        raise ValueError(f"scale={scale!r} must be a number") from None
    if not math.isfinite(scale):
        raise ValueError(f"scale={scale!r} must be finite")
    try:
        cor = float(cor)
    except (TypeError, ValueError):
        raise ValueError(f"cor={cor!r} must be a number in (0, 1]") from None
    if not (0.0 < cor <= 1.0):
        raise ValueError(f"cor={cor!r} must lie in (0, 1] (coefficient of restitution)")
    if impact not in LAWS:
        raise ValueError(f"impact={impact!r} is not an impact law; use one of "
                         f"{', '.join(map(repr, LAWS))}")
    try:
        tail = float(tail)
    except (TypeError, ValueError):
        raise ValueError(f"tail={tail!r} must be a duration in seconds") from None
    if not (math.isfinite(tail) and tail >= 0.0):
        raise ValueError(f"tail={tail!r} must be a non-negative duration in seconds")
    window = float(window)
    if not (math.isfinite(window) and 0.0 < window < dt):
        raise ValueError(f"window={window!r} must lie in (0, dt)")
    ntail = int(round(tail / dt))
    return ag * scale, dt, ntail, LAWS[impact]


def _scalars(peaks, outs, status):
    """The result dict of one analysis (shared by both solvers)."""
    pk = peaks.tolist()  # Python floats in one call (this runs once per analysis)
    out = outs.tolist()
    duration = out[O_DURATION]
    res = {
        "peak_crack_displacement": pk[TR_UC],
        "peak_top_displacement": pk[TR_UT],
        "peak_base_displacement": pk[TR_UB],
        "peak_lower_drift": pk[TR_D1],
        "peak_upper_drift": pk[TR_D2],
        "peak_top_acceleration": pk[TR_AT],
        "peak_crack_acceleration": pk[TR_AC],
        "peak_base_acceleration": pk[TR_AB],
        "instability_ratio_lower": pk[TR_RL],
        "instability_ratio_upper": pk[TR_RU],
        "instability_ratio": max(pk[TR_RL], pk[TR_RU]),
        "collapsed": int(status == ST_COLLAPSED),
        "collapse_time": out[O_COLLAPSE_T],
        "unfavourable_fraction": out[O_FAM1_TIME] / duration if duration > 0 else 0.0,
        "base_impacts": int(out[O_BASE_IMP]),
        "crack_impacts": int(out[O_CRACK_IMP]),
        "status": STATUS[status],
        "duration": duration,
        "events": int(out[O_EVENTS]),
        "substeps": int(out[O_SUBSTEPS]),
        "series": int(out[O_SERIES]),
    }
    return res


_NO_HIST = np.full((1, 9 + 2 * NP), np.nan)
_NO_LOG = np.zeros((0, 3))


def run(wall: Wall, ground_acceleration, dt: float, *, scale: float = 1.0, cor: float = 0.8,
        impact: str = "scale", tail: float = 0.0, window: float = WINDOW,
        history: bool = False, max_log: int = 0) -> dict:
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
    history : bool
        Also return the histories on the record grid under ``"history"``.

    Returns
    -------
    dict
        The scalars of ``urmx.variables.SCALARS`` as floats/ints, ``status`` ("ok",
        "collapsed" or "event-limit"), ``duration`` (analysed, s) and ``events``.
    """
    ag, dt, ntail, law = check_inputs(wall, ground_acceleration, dt, scale, cor, impact, tail,
                                      window)
    P = wall.params
    n = int(n_dof(P))
    N = ag.size
    ready, nsub, mats, vecs, prop, pvec = _tables(wall, dt)
    peaks = np.zeros(N_TRACK)
    outs = np.zeros(N_OUT)
    # without history or a log the kernel never writes them: shared placeholders
    hist = np.full((N + ntail, 9 + 2 * n), np.nan) if history else _NO_HIST
    evlog = np.zeros((max_log, 3)) if max_log else _NO_LOG
    status = _integrate(P, ag, dt, ntail, float(cor), law, float(window), ready, nsub, mats,
                        vecs, prop, pvec, peaks, outs, hist, bool(history), evlog)
    res = _scalars(peaks, outs, status)
    if history:
        res["history"] = history_dict(hist, dt, n)
    if max_log:
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
