"""Block constructors name the block type and the keyword they do not know, and
refuse a starting speed beyond the robot's limits."""

import pytest

from unidyn import ValidationError
from unidyn import blocks as B
from unidyn.diagrams import new_simulator
from unidyn.model.trajectories import FigureEight


def _clock():
    return new_simulator().blockdiagram().clock(0.1, name="c")


CASES = [
    (B.DynamicUnicycle, {}, "spedd_max", "speed_max"),
    (B.KinematicUnicycle, {}, "steer_mx", "steer_max"),
    (B.KinematicController, {}, "kxx", None),
    (B.DynamicCompensator, {}, "gama", "gamma"),
    (B.FigureEight, {}, "wxx", "wx"),
    (B.Circle, {}, "radious", "radius"),
    (B.Line, {}, "velocty", "velocity"),
    (B.TrajectorySource, {"trajectory": FigureEight()}, "acceleraton", "acceleration"),
    (B.MeasurementNoise, {"clock": None}, "sed", "seed"),
]


@pytest.mark.parametrize("cls, args, bad, hint", CASES, ids=[c[0].__name__ for c in CASES])
def test_a_misspelt_keyword_names_the_block_and_the_keyword(cls, args, bad, hint):
    if "clock" in args:
        args = {**args, "clock": _clock()}
    with pytest.raises(ValidationError) as info:
        cls(**args, **{bad: 1.0})
    msg = str(info.value)
    assert msg.startswith(cls.__name__) and repr(bad) in msg, msg
    if hint:
        assert f"did you mean {hint!r}" in msg, msg


def test_bdsim_common_block_options_are_still_accepted():
    b = B.DynamicUnicycle(name="robot", velocity_output=True)
    assert b.name == "robot"


@pytest.mark.parametrize("x0, word", [((0, 0, 0, 0.8, 0), "u = 0.8"), ((0, 0, 0, 0, -2.0), "w = -2")])
def test_an_initial_speed_beyond_the_limits_is_refused(x0, word):
    with pytest.raises(ValidationError) as info:
        B.DynamicUnicycle(x0=x0, speed_max=0.75, steer_max=1.745)
    assert "DynamicUnicycle" in str(info.value) and word in str(info.value)
    B.DynamicUnicycle(x0=(0, 0, 0, 0.75, -1.745), speed_max=0.75, steer_max=1.745)  # on the limit


def test_each_accepted_keyword_is_listed_once():
    with pytest.raises(ValidationError) as info:
        B.DynamicUnicycle(spedd_max=1.0)
    names = str(info.value).split("it accepts ")[1].replace(" and bdsim's block options", ",")
    names = [n.strip() for n in names.split(",")]
    assert "x0" in names and len(names) == len(set(names)), names


def test_through_bdsims_factory_the_error_is_bdsims_and_says_ours(capsys):
    """bdsim's factory (bd.DYNAMICUNICYCLE) prints the block's error and raises its own
    BlockCreationError (as the README says); the class raises the ValidationError."""
    from bdsim.exceptions import BlockCreationError
    bd = new_simulator().blockdiagram()
    with pytest.raises(BlockCreationError):
        bd.DYNAMICUNICYCLE(speed_max=-1.0)
    assert "speed_max must be > 0" in capsys.readouterr().out
    with pytest.raises(ValidationError, match="speed_max must be > 0"):
        B.DynamicUnicycle(speed_max=-1.0, bd=bd)


@pytest.mark.parametrize("cls", [B.DynamicUnicycle, B.KinematicUnicycle, B.DynamicUnicycleWithVelocity])
@pytest.mark.parametrize("old, meant", [("vlim", "speed_max"), ("slim", "steer_max")])
def test_the_toolboxs_old_keywords_name_the_keyword_meant(cls, old, meant):
    # roboticstoolbox's BICYCLE still takes vlim and slim (deprecated) for speed_max and steer_max
    with pytest.raises(ValidationError) as info:
        cls(**{old: 1.0})
    msg = str(info.value)
    assert f"unknown keyword {old!r} (roboticstoolbox's old name for {meant})" in msg, msg


def test_the_bicycles_wheelbase_says_a_unicycle_has_none():
    with pytest.raises(ValidationError, match=r"'L' \(the wheelbase of roboticstoolbox's BICYCLE"):
        B.DynamicUnicycle(L=2.0)
    # a block without the keyword the toolbox means gets no hint towards it
    with pytest.raises(ValidationError, match=r"unknown keyword 'slim'; it accepts"):
        B.Line(slim=1.0)
