"""unidyn: the velocity-based dynamic model of differential-drive robots
(Martins, Sarcinelli-Filho, Carelli, J Intell Robot Syst 2017) for bdsim and
the Robotics Toolbox for Python.

The numerical core (this package's modules) is pure numpy and usable without
bdsim; the bdsim blocks live in :mod:`unidyn.blocks` and the Fig. 2 diagrams in
:mod:`unidyn.diagrams`.
"""

from . import _bdsim_path

#: True only for type checkers (mypy and pyright read a local one as typing's, whose
#: import adds 3 ms to the command's start-up, before its Ctrl-C handling)
TYPE_CHECKING = False

__version__ = "0.1.0"

_bdsim_path.register()

__all__ = ["ValidationError", "RobotParameters", "Limits", "NoiseSpec", "NO_LIMITS",
           "PAPER_LIMITS", "robots", "model", "control", "trajectories", "__version__"]

if TYPE_CHECKING:  # for readers and type checkers; at run time, loaded when first used
    from . import control, model, robots, trajectories  # noqa: F401
    from ._validate import ValidationError  # noqa: F401
    from .model import NO_LIMITS, PAPER_LIMITS, Limits  # noqa: F401
    from .noise import NoiseSpec  # noqa: F401
    from .parameters import RobotParameters  # noqa: F401
del TYPE_CHECKING  # only for the block above: not one of the package's names

#: What ``unidyn.<name>`` loads on first use: (module, attribute or None for the module).
#: Nothing heavy loads on ``import unidyn`` (numpy does when any of these is used), so
#: the ``unidyn`` command starts with its Ctrl-C handling in place.
_LAZY = {
    "ValidationError": ("_validate", "ValidationError"),
    "RobotParameters": ("parameters", "RobotParameters"),
    "Limits": ("model", "Limits"),
    "NO_LIMITS": ("model", "NO_LIMITS"),
    "PAPER_LIMITS": ("model", "PAPER_LIMITS"),
    "NoiseSpec": ("noise", "NoiseSpec"),
    "robots": ("robots", None),
    "parameters": ("parameters", None),
    "noise": ("noise", None),
    "model": ("model", None),
    "control": ("control", None),
    "trajectories": ("trajectories", None),
    # the scenario layer imports bdsim
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


def __getattr__(name):
    if name in _LAZY:
        import importlib
        mod_name, attr = _LAZY[name]
        mod = importlib.import_module(f".{mod_name}", __name__)
        return mod if attr is None else getattr(mod, attr)
    raise AttributeError(f"module 'unidyn' has no attribute {name!r}")


def __dir__():
    return sorted(set(globals()) | set(_LAZY))
