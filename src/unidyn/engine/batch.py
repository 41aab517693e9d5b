r"""Batch engine: many continuous-control scenarios integrated at once (numpy).

The right-hand side is :class:`unidyn.engine.rhs.ClosedLoop` (the core
functions of :mod:`unidyn.model.unicycle` and :mod:`unidyn.model.laws`, vectorised over
runs). Each noise interval [k Ts, (k+1) Ts) is integrated with ``substeps``
classical Runge-Kutta (RK4) steps, for all runs at once; the noise is constant
inside an interval, exactly as in the bdsim diagram. Results are sampled at the
same grid t = k Ts as :func:`unidyn.simulate`.

The speed limits are enforced exactly: a step that would end beyond one ends on
it (the diagram's adaptive solver holds them to its tolerance). Accuracy is that
of RK4 with step Ts/substeps: fourth order where the loop is
smooth. Two events are not smooth: the limits' clipping (a kink in the
right-hand side) and switching adaptation on at ``adapt_from`` (a jump), which a
fixed step integrates with an error proportional to the step (about 5e-6 m at
substeps=100 for the paper's case 4; bdsim's adaptive solver resolves it).
``tests/evals/test_engines.py`` measures the agreement with the bdsim diagram;
``benchmarks/engines.py`` the speed.

Where each piece lives: the loop's equations in :mod:`unidyn.model.equations`; this module
sets the steps, groups the runs and reads the results; the numpy backend's step
rule is here (:func:`_steps`, :func:`_rk4`, :func:`_split`), the compiled one's in
:mod:`unidyn.engine.kernels` (:func:`~unidyn.engine.kernels.run_groups`), both taking the same
steps; numba's cache and compile notice in :mod:`unidyn.engine.jit`. Until the compiled
kernel was compiled once (per install and version), small calls are answered by the
numpy backend (:data:`READY_STEPS`).

The step is set from the scenario (:func:`stable_substeps`) and checked against the
loop's state at the start of every interval of a compensated run
(:func:`unidyn.model.equations.loop_step_rate`): an estimate far from theta makes the
velocity loop of Eq. (14) much faster than the scenario says, and RK4 unstable. An
interval where |rate h| > :data:`STEP_RATE_CHECK` is integrated again, for that run
alone, with steps short enough for |rate h| <= :data:`STEP_RATE_REFINED`.
"""

from __future__ import annotations

import warnings

import numpy as np

from .._errors import SimulationInterrupted
from .._errors import AccuracyWarning
from .._validate import ValidationError, integer
from .rhs import ClosedLoop
from ..model.equations import STATE, SWITCH_TOL, TRAJECTORY_KINDS, P, saturate
from ..results.result import Result
from ..model.scenario import ALWAYS_LOGGED, HIGH_GAIN, Scenario

__all__ = ["simulate_batch", "DEFAULT_SUBSTEPS", "AccuracyWarning"]

#: RK4 steps per sample interval Ts. With Ts = 0.1 s this is a 10 ms step; on the
#: noise-free Fig. 11 grid the IAE is then within 7.7e-7 (relative) of a run at 200 steps
#: per sample, 5.1e-6 for exact compensation at the highest gains (benchmarks/engines.py prints
#: the measured accuracy).
DEFAULT_SUBSTEPS = 10
#: The loop's state count (:data:`unidyn.model.equations.STATE`).
NSTATE = len(STATE)


def _group(scenarios):
    groups = {}
    for i, s in enumerate(scenarios):
        groups.setdefault((s.T, s.Ts), []).append(i)
    return groups


BACKENDS = ("auto", "numba", "numpy")

#: RK4 is stable for real eigenvalues lambda with |lambda h| < 2.78, and accurate
#: to about 1e-5 per unit time at |lambda h| = 0.5; the step is kept below
#: STEP_RATE_LIMIT / (fastest rate of the loop fixed by the scenario).
STEP_RATE_LIMIT = 0.5
#: The loop's rates that move with its state are checked at the start of every
#: sample interval of a compensated run: where |rate h| exceeds STEP_RATE_CHECK
#: (inside RK4's stability region: 2.78 on the real axis, 2.83 on the imaginary),
#: that interval is integrated with steps short enough for |rate h| <= STEP_RATE_REFINED.
STEP_RATE_CHECK = 2.0
STEP_RATE_REFINED = 1.0
#: A step across a change of the limits (on the robot's accelerations or its command) is split where
#: the change is, located to a part of at most Ts / SPLIT_PARTS
#: (:func:`unidyn.engine.kernels.split_depth`; measured on the noise-free Fig. 11 grid: the
#: IAE within 5e-7 of a converged run with 160, 2.3e-6 with 80, 1e-5 with 40).
SPLIT_PARTS = 160


def _regressor_scale(sc: Scenario) -> np.ndarray:
    r"""Typical magnitudes (2, 6) of the entries of the regressor G of Eq. (14)
    along the run, from the reference's speed and acceleration, the controller's
    saturations and the speed limits.

    With \|nu\| <= \|h_d'\| + l (Eq. 10): \|u_d\| <= U, \|w_d\| <= U/a; the
    robot's speeds are at most the limits (or U, U/a without limits); v_d' is
    bounded through the exact derivative of Eq. (10) (or by U/tau for the filter)."""
    _, V, Acc = sc.reference_scale
    U = V + max(sc.lx, sc.ly)
    Ud, Wd = U, U / sc.a
    vmax, wmax = sc.limits.speed
    Vu = vmax if np.isfinite(vmax) else Ud
    Vw = wmax if np.isfinite(wmax) else Wd
    if sc.derivative == "filter":
        udd, wdd = Ud / sc.tau, Wd / sc.tau
    else:
        nd = Acc + max(sc.kx, sc.ky) * (V + Vu + sc.a * Vw)
        udd = Vw * U + nd
        wdd = udd / sc.a
    s1, s2 = udd + sc.lu, wdd + sc.lw
    return np.array([[s1, 0.0, Wd * Vw, Ud, 0.0, 0.0],
                     [0.0, s2, Ud * Vw + Vu * Wd, 0.0, Vu * Wd, Wd]])


def fastest_rate(sc: Scenario) -> tuple[float, str]:
    """The fastest rate (1/s) in the loop of ``sc`` and what it comes from.

    The candidates are the robot's velocity loops (theta4/theta1, theta6/theta2,
    Eq. 2, with the speed-dependent term of F at the speed limit), the designed
    error dynamics of the kinematic controller (kx, ky) and of the compensator
    (ku, kw), the derivative filter (1/tau) and, for the adaptive case, the update
    law in closed loop with the robot (:func:`unidyn.model.equations.update_law_rate`,
    Eqs. 18/20: sqrt(q), from the regressor G at its typical magnitudes,
    :func:`_regressor_scale`) and the leakage rate gamma_j sigma_j (Eq. 20).

    These are rates of the scenario. The loop's rate also moves with its state: the
    velocity loop that the compensator closes scales with theta_hat / theta
    (:func:`unidyn.model.equations.velocity_loop_rate`), and the update law drifts theta_hat
    far from theta under noise. The engine checks that rate at every sample and takes
    the intervals that need it with finer steps (:func:`simulate_batch`). Measured
    along the Fig. 11 runs with the paper's noise: the update law's own sqrt(q) peaks
    at 11 to 33 1/s, 20 to 60 times below the candidate above, while theta_hat2
    reaches 60 to 320 times theta2 and the velocity loop 650 to 3,300 1/s, for about
    one sample in a hundred (k = 5 to 35). The candidate still sets the step of the
    other samples, and that step is what keeps the IAE at k = 5 and 15 within 1e-5 of
    the diagram's (10 steps per sample with the same check: 3.5e-3 off).
    """
    th = sc.robot.theta
    vmax = sc.limits.speed_max if np.isfinite(sc.limits.speed_max) else 1.0
    f22 = th[5] + abs(th[4] - th[2]) * vmax
    rates = {f"robot time constant theta1/theta4 = {th[0] / th[3]:.3g} s": th[3] / th[0],
             f"robot time constant theta2/theta6 = {th[1] / f22:.3g} s": f22 / th[1],
             f"kinematic gains kx, ky = {sc.kx:g}, {sc.ky:g} 1/s": max(sc.kx, sc.ky)}
    if sc.case in ("compensated", "adaptive"):
        # with exact compensation the velocity error decays at ku, kw plus H^-1 F
        rates[f"compensator gains ku, kw = {sc.ku:g}, {sc.kw:g} 1/s"] = max(sc.ku, sc.kw)
        if sc.derivative == "filter":
            rates[f"derivative filter tau = {sc.tau:g} s"] = 1.0 / sc.tau
    # the update runs from adapt_from (less SWITCH_TOL) on, the step's end t = T included
    if sc.case == "adaptive" and sc.adapt_from - SWITCH_TOL <= sc.T:
        gamma, sigma = np.array(sc.gamma), np.array(sc.sigma)
        with np.errstate(over="ignore", invalid="ignore"):  # a huge gain: inf, refused below
            G = _regressor_scale(sc)
            q = float(np.sum(gamma * (G[0] ** 2 / abs(th[0]) + G[1] ** 2 / abs(th[1]))))
        # the regressor's scale: name what it grows with (v_d' of Eq. 10, Eq. 14)
        _, V, Acc = sc.reference_scale
        rates[f"update law with the robot, Eqs. 18/20: adaptation gain gamma = "
              f"{_short(sc.gamma)}, regressor from the reference (speed {V:.3g} m/s, "
              f"acceleration {Acc:.3g} m/s²), kx, ky = {sc.kx:g}, {sc.ky:g}, "
              f"lx, ly = {sc.lx:g}, {sc.ly:g} and a = {sc.a:g}"] = float(np.sqrt(q))
        leak = {"paper": gamma * sigma, "fx44850": sigma, "none": 0.0 * sigma}[sc.leakage]
        rates[f"leakage gamma*sigma = {float(np.max(leak)):.3g} 1/s (Eq. 20)"] = float(np.max(leak))
    what = max(rates, key=rates.get)
    return rates[what], what


def _short(v) -> str:
    return "[" + ", ".join(f"{x:g}" for x in v) + "]"


#: While the compiled kernel has never been compiled in this version and cache folder
#: (the first calls after an install), ``backend="auto"`` answers a call of at most this
#: many RK4 steps (a 200 s run at 0.1 s and 10 steps per sample is 20,000) with the
#: numpy backend, which needs no compiling, rather than compile first; a larger call
#: compiles (once per install, saying so on a terminal) and is then compiled throughout.
READY_STEPS = 100_000
#: The most RK4 steps per sample interval the engine takes before it refuses.
MAX_SUBSTEPS = 10_000


def stable_substeps(sc: Scenario, substeps: int) -> int:
    """``substeps``, raised where needed so that the RK4 step Ts/substeps stays
    below STEP_RATE_LIMIT / :func:`fastest_rate` (a fast robot such as the
    Khepera III needs a shorter step than the Pioneer, and so does a high gain); a
    raised count is rounded up to one of few values (:func:`_round_up`).

    :raises ValidationError: if that needs more than :data:`MAX_SUBSTEPS` steps per
        sample; the message names the time constant responsible
    """
    rate, what = fastest_rate(sc)
    need = sc.Ts * rate / STEP_RATE_LIMIT
    if not np.isfinite(need) or need > MAX_SUBSTEPS:
        raise ValidationError(
            f"{sc.name or sc.case}: the batch engine would need more than {MAX_SUBSTEPS} RK4 "
            f"steps per {sc.Ts:g} s sample for the fastest rate of this loop ({what}); use a "
            f"shorter Ts, or unidyn.simulate (the bdsim diagram, adaptive step)")
    m = int(np.ceil(need - 1e-9))
    return int(substeps) if m <= substeps else min(_round_up(m), MAX_SUBSTEPS)


def _round_up(m: int) -> int:
    """m rounded up to the next number of the form 2^e (4, 5, 6 or 7) / 4 (at most
    25 % more steps). Raised step counts then fall on few values, so runs whose
    rates differ a little (a sweep over gains) share their steps and can be
    integrated side by side (:data:`unidyn.engine.kernels.LANES`); each run's count still
    depends on that run alone."""
    e = max(0, m.bit_length() - 3)
    return -(-m // (1 << e)) << e


#: RK4 steps the compiled engine takes per thread between returns to Python (a group
#: of runs in SIMD lanes counts as one): the interpreter can then handle Ctrl-C and
#: update the progress bar (about 0.1 s). Intervals taken again with finer steps are
#: not foreseen: a slice where many are takes longer (Ctrl-C waits for it).
SLICE_STEPS = 200_000
#: Show a progress bar (on a terminal) when a call takes at least this many RK4 steps.
PROGRESS_STEPS = 5_000_000


def simulate_batch(scenarios, *, substeps: int = DEFAULT_SUBSTEPS, backend: str = "auto",
                   progress=None) -> list:
    """Simulate many scenarios at once; returns one :class:`~unidyn.Result` per scenario,
    in order.

    Scenarios are grouped by (T, Ts, substeps, log_every, log_dtype) and each group is
    integrated as one vectorised system; every run's numbers are independent of
    which other runs share its call (bit for bit). Only continuous control is
    supported here (sampled control runs through :func:`unidyn.simulate`).

    A run that diverges (a non-finite state, or a position or speed beyond
    :meth:`~unidyn.Scenario.divergence_bounds`) stops there and is returned with
    ``complete=False``, the samples up to the failure, and a message naming the
    cause; the other runs continue.

    :param scenarios: a sequence of :class:`~unidyn.Scenario`
    :param substeps: RK4 steps per sample interval, integer >= 1; raised
        automatically where a run's fastest time constant needs a shorter step for
        RK4 to be stable (:func:`stable_substeps`; the value used is
        ``Result.substeps``), and for the intervals where a compensated run's loop is
        faster than that step resolves: both backends check the loop's
        state-dependent rate (:func:`unidyn.model.equations.loop_step_rate`) at the start of
        every interval, and where |rate h| > STEP_RATE_CHECK that run's interval is
        integrated alone with ceil(Ts rate / STEP_RATE_REFINED) steps (the most it
        took is ``Result.substeps_max``; it depends on that run alone). A step
        across a change of the limits (a limit starts or stops clipping the robot's
        accelerations or its command, or a speed limit is reached: a kink or a jump
        of the right-hand side, where RK4 loses its order; the step's stages
        disagree on which limits act) is split there: the change is located by bisection to a
        part of at most Ts / SPLIT_PARTS, and the step up to that part, the part and
        the rest are steps of their own (``Result.split_steps`` counts the splits).
        Without it the noise-free Fig. 11 IAE was up to 1e-4 from a converged run at
        the default step
    :param backend: ``"numba"`` (compiled kernel, :mod:`unidyn.engine.kernels`; needs numba and
        the built-in trajectories), ``"numpy"`` (vectorised numpy), or ``"auto"`` (numba
        when it can be used, else numpy; numpy also for a call of at most
        :data:`READY_STEPS` RK4 steps while the kernel was never compiled: the first
        result after an install does not wait for the compiler; ``Result.backend`` says
        which ran). Both integrate the same equations with the
        same steps and agree to rounding (the compiled sin and cos,
        :mod:`unidyn.engine.vecmath`, are NaN beyond 1e8 rad, a heading after 16 million
        turns, where the run then stops as non-finite).
    :param progress: ``None`` (default: a tqdm progress bar on stderr for long calls,
        only when stderr is a terminal), ``False`` (none), ``True`` (always a bar), or a
        callable ``f(done_samples, total_samples)``
    The results of one call share the engine's log: each result's series are views of
    one array holding every run of its group (no copy), so keeping one result keeps
    that array; ``np.array(r.pose)`` and the like copy what is to outlive the rest.

    :raises SimulationInterrupted: on Ctrl-C (a KeyboardInterrupt); its ``results``
        hold one entry per scenario: the computed part, marked incomplete (``None``
        for a run not yet started); ``result`` is the first of them
    """
    scs = list(scenarios)
    if not scs:
        return []
    for s in scs:
        if not isinstance(s, Scenario):
            raise ValidationError(f"scenarios must be unidyn.Scenario objects, got {type(s).__name__}")
        if s.control != "continuous":
            raise ValidationError("the batch engine runs control='continuous' only; "
                                  "use unidyn.simulate (engine 'bdsim') for sampled control")
    substeps = integer("substeps", substeps, 1, MAX_SUBSTEPS)
    if backend not in BACKENDS:
        raise ValidationError(f"backend must be one of {', '.join(BACKENDS)}; got {backend!r}")
    from . import kernels  # numba loads with the kernels
    compilable = all(getattr(s.trajectory, "kind", None) in TRAJECTORY_KINDS for s in scs)
    if backend == "numba" and not kernels.AVAILABLE:
        raise ValidationError("backend='numba' needs numba (pip install unidyn[fast])")
    if backend == "numba" and not compilable:
        raise ValidationError("backend='numba' supports the figure_eight, circle and line "
                              "trajectories only; use backend='numpy' for a FunctionTrajectory")
    m_all = [stable_substeps(s, int(substeps)) for s in scs]  # refuses before any work
    use_numba = backend == "numba" or (
        backend == "auto" and kernels.AVAILABLE and compilable
        and (kernels.compiled() or sum(s.steps * m for s, m in zip(scs, m_all)) > READY_STEPS))
    groups = {}
    for i, s in enumerate(scs):
        key = (s.T, s.Ts, s.log_every, s.log_dtype, s.log_series) + (() if use_numba else (m_all[i],))
        groups.setdefault(key, []).append(i)
    bar = _Progress(progress, sum(scs[i].steps * m_all[i] for i in range(len(scs))),
                    sum(scs[g[0]].steps for g in groups.values()))
    results = [None] * len(scs)
    interrupted = False
    try:
        for idx in groups.values():
            loop = ClosedLoop([scs[i] for i in idx])
            m = np.array([m_all[i] for i in idx], dtype=np.int64)
            run = _Run(loop, m, asked=int(substeps))
            try:
                if use_numba:
                    _integrate_numba(run, bar)
                else:
                    _integrate(run, int(m[0]), bar)
            except KeyboardInterrupt:
                run.interrupted = True
            for j, r in enumerate(run.results()):
                results[idx[j]] = r
            if run.interrupted:
                interrupted = True
                break
    finally:
        bar.close()
    if interrupted:
        done = [r for r in results if r is not None]
        raise SimulationInterrupted(
            f"interrupted: {sum(r.complete for r in done)} of {len(scs)} run(s) complete; "
            f"the computed part of the others is kept, marked incomplete", results=results)
    return results


class _Progress:
    """tqdm over samples, or a user callable, or nothing."""

    def __init__(self, progress, work: int, total: int):
        self.f, self.bar, self.done, self.total = None, None, 0, total
        if callable(progress) and not isinstance(progress, bool):
            self.f = progress
        elif progress is True or (progress is None and work >= PROGRESS_STEPS):
            import sys

            from tqdm import tqdm
            self.bar = tqdm(total=total, unit="sample", desc="unidyn batch", leave=False,
                            disable=None if progress is None else False, file=sys.stderr,
                            mininterval=0.5)

    def advance(self, n: int):
        self.done += n
        if self.f is not None:
            self.f(self.done, self.total)
        if self.bar is not None:
            self.bar.update(n)

    def close(self):
        if self.bar is not None:
            self.bar.close()


class _Run:
    """The logged arrays of one group of runs, filled by either backend."""

    def __init__(self, loop: ClosedLoop, m, asked: int):
        self.loop, self.m = loop, m
        self.asked = asked  # the steps per sample the caller chose; more is the engine's doing
        n, B = loop.steps, loop.B
        self.L = L = int(loop.scenarios[0].log_every)
        rows = n // L + 2  # every L-th sample, plus the one a run stops at
        from .kernels import log_layout  # (here: importing _kernels loads numba)
        sc0 = loop.scenarios[0]
        # only the columns of the series asked for (Scenario.log_series)
        self.cols, self.layout = log_layout(ALWAYS_LOGGED + sc0.log_series)
        self.LOG = np.full((B, rows, len(self.cols)), np.nan, dtype=sc0.log_dtype)
        self.status = np.zeros(B, dtype=np.int64)
        self.last = np.zeros(B, dtype=np.int64)
        self.bounds = np.array([sc.divergence_bounds() for sc in loop.scenarios])
        # the fastest state-dependent rate each run's step resolves; checked where the
        # compensator closes the robot's velocity loop (equations.loop_step_rate)
        checked = np.array([sc.case in ("compensated", "adaptive") for sc in loop.scenarios])
        self.rate_max = np.where(checked, STEP_RATE_CHECK * np.asarray(m) / loop.Ts, np.inf)
        self.seen = np.zeros(B)  # the fastest rate met
        self.m_max = np.array(m, dtype=np.int64)  # the most steps an interval took
        self.work = np.zeros(B, dtype=np.int64)  # RK4 steps taken
        self.splits = np.zeros(B, dtype=np.int64)  # steps split at a change of the limits
        self.interrupted = False
        self.backend = ""

    def results(self) -> list:
        return _results(self)


def _lane_groups(loop: ClosedLoop, m):
    """The runs of ``loop`` in groups of at most LANES that share their steps per
    interval and their reference (the compiled engine integrates a group in SIMD
    lanes), the costliest first: (runs (G, LANES), lanes used (G,), steps (G,))."""
    from .kernels import LANES  # numba loads with the kernels
    ref = loop.P[:, P.trajectory:]
    keys = {}
    for i in range(loop.B):
        keys.setdefault((int(m[i]),) + tuple(ref[i]), []).append(i)
    groups = [(key[0], idx[j:j + LANES]) for key, idx in keys.items()
              for j in range(0, len(idx), LANES)]
    groups.sort(key=lambda g: -g[0] * len(g[1]))
    runs = np.zeros((len(groups), LANES), dtype=np.int64)
    for g, (_, idx) in enumerate(groups):
        runs[g, :len(idx)] = idx
        runs[g, len(idx):] = idx[0]  # unused lanes: never computed
    return (runs, np.array([len(idx) for _, idx in groups], dtype=np.int64),
            np.array([mg for mg, _ in groups], dtype=np.int64))


def _integrate_numba(run: _Run, bar):
    from . import kernels  # numba loads with the kernels
    loop = run.loop
    run.backend = "numba (compiled)"
    n = loop.steps
    X = loop.initial_state()

    def runs():  # the per-run arrays (the noise window's arrays change as it moves on)
        return kernels.Runs(loop.P, loop.pos_noise, loop.vel_noise, run.bounds, run.rate_max,
                             run.cols, run.LOG, run.status, run.last, run.seen, run.m_max,
                             run.work, run.splits)
    kernels.start(X, runs())
    lanes, count, steps = _lane_groups(loop, run.m)
    # lane-minor: value i of lane b at [i * LANES + b]
    group = kernels.Groups(
        np.ascontiguousarray(X[lanes].transpose(0, 2, 1)).reshape(len(lanes), -1),
        np.ascontiguousarray(loop.P[lanes].transpose(0, 2, 1)).reshape(len(lanes), -1),
        lanes, count, steps)
    import os
    per_thread = -(-len(lanes) // max(1, min(len(lanes), os.cpu_count() or 1)))
    S = max(1, SLICE_STEPS // (int(steps.max()) * per_thread))
    k = 0
    import numba
    # groups differ in cost (their steps per sample): hand them to the threads one at
    # a time, not in two contiguous halves
    previous = numba.set_parallel_chunksize(1)
    try:
        while k < n and (run.status == kernels.OK).any():
            loop.next_noise_window(k)
            k1 = min(n, k + S, loop.noise_end)
            call = kernels.Call(float(loop.Ts), loop.noise_k0, n, run.L, STEP_RATE_REFINED,
                                 MAX_SUBSTEPS, SPLIT_PARTS)
            kernels.run_groups(group, runs(), call, k, k1)
            bar.advance(k1 - k)
            k = k1
    finally:
        numba.set_parallel_chunksize(previous)


def _integrate(run: _Run, m: int, bar):
    """The numpy backend: fills the same arrays as the compiled kernel."""
    from .kernels import NONFINITE, OK, POSITION, SPEED_U, SPEED_W  # numba loads with the kernels
    loop = run.loop
    run.backend = "numpy"
    h = loop.Ts / m
    X = loop.initial_state()
    b = run.bounds

    def check(X):
        with np.errstate(invalid="ignore"):
            return np.select(
                [~np.isfinite(X).all(axis=1), np.hypot(X[:, 0], X[:, 1]) > b[:, 0],
                 np.abs(X[:, 3]) > b[:, 1], np.abs(X[:, 4]) > b[:, 2]],
                [NONFINITE, POSITION, SPEED_U, SPEED_W], OK)

    dynamic = loop.P[:, P.dynamic, None] != 0.0

    def record(rows, X, t, noise_k, which):  # the columns of kernels.LOG_COLUMNS
        s = loop.signals(t, X, noise_k)
        v_ref = saturate(s["v_ref"], loop.vmax)
        # a kinematic robot moves at its clipped command
        row = np.concatenate([X[:, :3], np.where(dynamic, X[:, 3:5], v_ref), X[:, 5:11],
                              s["h_d"], s["v_d"], v_ref], axis=1)[:, run.cols]
        for i in np.flatnonzero(which):
            run.LOG[i, rows[i]] = row[i]

    run.status[:] = check(X)
    record(np.zeros(loop.B, dtype=int), X, 0.0, 0, np.ones(loop.B, bool))
    with np.errstate(all="ignore"):  # a run that stopped may overflow; it is no longer logged
        _steps(run, loop, X, m, h, check, record, bar)


def _stages(loop, X, t, h, k, rows):
    """RK4's four stages of the step of length h from (t, X) in noise interval k, for
    the runs ``rows`` (X theirs only): each the rates (B, 13) and, in a last column,
    which limits act (:func:`unidyn.model.equations.limit_state`)."""
    k1 = loop.rhs(t, X, k, rows, limits=True)
    k2 = loop.rhs(t + 0.5 * h, X + 0.5 * h * k1[:, :NSTATE], k, rows, limits=True)
    k3 = loop.rhs(t + 0.5 * h, X + 0.5 * h * k2[:, :NSTATE], k, rows, limits=True)
    k4 = loop.rhs(t + h, X + h * k3[:, :NSTATE], k, rows, limits=True)
    return k1, k2, k3, k4


def _changes(ks):
    """Whether each run's stages disagree on which limits act (as
    :func:`unidyn.engine.kernels._limit_changes`)."""
    c = [d[:, NSTATE] for d in ks]
    return (c[0] != c[1]) | (c[0] != c[2]) | (c[0] != c[3])


def _combine(loop, X, h, ks, rows):
    """RK4's step from its stages; the speed limits are hard: a step that crosses one
    ends on it."""
    k1, k2, k3, k4 = (d[:, :NSTATE] for d in ks)
    Xn = X + h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
    Xn[:, 3:5] = saturate(Xn[:, 3:5], loop.vmax[rows])
    return Xn


def _split(loop, X, tb, h, k, depth, ks, row):
    """Run ``row``'s step of length h from (tb, X (1, 13)), split where it crosses a
    change of the limits, as :func:`unidyn.engine.kernels._split` does it (the same parts
    and probes, in the same arithmetic); ks: the step's stages when it was computed
    and crosses one, else None. Returns (the state, RK4 steps computed, changes
    located)."""
    from .kernels import _dense_weights  # numba loads with the kernels
    _dense_weights = getattr(_dense_weights, "py_func", _dense_weights)  # plain Python here
    rows = np.array([row])
    U = 1 << depth
    steps = located = 0
    pos, end, klo, khi = 0, U, -1, -1
    while pos < U:
        hh = (end - pos) * (h / U)
        t = tb + pos * (h / U)
        if ks is None:
            ks = _stages(loop, X, t, hh, k, rows)
            steps += 1
        if end - pos > 1 and _changes(ks)[0]:
            located += 1
            c1 = ks[0][0, NSTATE]
            lo, hi = pos, end
            while hi - lo > 1:
                q = (lo + hi) // 2
                b1, b2, b4 = _dense_weights((q - pos) / (end - pos))
                dc = (b1 * ks[0] + b2 * (ks[1] + ks[2]) + b4 * ks[3])[:, :NSTATE]
                d = loop.rhs(tb + q * (h / U), X + hh * dc, k, rows, limits=True)
                if d[0, NSTATE] == c1:
                    lo = q
                else:
                    hi = q
            if lo > pos:  # up to the part first, then the part
                end, klo, khi = lo, lo, hi
            else:
                end = hi
            ks = None
            continue
        X = _combine(loop, X, hh, ks, rows)
        ks = None
        pos = end
        end = khi if pos == klo else U
    return X, steps, located


def _rk4(loop, X, t0, k, m, h, rows, work, splits):
    """m RK4 steps of length h from (t0, X) in noise interval k for the runs ``rows``
    (X theirs only), as the compiled engine takes them (:func:`unidyn.engine.kernels._steps_lanes`):
    a run's step that crosses a change of the limits (on its accelerations or its
    command) is split
    there (:func:`_split`). work and splits (per run of the batch) count the RK4
    steps beyond m and the changes located."""
    from .kernels import split_depth  # numba loads with the kernels
    depth = getattr(split_depth, "py_func", split_depth)(m, SPLIT_PARTS)  # plain Python here
    for j in range(m):
        tb = t0 + j * h
        ks = _stages(loop, X, tb, h, k, rows)
        Xn = _combine(loop, X, h, ks, rows)
        if depth > 0:
            for r in np.flatnonzero(_changes(ks)):
                Xn[r], steps, located = _split(loop, X[r:r + 1], tb, h, k, depth,
                                               tuple(d[r:r + 1] for d in ks), rows[r])
                work[rows[r]] += steps
                splits[rows[r]] += located
        X = Xn
    return X


def _steps(run, loop, X, m, h, check, record, bar):
    from .kernels import OK, STEP  # numba loads with the kernels
    Ts, n, L = loop.Ts, loop.steps, run.L
    checked = np.isfinite(run.rate_max)
    for k in range(n):
        running = run.status == OK
        if not running.any():
            break
        loop.next_noise_window(k)
        t0 = k * Ts
        finer = np.zeros(loop.B, dtype=bool)
        mk = np.full(loop.B, m, dtype=np.int64)  # this interval's steps, run by run
        if (checked & running).any():  # as kernels._interval_steps
            rate = np.where(checked & running, loop.step_rate(t0, X, k), 0.0)  # NaN: not finer
            run.seen = np.fmax(run.seen, rate)
            finer = rate > run.rate_max
            need = Ts * rate / STEP_RATE_REFINED
            too = finer & ~(need <= MAX_SUBSTEPS)
            run.status[too], run.last[too] = STEP, k
            running &= ~too
            finer &= ~too
            mk = np.where(finer, np.ceil(np.where(finer, need, 0.0)), m).astype(np.int64)
            run.m_max = np.maximum(run.m_max, mk)
            run.work += np.where(finer, mk, 0)
            if not running.any():
                break
        run.work += np.where(running, m, 0)
        work, split = np.zeros(loop.B, dtype=np.int64), np.zeros(loop.B, dtype=np.int64)
        X0, X = X, _rk4(loop, X, t0, k, m, h, np.arange(loop.B), work, split)
        run.work += np.where(running, work, 0)
        run.splits += np.where(running & ~finer, split, 0)
        for mk_value in np.unique(mk[finer]):
            # these runs' interval again, with their own finer step (each row of the
            # numpy engine is computed independently of the others)
            rows = np.flatnonzero(finer & (mk == mk_value))
            X[rows] = _rk4(loop, X0[rows], t0, k, int(mk_value), Ts / mk_value, rows,
                           run.work, run.splits)
        status = np.where(running, check(X), run.status)
        stopped = running & (status != OK)
        # the sample at the end of interval k is logged with interval k's
        # measurement, as the diagram logs it just before the clock tick
        if (k + 1) % L == 0 or stopped.any():
            rows = np.where(stopped & ((k + 1) % L != 0), (k + 1) // L + 1, (k + 1) // L)
            record(rows, X, (k + 1) * Ts, k, running & (stopped | ((k + 1) % L == 0)))
        run.last[running] = k + 1
        run.status[:] = status
        bar.advance(1)


_CAUSE = {
    1: "non-finite state (diverged, or the loop is too stiff for the RK4 step; "
       "unidyn.simulate with method='LSODA' can tell which)",
    2: "diverged: the position |(x, y)| = {v:.3g} m is beyond {b:.3g} m "
       "(1e6 times the reference's size)",
    3: "diverged: |u| = {v:.3g} m/s is beyond {b:.3g} m/s (1e6 times the speed limit, "
       "or the speed the controller asks for)",
    4: "diverged: |w| = {v:.3g} rad/s is beyond {b:.3g} rad/s (1e6 times the steering "
       "limit, or the turn rate the controller asks for)",
    6: "too stiff for the batch engine: the loop reached a rate of {v:.3g} 1/s ({what}), "
       "beyond what " + f"{MAX_SUBSTEPS:,}" + " RK4 steps per sample resolve; use a shorter "
       "Ts, or unidyn.simulate (the bdsim diagram, adaptive step)",
}


def _unvouched(sc: Scenario, m_max: int, asked: int) -> str:
    """Why the engine cannot vouch for a complete run's accuracy, or "". At SPLIT_PARTS
    steps per sample or more, a step that crosses a change of the limits is no longer
    split (:func:`unidyn.engine.kernels.split_depth`): RK4 is then second order across each
    kink, and at high adaptation gains the estimate drifts from a converged solution
    (Scenario(gamma=[1000] * 6, adapt_from=0, T=20, noise=None): theta_hat 1.2e-3 off,
    against 5.5e-6 at gamma = 100)."""
    lim = sc.limits
    limited = any(np.isfinite(v) for v in (*lim.speed, *lim.accel))
    # a step the caller chose is as accurate as that step: second order at the kinks,
    # as documented under ``substeps``; only steps the engine had to shorten on its own
    # (stiffness) leave the caller unaware of it. Below HIGH_GAIN, and without
    # adaptation, runs at these steps agree with the diagram to 1e-6 (Fig. 11's gains
    # up to 35, tests/evals/test_engines.py); a high-gain update law is what drifts
    if (m_max < SPLIT_PARTS or m_max <= asked or not limited or sc.case != "adaptive"
            or max(sc.gamma) <= HIGH_GAIN):
        return ""
    text = (f"complete, but its accuracy is not vouched for: the loop needed {m_max} RK4 steps "
            f"per {sc.Ts:g} s sample (at least {SPLIT_PARTS}), where the engine no longer "
            f"splits steps at the speed and acceleration limits and is second order there; "
            f"lower the adaptation gain gamma or the controller gains, or run it through "
            f"unidyn.simulate (the bdsim diagram) with a tight rtol (scenario {sc.name or sc.case})")
    warnings.warn(text, AccuracyWarning, stacklevel=5)  # at the caller of simulate_batch
    return text


def _results(run: _Run) -> list:
    """One Result per run of ``run``. A run that stopped keeps the samples up to
    its stop (a non-finite last sample is dropped; a run too stiff to go on keeps
    its samples logged before that) and is marked incomplete."""
    from . import kernels  # numba loads with the kernels
    loop, L = run.loop, run.L
    n = loop.steps
    out = []
    for i, sc in enumerate(loop.scenarios):
        status, last = int(run.status[i]), int(run.last[i])
        nrow = last // L + 1
        t = np.arange(nrow) * (L * loop.Ts)
        if status not in (0, kernels.STEP) and last % L != 0:  # the sample it stopped at
            nrow += 1
            t = np.r_[t, last * loop.Ts]
        # the result's arrays are views of the log (no copy)
        log = run.LOG[i, :nrow]
        if status == 1:  # drop the non-finite sample
            log, t = log[:-1], t[:-1]
        # every sample computed: complete, even if Ctrl-C came after the last
        complete = status == 0 and last == n
        label = sc.name or sc.case
        t_stop = last * loop.Ts
        if complete:
            message = _unvouched(sc, int(run.m_max[i]), run.asked)
        elif status == 0:
            message = f"interrupted at t = {t_stop:.6g} s (scenario {label})"
        else:
            last_row = run.LOG[i, nrow - 1].astype(float)
            (x, y, _), (u, w) = last_row[run.layout["pose"]], last_row[run.layout["velocity"]]
            v = {2: np.hypot(x, y) if nrow else np.nan, 3: abs(u), 4: abs(w),
                 6: run.seen[i]}.get(status, 0.0)
            estimate = (f" with theta_hat = {_short(last_row[run.layout['theta_hat']])}"
                        if "theta_hat" in run.layout else "")
            what = ("the velocity loop as the compensator closes it" + estimate
                    + (f", or the update law with adaptation gain gamma = {_short(sc.gamma)}"
                       if sc.case == "adaptive" else ""))
            cause = _CAUSE[status].format(v=v, b=run.bounds[i, status - 2] if 1 < status < 5 else 0.0,
                                          what=what)
            message = f"{cause} at t = {t_stop:.6g} s (scenario {label})"
        series = {k: log[:, run.layout[k]] if k in run.layout else None
                  for k in kernels.LOG_SERIES}
        out.append(Result(scenario=sc, t=t, **series, engine="batch", complete=complete,
                          message=message, backend=run.backend, substeps=int(run.m[i]),
                          substeps_max=int(run.m_max[i]), rk4_steps=int(run.work[i]),
                          split_steps=int(run.splits[i])))
    return out
