"""The fixed goal point (positioning, as in the authors' MATLAB package): in the
kinematic case with no limits, Eq. (10) makes each component of the error obey
h~' = -l tanh(k h~ / l), whose solution is h~(t) = (l/k) asinh(sinh(k h~0 / l) e^{-kt}).
Both engines, the POINT block in a diagram, and the scenario file's fields."""

import math

import numpy as np
import pytest

import unidyn
from unidyn import NO_LIMITS, Scenario, ValidationError
from unidyn.model.trajectories import Point, from_spec

GOAL, X0, K, L = (1.0, -0.6), (0.2, 0.0, 0.3), 0.8, 0.3


def closed_form(t):
    """The distance to the goal at times t, from the solution above (per component)."""
    e0 = np.subtract(GOAL, X0[:2])
    e = [(L / K) * np.arcsinh(np.sinh(K * c / L) * np.exp(-K * t)) for c in e0]
    return np.hypot(*e)


def scenario(**kw):
    return Scenario(case="kinematic", trajectory={"type": "point", "x": GOAL[0], "y": GOAL[1]},
                    x0=X0, kx=K, ky=K, lx=L, ly=L, limits=NO_LIMITS, noise=None, T=20.0, **kw)


@pytest.mark.parametrize("engine", ["batch", "bdsim"])
def test_the_goal_is_reached_as_the_closed_form_says(engine):
    r = unidyn.run(scenario(), engine=engine)
    assert r.complete, r.message
    np.testing.assert_allclose(r.error, closed_form(r.t), atol=1e-6)
    # within 1 cm of the goal, and at rest there, by the end
    assert r.error[-1] < 0.01 and np.all(np.abs(r.velocity[-1]) < 0.05)


def test_the_point_block_drives_a_diagram_to_the_goal():
    r = unidyn.simulate(scenario(), trajectory=lambda bd, sc: bd.POINT(x=GOAL[0], y=GOAL[1]))
    assert r.complete, r.message
    np.testing.assert_allclose(r.error, closed_form(r.t), atol=1e-6)


def test_a_point_reads_and_writes_as_a_scenario_file_does():
    p = from_spec({"type": "point", "x": 1.5, "y": -2})
    assert p == Point(1.5, -2.0) and p.to_spec() == {"type": "point", "x": 1.5, "y": -2.0}
    np.testing.assert_array_equal(p.velocity([0.0, 3.0]), np.zeros((2, 2)))
    sc = scenario()
    assert Scenario.from_dict(sc.to_dict()).trajectory == sc.trajectory
    with pytest.raises(ValidationError, match="unknown trajectory.velocity for type 'point'"):
        from_spec({"type": "point", "x": 1, "y": 1, "velocity": [1, 0]})
    with pytest.raises(ValidationError, match="x"):
        from_spec({"type": "point", "x": math.nan, "y": 1})
