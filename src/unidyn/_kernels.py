"""Compiled batch engine: the Fig. 2 loop of :func:`unidyn.equations.loop_derivative`
integrated with RK4, one run per thread (numba).

The right-hand side is the very function the numpy engine
(:class:`unidyn.closedloop.ClosedLoop`) evaluates on arrays of runs, here compiled
for one run at a time; the per-run parameters are the rows of the named table
:data:`unidyn.equations.LOOP_PARAMETERS` (:meth:`ClosedLoop.parameter_table`). The
reference is evaluated here from its kind (:data:`unidyn.equations.TRAJECTORY_KINDS`)
with the trajectory functions of :mod:`unidyn.equations`. Used by
:func:`unidyn.simulate_batch` when numba is installed (``pip install unidyn[fast]``);
without numba the same code runs as plain Python, which ``tests/evals/test_engines.py``
checks against the numpy engine.
"""

from __future__ import annotations

import math

import numpy as np

from . import equations as eq
from ._jit import AVAILABLE, jit, prange
from .equations import P, S

__all__ = ["AVAILABLE", "LOG_COLUMNS", "reference", "rhs", "run_batch", "start", "OK", "NONFINITE",
           "POSITION", "SPEED_U", "SPEED_W", "INTERRUPTED"]

NSTATE = len(eq.STATE)


@jit(inline=True)
def reference(t, p):
    """(x_d, y_d, x_d', y_d', x_d'', y_d'') of the run with parameters p at time t."""
    kind = p[P.trajectory]
    if kind == 0.0:
        return eq.figure_eight(t, p[P.path1], p[P.path2], p[P.path3], p[P.path4],
                               p[P.path5], p[P.path6])
    if kind == 1.0:
        return eq.circle(t, p[P.path1], p[P.path2], p[P.path3], p[P.path4], p[P.path5])
    return eq.line(t, p[P.path1], p[P.path2], p[P.path3], p[P.path4])


@jit
def rhs(t, X, p, noise, dX):
    """dX/dt of one run (X, dX: (13,), p: a row of the parameter table)."""
    eq.loop_derivative(t, X, reference(t, p), p, noise, dX)


#: The columns of the log, in order: the states the result keeps (pose, robot
#: velocity, theta_hat: the first 11 of :data:`unidyn.equations.STATE`), then h_d,
#: v_d and v_ref (after the speed limits). Nothing else is logged.
LOG_COLUMNS = eq.STATE[:11] + ("x_d", "y_d", "u_d", "w_d", "u_ref", "w_ref")
NLOG = len(LOG_COLUMNS)



def _columns(first, last):
    return slice(LOG_COLUMNS.index(first), LOG_COLUMNS.index(last) + 1)


#: Where each series of a :class:`~unidyn.Result` lies in a row of the log.
LOG_SERIES = {"pose": _columns("x", "psi"), "velocity": _columns("u", "w"),
              "theta_hat": _columns("theta_hat1", "theta_hat6"),
              "reference": _columns("x_d", "y_d"), "v_d": _columns("u_d", "w_d"),
              "v_ref": _columns("u_ref", "w_ref")}


@jit
def log_signals(t, X, p, noise, out):
    """One row of the log (:data:`LOG_COLUMNS`) at (t, X) into out, whatever out's
    floating dtype."""
    for i in range(11):
        out[i] = X[i]
    ref = reference(t, p)
    ud, wd, udd, wdd, G, u_ref, w_ref, um, wm = eq.loop_signals(X, ref, p, noise)
    out[11] = ref[0]
    out[12] = ref[1]
    out[13] = ud
    out[14] = wd
    out[15] = eq.saturate(u_ref, p[P.speed_u])
    out[16] = eq.saturate(w_ref, p[P.speed_w])


#: Why a run stopped (``status``): still running / complete, a non-finite state,
#: |(x, y)|, |u| or |w| beyond its divergence bound, interrupted.
OK, NONFINITE, POSITION, SPEED_U, SPEED_W, INTERRUPTED = 0, 1, 2, 3, 4, 5


@jit
def check_state(X, bound):
    """The status of state X against bound = [|(x, y)|, |u|, |w|] bounds."""
    for i in range(X.shape[0]):
        if not math.isfinite(X[i]):
            return NONFINITE
    if math.hypot(X[S.x], X[S.y]) > bound[0]:
        return POSITION
    if abs(X[S.u]) > bound[1]:
        return SPEED_U
    if abs(X[S.w]) > bound[2]:
        return SPEED_W
    return OK


@jit
def log_row(k, n, L, stopped):
    """Row of the logged arrays for sample k (every L-th sample, plus the sample a
    run stopped at); -1 when sample k is not logged."""
    if k % L == 0:
        return k // L
    if stopped:
        return k // L + 1
    return -1


@jit
def _run_one(X, p, pos_noise, vel_noise, kn, Ts, k0, k1, n, m, L, bound, LOG):
    """Advance X (in place) over sample intervals k0..k1-1 with m RK4 steps each (the
    noise arrays hold intervals kn, kn + 1, ...); returns (status, last sample reached)."""
    d1 = np.empty(NSTATE)
    d2 = np.empty(NSTATE)
    d3 = np.empty(NSTATE)
    d4 = np.empty(NSTATE)
    tmp = np.empty(NSTATE)
    h = Ts / m
    for k in range(k0, k1):
        r = k - kn
        noise = (pos_noise[r, 0], pos_noise[r, 1], vel_noise[r, 0], vel_noise[r, 1])
        for j in range(m):
            t = k * Ts + j * h
            rhs(t, X, p, noise, d1)
            for i in range(NSTATE):
                tmp[i] = X[i] + 0.5 * h * d1[i]
            rhs(t + 0.5 * h, tmp, p, noise, d2)
            for i in range(NSTATE):
                tmp[i] = X[i] + 0.5 * h * d2[i]
            rhs(t + 0.5 * h, tmp, p, noise, d3)
            for i in range(NSTATE):
                tmp[i] = X[i] + h * d3[i]
            rhs(t + h, tmp, p, noise, d4)
            for i in range(NSTATE):
                X[i] += h / 6.0 * (d1[i] + 2.0 * d2[i] + 2.0 * d3[i] + d4[i])
            # the speed limits are hard: a step that crosses one ends on it
            X[S.u] = eq.saturate(X[S.u], p[P.speed_u])
            X[S.w] = eq.saturate(X[S.w], p[P.speed_w])
        status = check_state(X, bound)
        row = log_row(k + 1, n, L, status != OK)
        if row >= 0:
            # logged with interval k's measurement, as the diagram logs it before the tick
            log_signals((k + 1) * Ts, X, p, noise, LOG[row])
        if status != OK:
            return status, k + 1
    return OK, k1


@jit
def start(X, P_, pos_noise, vel_noise, bound, LOG, status):
    """Log sample 0 of every run and check its state (noise row 0: interval 0)."""
    for i in range(X.shape[0]):
        noise = (pos_noise[i, 0, 0], pos_noise[i, 0, 1], vel_noise[i, 0, 0], vel_noise[i, 0, 1])
        log_signals(0.0, X[i], P_[i], noise, LOG[i, 0])
        status[i] = check_state(X[i], bound[i])


@jit(parallel=True)
def run_batch(X, P_, pos_noise, vel_noise, kn, Ts, k0, k1, n, m, L, bound, LOG, status, last):
    """Advance every running run (status OK) over sample intervals k0..k1-1, run i
    with m[i] RK4 steps per interval, the noise arrays (B, rows, 2) holding intervals
    kn .. kn + rows - 1 (k0 >= kn, k1 <= kn + rows). X (B, 13) is updated in place; every L-th
    sample (and the one a run stops at) is logged into LOG (B, rows, NLOG; float64 or
    float32); status[i] says why run i stopped and last[i] is the last
    sample it reached."""
    for i in prange(X.shape[0]):
        if status[i] == OK:
            st, lst = _run_one(X[i], P_[i], pos_noise[i], vel_noise[i], kn, Ts, k0, k1, n, m[i], L,
                               bound[i], LOG[i])
            status[i] = st
            last[i] = lst
