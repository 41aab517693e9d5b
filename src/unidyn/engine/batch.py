r"""The batch engine: many continuous-control scenarios integrated at once
(:func:`simulate_batch`; the guide ``docs/guides/batch-engine.md`` explains the method).

Each noise interval [k Ts, (k+1) Ts) of a run is integrated with ``substeps`` classical
Runge-Kutta (RK4) steps of the Fig. 2 loop, the noise held over it as in the bdsim
diagram, and results are sampled at t = k Ts like :func:`unidyn.simulate`'s. The step is
short enough for the loop's fastest rate (:func:`stable_substeps`); an interval where a
compensated run's loop is faster at its start (:func:`unidyn.model.equations.loop_step_rate`)
is taken with finer steps; a step across a change of the limits is split where the
change is, located to Ts / :data:`SPLIT_PARTS`; a speed limit is hard. Switching
adaptation on at ``adapt_from`` (a jump) carries an error proportional to the step.

This module chooses the steps and reads the results; the step rule is
:mod:`unidyn.engine.kernels`, compiled by numba where installed or run as plain Python
(:data:`READY_STEPS`); the runs' parameters, noise and initial state come from
:class:`unidyn.engine.rhs.ClosedLoop`. ``tests/evals/`` checks the engine against the
bdsim diagram and a converged ``solve_ivp`` solution.
"""

from __future__ import annotations

import os
import warnings
from concurrent.futures import ThreadPoolExecutor, wait

import numpy as np

from .._errors import SimulationInterrupted
from .._errors import AccuracyWarning
from .._validate import ValidationError, integer
from .rhs import ClosedLoop
from ..model.equations import SWITCH_TOL, TRAJECTORY_KINDS
from ..results.result import Result
from ..model.scenario import ALWAYS_LOGGED, HIGH_GAIN, Scenario

__all__ = ["simulate_batch", "DEFAULT_SUBSTEPS", "AccuracyWarning"]

#: RK4 steps per sample interval Ts: a 10 ms step at Ts = 0.1 s (``python
#: benchmarks/engines.py`` prints the noise-free Fig. 11 IAE against 200 steps per sample).
DEFAULT_SUBSTEPS = 10
BACKENDS = ("auto", "compiled", "plain")

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
#: A step across a change of the limits (on the robot's accelerations or its command) is
#: split where the change is, located to a part of at most Ts / SPLIT_PARTS
#: (:func:`unidyn.engine.kernels.split_depth`).
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

    These are rates of the scenario; the loop's rate also moves with its state (the
    velocity loop the compensator closes scales with theta_hat / theta), which the
    engine checks at every sample (:func:`unidyn.model.equations.loop_step_rate`).
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


#: A process runs the plain copy of the kernels (no compiling) until it has taken this
#: many RK4 steps in all, unless the compiled kernels are in numba's cache already: a
#: first small result does not wait for the compiler, and a process that makes many
#: calls compiles once (saying so on a terminal) and is compiled from then on. (A 200 s
#: run at 0.1 s and 10 steps per sample is 20,000 steps.)
READY_STEPS = 100_000
_plain_steps = [0]  # the RK4 steps this process ran with the plain copy
#: The most RK4 steps per sample interval the engine takes before it refuses.
MAX_SUBSTEPS = 10_000


def stable_substeps(sc: Scenario, substeps: int) -> int:
    """``substeps``, raised where needed so that the RK4 step Ts/substeps stays
    below STEP_RATE_LIMIT / :func:`fastest_rate` (a fast robot such as the
    Khepera III needs a shorter step than the Pioneer, and so does a high gain).

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
    return int(substeps) if m <= substeps else min(m, MAX_SUBSTEPS)


#: RK4 steps the engine takes per thread between updates of the progress bar, compiled
#: and as plain Python (a fraction of a second each); compiled, the interpreter handles
#: Ctrl-C between them. Intervals taken with finer steps are not foreseen: a slice where
#: many are takes longer (Ctrl-C waits for it).
SLICE_STEPS = {True: 200_000, False: 2_000}
#: Show a progress bar (on a terminal) when a call takes at least this many RK4 steps.
PROGRESS_STEPS = 5_000_000


def simulate_batch(scenarios, *, substeps: int = DEFAULT_SUBSTEPS, backend: str = "auto",
                   progress=None) -> list:
    """Simulate many scenarios at once; returns one :class:`~unidyn.Result` per scenario,
    in order.

    Scenarios are grouped by (T, Ts, log_every, log_dtype, log_series) and each group is
    integrated in one call of the kernels; every run's numbers are independent of
    which other runs share its call (bit for bit). Only continuous control is
    supported here (sampled control runs through :func:`unidyn.simulate`).

    A run that diverges (a non-finite state, or a position or speed beyond
    :meth:`~unidyn.Scenario.divergence_bounds`) stops there and is returned with
    ``complete=False``, the samples up to the failure, and a message naming the
    cause; the other runs continue.

    :param scenarios: a sequence of :class:`~unidyn.Scenario`
    :param substeps: RK4 steps per sample interval, integer >= 1; raised where a run's
        fastest rate needs a shorter step (:func:`stable_substeps`; ``Result.substeps``),
        and for each interval where a compensated run's loop is faster at its start
        than that step resolves (|rate h| > STEP_RATE_CHECK: ceil(Ts rate /
        STEP_RATE_REFINED) steps; the most is ``Result.substeps_max``). A step across a
        change of the limits is split there (``Result.split_steps``; the module's
        docstring)
    :param backend: ``"compiled"`` (the kernels compiled by numba: needs numba and the
        built-in trajectories), ``"plain"`` (the same kernels run by Python: no compiling,
        any trajectory, slower per step), or ``"auto"`` (compiled where it can be, except
        while a process has taken fewer than :data:`READY_STEPS` steps and the compiled
        kernels are not in the cache yet; ``Result.backend`` says which ran). Both
        agree to rounding (the compiled sin and cos, :mod:`unidyn.engine.vecmath`, are
        NaN beyond 1e8 rad, a heading after 16 million turns, where the run then stops
        as non-finite)
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
    from .jit import plain_copy
    compilable = all(getattr(s.trajectory, "kind", None) in TRAJECTORY_KINDS for s in scs)
    if backend == "compiled" and not kernels.AVAILABLE:
        raise ValidationError("backend='compiled' needs numba (pip install unidyn[fast])")
    if backend == "compiled" and not compilable:
        raise ValidationError("backend='compiled' runs the figure_eight, circle and line "
                              "trajectories only; use backend='plain' for a FunctionTrajectory")
    m_all = [stable_substeps(s, int(substeps)) for s in scs]  # refuses before any work
    steps = sum(s.steps * m for s, m in zip(scs, m_all))
    compiled = kernels.AVAILABLE and compilable and (backend == "compiled" or (
        backend == "auto"
        and (kernels.compiled() or _plain_steps[0] + steps > READY_STEPS)))
    if not compiled:
        _plain_steps[0] += steps
    engine = kernels if compiled or not kernels.AVAILABLE else plain_copy(kernels)
    groups = {}
    for i, s in enumerate(scs):
        groups.setdefault((s.T, s.Ts, s.log_every, s.log_dtype, s.log_series), []).append(i)
    bar = _Progress(progress, steps, sum(scs[g[0]].steps for g in groups.values()))
    results = [None] * len(scs)
    interrupted = False
    try:
        for idx in groups.values():
            loop = ClosedLoop([scs[i] for i in idx])
            runs = _runs(engine, loop, np.array([m_all[i] for i in idx], dtype=np.int64))
            try:
                _integrate(engine, loop, runs, compiled, bar)
            except KeyboardInterrupt:
                interrupted = True
            for i, r in zip(idx, _results(engine, loop, runs, int(substeps),
                                          "compiled" if compiled else "plain")):
                results[i] = r
            if interrupted:
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


def _runs(kernels, loop: ClosedLoop, m):
    """The per-run arrays (:data:`unidyn.engine.kernels.Runs`) of the runs of ``loop``,
    with m RK4 steps per interval, ready for the first sample."""
    B, sc0 = loop.B, loop.scenarios[0]
    columns, _ = kernels.log_layout(ALWAYS_LOGGED + sc0.log_series)  # the series asked for
    rows = loop.steps // sc0.log_every + 2  # every log_every-th sample, and a run's last
    # the fastest state-dependent rate each run's step resolves; checked where the
    # compensator closes the robot's velocity loop (equations.loop_step_rate)
    checked = np.array([sc.case in ("compensated", "adaptive") for sc in loop.scenarios])
    return kernels.Runs(
        state=loop.initial_state(), params=loop.P, steps=m, noise_pos=loop.pos_noise,
        noise_vel=loop.vel_noise, bounds=np.array([sc.divergence_bounds() for sc in loop.scenarios]),
        rate_max=np.where(checked, STEP_RATE_CHECK * m / loop.Ts, np.inf), log_columns=columns,
        log=np.full((B, rows, len(columns)), np.nan, dtype=sc0.log_dtype),
        status=np.zeros(B, dtype=np.int64), last=np.zeros(B, dtype=np.int64),
        fastest=np.zeros(B), most_steps=m.copy(), rk4_steps=np.zeros(B, dtype=np.int64),
        splits=np.zeros(B, dtype=np.int64))


def _integrate(kernels, loop: ClosedLoop, runs, compiled: bool, bar):
    """Advance ``runs`` through ``kernels`` (the compiled module or its plain copy,
    :func:`unidyn.engine.jit.plain_copy`) in slices of sample intervals. Compiled, a
    thread per core advances its share of the runs (compiled code releases the GIL);
    Ctrl-C then waits for the slice to end, so every run's log stays whole."""
    n = loop.steps
    kernels.PYTHON_REFERENCES[:] = loop.trajectories  # the plain copy's, for FunctionTrajectory
    threads = min(loop.B, os.cpu_count() or 1) if compiled else 1
    # the costliest first, dealt in turn: each thread's share costs about the same
    order = np.argsort(-runs.steps, kind="stable")
    shares = [np.ascontiguousarray(order[j::threads]) for j in range(threads)]
    S = max(1, SLICE_STEPS[compiled] * threads // int(runs.steps.sum()))
    k = 0
    with ThreadPoolExecutor(threads) as pool:
        while True:
            loop.next_noise_window(k)
            k1 = min(n, k + S, loop.noise_end)
            runs = runs._replace(noise_pos=loop.pos_noise, noise_vel=loop.vel_noise)
            call = kernels.Call(float(loop.Ts), loop.noise_k0, loop.scenarios[0].log_every,
                                STEP_RATE_REFINED, MAX_SUBSTEPS, SPLIT_PARTS)
            # a run that diverges overflows, and is stopped by its check: as compiled code
            # does, plain Python goes on with inf and NaN, without numpy's warnings
            with np.errstate(all="ignore"):
                if threads == 1:
                    kernels.advance(runs, call, k, k1, order)
                else:
                    slices = [pool.submit(kernels.advance, runs, call, k, k1, s) for s in shares]
                    try:
                        for f in slices:
                            f.result()
                    finally:
                        wait(slices)
            bar.advance(k1 - k)
            k = k1
            if k >= n or not (runs.status == kernels.OK).any():
                break


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
    """Why the engine cannot vouch for a complete run's accuracy, or "". Above
    :data:`unidyn.model.scenario.HIGH_GAIN` the update law drives the robot across its
    speed and acceleration limits so often that RK4, each crossing located to Ts /
    SPLIT_PARTS, drifts from a converged solution (Scenario(gamma=[g] * 6, adapt_from=0,
    T=20, noise=None), theta_hat off by 1.1e-5 at g = 100, 4e-5 at 300, 1.1e-3 at 1000;
    tests/evals/test_high_gain.py)."""
    lim = sc.limits
    limited = any(np.isfinite(v) for v in (*lim.speed, *lim.accel))
    # a step the caller chose is as accurate as that step, as documented under
    # ``substeps``; only steps the engine had to shorten on its own (stiffness) leave the
    # caller unaware of it
    if (m_max <= asked or not limited or sc.case != "adaptive"
            or max(sc.gamma) <= HIGH_GAIN):
        return ""
    text = (f"complete, but its accuracy is not vouched for: with adaptation gain gamma up to "
            f"{max(sc.gamma):g} (above {HIGH_GAIN:g}) the loop crosses its speed and "
            f"acceleration limits so often that the engine's steps ({m_max} per {sc.Ts:g} s "
            f"sample) drift from a converged solution; lower gamma or the controller gains, "
            f"or run it through unidyn.simulate (the bdsim diagram) with a tight rtol "
            f"(scenario {sc.name or sc.case})")
    warnings.warn(text, AccuracyWarning, stacklevel=5)  # at the caller of simulate_batch
    return text


def _results(kernels, loop: ClosedLoop, runs, asked: int, backend: str) -> list:
    """One Result per run. A run that stopped keeps the samples up to its stop (a
    non-finite last sample is dropped; a run too stiff to go on keeps its samples logged
    before that) and is marked incomplete."""
    L = loop.scenarios[0].log_every
    _, layout = kernels.log_layout(ALWAYS_LOGGED + loop.scenarios[0].log_series)
    out = []
    for i, sc in enumerate(loop.scenarios):
        status, last = int(runs.status[i]), int(runs.last[i])
        nrow = last // L + 1
        t = np.arange(nrow) * (L * loop.Ts)
        if status not in (kernels.OK, kernels.STEP) and last % L != 0:  # the sample it stopped at
            nrow += 1
            t = np.r_[t, last * loop.Ts]
        # the result's arrays are views of the log (no copy)
        log = runs.log[i, :nrow]
        if status == kernels.NONFINITE:  # drop the non-finite sample
            log, t = log[:-1], t[:-1]
        # every sample computed: complete, even if Ctrl-C came after the last
        complete = status == kernels.OK and last == loop.steps
        label = sc.name or sc.case
        t_stop = last * loop.Ts
        if complete:
            message = _unvouched(sc, int(runs.most_steps[i]), asked)
        elif status == kernels.OK:
            message = f"interrupted at t = {t_stop:.6g} s (scenario {label})"
        else:
            last_row = runs.log[i, nrow - 1].astype(float)
            (x, y, _), (u, w) = last_row[layout["pose"]], last_row[layout["velocity"]]
            v = {2: np.hypot(x, y) if nrow else np.nan, 3: abs(u), 4: abs(w),
                 6: runs.fastest[i]}.get(status, 0.0)
            estimate = (f" with theta_hat = {_short(last_row[layout['theta_hat']])}"
                        if "theta_hat" in layout else "")
            what = ("the velocity loop as the compensator closes it" + estimate
                    + (f", or the update law with adaptation gain gamma = {_short(sc.gamma)}"
                       if sc.case == "adaptive" else ""))
            cause = _CAUSE[status].format(v=v, b=runs.bounds[i, status - 2] if 1 < status < 5 else 0.0,
                                          what=what)
            message = f"{cause} at t = {t_stop:.6g} s (scenario {label})"
        series = {k: log[:, layout[k]] if k in layout else None for k in kernels.LOG_SERIES}
        out.append(Result(scenario=sc, t=t, **series, engine="batch", complete=complete,
                          message=message, backend=backend, substeps=int(runs.steps[i]),
                          substeps_max=int(runs.most_steps[i]), rk4_steps=int(runs.rk4_steps[i]),
                          split_steps=int(runs.splits[i])))
    return out
