"""Stiff and fast robots: the Khepera III and a robot ten times faster, in every engine."""

import numpy as np
import pytest

import unidyn
from unidyn import RobotParameters
from unidyn.engine.batch import simulate_batch
from unidyn.model.scenario import Scenario

pytestmark = pytest.mark.reliability

KHEPERA = unidyn.model.robots.get("khepera3")
t = KHEPERA.theta
# ten times faster: both time constants (theta1, theta2, and the coupling terms) / 10
FAST = RobotParameters(t[0] / 10, t[1] / 10, t[2] / 10, t[3], t[4] / 10, t[5], name="khepera3_x10")
ROBOTS = [KHEPERA, FAST]
# the diagram on the ten-times-faster robot takes 10-45 s a run (rtol 1e-10 on a
# 2.3 ms time constant): the whole-system tier (pytest -m slow) runs those
DIAGRAM_ROBOTS = [KHEPERA, pytest.param(FAST, marks=pytest.mark.slow, id=FAST.name)]


@pytest.mark.parametrize("robot", ROBOTS, ids=lambda r: r.name)
def test_the_batch_engine_shortens_its_steps_for_a_fast_robot_unasked(robot):
    """No time constant is looked up: the error control takes the steps the robot needs,
    more for the faster one, and the run is complete."""
    sc = Scenario.paper(2, robot=robot, T=2.0, noise=None)
    r = simulate_batch([sc], rtol=1e-8, atol=1e-10)[0]
    slow = simulate_batch([sc.replace(robot="p3dx_laser")], rtol=1e-8, atol=1e-10)[0]
    assert r.complete and r.steps > 2 * slow.steps


@pytest.mark.parametrize("robot", DIAGRAM_ROBOTS, ids=lambda r: r.name)
@pytest.mark.parametrize("n", [2, pytest.param(3, marks=pytest.mark.slow),
                               pytest.param(4, marks=pytest.mark.slow)])
def test_fast_robots_agree_between_the_diagram_and_the_batch_engine(robot, n):
    sc = Scenario.paper(n, robot=robot, T=10.0, adapt_from=2.0, noise=None,
                        limits=unidyn.Limits(speed_max=0.5, steer_max=3.0))
    rd = unidyn.simulate(sc, rtol=1e-10, atol=1e-12)
    rb = simulate_batch([sc])[0]  # at the defaults: the steps are the engine's choice
    assert rd.complete and rb.complete and not rb.sensitive
    assert np.all(np.isfinite(rb.pose)) and np.all(np.isfinite(rd.pose))
    for k in ("iae", "ise", "itae", "itse", "energy"):  # within twice the engine's estimate
        assert abs(rb.metrics[k] - rd.metrics[k]) <= 2 * rb.numerical_error[k] * rd.metrics[k]
    assert np.max(np.abs(rb.pose[:, :2] - rd.pose[:, :2])) < 1e-4
    tight = simulate_batch([sc], rtol=1e-11, atol=1e-13)[0]
    assert np.max(np.abs(tight.pose[:, :2] - rd.pose[:, :2])) < 1e-8


@pytest.mark.slow
@pytest.mark.parametrize("robot", DIAGRAM_ROBOTS, ids=lambda r: r.name)
def test_fast_robots_follow_the_kinematic_design_with_exact_compensation(robot):
    # a fast robot with exact compensation behaves like an ideal one: with no
    # limits the position error follows sinh(k e/l) = sinh(k e0/l) exp(-k t)
    k, l = 0.5, 0.1
    sc = Scenario(case="compensated", robot=robot, limits=unidyn.NO_LIMITS, noise=None,
                  kx=k, ky=k, T=15.0)
    r = unidyn.simulate(sc, rtol=1e-10, atol=1e-12)
    e = r.reference - r.pose[:, :2]
    i0 = int(round(5.0 / sc.Ts))
    tt = r.t[i0:] - r.t[i0]
    for i in range(2):
        analytic = l / k * np.arcsinh(np.sinh(k * e[i0, i] / l) * np.exp(-k * tt))
        assert np.max(np.abs(e[i0:, i] - analytic)) < 1e-6


@pytest.mark.slow
@pytest.mark.parametrize("robot", DIAGRAM_ROBOTS, ids=lambda r: r.name)
@pytest.mark.parametrize("case", ["uncompensated", "compensated", "adaptive"])
def test_fast_robots_under_sampled_control_are_integrated_exactly_between_ticks(robot, case):
    # A 10 Hz digital controller on a robot whose time constant is 23 ms (or
    # 2.3 ms). Between ticks the command is held, so the robot's velocities must
    # follow Eq. (2) from the logged state under that constant command: check
    # every interval against an independent solve_ivp of Eq. (2) (DOP853, an explicit
    # method of order 8: the diagram integrates with RK45), 20 intervals before the
    # adaptation starts and 40 after.
    from scipy.integrate import solve_ivp
    sc = Scenario(case=case, control="sampled", robot=robot, T=6.0, adapt_from=2.0,
                  noise=None, limits=unidyn.Limits(speed_max=0.5, steer_max=3.0))
    r = unidyn.simulate(sc, rtol=1e-10, atol=1e-12)
    assert r.complete and np.all(np.isfinite(r.pose)) and np.all(np.isfinite(r.theta_hat))
    th = robot.theta
    lim = np.array([0.5, 3.0])
    worst = 0.0
    for k in range(1, len(r.t) - 1):   # v_ref logged at t_{k+1} is the value held over (t_k, t_{k+1})
        cmd = np.clip(r.v_ref[k + 1], -lim, lim)

        def f(t, v, cmd=cmd):
            du = (th[2] * v[1] ** 2 - th[3] * v[0] + cmd[0]) / th[0]
            dw = (-th[4] * v[0] * v[1] - th[5] * v[1] + cmd[1]) / th[1]
            return [du, dw]
        sol = solve_ivp(f, (0.0, sc.Ts), r.velocity[k], method="DOP853", rtol=1e-12, atol=1e-13)
        worst = max(worst, np.max(np.abs(sol.y[:, -1] - r.velocity[k + 1])))
    assert worst < 1e-7
