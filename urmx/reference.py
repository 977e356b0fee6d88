"""The accuracy yardstick: a plain scipy ``solve_ivp`` integration of the same model.

Obviously-correct rather than fast: every record step is integrated separately (so the
kinks of the piecewise-linear ground motion are never inside an integration step), each
piece uses the smooth continuation of its branch (MODEL.md section 11), and the state at
an event is obtained by a fresh integration *to* the event time, not from the interpolant.
Events and the interior extrema of the peak outputs are found on ``solve_ivp``'s dense
output, sampled at SAMPLES points in every solver step and, after a piece's start, at
GEOMETRIC points approaching it geometrically: the first fall of an event function
through zero after it has been positive (a function at zero after an event, an impact or
a release, may come back at once, and an even number of crossings inside one step leaves
the signs at its ends alike), and every change of sign of a peak output's rate, each
located by brentq on the dense output. What an event does is decided by the same
functions as in the exact kernel (:func:`urmx.kernel.loop.handle_event`,
:func:`urmx.kernel.loop.active_events`, compiled with Python wrappers as ``*_py``), on the same
piece matrices (:func:`urmx.kernel.tables`), so the two solvers differ only in how they
integrate and search.
"""

from __future__ import annotations

from functools import partial

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

from . import kernel
from .errors import InputError
from .kernel import loop as K

#: samples of the dense output per solver step, and geometric ones after a piece's start
SAMPLES, GEOMETRIC = 16, 40
_EPS = np.finfo(float).eps


def _rhs(MK, MC, MR, MG, alpha, beta, n):
    """First-order right-hand side of one piece, x' = A x + c0 + c1 t for x = [r, r_d], the
    ground linear in the step's time."""
    A = np.zeros((2 * n, 2 * n))
    A[:n, n:] = np.eye(n)
    A[n:, :n] = -MK
    A[n:, n:] = -MC
    c0 = np.concatenate([np.zeros(n), -MR - MG * alpha])
    c1 = np.concatenate([np.zeros(n), -MG * beta])

    def rhs(t, x):
        return A @ x + (c0 + c1 * t)
    return rhs


def _samples(ts, tau):
    """Sample times of a piece solved on the steps ts (ts[0] = tau): tau, GEOMETRIC points
    approaching tau geometrically (down to 2^-GEOMETRIC of the first step) and SAMPLES
    even points in every step, increasing."""
    geo = tau + (ts[1] - tau) * 2.0 ** -np.arange(GEOMETRIC, 0, -1)
    frac = np.arange(1, SAMPLES + 1) / SAMPLES
    even = (ts[:-1, None] + (ts[1:] - ts[:-1])[:, None] * frac[None, :]).ravel()
    t = np.concatenate([[tau], geo, even])
    return t[np.r_[True, np.diff(t) > 0.0]]


def _at(tt, sol, n, mode, TR, ev, alpha, beta, X=None):
    """Event functions, peak outputs and the outputs' rates at the times tt, on the dense
    output of a piece (mode: its matrices; TR: tracker rows; ev: event rows, rate rows,
    ground coefficients, signs and offsets; the ground alpha + beta t; X: the states at tt
    if known)."""
    MK, MC, MR, MG = mode
    S, Vr, Ag, Sg, Kp = ev
    X = sol.sol(tt) if X is None else X
    R, V = X[:n], X[n:2 * n]
    a = alpha + beta * tt
    acc = -MK @ R - MC @ V - MR[:, None] - MG[:, None] * a[None, :]
    jerk = -MK @ V - MC @ acc - MG[:, None] * beta
    E = Sg[:, None] * (S @ R + Vr @ V + Ag[:, None] * a[None, :]) + Kp[:, None]
    val = np.concatenate([TR[:K.N_DISP] @ R, TR[K.N_DISP:] @ acc + a])
    der = np.concatenate([TR[:K.N_DISP] @ V, TR[K.N_DISP:] @ jerk + beta])
    return E, val, der


def _root(f, a, b):
    """brentq at the tolerance solve_ivp uses for its events."""
    return brentq(f, a, b, xtol=4 * _EPS, rtol=4 * _EPS)


def _noise(t, X, sol, n, ev, alpha, beta):
    """Round-off of the event functions at the sample times t (states X) on the dense
    output: of their terms there, and of the interpolant, which adds the step's increment
    of each coordinate to its start and subtracts it again (about eps times the
    increment)."""
    S, Vr, Ag, Sg, Kp = ev
    k = np.clip(np.searchsorted(sol.t, t, side="right") - 1, 0, sol.t.size - 2)
    inc = np.abs(np.diff(sol.y, axis=1))[:, k]
    terms = np.abs(S) @ np.abs(X[:n]) + np.abs(Vr) @ np.abs(X[n:2 * n]) \
        + np.abs(Ag)[:, None] * np.abs(alpha + beta * t)[None, :] + np.abs(Kp)[:, None]
    return 4.0 * _EPS * terms + 16.0 * _EPS * (np.abs(S) @ inc[:n] + np.abs(Vr) @ inc[n:2 * n])


def _first_event(t, E, z, e0, ed0, at, tie):
    """The first event of a piece: the earliest time in (t[0], t[-1]] at which an event
    function falls through zero after having been positive, and its index; (None, -1) when
    none does. E: the functions at the sample times t; `at`: :func:`_at` of the piece;
    ``tie(a, b)``: whether function b is taken before a when both are due at once.

    A function counts as positive once it exceeds `z` (its round-off at each sample,
    :func:`_noise`), or at the start when it is above zero and falling (it is due at
    once); its fall is then located between the samples around it."""
    up = E > z
    up[:, 0] |= (e0 > 0.0) & (ed0 < 0.0)
    armed = np.maximum.accumulate(up, axis=1)
    fall = np.zeros_like(up)
    fall[:, 1:] = armed[:, :-1] & (E[:, 1:] <= 0.0)
    best, k_best = None, -1
    for k in np.flatnonzero(fall.any(axis=1)):
        i = int(np.argmax(fall[k]))
        if best is not None and t[i - 1] >= best:
            continue
        root = _root(lambda x, k=k: at(np.array([x]))[0][k, 0], t[i - 1], t[i])
        if best is None or root < best or (root == best and tie(k_best, int(k))):
            best, k_best = root, int(k)
    return best, k_best


def _extrema(t, val, der, peaks, at):
    """Peaks over the interior extrema of the outputs sampled at times t (values val, rates
    der, outputs x times): each change of sign of a rate is located by brentq on the dense
    output (`at`: :func:`_at` of the piece) and the value there raises the peak, unless the
    bound of the cubic between the two samples, max(|p0|, |p1|) + (t1 - t0)/4 (|d0| + |d1|),
    cannot."""
    np.maximum(peaks, np.abs(val).max(axis=1), out=peaks)
    change = der[:, :-1] * der[:, 1:] < 0.0
    bound = np.maximum(np.abs(val[:, :-1]), np.abs(val[:, 1:])) + 0.25 * np.diff(t)[None, :] \
        * (np.abs(der[:, :-1]) + np.abs(der[:, 1:]))
    for i, j in zip(*np.nonzero(change & (bound > peaks[:, None])), strict=True):
        x = _root(lambda x, i=i: at(np.array([x]))[2][i, 0], t[j], t[j + 1])
        peaks[i] = max(peaks[i], abs(at(np.array([x]))[1][i, 0]))


def run(wall, ground_acceleration, dt, *, scale=1.0, cor=0.8, impact="scale", tail=0.0,
        window=K.WINDOW, t_rest=kernel.T_REST, rtol=1e-10, atol=None, method="DOP853",
        max_step=None, history=False) -> dict:
    """One analysis with scipy's ``solve_ivp`` (same outputs as :func:`urmx.kernel.run`).

    Parameters
    ----------
    t_rest : float
        ``v_rest = g_open/t_rest``, as in :func:`urmx.kernel.run`. [s]
    rtol : float
        Relative tolerance of ``solve_ivp``. [1]
    atol : float, optional
        Absolute tolerance; default ``rtol * 1e-3 * theta_a`` of Case 2 on rotations.
    method : {"DOP853", "Radau", "RK45", "LSODA"}
        The ``solve_ivp`` method.
    max_step : float, optional
        Largest solver step; default ``dt/8`` (with SAMPLES samples a step, events and
        extrema are searched at least every dt/128). [s]
    """
    ag, dt, ntail, law = kernel.check_inputs(wall, ground_acceleration, dt, scale, cor, impact,
                                        tail, window, t_rest)
    if not (rtol and 0.0 < float(rtol) < 1.0):
        raise InputError(f"rtol={rtol!r} must lie in (0, 1)")
    if atol is None:
        atol = rtol * 1e-3 * wall.segment(2).theta_a
    solver = dict(method=method, rtol=rtol, atol=atol,
                  max_step=dt / 8.0 if max_step is None else float(max_step))
    return _Analysis(wall, ag, dt, ntail, history, solver, t_rest=float(t_rest),
                     cor=float(cor), law=law, window=float(window)).run()


def _tracker_values(mode, TR, r, v, a, b):
    """(values, rates) of the tracked outputs at state (r, v) under ground acceleration
    `a` and its rate `b`."""
    MK, MC, MR, MG = mode
    acc = -MK @ r - MC @ v - MR - MG * a
    jerk = -MK @ v - MC @ acc - MG * b
    val = np.concatenate([TR[:K.N_DISP] @ r, TR[K.N_DISP:] @ acc + a])
    der = np.concatenate([TR[:K.N_DISP] @ v, TR[K.N_DISP:] @ jerk + b])
    return val, der


class _Analysis:
    """One analysis in progress: the wall's piece tables, the state (``r``, ``v``) of the
    current piece, its event rows, the counts, peaks and history as they grow, and how it
    ends (``status``)."""

    def __init__(self, wall, ag, dt, ntail, history, solver, *, t_rest, cor, law, window):
        self.tab = tab = kernel.tables(wall, dt)
        self.GL, self.GN, self.GX, self.GMI, self.GROT, self.GNN, self.GTR = tab.geo
        self.ag, self.dt, self.N, self.history, self.solver = ag, dt, ag.size, history, solver
        self.nsteps = self.N - 1 + ntail
        self.g_open = K.G_OPEN_FACTOR * wall.segment(2).theta_a
        self.v_rest = self.g_open / t_rest
        self.cor, self.law, self.window = cor, law, window
        self.rows = np.zeros((K.MAX_EV, K.NP))
        self.vrows = np.zeros((K.MAX_EV, K.NP))
        self.agc = np.zeros(K.MAX_EV)
        self.sig = np.zeros(K.MAX_EV)
        self.kap = np.zeros(K.MAX_EV)
        self.kind = np.zeros(K.MAX_EV, np.int64)
        self.tgt = np.zeros(K.MAX_EV, np.int64)
        self.tmp = np.zeros(K.NP)
        self.ist = ist = np.zeros(K.N_IST, np.int64)
        nz = np.flatnonzero(ag)
        ist[K.I_S] = -1 if (nz.size and ag[nz[0]] > 0) else 1
        ist[K.I_C] = -ist[K.I_S]
        ist[K.I_FAM] = 2
        self.counts = np.zeros(3, np.int64)
        self.peaks = np.zeros(K.N_TRACK)
        self.status, self.collapse_time, self.collapse_segment = K.ST_OK, np.nan, 0
        self.fam1, self.events, self.log = 0.0, 0, []
        self.span, self.ev_here = -1, 0  # the event bound: events in one K.EVENT_SPAN
        self.hist = np.full((self.N + ntail if history else 1, 9 + 2 * tab.nfull), np.nan)

    def piece(self):
        """(n, mid, mode over y, padded mode, tracker rows, watch rows) of the piece."""
        tab, ist = self.tab, self.ist
        h = int(ist[K.I_H])
        mid = K.piece_index(h, ist[K.I_FAM], ist[K.I_BL], ist[K.I_BU], ist[K.I_BLA])
        if not tab.ready[mid]:
            tab.build([K.piece_key(mid)])
        n = int(self.GNN[h])
        padded = (tab.mats[mid, 0], tab.mats[mid, 1], tab.vecs[mid, 0], tab.vecs[mid, 1])
        mode = (padded[0][:n, :n], padded[1][:n, :n], padded[2][:n], padded[3][:n])
        return n, mid, mode, padded, self.GTR[h, ist[K.I_FAM] - 1][:, :n], self.GL[h]

    def bump(self, val):
        np.maximum(self.peaks, np.abs(val), out=self.peaks)

    def record(self, k, a):
        """Row `k` of the history: the state now under ground acceleration `a`."""
        n, mid, mode, padded, TR, L = self.piece()
        val, _ = _tracker_values(mode, TR, self.r, self.v, a, 0.0)
        K.record_row_py(self.hist, k, L, self.GN[self.ist[K.I_H]], self.ist, _pad(self.r),
                        _pad(self.v), val, self.tab.nfull)

    def active(self, L, mid):
        """The number of events active in the piece (their rows filled in)."""
        return K.active_events_py(self.tab.P, L, self.tab.rel[mid], self.ist, self.g_open,
                                  self.rows, self.vrows, self.agc, self.sig, self.kap,
                                  self.kind, self.tgt)

    def event_values(self, ne, n, r, v, a, b, mode):
        MK, MC, MR, MG = mode
        acc = -MK @ r - MC @ v - MR - MG * a
        rows, vrows, agc, sig = self.rows, self.vrows, self.agc, self.sig
        e = sig[:ne] * (rows[:ne, :n] @ r + vrows[:ne, :n] @ v + agc[:ne] * a) + self.kap[:ne]
        ed = sig[:ne] * (rows[:ne, :n] @ v + vrows[:ne, :n] @ acc + agc[:ne] * b)
        return e, ed

    def run(self) -> dict:
        ag, dt = self.ag, self.dt
        n, mid, mode, padded, TR, L = self.piece()
        self.r, self.v = np.zeros(n), np.zeros(n)
        val, _ = _tracker_values(mode, TR, self.r, self.v, ag[0], (ag[1] - ag[0]) / dt)
        self.bump(val)
        if self.history:
            self.record(0, ag[0])
        duration = self.nsteps * dt
        for step in range(self.nsteps):
            tau = self.step(step)
            if self.status != K.ST_OK:
                duration = step * dt + tau
                break
            if step == self.N - 2:
                n, mid, mode, padded, TR, L = self.piece()
                val, _ = _tracker_values(mode, TR, self.r, self.v, 0.0, 0.0)
                np.maximum(self.peaks[K.N_DISP:], np.abs(val[K.N_DISP:]),
                           out=self.peaks[K.N_DISP:])
            if self.history:
                self.record(step + 1, ag[step + 1] if step + 1 < self.N else 0.0)
        return self.result(duration)

    def step(self, step: int) -> float:
        """Integrate record step `step` piece by piece, each event met handled; returns how
        far into the step the analysis got (dt, unless it stopped). [s]"""
        ag, dt = self.ag, self.dt
        alpha, beta = ((ag[step], (ag[step + 1] - ag[step]) / dt) if step < self.N - 1
                       else (0., 0.))
        t0 = step * dt
        tau = 0.0
        while tau < dt and self.status == K.ST_OK:
            n, mid, mode, padded, TR, L = self.piece()
            MK, MC, MR, MG = mode
            ne = self.active(L, mid)
            rhs = _rhs(MK, MC, MR, MG, alpha, beta, n)
            x0 = np.concatenate([self.r, self.v])
            if n == 0:  # nothing moves (both joints held): events follow the ground alone
                x0 = np.zeros(1)

                def rhs(t, x):
                    return np.zeros(1)
            sol = solve_ivp(rhs, (tau, dt), x0, dense_output=True, **self.solver)
            ev = (self.rows[:ne, :n], self.vrows[:ne, :n], self.agc[:ne], self.sig[:ne],
                  self.kap[:ne])
            at = partial(_at, sol=sol, n=n, mode=mode, TR=TR, ev=ev, alpha=alpha, beta=beta)
            t_s = _samples(sol.t, tau)
            X = sol.sol(t_s)
            E, val, der = at(t_s, X=X)
            e0, ed0 = self.event_values(ne, n, self.r, self.v, alpha + beta * tau, beta, mode)
            z = _noise(t_s, X, sol, n, ev, alpha, beta)
            te, k_ev = _first_event(t_s, E, z, e0, ed0, at, lambda a, b: K.release_tie_py(
                self.ist, self.kind, self.tgt, a, b))
            # interior extrema of the outputs up to the end of this piece
            if te is not None:
                keep = t_s < te
                _, v_e, d_e = at(np.array([te]))
                t_s = np.append(t_s[keep], te)
                val = np.concatenate([val[:, keep], v_e], axis=1)
                der = np.concatenate([der[:, keep], d_e], axis=1)
            _extrema(t_s, val, der, self.peaks, at)
            if te is None:
                self.r, self.v = sol.y[:n, -1].copy(), sol.y[n:2 * n, -1].copy()
                if self.ist[K.I_FAM] == 1:
                    self.fam1 += dt - tau
                tau = dt
                val, _ = _tracker_values(mode, TR, self.r, self.v, alpha + beta * tau, beta)
                self.bump(val)
                break
            # step to the event (an interpolated state is less accurate)
            if te > tau and n:
                s2 = solve_ivp(rhs, (tau, te), x0, **self.solver)
                self.r, self.v = s2.y[:n, -1].copy(), s2.y[n:2 * n, -1].copy()
            if self.ist[K.I_FAM] == 1:
                self.fam1 += te - tau
            tau = te
            val, _ = _tracker_values(mode, TR, self.r, self.v, alpha + beta * tau, beta)
            self.bump(val)
            self.handle(k_ev, t0 + tau, alpha + beta * tau, beta, padded)
        return tau

    def handle(self, k_ev: int, t: float, a: float, b: float, padded) -> None:
        """The event `k_ev` at time `t` (ground acceleration `a`, its rate `b`) and any
        event it makes due at once, until none is, the event bound is passed or the wall
        collapses."""
        ist, kind, tgt = self.ist, self.kind, self.tgt
        while k_ev >= 0:
            self.log.append((t, kind[k_ev], tgt[k_ev]))
            self.events += 1
            sp = int(np.floor(t / K.EVENT_SPAN))
            if sp != self.span:
                self.span, self.ev_here = sp, 0
            self.ev_here += 1
            if self.ev_here > K.MAX_EVENTS:
                self.status = K.ST_EVENT_LIMIT
                break
            rp, vp = _pad(self.r), _pad(self.v)
            code = K.handle_event_py(self.tab.P, self.GL, self.GX, self.GMI, self.GROT, ist,
                                     kind[k_ev], tgt[k_ev], rp, vp, self.cor, self.law,
                                     self.window, a, *padded, self.v_rest, self.counts,
                                     self.tmp)
            self.log[-1] = (*self.log[-1], ist[K.I_FAM] * 10 + (1 if ist[K.I_S] > 0 else 2))
            if code:
                self.collapse_segment = code
                self.status = K.ST_COLLAPSED
                self.collapse_time = t
                break
            n, mid, mode, padded, TR, L = self.piece()
            self.r, self.v = rp[:n].copy(), vp[:n].copy()
            val, _ = _tracker_values(mode, TR, self.r, self.v, a, b)
            self.bump(val)
            ne = self.active(L, mid)
            e, ed = self.event_values(ne, n, self.r, self.v, a, b, mode)
            release = (kind[:ne] == K.EV_BASE_RELEASE) | (kind[:ne] == K.EV_CRACK_RELEASE)
            now = np.flatnonzero(np.where(release, (e < 0.0) | ((e == 0.0) & (ed < 0.0)),
                                          (e <= 0.0) & (ed < 0.0)))
            k_ev = int(now[0]) if now.size else -1
            for k in now[1:]:  # both sides of a held joint: the current family's
                if K.release_tie_py(ist, kind, tgt, k_ev, int(k)):
                    k_ev = int(k)

    def result(self, duration: float) -> dict:
        """The kernel's outputs (`urmx.kernel.scalars`), the history and the event log."""
        outs = np.zeros(K.N_OUT)
        outs[K.O_COLLAPSE_SEG] = self.collapse_segment
        outs[K.O_COLLAPSE_T] = self.collapse_time
        outs[K.O_FAM1_TIME] = self.fam1
        outs[K.O_DURATION] = duration
        outs[K.O_BASE_IMP], outs[K.O_CRACK_IMP], outs[K.O_HOLDS] = self.counts
        outs[K.O_EVENTS] = self.events
        res = kernel.scalars(self.peaks, outs, self.status, self.tab.P)
        if self.history:
            res["history"] = kernel.history_dict(self.hist, self.dt, self.tab.nfull)
        res["event_log"] = np.array([row + (0,) * (4 - len(row))
                                     for row in self.log]).reshape(-1, 4)
        return res


def _pad(x):
    """A vector padded with zeros to urmx.kernel.loop.NP coordinates."""
    out = np.zeros(K.NP)
    out[:x.size] = x
    return out
