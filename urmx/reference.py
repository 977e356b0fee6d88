"""The accuracy yardstick: a plain scipy ``solve_ivp`` integration of the same model.

Obviously-correct rather than fast: every record step is integrated separately (so the
kinks of the piecewise-linear ground motion are never inside an integration step), each
piece uses the smooth continuation of its branch (MODEL.md section 11), events are
found by ``solve_ivp``'s event location, and the state at an event is obtained by a
fresh integration *to* the event time, not from the interpolant. Interior extrema of
the peak outputs are events too (their rates crossing zero). What an event does is
decided by the same functions as in the exact kernel (:func:`urmx.kernel.handle_event`,
:func:`urmx.kernel.active_events`), so the two solvers differ only in how they integrate.
"""

from __future__ import annotations

import numpy as np
from scipy.integrate import solve_ivp

from . import kernel as K
from .model import n_dof, system


def _mode(P, ist, cache):
    """(M^-1 K, M^-1 C, M^-1 R0, M^-1 G) of the piece, and the same padded to
    urmx.kernel.NP coordinates for the shared numba event functions."""
    key = (int(ist[K.I_FAM]), int(ist[K.I_BL]), int(ist[K.I_BU]))
    if key not in cache:
        M, C, Kmat, R0, MinvG, Minv = system(P, *key)
        mode = (Minv @ Kmat, Minv @ C, Minv @ R0, MinvG)
        cache[key] = mode, tuple(_pad(x) for x in mode)
    return cache[key]


def _pad(x):
    """A vector or square matrix padded with zeros to urmx.kernel.NP coordinates."""
    out = np.zeros((K.NP,) * x.ndim)
    out[tuple(slice(0, s) for s in x.shape)] = x
    return out


def _rhs(MK, MC, MR, MG, alpha, beta, n):
    """First-order right-hand side of one piece, the ground linear in the step's time."""
    def rhs(t, x):
        rr, vv = x[:n], x[n:]
        return np.concatenate([vv, -MK @ rr - MC @ vv - MR - MG * (alpha + beta * t)])
    return rhs


def _event(row, sig, kap, n):
    """Terminal event e = sig*(row . r) + kap falling through zero (urmx.kernel's form)."""
    def ev(t, x):
        return sig * (row @ x[:n]) + kap
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
        raise ValueError(f"rtol={rtol!r} must lie in (0, 1)")
    P = wall.params
    n = int(n_dof(P))
    L = K.watch_rows(P)  # padded rows (the shared event functions use them)
    N = ag.size
    nsteps = N - 1 + ntail
    g_open = K.G_OPEN_FACTOR * wall.segment(2).theta_a
    v_rest = g_open / dt
    if atol is None:
        atol = rtol * 1e-3 * wall.segment(2).theta_a
    max_step = dt / 8.0 if max_step is None else float(max_step)
    cache: dict = {}
    Minv_fam = K.mass_inverses(P, law)
    TRp = np.zeros((K.N_TRACK, K.NP))
    TR = TRp[:, :n]  # a view: tracker_rows fills TRp
    rows = np.zeros((K.MAX_EV, K.NP))
    sig = np.zeros(K.MAX_EV)
    kap = np.zeros(K.MAX_EV)
    kind = np.zeros(K.MAX_EV, np.int64)
    tgt = np.zeros(K.MAX_EV, np.int64)
    ist = np.zeros(K.N_IST, np.int64)
    nz = np.flatnonzero(ag)
    ist[K.I_S] = -1 if (nz.size and ag[nz[0]] > 0) else 1
    ist[K.I_C] = -ist[K.I_S]
    ist[K.I_FAM] = 2
    counts = np.zeros(2, np.int64)
    peaks = np.zeros(K.N_TRACK)
    r = np.zeros(n)
    v = np.zeros(n)
    status = K.ST_OK
    collapse_time = np.nan
    fam1 = 0.0
    events = 0
    log = []
    hist = np.full((N + ntail if history else 1, 9 + 2 * n), np.nan)

    def tracker_values(mode, r, v, a, b):
        MK, MC, MR, MG = mode
        acc = -MK @ r - MC @ v - MR - MG * a
        jerk = -MK @ v - MC @ acc - MG * b
        val = np.concatenate([TR[:K.N_DISP] @ r, TR[K.N_DISP:] @ acc + a])
        der = np.concatenate([TR[:K.N_DISP] @ v, TR[K.N_DISP:] @ jerk + b])
        return val, der

    def bump(val):
        np.maximum(peaks, np.abs(val), out=peaks)

    K.tracker_rows(P, L, ist[K.I_FAM], TRp)
    mode, _ = _mode(P, ist, cache)
    b0 = (ag[1] - ag[0]) / dt
    val, _ = tracker_values(mode, r, v, ag[0], b0)
    bump(val)
    if history:
        K._record(hist, 0, L, ist, _pad(r), _pad(v), val, n)
    duration = nsteps * dt
    for step in range(nsteps):
        alpha, beta = (ag[step], (ag[step + 1] - ag[step]) / dt) if step < N - 1 else (0., 0.)
        t0 = step * dt
        tau = 0.0
        ev_here = 0
        while tau < dt and status == K.ST_OK:
            mode, padded = _mode(P, ist, cache)
            MK, MC, MR, MG = mode
            ne = K.active_events(P, L, ist, g_open, rows, sig, kap, kind, tgt)

            rhs = _rhs(MK, MC, MR, MG, alpha, beta, n)
            evfuns = [_event(rows[k, :n].copy(), sig[k], kap[k], n) for k in range(ne)]
            for t_ in range(K.N_TRACK):
                if TR[t_].any():
                    evfuns.append(_extremum(TR[t_].copy(), t_, mode, alpha, beta, n))
            x0 = np.concatenate([r, v])
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
                        val, _ = tracker_values(mode, ye[:n], ye[n:], alpha + beta * te, beta)
                        peaks[evfuns[k].tracker] = max(peaks[evfuns[k].tracker],
                                                       abs(val[evfuns[k].tracker]))
            hit = [k for k in range(ne) if sol.t_events[k].size]
            if not hit:
                r, v = sol.y[:n, -1].copy(), sol.y[n:, -1].copy()
                if ist[K.I_FAM] == 1:
                    fam1 += dt - tau
                tau = dt
                val, _ = tracker_values(mode, r, v, alpha + beta * tau, beta)
                bump(val)
                break
            k_ev = min(hit, key=lambda k: sol.t_events[k][0])
            te = float(sol.t_events[k_ev][0])
            # step to the event (an interpolated state is less accurate)
            if te > tau:
                s2 = solve_ivp(rhs, (tau, te), x0, method=method, rtol=rtol, atol=atol,
                               max_step=max_step)
                r, v = s2.y[:n, -1].copy(), s2.y[n:, -1].copy()
            if ist[K.I_FAM] == 1:
                fam1 += te - tau
            tau = te
            val, _ = tracker_values(mode, r, v, alpha + beta * tau, beta)
            bump(val)
            while k_ev >= 0:
                log.append((t0 + tau, kind[k_ev], tgt[k_ev]))
                events += 1
                ev_here += 1
                if ev_here > K.MAX_EVENTS_PER_STEP:
                    status = K.ST_EVENT_LIMIT
                    break
                rp, vp = _pad(r), _pad(v)
                code = K.handle_event(P, L, ist, kind[k_ev], tgt[k_ev], rp, vp, float(cor), law,
                                      float(window), alpha + beta * tau, *padded, Minv_fam,
                                      v_rest, counts)
                v = vp[:n].copy()
                if code:
                    peaks[K.TR_RL if code == 1 else K.TR_RU] = 1.0
                    status = K.ST_COLLAPSED
                    collapse_time = t0 + tau
                    break
                K.tracker_rows(P, L, ist[K.I_FAM], TRp)
                mode, padded = _mode(P, ist, cache)
                MK, MC, MR, MG = mode
                val, _ = tracker_values(mode, r, v, alpha + beta * tau, beta)
                bump(val)
                ne = K.active_events(P, L, ist, g_open, rows, sig, kap, kind, tgt)
                e = sig[:ne] * (rows[:ne, :n] @ r) + kap[:ne]
                ed = sig[:ne] * (rows[:ne, :n] @ v)
                now = np.flatnonzero((e <= 0.0) & (ed < 0.0))
                k_ev = int(now[0]) if now.size else -1
        if status != K.ST_OK:
            duration = t0 + tau
            break
        if step == N - 2:
            val, _ = tracker_values(_mode(P, ist, cache)[0], r, v, 0.0, 0.0)
            np.maximum(peaks[K.N_DISP:], np.abs(val[K.N_DISP:]), out=peaks[K.N_DISP:])
        if history:
            a_grid = ag[step + 1] if step + 1 < N else 0.0
            val, _ = tracker_values(_mode(P, ist, cache)[0], r, v, a_grid, 0.0)
            K._record(hist, step + 1, L, ist, _pad(r), _pad(v), val, n)
    if status == K.ST_COLLAPSED:
        peaks[K.TR_RL] = min(peaks[K.TR_RL], 1.0)
        peaks[K.TR_RU] = min(peaks[K.TR_RU], 1.0)
    outs = np.zeros(K.N_OUT)
    outs[K.O_COLLAPSE_T] = collapse_time
    outs[K.O_FAM1_TIME] = fam1
    outs[K.O_DURATION] = duration
    outs[K.O_BASE_IMP], outs[K.O_CRACK_IMP] = counts
    outs[K.O_EVENTS] = events
    res = K._scalars(peaks, outs, status)
    if history:
        res["history"] = K.history_dict(hist, dt, n)
    res["event_log"] = np.array(log).reshape(-1, 3)
    return res
