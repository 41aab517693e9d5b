"""Which engine runs a scenario, chosen the same way in Python (:func:`unidyn.run`),
on the command line (``unidyn run --engine``) and in sweeps.

Two engines integrate the same equations (:mod:`unidyn.model.equations`):

- ``"bdsim"``: the Fig. 2 diagram of bdsim blocks, integrated by scipy's ``solve_ivp``
  with an adaptive step (:func:`unidyn.simulate`); it runs every scenario, sampled
  control included;
- ``"batch"``: the batch engine, the same kind of adaptive step over many runs at once,
  compiled (:func:`unidyn.simulate_batch`); continuous control only, and far faster,
  with each metric's numerical error estimated.

Both take ``rtol`` and ``atol`` with the same meaning (``solve_ivp``'s). Both report a
run that stopped the same way: a :class:`~unidyn.Result` with ``complete=False``, its
``message`` saying why, and the metrics of the part computed.

This module sits above both engines (it imports each when a run needs it).

``"auto"`` picks the batch engine for continuous control and the diagram for sampled
control; :attr:`Result.engine <unidyn.Result>` says which ran.

The batch engine runs compiled (numba is a dependency of the package); where it cannot
(numba not installed on the platform, or a reference that is a Python function) it runs
as plain Python, about a hundred times slower, and a job that would take longer than
:data:`LONG_JOB` seconds then says so at its start (:func:`warn_if_plain`).

``seeds=N`` runs one scenario over N noise seeds (:class:`unidyn.sweeps.seeds.SeedRuns`):
its metrics' spread over the noise, the uncertainty a noisy run's numbers carry.
"""

from __future__ import annotations

import dataclasses
import difflib
import warnings

from ._validate import ValidationError, choice
from .model.scenario import Scenario
from .model.trajectories import KINDS

__all__ = ["ENGINES", "OPTIONS", "choose", "run", "warn_if_plain", "plain_cost",
           "PlainPythonWarning", "PLAIN_SECONDS_PER_SAMPLE", "LONG_JOB"]

#: CPU seconds per sample interval of one run that the batch engine takes as plain
#: Python, its numerical error estimated (the run, its probe and a tighter run):
#: 2.2-3.9 ms for the paper's cases 3 and 4 on one core of an AMD EPYC server (compiled:
#: 0.03-0.05 ms).
PLAIN_SECONDS_PER_SAMPLE = 3e-3
#: A job estimated to take longer than this (s) as plain Python warns at its start.
LONG_JOB = 10.0


class PlainPythonWarning(UserWarning):
    """The batch engine runs a long job as plain Python; the message says how long it
    is expected to take and how to have it compiled."""

#: The two engines; :func:`run` also takes ``"auto"``, which picks one of them.
ENGINES = ("batch", "bdsim")
#: The options each engine's function takes through :func:`run`.
OPTIONS = {"batch": ("rtol", "atol", "backend", "progress"),
           "bdsim": ("rtol", "atol", "method", "timeout", "progress", "robot", "controller",
                     "compensator", "trajectory")}


def choose(scenario: Scenario, engine: str = "auto") -> str:
    """The engine that runs ``scenario``: ``"batch"`` or ``"bdsim"``.

    :param engine: ``"auto"`` (the batch engine for continuous control, the bdsim
        diagram for sampled control), ``"batch"`` or ``"bdsim"``
    :raises ValidationError: for another engine
    """
    engine = choice("engine", engine, ("auto",) + ENGINES)
    if engine == "auto":
        return "batch" if scenario.control == "continuous" else "bdsim"
    return engine


def plain_cost(scenarios, backend: str = "auto"):
    """Why and how long the batch engine would run ``scenarios`` as plain Python:
    ``(seconds estimated, what to do about it)``, or None where it runs them compiled.
    The estimate is :data:`PLAIN_SECONDS_PER_SAMPLE` times their sample intervals: a
    rough one (a loop that needs short steps takes longer)."""
    from .engine import batch, kernels  # numba, where installed, loads with them
    scenarios = list(scenarios)
    if batch.backend_for(scenarios, backend) != "plain":
        return None
    seconds = PLAIN_SECONDS_PER_SAMPLE * sum(s.steps for s in scenarios)
    if not kernels.AVAILABLE:
        fix = ("numba is not installed (pip install numba; it is a dependency of unidyn, "
               "so this platform may have no release of it)")
    elif backend == "plain":
        fix = "backend='plain' was asked for (backend='auto' compiles it)"
    else:
        fix = ("a reference is a Python function (FunctionTrajectory); a built-in "
               f"trajectory ({', '.join(KINDS)}) runs compiled")
    return seconds, fix


def warn_if_plain(scenarios, backend: str = "auto", stacklevel: int = 2) -> None:
    """Warn once (:class:`PlainPythonWarning`) where the batch engine would run
    ``scenarios``, a job of more than :data:`LONG_JOB` seconds, as plain Python: the
    estimated time and the fix. Call it at the start of a job that makes several calls
    of the engine (a sweep), with every scenario of the job."""
    cost = plain_cost(scenarios, backend)
    if cost is None or cost[0] < LONG_JOB:
        return
    seconds, fix = cost
    took = f"{seconds / 60:.0f} min" if seconds >= 120 else f"{seconds:.0f} s"
    warnings.warn(f"the batch engine runs as plain Python here, about a hundred times "
                  f"slower than compiled: about {took} of CPU for these runs; {fix}",
                  PlainPythonWarning, stacklevel=stacklevel + 1)


def run(scenario: Scenario, engine: str = "auto", *, seeds=None, **options):
    """Run ``scenario`` with the engine :func:`choose` picks, as ``unidyn run`` does.

    A run with measurement noise is one sample of it: ``seeds`` runs the scenario over
    several noise seeds and gives each metric's mean and standard error over them, the
    uncertainty to quote (:class:`~unidyn.sweeps.seeds.SeedRuns`)::

        runs = unidyn.run(unidyn.Scenario.paper(3), seeds=8)
        print(runs)                      # iae 2.540 ± 0.067 m·s (n = 8), ...
        runs.statistics["iae_sem"]       # the standard error of the mean IAE

    :param engine: ``"auto"``, ``"batch"`` or ``"bdsim"`` (:func:`choose`)
    :param seeds: ``None`` (one run, the scenario's own ``noise.seed``), a number N
        (the seeds ``noise.seed``, ``noise.seed + 1``, ..., N of them) or a list of
        seeds; the batch engine runs them in one call, sharing the cores
    :param options: passed to the engine's function: :func:`unidyn.simulate_batch`
        (``rtol``, ``atol``, ``backend``, ``progress``) or :func:`unidyn.simulate` (``rtol``,
        ``atol``, ``method``, ``timeout``, ``progress``, the diagram's block factories)
    :return: :class:`~unidyn.Result` (its ``engine`` says which ran); with ``seeds``, a
        :class:`~unidyn.sweeps.seeds.SeedRuns` holding a Result per seed
    :raises ValidationError: for an option the engine does not take (a scenario's
        field is set on the scenario: ``scenario.replace(T=20)``); ``seeds`` for a
        scenario without noise
    """
    if not isinstance(scenario, Scenario):
        raise ValidationError(f"scenario must be a unidyn.Scenario, got {type(scenario).__name__}")
    chosen = choose(scenario, engine)
    fields = {f.name for f in dataclasses.fields(Scenario)}
    for name in options:
        if name in OPTIONS[chosen]:
            continue
        if name in fields:
            raise ValidationError(f"{name!r} is a field of the scenario, not an option of "
                                  f"unidyn.run: unidyn.run(scenario.replace({name}=...))")
        near = difflib.get_close_matches(name, OPTIONS[chosen], n=1)
        raise ValidationError(f"unidyn.run() with engine {chosen!r} takes "
                              f"{', '.join(OPTIONS[chosen])}; got {name!r}"
                              + (f" (did you mean {near[0]!r}?)" if near else ""))
    if seeds is None:
        return _run_all([scenario], chosen, options, keep_failed=False)[0]
    from .sweeps.seeds import SeedRuns, seed_scenarios
    seeds, scenarios = seed_scenarios(scenario, seeds)
    if chosen == "batch":  # the seeds start from the tolerance the first seed needed
        options = {**options, "estimate": "per_point"}
    return SeedRuns(scenario, tuple(seeds), _run_all(scenarios, chosen, options, keep_failed=True))


def _run_all(scenarios, chosen: str, options: dict, keep_failed: bool) -> list:
    """A Result per scenario: the batch engine in one call (the runs share the cores),
    the diagram one run after another (``keep_failed``: a run that stops is kept, marked
    incomplete, and the others go on, as the batch engine does)."""
    if chosen == "batch":
        from .engine.batch import simulate_batch  # numba, where installed, loads with it
        warn_if_plain(scenarios, options.get("backend", "auto"), stacklevel=3)
        return simulate_batch(scenarios, **options)
    from ._errors import SimulationError
    from .diagrams.simulate import simulate  # bdsim loads with it
    out = []
    for sc in scenarios:
        try:
            out.append(simulate(sc, **options))
        except SimulationError as err:
            if not keep_failed or err.result is None:
                raise
            out.append(err.result)
    return out
