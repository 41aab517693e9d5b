"""Both engines stop a run whose state diverges or that they cannot resolve, with
an error naming the cause and the part computed."""

import numpy as np
import pytest

import unidyn
from unidyn import Scenario, SimulationError, ValidationError
from unidyn.engine.batch import simulate_batch
from unidyn.model.unicycle import NO_LIMITS

pytestmark = pytest.mark.reliability

# the Pioneer of the paper with theta5 = -100 (Eq. 2: w' grows with u w) and
# almost no damping of w: a robot whose velocity loop runs away
UNSTABLE = [0.2604, 0.2509, -0.000499, 0.9965, -100.0, 1e-12]


def _gamma(g, T=20.0):
    return Scenario(gamma=[g] * 6, adapt_from=0.0, T=T, noise=None)


@pytest.mark.parametrize("gamma", [1e6, 1e9])
def test_an_adaptation_gain_too_high_for_the_tolerance_stops_or_says_so_naming_rtol(gamma):
    """No rate of the update law is foreseen: error control shortens the steps until an
    interval needs more than MAX_STEPS, or the run's check disagrees; either way the
    run is not complete and names what to change."""
    r, = simulate_batch([_gamma(gamma, T=3.0)])
    assert not r.complete and "rtol" in r.message, r.message


def test_a_runaway_robot_is_never_reported_complete_by_the_batch_engine():
    sc = Scenario(robot=UNSTABLE, limits=NO_LIMITS, T=6.0, adapt_from=0.0, name="runaway")
    r, = simulate_batch([sc])
    assert not r.complete and "runaway" in r.message
    assert all(v is None for v in r.metrics.values())
    assert 0 < len(r.t) and np.isfinite(r.pose).all()


def test_x0_far_beyond_the_reference_is_refused():
    with pytest.raises(ValidationError, match="x0"):
        Scenario(x0=(1e300, 0.0, 0.0))


@pytest.mark.slow
def test_the_diagram_stops_a_run_too_stiff_for_its_solver_instead_of_hanging():
    sc = Scenario(robot=UNSTABLE, limits=NO_LIMITS, T=6.0, adapt_from=0.0, name="runaway")
    with pytest.raises(SimulationError) as info:
        unidyn.simulate(sc)
    msg = str(info.value)
    assert "runaway" in msg and "evaluations" in msg and "LSODA" in msg
    part = info.value.result
    assert part is not None and not part.complete and 1.0 < part.t[-1] < 6.0


def test_the_diagram_stops_at_its_wall_clock_limit():
    sc = Scenario.paper(4, T=200.0, name="slow")
    with pytest.raises(SimulationError, match="wall-clock limit of 1 s") as info:
        unidyn.simulate(sc, timeout=1.0)
    assert not info.value.result.complete and info.value.result.t[-1] < 200.0


@pytest.mark.parametrize("backend", ["compiled", "plain"])
def test_a_loop_too_fast_for_the_steps_allowed_stops_with_a_reason(backend):
    """Compensation with an estimate 1e6 times theta closes a velocity loop 1e6 times
    faster than the robot's: no step within MAX_STEPS per sample holds the error."""
    p3dx = unidyn.model.robots.get("p3dx_laser")
    sc = Scenario(case="compensated", theta_hat0=p3dx.scaled(1e6), limits=NO_LIMITS,
                  noise=None, T=5.0, name="far")
    r, = simulate_batch([sc], backend=backend)
    assert not r.complete and r.metrics["iae"] is None
    assert "could not be held within rtol" in r.message and "far" in r.message
    assert "Radau" in r.message  # what to change
