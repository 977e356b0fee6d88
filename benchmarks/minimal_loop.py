"""A minimal exact stepping loop: the bound the kernel's per-sample path is measured against
(issue 41, ``urmx bench kernel``).

It steps a wall at rest's piece over a record with the kernel's own exact propagator (the
``prop``/``pvec`` tables of :func:`urmx.kernel.tables`: state ``z = [y, y_d]`` after a
sub-step ``E z + PV[0] + a0 PV[1] + beta PV[2]``, ``a0`` the ground acceleration at the
sub-step's start and ``beta`` its slope), in three variants, each adding to the one before:

* ``mode 0``: the propagator alone;
* ``mode 1``: and the values and rates of 4 event functions (rows over y with an offset)
  and the kernel's sign test on them (a value at or below zero, or a rate turning upward);
* ``mode 2``: and the 9 peak trackers (the |value| maximum of each tracker row: the first
  6 on y, the last 3 on the absolute accelerations ``y_dd + xg_dd``).

This is not urmx code and no analysis uses it: it is a yardstick. Like the kernel's loop
it is specialised to the number of coordinates (2 or 3: the small loops have constant trip
counts that the compiler unrolls) and compiled with numba's numpy error model; it keeps
the state in small arrays as the kernel does. Loaded by the paired kernel benchmark's
worker processes by file path, so it runs beside either commit's kernel; compiled in each
process (a few seconds), not cached: numba's cache would be shared between the module's
names here and in the tests, and a worker cannot import the other name.
"""

from __future__ import annotations

import numpy as np
from numba import njit

NP = 3  # padded coordinates (the kernel's tables are padded to 3)
N_EV = 4  # event functions of the sign test
N_TRACK, N_DISP = 9, 6  # peak trackers: the first N_DISP on y, the rest on accelerations


@njit(inline="always", error_model="numpy")
def _steps(E, PV, ag, dt, RT, KP, TR, MK, MC, MR, MG, out, nn, mode):
    """Step the record (nn coordinates, a constant once inlined); returns the number of
    sub-steps the sign test flagged (kept so that the compiler cannot drop the test)."""
    r = np.zeros(NP)
    v = np.zeros(NP)
    rb = np.zeros(NP)
    vb = np.zeros(NP)
    acc = np.zeros(NP)
    ed_a = np.zeros(N_EV)
    peaks = np.zeros(N_TRACK)
    inv_dt = 1.0 / dt
    flagged = 0
    for step in range(ag.shape[0] - 1):
        a0 = ag[step]
        beta = (ag[step + 1] - a0) * inv_dt
        for i in range(nn):
            s1 = PV[0, i] + a0 * PV[1, i] + beta * PV[2, i]
            s2 = PV[0, NP + i] + a0 * PV[1, NP + i] + beta * PV[2, NP + i]
            for j in range(nn):
                s1 += E[i, j] * r[j] + E[i, NP + j] * v[j]
                s2 += E[NP + i, j] * r[j] + E[NP + i, NP + j] * v[j]
            rb[i] = s1
            vb[i] = s2
        for i in range(nn):
            r[i] = rb[i]
            v[i] = vb[i]
        if mode >= 1:
            flag = False
            for k in range(N_EV):
                e = KP[k]
                ed = 0.0
                for i in range(nn):
                    e += RT[i, k] * r[i]
                    ed += RT[i, k] * v[i]
                flag |= (e <= 0.0) | ((ed_a[k] < 0.0) & (ed > 0.0))
                ed_a[k] = ed
            flagged += flag
        if mode >= 2:
            a_end = ag[step + 1]
            for i in range(nn):
                x = -MR[i] - MG[i] * a_end
                for j in range(nn):
                    x -= MK[i, j] * r[j] + MC[i, j] * v[j]
                acc[i] = x
            for t in range(N_TRACK):
                x = a_end if t >= N_DISP else 0.0
                for i in range(nn):
                    x += TR[t, i] * (acc[i] if t >= N_DISP else r[i])
                peaks[t] = max(peaks[t], abs(x))
    for t in range(N_TRACK):
        out[t] = peaks[t]
    out[N_TRACK] = r[0]
    return flagged


@njit(error_model="numpy")
def minimal_loop(E, PV, ag, dt, RT, KP, TR, MK, MC, MR, MG, out, n, mode):
    """Step `ag` (scaled samples, step `dt`) with the propagator E, PV of a piece with `n`
    coordinates (2 or 3), `mode` 0, 1 or 2 (module docstring); writes the peaks and the
    final first coordinate into `out` (10 entries) and returns the flagged sub-steps."""
    if n == 2:
        if mode == 0:
            return _steps(E, PV, ag, dt, RT, KP, TR, MK, MC, MR, MG, out, 2, 0)
        if mode == 1:
            return _steps(E, PV, ag, dt, RT, KP, TR, MK, MC, MR, MG, out, 2, 1)
        return _steps(E, PV, ag, dt, RT, KP, TR, MK, MC, MR, MG, out, 2, 2)
    if mode == 0:
        return _steps(E, PV, ag, dt, RT, KP, TR, MK, MC, MR, MG, out, 3, 0)
    if mode == 1:
        return _steps(E, PV, ag, dt, RT, KP, TR, MK, MC, MR, MG, out, 3, 1)
    return _steps(E, PV, ag, dt, RT, KP, TR, MK, MC, MR, MG, out, 3, 2)


def inputs(wall, dt: float) -> dict:
    """The arrays of :func:`minimal_loop` for `wall` at record step `dt`, from the kernel's
    tables of the piece a wall at rest is in (no joint held, family 2, both segments on
    their first branch): its propagator, its matrices (for the accelerations), its tracker
    rows; as event functions the first 4 watch rows with offset 1 (the cost of the test
    does not depend on what the rows are). Also ``n``, the wall's coordinates."""
    from urmx.kernel import tables

    try:
        from urmx.kernel.loop import piece_index
    except ImportError:  # (the kernel as one module, before the package)
        from urmx.kernel import piece_index
    tab = tables(wall, dt)
    mid = piece_index(0, 2, 0, 0, 0)
    n = int(tab.geo[5][0])  # GNN: coordinates of the state with no joint held
    GL, GTR = tab.geo[0], tab.geo[6]
    return {"E": tab.prop[mid].copy(), "PV": tab.pvec[mid].copy(),
            "RT": np.ascontiguousarray(GL[0, :N_EV].T), "KP": np.ones(N_EV),
            "TR": GTR[0, 1].copy(), "MK": tab.mats[mid, 0].copy(),
            "MC": tab.mats[mid, 1].copy(), "MR": tab.vecs[mid, 0].copy(),
            "MG": tab.vecs[mid, 1].copy(), "n": n, "nsub": int(tab.nsub[mid])}
