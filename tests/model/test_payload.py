"""A load that changes during a run: the loaded robot's theta against Section 2's
expressions, the schedule's validation, and both engines on a load picked up mid-run."""

import numpy as np
import pytest

from unidyn import Scenario, ValidationError
from unidyn.model import equations as eq
from unidyn.model.parameters import PAYLOAD_STEPS, RobotParameters, payload_schedule

#: A Pioneer-like robot in physical units (Section 2's symbols), the rotors' inertia
#: and the servos' derivative gains zero: the case in which theta1 and theta2 are
#: proportional to the mass when I_z scales with it.
PHYSICAL = dict(Iz=0.3, Ra=0.7, ka=0.02, kb=0.02, Be=0.001, Ie=0.0, r=0.095, b=0.04,
                d=0.33, kPT=3.0, kPR=4.0)


def _flat(rows):
    return tuple(v for row in rows for v in row)


@pytest.mark.parametrize("mu", [0.5, 1.0, 1.8, 3.0])
def test_loaded_theta_is_section2_theta_of_the_heavier_robot(mu):
    """From the load's time on, the engines' theta is Section 2's theta of the robot
    with mass and inertia mu times the empty robot's (Ie = kDT = kDR = 0); before it,
    the empty robot's."""
    m = 9.0
    empty = RobotParameters.from_physical(m=m, **PHYSICAL)
    loaded = RobotParameters.from_physical(m=mu * m, **{**PHYSICAL, "Iz": mu * PHYSICAL["Iz"]})
    steps = _flat(payload_schedule([[12.0, mu]]))
    before = eq.payload_theta(11.9, *empty.theta, steps)
    after = eq.payload_theta(12.0, *empty.theta, steps)
    np.testing.assert_allclose(before, empty.theta, rtol=1e-15)
    np.testing.assert_allclose(after, loaded.theta, rtol=1e-12)
    np.testing.assert_allclose(empty.with_mass(mu).theta, loaded.theta, rtol=1e-12)


def test_rotor_inertia_keeps_theta1_from_scaling_exactly():
    """With rotor inertia Ie > 0 theta1 grows less than the mass (the approximation
    the payload makes): theta3 and theta5 still scale exactly, theta4 and theta6 not at
    all."""
    args = {**PHYSICAL, "Ie": 0.005}
    empty = RobotParameters.from_physical(m=9.0, **args)
    heavy = RobotParameters.from_physical(m=18.0, **{**args, "Iz": 2 * args["Iz"]})
    ratio = heavy.theta / empty.theta
    assert 1.0 < ratio[0] < 2.0 and 1.0 < ratio[1] < 2.0
    np.testing.assert_allclose(ratio[[2, 4]], 2.0, rtol=1e-12)
    np.testing.assert_allclose(ratio[[3, 5]], 1.0, rtol=1e-12)


def test_mass_scale_steps_on_arrays_and_floats():
    steps = _flat(payload_schedule([[5.0, 2.0], [10.0, 0.5]]))
    t = np.array([0.0, 4.999, 5.0, 9.0, 10.0, 100.0])
    np.testing.assert_array_equal(eq.mass_scale(t, steps), [1, 1, 2, 2, 0.5, 0.5])
    assert eq.mass_scale(7.0, steps) == 2.0
    assert eq.mass_scale(7.0, ()) == 1.0


def test_scenario_theta_at_is_the_loaded_robots_theta_from_each_row_on():
    sc = Scenario.paper(4, payload=[[5.0, 2.0], [10.0, 0.5]])
    th = np.asarray(sc.robot.theta)
    t = np.array([0.0, 4.999, 5.0, 9.0, 10.0, 100.0])
    got = sc.theta_at(t)
    assert got.shape == (6, 6)
    scale = np.array([1, 1, 2, 2, 0.5, 0.5])
    for i in range(6):  # theta1, 2, 3, 5 carry the mass (Section 2); theta4, 6 do not
        want = th[i] * (scale if i in (0, 1, 2, 4) else 1.0)
        np.testing.assert_allclose(got[:, i], want, rtol=1e-15)
    np.testing.assert_allclose(sc.theta_at(7.0), got[3], rtol=0)
    np.testing.assert_allclose(Scenario.paper(4).theta_at(t), np.tile(th, (6, 1)), rtol=0)
    with pytest.raises(ValidationError, match="^t must be a time in s"):
        sc.theta_at("later")


def test_schedule_forms():
    assert payload_schedule(None) == () == payload_schedule([])
    assert payload_schedule(2) == ((0.0, 2.0),)
    assert payload_schedule(np.array([[1, 2], [3, 4]])) == ((1.0, 2.0), (3.0, 4.0))


@pytest.mark.parametrize("value, words", [
    ([[5.0, 2.0], [3.0, 1.0]], "times increase; row 1"),
    ([[5.0, 2.0], [5.0, 1.0]], "times increase; row 1"),
    ([[5.0, 0.0]], r"payload\[0\] mass scale must be > 0"),
    ([[5.0, -2.0]], r"payload\[0\] mass scale must be > 0"),
    ([[-1.0, 2.0]], r"payload\[0\] t must be >= 0"),
    ([[5.0, float("nan")]], r"payload\[0\] mass scale"),
    ([[5.0, float("inf")]], r"payload\[0\] mass scale"),
    ([[float(k), 1.5] for k in range(PAYLOAD_STEPS + 1)], f"at most {PAYLOAD_STEPS} rows"),
    ([[5.0, 2.0, 1.0]], r"rows \(t >= 0"),
    ("heavy", "payload must be a mass scale"),
    (True, "payload must be a mass scale"),
    (0.0, "payload must be > 0"),
])
def test_bad_schedules_get_one_clear_line(value, words):
    with pytest.raises(ValidationError, match=words) as err:
        Scenario(payload=value)
    assert "\n" not in str(err.value) and "payload" in str(err.value)


def test_a_payload_after_the_run_ends_is_refused_naming_the_field():
    with pytest.raises(ValidationError) as err:
        Scenario.paper(4, T=2.0, payload=[[100.0, 2.0]])
    assert str(err.value) == ("payload: a row at t = 100 s is after the run's end, T = 2 s; "
                              "every row's time must be within [0, T]")
    assert Scenario.paper(4, T=2.0, payload=[[0.0, 2.0], [2.0, 1.0]]).payload[-1] == (2.0, 1.0)
    with pytest.raises(ValidationError, match=r"t = 150 s is after the run's end, T = 120 s"):
        Scenario.paper(4, payload=[[100, 2.5], [150, 1]]).replace(T=120.0)


def test_scenario_keeps_the_schedule_through_its_dict():
    sc = Scenario.paper(4, payload=[[100, 2.5], [150, 1]])
    assert sc.payload == ((100.0, 2.5), (150.0, 1.0))
    data = sc.to_dict()
    assert data["payload"] == [[100.0, 2.5], [150.0, 1.0]]
    assert Scenario.from_dict(data) == sc
    # the compensators' estimates are the empty robot's (exact) and theta/1.5 (adaptive)
    np.testing.assert_array_equal(Scenario.paper(3, payload=2.0).theta_hat_initial,
                                  Scenario.paper(3).robot.theta)


def test_table_holds_the_schedule_and_unused_rows_never_apply():
    from unidyn.model.closed_loop import ClosedLoop
    sc = Scenario.paper(2, T=1.0, payload=[[0.5, 2.0]], noise=None)
    p = ClosedLoop([sc]).P[0]
    steps = p[eq.P.payload_time1:eq.P.payload_time1 + 2 * PAYLOAD_STEPS]
    assert tuple(steps[:2]) == (0.5, 2.0)
    assert np.all(np.isinf(steps[2::2])) and np.all(steps[3::2] == 1.0)
    assert eq.mass_scale(1e12, steps) == 2.0


def test_the_loop_sees_the_loaded_robot():
    """The loop's acceleration of (u, w) after the load is Eq. (2) with the loaded
    theta (an independent evaluation of Eq. 2), and before it the empty robot's."""
    from unidyn.model import unicycle
    from unidyn.model.closed_loop import ClosedLoop
    sc = Scenario.paper(2, T=1.0, payload=[[0.5, 2.5]], noise=None, limits=unicycle.NO_LIMITS)
    loop = ClosedLoop([sc])
    X = loop.initial_state()
    X[0, 3:5] = (0.3, 0.4)
    for t, mu in ((0.2, 1.0), (0.7, 2.5)):
        d = loop.rhs(t, X, 0)[0]
        ud, wd = eq.kinematic_control_components(*loop.reference(t)[:4], *X[0, :3], sc.a,
                                                 sc.kx, sc.ky, sc.lx, sc.ly)
        th = sc.robot.with_mass(mu).theta
        du = (th[2] * 0.4 ** 2 - th[3] * 0.3 + ud[0]) / th[0]
        dw = (-th[4] * 0.3 * 0.4 - th[5] * 0.4 + wd[0]) / th[1]
        np.testing.assert_allclose(d[3:5], [du, dw], rtol=1e-12)


@pytest.mark.parametrize("payload", [[[6.0, 2.5]], [[6.037, 2.5], [9.0, 0.7]]])
def test_both_engines_agree_on_a_load_picked_up_mid_run(payload):
    """The diagram (DYNAMICUNICYCLE with the schedule) and the batch engine, with noise,
    a load of 2.5 times the mass at 6 s (on a sample; or between samples, and set down
    to 0.7 times the mass at 9 s) and adaptation from 3 s: the same IAE."""
    from unidyn import simulate, simulate_batch
    sc = Scenario.paper(4, T=12.0, adapt_from=3.0, payload=payload)
    rd = simulate(sc)
    rb, = simulate_batch([sc], progress=False)
    empty, = simulate_batch([sc.replace(payload=())], progress=False)
    assert rd.complete and rb.complete
    assert abs(rd.metrics["iae"] - rb.metrics["iae"]) <= 1e-5 * rb.metrics["iae"]
    np.testing.assert_allclose(rd.pose, rb.pose, atol=1e-5)
    np.testing.assert_allclose(rd.theta_hat, rb.theta_hat, atol=1e-5)
    # the load changes the motion from 6 s on, not before
    k = int(round(6.0 / sc.Ts))
    np.testing.assert_allclose(rb.pose[:k + 1], empty.pose[:k + 1], atol=1e-6)  # their estimates
    assert np.abs(rb.pose[k + 10:] - empty.pose[k + 10:]).max() > 1e-3


def test_block_takes_the_schedule():
    """DYNAMICUNICYCLE's state derivative is Eq. (2) of the empty robot before the load
    and of the loaded robot after it (the model's own unicycle_deriv, given each theta)."""
    from unidyn.blocks import DynamicUnicycle
    from unidyn.model import robots, unicycle
    empty = robots.get("p3dx_laser")
    block = DynamicUnicycle(robot=empty, a=0.2, payload=[[1.0, 2.0]])
    x = np.array([0.1, 0.2, 0.3, 0.25, 0.4])
    v_ref = [0.35, -0.2]
    for t, theta in ((0.5, empty.theta), (1.5, empty.with_mass(2.0).theta)):
        got = block.deriv(t, [v_ref[0], v_ref[1]], x)
        want = unicycle.unicycle_deriv(x, np.array(v_ref), theta, 0.2, block.limits, None)
        np.testing.assert_allclose(got, want, rtol=1e-14)
    assert block.arguments["payload"] == [[1.0, 2.0]]
    with pytest.raises(ValidationError, match="payload: a schedule's times increase"):
        DynamicUnicycle(payload=[[2.0, 2.0], [1.0, 1.0]])
