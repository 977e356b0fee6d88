"""The kernel's host-side arrays (numpy): the held-state geometry and the piece tables of
one wall at one record step (modes, exact propagators, release rows), kept in a cache for
the next analysis of the same wall and step (:func:`tables`)."""

from __future__ import annotations

import math
from collections import OrderedDict

import numpy as np

from .. import native
from ..errors import InputError
from ..model import (
    HELD_BASE,
    HELD_BOTH,
    HELD_CRACK,
    HELD_NONE,
    P_A1,
    P_A2,
    P_CASE,
    P_CB,
    P_CT,
    P_KDB,
    P_KDT,
    P_M1,
    P_M2,
    P_MDB,
    P_MDT,
    P_RIGID_B,
    P_RIGID_T,
    Wall,
    branch_coeffs,
    full_mass,
    held_map,
    n_dof,
    transform,
)
from .loop import (
    ARRAYS,
    KMAX,
    LOOP,
    MAX_EV,
    MAX_SUBSTEPS,
    N_IST,
    N_OUT,
    N_TRACK,
    NP,
    NPIECE,
    REL_W,
    RHO,
    ROW_GC,
    ROW_T1,
    ROW_T2,
    ROW_UB,
    ROW_UC,
    ROW_UT,
    piece_index,
)

# placeholders of the arrays an analysis writes only when asked to
NO_HIST = np.full((1, 9 + 2 * NP), np.nan)
NO_LOG = np.zeros((0, 4))
NO_RECORD = np.zeros(1)  # the record's slot until an analysis writes its own


# ---- tables (numpy): held-state geometry and piece modes ---------------------------------

def _pad(x: np.ndarray, shape: tuple[int, ...]) -> np.ndarray:
    out = np.zeros(shape)
    out[tuple(slice(0, s) for s in x.shape)] = x
    return out


def watch_rows(P: np.ndarray, held: int = HELD_NONE) -> np.ndarray:
    """Rows over the padded coordinates y of a held state of theta1, theta2, u_b, u_c, u_t,
    g_crack. Outputs fixed by a constraint get exactly zero rows (MODEL.md section 6)."""
    a1, a2 = P[P_A1], P[P_A2]
    Lq = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [a1, 0.0, 1.0],
                   [a1, a2, 1.0], [-1.0, 1.0, 0.0]])
    L = _pad(Lq @ transform(P, held), (6, NP))
    if P[P_RIGID_B] > 0.5:
        L[ROW_UB, :] = 0.0
    if P[P_RIGID_T] > 0.5:
        L[ROW_UT, :] = 0.0
    return L


def theta0(P: np.ndarray, case: int) -> float:
    return float(P[P_CASE + 5 * (case - 1) + 1])


def tracker_rows(P: np.ndarray, L: np.ndarray, fam: int) -> np.ndarray:
    """Rows of the nine peak trackers in a family (the lower drift by its family)."""
    d1, d2 = P[P_A1] * L[ROW_T1], P[P_A2] * L[ROW_T2]
    zero = np.zeros_like(d1)
    return np.array([L[ROW_UB], L[ROW_UC], L[ROW_UT], d1 if fam == 1 else zero,
                     zero if fam == 1 else d1, d2, L[ROW_UB], L[ROW_UC], L[ROW_UT]])


def geometry(P: np.ndarray) -> tuple:
    """Per held state h (none, base, crack, both): watch rows GL, the map GN from its
    coordinates y to the support-reduced r, the maps GX[h, h'] between held states, the
    inverse reduced masses GMI per family, the rotation masks GROT (the scale law), the
    number of coordinates GNN and the tracker rows GTR per family."""
    n = n_dof(P)
    GL = np.zeros((4, 6, NP))
    GN = np.zeros((4, NP, NP))
    GS = np.zeros((4, NP, NP))
    GMI = np.zeros((4, 2, NP, NP))
    GROT = np.zeros((4, NP))
    GNN = np.zeros(4, np.int64)
    GTR = np.zeros((4, 2, N_TRACK, NP))
    free_ub = P[P_RIGID_B] < 0.5 and P[P_RIGID_T] < 0.5
    for h in range(4):
        T = transform(P, h)
        ny = T.shape[1]
        N = held_map(P, h)
        GNN[h] = ny
        GL[h] = watch_rows(P, h)
        GN[h, :n, :ny] = N
        GS[h, :ny, :n] = np.linalg.pinv(N) if ny else np.zeros((0, n))
        GROT[h, :ny - (1 if free_ub else 0)] = 1.0
        for fam in (1, 2):
            if ny:
                GMI[h, fam - 1, :ny, :ny] = np.linalg.inv(T.T @ full_mass(P, fam) @ T)
            GTR[h, fam - 1] = tracker_rows(P, GL[h], fam)
    GX = np.einsum("bij,ajk->abik", GS, GN)
    return (GL, GN, GX, GMI, GROT, GNN, GTR)


def _branch(P: np.ndarray, case: int, theta: float) -> int:
    """Signed branch of theta on a curve (theta not on a boundary)."""
    ta, tb = P[P_CASE + 5 * (case - 1) + 3], P[P_CASE + 5 * (case - 1) + 4]
    a = abs(theta)
    s = 1 if theta > 0 else -1
    return 0 if a < ta else (s if a < tb else 2 * s)


def _reachable(P: np.ndarray) -> list[tuple[int, int, int, int, int]]:
    """The pieces a wall can reach: every (family, lower, upper) branch pair with no joint
    held; a held base joint (theta1 = 0) with every upper branch; both held; and with a
    held crack joint (theta2 = theta1) the branch triples met along theta1."""
    if n_dof(P) == 1:  # both supports rigid: one coordinate, held or not
        holds = [HELD_NONE, HELD_BOTH]
    else:
        holds = [HELD_NONE, HELD_BASE, HELD_CRACK, HELD_BOTH]
    keys = []
    for h in holds:
        for fam in (1, 2):
            if h == HELD_NONE:
                keys += [(h, fam, bl, bu, 0) for bl in range(-2, 3) for bu in range(-2, 3)]
            elif h == HELD_BASE:
                keys += [(h, fam, 0, bu, 0) for bu in range(-2, 3)]
            elif h == HELD_BOTH:
                keys.append((h, fam, 0, 0, 0))
            else:
                cases = (3 if fam == 1 else 2, 1, 2 if fam == 1 else 3)
                bounds = sorted({s * P[P_CASE + 5 * (c - 1) + i] for c in cases
                                 for i in (3, 4) for s in (1.0, -1.0)})
                pts = [bounds[0] - 1.0, bounds[-1] + 1.0]
                pts += [0.5 * (a + b) for a, b in zip(bounds[:-1], bounds[1:], strict=True)]
                keys += [(h, fam, *(_branch(P, c, x) for c in cases)) for x in pts]
    return list(dict.fromkeys(keys))


def _expm(Z: np.ndarray) -> np.ndarray:
    """Matrix exponentials of a stack of small matrices: scaling, a Taylor series of 24
    terms (|Z|/2^s <= 0.5, truncation below 1e-25), squaring."""
    norm = np.abs(Z).sum(axis=-1).max(axis=-1)
    s = np.maximum(0, np.ceil(np.log2(np.maximum(norm, 1e-300) / 0.5))).astype(int)
    Zs = Z / (2.0 ** s)[:, None, None]
    out = np.broadcast_to(np.eye(Z.shape[-1]), Z.shape).copy()
    term = out.copy()
    for k in range(1, 25):
        term = term @ Zs / k
        out = out + term
    for i in range(Z.shape[0]):
        for _ in range(s[i]):
            out[i] = out[i] @ out[i]
    return out


class Tables:
    """Everything the kernel needs for one wall at one record step, built once and kept:
    the held-state geometry, the piece tables (filled for the reachable pieces), and the
    work arrays of :func:`_march`."""

    def __init__(self, wall: Wall, dt: float, like: Tables | None = None):
        # a copy: the loop reads aligned, contiguous arrays it alone owns (a wall of a study
        # batch may hold its parameters in an unaligned view of a received buffer)
        P = np.array(wall.params, dtype=np.float64)
        self.P = P
        self.dt = float(dt)
        self.nfull = n_dof(P)
        # `like`: the same wall's tables at another record step, whose parts that do not
        # depend on the step (geometry, piece matrices, release rows, eigenvalues) are
        # copied, not computed again: the same numbers
        self.geo = tuple(a.copy() for a in like.geo) if like is not None else geometry(P)
        self.ready = np.zeros(NPIECE, np.bool_)
        self.nsub = np.ones(NPIECE, np.int64)
        self.mats = np.zeros((NPIECE, 2, NP, NP))
        self.vecs = np.zeros((NPIECE, 2, NP))
        self.prop = np.zeros((NPIECE, 2 * NP, 2 * NP))
        self.pvec = np.zeros((NPIECE, 3, 2 * NP))
        self.rel = np.zeros((NPIECE, 2, 2, REL_W))
        self.nu = np.zeros(NPIECE)  # each piece's largest |eigenvalue| [1/s]
        self.pieces = (self.ready, self.nsub, self.mats, self.vecs, self.prop, self.pvec,
                       self.rel)
        # the parts of the equations every piece shares (MODEL.md section 5)
        a1, a2 = P[P_A1], P[P_A2]
        vt = np.array([a1, a2, 1.0])
        e3 = np.array([0.0, 0.0, 1.0])
        self._KD = P[P_KDT] * np.outer(vt, vt) + P[P_KDB] * np.outer(e3, e3)
        self._CD = P[P_CT] * np.outer(vt, vt) + P[P_CB] * np.outer(e3, e3)
        self._Mf = {f: full_mass(P, f) for f in (1, 2)}
        self._T = [transform(P, h) for h in range(4)]
        # resistance on each signed branch, R = k*theta + r0, per case
        self._branch = {c: np.array([branch_coeffs(P, c, b) for b in range(-2, 3)])
                        for c in (1, 2, 3)}
        self.build(_reachable(P), like)  # (pieces added later are computed)
        self.work = (
            np.zeros((KMAX, NP)), np.zeros(KMAX), np.zeros(N_IST, np.int64),
            np.zeros((MAX_EV, NP)), np.zeros((MAX_EV, NP)), np.zeros(MAX_EV),
            np.zeros(MAX_EV), np.zeros(MAX_EV), np.zeros(MAX_EV, np.int64),
            np.zeros(MAX_EV, np.int64),
            np.zeros(MAX_EV), np.zeros(MAX_EV), np.zeros(MAX_EV), np.zeros(MAX_EV),
            np.zeros((NP, MAX_EV)), np.zeros((NP, MAX_EV)), np.zeros(MAX_EV),
            np.zeros(MAX_EV), np.zeros(MAX_EV),
            np.zeros(N_TRACK), np.zeros(N_TRACK), np.zeros(N_TRACK), np.zeros(N_TRACK),
            np.zeros(NP), np.zeros(NP), np.zeros(NP), np.zeros(NP), np.zeros(NP),
            np.zeros(NP), np.zeros(NP), np.zeros(3, np.int64))
        names = [x[0] for x in ARRAYS]
        fixed = [P, NO_RECORD, *self.geo, *self.pieces, *self.work, np.zeros(N_TRACK),
                 np.zeros(N_OUT), NO_HIST, NO_LOG]
        self.args = native.Args(ARRAYS, dict(zip(names, fixed, strict=True)), self.dt, LOOP)

    @property
    def nbytes(self) -> int:
        """Memory held by the tables and work arrays. [B]"""
        arrays = [*self.geo, *self.pieces, *self.work]
        return int(sum(a.nbytes for a in arrays))

    def _stiffness(self, h: int, case_l: int, bl, bu):
        """K and R0 of pieces of held state h over y (stacked over the branch arrays bl,
        bu of the lower curve `case_l` and the upper curve)."""
        T = self._T[h]
        kl, rl = self._branch[case_l][np.asarray(bl) + 2].T
        ku, ru = self._branch[1][np.asarray(bu) + 2].T
        K = (T.T @ self._KD @ T)[None] + kl[:, None, None] * np.outer(T[0], T[0])[None] \
            + ku[:, None, None] * np.outer(T[1], T[1])[None]
        R0 = rl[:, None] * T[0][None] + ru[:, None] * T[1][None]
        return K, R0

    def _ground(self, h: int, fam: int, Minv: np.ndarray) -> np.ndarray:
        """M^-1 G over y; while u_b is a free coordinate its unit vector exactly (MODEL.md
        section 5: the ground drives u_b alone)."""
        T = self._T[h]
        ny = T.shape[1]
        if self.P[P_RIGID_B] < 0.5 and self.P[P_RIGID_T] < 0.5:
            out = np.zeros(ny)
            out[ny - 1] = 1.0  # u_b is the last coordinate of every held state
            return out
        return Minv @ (T.T @ self._Mf[fam][:, 2])

    def build(self, keys, like: Tables | None = None) -> None:
        """Fill the tables of the given pieces (h, fam, bl, bu, bla); those `like` (the same
        wall's tables at another step) has ready are copied from it but the propagators."""
        GMI = self.geo[3]
        groups: dict[tuple[int, int], list] = {}
        for key in keys:
            if not self.ready[piece_index(*key)]:
                groups.setdefault(key[:2], []).append(key)
        by_size: dict[int, list] = {}
        for (h, fam), ks in groups.items():
            ny = self._T[h].shape[1]
            mids = np.array([piece_index(*k) for k in ks])
            if like is not None and like.ready[mids].all():
                for mine, theirs in ((self.mats, like.mats), (self.vecs, like.vecs),
                                     (self.rel, like.rel), (self.nu, like.nu)):
                    mine[mids] = theirs[mids]
                MK, MC = self.mats[mids, 0, :ny, :ny], self.mats[mids, 1, :ny, :ny]
                MR, MG = self.vecs[mids, 0, :ny], self.vecs[mids, 1, :ny]
            else:
                MK, MC, MR, MG = self._piece_matrices(h, fam, ny, mids, ks, GMI)
            by_size.setdefault(ny, []).append((mids, MK, MC, MR, MG))
        for ny, items in by_size.items():
            self._propagators(ny, *(np.concatenate(x) for x in zip(*items, strict=True)))
        for ks in groups.values():
            self.ready[[piece_index(*k) for k in ks]] = True

    def _piece_matrices(self, h: int, fam: int, ny: int, mids, ks, GMI) -> tuple:
        """M^-1 K, M^-1 C, M^-1 R0 and M^-1 G of pieces `ks` (indices `mids`) of held state
        h and family `fam`, stored with their release rows; returned stacked."""
        bl, bu, bla = (np.array([k[i] for k in ks]) for i in (2, 3, 4))
        Minv = GMI[h, fam - 1, :ny, :ny]
        K, R0 = self._stiffness(h, 3 if fam == 1 else 2, bl, bu)
        MK = Minv[None] @ K
        MC = np.broadcast_to(Minv @ (self._T[h].T @ self._CD @ self._T[h]), MK.shape)
        MR = R0 @ Minv.T
        MG = np.broadcast_to(self._ground(h, fam, Minv), MR.shape)
        self.mats[mids, 0, :ny, :ny] = MK
        self.mats[mids, 1, :ny, :ny] = MC
        self.vecs[mids, 0, :ny] = MR
        self.vecs[mids, 1, :ny] = MG
        if h != HELD_NONE:
            self.rel[mids] = self._release_rows(h, fam, bl, bu, bla)
        self.nu[mids] = np.nan  # (not known yet: _propagators finds it)
        return MK, MC, MR, MG

    def _release_rows(self, h, fam, bl, bu, bla) -> np.ndarray:
        """Unconstrained acceleration of each held joint's gap under each family, as rows
        on y and y_d, a ground coefficient and a constant (MODEL.md section 4), stacked
        over the pieces (branch arrays bl, bu, bla)."""
        P = self.P
        n = self.nfull
        Lr = watch_rows(P, HELD_NONE)[:, :n]
        N = held_map(P, h)
        ny = N.shape[1]
        T0 = self._T[HELD_NONE]
        out = np.zeros((len(bl), 2, 2, REL_W))
        held_theta1 = h in (HELD_BASE, HELD_BOTH)
        for f in (1, 2):
            bl_f = np.zeros_like(bl) if held_theta1 else (bl if f == fam else bla)
            bu_f = np.zeros_like(bu) if h == HELD_BOTH else bu
            K, R0 = self._stiffness(HELD_NONE, 3 if f == 1 else 2, bl_f, bu_f)
            Minv = self.geo[3][HELD_NONE, f - 1, :n, :n]
            MinvG = self._ground(HELD_NONE, f, Minv)
            C = T0.T @ self._CD @ T0
            for which, lrow in ((0, ROW_T1), (1, ROW_GC)):
                JM = Lr[lrow] @ Minv
                out[:, which, f - 1, :ny] = -(JM @ K) @ N
                out[:, which, f - 1, NP:NP + ny] = -(JM @ C @ N)
                out[:, which, f - 1, 2 * NP] = -Lr[lrow] @ MinvG
                out[:, which, f - 1, 2 * NP + 1] = -(R0 @ JM)
        return out

    def _too_stiff(self, need: float) -> str:
        """The message refusing a support whose spring needs `need` sub-steps a step: it
        names the stiffer support (by its frequency with the diaphragm and half the wall)."""
        P = self.P
        freq = {}
        for where, k, md in (("bottom", P[P_KDB], P[P_MDB]), ("top", P[P_KDT], P[P_MDT])):
            if k > 0.0:
                freq[where] = math.sqrt(k / (md + 0.5 * (P[P_M1] + P[P_M2])))
        if not freq:  # (no spring: the trilinear curves alone cannot be this stiff)
            return f"the wall needs {need:.3g} sub-steps per record step of {self.dt:g} s"
        where = max(freq, key=freq.get)
        k = P[P_KDB] if where == "bottom" else P[P_KDT]
        return (f"{where}_stiffness={k:g} N/m needs {need:.3g} sub-steps per record step of "
                f"{self.dt:g} s, above the bound of {MAX_SUBSTEPS}: the analysis would not "
                f"finish in reasonable time; declare the support rigid "
                f"({where}_stiffness = \"rigid\") if it stands for one")

    def _propagators(self, ny: int, mids, MK, MC, MR, MG) -> None:
        """Sub-step count and exact propagator of pieces with ny coordinates: one matrix
        exponential of [[A, c_R, c_G, 0], [0, 0, 0, 0], [0, 0, 0, 1], [0, 0, 0, 0]] (A the
        first-order matrix, c_R and c_G the resistance and ground columns) gives the
        state transition and the responses to the constant, ramp and resistance forcing."""
        m = 2 * ny
        npc = len(mids)
        Z = np.zeros((npc, m + 3, m + 3))
        Z[:, :ny, ny:m] = np.eye(ny)
        Z[:, ny:m, :ny] = -MK
        Z[:, ny:m, ny:m] = -MC
        Z[:, ny:m, m] = -MR
        Z[:, ny:m, m + 1] = -MG
        Z[:, m + 1, m + 2] = 1.0
        if not np.isfinite(Z).all():
            raise InputError(self._too_stiff(math.inf))
        nu = self.nu[mids]
        if m and not np.isfinite(nu).all():  # (pieces copied from another step know it)
            nu = np.abs(np.linalg.eigvals(Z[:, :m, :m])).max(axis=-1)
            self.nu[mids] = nu
        elif not m:
            nu = np.zeros(npc)
        need = float(np.ceil(nu.max() * self.dt / RHO)) if npc else 1.0
        if not need <= MAX_SUBSTEPS:
            raise InputError(self._too_stiff(need))
        ns = np.maximum(1, np.ceil(nu * self.dt / RHO)).astype(np.int64)
        hs = self.dt / ns
        # balanced: rates scaled by the sub-step (z = [y, h y_d]), so that |Z h| is about
        # (nu h)^2 <= 1 even for stiff springs (few squarings, no loss of accuracy)
        scale = np.ones((npc, m + 3))
        scale[:, ny:m] = hs[:, None]
        X = _expm(Z * hs[:, None, None] * scale[:, :, None] / scale[:, None, :])
        X = X / scale[:, :, None] * scale[:, None, :]
        idx = np.r_[np.arange(ny), NP + np.arange(ny)]
        self.nsub[mids] = ns
        self.prop[mids] = 0.0
        self.pvec[mids] = 0.0
        self.prop[np.ix_(mids, idx, idx)] = X[:, :m, :m]
        for which in range(3):
            self.pvec[mids[:, None], which, idx[None, :]] = X[:, :m, m + which]


_TABLES: OrderedDict = OrderedDict()
_TABLES_MAX = 128


def tables(wall: Wall, dt: float) -> Tables:
    """The kernel's tables of a wall at a record step, kept for the next analysis of the
    same wall (studies and collapse searches run each wall many times)."""
    key = (wall.params.tobytes(), float(dt))
    tab = _TABLES.get(key)
    if tab is None:
        like = next((t for k, t in reversed(_TABLES.items()) if k[0] == key[0]), None)
        tab = Tables(wall, dt, like)
        _TABLES[key] = tab
        if len(_TABLES) > _TABLES_MAX:
            _TABLES.popitem(last=False)
    else:
        _TABLES.move_to_end(key)
    return tab



def clear_cache() -> None:
    """Forget the cached tables (benchmarks measure cold runs with it)."""
    _TABLES.clear()

