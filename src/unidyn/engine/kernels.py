"""The batch engine's step rule, once: classical RK4 (Runge-Kutta, fourth order) over
the Fig. 2 loop, one run after another.

How a call runs, from the top:

- :func:`advance` takes runs, one after another, over sample intervals k0..k1-1 (the
  engine calls it from a thread per core, each with its own runs): it checks the loop's
  rate at each interval's start and takes ``steps`` RK4 steps, or more where the loop is
  faster than they resolve; it checks the state and logs it after each interval;
- :func:`loop_step` takes one RK4 step of the loop, split where it crosses a change of
  the speed and acceleration limits (a kink or a jump of the right-hand side);
- :func:`rk4_stages`, :func:`rk4_advance` and :func:`rk4_dense` are RK4 itself, for any
  right-hand side ``f(t, x, args, out)``: the loop's (:func:`loop_rates`) here, the
  robot's Eq. (2) under logged commands in :mod:`unidyn.identification`.

numba compiles this module where it is installed (:mod:`unidyn.engine.jit`);
:func:`unidyn.engine.jit.plain_copy` runs the same source as plain Python.
"""

from __future__ import annotations

import math
from collections import namedtuple

import numpy as np

from ..model import equations as eq
from ..model.equations import P, S
from .jit import AVAILABLE, jit

if AVAILABLE:
    from numba.extending import overload

__all__ = ["AVAILABLE", "compiled", "Runs", "Call", "Work", "LOG_COLUMNS", "LOG_SERIES",
           "log_layout", "reference", "loop_rates", "advance", "rk4_stages", "rk4_advance",
           "rk4_dense", "OK", "NONFINITE", "POSITION", "SPEED_U", "SPEED_W", "STEP"]

NSTATE = len(eq.STATE)
#: The entry of :func:`loop_rates`' output after the 13 rates: which limits act there
#: (:func:`unidyn.model.equations.limit_state`), which tells where a step crosses a change.
CODE = NSTATE


# ---------------------------------------------------------------------- RK4
# not cached itself: numba's cache index records a signature's types by their module, and
# a right-hand side defined in a script or a test would then break the index of every
# other process that loads it (its callers are cached, with its code in them)
@jit(inline=True, cache=False)
def rk4_stages(f, t, x, h, args, K, y):
    """The four stages of the RK4 step of length h from (t, x) of dx/dt = f(t, x, args)
    into the rows K[0..3] (f writes its rates into its last argument, and may write
    more entries than x has); y is scratch of x's length."""
    n = x.shape[0]
    f(t, x, args, K[0])
    for i in range(n):
        y[i] = x[i] + 0.5 * h * K[0, i]
    f(t + 0.5 * h, y, args, K[1])
    for i in range(n):
        y[i] = x[i] + 0.5 * h * K[1, i]
    f(t + 0.5 * h, y, args, K[2])
    for i in range(n):
        y[i] = x[i] + h * K[2, i]
    f(t + h, y, args, K[3])


@jit(inline=True)
def rk4_advance(x, h, K):
    """x += h / 6 (k1 + 2 k2 + 2 k3 + k4): the step from the stages K, in place."""
    c = h / 6.0
    for i in range(x.shape[0]):
        x[i] += c * (K[0, i] + 2.0 * K[1, i] + 2.0 * K[2, i] + K[3, i])


@jit(inline=True)
def rk4_dense(x, h, K, theta, out):
    """RK4's continuous extension (third order): the state at t + theta h within the
    step of length h from (t, x) with stages K, into out."""
    c = 2.0 / 3.0
    b1 = theta * (1.0 + theta * (-1.5 + theta * c))
    b2 = theta * theta * (1.0 - theta * c)
    b4 = theta * theta * (-0.5 + theta * c)
    for i in range(x.shape[0]):
        out[i] = x[i] + h * (b1 * K[0, i] + b2 * (K[1, i] + K[2, i]) + b4 * K[3, i])


# ------------------------------------------------------------- the Fig. 2 loop
#: The references that are Python functions (:class:`~unidyn.model.trajectories.FunctionTrajectory`,
#: trajectory code -1, their index in path1), set by the engine before it runs them: the
#: plain copy of this module evaluates them; the compiled one runs only the built-in ones.
PYTHON_REFERENCES = []


def python_reference(t, index):
    """(x_d, y_d, x_d', y_d', x_d'', y_d'') of reference ``PYTHON_REFERENCES[index]``."""
    tr = PYTHON_REFERENCES[int(index)]
    (x, y), (dx, dy), (ddx, ddy) = tr.evaluate(t)
    return float(x), float(y), float(dx), float(dy), float(ddx), float(ddy)


if AVAILABLE:
    @overload(python_reference)
    def _python_reference_compiled(t, index):
        """Compiled code cannot call the Python function: NaN (never run, the engine
        sends such runs to the plain copy)."""
        return lambda t, index: (math.nan, math.nan, math.nan, math.nan, math.nan, math.nan)


@jit(inline=True)
def reference(t, p):
    """(x_d, y_d, x_d', y_d', x_d'', y_d'') of the run with parameters p at time t."""
    kind = p[P.trajectory]
    if kind < 0.0:
        return python_reference(t, p[P.path1])
    if kind == 0.0:
        return eq.figure_eight(t, p[P.path1], p[P.path2], p[P.path3], p[P.path4],
                               p[P.path5], p[P.path6])
    if kind == 1.0:
        return eq.circle(t, p[P.path1], p[P.path2], p[P.path3], p[P.path4], p[P.path5])
    return eq.line(t, p[P.path1], p[P.path2], p[P.path3], p[P.path4])


@jit
def loop_rates(t, X, args, out):
    """The Fig. 2 loop's dX/dt (:func:`unidyn.model.equations.loop_rates_and_limits`)
    of one run at time t into out[:13], and which limits act there into out[13]
    (where out is longer). args = (p, noise): a row of the parameter table
    (:data:`unidyn.model.equations.LOOP_PARAMETERS`) and the interval's held noise
    (position x, y, velocity u, w)."""
    p, noise = args
    d, code = eq.loop_rates_and_limits(t, X, reference(t, p), p, noise)
    for i in range(NSTATE):
        out[i] = d[i]
    if out.shape[0] > NSTATE:
        out[CODE] = code


#: Scratch arrays of one thread: ``stages`` (4, 14), ``y`` (13,), ``probe`` (14,),
#: ``x`` (13,): the run's state while it is advanced, ``row``: a full log row.
Work = namedtuple("Work", "stages y probe x row")


@jit
def loop_step(t0, X, h, depth, args, w):
    """One RK4 step of the loop of length h from (t0, X), X updated in place. Where the
    stages disagree on which limits act (:data:`CODE`), the step crosses a kink or a
    jump of the right-hand side, where RK4 is only first or second order accurate:
    the change is located by bisection to a part of 2^-depth of the step, each probe
    one right-hand side at RK4's continuous extension (:func:`rk4_dense`), and the
    step up to that part, the part and the rest are steps of their own, each checked
    again. A speed limit is hard: a step that would end beyond it ends on it.
    Returns (RK4 steps computed, changes located)."""
    K, y, probe = w.stages, w.y, w.probe
    p = args[0]
    parts = 1 << depth  # the step's length in units of its finest part
    part = h / parts
    steps = 0
    located = 0
    pos = 0  # the parts done
    end = parts  # the parts the next step reaches
    klo = -1  # a located part: from klo to khi
    khi = -1
    while pos < parts:
        t = t0 + pos * part
        hh = (end - pos) * part
        rk4_stages(loop_rates, t, X, hh, args, K, y)
        steps += 1
        c1 = K[0, CODE]
        if end - pos > 1 and (c1 != K[1, CODE] or c1 != K[2, CODE] or c1 != K[3, CODE]):
            located += 1
            lo = pos
            hi = end
            while hi - lo > 1:
                q = (lo + hi) // 2
                rk4_dense(X, hh, K, (q - pos) / (end - pos), y)
                loop_rates(t0 + q * part, y, args, probe)
                if probe[CODE] == c1:
                    lo = q
                else:
                    hi = q
            if lo > pos:  # up to the part first, then the part
                end = lo
                klo = lo
                khi = hi
            else:
                end = hi
            continue
        rk4_advance(X, hh, K)
        X[S.u] = eq.saturate(X[S.u], p[P.speed_u])
        X[S.w] = eq.saturate(X[S.w], p[P.speed_w])
        pos = end
        end = khi if pos == klo else parts
    return steps, located


@jit
def split_depth(m, parts):
    """How finely a step of Ts / m that crosses a change of the limits is split: into
    2^depth parts, each at most Ts / parts long (with parts = 160: depth 4 at 10 steps
    per sample, 0, not split, from 160 on)."""
    d = 0
    while (m << d) < parts:
        d += 1
    return d


# -------------------------------------------------------------------- the log
#: The columns of the log, in order: the states the result keeps (pose, robot
#: velocity, theta_hat: the first 11 of :data:`unidyn.model.equations.STATE`; a kinematic
#: robot, which has no velocity state, moves at its clipped command), then h_d,
#: v_d and v_ref (after the speed limits).
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
    """The log of a run that keeps the named series (:data:`LOG_SERIES` keys): (the
    columns of :data:`LOG_COLUMNS` it keeps, as an index array; where each kept series
    lies in its rows)."""
    keep, where = [], {}
    for k, sl in LOG_SERIES.items():  # in the order of the columns
        if k in series:
            columns = range(NLOG)[sl]
            where[k] = slice(len(keep), len(keep) + len(columns))
            keep += columns
    return np.array(keep, dtype=np.int64), where


@jit
def log_row(t, X, p, noise, columns, row, out):
    """The log row (:data:`LOG_COLUMNS`) at (t, X) into the scratch row, and its kept
    columns into out (whatever out's floating dtype)."""
    for i in range(11):
        row[i] = X[i]
    ref = reference(t, p)
    ud, wd, udd, wdd, G, u_ref, w_ref, um, wm = eq.loop_signals(X, ref, p, noise)
    row[11] = ref[0]
    row[12] = ref[1]
    row[13] = ud
    row[14] = wd
    row[15] = eq.saturate(u_ref, p[P.speed_u])
    row[16] = eq.saturate(w_ref, p[P.speed_w])
    if p[P.dynamic] == 0.0:  # a kinematic robot moves at its clipped command
        row[S.u] = row[15]
        row[S.w] = row[16]
    for j in range(columns.shape[0]):
        out[j] = row[columns[j]]


# ------------------------------------------------------------------- the runs
#: Why a run stopped (``status``): still running / complete, a non-finite state,
#: |(x, y)|, |u| or |w| beyond its divergence bound, the loop faster than the finest
#: step allowed resolves.
OK, NONFINITE, POSITION, SPEED_U, SPEED_W, STEP = 0, 1, 2, 3, 4, 6

#: The per-run arrays of a call (row i: run i): ``state`` (B, 13), updated;
#: ``params``: rows of the parameter table (:data:`unidyn.model.equations.LOOP_PARAMETERS`);
#: ``steps`` (B,): RK4 steps per interval;
#: ``noise_pos``, ``noise_vel`` (B, rows, 2): the held noise of intervals
#: noise_first, noise_first + 1, ...; ``bounds`` (B, 3): divergence bounds on |(x, y)|,
#: |u|, |w|; ``rate_max`` (B,): the fastest loop rate the step resolves (inf: not
#: checked); ``log_columns``: the columns of :data:`LOG_COLUMNS` kept; ``log`` (B, rows,
#: columns); and what the engine fills: ``status`` (OK while running), ``last`` (last
#: sample reached), ``fastest`` (fastest rate met), ``most_steps`` (most steps an
#: interval took), ``rk4_steps`` (RK4 steps computed), ``splits`` (changes of the
#: limits located).
Runs = namedtuple("Runs", "state params steps noise_pos noise_vel bounds rate_max "
                          "log_columns log status last fastest most_steps rk4_steps splits")
#: The numbers of a call: sample interval ``Ts``; ``noise_first``, the interval of the
#: noise arrays' row 0; ``log_every``; an interval
#: taken finer uses ceil(Ts rate / ``refined_rate``) steps, at most ``max_steps``; a
#: change of the limits is located to Ts / ``split_parts`` (:func:`split_depth`).
Call = namedtuple("Call", "Ts noise_first log_every refined_rate max_steps split_parts")


@jit(inline=True)
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


@jit(inline=True)
def log_index(k, L, stopped):
    """Row of the log for sample k (every L-th sample, plus the sample a run stopped
    at); -1 when sample k is not logged."""
    if k % L == 0:
        return k // L
    if stopped:
        return k // L + 1
    return -1


@jit(entry="the batch engine")
def advance(runs, call, k0, k1, which):
    """Advance the runs ``which`` (indices into :data:`Runs`) over sample intervals
    k0..k1-1, with the numbers of :data:`Call` (sample 0 logged and checked first where
    k0 = 0). Where a compensated run's loop is faster at an interval's start
    (:func:`unidyn.model.equations.loop_step_rate`) than ``rate_max``, that interval
    takes ceil(Ts rate / refined_rate) steps instead of ``steps``, or the run stops
    with status STEP beyond max_steps. Interval k's noise is held over it, and the
    sample at its end is logged with it, as the diagram logs it before the tick."""
    w = Work(np.empty((4, NSTATE + 1)), np.empty(NSTATE), np.empty(NSTATE + 1),
             np.empty(NSTATE), np.empty(NLOG))
    X = w.x
    Ts = call.Ts
    for i in which:
        for q in range(NSTATE):  # (a loop: an array assignment compiles its error messages)
            X[q] = runs.state[i, q]
        p = runs.params[i]
        status, last = runs.status[i], runs.last[i]
        fastest, most = runs.fastest[i], runs.most_steps[i]
        work = 0
        splits = 0
        for k in range(k0, k1):
            r = k - call.noise_first
            noise = (runs.noise_pos[i, r, 0], runs.noise_pos[i, r, 1], runs.noise_vel[i, r, 0],
                     runs.noise_vel[i, r, 1])
            if k == 0:
                log_row(0.0, X, p, noise, runs.log_columns, w.row, runs.log[i, 0])
                status = check_state(X, runs.bounds[i])
            if status != OK:
                break
            t = k * Ts
            m = runs.steps[i]
            if runs.rate_max[i] != np.inf:
                rate = eq.loop_step_rate(t, X, reference(t, p), p, noise)
                fastest = max(fastest, rate)
                if rate > runs.rate_max[i]:
                    need = Ts * rate / call.refined_rate
                    if not need <= call.max_steps:
                        status, last = STEP, k
                        break
                    m = math.ceil(need)
                    most = max(most, m)
            depth = split_depth(m, call.split_parts)
            h = Ts / m
            for j in range(m):
                done, located = loop_step(t + j * h, X, h, depth, (p, noise), w)
                work += done
                splits += located
            status = check_state(X, runs.bounds[i])
            row = log_index(k + 1, call.log_every, status != OK)
            if row >= 0:
                log_row((k + 1) * Ts, X, p, noise, runs.log_columns, w.row, runs.log[i, row])
            last = k + 1
        # written back once: threads advancing neighbouring runs never share a cache
        # line in the loop above
        for q in range(NSTATE):
            runs.state[i, q] = X[q]
        runs.status[i], runs.last[i] = status, last
        runs.fastest[i], runs.most_steps[i] = fastest, most
        runs.rk4_steps[i] += work
        runs.splits[i] += splits


def compiled() -> bool:
    """Whether the engine was compiled (or loaded) in this process or lies compiled in
    the cache folder (:class:`unidyn.engine.jit.Compiled`)."""
    return AVAILABLE and advance.compiled()
