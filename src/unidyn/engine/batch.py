r"""The batch engine: many continuous-control scenarios integrated at once
(:func:`simulate_batch`; ``docs/guides/batch-engine.md`` explains the method).

Each noise interval [k Ts, (k+1) Ts) of a run is integrated on its own, the noise held
over it as in the bdsim diagram, by the Dormand-Prince 5(4) pair with step-size control
(:mod:`unidyn.engine.kernels`, compiled or plain: :func:`backend_for`): whatever makes a
step inaccurate shortens it, so no rate of the loop has to be foreseen. Each run is
checked against a second one at looser tolerances (:data:`PROMISE`). The runs'
parameters, noise and initial state come from :class:`unidyn.engine.rhs.ClosedLoop`.
"""

from __future__ import annotations

import dataclasses
import os
from concurrent.futures import ThreadPoolExecutor, wait

import numpy as np

from .._errors import SimulationInterrupted
from .._validate import DEFAULT_ATOL, DEFAULT_RTOL, ValidationError, tolerances
from ..model.equations import TRAJECTORY_KINDS
from ..model.scenario import ALWAYS_LOGGED, Scenario
from ..results.result import Result
from .rhs import ClosedLoop

__all__ = ["simulate_batch", "backend_for", "MAX_STEPS"]

#: A complete result's IAE is within PROMISE (relative), its theta_hat within PROMISE,
#: of its check: the run at CHECK_FACTOR times the tolerances, less accurate, whose
#: difference bounds the result's error; else it is ``complete=False``, saying so.
PROMISE = 1e-4
CHECK_FACTOR = 10.0
#: The most steps (kept or not) a sample interval may take before its run stops.
MAX_STEPS = 10_000
BACKENDS = ("auto", "compiled", "plain")
#: Samples (runs x intervals) between updates of the progress bar, compiled and plain
#: (a fraction of a second; compiled, Ctrl-C is handled between them).
SLICE_SAMPLES = {True: 50_000, False: 200}
#: Show a progress bar (on a terminal) when a call holds at least this many samples.
PROGRESS_SAMPLES = 1_000_000


def backend_for(scenarios, backend: str = "auto") -> str:
    """``"compiled"`` or ``"plain"``, from the call alone (the same call, the same bits):
    ``backend="auto"`` is compiled where numba is installed and every trajectory is a
    built-in one; ``"compiled"`` where it cannot be raises ValidationError."""
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


def simulate_batch(scenarios, *, rtol: float = DEFAULT_RTOL, atol: float = DEFAULT_ATOL,
                   backend: str = "auto", progress=None) -> list:
    """Simulate many scenarios at once; returns one :class:`~unidyn.Result` per scenario,
    in order.

    Scenarios are grouped by (T, Ts, log_every, log_dtype, log_series), each group in
    one call of the kernels; a run's numbers do not depend on which runs share its call
    or on what the process ran before (bit for bit). Continuous control only.

    A run that diverges (non-finite, or beyond :meth:`~unidyn.Scenario.divergence_bounds`)
    or whose error cannot be held within the tolerances in :data:`MAX_STEPS` steps of a
    sample interval stops there, ``complete=False``, with the samples up to the failure
    and a message naming the cause and what to change; the other runs continue (a run
    that stopped is not checked: its check would cost as much and tell nothing). A run
    that differs from its check (the same run at :data:`CHECK_FACTOR` times the
    tolerances) by more than :data:`PROMISE` in IAE (relative) or theta_hat is returned
    whole but ``complete=False``, its message giving the differences.

    :param rtol: relative tolerance, as ``solve_ivp``'s and :func:`unidyn.simulate`'s
    :param atol: absolute tolerance (m, rad, m/s, rad/s and theta's units alike)
    :param backend: ``"compiled"``, ``"plain"`` or ``"auto"`` (:func:`backend_for`;
        ``Result.backend`` says which ran; the two agree to the tolerance)
    :param progress: ``None`` (a tqdm bar on a terminal for long calls), ``False``,
        ``True``, or a callable ``f(done_samples, total_samples)``

    A call's results share one log array per group (views, no copy): ``np.array(r.pose)``
    copies what is to outlive the rest. ``Result.steps`` counts the steps a run kept,
    ``Result.rejected`` those taken again shorter.

    :raises SimulationInterrupted: on Ctrl-C (a KeyboardInterrupt); its ``results``
        hold one entry per scenario: the computed part, marked incomplete (``None``
        for a run not yet started); ``result`` is the first of them
    """
    scs = list(scenarios)
    if not scs:
        return []
    for s in scs:
        if not isinstance(s, Scenario):
            raise ValidationError(f"scenarios must be unidyn.Scenario objects, got "
                                  f"{type(s).__name__}")
        if s.control != "continuous":
            raise ValidationError("the batch engine runs control='continuous' only; "
                                  "use unidyn.simulate (engine 'bdsim') for sampled control")
    rtol, atol = tolerances(rtol, atol)
    label = backend_for(scs, backend)
    compiled = label == "compiled"
    from . import kernels
    from .jit import plain_copy
    engine = kernels if compiled else plain_copy(kernels)
    groups = {}
    for i, s in enumerate(scs):
        groups.setdefault((s.T, s.Ts, s.log_every, s.log_dtype, s.log_series), []).append(i)
    bar = _Progress(progress, sum(s.steps for s in scs),
                    2 * sum(scs[g[0]].steps for g in groups.values()))
    results = [None] * len(scs)
    interrupted = False
    try:
        for idx in groups.values():
            passes = [{}, {}]  # the results, then the checks of those that completed
            todo = idx
            for p, factor in enumerate((1.0, CHECK_FACTOR)):
                if not todo:
                    break
                loop = ClosedLoop([scs[i] for i in todo])
                runs, tol = _runs(engine, loop), (rtol * factor, atol * factor)
                try:
                    _integrate(engine, loop, runs, tol, compiled, bar)
                except KeyboardInterrupt:
                    interrupted = True
                passes[p] = dict(zip(todo, _results(engine, loop, runs, *tol, label)))
                if interrupted:
                    break
                todo = [i for i in todo if passes[p][i].complete]
            for i in idx:
                r, check = passes[0][i], passes[1].get(i)
                results[i] = r if interrupted or check is None else _checked(r, check, rtol)
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
    """The arrays of ``loop``'s runs (:data:`unidyn.engine.kernels.Runs`), at t = 0."""
    B, sc0 = loop.B, loop.scenarios[0]
    columns, _ = kernels.log_layout(ALWAYS_LOGGED + sc0.log_series)  # the series asked for
    rows = loop.steps // sc0.log_every + 2  # every log_every-th sample, and a run's last
    count = lambda: np.zeros(B, dtype=np.int64)  # noqa: E731
    return kernels.Runs(
        state=loop.initial_state(), params=loop.P, h=np.zeros(B), noise_pos=loop.pos_noise,
        noise_vel=loop.vel_noise, bounds=np.array([sc.divergence_bounds() for sc in loop.scenarios]),
        log_columns=columns, log=np.full((B, rows, len(columns)), np.nan, dtype=sc0.log_dtype),
        status=count(), last=count(), steps=count(), rejected=count())


def _integrate(kernels, loop: ClosedLoop, runs, tol, compiled: bool, bar):
    """Advance ``runs`` through ``kernels`` (compiled, or its plain copy) in slices of
    sample intervals; compiled, a thread per core takes its share of the runs (the GIL
    released), and Ctrl-C waits for the slice to end, so every run's log stays whole."""
    n = loop.steps
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
            c = kernels.Call(float(loop.Ts), loop.noise_k0, loop.scenarios[0].log_every,
                             float(tol[0]), float(tol[1]), MAX_STEPS)
            # as compiled code, plain Python goes on with inf and NaN until a check stops it
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
    6: "the error could not be held within rtol = {rtol:g}, atol = {atol:g} in "
       + f"{MAX_STEPS:,}" + " steps of the sample interval from here (a loop too stiff for "
       "an explicit method, or diverging); use a looser rtol and atol, a shorter Ts, or "
       "unidyn.simulate(..., method='Radau') (the diagram with a stiff solver)",
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
    message = (f"every sample computed, but not within {PROMISE:g} of a converged solution: "
               f"{why}; a tighter rtol and atol may reach it (a loop sensitive to its initial "
               f"state, as an adaptive one at high gains can be, reaches it at no tolerance) "
               f"(scenario {label})")
    return dataclasses.replace(r, complete=False, message=message)


def _results(kernels, loop: ClosedLoop, runs, rtol: float, atol: float, backend: str) -> list:
    """One Result per run; a run that stopped keeps its samples up to the stop (not a
    non-finite one, nor the end of an interval that failed) and is incomplete."""
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
        log = runs.log[i, :nrow]  # views of the log (no copy)
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
            b = runs.bounds[i, status - 2] if 1 < status < 5 else 0.0
            cause = (Scenario.divergence(status - 2, v, b) if 1 < status < 5
                     else _CAUSE[status].format(rtol=rtol, atol=atol))
            message = f"{cause} at t = {t_stop:.6g} s (scenario {label})"
        series = {k: log[:, layout[k]] if k in layout else None for k in kernels.LOG_SERIES}
        out.append(Result(scenario=sc, t=t, **series, engine="batch", complete=complete,
                          message=message, backend=backend, steps=int(runs.steps[i]),
                          rejected=int(runs.rejected[i])))
    return out
