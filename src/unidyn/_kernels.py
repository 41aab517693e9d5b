"""Compiled batch engine: the Fig. 2 loop of :func:`unidyn.equations.loop_rates`
integrated with RK4, runs side by side in SIMD lanes (numba).

The right-hand side is the very function the numpy engine
(:class:`unidyn.closedloop.ClosedLoop`) evaluates on arrays of runs, here compiled
for the values of one run held in registers; the per-run parameters are the rows of
the named table :data:`unidyn.equations.LOOP_PARAMETERS`
(:meth:`ClosedLoop.parameter_table`). Runs that take the same RK4 steps and follow
the same reference form a group of up to :data:`LANES`; a thread integrates a
group's runs in one loop over its lanes, which the compiler vectorises (each
instruction serves several runs), with the reference evaluated once per stage for
the whole group. Lanes are independent: a run's numbers are the same bit for bit
whichever runs share its group. Used by :func:`unidyn.simulate_batch` when numba is
installed (``pip install unidyn[fast]``); without numba the same code runs as plain
Python, which ``tests/evals/test_engines.py`` checks against the numpy engine.
"""

from __future__ import annotations

import math

import numpy as np

from . import equations as eq
from ._jit import AVAILABLE, jit, prange
from .equations import P, S

__all__ = ["AVAILABLE", "compiled", "LOG_COLUMNS", "reference", "rhs", "run_groups", "start", "LANES", "OK", "NONFINITE",
           "POSITION", "SPEED_U", "SPEED_W", "INTERRUPTED", "STEP"]

NSTATE = len(eq.STATE)
#: The rows of an RK4 stage: the 13 rates, then (row CODE) which limits act there
#: (:func:`unidyn.equations.limit_state`), which tells where a step crosses a change.
CODE = NSTATE
NSTAGE = NSTATE + 1


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
    """dX/dt of one run (X, dX: (13,), p: a row of the parameter table), as the
    engine integrates it."""
    eq.loop_derivative(t, X, reference(t, p), p, noise, dX)


#: The columns of the log, in order: the states the result keeps (pose, robot
#: velocity, theta_hat: the first 11 of :data:`unidyn.equations.STATE`; a kinematic
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


#: The tuples below are written out (numba keeps a tuple of floats in registers and
#: has no tuple comprehension); tests/evals/test_engines.py checks them against the
#: lengths of :data:`unidyn.equations.STATE` and :data:`~unidyn.equations.LOOP_PARAMETERS`.
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


@jit
def _stage(t, ref, XL, a, DL, first, PL, NL, nl, OUT):
    """One RK4 stage for lanes 0..nl-1 of a group: OUT = the loop's rates at
    XL + a DL (at XL itself when ``first``), time t, reference ref (all lane-minor).
    Compiled once and called for the four stages: the equations are inlined into
    this one loop, which the compiler vectorises over the lanes."""
    for b in range(nl):
        X = _lane_state(XL, b)
        if not first:
            X = _axpy(X, a, _lane_state(DL, b))
        d, code = eq.loop_rates_and_limits(t, X, ref, _lane_params(PL, b), _lane_noise(NL, b))
        for i in range(NSTATE):
            OUT[i * LANES + b] = d[i]
        OUT[CODE * LANES + b] = code


@jit(inline=True)
def _limit_changes(D1, D2, D3, D4, PL, b):
    """Whether the four stages of lane b's RK4 step disagree on which limits act on
    the robot's accelerations and its command (:func:`unidyn.equations.limit_state`,
    in the stages' row CODE): the step then crosses a kink or a jump of the
    right-hand side."""
    c = CODE * LANES + b
    c1 = D1[c]
    return (c1 != D2[c]) | (c1 != D3[c]) | (c1 != D4[c])


@jit
def _step(XL, h, D1, D2, D3, D4, PL, nl, KF):
    """RK4's step from the four stages, X + h / 6 (d1 + 2 d2 + 2 d3 + d4), for lanes
    0..nl-1; the speeds end on their limits where the step crosses one. KF[b] is set
    to 1 where lane b's step crosses a change of the limits (:func:`_limit_changes`),
    else 0."""
    for b in range(nl):
        X = _rk4(_lane_state(XL, b), h, _lane_state(D1, b), _lane_state(D2, b),
                 _lane_state(D3, b), _lane_state(D4, b))
        for i in range(NSTATE):
            XL[i * LANES + b] = X[i]
        XL[S.u * LANES + b] = eq.saturate(X[S.u], PL[P.speed_u * LANES + b])
        XL[S.w * LANES + b] = eq.saturate(X[S.w], PL[P.speed_w * LANES + b])
        KF[b] = eq.select(_limit_changes(D1, D2, D3, D4, PL, b), 1.0, 0.0)


@jit(inline=True)
def _stages(t, h, XL, PL, NL, p0, nl, D):
    """RK4's four stages of the step of length h from t for lanes 0..nl-1 of a group
    into D[0..3]; the reference (p0's) is evaluated once a stage for all lanes."""
    r2 = reference(t + 0.5 * h, p0)
    # first: a literal, so that numba compiles the stage without the branch
    _stage(t, reference(t, p0), XL, 0.0, D[0], True, PL, NL, nl, D[0])
    _stage(t + 0.5 * h, r2, XL, 0.5 * h, D[0], False, PL, NL, nl, D[1])
    _stage(t + 0.5 * h, r2, XL, 0.5 * h, D[1], False, PL, NL, nl, D[2])
    _stage(t + h, reference(t + h, p0), XL, h, D[2], False, PL, NL, nl, D[3])


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
def _split(XS, PS, NS, p0, tb, h, depth, tried, one, D, DC, KS):
    """The RK4 step of length h from tb of lane 0 of the scratch group XS (parameters
    PS, noise NS), split where it crosses a change of the limits (D holds the step's
    stages when ``tried``: it was computed and crosses one). Where a step crosses a
    change, the change is located to one part of 2^-depth of the step by bisection,
    each probe one right-hand side at RK4's continuous extension of that step
    (:func:`_dense_weights`); then the step up to that part, the part, and the rest
    are steps of their own, each checked again. A step that crosses no change is the
    very step :func:`_steps_lanes` takes. DC (2, 13 * LANES) is scratch. Returns (RK4
    steps computed, changes located)."""
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
            _stages(t, hh, XS, PS, NS, p0, one, D)
            steps += 1
        tried = False
        if end - pos > 1 and _limit_changes(D[0], D[1], D[2], D[3], PS, 0):
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
                _stage(tq, reference(tq, p0), XS, hh, DC[0], False, PS, NS, one, DC[1])
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
        _step(XS, hh, D[0], D[1], D[2], D[3], PS, one, KS)
        pos = end
        end = khi if pos == klo else U
    return steps, located


@jit
def _lane_in(XS, PS, NS, XL, PL, NL, b):
    """Lane b of a group's state XL, parameters PL and noise NL into lane 0 of the
    scratch group XS, PS, NS."""
    for q in range(NSTATE):
        XS[q * LANES] = XL[q * LANES + b]
    for q in range(NPARAM):
        PS[q * LANES] = PL[q * LANES + b]
    for q in range(4):
        NS[q * LANES] = NL[q * LANES + b]


@jit
def _steps_lanes(XL, PL, NL, p0, t0, h, m, nl, D, KF, XP, XS, PS, NS, DS, DC, KS, WK, SP, depth,
                 one):
    """m RK4 steps of length h from t0 for lanes 0..nl-1 of one group (state XL,
    parameters PL, this interval's noise NL; all lane-minor; D (4, 13 * LANES) holds
    the stages). The reference is the same for every lane (p0: the group's first
    run), so it is evaluated once a stage. A lane's step that crosses a change of the
    limits is taken again alone, in parts (:func:`_split`, in the scratch group XS,
    PS, NS from the state before the step, kept in XP, with its stages copied to DS;
    located to 2^-depth of the step); WK[b] and SP[b] count lane b's extra RK4 steps
    and the changes located. (one: the lane count 1 as a value known only when
    running; a literal 1 would make numba compile the steps again.)"""
    for j in range(m):
        t = t0 + j * h
        _stages(t, h, XL, PL, NL, p0, nl, D)
        XP[:] = XL
        _step(XL, h, D[0], D[1], D[2], D[3], PL, nl, KF)
        for b in range(nl):
            if KF[b] != 0.0 and depth > 0:
                _lane_in(XS, PS, NS, XP, PL, NL, b)
                for s_ in range(4):
                    for q in range(NSTAGE):
                        DS[s_][q * LANES] = D[s_][q * LANES + b]
                steps, splits = _split(XS, PS, NS, p0, t, h, depth, True, one, DS, DC, KS)
                WK[b] += steps
                SP[b] += splits
                for q in range(NSTATE):
                    XL[q * LANES + b] = XS[q * LANES]


def compiled() -> bool:
    """Whether the engine's entry points were compiled (or loaded) in this process or
    lie compiled in the cache folder (:class:`unidyn._jit.Compiled`)."""
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


@jit(entry=True)
def start(X, P_, pos_noise, vel_noise, bound, cols, LOG, status):
    """Log sample 0 of every run (its columns cols) and check its state (noise row 0:
    interval 0)."""
    row = np.empty(NLOG)
    for i in range(X.shape[0]):
        noise = (pos_noise[i, 0, 0], pos_noise[i, 0, 1], vel_noise[i, 0, 0], vel_noise[i, 0, 1])
        log_row(0.0, X[i], P_[i], noise, cols, row, LOG[i, 0])
        status[i] = check_state(X[i], bound[i])


@jit
def _interval_steps(t, k, XL, PL, NL, p0, runs, nl, m, Ts, rate_max, refined, max_steps,
                    status, seen, last, m_max, work, MK):
    """The RK4 steps each running lane of a group takes over interval k, into MK: m,
    or, where the loop's rate at the interval's start
    (:func:`unidyn.equations.loop_step_rate`) is beyond rate_max of its run,
    ceil(Ts rate / refined); a lane that would need more than max_steps stops with
    status STEP. seen and m_max keep each run's fastest rate and most steps, work
    counts its steps. Returns whether any lane takes finer steps. Runs with
    rate_max = inf are not checked."""
    finer = False
    ref = reference(t, p0)
    for b in range(nl):
        i = runs[b]
        MK[b] = m
        if status[i] != OK:
            continue
        if rate_max[i] != np.inf:
            rate = eq.loop_step_rate(t, _lane_state(XL, b), ref, _lane_params(PL, b),
                                     _lane_noise(NL, b))
            if rate > seen[i]:
                seen[i] = rate
            if rate > rate_max[i]:
                need = Ts * rate / refined
                if not need <= max_steps:
                    status[i] = STEP
                    last[i] = k
                    continue
                MK[b] = math.ceil(need)
                m_max[i] = max(m_max[i], MK[b])
                work[i] += MK[b]
                finer = True
        work[i] += m
    return finer


@jit
def _lane_alone(XS0, XL, PL, NL, b, p0, t0, h, m, parts, XS, PS, NS, D, DC, KS, one):
    """Lane b's interval again from its start XS0, alone (in lane 0 of the scratch
    group XS, PS, NS) with m steps of h (each split where it crosses a change of the
    limits, :func:`_split`), into lane b of XL: the numbers the run has when it is
    alone in its group. Returns (RK4 steps computed, steps split)."""
    _lane_in(XS, PS, NS, XS0, PL, NL, b)
    steps = 0
    splits = 0
    for j in range(m):
        st, sp = _split(XS, PS, NS, p0, t0 + j * h, h, split_depth(m, parts), False, one, D, DC,
                        KS)
        steps += st
        splits += sp
    for q in range(NSTATE):
        XL[q * LANES + b] = XS[q * LANES]
    return steps, splits


@jit
def _run_group(XL, PL, runs, nl, m, P_, pos_noise, vel_noise, kn, Ts, k0, k1, n, L, bound,
               rate_max, refined, max_steps, parts, cols, LOG, status, last, seen, m_max, work,
               splits):
    """Advance the nl runs of one group (run runs[b] in lane b; state XL and
    parameters PL lane-minor) over sample intervals k0..k1-1 with m RK4 steps each;
    a lane whose loop is faster at an interval's start than m steps resolve
    (:func:`_interval_steps`), or one of whose steps crosses a change of the limits,
    takes that interval again alone, with its steps split where they cross such a
    change (:func:`_lane_alone`; splits counts them).
    A run that stops is no longer logged (its lane goes on being computed, unused)."""
    NL = np.empty(4 * LANES)
    D = np.zeros((4, NSTAGE * LANES))
    x = np.empty(NSTATE)
    XS0 = np.empty(NSTATE * LANES)
    XS = np.zeros(NSTATE * LANES)
    PS = np.zeros(NPARAM * LANES)
    NS = np.zeros(4 * LANES)
    MK = np.empty(LANES, dtype=np.int64)
    KF = np.zeros(LANES)
    KS = np.zeros(LANES)
    XP = np.empty(NSTATE * LANES)
    DS = np.zeros((4, NSTAGE * LANES))
    DC = np.zeros((2, NSTAGE * LANES))
    WK = np.zeros(LANES, dtype=np.int64)
    SP = np.zeros(LANES, dtype=np.int64)
    full = np.empty(NLOG)
    h = Ts / m
    depth = split_depth(m, parts)
    p0 = P_[runs[0]]
    for k in range(k0, k1):
        r = k - kn
        for b in range(nl):
            i = runs[b]
            NL[b] = pos_noise[i, r, 0]
            NL[LANES + b] = pos_noise[i, r, 1]
            NL[2 * LANES + b] = vel_noise[i, r, 0]
            NL[3 * LANES + b] = vel_noise[i, r, 1]
        finer = _interval_steps(k * Ts, k, XL, PL, NL, p0, runs, nl, m, Ts, rate_max, refined,
                                max_steps, status, seen, last, m_max, work, MK)
        running = False
        for b in range(nl):
            running = running or status[runs[b]] == OK
        if not running:
            return
        if finer:
            XS0[:] = XL
        WK[:] = 0
        SP[:] = 0
        _steps_lanes(XL, PL, NL, p0, k * Ts, h, m, nl, D, KF, XP, XS, PS, NS, DS, DC, KS, WK, SP,
                     depth, min(nl, 1))
        for b in range(nl):
            i = runs[b]
            if status[i] != OK:
                continue
            work[i] += WK[b]
            if MK[b] > m:  # the interval again, alone, finer (MK[b] counted already)
                steps, split = _lane_alone(XS0, XL, PL, NL, b, p0, k * Ts, Ts / MK[b], MK[b],
                                           parts, XS, PS, NS, D, DC, KS, min(nl, 1))
                work[i] += steps - MK[b]
                splits[i] += split
            else:
                splits[i] += SP[b]
        for b in range(nl):
            i = runs[b]
            if status[i] != OK:
                continue
            for q in range(NSTATE):
                x[q] = XL[q * LANES + b]
            st = check_state(x, bound[i])
            row = log_index(k + 1, n, L, st != OK)
            if row >= 0:
                # logged with interval k's measurement, as the diagram logs it before the tick
                log_row((k + 1) * Ts, x, P_[i], _lane_noise(NL, b), cols, full, LOG[i, row])
            status[i] = st
            last[i] = k + 1


@jit(parallel=True, entry=True)
def run_groups(XG, PG, runs, nlanes, mG, P_, pos_noise, vel_noise, kn, Ts, k0, k1, n, L, bound,
               rate_max, refined, max_steps, parts, cols, LOG, status, last, seen, m_max, work,
               splits):
    """Advance every group of runs over sample intervals k0..k1-1, one group per
    thread at a time. Group g holds nlanes[g] runs (indices runs[g, :nlanes[g]] into
    the per-run arrays) that share their RK4 steps per interval, mG[g], and their
    reference; XG (G, 13 * LANES) and PG (G, len(LOOP_PARAMETERS) * LANES) are their
    states (updated in place) and parameters, lane-minor. Per run: P_ (B, ...) its
    parameters; pos_noise, vel_noise (B, rows, 2) the noise of intervals kn, kn + 1, ...
    (k0 >= kn, k1 <= kn + rows); every L-th sample (and the one a run stops at) is
    logged into LOG (B, rows, len(cols); float64 or float32): the columns cols of
    :data:`LOG_COLUMNS` (:func:`log_layout`); status[i] says why run i
    stopped (OK while it runs) and last[i] is the last sample it reached. Where the
    loop's rate at an interval's start exceeds rate_max[i] (inf: not checked), run i
    takes that interval with ceil(Ts rate / refined) steps, at most max_steps (else it
    stops with status STEP); seen[i] and m_max[i] keep its fastest rate and most
    steps, work[i] counts the RK4 steps computed for it (with the coarse steps of an
    interval taken again) and splits[i] its steps split where they cross a change of
    the limits (on the robot's accelerations or its command), down to parts of Ts / parts
    (:func:`split_depth`)."""
    for g in prange(XG.shape[0]):
        _run_group(XG[g], PG[g], runs[g], nlanes[g], mG[g], P_, pos_noise, vel_noise, kn, Ts,
                   k0, k1, n, L, bound, rate_max, refined, max_steps, parts, cols, LOG, status,
                   last, seen, m_max, work, splits)
