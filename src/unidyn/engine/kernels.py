"""The batch engine's step rule, once: the Dormand-Prince 5(4) pair with step-size
control (:func:`dp_step`, its table :data:`A`, :data:`B`, :data:`C`, :data:`E`; the
method of ``solve_ivp``'s RK45) over any right-hand side with a projection onto its
constraints (:func:`integrate_interval`), restarted at every sample interval; the Fig. 2
loop (:func:`loop_rhs`, its speed limits :func:`loop_limits`) one run after another,
its metrics accumulated at every sample (:func:`advance`, called from a thread per core). numba compiles this module where installed (:mod:`unidyn.engine.jit`);
:func:`unidyn.engine.jit.plain_copy` runs the same source as plain Python.
"""

from __future__ import annotations

import math
from collections import namedtuple
from enum import IntEnum

import numpy as np

from ..model import equations as eq
from ..model.equations import NSTATE, P, S
from .jit import AVAILABLE, jit

if AVAILABLE:
    from numba.extending import overload

__all__ = ["AVAILABLE", "Runs", "Call", "LOG_COLUMNS", "LOG_SERIES",
           "log_layout", "reference", "loop_rhs", "loop_limits", "advance", "dp_step",
           "integrate_interval", "Status"]


# ------------------------------------------------ Dormand-Prince 5(4), a table
# Dormand, Prince, J. Comp. Appl. Math. 6 (1980): stage s at t + C[s] h from
# x + h sum_j A[s, j] K[j]; B: the fifth-order solution; E (the last weight on f at the
# step's end): its difference from the embedded fourth-order one, the error estimate.
C = np.array([0.0, 1 / 5, 3 / 10, 4 / 5, 8 / 9, 1.0])
A = np.array([[0.0, 0.0, 0.0, 0.0, 0.0],
              [1 / 5, 0.0, 0.0, 0.0, 0.0],
              [3 / 40, 9 / 40, 0.0, 0.0, 0.0],
              [44 / 45, -56 / 15, 32 / 9, 0.0, 0.0],
              [19372 / 6561, -25360 / 2187, 64448 / 6561, -212 / 729, 0.0],
              [9017 / 3168, -355 / 33, 46732 / 5247, 49 / 176, -5103 / 18656]])
B = np.array([35 / 384, 0.0, 500 / 1113, 125 / 192, -2187 / 6784, 11 / 84])
E = np.array([-71 / 57600, 0.0, 71 / 16695, -71 / 1920, 17253 / 339200, -22 / 525, 1 / 40])
#: As scipy's: the next step is h SAFETY err^(-1/5), within [MIN_FACTOR, MAX_FACTOR] h.
SAFETY, MIN_FACTOR, MAX_FACTOR = 0.9, 0.2, 10.0


# not cached itself: numba's cache index records a signature's types by their module, so
# a right-hand side of a script would break the index for other processes (its callers
# are cached, with its code in them)
@jit(inline=True)
def dp_step(f, t, x, h, args, K, y, out, rtol, atol):
    """One Dormand-Prince step of length h from (t, x) of dx/dt = f(t, x, args) (f writes
    into its last argument), the fifth-order solution into out. K[0] holds f(t, x) on
    entry; K[1..6] get the other stages, K[6] = f(t + h, out); y is scratch. Returns the
    error as ``solve_ivp`` measures it: the root mean square over the states of
    error / (atol + rtol max(|x|, |out|)), at most 1 for a step accurate enough."""
    n = x.shape[0]
    for s in range(1, 6):
        for i in range(n):
            acc = 0.0
            for j in range(s):
                acc += A[s, j] * K[j, i]
            y[i] = x[i] + h * acc
        f(t + C[s] * h, y, args, K[s])
    for i in range(n):
        acc = 0.0
        for j in range(6):
            acc += B[j] * K[j, i]
        out[i] = x[i] + h * acc
    f(t + h, out, args, K[6])
    err = 0.0
    for i in range(n):
        acc = 0.0
        for j in range(7):
            acc += E[j] * K[j, i]
        err += (h * acc / (atol + rtol * max(abs(x[i]), abs(out[i])))) ** 2
    return math.sqrt(err / n)


@jit(inline=True)
def step_factor(err):
    """How much longer (or shorter) the next step is than one with error ``err``."""
    if err == 0.0:
        return MAX_FACTOR
    return min(MAX_FACTOR, max(MIN_FACTOR, SAFETY * err ** -0.2))


# ------------------------------------------------------------- the Fig. 2 loop
def python_reference(t, index, references):
    """(x_d, y_d, x_d', y_d', x_d'', y_d'') of ``references[index]``, a reference that is
    a Python function (:class:`unidyn.FunctionTrajectory`), passed with the call."""
    (x, y), (dx, dy), (ddx, ddy) = references[int(index)].evaluate(t)
    return float(x), float(y), float(dx), float(dy), float(ddx), float(ddy)


if AVAILABLE:
    @overload(python_reference)
    def _python_reference_compiled(t, index, references):
        """Compiled code cannot call the Python function: NaN (never run)."""
        return lambda t, index, references: (math.nan, math.nan, math.nan, math.nan,
                                               math.nan, math.nan)


@jit(inline=True)
def reference(t, p, references):
    """(x_d, y_d, x_d', y_d', x_d'', y_d'') of the run with parameters p at time t
    (``references``: the call's Python-function references, trajectory code -1)."""
    kind = p[P.trajectory]
    if kind < 0.0:
        return python_reference(t, p[P.path1], references)
    if kind == 0.0:
        return eq.figure_eight(t, p[P.path1], p[P.path2], p[P.path3], p[P.path4],
                               p[P.path5], p[P.path6])
    if kind == 1.0:
        steps = p[P.step_time1:P.step_time1 + 2 * eq.RADIUS_STEPS]  # unused: at t = inf
        radius = eq.stepped_radius(t, p[P.path1], steps)
        return eq.circle(t, radius, p[P.path2], p[P.path3], p[P.path4], p[P.path5])
    return eq.line(t, p[P.path1], p[P.path2], p[P.path3], p[P.path4])


@jit
def loop_rhs(t, X, args, out):
    """The Fig. 2 loop's dX/dt (:func:`unidyn.model.equations.loop_rates`) of one run
    at time t into out. args = (p, noise, references): a row of the parameter table
    (:data:`unidyn.model.equations.LOOP_PARAMETERS`), the interval's held noise
    (position x, y, velocity u, w) and the call's Python-function references."""
    p, noise, references = args
    d = eq.loop_rates(t, X, reference(t, p, references), p, noise)
    for i in range(NSTATE):
        out[i] = d[i]


@jit(inline=True)
def loop_limits(X, args):
    """The robot's speed limits at the end of a step: u and w of X clipped to them
    (the acceleration limits of Eq. (2) hold the speeds there; a step ends on them).
    Returns whether one was clipped."""
    p = args[0]
    u, w = eq.saturate(X[S.u], p[P.speed_u]), eq.saturate(X[S.w], p[P.speed_w])
    clipped = u != X[S.u] or w != X[S.w]
    X[S.u], X[S.w] = u, w
    return clipped


# -------------------------------------------------------------------- the log
#: The log's columns: pose, velocity (a kinematic robot's: its clipped command),
#: theta_hat (the first 11 states), h_d, v_d and v_ref (after the speed limits).
LOG_COLUMNS = eq.STATE[:11] + ("x_d", "y_d", "u_d", "w_d", "u_ref", "w_ref")
NLOG = len(LOG_COLUMNS)


def _columns(first, last):
    return slice(LOG_COLUMNS.index(first), LOG_COLUMNS.index(last) + 1)


#: Where each series of a :class:`~unidyn.Result` lies in a row of the full log.
LOG_SERIES = {"pose": _columns("x", "psi"), "velocity": _columns("u", "w"),
              "theta_hat": _columns("theta_hat1", "theta_hat6"),
              "reference": _columns("x_d", "y_d"), "v_d": _columns("u_d", "w_d"),
              "v_ref": _columns("u_ref", "w_ref")}


def log_layout(series):
    """(the columns of :data:`LOG_COLUMNS` kept for the named series, as an index array;
    where each kept series lies in a row)."""
    keep, where = [], {}
    for k, sl in LOG_SERIES.items():  # in the order of the columns
        if k in series:
            columns = range(NLOG)[sl]
            where[k] = slice(len(keep), len(keep) + len(columns))
            keep += columns
    return np.array(keep, dtype=np.int64), where


@jit
def sample_row(t, X, p, noise, references, row):
    """The full log row (:data:`LOG_COLUMNS`) of the sample at (t, X) into row."""
    for i in range(11):
        row[i] = X[i]
    ref = reference(t, p, references)
    ud, wd, udd, wdd, G, u_ref, w_ref, um, wm = eq.loop_signals(X, ref, p, noise)
    row[11], row[12], row[13], row[14] = ref[0], ref[1], ud, wd
    row[15], row[16] = eq.saturate(u_ref, p[P.speed_u]), eq.saturate(w_ref, p[P.speed_w])
    if p[P.dynamic] == 0.0:  # a kinematic robot moves at its clipped command
        row[S.u], row[S.w] = row[15], row[16]


@jit(inline=True)
def accumulate(k, Ts, row, acc):
    """Add the trapezoid from sample k - 1 to sample k (at t = k Ts, its row) to the
    integrals acc[0:5] (:data:`unidyn.results.result.INTEGRAL_NAMES`, by the rule of
    :func:`unidyn.results.result.integrals`, at every sample whatever is logged);
    acc[5], acc[6] hold the last sample's distance error and squared speed."""
    e = math.hypot(row[11] - row[S.x], row[12] - row[S.y])
    v2 = row[S.u] * row[S.u] + row[S.w] * row[S.w]
    if k > 0:
        t0, t1 = (k - 1) * Ts, k * Ts
        half, e0, v0 = 0.5 * (t1 - t0), acc[5], acc[6]
        acc[0] += half * (e0 + e)
        acc[1] += half * (e0 * e0 + e * e)
        acc[2] += half * (t0 * e0 + t1 * e)
        acc[3] += half * (t0 * e0 * e0 + t1 * e * e)
        acc[4] += half * (v0 + v2)
    acc[5], acc[6] = e, v2


@jit(inline=True)
def write_log(row, columns, acc, out, integrals):
    """The kept columns of row into out, the integrals so far into integrals."""
    for j in range(columns.shape[0]):
        out[j] = row[columns[j]]
    for j in range(5):
        integrals[j] = acc[j]


# ------------------------------------------------------------------- the runs
class Status(IntEnum):
    """Why a run stopped (its message: :data:`unidyn.engine.batch.STATUS_MESSAGES`)."""
    OK = 0  #: running, or complete
    NONFINITE = 1  #: a state not a number
    POSITION = 2  #: |(x, y)| beyond its divergence bound
    SPEED_U = 3  #: |u| beyond its divergence bound
    SPEED_W = 4  #: |w| beyond its divergence bound
    STEP = 5  #: the tolerance not met within ``max_steps`` steps of an interval


OK, NONFINITE, POSITION, SPEED_U, SPEED_W, STEP = (int(s) for s in Status)  # compiled code's

#: The per-run arrays of a call (row i: run i): ``state`` (B, 13); ``params`` (rows of
#: :data:`unidyn.model.equations.LOOP_PARAMETERS`); ``h``, the next step (carried across
#: intervals, 0 at first); ``noise_pos``, ``noise_vel`` (B, rows, 2), the held noise from
#: interval noise_first on; ``bounds`` (B, 3) on |(x, y)|, |u|, |w|; ``log_columns`` kept
#: of :data:`LOG_COLUMNS`; ``log`` (B, rows, columns); ``integrals`` (B, rows, 5), float64,
#: the metrics' integrals at each logged sample; ``acc`` (B, 7), float64, the integrals so
#: far and the last sample's error and squared speed (:func:`accumulate`); ``status``,
#: ``last`` (sample reached), ``steps`` (kept) and ``rejected`` (taken again shorter);
#: ``references``, the call's Python-function references (a tuple; empty compiled).
Runs = namedtuple("Runs", "state params h noise_pos noise_vel bounds log_columns log "
                          "integrals acc status last steps rejected references")
#: A call's numbers: ``Ts``; ``noise_first`` (the noise arrays' row 0); ``log_every``;
#: ``rtol``, ``atol``; ``max_steps`` (kept or not) an interval may take.
Call = namedtuple("Call", "Ts noise_first log_every rtol atol max_steps")


@jit(inline=True)
def check_state(X, bound):
    """The status of state X against bounds on [|(x, y)|, |u|, |w|]."""
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


# not cached itself (as dp_step): it takes the right-hand side as an argument
@jit(inline=True)
def integrate_interval(f, limits, t0, t1, X, h, args, call, K, y, Xn):
    """One run of dX/dt = f(t, X, args) from (t0, X) to t1 by error-controlled steps, X
    updated, the first step h (0: t1 - t0); after each step ``limits(X, args)``
    projects the state onto its constraints, returning whether it moved it (then f is
    evaluated again there). Returns (the next step, steps kept, steps rejected,
    ``OK``; or ``STEP``: the tolerance not met in ``call.max_steps`` steps;
    ``NONFINITE``: the last error estimate not a number)."""
    span = t1 - t0
    h = h if h > 0.0 else span
    f(t0, X, args, K[0])
    t, kept, rejected, proposal = t0, 0, 0, h
    again = False  # a step of this interval was taken again: grow no step after it
    while True:
        last = h >= t1 - t
        h = t1 - t if last else h
        err = dp_step(f, t, X, h, args, K, y, Xn, call.rtol, call.atol)
        if err <= 1.0:  # kept (an error estimate that is NaN is not)
            kept += 1
            factor = min(1.0, step_factor(err)) if again else step_factor(err)
            if not last:
                proposal = h * factor
            elif factor < 1.0:  # the interval's last step, cut to its end
                proposal = min(proposal, h * factor)
            moved = limits(Xn, args)
            for i in range(X.shape[0]):
                X[i] = Xn[i]
            if last:
                return proposal, kept, rejected, OK
            t = t + h
            if moved:  # f at the step's end was evaluated off the constraints
                f(t, X, args, K[0])
            else:
                for i in range(X.shape[0]):
                    K[0, i] = K[6, i]
            h = proposal
            again = False
        else:
            rejected += 1
            again = True
            h = h * step_factor(err) if err < math.inf else 0.5 * h  # NaN: halved
            proposal = h
        if kept + rejected >= call.max_steps or not h >= 1e-12 * span:
            return proposal, kept, rejected, STEP if err < math.inf else NONFINITE


@jit(entry="the batch engine")
def advance(runs, call, k0, k1, which):
    """Advance the runs ``which`` (indices into :data:`Runs`) over sample intervals
    k0..k1-1 (sample 0 logged and checked first where k0 = 0): interval k with its
    noise held, integrated afresh (:func:`integrate_interval`), the sample at its end
    accumulated into the metrics' integrals (:func:`accumulate`) and, every
    ``log_every``-th and where the run stops, logged with that noise, as the diagram
    logs it before the tick."""
    K, y, Xn, X, row = (np.empty((7, NSTATE)), np.empty(NSTATE), np.empty(NSTATE),
                        np.empty(NSTATE), np.empty(NLOG))
    Ts, L = call.Ts, call.log_every
    for i in which:
        for q in range(NSTATE):  # (a loop: an array assignment compiles its error messages)
            X[q] = runs.state[i, q]
        p, acc = runs.params[i], runs.acc[i]
        status, last, h = runs.status[i], runs.last[i], runs.h[i]
        steps = rejected = 0
        for k in range(k0, k1):
            r = k - call.noise_first
            noise = (runs.noise_pos[i, r, 0], runs.noise_pos[i, r, 1], runs.noise_vel[i, r, 0],
                     runs.noise_vel[i, r, 1])
            args = (p, noise, runs.references)
            if k == 0:
                sample_row(0.0, X, p, noise, runs.references, row)
                accumulate(0, Ts, row, acc)
                write_log(row, runs.log_columns, acc, runs.log[i, 0], runs.integrals[i, 0])
                status = check_state(X, runs.bounds[i])
            if status != OK:
                break
            h, kept, again, status = integrate_interval(loop_rhs, loop_limits, k * Ts,
                                                        (k + 1) * Ts, X, h, args, call, K, y, Xn)
            steps += kept
            rejected += again
            if status == OK:
                status = check_state(X, runs.bounds[i])
            elif status == NONFINITE:
                for q in range(NSTATE):
                    X[q] = math.nan
            if status == STEP:
                last = k
                break
            if status != NONFINITE:  # a sample beyond a divergence bound still counts
                sample_row((k + 1) * Ts, X, p, noise, runs.references, row)
                accumulate(k + 1, Ts, row, acc)
            if (k + 1) % L == 0 or status != OK:  # every L-th sample, and where a run stops
                j = (k + 1) // L + ((k + 1) % L != 0)
                if status == NONFINITE:
                    sample_row((k + 1) * Ts, X, p, noise, runs.references, row)
                write_log(row, runs.log_columns, acc, runs.log[i, j], runs.integrals[i, j])
            last = k + 1
        # written back once: threads advancing neighbouring runs never share a cache
        # line in the loop above
        for q in range(NSTATE):
            runs.state[i, q] = X[q]
        runs.status[i], runs.last[i], runs.h[i] = status, last, h
        runs.steps[i] += steps
        runs.rejected[i] += rejected
