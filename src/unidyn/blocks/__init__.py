"""bdsim blocks of unidyn.

After ``pip install unidyn`` every block is available in a bdsim diagram by its
upper-cased class name (``bd.DYNAMICUNICYCLE(...)``), and can also be built
directly (``DynamicUnicycle(..., bd=bd)``).
"""

from .controllers import (
    DynamicCompensator,
    DynamicCompensatorWithRateInput,
    KinematicController,
    KinematicControllerWithRate,
)
from .sources import (
    Circle,
    FigureEight,
    Line,
    MeasurementNoise,
    Point,
    Segment,
    SensorNoise,
    TrajectorySource,
    trajectory_block,
)
from .unicycles import DynamicUnicycle, DynamicUnicycleWithVelocity, KinematicUnicycle

__all__ = ["DynamicUnicycle", "KinematicUnicycle", "KinematicController",
           "DynamicCompensator", "FigureEight", "Circle", "Line", "Point", "Segment",
           "TrajectorySource",
           "MeasurementNoise",
           # the same blocks with fixed ports (drawn by bdedit, loaded from .bd files)
           "DynamicUnicycleWithVelocity", "KinematicControllerWithRate",
           "DynamicCompensatorWithRateInput", "SensorNoise",
           # the reference block of a trajectory
           "trajectory_block"]
