"""Compiled batch kernel: the Fig. 2 loop of :class:`unidyn.closedloop.ClosedLoop`
in scalar form, integrated with RK4, one run per thread (numba).

The equations are those of :mod:`unidyn.model` (Eqs. 1-2 with limits) and
:mod:`unidyn.control` (Eqs. 10, 12/14, 18/20, the exact v_d'), written out on
scalars so numba can compile them. ``tests/test_engines.py`` checks this
right-hand side against ``ClosedLoop.rhs`` on seeded random states, so the
two stay the same equations. Used by :func:`unidyn.simulate_batch` when numba
is installed (``pip install unidyn[fast]``); otherwise the numpy engine runs.
"""

from __future__ import annotations

import math

import numpy as np

from .control import SWITCH_TOL

try:  # numba is optional
    import numba
    _njit = numba.njit(cache=True, nogil=True)
    _prange = numba.prange
    _parallel = numba.njit(cache=True, parallel=True)
    AVAILABLE = True
except ImportError:  # pragma: no cover - exercised where numba is absent
    AVAILABLE = False

    def _njit(f):
        return f

    _parallel = _njit
    _prange = range

# layout of the per-run parameter vector
TH, A, KK, LK, KD, LD, GAM, SIG, ADAPT, TAU, FILT, LEAK, VMAX, AMAX, CASE, TRAJ, TP = (
    0, 6, 7, 9, 11, 13, 15, 21, 27, 28, 29, 30, 31, 33, 35, 36, 37)
NPARAM = TP + 6
TRAJ_CODES = {"figure_eight": 0, "circle": 1, "line": 2}


def pack(loop) -> np.ndarray:
    """Per-run parameter vectors (B, NPARAM) of a :class:`~unidyn.closedloop.ClosedLoop`."""
    B = loop.B
    P = np.zeros((B, NPARAM))
    P[:, TH:TH + 6] = loop.theta
    P[:, A] = loop.a
    P[:, KK:KK + 2] = loop.kK
    P[:, LK:LK + 2] = loop.lK
    P[:, KD:KD + 2] = loop.kD
    P[:, LD:LD + 2] = loop.lD
    P[:, GAM:GAM + 6] = loop.gamma
    P[:, SIG:SIG + 6] = loop.sigma
    P[:, ADAPT] = loop.adapt_from
    P[:, TAU] = loop.tau
    P[:, FILT] = loop.filt
    P[:, LEAK] = loop.leak
    P[:, VMAX:VMAX + 2] = loop.vmax
    P[:, AMAX:AMAX + 2] = loop.amax
    P[:, CASE] = loop.case
    for i, sc in enumerate(loop.scenarios):
        tr = sc.trajectory
        code = TRAJ_CODES.get(getattr(tr, "kind", None))
        if code is None:
            raise TypeError(f"the compiled kernel has no trajectory of kind {tr.kind!r}")
        P[i, TRAJ] = code
        if code == 0:
            P[i, TP:TP + 6] = (tr.ax, tr.ay, tr.wx, tr.wy, tr.center[0], tr.center[1])
        elif code == 1:
            P[i, TP:TP + 6] = (tr.radius, tr.omega, tr.center[0], tr.center[1], tr.phase, 0.0)
        else:
            P[i, TP:TP + 6] = (tr.start[0], tr.start[1], tr.velocity_[0], tr.velocity_[1], 0.0, 0.0)
    return P


@_njit
def reference(t, P, out):
    """h_d, h_d_dot, h_d_ddot into out[0:6]."""
    code = P[TRAJ]
    if code == 0.0:
        ax, ay, wx, wy, cx, cy = P[TP], P[TP + 1], P[TP + 2], P[TP + 3], P[TP + 4], P[TP + 5]
        sx, cxw = math.sin(wx * t), math.cos(wx * t)
        sy, cyw = math.sin(wy * t), math.cos(wy * t)
        out[0] = cx + ax * sx
        out[1] = cy + ay * (cyw - 1.0)
        out[2] = ax * wx * cxw
        out[3] = -ay * wy * sy
        out[4] = -ax * wx * wx * sx
        out[5] = -ay * wy * wy * cyw
    elif code == 1.0:
        r, om, cx, cy, ph = P[TP], P[TP + 1], P[TP + 2], P[TP + 3], P[TP + 4]
        a = om * t + ph
        c, s = math.cos(a), math.sin(a)
        out[0] = cx + r * c
        out[1] = cy + r * s
        out[2] = -r * om * s
        out[3] = r * om * c
        out[4] = -r * om * om * c
        out[5] = -r * om * om * s
    else:
        out[0] = P[TP] + P[TP + 2] * t
        out[1] = P[TP + 1] + P[TP + 3] * t
        out[2] = P[TP + 2]
        out[3] = P[TP + 3]
        out[4] = 0.0
        out[5] = 0.0


@_njit
def signals(t, X, P, pn0, pn1, vn0, vn1, sig):
    """The loop's signals at (t, X): sig[0:2] h_d, [2:4] v_d, [4:6] v_d', [6:8] v_ref
    (before clipping), [8:20] G (row-major 2x6), [20:22] v_meas."""
    ref = np.empty(6)
    reference(t, P, ref)
    psi = X[2]
    c, s = math.cos(psi), math.sin(psi)
    a = P[A]
    hx, hy = X[0] + pn0, X[1] + pn1
    um, wm = X[3] + vn0, X[4] + vn1
    # Eq. (10)
    zx = P[KK] * (ref[0] - hx) / P[LK]
    zy = P[KK + 1] * (ref[1] - hy) / P[LK + 1]
    nux = ref[2] + P[LK] * math.tanh(zx)
    nuy = ref[3] + P[LK + 1] * math.tanh(zy)
    ud = c * nux + s * nuy
    wd = (-s * nux + c * nuy) / a
    # v_d': exact (Eq. 10 differentiated along the motion) or filtered
    if P[FILT] != 0.0:
        udd = (ud - X[11]) / P[TAU]
        wdd = (wd - X[12]) / P[TAU]
    else:
        hdx = um * c - a * wm * s
        hdy = um * s + a * wm * c
        chx = math.cosh(zx)
        chy = math.cosh(zy)
        ndx = ref[4] + P[KK] / (chx * chx) * (ref[2] - hdx)
        ndy = ref[5] + P[KK + 1] / (chy * chy) * (ref[3] - hdy)
        udd = wm * (-s * nux + c * nuy) + c * ndx + s * ndy
        wdd = (wm * (-c * nux - s * nuy) - s * ndx + c * ndy) / a
    # Eq. (14)
    s1 = udd + P[LD] * math.tanh(P[KD] * (ud - um) / P[LD])
    s2 = wdd + P[LD + 1] * math.tanh(P[KD + 1] * (wd - wm) / P[LD + 1])
    G = sig[8:20]
    for j in range(12):
        G[j] = 0.0
    G[0] = s1
    G[2] = -wd * wm
    G[3] = ud
    G[7] = s2
    G[8] = ud * wm - um * wd
    G[10] = um * wd
    G[11] = wd
    sig[0], sig[1] = ref[0], ref[1]
    sig[2], sig[3] = ud, wd
    sig[4], sig[5] = udd, wdd
    if P[CASE] >= 2.0:
        ur = 0.0
        wr = 0.0
        for j in range(6):
            ur += G[j] * X[5 + j]
            wr += G[6 + j] * X[5 + j]
        sig[6], sig[7] = ur, wr
    else:
        sig[6], sig[7] = ud, wd
    sig[20], sig[21] = um, wm


@_njit
def rhs(t, X, P, pn0, pn1, vn0, vn1, dX, sig):
    signals(t, X, P, pn0, pn1, vn0, vn1, sig)
    th = P[TH:TH + 6]
    # commands clipped to the speed limits
    ur = min(max(sig[6], -P[VMAX]), P[VMAX])
    wr = min(max(sig[7], -P[VMAX + 1]), P[VMAX + 1])
    psi = X[2]
    c, s = math.cos(psi), math.sin(psi)
    a = P[A]
    if P[CASE] == 0.0:  # kinematic robot: v = clipped v_d
        u, w = ur, wr
        dX[3] = 0.0
        dX[4] = 0.0
    else:  # Eq. (2) with acceleration limits
        u, w = X[3], X[4]
        du = (th[2] * w * w - th[3] * u + ur) / th[0]
        dw = (-th[4] * u * w - th[5] * w + wr) / th[1]
        du = min(max(du, -P[AMAX]), P[AMAX])
        dw = min(max(dw, -P[AMAX + 1]), P[AMAX + 1])
        if (u >= P[VMAX] and du > 0.0) or (u <= -P[VMAX] and du < 0.0):
            du = 0.0
        if (w >= P[VMAX + 1] and dw > 0.0) or (w <= -P[VMAX + 1] and dw < 0.0):
            dw = 0.0
        dX[3] = du
        dX[4] = dw
    # Eq. (1)
    dX[0] = u * c - a * w * s
    dX[1] = u * s + a * w * c
    dX[2] = w
    # Eqs. (18)/(20), on from adapt_from
    if t >= P[ADAPT] - SWITCH_TOL:
        e0 = sig[2] - sig[20]
        e1 = sig[3] - sig[21]
        leak = P[LEAK]
        for j in range(6):
            g = sig[8 + j] * e0 + sig[14 + j] * e1
            r = P[GAM + j] * g
            if leak == 0.0:
                r -= P[GAM + j] * P[SIG + j] * X[5 + j]
            elif leak == 1.0:
                r -= P[SIG + j] * X[5 + j]
            dX[5 + j] = r
    else:
        for j in range(6):
            dX[5 + j] = 0.0
    if P[FILT] != 0.0:
        dX[11] = sig[4]
        dX[12] = sig[5]
    else:
        dX[11] = 0.0
        dX[12] = 0.0


#: Why a run stopped (``status``): still running / complete, a non-finite state,
#: |(x, y)|, |u| or |w| beyond its divergence bound, interrupted.
OK, NONFINITE, POSITION, SPEED_U, SPEED_W, INTERRUPTED = 0, 1, 2, 3, 4, 5


@_njit
def check_state(X, bound):
    """The status of state X against bound = [|(x, y)|, |u|, |w|] bounds."""
    for i in range(13):
        if not math.isfinite(X[i]):
            return NONFINITE
    if math.hypot(X[0], X[1]) > bound[0]:
        return POSITION
    if abs(X[3]) > bound[1]:
        return SPEED_U
    if abs(X[4]) > bound[2]:
        return SPEED_W
    return OK


@_njit
def log_row(k, n, L, stopped):
    """Row of the logged arrays for sample k (every L-th sample, plus the sample a
    run stopped at); -1 when sample k is not logged."""
    if k % L == 0:
        return k // L
    if stopped:
        return k // L + 1
    return -1


@_njit
def _run_one(X, P, pos_noise, vel_noise, Ts, k0, k1, n, m, L, bound, Xs, SIG):
    """Advance X (in place) over sample intervals k0..k1-1; returns (status, last
    sample reached)."""
    k1_ = np.empty(13)
    k2 = np.empty(13)
    k3 = np.empty(13)
    k4 = np.empty(13)
    tmp = np.empty(13)
    sig = np.empty(22)
    h = Ts / m
    for k in range(k0, k1):
        p0, p1 = pos_noise[k, 0], pos_noise[k, 1]
        v0, v1 = vel_noise[k, 0], vel_noise[k, 1]
        for j in range(m):
            t = k * Ts + j * h
            rhs(t, X, P, p0, p1, v0, v1, k1_, sig)
            for i in range(13):
                tmp[i] = X[i] + 0.5 * h * k1_[i]
            rhs(t + 0.5 * h, tmp, P, p0, p1, v0, v1, k2, sig)
            for i in range(13):
                tmp[i] = X[i] + 0.5 * h * k2[i]
            rhs(t + 0.5 * h, tmp, P, p0, p1, v0, v1, k3, sig)
            for i in range(13):
                tmp[i] = X[i] + h * k3[i]
            rhs(t + h, tmp, P, p0, p1, v0, v1, k4, sig)
            for i in range(13):
                X[i] += h / 6.0 * (k1_[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i])
            # the speed limits are hard: a step that crosses one ends on it
            X[3] = min(max(X[3], -P[VMAX]), P[VMAX])
            X[4] = min(max(X[4], -P[VMAX + 1]), P[VMAX + 1])
        status = check_state(X, bound)
        row = log_row(k + 1, n, L, status != OK)
        if row >= 0:
            Xs[row] = X
            # logged with interval k's measurement, as the diagram logs it before the tick
            signals((k + 1) * Ts, X, P, p0, p1, v0, v1, sig)
            SIG[row] = sig[0:8]
        if status != OK:
            return status, k + 1
    return OK, k1


@_njit
def start(X, P, pos_noise, vel_noise, bound, Xs, SIG, status):
    """Log sample 0 of every run and check its state."""
    sig = np.empty(22)
    for i in range(X.shape[0]):
        Xs[i, 0] = X[i]
        signals(0.0, X[i], P[i], pos_noise[i, 0, 0], pos_noise[i, 0, 1],
                vel_noise[i, 0, 0], vel_noise[i, 0, 1], sig)
        SIG[i, 0] = sig[0:8]
        status[i] = check_state(X[i], bound[i])


@_parallel
def run_batch(X, P, pos_noise, vel_noise, Ts, k0, k1, n, m, L, bound, Xs, SIG, status, last):
    """Advance every running run (status OK) over sample intervals k0..k1-1, run i
    with m[i] RK4 steps per interval. X (B, 13) is updated in place; every L-th
    sample (and the one a run stops at) is logged into Xs (B, rows, 13) and SIG
    (B, rows, 8); status[i] says why run i stopped and last[i] is the last
    sample it reached."""
    for i in _prange(X.shape[0]):
        if status[i] == OK:
            st, lst = _run_one(X[i], P[i], pos_noise[i], vel_noise[i], Ts, k0, k1, n, m[i], L,
                               bound[i], Xs[i], SIG[i])
            status[i] = st
            last[i] = lst
