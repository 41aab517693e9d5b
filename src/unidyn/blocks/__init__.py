"""bdsim blocks of unidyn.

After ``pip install unidyn`` every block is available in a bdsim diagram by its
upper-cased class name (``bd.DYNAMICUNICYCLE(...)``), and can also be built
directly (``DynamicUnicycle(..., bd=bd)``).
"""

from .robots import DynamicUnicycle, KinematicUnicycle
from .controllers import KinematicController, DynamicCompensator
from .sources import FigureEight, Circle, Line, TrajectorySource, MeasurementNoise

__all__ = ["DynamicUnicycle", "KinematicUnicycle", "KinematicController",
           "DynamicCompensator", "FigureEight", "Circle", "Line", "TrajectorySource",
           "MeasurementNoise"]
