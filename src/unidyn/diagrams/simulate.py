"""Run a :class:`~unidyn.Scenario` through the bdsim diagram of Fig. 2."""

from __future__ import annotations

import contextlib
import io
import math
import time
import warnings

import numpy as np

from .._errors import AccuracyWarning, SimulationError, SimulationInterrupted
from .._validate import (
    DEFAULT_ATOL,
    DEFAULT_RTOL,
    NonFiniteSignalError,
    ValidationError,
    positive,
    tolerances,
)
from ..model.equations import saturate
from ..model.log import logged
from ..model.scenario import Scenario
from ..progress import Progress
from ..results.result import Result, distance, running

__all__ = ["simulate", "SimulationError", "SimulationInterrupted"]


def _root_cause(err):
    seen = []
    e = err
    while e is not None and e not in seen:
        seen.append(e)
        e = e.__cause__ or e.__context__
    for e in seen:
        if isinstance(e, (NonFiniteSignalError, ValidationError, GuardStop)):
            return e
    return seen[-1]

#: The most right-hand-side evaluations the solver may make in one sample interval
#: Ts before the run is stopped as too stiff for it (RK45 makes six per step).
MAX_RHS_PER_SAMPLE = 5_000
#: Above this adaptation gain (the largest element of ``Scenario.gamma``, Eq. 18) an
#: adaptive run of the diagram is ``complete=False`` unless its ``rtol`` is at most
#: HIGH_GAIN_RTOL: where the acceleration limits clip, the solver steps across their
#: kinks and theta_hat drifts from a converged solution (``python benchmarks/engines.py
#: --accuracy`` measures by how much).
HIGH_GAIN = 100.0
#: The relative tolerance that keeps high-gain adaptive runs converged.
HIGH_GAIN_RTOL = 1e-11
#: From this kinematic gain (the larger of kx, ky, 1/s) on, with finite acceleration
#: limits on a dynamic robot, the limits switch on and off within 15 ms (where the paper's
#: Fig. 11 ends, k = 20-35): bdsim's solver, which cannot locate a switch, steps over such
#: episodes (IAE off by 0.36 % at k = 30 at every rtol from 1e-8 to 1e-10), so the
#: diagram's steps are capped at SWITCHING_STEP there (then within 3e-7 of a converged
#: solution on that run, for 10 % more time); the batch engine locates the switches.
SWITCHING_GAIN = 20.0
#: The diagram's longest step, s, where its limits can switch faster than its steps.
SWITCHING_STEP = 0.005


class GuardStop(ArithmeticError):
    """The diagram's run guard stopped the run: a state beyond its divergence
    bound, more solver work per sample than :data:`MAX_RHS_PER_SAMPLE`, or the
    wall-clock limit."""


class _Guard:
    """What the diagram's :class:`~unidyn.diagrams.monitor.RunMonitor` calls at every
    evaluation: checks the robot's pose and velocities against
    ``Scenario.divergence_bounds``, counts the evaluations per sample interval,
    advances the progress bar and watches the wall clock."""

    def __init__(self, sc, timeout, bar=None):
        self.sc, self.bar = sc, bar
        self.bounds = sc.divergence_bounds()
        self.k, self.count = -1, 0
        self.deadline = None if timeout is None else time.monotonic() + timeout
        self.timeout = timeout

    def __call__(self, t, pose, velocity=None):
        sc = self.sc
        k = int(t / sc.Ts + 1e-9)
        if k > self.k:  # a new sample interval (a probe of its end counts as the next)
            if self.bar is not None and self.k >= 0:
                self.bar.advance(min(k, sc.steps) - min(self.k, sc.steps))
            self.k, self.count = k, 0
        self.count += 1
        if self.count > MAX_RHS_PER_SAMPLE:
            raise GuardStop(
                f"the solver needed more than {MAX_RHS_PER_SAMPLE} evaluations in the sample "
                f"interval from t = {k * sc.Ts:.6g} s (a stiff or diverging loop); a stiff "
                f"solver may resolve it: unidyn.simulate(..., method='LSODA')")
        _check_bounds(pose, velocity, self.bounds, t)
        if self.deadline is not None and time.monotonic() > self.deadline:
            raise GuardStop(f"wall-clock limit of {self.timeout:g} s reached at t = {t:.6g} s")


def _check_bounds(pose, velocity, b, t):
    pose = np.ravel(pose)
    values = [math.hypot(pose[0], pose[1])]
    if velocity is not None:
        values += [abs(v) for v in np.ravel(velocity)[:2]]
    for which, v in enumerate(values):
        if not v <= b[which]:
            raise GuardStop(f"{Scenario.divergence(which, v, b[which])} at t = {t:.6g} s")


def _longest_step(sc) -> float:
    """The diagram's longest step: Ts, or :data:`SWITCHING_STEP` where the acceleration
    limits can switch faster than its steps (:data:`SWITCHING_GAIN`)."""
    if (sc.case_spec.dynamic and max(sc.kx, sc.ky) >= SWITCHING_GAIN
            and np.isfinite(sc.limits.accel).any()):
        return min(sc.Ts, SWITCHING_STEP)
    return sc.Ts


def _unvouched(sc, rtol):
    """Why a complete run's accuracy is not vouched for, or "" (see :data:`HIGH_GAIN`)."""
    gamma = max(sc.gamma)
    if not sc.case_spec.adaptive or gamma <= HIGH_GAIN or rtol <= HIGH_GAIN_RTOL:
        return ""
    return (f"every sample computed, but its accuracy is not vouched for: at adaptation "
            f"gain gamma up to {gamma:g} (above {HIGH_GAIN:g}) with rtol {rtol:g}, the solver "
            f"steps across the kinks where the acceleration limits clip and theta_hat drifts "
            f"from a converged solution; run it with unidyn.simulate(..., "
            f"rtol={HIGH_GAIN_RTOL:g}, atol=1e-13) (scenario {sc.name or sc.case})")


def _logged_before(err, simstate, sc):
    """What bdsim logged before ``err`` stopped the run: (t, the watched signals, the
    message saying where and why it stopped). Raises where it stopped before its start."""
    interrupted = isinstance(err, KeyboardInterrupt)
    if getattr(simstate, "tlist", None) is None:  # failed while bdsim started the blocks
        simstate = None
    cause = err if interrupted else _root_cause(err)
    t_stop = getattr(simstate, "t", None)
    t_stop = float("nan") if t_stop is None else t_stop
    failure = (f"{sc.name or sc.case}: interrupted at t = {t_stop:.6g} s" if interrupted else
               f"{sc.name or sc.case}: run stopped at t = {t_stop:.6g} s: "
               f"{type(cause).__name__}: {cause}")
    if simstate is None:  # it failed before the run started
        if interrupted:
            raise SimulationInterrupted(failure) from err
        if isinstance(cause, GuardStop):
            raise SimulationError(failure) from err
        raise err
    t = np.asarray(simstate.tlist, dtype=float)
    y = [list(p) for p in simstate.plist]
    n = min([len(t)] + [len(p) for p in y])
    return t[:n], [p[:n] for p in y], failure


def simulate(scenario: Scenario, *, rtol: float = DEFAULT_RTOL, atol: float = DEFAULT_ATOL,
             method: str = "RK45", timeout: float | None = None, progress=None,
             max_step: float | None = None, **builder_args) -> Result:
    """Simulate ``scenario`` with bdsim (Fig. 2 diagram, :func:`unidyn.diagrams.build_fig2`).

    The continuous states are integrated by ``scipy.integrate.solve_ivp``
    (``method``) with relative and absolute tolerances ``rtol``, ``atol``;
    results are sampled every ``scenario.Ts``.

    :param max_step: the solver's longest step, s (``None``: ``Ts``, or
        :data:`SWITCHING_STEP` at kinematic gains from :data:`SWITCHING_GAIN` on with
        acceleration limits: bdsim's solver cannot locate where a limit switches, and its
        steps must not jump an episode of clipping)
    :param timeout: wall-clock limit of the run, s (``None``: none). Whatever the
        limit, the run stops (``complete=False``) when the robot's state leaves
        :meth:`~unidyn.Scenario.divergence_bounds` or the solver needs more than
        :data:`MAX_RHS_PER_SAMPLE` evaluations in one sample interval
    :param progress: ``None`` (default: for runs of 2000 samples or more, a tqdm bar on
        stderr when it is a terminal, else a line every few seconds:
        :class:`unidyn.progress.Progress`), ``True``, ``False``, or a callable
        ``f(done_samples, total_samples)``
    :param builder_args: factories passed to :func:`unidyn.diagrams.build_fig2`
        (``robot=``, ``controller=``, ``compensator=``, ``trajectory=``)
    :return: :class:`Result`, its metrics over every sample computed (``log_every``
        thins the series only). A run that stops early (a block meets a NaN, the state
        diverges, the solver stalls, the wall-clock limit) returns the samples and
        metrics up to the stop, ``complete=False``, its ``message`` saying why, as the
        batch engine does. The diagram integrates once: ``numerical_error`` is None.
    :raises SimulationError: if the run fails before its first sample
    :raises SimulationInterrupted: on Ctrl-C, with the samples logged before it
    :warns unidyn._errors.AccuracyWarning: for an adaptive run with adaptation gain
        above :data:`HIGH_GAIN` at an ``rtol`` looser than about :data:`HIGH_GAIN_RTOL`;
        its ``message`` then names the fix
    """
    if not isinstance(scenario, Scenario):
        raise ValidationError(f"scenario must be a unidyn.Scenario, got {type(scenario).__name__}")
    rtol, atol = tolerances(rtol, atol)
    if timeout is not None:
        timeout = positive("timeout", timeout)
    from . import RunMonitor, build_fig2, new_simulator  # bdsim: loaded when a run starts

    sim = new_simulator()
    fig = build_fig2(sim, scenario, **builder_args)
    roles = list(fig.watch)
    sc = scenario
    bar = Progress(progress, sc.steps, show=sc.steps >= 2000, desc="unidyn bdsim")
    # the run guard is a block of the diagram: bdsim evaluates it with the others at
    # every solver evaluation, and hands it the run state (whose tlist and plist log
    # the watched signals) when the run starts, so a run that fails gives back its log
    checked = [fig.watch[r] for r in ("pose", "velocity") if r in fig.watch]
    guard = RunMonitor(_Guard(sc, timeout, bar), nin=len(checked), bd=fig.bd, name="run_guard")
    for i, plug in enumerate(checked):
        fig.bd.connect(plug, guard[i])
    said = io.StringIO()
    try:
        with contextlib.redirect_stdout(said):  # bdsim's notes (e.g. a user block's unused output)
            fig.bd.compile()
    except Exception as err:  # a real error: pass on what bdsim said about it
        raise RuntimeError(f"bdsim could not compile the Fig. 2 diagram: {err}\n"
                           f"{said.getvalue().strip()}") from err
    failure = None
    interrupted = False
    try:
        # bdsim prints a report of a failing block; the exception carries it to the user
        with contextlib.redirect_stdout(io.StringIO()):
            out = sim.run(fig.bd, T=sc.T, dt=sc.Ts, watch=[fig.watch[r] for r in roles],
                          solver=method, solver_args=dict(rtol=rtol, atol=atol,
                                                          max_step=max_step or _longest_step(sc)))
        t = np.asarray(out.t, dtype=float)
        y = out[".ywatch"]
        bar.close()
    except (Exception, KeyboardInterrupt) as err:  # keep what bdsim logged before the failure
        bar.close()
        interrupted = isinstance(err, KeyboardInterrupt)
        t, y, failure = _logged_before(err, guard.simstate, sc)
    if len(t) == 0:
        if interrupted:
            raise SimulationInterrupted(failure)
        raise SimulationError(failure or "no samples", None)
    signals = {r: np.asarray(y[i], dtype=float).reshape(len(t), -1) for i, r in enumerate(roles)}
    # bdsim restarts integration at clock ticks and may log a tick twice: keep
    # the last sample at each grid time and check that the grid is complete
    grid = np.round(t / sc.Ts).astype(int)
    keep = np.r_[grid[1:] != grid[:-1], True]
    t, grid = t[keep], grid[keep]
    signals = {k: v[keep] for k, v in signals.items()}
    expected = sc.steps + 1 if failure is None else len(grid)
    if not np.array_equal(grid, np.arange(len(grid))) or len(grid) != expected:
        raise RuntimeError(f"bdsim returned {len(grid)} samples, expected {expected} "
                           f"on a grid of step {sc.Ts}")
    velocity = signals.get("velocity")
    if velocity is None:  # kinematic robot: v = v_d clipped to the speed limits
        velocity = saturate(signals["v_d"], sc.limits.speed)
    # the metrics over every sample, whatever is logged
    sums = running(grid * sc.Ts, distance(signals["reference"], signals["pose"]), velocity)
    if sc.log_every > 1:
        keep = logged(grid, sc.log_every, (grid == grid[-1]) & (failure is not None))
        grid, velocity, sums = grid[keep], velocity[keep], sums[keep]
        signals = {k: v[keep] for k, v in signals.items()}
    t = grid * sc.Ts
    theta_hat = signals.get("theta_hat")
    if theta_hat is None:
        theta_hat = np.tile(sc.theta_hat_initial, (len(t), 1))
    unvouched = "" if failure is not None else _unvouched(sc, rtol)
    if unvouched:
        warnings.warn(unvouched, AccuracyWarning, stacklevel=2)
    c = lambda a: np.asarray(a, dtype=sc.log_dtype)  # noqa: E731
    kept = lambda k, a: c(a) if k in sc.log_series else None  # noqa: E731 (log_series)
    result = Result(scenario=sc, t=t, pose=c(signals["pose"]), velocity=c(velocity),
                    reference=c(signals["reference"]), v_d=kept("v_d", signals["v_d"]),
                    v_ref=kept("v_ref", signals["v_ref"]),
                    theta_hat=kept("theta_hat", theta_hat), engine="bdsim",
                    complete=failure is None, message=failure or unvouched,
                    backend=f"solve_ivp {method}", running=sums)
    if interrupted:
        raise SimulationInterrupted(failure, result)
    return result
