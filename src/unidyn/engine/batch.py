r"""The batch engine: many continuous-control scenarios integrated at once, each with
its metrics' estimated numerical error (:func:`simulate_batch`;
``docs/guides/batch-engine.md`` explains the method and why).

Each noise interval [k Ts, (k+1) Ts) is integrated on its own, the noise held over it as
in the bdsim diagram, by the Dormand-Prince 5(4) pair with step-size control
(:mod:`unidyn.engine.kernels`, compiled or plain: :func:`backend_for`). The runs'
parameters, noise and initial state come from :class:`unidyn.model.closed_loop.ClosedLoop`.
"""

from __future__ import annotations

import dataclasses
import os
from concurrent.futures import ThreadPoolExecutor, wait

import numpy as np

from .._errors import SimulationInterrupted
from .._validate import BATCH_ATOL, BATCH_RTOL, ValidationError, tolerances
from ..model import equations, trajectories
from ..model.closed_loop import ClosedLoop
from ..model.equations import S
from ..model.log import LOG_SERIES, log_layout, log_length
from ..model.metrics import INTEGRAL, INTEGRAL_NAMES, MEAN_ERROR, METRICS, NMETRIC
from ..model.scenario import ALWAYS_LOGGED, Scenario
from ..progress import Progress
from ..results.result import Result

__all__ = ["simulate_batch", "backend_for", "MAX_STEPS", "ACCURACY", "STATUS_MESSAGES",
           "ESTIMATES", "seedless", "DECISIVE", "SERIES"]

#: The promise: a run that is not sensitive has an estimate of at most ACCURACY
#: (relative) and its true error is within twice its estimate (:func:`simulate_batch`).
ACCURACY = 1e-4
#: The probe's move of the starting point, m, in x and y.
PERTURBATION = 1e-12
#: A run that is not sensitive is run again this much tighter until its estimate is
#: within ACCURACY, down to rtol RTOL_FLOOR (atol in proportion).
TIGHTEN, RTOL_FLOOR = 10.0, 1e-13
#: The estimate is ESTIMATE_FACTOR times the difference from the run before (the error
#: of the tighter run is well within it where the error falls with the tolerance; the
#: factor covers a decade over which it falls more slowly: ``benchmarks/engines.py
#: --accuracy`` measures the true error against the estimate).
ESTIMATE_FACTOR = 3.0
#: A tighter run must take this many times the steps of the one before for their
#: difference to estimate the error (a decade takes 1.3-1.5 times as many where the
#: tolerance sets the steps); otherwise it is tightened again.
STEP_GROWTH = 1.2
#: Fewer runs than cores run their probes beside them, in one pass, where their logs
#: take at most this many bytes.
TOGETHER_BYTES = 100_000_000
#: The most steps (kept or not) a sample interval may take before its run stops.
MAX_STEPS = 10_000
BACKENDS = ("auto", "compiled", "plain")
#: How a call estimates its runs' numerical error (:func:`simulate_batch`'s ``estimate``).
ESTIMATES = ("each", "per_point")
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
    compilable = all(s.trajectory.code != equations.PYTHON for s in scenarios)
    if backend == "compiled" and not kernels.AVAILABLE:
        raise ValidationError("backend='compiled' needs numba (pip install unidyn[fast])")
    if backend == "compiled" and not compilable:
        raise ValidationError(f"backend='compiled' runs the trajectories "
                              f"{', '.join(trajectories.KINDS)} only; use backend='plain' "
                              f"for a FunctionTrajectory")
    if backend == "compiled" or (backend == "auto" and kernels.AVAILABLE and compilable):
        return "compiled"
    return "plain"


def simulate_batch(scenarios, *, rtol: float = BATCH_RTOL, atol: float = BATCH_ATOL,
                   backend: str = "auto", progress=None, estimate: str = "each") -> list:
    """Simulate many scenarios at once; returns one :class:`~unidyn.Result` per scenario,
    in order, each with its metrics and their estimated numerical error.

    Scenarios are grouped by (T, Ts, log_every, log_dtype, log_series), each group in
    one call of the kernels; a run's numbers do not depend on which runs share its call
    or on what the process ran before (bit for bit). Continuous control only. The
    metrics are accumulated at every sample: ``log_every`` thins the stored series only.

    **The switched loop.** The speed and acceleration limits switch the loop's rates,
    and adaptation, a payload and a circle's radius switch them at given times. Every
    step holds the switches as they are at its start, so that it integrates a smooth
    right-hand side, and a step in which a limit starts or stops acting ends there,
    located from the step's interpolant (``docs/guides/batch-engine.md``).

    **Numerical error.** Each run is integrated at ``rtol``, ``atol``, and again with
    its start moved by :data:`PERTURBATION` m (the probe), then again :data:`TIGHTEN`
    times tighter; the tighter run is returned, its ``numerical_error``
    :data:`ESTIMATE_FACTOR` times its difference from the run before, for each metric
    and for the series (``position``, ``heading``, ``distance_error``, ``theta_hat``:
    the largest difference over the logged samples, relative to the series' largest
    value); where that is above :data:`ACCURACY`, or the tighter run took few more
    steps, it is tightened again, down to :data:`RTOL_FLOOR`. A run is ``sensitive``
    where the probe moves it by more than :data:`ACCURACY` at two tolerances in a row
    (the perturbation's effect does not fall as the tolerance tightens): no tolerance
    converges it, its ``numerical_error`` is how far the probe moved it (one sample of
    the spread, not a bound), and its spread over noise seeds is the uncertainty to
    quote. **The promise: a run that is not sensitive has an estimate of at most 1e-4
    (relative), and its true error is within twice its estimate; a run where that
    cannot be reached says so in its** ``message``.

    With ``estimate="per_point"``, runs that differ only in their noise seed (the
    seeds of one point of a sweep) share the search for a tolerance: the run with the
    smallest seed among them is estimated as above, and each of the others starts a
    decade looser than the tolerance it was returned at, without the loose passes
    and the first probe, and is estimated on its own from there (tightened, and
    probed, where its own estimate is not yet within :data:`ACCURACY`; from ``rtol``
    with its probe where the smallest seed is sensitive). Every run keeps the promise
    above with an estimate of its own; their statistics over seeds are the
    uncertainty to quote, and the numerical error is checked small against it.

    **Runs that stop** (diverged, or the error not held within :data:`MAX_STEPS` steps
    of an interval) are returned ``complete=False`` with the samples and metrics up to
    the stop, ``numerical_error`` None, and a message naming the cause and what to change
    (:data:`STATUS_MESSAGES`); the other runs go on.

    :param rtol: relative tolerance of the steps, as ``solve_ivp``'s, to start from
        (default 1e-6: the estimate tightens what needs it)
    :param atol: absolute tolerance (m, rad, m/s, rad/s and theta's units alike)
    :param backend: ``"compiled"``, ``"plain"`` or ``"auto"`` (:func:`backend_for`;
        ``Result.backend`` says which ran; the two agree to the tolerance)
    :param progress: ``None`` (a tqdm bar on a terminal for long calls), ``False``,
        ``True``, or a callable ``f(done_samples, total_samples)`` (the total grows
        where runs are tightened)
    :param estimate: ``"each"`` (every run estimated from ``rtol``) or ``"per_point"``
        (runs that differ only in their noise seed start from the tolerance the smallest
        seed needed, above)

    A call's results share one log array per group (views, no copy): ``np.array(r.pose)``
    copies what is to outlive the rest. ``Result.steps`` and ``Result.rejected`` count
    the steps the run returned kept and took again shorter; ``Result.rtol`` is the
    tolerance it was returned at.

    :raises SimulationInterrupted: on Ctrl-C (a KeyboardInterrupt); its ``results``
        hold one entry per scenario: the computed part, marked incomplete (``None``
        for a run not yet started; a run computed whole keeps ``complete=True``, its
        error not estimated if the interrupt came first); ``result`` is the first
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
    if estimate not in ESTIMATES:
        raise ValidationError(f"estimate must be one of {', '.join(ESTIMATES)}; got {estimate!r}")
    label = backend_for(scs, backend)
    compiled = label == "compiled"
    from ..compiled import plain_copy
    from . import kernels
    engine = kernels if compiled else plain_copy(kernels)
    groups = {}
    for i, s in enumerate(scs):
        groups.setdefault((s.T, s.Ts, s.log_every, s.log_dtype, s.log_series), []).append(i)
    shared = _seed_siblings(scs) if estimate == "per_point" else {}
    # the first pass: each run and its probe, or once for a run sharing a sibling's
    # estimate; a tighter pass adds its work when it starts (Progress.grow)
    work = sum(s.steps * (1 if i in shared else 2) for i, s in enumerate(scs))
    bar = Progress(progress, work, show=sum(s.steps for s in scs) >= PROGRESS_SAMPLES,
                   desc="unidyn batch")
    results = [None] * len(scs)
    run = _Call(engine, label, compiled, bar, results)
    try:
        for idx in groups.values():
            first = [i for i in idx if i not in shared]
            _group(run, [scs[i] for i in first], first, rtol, atol)
            _siblings(run, scs, [i for i in idx if i in shared], shared, rtol, atol)
    except KeyboardInterrupt:
        done = [r for r in results if r is not None]
        raise SimulationInterrupted(
            f"interrupted: {sum(r.complete for r in done)} of {len(scs)} run(s) complete; "
            f"the computed part of the others is kept, marked incomplete",
            results=results) from None
    finally:
        bar.close()
    return results


class _Call:
    """What every pass of one call shares: the kernels (``engine``), the backend's name,
    whether compiled, the progress bar, and the results list filled in."""

    def __init__(self, engine, label, compiled, bar, results):
        self.engine, self.label, self.compiled = engine, label, compiled
        self.bar, self.results = bar, results

    def runs(self, scs, tol, shift=0.0, where=(), keep=None):
        """One pass of the kernels over ``scs`` at tolerances ``tol``, each start moved
        by ``shift`` m in x and y (or run i's by ``shift[i]``); one Result per run. On
        Ctrl-C, the computed part of the first ``keep`` runs (the runs themselves, not
        their probes) is put into ``results[where]`` first."""
        if not scs:
            return []
        loop = ClosedLoop(scs)
        runs = _runs(self.engine, loop, self.compiled)
        runs.state[:, [S.x, S.y]] += np.broadcast_to(np.asarray(shift, dtype=float),
                                                     (len(scs),))[:, None]
        done = lambda: _results(self.engine, loop, runs, *tol, self.label)  # noqa: E731
        try:
            _integrate(self.engine, loop, runs, tol, self.compiled, self.bar)
        except KeyboardInterrupt:
            if keep:
                for i, r in zip(where, done()[:keep]):
                    self.results[i] = r
            raise
        return done()


def _first_pass(run: _Call, scs, idx, tol, probe=True):
    """The runs of a group at ``tol`` and, with ``probe``, their probes, into
    ``run.results[idx]``: returns (``moved``: run j -> (how far its probe moved it, at
    which rtol), for the runs their probe moved; ``steady``: the runs whose error is to
    be estimated by tightening)."""
    B, results = len(scs), run.results
    if probe and _together(scs):  # the runs and their probes in one pass, on cores otherwise idle
        both = run.runs(scs + scs, tol, [0.0] * B + [PERTURBATION] * B, where=idx, keep=B)
        main, probes = both[:B], both[B:]
    else:
        main = run.runs(scs, tol, where=idx, keep=B)
        probes = [None] * B
        done = [j for j, r in enumerate(main) if r.complete] if probe else []
        for j, q in zip(done, run.runs([scs[j] for j in done], tol, PERTURBATION)):
            probes[j] = q
    moved, steady = {}, []
    for j, (r, q) in enumerate(zip(main, probes)):
        results[idx[j]] = _noted(r, rtol=tol[0], estimate="tightened" if r.complete else "")
        if not r.complete:
            continue
        if q is not None and not q.complete:
            results[idx[j]] = _noted(r, message=f"every sample computed, its numerical error "
                                                f"not estimated: its probe stopped ({q.message})")
            continue
        d = _differences(r, q) if q is not None else {}
        if d and _decisive(d) > ACCURACY:
            moved[j] = (d, tol[0])
        steady.append(j)
    return moved, steady


def _group(run: _Call, scs, idx, rtol, atol, probe=True):
    """Run one group (scenarios sharing the kernels' call) into ``run.results[idx]``: the
    runs at (rtol, atol) and, with ``probe``, their probes; then each run not yet judged again at
    tolerances :data:`TIGHTEN` times tighter (its probe too, where the probe moved it),
    each returned with the difference from the run before as its estimate, until that
    is within :data:`ACCURACY`; sensitive where the probe moves it at two tolerances in
    a row."""
    if not scs:
        return
    tol, results = (rtol, atol), run.results
    moved, steady = _first_pass(run, scs, idx, tol, probe)
    shaky = {}  # run j -> whether its last estimate was beyond the promise
    while steady:
        tol = (tol[0] / TIGHTEN, tol[1] / TIGHTEN)
        if tol[0] < RTOL_FLOOR:
            for j in steady:
                results[idx[j]] = _beyond(results[idx[j]], tol[0] * TIGHTEN)
            return
        # probed again: a run its probe moved, and a run whose estimate did not come
        # within the promise (a perturbation's effect may be what moves it)
        probed = [j for j in steady if j in moved or shaky.get(j)]
        run.bar.grow(sum(scs[j].steps for j in steady + probed))
        tighter = run.runs([scs[j] for j in steady], tol)
        probes = dict(zip(probed, run.runs([scs[j] for j in probed], tol, PERTURBATION)))
        again = []
        for j, r in zip(steady, tighter):
            before = results[idx[j]]
            if not r.complete:  # the tighter run stopped: the run before, not estimated
                results[idx[j]] = _noted(before, message=(
                    f"every sample computed, its numerical error not estimated: the same "
                    f"run at rtol = {tol[0]:g} stopped ({r.message})"))
                continue
            r = _noted(r, rtol=tol[0])
            if j in probes:
                q = probes[j]
                d = _differences(r, q) if q.complete else {}
                if d and _decisive(d) > ACCURACY:
                    if j in moved:  # the probe's effect persists as the tolerance tightens
                        results[idx[j]] = _sensitive(r, d, tol[0], *moved[j])
                        continue
                    moved[j] = (d, tol[0])
                else:
                    moved.pop(j, None)
            results[idx[j]] = _estimated(r, before)
            # a tighter run whose steps the sample intervals set, not the tolerance (it
            # took few more), differs from the looser by less than either's error
            idle = r.steps < STEP_GROWTH * before.steps
            shaky[j] = _decisive(results[idx[j]].numerical_error) > ACCURACY
            if idle or shaky[j]:
                again.append(j)
            else:
                results[idx[j]] = _series_noted(results[idx[j]])
        steady = again


def seedless(sc) -> str | None:
    """What the runs of one scenario over noise seeds share: its text with the seed 0 and
    no name (None without noise)."""
    if sc.noise is None:
        return None
    return repr(sc.replace(noise=dataclasses.replace(sc.noise, seed=0), name=""))


def _seed_siblings(scs) -> dict:
    """For each run that differs from another only in its noise seed (and name) and is
    not the one with the smallest seed among them: the index of that one (its estimate
    is shared)."""
    keys = [seedless(s) for s in scs]
    first = {}
    for i, (s, key) in enumerate(zip(scs, keys)):
        if key is not None and (key not in first or s.noise.seed < scs[first[key]].noise.seed):
            first[key] = i
    return {i: first[key] for i, key in enumerate(keys)
            if key is not None and first[key] != i}


def _siblings(run: _Call, scs, idx, shared, rtol, atol):
    """The runs ``idx``, each estimated on its own, starting where its seed sibling
    ``shared[i]`` (already in ``run.results``) ended: a run first at :data:`TIGHTEN`
    times the tolerance that sibling was returned at, without a probe, then tightened
    as in :func:`_group` (its estimate from the last two tolerances, a probe where it
    is not yet within :data:`ACCURACY`). Where the sibling is sensitive or was not
    estimated, from (``rtol``, ``atol``) with its probe, as alone."""
    by_start = {}
    for i in idx:
        ref = run.results[shared[i]]
        known = ref is not None and ref.complete and ref.numerical_error and not ref.sensitive
        start = min(ref.rtol * TIGHTEN, rtol) if known else None
        by_start.setdefault(start, []).append(i)
    for start, members in by_start.items():
        tol = (rtol, atol) if start is None else (start, start * atol / rtol)
        if start is None:  # the probes, not counted at the call's start
            run.bar.grow(sum(scs[i].steps for i in members))
        _group(run, [scs[i] for i in members], members, *tol, probe=start is None)


def _together(scs) -> bool:
    """Whether a group's runs and their probes go in one pass: where the runs alone
    would leave cores idle (fewer runs than cores), and their logs are small
    (:data:`TOGETHER_BYTES`)."""
    sc = scs[0]
    log = len(scs) * log_length(sc.steps, sc.log_every, True) * sc.logged_bytes()
    return len(scs) < (os.cpu_count() or 1) and log <= TOGETHER_BYTES


def _runs(kernels, loop: ClosedLoop, compiled: bool):
    """The arrays of ``loop``'s runs (:data:`unidyn.engine.kernels.Runs`), at t = 0."""
    B, sc0 = loop.B, loop.scenarios[0]
    columns, _ = log_layout(ALWAYS_LOGGED + sc0.log_series)  # the series asked for
    rows = log_length(loop.steps, sc0.log_every, True)  # however a run stops
    count = lambda: np.zeros(B, dtype=np.int64)  # noqa: E731
    return kernels.Runs(
        state=loop.initial_state(), params=loop.P, h=np.zeros(B), noise_pos=loop.pos_noise,
        noise_vel=loop.vel_noise, bounds=np.array([sc.divergence_bounds() for sc in loop.scenarios]),
        log_columns=columns, log=np.full((B, rows, len(columns)), np.nan, dtype=sc0.log_dtype),
        running=np.full((B, rows, NMETRIC), np.nan), acc=np.zeros((B, 2 * NMETRIC)),
        status=count(), last=count(), steps=count(), rejected=count(),
        # the Python-function references, for the plain copy (compiled code has none)
        references=() if compiled else tuple(loop.trajectories))


def _integrate(kernels, loop: ClosedLoop, runs, tol, compiled: bool, bar):
    """Advance ``runs`` through ``kernels`` (compiled, or its plain copy) in slices of
    sample intervals; compiled, a thread per core takes its share of the runs (the GIL
    released), and Ctrl-C waits for the slice to end, so every run's log stays whole."""
    n = loop.steps
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
            bar.advance((k1 - k) * loop.B)
            k = k1
            if k >= n or not (runs.status == kernels.Status.OK).any():
                break


#: What a run that stopped says, by its :class:`unidyn.engine.kernels.Status` (the
#: divergence bounds' messages are :meth:`unidyn.Scenario.divergence`'s).
STATUS_MESSAGES = {
    "NONFINITE": "non-finite state (diverged)",
    "STEP": "the error could not be held within rtol = {rtol:g}, atol = {atol:g} in "
            + f"{MAX_STEPS:,}" + " steps of the sample interval from here (a loop too stiff "
            "for an explicit method, or diverging); use a looser rtol and atol, a shorter Ts, "
            "or unidyn.simulate(..., method='Radau') (the diagram with a stiff solver)",
}
#: The divergence bound of each status that stops at one: its index in the bounds.
_BOUND = {"POSITION": 0, "SPEED_U": 1, "SPEED_W": 2}


def _noted(r: Result, **changes) -> Result:
    """``r``, made by this call, changed in place (a copy recomputes its error series)."""
    vars(r).update(changes)
    return r


def _relative(a: float, b: float, scale: float) -> float:
    """|a - b| relative to ``scale`` (0 where they are equal, inf where only scale is 0)."""
    d = abs(a - b)
    return d / abs(scale) if scale else (0.0 if d == 0 else float("inf"))


def _series_difference(a, b) -> float:
    """The largest difference between two logged series over their samples, relative
    to the first one's largest value (0 for a series not logged)."""
    if a is None or b is None or not len(a):
        return 0.0
    a, b = np.asarray(a, float), np.asarray(b, float)
    return _relative(float(np.max(np.abs(a - b))), 0.0, float(np.max(np.abs(a))))


def _differences(r: Result, other: Result) -> dict:
    """How far ``other``'s metrics and series are from ``r``'s, relative to their size:
    the integral metrics all by the largest of their differences (one metric's
    difference may vanish by chance; all of them rarely do), the others each relative
    to its own size or to the mean error of the run (:data:`unidyn.model.metrics.Metric`'s
    ``own_scale``), and the series (``position``, ``heading``, ``distance_error``,
    ``theta_hat``) by their largest difference over the logged samples."""
    a, b = r.metrics, other.metrics
    spread = max(_relative(a[k], b[k], a[k]) for k in INTEGRAL_NAMES)
    out = {k: spread for k in INTEGRAL_NAMES}
    for m in METRICS:
        if m.rule != INTEGRAL:
            # the mean error of the run, the scale of a final error (it may end near zero)
            mean_error = a[MEAN_ERROR] / r.t[-1] if len(r.t) > 1 else a[m.name]
            out[m.name] = _relative(a[m.name], b[m.name], a[m.name] if m.own_scale
                                    else mean_error)
    n = min(len(r.t), len(other.t))
    last = [x[n - 1] for x in (r.pose, other.pose) if n]
    if r.theta_hat is not None and other.theta_hat is not None and n:
        last = [np.r_[np.asarray(p, float), np.asarray(q[n - 1], float)]
                for p, q in zip(last, (r.theta_hat, other.theta_hat))]
    out["final_state"] = (_series_difference(last[0][None], last[1][None]) if last else 0.0)
    out["position"] = _series_difference(r.pose[:n, :2], other.pose[:n, :2])
    out["heading"] = _series_difference(r.pose[:n, 2], other.pose[:n, 2])
    out["distance_error"] = _series_difference(r.error[:n], other.error[:n])
    out["theta_hat"] = _series_difference(
        None if r.theta_hat is None else r.theta_hat[:n],
        None if other.theta_hat is None else other.theta_hat[:n])
    return out


#: The estimates that decide a run's tolerance and its sensitivity: the metrics that say
#: so (:data:`unidyn.model.metrics.Metric`'s ``decisive``), and the state at the last
#: sample (logged whatever ``log_every``), so that neither depends on how thinly the
#: series are logged. The series' estimates are over the logged samples.
DECISIVE = tuple(m.name for m in METRICS if m.decisive) + ("final_state",)
#: The series whose largest difference over the logged samples is estimated.
SERIES = ("position", "heading", "distance_error", "theta_hat")


def _decisive(error: dict) -> float:
    """The largest of the estimates in :data:`DECISIVE`."""
    return max(error[k] for k in DECISIVE)


def _series_noted(r: Result) -> Result:
    """``r``, whose metrics are within the promise, saying where a logged series' estimate
    is not (a transient between samples that the metrics do not weigh)."""
    over = {k: r.numerical_error[k] for k in SERIES if r.numerical_error[k] > ACCURACY}
    if not over:
        return r
    worst = max(over, key=over.get)
    return _noted(r, message=(f"its logged {worst} is estimated within {over[worst]:.1e} of "
                              f"the exact solution (relative), above {ACCURACY:g}, though its "
                              f"metrics are within it; a tighter rtol (rtol={r.rtol / TIGHTEN:g})"
                              f" brings the series closer (scenario "
                              f"{r.scenario.name or r.scenario.case})"))


def _sensitive(r: Result, moved: dict, rtol: float, moved_before: dict, rtol_before: float):
    """``r`` marked sensitive: its probe moved it by ``moved`` at ``rtol`` and by
    ``moved_before`` at ``rtol_before``, both more than :data:`ACCURACY`."""
    worst, first = max(moved.values()), METRICS[0]
    message = (f"sensitive: a {PERTURBATION:g} m move of the starting point moves "
               f"{first.label} by {100 * moved_before[first.name]:.2g} % at rtol = "
               f"{rtol_before:g} and {100 * moved[first.name]:.2g} % at rtol = {rtol:g} "
               f"(its metrics and series up to "
               f"{100 * worst:.2g} %): the perturbation's effect does not fall as the "
               f"tolerance tightens, so no tolerance converges the run, and its spread over "
               f"noise seeds is the uncertainty to quote (scenario "
               f"{r.scenario.name or r.scenario.case})")
    return _noted(r, numerical_error=moved, sensitive=True, message=message, estimate="probe")


def _estimated(r: Result, looser: Result) -> Result:
    """``r`` with its numerical error: :data:`ESTIMATE_FACTOR` times its difference from the same
    run at :data:`TIGHTEN` times looser tolerances (about the looser one's error, which
    ``r``'s is within where the error falls with the tolerance)."""
    error = {k: ESTIMATE_FACTOR * v for k, v in _differences(r, looser).items()}
    return _noted(r, numerical_error=error, sensitive=False, estimate="tightened")


def _beyond(r: Result, rtol: float) -> Result:
    """``r``, whose estimate stays above :data:`ACCURACY` (or is not made) at rtol
    :data:`RTOL_FLOOR`, saying so."""
    error = r.numerical_error
    worst = None if error is None else max(error, key=error.get)
    if error is None:
        why = (f"numerical error not estimated: at rtol = {rtol:g} the engine cannot "
               f"tighten the run to estimate it")
    elif error[worst] <= ACCURACY:  # tightened for steps that did not grow
        why = (f"numerical error estimated from runs whose steps the sample intervals set "
               f"at every tolerance down to rtol = {rtol:g}: the estimate may be low")
    else:
        why = (f"numerical error of {worst} estimated at {error[worst]:.1e}, above "
               f"{ACCURACY:g} at rtol = {rtol:g}, the tightest the engine goes to")
    return _noted(r, message=f"{why} (scenario {r.scenario.name or r.scenario.case})")


def _results(kernels, loop: ClosedLoop, runs, rtol: float, atol: float, backend: str) -> list:
    """One Result per run; a run that stopped keeps its samples and metrics up to the
    stop (not a non-finite sample, nor the end of an interval that failed) and is
    incomplete."""
    Status = kernels.Status
    L = loop.scenarios[0].log_every
    _, layout = log_layout(ALWAYS_LOGGED + loop.scenarios[0].log_series)
    out = []
    for i, sc in enumerate(loop.scenarios):
        status, last = Status(int(runs.status[i])), int(runs.last[i])
        nrow = log_length(last, L, status not in (Status.OK, Status.STEP))
        t = np.arange(last // L + 1) * (L * loop.Ts)
        if nrow > len(t):  # the sample it stopped at
            t = np.r_[t, last * loop.Ts]
        log, running = runs.log[i, :nrow], runs.running[i, :nrow]  # views (no copy)
        if status == Status.NONFINITE:  # drop the non-finite sample
            log, running, t = log[:-1], running[:-1], t[:-1]
        # every sample computed: complete, even if Ctrl-C came after the last
        complete = status == Status.OK and last == loop.steps
        label = sc.name or sc.case
        t_stop = last * loop.Ts
        if complete:
            message = ""
        elif status == Status.OK:
            message = f"interrupted at t = {t_stop:.6g} s (scenario {label})"
        elif status.name in _BOUND:
            which, last_row = _BOUND[status.name], runs.log[i, nrow - 1].astype(float)
            (x, y, _), (u, w) = last_row[layout["pose"]], last_row[layout["velocity"]]
            value = (np.hypot(x, y), abs(u), abs(w))[which]
            message = (f"{Scenario.divergence(which, value, runs.bounds[i, which])} "
                       f"at t = {t_stop:.6g} s (scenario {label})")
        else:
            message = (f"{STATUS_MESSAGES[status.name].format(rtol=rtol, atol=atol)} "
                       f"at t = {t_stop:.6g} s (scenario {label})")
        series = {k: log[:, layout[k]] if k in layout else None for k in LOG_SERIES}
        out.append(Result(scenario=sc, t=t, **series, engine="batch", complete=complete,
                          message=message, backend=backend, steps=int(runs.steps[i]),
                          rejected=int(runs.rejected[i]), running=running))
    return out
