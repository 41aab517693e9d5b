r"""The batch engine: many continuous-control scenarios integrated at once
(:func:`simulate_batch`; the guide ``docs/guides/batch-engine.md`` explains the method).

Each noise interval [k Ts, (k+1) Ts) of a run is integrated on its own, the noise held
over it as in the bdsim diagram, by the Dormand-Prince 5(4) pair with step-size control
(the method of ``solve_ivp``'s RK45, which bdsim restarts at every clock tick in the same
way): a step is kept where its error estimate is within ``atol + rtol |x|`` (the
root mean square over the states, as ``solve_ivp``'s), and taken again shorter where
not. Whatever makes a step inaccurate (a fast reference,
a high gain, a fast robot, a limit starting to act) shortens it; no rate of the loop has
to be foreseen. Results are sampled at t = k Ts like :func:`unidyn.simulate`'s.

This module reads the runs and the results; the step rule is
:mod:`unidyn.engine.kernels`, compiled by numba where installed or run as plain Python
(:func:`backend_for`); the runs' parameters, noise and initial state come from
:class:`unidyn.engine.rhs.ClosedLoop`. ``tests/engine/test_accuracy.py`` holds the
engine to converged ``solve_ivp`` solutions.
"""

from __future__ import annotations

import dataclasses
import os
from concurrent.futures import ThreadPoolExecutor, wait

import numpy as np

from .._errors import SimulationInterrupted
from .._validate import ValidationError, positive
from ..model.equations import TRAJECTORY_KINDS
from ..model.scenario import ALWAYS_LOGGED, Scenario
from ..results.result import Result
from .rhs import ClosedLoop

__all__ = ["simulate_batch", "backend_for", "tolerances", "DEFAULT_RTOL", "DEFAULT_ATOL", "MAX_STEPS"]

#: The tolerances of the error control, as ``solve_ivp``'s ``rtol`` and ``atol`` (and
#: the same defaults as :func:`unidyn.simulate`'s): each step's error estimate, relative
#: to atol + rtol |x| for each state x, is at most 1 in the root mean square.
DEFAULT_RTOL = 1e-8
DEFAULT_ATOL = 1e-10
#: What a complete result promises: its IAE within PROMISE (relative) and its
#: theta_hat within PROMISE (absolute) of a converged solution. Each run is checked
#: against a second one at CHECK_FACTOR times the tolerances, which is less accurate:
#: their difference bounds the result's error. A run whose check differs by more is
#: returned with ``complete=False``, saying so.
PROMISE = 1e-4
CHECK_FACTOR = 10.0
#: The most steps (kept or taken again) one sample interval may take; a run whose
#: interval needs more stops there, ``complete=False``, saying why.
MAX_STEPS = 10_000
BACKENDS = ("auto", "compiled", "plain")
#: Samples (runs x intervals) the engine advances between updates of the progress bar,
#: compiled and as plain Python (a fraction of a second each); compiled, the
#: interpreter handles Ctrl-C between them.
SLICE_SAMPLES = {True: 50_000, False: 200}
#: Show a progress bar (on a terminal) when a call holds at least this many samples.
PROGRESS_SAMPLES = 1_000_000


def backend_for(scenarios, backend: str = "auto") -> str:
    """The backend that runs ``scenarios``: ``"compiled"`` or ``"plain"``, from the call
    alone (never from what the process ran before: the same call gives the same bits).

    :param backend: ``"compiled"`` (needs numba and the built-in trajectories),
        ``"plain"``, or ``"auto"``: compiled where numba is installed and every trajectory
        is a built-in one, else plain
    :raises ValidationError: for another backend, or ``"compiled"`` where it cannot run
    """
    from . import kernels  # numba loads with the kernels
    if backend not in BACKENDS:
        raise ValidationError(f"backend must be one of {', '.join(BACKENDS)}; got {backend!r}")
    compilable = all(getattr(s.trajectory, "kind", None) in TRAJECTORY_KINDS for s in scenarios)
    if backend == "compiled" and not kernels.AVAILABLE:
        raise ValidationError("backend='compiled' needs numba (pip install unidyn[fast])")
    if backend == "compiled" and not compilable:
        raise ValidationError("backend='compiled' runs the figure_eight, circle and line "
                              "trajectories only; use backend='plain' for a FunctionTrajectory")
    if backend == "compiled" or (backend == "auto" and kernels.AVAILABLE and compilable):
        return "compiled"
    return "plain"


def tolerances(rtol, atol) -> tuple:
    """(rtol, atol) as floats, checked: rtol in [1e-13, 0.1], atol > 0.

    :raises ValidationError: naming the one out of range"""
    rtol, atol = positive("rtol", rtol), positive("atol", atol)
    if not 1e-13 <= rtol <= 0.1:
        raise ValidationError(f"rtol must lie in [1e-13, 0.1] (float64 resolves no finer); "
                              f"got {rtol:g}")
    return float(rtol), float(atol)


def simulate_batch(scenarios, *, rtol: float = DEFAULT_RTOL, atol: float = DEFAULT_ATOL,
                   backend: str = "auto", progress=None) -> list:
    """Simulate many scenarios at once; returns one :class:`~unidyn.Result` per scenario,
    in order.

    Scenarios are grouped by (T, Ts, log_every, log_dtype, log_series) and each group is
    integrated in one call of the kernels; every run's numbers are independent of which
    other runs share its call and of what the process ran before (bit for bit). Only
    continuous control is supported here (sampled control runs through
    :func:`unidyn.simulate`).

    A run that diverges (a non-finite state, or a position or speed beyond
    :meth:`~unidyn.Scenario.divergence_bounds`), or whose error cannot be held within
    the tolerances in :data:`MAX_STEPS` steps of a sample interval, stops there and is
    returned with ``complete=False``, the samples up to the failure, and a message
    naming the cause and what to change; the other runs continue.

    Every run is integrated twice: at ``rtol``, ``atol`` (the result) and at
    :data:`CHECK_FACTOR` times them (its check). Where their IAE differ by more than
    :data:`PROMISE` (relative) or their theta_hat by more than :data:`PROMISE`, the
    result is returned whole but with ``complete=False`` and a message giving the
    difference: its accuracy is not what the defaults promise (a tighter ``rtol``
    may reach it; a loop that is chaotic reaches it at no tolerance).

    :param rtol: relative tolerance, as ``solve_ivp``'s and :func:`unidyn.simulate`'s
    :param atol: absolute tolerance (m, rad, m/s, rad/s and theta's units alike)
    :param backend: ``"compiled"``, ``"plain"`` or ``"auto"`` (:func:`backend_for`;
        ``Result.backend`` says which ran). Both run the same source and agree to rounding
    :param progress: ``None`` (default: a tqdm progress bar on stderr for long calls,
        only when stderr is a terminal), ``False`` (none), ``True`` (always a bar), or a
        callable ``f(done_samples, total_samples)``

    The results of one call share the engine's log: each result's series are views of
    one array holding every run of its group (no copy), so keeping one result keeps
    that array; ``np.array(r.pose)`` and the like copy what is to outlive the rest.
    ``Result.steps`` counts the steps a run kept, ``Result.rejected`` those taken again
    shorter.

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
    rtol, atol = tolerances(rtol, atol)
    compiled = backend_for(scs, backend) == "compiled"
    from . import kernels
    from .jit import plain_copy
    engine = kernels if compiled else plain_copy(kernels)
    groups = {}
    for i, s in enumerate(scs):
        groups.setdefault((s.T, s.Ts, s.log_every, s.log_dtype, s.log_series), []).append(i)
    total = sum(s.steps for s in scs)
    bar = _Progress(progress, total, 2 * sum(scs[g[0]].steps for g in groups.values()))
    results = [None] * len(scs)
    interrupted = False
    try:
        for idx in groups.values():
            passes = []
            for factor in (1.0, CHECK_FACTOR):  # the result, then its check
                loop = ClosedLoop([scs[i] for i in idx])
                runs = _runs(engine, loop)
                call = (float(loop.Ts), loop.scenarios[0].log_every, float(rtol * factor),
                        float(atol * factor))
                try:
                    _integrate(engine, loop, runs, call, compiled, bar)
                except KeyboardInterrupt:
                    interrupted = True
                passes.append(_results(engine, loop, runs, call[2], call[3],
                                       "compiled" if compiled else "plain"))
                if interrupted:
                    break
            for n, i in enumerate(idx):
                r = passes[0][n]
                if not interrupted:
                    r = _checked(r, passes[1][n], rtol)
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
        elif progress is True or (progress is None and work >= PROGRESS_SAMPLES):
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


def _runs(kernels, loop: ClosedLoop):
    """The per-run arrays (:data:`unidyn.engine.kernels.Runs`) of the runs of ``loop``,
    ready for the first sample."""
    B, sc0 = loop.B, loop.scenarios[0]
    columns, _ = kernels.log_layout(ALWAYS_LOGGED + sc0.log_series)  # the series asked for
    rows = loop.steps // sc0.log_every + 2  # every log_every-th sample, and a run's last
    count = lambda: np.zeros(B, dtype=np.int64)  # noqa: E731
    return kernels.Runs(
        state=loop.initial_state(), params=loop.P, h=np.zeros(B), noise_pos=loop.pos_noise,
        noise_vel=loop.vel_noise, bounds=np.array([sc.divergence_bounds() for sc in loop.scenarios]),
        log_columns=columns, log=np.full((B, rows, len(columns)), np.nan, dtype=sc0.log_dtype),
        status=count(), last=count(), steps=count(), rejected=count(), most=count())


def _integrate(kernels, loop: ClosedLoop, runs, call, compiled: bool, bar):
    """Advance ``runs`` through ``kernels`` (the compiled module or its plain copy,
    :func:`unidyn.engine.jit.plain_copy`) in slices of sample intervals. Compiled, a
    thread per core advances its share of the runs (compiled code releases the GIL);
    Ctrl-C then waits for the slice to end, so every run's log stays whole."""
    n = loop.steps
    Ts, log_every, rtol, atol = call
    kernels.PYTHON_REFERENCES[:] = loop.trajectories  # the plain copy's, for FunctionTrajectory
    threads = min(loop.B, os.cpu_count() or 1) if compiled else 1
    order = np.arange(loop.B)
    shares = [np.ascontiguousarray(order[j::threads]) for j in range(threads)]
    S = max(1, SLICE_SAMPLES[compiled] // loop.B)
    k = 0
    with ThreadPoolExecutor(threads) as pool:
        while True:
            loop.next_noise_window(k)
            k1 = min(n, k + S, loop.noise_end)
            runs = runs._replace(noise_pos=loop.pos_noise, noise_vel=loop.vel_noise)
            c = kernels.Call(Ts, loop.noise_k0, log_every, rtol, atol, MAX_STEPS)
            # a run that diverges overflows, and is stopped by its check: as compiled code
            # does, plain Python goes on with inf and NaN, without numpy's warnings
            with np.errstate(all="ignore"):
                if threads == 1:
                    kernels.advance(runs, c, k, k1, order)
                else:
                    slices = [pool.submit(kernels.advance, runs, c, k, k1, s) for s in shares]
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
    1: "non-finite state (diverged)",
    2: "diverged: the position |(x, y)| = {v:.3g} m is beyond {b:.3g} m "
       "(1e6 times the reference's size)",
    3: "diverged: |u| = {v:.3g} m/s is beyond {b:.3g} m/s (1e6 times the speed limit, "
       "or the speed the controller asks for)",
    4: "diverged: |w| = {v:.3g} rad/s is beyond {b:.3g} rad/s (1e6 times the steering "
       "limit, or the turn rate the controller asks for)",
    6: "the error could not be held within rtol = {rtol:g}, atol = {atol:g} in "
       + f"{MAX_STEPS:,}" + " steps of the sample interval starting here (a loop too fast "
       "or too stiff for an explicit method, or diverging); use a looser rtol and atol, "
       "a shorter Ts, or unidyn.simulate(..., method='Radau') (the bdsim diagram with a "
       "stiff solver)",
}


def _checked(r: Result, check: Result, rtol: float) -> Result:
    """r, or r marked incomplete where its check (the same run at :data:`CHECK_FACTOR`
    times the tolerances) differs from it by more than :data:`PROMISE`."""
    if not r.complete:
        return r
    label = r.scenario.name or r.scenario.case
    if not check.complete:
        why = f"its check at rtol = {CHECK_FACTOR * rtol:g} stopped: {check.message}"
    else:
        a, b = r.metrics["iae"], check.metrics["iae"]
        iae = abs(a - b) / abs(a) if a else abs(a - b)
        theta = (float(np.max(np.abs(r.theta_hat - check.theta_hat), initial=0.0))
                 if r.theta_hat is not None else 0.0)
        if iae <= PROMISE and theta <= PROMISE:
            return r
        why = (f"at rtol = {rtol:g} and {CHECK_FACTOR * rtol:g} its IAE differs by {iae:.1e} "
               f"(relative) and theta_hat by {theta:.1e}")
    message = (f"every sample computed, but not within {PROMISE:g} of a converged solution: {why}; a "
               f"tighter rtol and atol may reach it (a loop sensitive to its initial state, "
               f"as an adaptive one at high gains can be, reaches it at no tolerance) "
               f"(scenario {label})")
    return dataclasses.replace(r, complete=False, message=message)


def _short(v) -> str:
    return "[" + ", ".join(f"{x:g}" for x in v) + "]"


def _results(kernels, loop: ClosedLoop, runs, rtol: float, atol: float, backend: str) -> list:
    """One Result per run. A run that stopped keeps the samples up to its stop (a
    non-finite last sample is dropped; a run whose tolerance could not be met keeps its
    samples up to the interval that failed) and is marked incomplete."""
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
            message = ""
        elif status == kernels.OK:
            message = f"interrupted at t = {t_stop:.6g} s (scenario {label})"
        else:
            last_row = runs.log[i, nrow - 1].astype(float)
            (x, y, _), (u, w) = last_row[layout["pose"]], last_row[layout["velocity"]]
            v = {2: np.hypot(x, y) if nrow else np.nan, 3: abs(u), 4: abs(w)}.get(status, 0.0)
            cause = _CAUSE[status].format(v=v, b=runs.bounds[i, status - 2] if 1 < status < 5 else 0.0,
                                          rtol=rtol, atol=atol)
            estimate = (f", theta_hat = {_short(last_row[layout['theta_hat']])}"
                        if status == kernels.STEP and "theta_hat" in layout and sc.case == "adaptive"
                        else "")
            message = f"{cause} at t = {t_stop:.6g} s (scenario {label}{estimate})"
        series = {k: log[:, layout[k]] if k in layout else None for k in kernels.LOG_SERIES}
        out.append(Result(scenario=sc, t=t, **series, engine="batch", complete=complete,
                          message=message, backend=backend, steps=int(runs.steps[i]),
                          rejected=int(runs.rejected[i])))
    return out
