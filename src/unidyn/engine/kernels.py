"""The batch engine's step rule, once: RK4 over the Fig. 2 loop for runs side by side.

The right-hand side is :func:`unidyn.model.equations.loop_rates_and_limits` for one run's
values; the per-run parameters are the rows of the named table
:data:`unidyn.model.equations.LOOP_PARAMETERS`. How a call runs, from the top:

- :func:`run_groups` hands each group of up to :data:`LANES` runs (same steps per
  sample, same reference) to a thread; :func:`_run_group` takes it over the sample
  intervals, logging and checking each run (:func:`check_state`);
- :func:`_interval_steps` checks each run's loop rate at an interval's start; a run
  too fast for the group's step takes that interval again alone, finer
  (:func:`_lane_alone`);
- :func:`_steps_lanes` takes the RK4 steps (:func:`_stages`, :func:`_step`); a run's
  step across a change of the limits is taken again alone, split where the change is
  (:func:`_split`).

A group's values are stored lane-minor (value i of lane b at [i * LANES + b]), so the
compiler turns the loop over lanes into vector instructions; lanes never mix, and a
run's numbers are the same bit for bit whichever runs share its group. The module is
compiled by numba where installed (:mod:`unidyn.engine.jit`); :func:`unidyn.engine.jit.plain_copy`
runs the same source as plain Python.
"""

from __future__ import annotations

import math
from collections import namedtuple

import numpy as np

from ..model import equations as eq
from .jit import AVAILABLE, jit, prange

if AVAILABLE:
    from numba.extending import overload
from ..model.equations import P, S

__all__ = ["AVAILABLE", "compiled", "Groups", "Runs", "Call", "LOG_COLUMNS", "reference", "rhs", "run_groups", "start", "LANES", "OK", "NONFINITE",
           "POSITION", "SPEED_U", "SPEED_W", "INTERRUPTED", "STEP"]

NSTATE = len(eq.STATE)
#: The rows of an RK4 stage: the 13 rates, then (row CODE) which limits act there
#: (:func:`unidyn.model.equations.limit_state`), which tells where a step crosses a change.
CODE = NSTATE
NSTAGE = NSTATE + 1


#: The references that are Python functions (:class:`~unidyn.model.trajectories.FunctionTrajectory`,
#: trajectory code -1, their index in path1), set by the engine before it runs them: the
#: plain copy of this module evaluates them (:func:`unidyn.engine.jit.plain_copy`); the
#: compiled one runs only the built-in trajectories.
PYTHON_REFERENCES = []


def python_reference(t, index):
    """(x_d, y_d, x_d', y_d', x_d'', y_d'') of reference ``PYTHON_REFERENCES[index]``."""
    tr = PYTHON_REFERENCES[int(index)]
    (x, y), (dx, dy), (ddx, ddy) = tr.position(t), tr.velocity(t), tr.acceleration(t)
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
def rhs(t, X, p, noise, dX):
    """dX/dt of one run (X, dX: (13,), p: a row of the parameter table), as the
    engine integrates it."""
    eq.loop_derivative(t, X, reference(t, p), p, noise, dX)


#: The columns of the log, in order: the states the result keeps (pose, robot
#: velocity, theta_hat: the first 11 of :data:`unidyn.model.equations.STATE`; a kinematic
#: robot, which has no velocity state, moves at its clipped command), then h_d,
#: v_d and v_ref (after the speed limits). Nothing else is logged.
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
    """The log of a run that keeps the named series (:data:`LOG_SERIES` keys; the
    others are not stored): (the columns of :data:`LOG_COLUMNS` it keeps, in order,
    as an index array; where each kept series lies in its rows)."""
    keep, where = [], {}
    for k, sl in LOG_SERIES.items():  # in the order of the columns
        if k in series:
            columns = range(NLOG)[sl]
            where[k] = slice(len(keep), len(keep) + len(columns))
            keep += columns
    return np.array(keep, dtype=np.int64), where


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
    dynamic = p[P.dynamic] != 0.0  # else the robot moves at its clipped command
    out[S.u] = eq.select(dynamic, X[S.u], out[15])
    out[S.w] = eq.select(dynamic, X[S.w], out[16])


# ------------------------------------------------------------------ runs in lanes
#: Runs integrated side by side by one thread: the compiled loop over them is
#: vectorised (SIMD), so up to LANES runs share each instruction. A group's values
#: are stored lane-minor, value i of lane b at [i * LANES + b]: the offsets are
#: constants, which lets the compiler prove that lanes do not overlap.
LANES = 8
NPARAM = len(eq.LOOP_PARAMETERS)
#: Zeros the size of a stage's lanes (the first stage's increment).
ZERO = np.zeros((len(eq.STATE) + 1) * LANES)


#: The tuples below are written out (numba keeps a tuple of floats in registers and
#: has no tuple comprehension); tests/engine/test_kernels.py checks them against the
#: lengths of :data:`unidyn.model.equations.STATE` and :data:`~unidyn.model.equations.LOOP_PARAMETERS`.
@jit(inline=True)
def _lane_state(A, b):
    """Lane b of a group's state (lane-minor), as a tuple."""
    L = LANES
    return (A[0 * L + b], A[1 * L + b], A[2 * L + b], A[3 * L + b], A[4 * L + b],
            A[5 * L + b], A[6 * L + b], A[7 * L + b], A[8 * L + b], A[9 * L + b],
            A[10 * L + b], A[11 * L + b], A[12 * L + b])


@jit(inline=True)
def _lane_params(A, b):
    """Lane b of a group's parameters (lane-minor), as a tuple."""
    L = LANES
    return (A[0 * L + b], A[1 * L + b], A[2 * L + b], A[3 * L + b], A[4 * L + b],
            A[5 * L + b], A[6 * L + b], A[7 * L + b], A[8 * L + b], A[9 * L + b],
            A[10 * L + b], A[11 * L + b], A[12 * L + b], A[13 * L + b], A[14 * L + b],
            A[15 * L + b], A[16 * L + b], A[17 * L + b], A[18 * L + b], A[19 * L + b],
            A[20 * L + b], A[21 * L + b], A[22 * L + b], A[23 * L + b], A[24 * L + b],
            A[25 * L + b], A[26 * L + b], A[27 * L + b], A[28 * L + b], A[29 * L + b],
            A[30 * L + b], A[31 * L + b], A[32 * L + b], A[33 * L + b], A[34 * L + b],
            A[35 * L + b], A[36 * L + b], A[37 * L + b], A[38 * L + b], A[39 * L + b],
            A[40 * L + b], A[41 * L + b], A[42 * L + b])


@jit(inline=True)
def _axpy(X, a, D):
    """X + a D, value by value (the stages of RK4)."""
    return (X[0] + a * D[0], X[1] + a * D[1], X[2] + a * D[2], X[3] + a * D[3],
            X[4] + a * D[4], X[5] + a * D[5], X[6] + a * D[6], X[7] + a * D[7],
            X[8] + a * D[8], X[9] + a * D[9], X[10] + a * D[10], X[11] + a * D[11],
            X[12] + a * D[12])


@jit(inline=True)
def _rk4(X, h, d1, d2, d3, d4):
    """RK4's step, X + h / 6 (d1 + 2 d2 + 2 d3 + d4), value by value."""
    c = h / 6.0
    return (X[0] + c * (d1[0] + 2.0 * d2[0] + 2.0 * d3[0] + d4[0]),
            X[1] + c * (d1[1] + 2.0 * d2[1] + 2.0 * d3[1] + d4[1]),
            X[2] + c * (d1[2] + 2.0 * d2[2] + 2.0 * d3[2] + d4[2]),
            X[3] + c * (d1[3] + 2.0 * d2[3] + 2.0 * d3[3] + d4[3]),
            X[4] + c * (d1[4] + 2.0 * d2[4] + 2.0 * d3[4] + d4[4]),
            X[5] + c * (d1[5] + 2.0 * d2[5] + 2.0 * d3[5] + d4[5]),
            X[6] + c * (d1[6] + 2.0 * d2[6] + 2.0 * d3[6] + d4[6]),
            X[7] + c * (d1[7] + 2.0 * d2[7] + 2.0 * d3[7] + d4[7]),
            X[8] + c * (d1[8] + 2.0 * d2[8] + 2.0 * d3[8] + d4[8]),
            X[9] + c * (d1[9] + 2.0 * d2[9] + 2.0 * d3[9] + d4[9]),
            X[10] + c * (d1[10] + 2.0 * d2[10] + 2.0 * d3[10] + d4[10]),
            X[11] + c * (d1[11] + 2.0 * d2[11] + 2.0 * d3[11] + d4[11]),
            X[12] + c * (d1[12] + 2.0 * d2[12] + 2.0 * d3[12] + d4[12]))


@jit(inline=True)
def _lane_noise(NL, b):
    """Lane b of a group's noise for the interval (position x, y, velocity u, w)."""
    return NL[b], NL[LANES + b], NL[2 * LANES + b], NL[3 * LANES + b]


#: A group of up to LANES runs, lane-minor: ``state`` (13 * LANES), ``params``
#: (NPARAM * LANES), ``noise`` (4 * LANES: this interval's position x, y and velocity
#: u, w noise), ``count``: the lanes in use. The engine's scratch group (one run taken
#: alone) is one too, with count 1.
Lanes = namedtuple("Lanes", "state params noise count")
#: Every group of a call: ``state`` (G, 13 * LANES), ``params`` (G, NPARAM * LANES),
#: ``runs`` (G, LANES): run index of each lane, ``count`` (G,): lanes used, ``steps``
#: (G,): RK4 steps per sample interval.
Groups = namedtuple("Groups", "state params runs count steps")
#: The per-run arrays of a call (row i: run i): ``params`` (B, NPARAM);
#: ``noise_pos``, ``noise_vel`` (B, rows, 2): the noise of intervals noise_first,
#: noise_first + 1, ...; ``bounds`` (B, 3): divergence bounds on |(x, y)|, |u|, |w|;
#: ``rate_max`` (B,): the fastest loop rate the step resolves (inf: not checked);
#: ``log_columns``: the columns of :data:`LOG_COLUMNS` kept; ``log`` (B, rows,
#: len(log_columns)); and what the engine fills: ``status`` (why it stopped, OK while
#: it runs), ``last`` (last sample reached), ``fastest`` (fastest rate met),
#: ``most_steps`` (most steps an interval took), ``rk4_steps`` (RK4 steps computed),
#: ``splits`` (steps split at a change of the limits).
Runs = namedtuple("Runs", "params noise_pos noise_vel bounds rate_max log_columns log status "
                          "last fastest most_steps rk4_steps splits")
#: The numbers of a call: sample interval ``Ts``; ``noise_first``, the interval of the
#: noise arrays' row 0; ``samples``, the run's intervals; ``log_every``; an interval
#: taken finer uses ceil(Ts rate / ``refined_rate``) steps, at most ``max_steps``; a
#: change of the limits is located to Ts / ``split_parts`` (:func:`split_depth`).
Call = namedtuple("Call", "Ts noise_first samples log_every refined_rate max_steps split_parts")
#: A group's work arrays: ``stages`` (4, NSTAGE * LANES), ``crossed`` (LANES,): 1 where a
#: lane's step crossed a change of the limits, ``before``: the state before the step;
#: for a lane taken alone (:func:`_split`): ``alone`` (a :class:`Lanes` of count 1),
#: ``alone_stages`` (4, NSTAGE * LANES), ``probe`` (2, NSTAGE * LANES), ``alone_crossed``;
#: ``extra_steps`` and ``located`` (LANES,): per lane, the RK4 steps of its splits and
#: the changes located, this interval.
Work = namedtuple("Work", "stages crossed before alone alone_stages probe alone_crossed "
                          "extra_steps located")


@jit
def _stage(t, ref, lanes, a, DL, out):
    """One RK4 stage for the lanes in use: out = the loop's rates at state + a DL, time
    t, reference ref (all lane-minor).
    Compiled once and called for the four stages: the equations are inlined into
    this one loop, which the compiler vectorises over the lanes."""
    XL, PL, NL = lanes.state, lanes.params, lanes.noise
    for b in range(lanes.count):
        X = _axpy(_lane_state(XL, b), a, _lane_state(DL, b))
        d, code = eq.loop_rates_and_limits(t, X, ref, _lane_params(PL, b), _lane_noise(NL, b))
        for i in range(NSTATE):
            out[i * LANES + b] = d[i]
        out[CODE * LANES + b] = code


@jit(inline=True)
def _limit_changes(D, b):
    """Whether the four stages D of lane b's RK4 step disagree on which limits act on
    the robot's accelerations and its command (:func:`unidyn.model.equations.limit_state`,
    in the stages' row CODE): the step then crosses a kink or a jump of the
    right-hand side."""
    c = CODE * LANES + b
    c1 = D[0][c]
    return (c1 != D[1][c]) | (c1 != D[2][c]) | (c1 != D[3][c])


@jit
def _step(lanes, h, D, crossed):
    """RK4's step from the four stages D, X + h / 6 (d1 + 2 d2 + 2 d3 + d4), for the
    lanes in use; the speeds end on their limits where the step crosses one.
    crossed[b] is set to 1 where lane b's step crosses a change of the limits
    (:func:`_limit_changes`), else 0."""
    XL, PL = lanes.state, lanes.params
    for b in range(lanes.count):
        X = _rk4(_lane_state(XL, b), h, _lane_state(D[0], b), _lane_state(D[1], b),
                 _lane_state(D[2], b), _lane_state(D[3], b))
        for i in range(NSTATE):
            XL[i * LANES + b] = X[i]
        XL[S.u * LANES + b] = eq.saturate(X[S.u], PL[P.speed_u * LANES + b])
        XL[S.w * LANES + b] = eq.saturate(X[S.w], PL[P.speed_w * LANES + b])
        crossed[b] = eq.select(_limit_changes(D, b), 1.0, 0.0)


@jit(inline=True)
def _stages(t, h, lanes, p0, D):
    """RK4's four stages of the step of length h from t for the lanes in use into
    D[0..3]; the reference (p0's) is evaluated once a stage for all lanes."""
    r2 = reference(t + 0.5 * h, p0)
    # the first stage at the state itself: state + 0 * ZERO (one compiled stage serves all
    # four; a flag would be compiled once for each of its values)
    _stage(t, reference(t, p0), lanes, 0.0, ZERO, D[0])
    _stage(t + 0.5 * h, r2, lanes, 0.5 * h, D[0], D[1])
    _stage(t + 0.5 * h, r2, lanes, 0.5 * h, D[1], D[2])
    _stage(t + h, reference(t + h, p0), lanes, h, D[2], D[3])


@jit
def split_depth(m, parts):
    """In how fine parts a step of Ts / m that crosses a change of the limits on the
    robot's accelerations is located (one starts or stops clipping, or a speed limit
    is reached: a kink or a jump of the right-hand side, where RK4 is only first or
    second order accurate): 2^-depth of the step, at most Ts / parts long (with
    parts = 160: depth 4 at 10 steps per sample, 0, not split, from 160 on)."""
    d = 0
    while (m << d) < parts:
        d += 1
    return d


@jit(inline=True)
def _dense_weights(th):
    """RK4's continuous extension (order 3): the state at t + th h is X + h (b1 k1 +
    b2 (k2 + k3) + b4 k4) from the stages k1..k4 of the step from (t, X)."""
    c = 2.0 / 3.0
    return (th * (1.0 + th * (-1.5 + th * c)), th * th * (1.0 - th * c),
            th * th * (-0.5 + th * c))


@jit
def _split(work, p0, tb, h, depth, tried):
    """The RK4 step of length h from tb of the run taken alone (``work.alone``),
    split where it crosses a change of the limits (``work.alone_stages`` holds the
    step's stages when ``tried``: it was computed and crosses one). Where a step
    crosses a change, the change is located to one part of 2^-depth of the step by
    bisection, each probe one right-hand side at RK4's continuous extension of that
    step (:func:`_dense_weights`); then the step up to that part, the part, and the
    rest are steps of their own, each checked again. A step that crosses no change is
    the very step :func:`_steps_lanes` takes. Returns (RK4 steps computed, changes
    located)."""
    alone, D, DC = work.alone, work.alone_stages, work.probe
    U = 1 << depth  # the step's length in units of its finest part
    steps = 0
    located = 0
    pos = 0  # the units done
    end = U  # the units the next step reaches
    klo = -1  # a located part: from klo to khi
    khi = -1
    ic = CODE * LANES
    while pos < U:
        hh = (end - pos) * (h / U)
        t = tb + pos * (h / U)
        if not tried:
            _stages(t, hh, alone, p0, D)
            steps += 1
        tried = False
        if end - pos > 1 and _limit_changes(D, 0):
            located += 1
            c1 = D[0][ic]
            lo = pos
            hi = end
            while hi - lo > 1:
                q = (lo + hi) // 2
                b1, b2, b4 = _dense_weights((q - pos) / (end - pos))
                for i in range(NSTATE):
                    DC[0][i * LANES] = (b1 * D[0][i * LANES] + b2 * (D[1][i * LANES] + D[2][i * LANES])
                                        + b4 * D[3][i * LANES])
                tq = tb + q * (h / U)
                _stage(tq, reference(tq, p0), alone, hh, DC[0], DC[1])
                if DC[1][ic] == c1:
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
        _step(alone, hh, D, work.alone_crossed)
        pos = end
        end = khi if pos == klo else U
    return steps, located


@jit
def _lane_in(alone, state, lanes, b):
    """Lane b of ``state`` (a group's state, lane-minor) and of the group's parameters
    and noise into lane 0 of the scratch group ``alone``."""
    for q in range(NSTATE):
        alone.state[q * LANES] = state[q * LANES + b]
    for q in range(NPARAM):
        alone.params[q * LANES] = lanes.params[q * LANES + b]
    for q in range(4):
        alone.noise[q * LANES] = lanes.noise[q * LANES + b]


@jit
def _steps_lanes(lanes, p0, t0, h, m, depth, work):
    """m RK4 steps of length h from t0 for the lanes in use of one group. The
    reference is the same for every lane (p0: the group's first run's parameters), so
    it is evaluated once a stage. A lane's step that crosses a change of the limits
    is taken again alone, in parts (:func:`_split`, from the state before the step,
    located to 2^-depth of the step); work.extra_steps[b] and work.located[b] count
    lane b's extra RK4 steps and the changes located."""
    D = work.stages
    for j in range(m):
        t = t0 + j * h
        _stages(t, h, lanes, p0, D)
        work.before[:] = lanes.state
        _step(lanes, h, D, work.crossed)
        for b in range(lanes.count):
            if work.crossed[b] != 0.0 and depth > 0:
                _lane_in(work.alone, work.before, lanes, b)
                for s_ in range(4):
                    for q in range(NSTAGE):
                        work.alone_stages[s_][q * LANES] = D[s_][q * LANES + b]
                steps, splits = _split(work, p0, t, h, depth, work.crossed[b] != 0.0)
                work.extra_steps[b] += steps
                work.located[b] += splits
                for q in range(NSTATE):
                    lanes.state[q * LANES + b] = work.alone.state[q * LANES]


def compiled() -> bool:
    """Whether the engine's entry points were compiled (or loaded) in this process or
    lie compiled in the cache folder (:class:`unidyn.engine.jit.Compiled`)."""
    return AVAILABLE and run_groups.compiled() and start.compiled()


#: Why a run stopped (``status``): still running / complete, a non-finite state,
#: |(x, y)|, |u| or |w| beyond its divergence bound, interrupted, the loop faster
#: than the finest step allowed resolves.
OK, NONFINITE, POSITION, SPEED_U, SPEED_W, INTERRUPTED, STEP = 0, 1, 2, 3, 4, 5, 6


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
def log_index(k, n, L, stopped):
    """Row of the logged arrays for sample k (every L-th sample, plus the sample a
    run stopped at); -1 when sample k is not logged."""
    if k % L == 0:
        return k // L
    if stopped:
        return k // L + 1
    return -1


@jit
def log_row(t, X, p, noise, cols, row, out):
    """The kept columns cols of the log row at (t, X) (:func:`log_signals`, into the
    scratch row) into out."""
    log_signals(t, X, p, noise, row)
    for j in range(cols.shape[0]):
        out[j] = row[cols[j]]


@jit(entry="the batch engine")
def start(X, runs):
    """Log sample 0 of every run (state X (B, 13); noise row 0: interval 0) and check
    its state (into runs.status)."""
    row = np.empty(NLOG)
    for i in range(X.shape[0]):
        noise = (runs.noise_pos[i, 0, 0], runs.noise_pos[i, 0, 1], runs.noise_vel[i, 0, 0],
                 runs.noise_vel[i, 0, 1])
        log_row(0.0, X[i], runs.params[i], noise, runs.log_columns, row, runs.log[i, 0])
        runs.status[i] = check_state(X[i], runs.bounds[i])


@jit
def _interval_steps(t, k, lanes, p0, group_runs, m, runs, call, steps):
    """The RK4 steps each running lane of a group takes over interval k, into steps:
    m, or, where the loop's rate at the interval's start
    (:func:`unidyn.model.equations.loop_step_rate`) is beyond rate_max of its run,
    ceil(Ts rate / refined_rate); a lane that would need more than max_steps stops
    with status STEP. Counts each run's fastest rate, most steps and RK4 steps.
    Returns whether any lane takes finer steps. Runs with rate_max = inf are not
    checked."""
    finer = False
    ref = reference(t, p0)
    for b in range(lanes.count):
        i = group_runs[b]
        steps[b] = m
        if runs.status[i] != OK:
            continue
        if runs.rate_max[i] != np.inf:
            rate = eq.loop_step_rate(t, _lane_state(lanes.state, b), ref,
                                     _lane_params(lanes.params, b), _lane_noise(lanes.noise, b))
            if rate > runs.fastest[i]:
                runs.fastest[i] = rate
            if rate > runs.rate_max[i]:
                need = call.Ts * rate / call.refined_rate
                if not need <= call.max_steps:
                    runs.status[i] = STEP
                    runs.last[i] = k
                    continue
                steps[b] = math.ceil(need)
                runs.most_steps[i] = max(runs.most_steps[i], steps[b])
                runs.rk4_steps[i] += steps[b]
                finer = True
        runs.rk4_steps[i] += m
    return finer


@jit
def _lane_alone(start_state, lanes, b, p0, t0, m, call, work):
    """Lane b's interval again from its start (``start_state``, the group's state
    then), alone (in the scratch group work.alone), with m steps of Ts / m from t0
    (each split where it crosses a change of the limits, :func:`_split`), into lane
    b of the group: the numbers the run has when it is alone in its group. Returns
    (RK4 steps computed, steps split)."""
    _lane_in(work.alone, start_state, lanes, b)
    h = call.Ts / m
    steps = 0
    splits = 0
    depth = split_depth(m, call.split_parts)
    # False, as a value the compiler does not fold (a literal would compile _split twice)
    tried = m < 0
    for j in range(m):
        st, sp = _split(work, p0, t0 + j * h, h, depth, tried)
        steps += st
        splits += sp
    for q in range(NSTATE):
        lanes.state[q * LANES + b] = work.alone.state[q * LANES]
    return steps, splits


@jit
def _run_group(group, g, runs, call, k0, k1):
    """Advance the runs of group g (run group.runs[g, b] in lane b) over sample
    intervals k0..k1-1 with group.steps[g] RK4 steps each; a lane whose loop is faster
    at an interval's start than those steps resolve (:func:`_interval_steps`) takes
    that interval again alone, finer (:func:`_lane_alone`); a step that crosses a
    change of the limits is split there (:func:`_steps_lanes`).
    A run that stops is no longer logged (its lane goes on being computed, unused)."""
    nl = group.count[g]
    m = group.steps[g]
    group_runs = group.runs[g]
    lanes = Lanes(group.state[g], group.params[g], np.empty(4 * LANES), nl)
    # the scratch group of one run taken alone (its count: 1 as a value known only when
    # running; a literal 1 would make numba compile the steps again)
    alone = Lanes(np.zeros(NSTATE * LANES), np.zeros(NPARAM * LANES), np.zeros(4 * LANES),
                  min(nl, 1))
    work = Work(np.zeros((4, NSTAGE * LANES)), np.zeros(LANES), np.empty(NSTATE * LANES), alone,
                np.zeros((4, NSTAGE * LANES)), np.zeros((2, NSTAGE * LANES)), np.zeros(LANES),
                np.zeros(LANES, dtype=np.int64), np.zeros(LANES, dtype=np.int64))
    steps = np.empty(LANES, dtype=np.int64)
    x = np.empty(NSTATE)
    start_state = np.empty(NSTATE * LANES)
    full = np.empty(NLOG)
    Ts = call.Ts
    h = Ts / m
    depth = split_depth(m, call.split_parts)
    p0 = runs.params[group_runs[0]]
    for k in range(k0, k1):
        r = k - call.noise_first
        for b in range(nl):
            i = group_runs[b]
            lanes.noise[b] = runs.noise_pos[i, r, 0]
            lanes.noise[LANES + b] = runs.noise_pos[i, r, 1]
            lanes.noise[2 * LANES + b] = runs.noise_vel[i, r, 0]
            lanes.noise[3 * LANES + b] = runs.noise_vel[i, r, 1]
        finer = _interval_steps(k * Ts, k, lanes, p0, group_runs, m, runs, call, steps)
        running = False
        for b in range(nl):
            running = running or runs.status[group_runs[b]] == OK
        if not running:
            return
        if finer:
            start_state[:] = lanes.state
        work.extra_steps[:] = 0
        work.located[:] = 0
        _steps_lanes(lanes, p0, k * Ts, h, m, depth, work)
        for b in range(nl):
            i = group_runs[b]
            if runs.status[i] != OK:
                continue
            runs.rk4_steps[i] += work.extra_steps[b]
            if steps[b] > m:  # the interval again, alone, finer (steps[b] counted already)
                done, split = _lane_alone(start_state, lanes, b, p0, k * Ts, steps[b], call, work)
                runs.rk4_steps[i] += done - steps[b]
                runs.splits[i] += split
            else:
                runs.splits[i] += work.located[b]
        for b in range(nl):
            i = group_runs[b]
            if runs.status[i] != OK:
                continue
            for q in range(NSTATE):
                x[q] = lanes.state[q * LANES + b]
            st = check_state(x, runs.bounds[i])
            row = log_index(k + 1, call.samples, call.log_every, st != OK)
            if row >= 0:
                # logged with interval k's measurement, as the diagram logs it before the tick
                log_row((k + 1) * Ts, x, runs.params[i], _lane_noise(lanes.noise, b),
                        runs.log_columns, full, runs.log[i, row])
            runs.status[i] = st
            runs.last[i] = k + 1


@jit(parallel=True, entry="the batch engine")
def run_groups(group, runs, call, k0, k1):
    """Advance every group of runs (:data:`Groups`; their states updated in place)
    over sample intervals k0..k1-1, one group per thread at a time; the per-run
    arrays :data:`Runs` are read and filled (every log_every-th sample, and the one a
    run stops at, is logged), with the numbers of :data:`Call`."""
    for g in prange(group.state.shape[0]):
        _run_group(group, g, runs, call, k0, k1)
