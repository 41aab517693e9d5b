"""The batch engine's step rule, once: the Dormand-Prince 5(4) pair (the method of
``solve_ivp``'s RK45 and of bdsim's default solver) with step-size control over the
Fig. 2 loop, one run after another, restarted at every sample interval.

How a call runs, from the top:

- :func:`advance` takes runs, one after another, over sample intervals k0..k1-1 (the
  engine calls it from a thread per core, each with its own runs); each interval is
  integrated from its start to its end (:func:`integrate_interval`), then the state is
  checked and logged;
- :func:`integrate_interval` takes steps whose length error control chooses: a step
  is kept where its error estimate is within ``atol + rtol |x|`` (the root mean square
  over the states, as ``solve_ivp``'s), else taken again shorter;
- :func:`dp_step` is one step of the pair, for any right-hand side ``f(t, x, args, out)``:
  the table of coefficients (:data:`A`, :data:`B`, :data:`C`, :data:`E`) is the
  method.

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

__all__ = ["AVAILABLE", "compiled", "Runs", "Call", "LOG_COLUMNS", "LOG_SERIES",
           "log_layout", "reference", "loop_rates", "advance", "dp_step",
           "integrate_interval", "OK", "NONFINITE", "POSITION", "SPEED_U", "SPEED_W", "STEP"]

NSTATE = len(eq.STATE)

# ------------------------------------------------ Dormand-Prince 5(4), a table
# J. R. Dormand, P. J. Prince, A family of embedded Runge-Kutta formulae, J. Comp.
# Appl. Math. 6 (1980): stage s is evaluated at t + C[s] h from x + h sum_j A[s, j] K[j];
# B gives the fifth-order solution, E (seven weights, the last on f at the step's end)
# the difference between it and the embedded fourth-order one: the error estimate.
C = np.array([0.0, 1 / 5, 3 / 10, 4 / 5, 8 / 9, 1.0])
A = np.array([[0.0, 0.0, 0.0, 0.0, 0.0],
              [1 / 5, 0.0, 0.0, 0.0, 0.0],
              [3 / 40, 9 / 40, 0.0, 0.0, 0.0],
              [44 / 45, -56 / 15, 32 / 9, 0.0, 0.0],
              [19372 / 6561, -25360 / 2187, 64448 / 6561, -212 / 729, 0.0],
              [9017 / 3168, -355 / 33, 46732 / 5247, 49 / 176, -5103 / 18656]])
B = np.array([35 / 384, 0.0, 500 / 1113, 125 / 192, -2187 / 6784, 11 / 84])
E = np.array([-71 / 57600, 0.0, 71 / 16695, -71 / 1920, 17253 / 339200, -22 / 525, 1 / 40])
#: Step-size control, as scipy's: the next step is h * SAFETY * err^(-1/5), by a factor
#: within [MIN_FACTOR, MAX_FACTOR].
SAFETY, MIN_FACTOR, MAX_FACTOR = 0.9, 0.2, 10.0


# not cached itself: numba's cache index records a signature's types by their module, and
# a right-hand side defined in a script or a test would then break the index of every
# other process that loads it (its callers are cached, with its code in them)
@jit(inline=True, cache=False)
def dp_step(f, t, x, h, args, K, y, out, rtol, atol):
    """One Dormand-Prince step of length h from (t, x) of dx/dt = f(t, x, args) (f
    writes its rates into its last argument). K[0] holds f(t, x) on entry; K[1..6]
    receive the other stages, K[6] = f(t + h, out) (the next step's first, where this
    one is kept); y is scratch of x's length. Writes the fifth-order solution into out
    and returns the error estimate relative to the tolerance, as ``solve_ivp`` measures
    it: the root mean square over the states of error / (atol + rtol max(|x|, |out|));
    the step is accurate enough where it is at most 1."""
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
    """The Fig. 2 loop's dX/dt (:func:`unidyn.model.equations.loop_rates`) of one run
    at time t into out. args = (p, noise): a row of the parameter table
    (:data:`unidyn.model.equations.LOOP_PARAMETERS`) and the interval's held noise
    (position x, y, velocity u, w)."""
    p, noise = args
    d = eq.loop_rates(t, X, reference(t, p), p, noise)
    for i in range(NSTATE):
        out[i] = d[i]


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
#: |(x, y)|, |u| or |w| beyond its divergence bound, the tolerance not met within
#: ``max_steps`` steps of an interval.
OK, NONFINITE, POSITION, SPEED_U, SPEED_W, STEP = 0, 1, 2, 3, 4, 6

#: The per-run arrays of a call (row i: run i): ``state`` (B, 13), updated;
#: ``params``: rows of the parameter table (:data:`unidyn.model.equations.LOOP_PARAMETERS`);
#: ``h`` (B,): the step error control proposes next (carried from one interval to the
#: next, 0 before the first); ``noise_pos``, ``noise_vel`` (B, rows, 2): the held noise
#: of intervals noise_first, noise_first + 1, ...; ``bounds`` (B, 3): divergence bounds
#: on |(x, y)|, |u|, |w|; ``log_columns``: the columns of :data:`LOG_COLUMNS` kept;
#: ``log`` (B, rows, columns); and what the engine fills: ``status`` (OK while running),
#: ``last`` (last sample reached), ``steps`` (steps kept), ``rejected`` (steps taken
#: again shorter), ``most`` (most steps an interval took).
Runs = namedtuple("Runs", "state params h noise_pos noise_vel bounds log_columns log "
                          "status last steps rejected most")
#: The numbers of a call: sample interval ``Ts``; ``noise_first``, the interval of the
#: noise arrays' row 0; ``log_every``; the tolerances ``rtol``, ``atol``; ``max_steps``,
#: the most steps (kept or not) an interval may take.
Call = namedtuple("Call", "Ts noise_first log_every rtol atol max_steps")


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


@jit
def integrate_interval(t0, t1, X, h, args, call, K, y, Xn):
    """Integrate the loop of one run from (t0, X) to t1 with error-controlled steps, X
    updated in place, starting with a step of h (at most t1 - t0; 0: t1 - t0). A speed
    limit is hard: a step that would end beyond it ends on it.
    Returns (the step proposed for what follows, steps kept, steps rejected, OK; or
    STEP where the tolerance was not met within ``call.max_steps`` steps, NONFINITE
    where the last error estimate was not a number: the loop left the model's range)."""
    p = args[0]
    span = t1 - t0
    if not h > 0.0:
        h = span
    loop_rates(t0, X, args, K[0])
    t = t0
    kept = 0
    rejected = 0
    again = False  # a step of this interval was taken again: grow no step after it
    proposal = h
    while True:
        last = h >= t1 - t
        if last:
            h = t1 - t
        err = dp_step(loop_rates, t, X, h, args, K, y, Xn, call.rtol, call.atol)
        if err <= 1.0:  # kept (an error estimate that is NaN is not)
            kept += 1
            factor = min(1.0, step_factor(err)) if again else step_factor(err)
            if not last:
                proposal = h * factor
            elif factor < 1.0:  # the interval's last step, cut to its end
                proposal = min(proposal, h * factor)
            u = eq.saturate(Xn[S.u], p[P.speed_u])
            w = eq.saturate(Xn[S.w], p[P.speed_w])
            clipped = u != Xn[S.u] or w != Xn[S.w]
            Xn[S.u] = u
            Xn[S.w] = w
            for i in range(X.shape[0]):
                X[i] = Xn[i]
            if last:
                return proposal, kept, rejected, OK
            t = t + h
            if clipped:  # f at the step's end was evaluated beyond the limit
                loop_rates(t, X, args, K[0])
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
    k0..k1-1, with the numbers of :data:`Call` (sample 0 logged and checked first where
    k0 = 0). Interval k's noise is held over it, the integration restarted at its
    start (:func:`integrate_interval`), and the sample at its end is logged with it,
    as the diagram logs it before the tick. A run whose interval cannot meet the
    tolerance stops with status STEP."""
    K = np.empty((7, NSTATE))
    y = np.empty(NSTATE)
    Xn = np.empty(NSTATE)
    X = np.empty(NSTATE)
    row = np.empty(NLOG)
    Ts = call.Ts
    for i in which:
        for q in range(NSTATE):  # (a loop: an array assignment compiles its error messages)
            X[q] = runs.state[i, q]
        p = runs.params[i]
        status, last, h = runs.status[i], runs.last[i], runs.h[i]
        steps = 0
        rejected = 0
        most = runs.most[i]
        for k in range(k0, k1):
            r = k - call.noise_first
            noise = (runs.noise_pos[i, r, 0], runs.noise_pos[i, r, 1], runs.noise_vel[i, r, 0],
                     runs.noise_vel[i, r, 1])
            if k == 0:
                log_row(0.0, X, p, noise, runs.log_columns, row, runs.log[i, 0])
                status = check_state(X, runs.bounds[i])
            if status != OK:
                break
            h, kept, again, status = integrate_interval(k * Ts, (k + 1) * Ts, X, h, (p, noise),
                                                        call, K, y, Xn)
            steps += kept
            rejected += again
            most = max(most, kept + again)
            if status == OK:
                status = check_state(X, runs.bounds[i])
            elif status == NONFINITE:
                for q in range(NSTATE):
                    X[q] = math.nan
            if status == STEP:
                last = k
                break
            index = log_index(k + 1, call.log_every, status != OK)
            if index >= 0:
                log_row((k + 1) * Ts, X, p, noise, runs.log_columns, row, runs.log[i, index])
            last = k + 1
        # written back once: threads advancing neighbouring runs never share a cache
        # line in the loop above
        for q in range(NSTATE):
            runs.state[i, q] = X[q]
        runs.status[i], runs.last[i], runs.h[i], runs.most[i] = status, last, h, most
        runs.steps[i] += steps
        runs.rejected[i] += rejected


def compiled() -> bool:
    """Whether the engine was compiled (or loaded) in this process or lies compiled in
    the cache folder (:class:`unidyn.engine.jit.Compiled`)."""
    return AVAILABLE and advance.compiled()
