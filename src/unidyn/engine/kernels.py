"""The batch engine's step rule, once: the Dormand-Prince 5(4) pair with step-size
control (:func:`dp_step`, its table :data:`A`, :data:`B`, :data:`C`, :data:`E`; the
method of ``solve_ivp``'s RK45) and its free interpolant (:data:`P_DENSE`), over any
switched right-hand side: each step holds the switches' mode, and a step in which a
switch's margin turns negative ends where it crosses zero, found from the step's
interpolant (:func:`integrate_interval`, :func:`switch_at`), restarted at every sample
interval; the Fig. 2 loop (:func:`loop_rhs`, its switches decided by
:func:`loop_decide`) one run after another, its metrics accumulated at every sample
(:func:`advance`, called from a thread per core). numba compiles this module where installed (:mod:`unidyn.compiled`);
:func:`unidyn.compiled.plain_copy` runs the same source as plain Python.
"""

from __future__ import annotations

import math
from collections import namedtuple
from enum import IntEnum

import numpy as np

from ..compiled import AVAILABLE, jit
from ..model import equations as eq
from ..model import metrics
from ..model.equations import NSTATE, P, S
from ..model.log import LOG, LOGGED_STATES, NLOG, log_row, logged

if AVAILABLE:
    from numba.extending import overload

__all__ = ["AVAILABLE", "Runs", "Call", "Work", "reference", "loop_rhs", "loop_decide",
           "advance", "dp_step", "dense", "switch_at", "integrate_interval", "work_arrays",
           "Status"]


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
#: The free fourth-order interpolant of the pair (Shampine, Math. Comp. 46 (1986); scipy's
#: ``RK45.P``): the state at t + theta h is x + h sum_j K[j] sum_k P_DENSE[j, k] theta^(k+1).
P_DENSE = np.array([
    [1.0, -8048581381 / 2820520608, 8663915743 / 2820520608, -12715105075 / 11282082432],
    [0.0, 0.0, 0.0, 0.0],
    [0.0, 131558114200 / 32700410799, -68118460800 / 10900136933, 87487479700 / 32700410799],
    [0.0, -1754552775 / 470086768, 14199869525 / 1410260304, -10690763975 / 1880347072],
    [0.0, 127303824393 / 49829197408, -318862633887 / 49829197408, 701980252875 / 199316789632],
    [0.0, -282668133 / 205662961, 2019193451 / 616988883, -1453857185 / 822651844],
    [0.0, 40617522 / 29380423, -110615467 / 29380423, 69997945 / 29380423]])
#: As scipy's: the next step is h STEP_SAFETY err^(-1/5), within [MIN_FACTOR, MAX_FACTOR] h.
STEP_SAFETY, MIN_FACTOR, MAX_FACTOR = 0.9, 0.2, 10.0
#: The shortest step, as a fraction of the sample interval, before a run stops (STEP).
MIN_STEP_FRACTION = 1e-12
#: A switch is located to this fraction of its step, or rtol if larger: ending a step that
#: late moves the state by the square of it (the loop's rates are continuous across its
#: switches; a speed reaching its limit is put back on it).
SWITCH_TOL_FRACTION = 1e-12
#: The most consecutive steps that may end on a switch before one step is taken with the
#: switches decided at each evaluation (a sliding mode: the limits chatter faster than any
#: step; as Simulink's bound on consecutive zero crossings).
MAX_SWITCH_CHAIN = 10
#: The iterations of the Illinois method that locate a switch within a step.
MAX_LOCATE = 60
#: A trial point of the Illinois method stays this fraction of the tolerance inside its
#: bracket (so that the bracket shrinks at each iteration).
BRACKET_MARGIN = 0.25
#: A step whose error estimate is not a number is taken again this much shorter.
NAN_STEP_FACTOR = 0.5


#: The per-call scratch of :func:`integrate_interval`: ``K`` (7, n) the stages' rates,
#: ``G`` (7, 2m) their m switches' margins, then the m values the switches clip, ``y`` (n,)
#: a stage's state, ``Xn`` (n,) the step's end, ``Xd`` (n,) a state of the interpolant,
#: ``rates`` (n,) and ``margins`` (2m,) its rates and margins, ``mode`` the switches
#: held over a step (the time switches' time, then each switch's side:
#: :data:`unidyn.model.equations.MODE`).
Work = namedtuple("Work", "K G y Xn Xd rates margins mode")


@jit(inline=True)
def work_arrays(n, m):
    """:data:`Work` for n states and m switches."""
    return Work(np.empty((7, n)), np.empty((7, 2 * m)), np.empty(n), np.empty(n), np.empty(n),
                np.empty(n), np.empty(2 * m), np.empty(m + 1))


# not cached itself: numba's cache index records a signature's types by their module, so
# a right-hand side of a script would break the index for other processes (its callers
# are cached, with its code in them)
@jit(inline=True)
def dp_step(f, t, x, h, args, work, rtol, atol):
    """One Dormand-Prince step of length h from (t, x) of dx/dt = f(t, x, args, mode)
    with the switches held at ``work.mode`` (f writes the rates and the switches' margins
    into its last two arguments), the fifth-order solution into ``work.Xn``. ``work.K[0]``
    holds f(t, x) on entry; K[1..6] get the other stages (G their margins), K[6] =
    f(t + h, Xn). Returns the error as ``solve_ivp`` measures it: the root mean square
    over the states of error / (atol + rtol max(|x|, |Xn|)), at most 1 for a step
    accurate enough."""
    K, G, y, out, mode = work.K, work.G, work.y, work.Xn, work.mode
    n = x.shape[0]
    for s in range(1, 6):
        for i in range(n):
            acc = 0.0
            for j in range(s):
                acc += A[s, j] * K[j, i]
            y[i] = x[i] + h * acc
        f(t + C[s] * h, y, args, mode, K[s], G[s])
    for i in range(n):
        acc = 0.0
        for j in range(6):
            acc += B[j] * K[j, i]
        out[i] = x[i] + h * acc
    f(t + h, out, args, mode, K[6], G[6])
    err = 0.0
    for i in range(n):
        acc = 0.0
        for j in range(7):
            acc += E[j] * K[j, i]
        err += (h * acc / (atol + rtol * max(abs(x[i]), abs(out[i])))) ** 2
    err = math.sqrt(err / n)
    # the values the switches clip, as if integrated with the states: the pair's estimate
    # of their integral over the step says whether the stages resolve them (held at a
    # limit, they drive no rate, and no state's error sees how fast they move)
    m = G.shape[1] // 2
    if m > 0:
        errs = 0.0
        for i in range(m, 2 * m):
            acc = 0.0
            for j in range(7):
                acc += E[j] * G[j, i]
            errs += (h * acc / (atol + rtol * max(abs(G[0, i]), abs(G[6, i])))) ** 2
        err = max(err, math.sqrt(errs / m))
    return err


@jit(inline=True)
def dense(x, h, K, theta, out):
    """The step's interpolant (:data:`P_DENSE`) at t + theta h into out."""
    for i in range(x.shape[0]):
        acc = 0.0
        for j in range(7):
            acc += K[j, i] * theta * (P_DENSE[j, 0] + theta * (P_DENSE[j, 1] + theta * (
                P_DENSE[j, 2] + theta * P_DENSE[j, 3])))
        out[i] = x[i] + h * acc


@jit(inline=True)
def lowest(g):
    """The smallest of the margins, the first half of g (inf for none)."""
    low = math.inf
    for j in range(g.shape[0] // 2):
        low = min(low, g[j])
    return low


@jit(inline=True)
def margin_at(f, t, x, h, args, work, theta):
    """The smallest switch margin on the step's interpolant at t + theta h (the state
    into ``work.Xd``)."""
    dense(x, h, work.K, theta, work.Xd)
    f(t + theta * h, work.Xd, args, work.mode, work.rates, work.margins)
    return lowest(work.margins)


#: What :func:`switch_at` returns for a step in which no switch flips.
NO_SWITCH = 2.0
#: The stages' distinct times as fractions of the step, in order.
SAMPLE_TIMES = (0.0, 0.2, 0.3, 0.8, 8.0 / 9.0, 1.0)


@jit(inline=True)
def switch_at(f, t, x, h, args, work, rtol):
    """Where the first switch of a kept step flips, as a fraction of its length (1: at its
    end): :data:`NO_SWITCH` where it finds none; else the end of the bracket just past the first crossing of zero by
    the smallest margin on the step's interpolant (its state in ``work.Xd``), found by
    the Illinois method to :data:`SWITCH_TOL_FRACTION` or rtol.

    Where a margin is negative at a stage, the margins are looked at on the interpolant
    at the stages' times, in order, for the first negative one; one negative at a stage
    state but nowhere on the interpolant keeps the step. No episode falls between the
    stages unseen: the values the switches clip are resolved by the step's error control
    (:func:`dp_step`) as the states are."""
    G = work.G
    seen = False
    for s in range(1, 7):
        seen = seen or lowest(G[s]) < 0.0
    if not seen:
        return NO_SWITCH
    lo, glo, hi, ghi = 0.0, lowest(G[0]), -1.0, 0.0
    for q in range(1, len(SAMPLE_TIMES)):  # the stages' times on the interpolant, in order
        theta = SAMPLE_TIMES[q]
        g = lowest(G[6]) if theta == 1.0 else margin_at(f, t, x, h, args, work, theta)
        if g < 0.0:
            hi, ghi = theta, g
            break
        lo, glo = theta, g
    if hi < 0.0:
        return NO_SWITCH
    tol = max(rtol, SWITCH_TOL_FRACTION)
    glo = max(glo, 0.0)
    side = 0  # which end moved last (Illinois: halve the other's value when one repeats)
    for _ in range(MAX_LOCATE):
        if hi - lo <= tol:
            break
        mid = hi - ghi * (hi - lo) / (ghi - glo) if ghi != glo else 0.5 * (lo + hi)
        # keep inside the bracket, away from its ends by a part of the tolerance
        mid = min(max(mid, lo + BRACKET_MARGIN * tol), hi - BRACKET_MARGIN * tol)
        g = margin_at(f, t, x, h, args, work, mid)
        if g < 0.0:
            hi, ghi = mid, g
            if side == -1:
                glo *= 0.5
            side = -1
        else:
            lo, glo = mid, g
            if side == 1:
                ghi *= 0.5
            side = 1
    dense(x, h, work.K, hi, work.Xd)
    return hi


@jit(inline=True)
def step_factor(err):
    """How much longer (or shorter) the next step is than one with error ``err``."""
    if err == 0.0:
        return MAX_FACTOR
    return min(MAX_FACTOR, max(MIN_FACTOR, STEP_SAFETY * err ** -0.2))


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
def reference(t, ts, p, references):
    """(x_d, y_d, x_d', y_d', x_d'', y_d'') of the run with parameters p at time t, the
    reference's steps judged at time ts (the step's start: a step never spans one)
    (:func:`unidyn.model.equations.reference_components`; ``references``: the call's
    Python-function references, code :data:`~unidyn.model.equations.PYTHON`)."""
    if p[P.trajectory] == eq.PYTHON:
        return python_reference(t, p[P.path1], references)
    return eq.reference_components(t, ts, p)


@jit
def loop_rhs(t, X, args, mode, out, margins):
    """The Fig. 2 loop's dX/dt (:func:`unidyn.model.equations.loop_rates_held`) of one
    run at time t, its switches held at ``mode``, into out, and the switches' margins
    into margins. args = (p, noise, references): a row of the parameter table
    (:data:`unidyn.model.equations.LOOP_PARAMETERS`), the interval's held noise
    (position x, y, velocity u, w) and the call's Python-function references."""
    p, noise, references = args
    d, g, _, v = eq.loop_rates_held(t, X, reference(t, mode[0], p, references), p, noise,
                                    (mode[0], mode[1], mode[2], mode[3], mode[4], mode[5], mode[6]))
    for i in range(NSTATE):
        out[i] = d[i]
    for j in range(eq.NSWITCH):
        margins[j] = g[j]
        margins[eq.NSWITCH + j] = v[j]


@jit(inline=True)
def loop_decide(t, X, args, mode):
    """The switches' mode at (t, X) into ``mode``: the time switches judged at t, each
    limit's side as the values there put it (:data:`unidyn.model.equations.AUTO`); u and
    w put back within their speed limits (a step that reached one ends just past it).
    Returns the next time a time switch flips (inf: none)."""
    p, noise, references = args
    X[S.u], X[S.w] = eq.saturate(X[S.u], p[P.speed_u]), eq.saturate(X[S.w], p[P.speed_w])
    auto = eq.AUTO
    _, _, side, _ = eq.loop_rates_held(t, X, reference(t, t, p, references), p, noise,
                                       (t, auto, auto, auto, auto, auto, auto))
    mode[0] = t
    for j in range(eq.NSWITCH):
        mode[j + 1] = side[j]
    return eq.next_switch_time(t, p)


# -------------------------------------------------------------------- the log
@jit
def sample_row(t, X, p, noise, references, row):
    """The full log row (:data:`unidyn.model.log.LOG_COLUMNS`) of the sample at (t, X)
    into row."""
    for i in range(LOGGED_STATES):
        row[i] = X[i]
    ref = reference(t, t, p, references)
    ud, wd, udd, wdd, G, u_ref, w_ref, um, wm = eq.loop_signals(X, ref, p, noise)
    row[LOG.x_d], row[LOG.y_d], row[LOG.u_d], row[LOG.w_d] = ref[0], ref[1], ud, wd
    row[LOG.u_ref] = eq.saturate(u_ref, p[P.speed_u])
    row[LOG.w_ref] = eq.saturate(w_ref, p[P.speed_w])
    if p[P.dynamic] == 0.0:  # a kinematic robot moves at its clipped command
        row[LOG.u], row[LOG.w] = row[LOG.u_ref], row[LOG.w_ref]


@jit(inline=True)
def accumulate(k, Ts, row, acc):
    """Sample k (at t = k Ts, its row) into the metrics so far, acc
    (:func:`unidyn.model.metrics.accumulate`), at every sample whatever is logged."""
    error = math.hypot(row[LOG.x_d] - row[LOG.x], row[LOG.y_d] - row[LOG.y])
    effort = row[LOG.u] * row[LOG.u] + row[LOG.w] * row[LOG.w]
    metrics.accumulate(k, Ts, error, effort, acc)


@jit(inline=True)
def write_log(row, columns, acc, out, running):
    """The kept columns of row into out, the metrics so far into running."""
    for j in range(columns.shape[0]):
        out[j] = row[columns[j]]
    for j in range(running.shape[0]):
        running[j] = acc[j]


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
#: of :data:`unidyn.model.log.LOG_COLUMNS`; ``log`` (B, rows, columns); ``running`` (B,
#: rows, metrics), float64, the metrics so far at each logged sample; ``acc`` (B, 2
#: metrics), float64, the metrics so far and what each accumulated at the last sample
#: (:func:`unidyn.model.metrics.accumulate`); ``status``,
#: ``last`` (sample reached), ``steps`` (kept) and ``rejected`` (taken again shorter);
#: ``references``, the call's Python-function references (a tuple; empty compiled).
Runs = namedtuple("Runs", "state params h noise_pos noise_vel bounds log_columns log "
                          "running acc status last steps rejected references")
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


@jit(inline=True)
def copy_into(dst, src):
    """dst[:] = src[:], element by element (as numba and the plain copy both run it)."""
    for i in range(dst.shape[0]):
        dst[i] = src[i]


# not cached itself (as dp_step): it takes the right-hand side as an argument
@jit(inline=True)
def integrate_interval(f, decide, t0, t1, X, h, args, call, work):
    """One run of the switched system dX/dt = f(t, X, args, mode) from (t0, X) to t1 by
    error-controlled steps, X updated, the first step h (0: t1 - t0).

    ``decide(t, X, args, mode)`` sets the switches' mode at (t, X) (it may put X back
    onto its constraints) and returns the next time a time switch flips. Each step holds
    the mode, so that it integrates a smooth right-hand side; a kept step in which a
    switch's margin turns negative ends where it crosses zero (:func:`switch_at`), steps
    end at the time switches, and the mode is decided again there. After
    :data:`MAX_SWITCH_CHAIN` steps in a row that end on a switch (a sliding mode), one
    step decides the switches at each evaluation instead. Returns (the next step, steps
    kept, steps rejected, ``OK``; or ``STEP``: the tolerance not met in
    ``call.max_steps`` steps or the step below :data:`MIN_STEP_FRACTION` of the
    interval; ``NONFINITE``: the last error estimate not a number)."""
    K, G, mode = work.K, work.G, work.mode
    span = t1 - t0
    h = h if h > 0.0 else span
    t_switch = decide(t0, X, args, mode)
    f(t0, X, args, mode, K[0], G[0])
    t, kept, rejected, proposal = t0, 0, 0, h
    again = False  # a step of this interval was taken again: grow no step after it
    chain = 0  # steps in a row that ended on a switch
    while True:
        end = min(t1, t_switch)
        last = h >= end - t
        h = end - t if last else h
        err = dp_step(f, t, X, h, args, work, call.rtol, call.atol)
        if err <= 1.0:  # kept (an error estimate that is NaN is not)
            kept += 1
            factor = min(1.0, step_factor(err)) if again else step_factor(err)
            theta = NO_SWITCH if mode[1] == eq.AUTO else switch_at(f, t, X, h, args, work,
                                                                    call.rtol)
            switched = theta == 1.0  # a switch at the step's end: the mode decided there
            if theta < 1.0 or (switched and not last):  # ended on a switch: decided there
                copy_into(X, work.Xd)
                t = t + theta * h
                proposal = h * factor
                chain += 1
                t_switch = decide(t, X, args, mode)
                if chain >= MAX_SWITCH_CHAIN:  # a sliding mode: one step deciding as it goes
                    for j in range(1, mode.shape[0]):
                        mode[j] = eq.AUTO
                    chain = 0
                f(t, X, args, mode, K[0], G[0])
                h = proposal
                again = False
            else:
                if not last:
                    proposal = h * factor
                elif factor < 1.0:  # the step cut to the interval's end or a time switch
                    proposal = min(proposal, h * factor)
                copy_into(X, work.Xn)
                if last and end == t1:
                    if mode[1] == eq.AUTO or switched:  # back on the limits
                        decide(t1, X, args, mode)
                    return proposal, kept, rejected, OK
                t = end if last else t + h
                if last or mode[1] == eq.AUTO:  # a time switch, or after a sliding step
                    t_switch = decide(t, X, args, mode)
                    f(t, X, args, mode, K[0], G[0])
                else:  # the rates at the step's end start the next (the pair's FSAL)
                    copy_into(K[0], K[6])
                    copy_into(G[0], G[6])
                chain = 0
                h = proposal
                again = False
        else:
            rejected += 1
            again = True
            h = h * step_factor(err) if err < math.inf else NAN_STEP_FACTOR * h
            proposal = h
        if kept + rejected >= call.max_steps or not h >= MIN_STEP_FRACTION * span:
            return proposal, kept, rejected, STEP if err < math.inf else NONFINITE


@jit(entry="the batch engine")
def advance(runs, call, k0, k1, which):
    """Advance the runs ``which`` (indices into :data:`Runs`) over sample intervals
    k0..k1-1 (sample 0 logged and checked first where k0 = 0): interval k with its
    noise held, integrated afresh (:func:`integrate_interval`), the sample at its end
    accumulated into the metrics (:func:`accumulate`) and, where
    :func:`unidyn.model.log.logged` (every ``log_every``-th and where the run stops),
    logged with that noise, as the diagram logs it before the tick."""
    work = work_arrays(NSTATE, eq.NSWITCH)
    X, row = np.empty(NSTATE), np.empty(NLOG)
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
                write_log(row, runs.log_columns, acc, runs.log[i, 0], runs.running[i, 0])
                status = check_state(X, runs.bounds[i])
            if status != OK:
                break
            h, kept, again, status = integrate_interval(loop_rhs, loop_decide, k * Ts,
                                                        (k + 1) * Ts, X, h, args, call, work)
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
            if logged(k + 1, L, status != OK):
                j = log_row(k + 1, L)
                if status == NONFINITE:
                    sample_row((k + 1) * Ts, X, p, noise, runs.references, row)
                write_log(row, runs.log_columns, acc, runs.log[i, j], runs.running[i, j])
            last = k + 1
        # written back once: threads advancing neighbouring runs never share a cache
        # line in the loop above
        for q in range(NSTATE):
            runs.state[i, q] = X[q]
        runs.status[i], runs.last[i], runs.h[i] = status, last, h
        runs.steps[i] += steps
        runs.rejected[i] += rejected
