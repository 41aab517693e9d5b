"""Both engines stop a run whose state diverges or that they cannot resolve, with
an error naming the cause and the part computed; the batch engine's step accounts
for the adaptation gain (Eqs. 18/20)."""

import warnings

import numpy as np
import pytest

import unidyn
from unidyn import Scenario, SimulationError, ValidationError
from unidyn.engine.batch import (MAX_SUBSTEPS, AccuracyWarning, fastest_rate, simulate_batch,
                          stable_substeps)
from unidyn.model.unicycle import NO_LIMITS

pytestmark = pytest.mark.reliability

# the Pioneer of the paper with theta5 = -100 (Eq. 2: w' grows with u w) and
# almost no damping of w: a robot whose velocity loop runs away
UNSTABLE = [0.2604, 0.2509, -0.000499, 0.9965, -100.0, 1e-12]


def _gamma(g, T=20.0):
    return Scenario(gamma=[g] * 6, adapt_from=0.0, T=T, noise=None)


def test_the_step_rule_accounts_for_the_adaptation_gain():
    paper = Scenario.paper(4)
    fast = _gamma(1000.0)
    assert stable_substeps(paper, 10) == 10  # the paper's gains need no finer step
    rate, what = fastest_rate(fast)
    assert "gamma" in what
    # the update law with the robot: sqrt(sum gamma_j G_ij^2 / theta_i) grows as sqrt(gamma)
    rate2, _ = fastest_rate(fast.replace(gamma=[4000.0] * 6))
    assert rate2 == pytest.approx(2 * rate)
    assert stable_substeps(fast, 10) > 40


def test_gamma_1000_matches_a_run_with_a_much_finer_step():
    sc = _gamma(1000.0)
    with pytest.warns(AccuracyWarning, match="not vouched"):  # and says so
        r, = simulate_batch([sc])
    fine, = simulate_batch([sc], substeps=2000)
    assert r.complete and fine.complete
    # theta_hat reaches about 200 here; with the old 10 steps it was off by 5.8
    assert np.abs(r.theta_hat - fine.theta_hat).max() < 0.02
    assert np.abs(r.pose - fine.pose).max() < 1e-4


@pytest.mark.slow
def test_gamma_1000_matches_the_diagram():
    sc = _gamma(1000.0, T=10.0)
    with pytest.warns(AccuracyWarning, match="not vouched"):  # and is still this close
        r, = simulate_batch([sc])
    d = unidyn.simulate(sc, rtol=1e-11, atol=1e-13)  # converged (runner.HIGH_GAIN)
    assert np.abs(r.theta_hat - d.theta_hat).max() < 0.02
    assert np.abs(r.pose - d.pose).max() < 1e-4


@pytest.mark.filterwarnings("ignore::unidyn.engine.batch.AccuracyWarning")  # asserted below
def test_gamma_1e6_completes_with_the_step_it_needs_and_1e9_is_refused_naming_gamma():
    sc = _gamma(1e6, T=3.0)
    r, = simulate_batch([sc])
    assert r.complete and r.substeps > 1000 and "not vouched" in r.message
    finer, = simulate_batch([sc], substeps=min(2 * r.substeps, MAX_SUBSTEPS))
    assert finer.substeps > r.substeps
    assert np.abs(r.theta_hat - finer.theta_hat).max() < 1e-3 * np.abs(finer.theta_hat).max()
    with pytest.raises(ValidationError, match="gamma"):
        simulate_batch([_gamma(1e9, T=3.0)])


@pytest.mark.parametrize("backend", ["compiled", "plain"])
def test_a_runaway_robot_is_never_reported_complete_by_the_batch_engine(backend):
    sc = Scenario(robot=UNSTABLE, limits=NO_LIMITS, T=6.0, adapt_from=0.0, name="runaway")
    r, = simulate_batch([sc], backend=backend)
    assert not r.complete and "runaway" in r.message and "t = " in r.message
    assert all(v is None for v in r.metrics.values())
    assert 0 < len(r.t) < 61 and np.isfinite(r.pose).all()


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


def test_an_update_that_never_runs_sets_no_step():
    """adapt_from >= T: the run is compensation with theta_hat0, and its step that of
    the compensated loop (it was the update law's, 160 steps per sample at k = 35)."""
    never = Scenario.paper(4, kx=35.0, ky=35.0, T=50.0)
    assert stable_substeps(never, 10) == stable_substeps(never.replace(case="compensated"), 10)
    assert stable_substeps(never.replace(adapt_from=0.0), 10) > 100
    assert "update law" in fastest_rate(never.replace(adapt_from=49.9))[1]
    # at adapt_from = T the update runs at the last step's end (t >= adapt_from - SWITCH_TOL)
    assert "update law" in fastest_rate(never.replace(adapt_from=50.0))[1]


@pytest.mark.parametrize("field, value", [("kx", 1e300), ("trajectory", {"type": "circle",
                                                                        "radius": 1.0,
                                                                        "omega": 1e10})])
def test_a_refused_update_law_names_what_its_regressor_grows_with(field, value):
    sc = Scenario.paper(4, adapt_from=0.0, **{field: value})
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no overflow warning on the way
        with pytest.raises(ValidationError, match="update law") as err:
            stable_substeps(sc, 10)
    msg = str(err.value)
    assert "kx, ky = 1e+300" in msg if field == "kx" else "speed 1e+10 m/s" in msg
