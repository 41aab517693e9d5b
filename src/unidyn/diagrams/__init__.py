"""bdsim diagrams of the paper's closed loop (Fig. 2): trajectory -> K -> D -> R."""

from .fig2 import Fig2, build_fig2, new_simulator

__all__ = ["Fig2", "build_fig2", "new_simulator"]
