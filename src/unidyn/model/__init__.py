"""The paper's science: the robot's model, its controllers and what they are run with.

Free of bdsim and of files; every other part of unidyn builds on it.

- :mod:`~unidyn.model.equations`: every equation of the paper, once, as plain
  arithmetic (Eqs. 1-2, 10, 12, 14, 18, 20) and the closed loop of Fig. 2 built from it;
- :mod:`~unidyn.model.unicycle`: the robot (Eqs. 1-2) on arrays, its speed and
  acceleration limits (:class:`~unidyn.model.unicycle.Limits`); its names are also
  this package's (``unidyn.model.unicycle_deriv``);
- :mod:`~unidyn.model.laws`: the control laws (Eqs. 10, 12, 14, 18, 20) on arrays;
- :mod:`~unidyn.model.parameters` (:class:`~unidyn.RobotParameters`, Eq. 3) and
  :mod:`~unidyn.model.robots` (the Pioneer 3-DX and the other presets);
- :mod:`~unidyn.model.trajectories` (the references), :mod:`~unidyn.model.noise`
  (measurement noise), :mod:`~unidyn.model.properties` (the model's properties,
  Section 3), :mod:`~unidyn.model.scenario` (:class:`~unidyn.Scenario`: one run of the
  loop described).
"""

from .unicycle import *  # noqa: F401,F403 - unidyn.model.<function of the robot>
from .unicycle import __all__  # noqa: F401
