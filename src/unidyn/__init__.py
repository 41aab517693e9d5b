"""unidyn: the velocity-based dynamic model of differential-drive robots
(Martins, Sarcinelli-Filho, Carelli, J Intell Robot Syst 2017) for bdsim and
the Robotics Toolbox for Python.

Its parts, lowest layer first (a part imports only its own layer or lower ones):
:mod:`unidyn.model` (the paper's science: pure numpy, no bdsim, no files);
:mod:`unidyn.results` (what a run gives back, its files and figures);
:mod:`unidyn.blocks`, :mod:`unidyn.diagrams` (bdsim) and :mod:`unidyn.engine` (the
batch engine); :mod:`unidyn.identification`, :mod:`unidyn.sweeps` and
:mod:`unidyn.teaching`; :mod:`unidyn.paper` (the paper's Section 5 and Fig. 11); and
:mod:`unidyn.cli` (the ``unidyn`` command).
"""

from . import _bdsim_path
from ._errors import (
    AccuracyWarning,
    Interrupted,
    MissingDependency,
    NonFiniteSignalError,
    SimulationError,
    SimulationInterrupted,
    ValidationError,
)

__version__ = "0.1.0"

_bdsim_path.register()

__all__ = ["Scenario", "read_scenario", "run", "simulate", "simulate_batch", "Result", "SimulationError",
           "ValidationError", "NonFiniteSignalError", "SimulationInterrupted", "Interrupted",
           "MissingDependency", "AccuracyWarning", "RobotParameters", "Limits", "NoiseSpec", "NO_LIMITS",
           "PAPER_LIMITS", "robots", "laws", "trajectories", "equations", "check_properties",
           "rank_test", "to_iosys", "LoopExplorer", "__version__"]


#: What ``unidyn.<name>`` loads on first use: (module, attribute or None for the module).
#: Nothing heavy loads on ``import unidyn`` (numpy does when any of these is used), so
#: the ``unidyn`` command starts with its Ctrl-C handling in place.
_LAZY = {
    "RobotParameters": ("model.parameters", "RobotParameters"),
    "Limits": ("model.unicycle", "Limits"),
    "NO_LIMITS": ("model.unicycle", "NO_LIMITS"),
    "PAPER_LIMITS": ("model.unicycle", "PAPER_LIMITS"),
    "NoiseSpec": ("model.noise", "NoiseSpec"),
    "Scenario": ("model.scenario", "Scenario"),
    # a scenario file (TOML) as unidyn run reads it; files are read above the model
    "read_scenario": ("sweeps.sweep_files", "read_scenario"),
    "robots": ("model.robots", None),
    "laws": ("model.laws", None),
    "trajectories": ("model.trajectories", None),
    "equations": ("model.equations", None),
    "check_properties": ("model.properties", "check_properties"),
    "rank_test": ("model.properties", "rank_test"),
    "Result": ("results.result", "Result"),
    # one run, the engine chosen as on the command line; the bdsim diagram of Fig. 2
    # (bdsim loads with it), and the batch engine
    "run": ("engines", "run"),
    "simulate": ("diagrams.simulate", "simulate"),
    "simulate_batch": ("engine.batch", "simulate_batch"),
    # python-control and ipywidgets are optional (unidyn[control], unidyn[teach])
    "to_iosys": ("teaching.iosys", "to_iosys"),
    "LoopExplorer": ("teaching.widgets", "LoopExplorer"),
}


def __getattr__(name):
    import importlib
    if name in _LAZY:
        mod_name, attr = _LAZY[name]
        mod = importlib.import_module(f".{mod_name}", __name__)
        return mod if attr is None else getattr(mod, attr)
    if name in _SUBPACKAGES:  # unidyn.engine.batch and the like without importing them first
        return importlib.import_module(f".{name}", __name__)
    raise AttributeError(f"module 'unidyn' has no attribute {name!r}")


#: The package's parts, by layer (lowest first), loaded on first use as ``unidyn.<part>``.
_SUBPACKAGES = ("model", "results", "blocks", "diagrams", "engine", "identification",
                "sweeps", "teaching", "paper", "cli", "process", "datasets")


def __dir__():
    return sorted(set(globals()) | set(_LAZY) | set(_SUBPACKAGES))
