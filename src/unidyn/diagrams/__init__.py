"""bdsim diagrams of the paper's closed loop (Fig. 2): trajectory -> K -> D -> R."""

from .fig2 import TOOLBOX_CRASH, Fig2, ToolboxWarning, build_fig2, new_simulator
from .monitor import RunMonitor

__all__ = ["Fig2", "RunMonitor", "TOOLBOX_CRASH", "ToolboxWarning", "build_fig2", "new_simulator"]
