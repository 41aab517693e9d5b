"""Which engine runs a scenario, chosen the same way in Python (:func:`unidyn.run`),
on the command line (``unidyn run --engine``) and in sweeps.

Two engines integrate the same equations (:mod:`unidyn.model.equations`):

- ``"bdsim"``: the Fig. 2 diagram of bdsim blocks, integrated by scipy's ``solve_ivp``
  with an adaptive step (:func:`unidyn.simulate`); it runs every scenario, sampled
  control included;
- ``"batch"``: the batch engine, the same kind of adaptive step over many runs at once,
  compiled (:func:`unidyn.simulate_batch`); continuous control only, and far faster.

Both take ``rtol`` and ``atol`` with the same meaning (``solve_ivp``'s).

``"auto"`` picks the batch engine for continuous control and the diagram for sampled
control; :attr:`Result.engine <unidyn.Result>` says which ran.
"""

from __future__ import annotations

from .._validate import choice
from ..model.scenario import Scenario

__all__ = ["ENGINES", "choose", "run"]

#: The two engines; :func:`run` also takes ``"auto"``, which picks one of them.
ENGINES = ("batch", "bdsim")


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
    """
    if choose(scenario, engine) == "batch":
        from .batch import simulate_batch  # numba, where installed, loads with it
        return simulate_batch([scenario], **options)[0]
    from ..diagrams.simulate import simulate  # bdsim loads with it
    return simulate(scenario, **options)
