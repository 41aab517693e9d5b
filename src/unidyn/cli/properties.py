"""``unidyn properties``: check the model's properties 1-7 (Section 3) for a robot."""

from __future__ import annotations

from ..model import robots
from ..model.properties import check_properties


def unidyn_properties(args) -> int:
    """``unidyn properties``: check properties 1-7 of Section 3 for a robot."""
    robot = robots.resolve(args.robot, "robot")
    print(check_properties(robot, args.u_max))
    return 0
