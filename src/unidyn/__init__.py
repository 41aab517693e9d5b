"""unidyn: the velocity-based dynamic model of differential-drive robots
(Martins, Sarcinelli-Filho, Carelli, J Intell Robot Syst 2017) for bdsim and
the Robotics Toolbox for Python.

The numerical core (this package's modules) is pure numpy and usable without
bdsim; the bdsim blocks live in :mod:`unidyn.blocks` and the Fig. 2 diagrams in
:mod:`unidyn.diagrams`.
"""

from . import _bdsim_path
from ._validate import ValidationError
from .model import Limits, NO_LIMITS, PAPER_LIMITS
from .noise import NoiseSpec
from .parameters import RobotParameters
from . import control, model, robots, trajectories

__version__ = "0.1.0"

_bdsim_path.register()

__all__ = ["ValidationError", "RobotParameters", "Limits", "NoiseSpec", "NO_LIMITS",
           "PAPER_LIMITS", "robots", "model", "control", "trajectories", "__version__"]


def __getattr__(name):
    # The scenario layer imports bdsim; load it only when asked for.
    lazy = {
        "Scenario": ("scenario", "Scenario"),
        "simulate": ("runner", "simulate"),
        "SimulationError": ("runner", "SimulationError"),
        "simulate_batch": ("batch", "simulate_batch"),
        "Result": ("result", "Result"),
        "properties": ("properties", None),
        "animation": ("animation", None),
        "batch": ("batch", None),
        "check_properties": ("properties", "check_properties"),
        "rank_test": ("properties", "rank_test"),
        # python-control and ipywidgets are optional (unidyn[control], unidyn[teach])
        "to_iosys": ("iosys", "to_iosys"),
        "iosys": ("iosys", None),
        "widgets": ("widgets", None),
        "LoopExplorer": ("widgets", "LoopExplorer"),
        "equations": ("equations", None),
    }
    if name in lazy:
        import importlib
        mod_name, attr = lazy[name]
        mod = importlib.import_module(f".{mod_name}", __name__)
        return mod if attr is None else getattr(mod, attr)
    raise AttributeError(f"module 'unidyn' has no attribute {name!r}")
