"""Both engines stop a run whose state diverges or that they cannot resolve, with
an error naming the cause and the part computed."""

import numpy as np
import pytest

import unidyn
import unidyn.results.result
from unidyn import Scenario, ValidationError
from unidyn.engine.batch import ACCURACY, DECISIVE, simulate_batch
from unidyn.model.unicycle import NO_LIMITS

pytestmark = pytest.mark.reliability

# the Pioneer of the paper with theta5 = -100 (Eq. 2: w' grows with u w) and
# almost no damping of w: a robot whose velocity loop runs away
UNSTABLE = [0.2604, 0.2509, -0.000499, 0.9965, -100.0, 1e-12]


def _gamma(g, T=20.0):
    return Scenario(gamma=[g] * 6, adapt_from=0.0, T=T, noise=None)


def test_an_adaptation_gain_of_a_million_is_tightened_until_its_estimate_is_honest():
    """No rate of the update law is foreseen: the error estimate tightens the run until
    it is within the promise, and the estimate holds against a converged reference
    (the engine at rtol 1e-12, itself within 1e-10 of rtol 1e-11 here)."""
    sc = _gamma(1e6, T=3.0)
    r, = simulate_batch([sc])
    ref, = simulate_batch([sc], rtol=1e-12, atol=1e-14)  # returned at 1e-13
    assert r.complete and not r.sensitive, r.message
    assert max(r.numerical_error[k] for k in DECISIVE) <= ACCURACY
    for k in ("iae", "ise", "itae", "itse", "energy"):
        assert abs(r.metrics[k] - ref.metrics[k]) <= 2 * r.numerical_error[k] * abs(ref.metrics[k])


def test_an_adaptation_gain_too_high_for_any_tolerance_stops_naming_rtol():
    r, = simulate_batch([_gamma(1e9, T=3.0)])
    assert not r.complete and "rtol" in r.message, r.message
    assert all(np.isfinite(v) for v in r.metrics.values())  # those of the part computed


def test_a_runaway_robot_is_never_reported_complete_by_the_batch_engine():
    # over 60 s its velocity loop runs away until no step holds the error
    sc = Scenario(robot=UNSTABLE, limits=NO_LIMITS, T=60.0, adapt_from=0.0, name="runaway")
    r, = simulate_batch([sc])
    assert not r.complete and "runaway" in r.message
    assert r.numerical_error is None  # a run that stopped is not estimated
    assert 0 < len(r.t) and np.isfinite(r.pose).all()
    # the metrics of the part computed: those of its samples
    assert r.metrics["iae"] == pytest.approx(unidyn.results.result.metrics(r.t, r.error, r.velocity)["iae"], rel=1e-12)


def test_x0_far_beyond_the_reference_is_refused():
    with pytest.raises(ValidationError, match="x0"):
        Scenario(x0=(1e300, 0.0, 0.0))


@pytest.mark.slow
def test_the_diagram_stops_a_run_too_stiff_for_its_solver_instead_of_hanging():
    sc = Scenario(robot=UNSTABLE, limits=NO_LIMITS, T=6.0, adapt_from=0.0, name="runaway")
    part = unidyn.simulate(sc)  # returned as the batch engine returns it: incomplete
    msg = part.message
    assert "runaway" in msg and "evaluations" in msg and "LSODA" in msg
    assert not part.complete and 1.0 < part.t[-1] < 6.0


def test_the_diagram_stops_at_its_wall_clock_limit():
    sc = Scenario.paper(4, T=200.0, name="slow")
    r = unidyn.simulate(sc, timeout=1.0)
    assert "wall-clock limit of 1 s" in r.message
    assert not r.complete and r.t[-1] < 200.0 and np.isfinite(r.metrics["iae"])


# plain Python takes its 10,000 steps in seconds: the whole-system tier
@pytest.mark.parametrize("backend", ["compiled", pytest.param("plain", marks=pytest.mark.slow)])
def test_a_loop_too_fast_for_the_steps_allowed_stops_with_a_reason(backend):
    """Compensation with an estimate 1e6 times theta closes a velocity loop 1e6 times
    faster than the robot's: no step within MAX_STEPS per sample holds the error."""
    p3dx = unidyn.model.robots.get("p3dx_laser")
    sc = Scenario(case="compensated", theta_hat0=p3dx.scaled(1e6), limits=NO_LIMITS,
                  noise=None, T=5.0, name="far")
    r, = simulate_batch([sc], backend=backend)
    assert not r.complete and r.numerical_error is None
    assert "could not be held within rtol" in r.message and "far" in r.message
    assert "Radau" in r.message  # what to change
