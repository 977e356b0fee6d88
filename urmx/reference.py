"""The accuracy yardstick: a plain scipy ``solve_ivp`` integration of the same model.

Obviously-correct rather than fast: every record step is integrated separately (so the
kinks of the piecewise-linear ground motion are never inside an integration step), each
piece uses the smooth continuation of its branch (MODEL.md section 11), events are
found by ``solve_ivp``'s event location, and the state at an event is obtained by a
fresh integration *to* the event time, not from the interpolant. Interior extrema of
the peak outputs are events too (their rates crossing zero). What an event does is
decided by the same functions as in the exact kernel (:func:`urmx.kernel.handle_event`,
:func:`urmx.kernel.active_events`, compiled with Python wrappers as ``*_py``), on the same
piece matrices
(:func:`urmx.kernel.tables`), so the two solvers differ only in how they integrate.
"""

from __future__ import annotations

import numpy as np
from scipy.integrate import solve_ivp

from . import kernel as K
from .errors import InputError


def _rhs(MK, MC, MR, MG, alpha, beta, n):
    """First-order right-hand side of one piece, the ground linear in the step's time."""
    def rhs(t, x):
        rr, vv = x[:n], x[n:]
        return np.concatenate([vv, -MK @ rr - MC @ vv - MR - MG * (alpha + beta * t)])
    return rhs


def _event(row, vrow, agc, sig, kap, alpha, beta, n):
    """Terminal event e = sig*(row.y + vrow.y_d + agc*xg_dd) + kap falling through zero
    (urmx.kernel's form)."""
    def ev(t, x):
        return sig * (row @ x[:n] + vrow @ x[n:2 * n] + agc * (alpha + beta * t)) + kap
    ev.terminal = True
    ev.direction = -1
    return ev


def _extremum(row, tracker, mode, alpha, beta, n):
    """Non-terminal event at an interior extremum of a peak output (its rate is zero)."""
    MK, MC, MR, MG = mode
    if tracker < K.N_DISP:
        def ex(t, x):
            return row @ x[n:]
    else:
        def ex(t, x):
            rr, vv = x[:n], x[n:]
            acc = -MK @ rr - MC @ vv - MR - MG * (alpha + beta * t)
            return row @ (-MK @ vv - MC @ acc - MG * beta) + beta
    ex.terminal = False
    ex.direction = 0
    ex.tracker = tracker
    return ex


def run(wall, ground_acceleration, dt, *, scale=1.0, cor=0.8, impact="scale", tail=0.0,
        window=K.WINDOW, rtol=1e-10, atol=None, method="DOP853", max_step=None,
        history=False) -> dict:
    """One analysis with scipy's ``solve_ivp`` (same outputs as :func:`urmx.kernel.run`).

    Parameters
    ----------
    rtol : float
        Relative tolerance of ``solve_ivp``. [1]
    atol : float, optional
        Absolute tolerance; default ``rtol * 1e-3 * theta_a`` of Case 2 on rotations.
    method : {"DOP853", "Radau", "RK45", "LSODA"}
        The ``solve_ivp`` method.
    max_step : float, optional
        Largest solver step; default ``dt/8``. solve_ivp finds an event only where its
        function changes sign between step ends, so a shallow closure (a grazing impact)
        inside one long step would be missed. [s]
    """
    ag, dt, ntail, law = K.check_inputs(wall, ground_acceleration, dt, scale, cor, impact,
                                        tail, window)
    if not (rtol and 0.0 < float(rtol) < 1.0):
        raise InputError(f"rtol={rtol!r} must lie in (0, 1)")
    tab = K.tables(wall, dt)
    P = tab.P
    GL, GN, GX, GMI, GROT, GNN, GTR = tab.geo
    nfull = tab.nfull
    N = ag.size
    nsteps = N - 1 + ntail
    g_open = K.G_OPEN_FACTOR * wall.segment(2).theta_a
    v_rest = g_open / dt
    if atol is None:
        atol = rtol * 1e-3 * wall.segment(2).theta_a
    max_step = dt / 8.0 if max_step is None else float(max_step)
    rows = np.zeros((K.MAX_EV, K.NP))
    vrows = np.zeros((K.MAX_EV, K.NP))
    agc = np.zeros(K.MAX_EV)
    sig = np.zeros(K.MAX_EV)
    kap = np.zeros(K.MAX_EV)
    kind = np.zeros(K.MAX_EV, np.int64)
    tgt = np.zeros(K.MAX_EV, np.int64)
    tmp = np.zeros(K.NP)
    ist = np.zeros(K.N_IST, np.int64)
    nz = np.flatnonzero(ag)
    ist[K.I_S] = -1 if (nz.size and ag[nz[0]] > 0) else 1
    ist[K.I_C] = -ist[K.I_S]
    ist[K.I_FAM] = 2
    counts = np.zeros(3, np.int64)
    peaks = np.zeros(K.N_TRACK)
    status = K.ST_OK
    collapse_time = np.nan
    collapse_segment = 0
    fam1 = 0.0
    events = 0
    log = []
    hist = np.full((N + ntail if history else 1, 9 + 2 * nfull), np.nan)

    def piece():
        """(n, mid, mode over y, padded mode, tracker rows, watch rows) of the piece."""
        h = int(ist[K.I_H])
        mid = K.piece_index(h, ist[K.I_FAM], ist[K.I_BL], ist[K.I_BU], ist[K.I_BLA])
        if not tab.ready[mid]:
            tab.build([K.piece_key(mid)])
        n = int(GNN[h])
        padded = (tab.mats[mid, 0], tab.mats[mid, 1], tab.vecs[mid, 0], tab.vecs[mid, 1])
        mode = (padded[0][:n, :n], padded[1][:n, :n], padded[2][:n], padded[3][:n])
        return n, mid, mode, padded, GTR[h, ist[K.I_FAM] - 1][:, :n], GL[h]

    def tracker_values(mode, TR, r, v, a, b):
        MK, MC, MR, MG = mode
        acc = -MK @ r - MC @ v - MR - MG * a
        jerk = -MK @ v - MC @ acc - MG * b
        val = np.concatenate([TR[:K.N_DISP] @ r, TR[K.N_DISP:] @ acc + a])
        der = np.concatenate([TR[:K.N_DISP] @ v, TR[K.N_DISP:] @ jerk + b])
        return val, der

    def bump(val):
        np.maximum(peaks, np.abs(val), out=peaks)

    def record(k, r, v, a):
        n, mid, mode, padded, TR, L = piece()
        val, _ = tracker_values(mode, TR, r, v, a, 0.0)
        K.record_row_py(hist, k, L, GN[ist[K.I_H]], ist, _pad(r), _pad(v), val, nfull)

    def event_values(ne, n, r, v, a, b, mode):
        MK, MC, MR, MG = mode
        acc = -MK @ r - MC @ v - MR - MG * a
        e = sig[:ne] * (rows[:ne, :n] @ r + vrows[:ne, :n] @ v + agc[:ne] * a) + kap[:ne]
        ed = sig[:ne] * (rows[:ne, :n] @ v + vrows[:ne, :n] @ acc + agc[:ne] * b)
        return e, ed

    n, mid, mode, padded, TR, L = piece()
    r = np.zeros(n)
    v = np.zeros(n)
    b0 = (ag[1] - ag[0]) / dt
    val, _ = tracker_values(mode, TR, r, v, ag[0], b0)
    bump(val)
    if history:
        record(0, r, v, ag[0])
    duration = nsteps * dt
    for step in range(nsteps):
        alpha, beta = (ag[step], (ag[step + 1] - ag[step]) / dt) if step < N - 1 else (0., 0.)
        t0 = step * dt
        tau = 0.0
        ev_here = 0
        while tau < dt and status == K.ST_OK:
            n, mid, mode, padded, TR, L = piece()
            MK, MC, MR, MG = mode
            ne = K.active_events_py(P, L, tab.rel[mid], ist, g_open, rows, vrows, agc, sig, kap,
                                 kind, tgt)
            rhs = _rhs(MK, MC, MR, MG, alpha, beta, n)
            evfuns = [_event(rows[k, :n].copy(), vrows[k, :n].copy(), agc[k], sig[k], kap[k],
                             alpha, beta, n) for k in range(ne)]
            for t_ in range(K.N_TRACK):
                if TR[t_].any():
                    evfuns.append(_extremum(TR[t_].copy(), t_, mode, alpha, beta, n))
            x0 = np.concatenate([r, v])
            if n == 0:  # nothing moves (both joints held): events follow the ground alone
                x0 = np.zeros(1)

                def rhs(t, x):
                    return np.zeros(1)
            sol = solve_ivp(rhs, (tau, dt), x0, method=method, rtol=rtol, atol=atol,
                            events=evfuns, max_step=max_step)
            # interior extrema (non-terminal events) up to the end of this piece
            t_stop = sol.t[-1]
            for k in range(ne):
                if sol.t_events[k].size:
                    t_stop = min(t_stop, sol.t_events[k][0])
            for k in range(ne, len(evfuns)):
                for te, ye in zip(sol.t_events[k], sol.y_events[k], strict=True):
                    if te <= t_stop:
                        val, _ = tracker_values(mode, TR, ye[:n], ye[n:2 * n], alpha + beta * te,
                                                beta)
                        peaks[evfuns[k].tracker] = max(peaks[evfuns[k].tracker],
                                                       abs(val[evfuns[k].tracker]))
            hit = [k for k in range(ne) if sol.t_events[k].size]
            if not hit:
                r, v = sol.y[:n, -1].copy(), sol.y[n:2 * n, -1].copy()
                if ist[K.I_FAM] == 1:
                    fam1 += dt - tau
                tau = dt
                val, _ = tracker_values(mode, TR, r, v, alpha + beta * tau, beta)
                bump(val)
                break
            k_ev = min(hit, key=lambda k: sol.t_events[k][0])
            te = float(sol.t_events[k_ev][0])
            # step to the event (an interpolated state is less accurate)
            if te > tau and n:
                s2 = solve_ivp(rhs, (tau, te), x0, method=method, rtol=rtol, atol=atol,
                               max_step=max_step)
                r, v = s2.y[:n, -1].copy(), s2.y[n:2 * n, -1].copy()
            if ist[K.I_FAM] == 1:
                fam1 += te - tau
            tau = te
            val, _ = tracker_values(mode, TR, r, v, alpha + beta * tau, beta)
            bump(val)
            while k_ev >= 0:
                log.append((t0 + tau, kind[k_ev], tgt[k_ev]))
                events += 1
                ev_here += 1
                if ev_here > K.MAX_EVENTS_PER_STEP:
                    status = K.ST_EVENT_LIMIT
                    break
                rp, vp = _pad(r), _pad(v)
                code = K.handle_event_py(P, GL, GX, GMI, GROT, ist, kind[k_ev], tgt[k_ev], rp, vp,
                                      float(cor), law, float(window), alpha + beta * tau,
                                      *padded, v_rest, counts, tmp)
                log[-1] = (*log[-1], ist[K.I_FAM] * 10 + (1 if ist[K.I_S] > 0 else 2))
                if code:
                    collapse_segment = code
                    status = K.ST_COLLAPSED
                    collapse_time = t0 + tau
                    break
                n, mid, mode, padded, TR, L = piece()
                r, v = rp[:n].copy(), vp[:n].copy()
                val, _ = tracker_values(mode, TR, r, v, alpha + beta * tau, beta)
                bump(val)
                ne = K.active_events_py(P, L, tab.rel[mid], ist, g_open, rows, vrows, agc, sig,
                                     kap, kind, tgt)
                e, ed = event_values(ne, n, r, v, alpha + beta * tau, beta, mode)
                release = (kind[:ne] == K.EV_BASE_RELEASE) | (kind[:ne] == K.EV_CRACK_RELEASE)
                now = np.flatnonzero(np.where(release, (e < 0.0) | ((e == 0.0) & (ed < 0.0)),
                                              (e <= 0.0) & (ed < 0.0)))
                k_ev = int(now[0]) if now.size else -1
        if status != K.ST_OK:
            duration = t0 + tau
            break
        if step == N - 2:
            n, mid, mode, padded, TR, L = piece()
            val, _ = tracker_values(mode, TR, r, v, 0.0, 0.0)
            np.maximum(peaks[K.N_DISP:], np.abs(val[K.N_DISP:]), out=peaks[K.N_DISP:])
        if history:
            record(step + 1, r, v, ag[step + 1] if step + 1 < N else 0.0)
    outs = np.zeros(K.N_OUT)
    outs[K.O_COLLAPSE_SEG] = collapse_segment
    outs[K.O_COLLAPSE_T] = collapse_time
    outs[K.O_FAM1_TIME] = fam1
    outs[K.O_DURATION] = duration
    outs[K.O_BASE_IMP], outs[K.O_CRACK_IMP], outs[K.O_HOLDS] = counts
    outs[K.O_EVENTS] = events
    res = K.scalars(peaks, outs, status, P)
    if history:
        res["history"] = K.history_dict(hist, dt, nfull)
    res["event_log"] = np.array([row + (0,) * (4 - len(row)) for row in log]).reshape(-1, 4)
    return res


def _pad(x):
    """A vector padded with zeros to urmx.kernel.NP coordinates."""
    out = np.zeros(K.NP)
    out[:x.size] = x
    return out
