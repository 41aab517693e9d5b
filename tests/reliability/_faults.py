"""Faults injected by the reliability tests."""

import numpy as np

from unidyn.model.trajectories import FigureEight, FunctionTrajectory

F8 = FigureEight()


def nan_after(t_bad):
    """The paper's figure eight whose x turns NaN after ``t_bad`` s."""
    def f(t):
        p = F8.position(t)
        if t > t_bad:
            p = np.array([np.nan, p[1]])
        return p, F8.velocity(t)
    return FunctionTrajectory(f, acceleration=F8.acceleration)
