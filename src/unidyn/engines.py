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
"""

from __future__ import annotations

import dataclasses
import difflib

from ._validate import ValidationError, choice
from .model.scenario import Scenario

__all__ = ["ENGINES", "OPTIONS", "choose", "run"]

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


def run(scenario: Scenario, engine: str = "auto", **options):
    """Run ``scenario`` with the engine :func:`choose` picks, as ``unidyn run`` does.

    :param engine: ``"auto"``, ``"batch"`` or ``"bdsim"`` (:func:`choose`)
    :param options: passed to the engine's function: :func:`unidyn.simulate_batch`
        (``rtol``, ``atol``, ``backend``, ``progress``) or :func:`unidyn.simulate` (``rtol``,
        ``atol``, ``method``, ``timeout``, ``progress``, the diagram's block factories)
    :return: :class:`~unidyn.Result` (its ``engine`` says which ran)
    :raises ValidationError: for an option the engine does not take (a scenario's
        field is set on the scenario: ``scenario.replace(T=20)``)
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
    if chosen == "batch":
        from .engine.batch import simulate_batch  # numba, where installed, loads with it
        return simulate_batch([scenario], **options)[0]
    from .diagrams.simulate import simulate  # bdsim loads with it
    return simulate(scenario, **options)
