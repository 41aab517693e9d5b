"""What the paper says, and the checks of it: its Section 5 simulations, its Fig. 11 and
its experiment, each in a module of its own, every claim once as data (the paper's
words and the criterion both made from its numbers).

- Section 5 (:mod:`unidyn.paper.section5`): :func:`section5_claims` takes the four
  results of ``Scenario.paper(1..4)`` and returns, for each claim the paper makes about
  them, the measured number and whether it holds by the stated criterion
  (:func:`format_claims` makes a Markdown table of them).
- Fig. 11 (:mod:`unidyn.paper.fig11`): :func:`paper_fig11` is the sweep of the paper's
  Fig. 11 (IAE against the kinematic controller's gain kx = ky, four cases
  :data:`FIG11_CASES`), :func:`fig11_claims` compares its metrics with what the paper
  says of them (:func:`format_fig11_claims`), and :func:`plot_fig11` draws the figure.
- The experiment (:mod:`unidyn.paper.experiment`): :func:`experiment` runs Section 5's
  experiment on a real Pioneer 3-DX as simulated scenarios and judges the paper's
  numbers (:func:`experiment_claims`, :func:`write_experiment`).
- :mod:`unidyn.paper.claims`: what the three share (:class:`Claim`, :data:`BARS`).
"""

from .claims import BARS, Claim
from .experiment import (
    EXPERIMENT_ADAPT_FROM,
    EXPERIMENT_CONTROLLERS,
    EXPERIMENT_ESTIMATE,
    EXPERIMENT_FILES,
    EXPERIMENT_PAPER,
    EXPERIMENT_T,
    EXPERIMENT_WINDOWS,
    Experiment,
    ExperimentRun,
    experiment,
    experiment_claims,
    experiment_scenarios,
    experiment_stats,
    format_experiment_claims,
    plot_experiment,
    write_experiment,
)
from .fig11 import (
    FIG11_CASES,
    Fig11Claim,
    Fig11Point,
    fig11_claims,
    fig11_table,
    format_fig11_claims,
    paper_fig11,
    plot_fig11,
)
from .section5 import format_claims, section5_claims

__all__ = ["Claim", "section5_claims", "format_claims", "paper_fig11", "fig11_claims",
           "format_fig11_claims", "fig11_table", "Fig11Claim", "Fig11Point", "FIG11_CASES",
           "plot_fig11", "BARS",
           "experiment", "experiment_scenarios", "experiment_stats", "experiment_claims",
           "format_experiment_claims", "plot_experiment", "write_experiment", "Experiment",
           "ExperimentRun", "EXPERIMENT_PAPER", "EXPERIMENT_WINDOWS", "EXPERIMENT_FILES",
           "EXPERIMENT_ADAPT_FROM", "EXPERIMENT_T", "EXPERIMENT_ESTIMATE", "EXPERIMENT_CONTROLLERS"]
