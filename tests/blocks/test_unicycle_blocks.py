"""The robot blocks in bdsim diagrams, against analytic solutions, an independent
solve_ivp integration of Eqs. (1)-(2), and roboticstoolbox's kinematic UNICYCLE.

All runs use tight solver tolerances (rtol 1e-10, atol 1e-12) so that the
comparison tolerances below (1e-7 and 1e-6) measure the model, not the solver.
"""

from __future__ import annotations

import math
import re

import bdsim
import numpy as np
import pytest
from scipy.integrate import solve_ivp

from unidyn import Limits, ValidationError
from unidyn.blocks import DynamicUnicycle, KinematicUnicycle
from unidyn.model import robots

RTOL, ATOL = 1e-10, 1e-12
TOL = 1e-7   # for analytic comparisons, well above the solver's error
DT = 0.05
SOLVER_SLACK = 1e-7  # overshoot of a speed limit allowed to the solver at the kink


@pytest.fixture(scope="module")
def sim():
    return bdsim.BDSim(graphics=False, progress=False, banner=False, sysargs=False, quiet=True)


def run(sim, bd, T, watch, rtol=RTOL, max_step=DT):
    bd.compile()
    return sim.run(bd, T=T, dt=DT, watch=watch,
                   solver_args=dict(rtol=rtol, atol=ATOL, max_step=max_step))


def fn_of_time(bd, f):
    """A FUNCTION block computing f(t) from a TIME block."""
    clk = bd.TIME()
    blk = bd.FUNCTION(f, nin=1, nout=1)
    bd.connect(clk, blk)
    return blk


# ---------------------------------------------------------------------------
# analytic responses of Eq. (2)
# ---------------------------------------------------------------------------

@pytest.mark.parametrize("robot", ["p3dx_laser", "robulab10"])
def test_linear_step_response(sim, robot):
    th = robots.get(robot)
    u_ref = 0.35
    bd = sim.blockdiagram()
    veh = bd.DYNAMICUNICYCLE(robot, velocity_output=True, x0=[0.5, -0.2, 0.0])
    bd.connect(bd.CONSTANT(u_ref), veh.v)
    bd.connect(bd.CONSTANT(0.0), veh[1])
    T = 3.0
    out = run(sim, bd, T, [veh[0], veh[1]])
    t = out.t
    assert t[-1] == pytest.approx(T)
    tau = th.theta1 / th.theta4
    u = u_ref / th.theta4 * (1 - np.exp(-t / tau))
    x = 0.5 + u_ref / th.theta4 * (t - tau * (1 - np.exp(-t / tau)))
    np.testing.assert_allclose(out.x[:, 3], u, atol=TOL, rtol=0)
    np.testing.assert_allclose(out.x[:, 4], 0.0, atol=TOL)
    np.testing.assert_allclose(out.x[:, 0], x, atol=TOL, rtol=0)
    np.testing.assert_allclose(out.x[:, 1], -0.2, atol=TOL)
    # the watched outputs are the states: q on port 0, (u, w) on port 1
    np.testing.assert_allclose(out.y[:, :3], out.x[:, :3], atol=0)
    np.testing.assert_allclose(out.y[:, 3:5], out.x[:, 3:5], atol=0)


def test_angular_step_response_and_point_of_interest_circle(sim):
    # theta3 = 0 and u_ref = 0 keep u = 0; w is then first order
    th = np.array([0.2604, 0.2509, 0.0, 0.9965, 0.00263, 1.0768])
    a, w_ref = 0.2, 0.6
    bd = sim.blockdiagram()
    # axle centre at the origin, heading 0: h starts at (a, 0)
    veh = bd.DYNAMICUNICYCLE(th, velocity_output=True, a=a, x0=[a, 0.0, 0.0])
    bd.connect(bd.CONSTANT(0.0), veh.v)
    bd.connect(bd.CONSTANT(w_ref), veh[1])
    out = run(sim, bd, 4.0, [veh[0]])
    t = out.t
    tau = th[1] / th[5]
    w = w_ref / th[5] * (1 - np.exp(-t / tau))
    psi = w_ref / th[5] * (t - tau * (1 - np.exp(-t / tau)))
    np.testing.assert_allclose(out.x[:, 3], 0.0, atol=TOL)
    np.testing.assert_allclose(out.x[:, 4], w, atol=TOL, rtol=0)
    np.testing.assert_allclose(out.x[:, 2], psi, atol=TOL, rtol=0)
    # the robot turns on the spot: h circles the fixed axle centre at radius a
    np.testing.assert_allclose(out.y[:, 0], a * np.cos(psi), atol=TOL)
    np.testing.assert_allclose(out.y[:, 1], a * np.sin(psi), atol=TOL)
    assert psi[-1] > 1.5  # it really turned


def test_x0_three_and_five_vectors(sim):
    th = np.array([0.2604, 0.2509, 0.0, 0.9965, 0.0, 1.0768])
    bd = sim.blockdiagram()
    v3 = bd.DYNAMICUNICYCLE(th, velocity_output=True, x0=[1.0, 2.0, 0.5])
    v5 = bd.DYNAMICUNICYCLE(th, velocity_output=True, x0=[-1.0, 0.5, -0.3, 0.4, -0.7])
    for v in (v3, v5):
        bd.connect(bd.CONSTANT(0.0), v.v)
        bd.connect(bd.CONSTANT(0.0), v[1])
    out = run(sim, bd, 2.0, [v3[1], v5[1]])
    t = out.t
    # the states of both blocks are in out.x; the watched velocities in out.y
    np.testing.assert_allclose(out.y[0], [0.0, 0.0, 0.4, -0.7], atol=0)
    # 3-vector: the robot starts and stays at rest
    np.testing.assert_allclose(out.y[:, 0:2], 0.0, atol=TOL)
    # 5-vector: free decay of u and w (decoupled because theta3 = theta5 = 0)
    np.testing.assert_allclose(out.y[:, 2], 0.4 * np.exp(-th[3] * t / th[0]), atol=TOL)
    np.testing.assert_allclose(out.y[:, 3], -0.7 * np.exp(-th[5] * t / th[1]), atol=TOL)
    x0s = sorted([out.x[0, :5].tolist(), out.x[0, 5:].tolist()])
    assert x0s == sorted([[1.0, 2.0, 0.5, 0.0, 0.0], [-1.0, 0.5, -0.3, 0.4, -0.7]])


def test_state_names(sim):
    bd = sim.blockdiagram()
    veh = bd.DYNAMICUNICYCLE("p3dx", velocity_output=True, name="robot")
    bd.connect(bd.CONSTANT(0.1), veh.v)
    bd.connect(bd.CONSTANT(0.1), veh[1])
    out = run(sim, bd, 0.2, [])
    assert list(out.xnames) == ["robot:x", "robot:y", "robot:psi", "robot:u", "robot:w"]
    assert out.x.shape[1] == 5


# ---------------------------------------------------------------------------
# against an independent integration of Eqs. (1)-(2)
# ---------------------------------------------------------------------------

def u_cmd(t):
    return 0.4 + 0.2 * math.sin(t)


def w_cmd(t):
    return 0.5 * math.sin(0.7 * t) + 0.1


def test_pose_is_point_of_interest_and_matches_solve_ivp(sim):
    robot = "p3dx"   # theta3, theta5 both nonzero: the coupling terms matter
    t1, t2, t3, t4, t5, t6 = robots.get(robot).theta
    a = 0.2
    x0 = np.array([0.3, -0.4, 0.8, 0.1, -0.2])
    T = 8.0
    bd = sim.blockdiagram()
    veh = bd.DYNAMICUNICYCLE(robot, velocity_output=True, a=a, x0=x0)
    bd.connect(fn_of_time(bd, u_cmd), veh.v)
    bd.connect(fn_of_time(bd, w_cmd), veh[1])
    out = run(sim, bd, T, [veh[0], veh[1]])

    # independent model: integrate the wheel-axle centre c, then h = c + a (cos, sin)
    def rhs(t, s):
        cx, cy, psi, u, w = s
        return [u * math.cos(psi), u * math.sin(psi), w,
                (t3 * w * w - t4 * u + u_cmd(t)) / t1,
                (-t5 * u * w - t6 * w + w_cmd(t)) / t2]

    c0 = x0[:2] - a * np.array([math.cos(x0[2]), math.sin(x0[2])])
    ref = solve_ivp(rhs, (0, T), np.r_[c0, x0[2:]], t_eval=out.t, rtol=1e-12, atol=1e-13,
                    method="DOP853")
    c, psi, v = ref.y[:2].T, ref.y[2], ref.y[3:].T
    h = c + a * np.column_stack([np.cos(psi), np.sin(psi)])
    np.testing.assert_allclose(out.y[:, 0:2], h, atol=1e-6, rtol=0)
    np.testing.assert_allclose(out.y[:, 2], psi, atol=1e-6, rtol=0)
    np.testing.assert_allclose(out.y[:, 3:5], v, atol=1e-6, rtol=0)
    # the robot went somewhere interesting
    assert np.ptp(psi) > 1.0 and np.ptp(h[:, 0]) > 1.0


@pytest.mark.slow
def test_fast_robot_tracks_toolbox_unicycle(sim):
    # theta1 = theta2 = 1 ms, unit gains, no coupling: v follows v_ref with a 1 ms lag
    fast = [1e-3, 1e-3, 0.0, 1.0, 0.0, 1.0]
    x0 = [1.0, 2.0, 0.3]
    bd = sim.blockdiagram()
    fu = fn_of_time(bd, lambda t: 0.3 + 0.1 * math.sin(0.5 * t))
    fw = fn_of_time(bd, lambda t: 0.4 * math.cos(0.3 * t))
    veh = bd.DYNAMICUNICYCLE(fast, velocity_output=True, x0=x0)
    uni = bd.UNICYCLE(x0=x0, w=1)  # UNICYCLE's psi' is omega / w
    bd.connect(fu, veh.v, uni.v)
    bd.connect(fw, veh[1], uni[1])
    out = run(sim, bd, 10.0, [veh[0], uni[0]], rtol=1e-8)
    dyn, kin = out.y[:, :3], out.y[:, 3:]
    err = np.hypot(dyn[:, 0] - kin[:, 0], dyn[:, 1] - kin[:, 1])
    assert err.max() < 2e-3
    assert np.abs(dyn[:, 2] - kin[:, 2]).max() < 2e-3
    # and the path really curved and covered ground
    assert np.ptp(kin[:, 2]) > 1.0
    assert np.hypot(*(kin[-1, :2] - kin[0, :2])) > 1.5


# ---------------------------------------------------------------------------
# limits
# ---------------------------------------------------------------------------

def test_speed_and_acceleration_limits_hold_during_a_run(sim):
    # steady states u_ref/theta4 = 0.625 and w_ref/theta6 = -1.25 lie beyond the limits
    th = [0.26, 0.25, 0.0, 0.8, 0.0, 0.8]
    smax, wmax, amax, alpha = 0.5, 1.0, 0.3, 2.0
    bd = sim.blockdiagram()
    veh = bd.DYNAMICUNICYCLE(th, velocity_output=True, speed_max=smax, steer_max=wmax, accel_max=amax,
                             angular_accel_max=alpha)
    bd.connect(bd.CONSTANT(2.0), veh.v)    # clipped to 0.5
    bd.connect(bd.CONSTANT(-3.0), veh[1])  # clipped to -1
    out = run(sim, bd, 3.0, [veh[1]])
    t, u, w = out.t, out.y[:, 0], out.y[:, 1]
    # the solver may step a little past the kink where the limit engages (about
    # 1e-8 at rtol 1e-10); nothing pushes further, so the excess stays that small
    assert np.abs(u).max() <= smax + SOLVER_SLACK
    assert np.abs(w).max() <= wmax + SOLVER_SLACK
    assert np.abs(np.diff(u) / np.diff(t)).max() <= amax + 1e-7
    assert np.abs(np.diff(w) / np.diff(t)).max() <= alpha + 1e-7
    # the limits bind exactly as designed: u ramps at accel_max up to speed_max
    np.testing.assert_allclose(u, np.minimum(amax * t, smax), atol=1e-7)
    # w ramps at -alpha until Eq. 2's own rate drops below alpha (|w| = 0.625),
    # then relaxes towards -1.25 and stops at -steer_max
    t_a = (1.0 - alpha * th[1]) / th[5] / alpha    # |w| = 0.625 at t = 0.3125
    w_a = -alpha * t_a
    w_free = -1.25 + (w_a + 1.25) * np.exp(-th[5] * (t - t_a) / th[1])
    w_exp = np.where(t <= t_a, -alpha * t, np.maximum(w_free, -wmax))
    np.testing.assert_allclose(w, w_exp, atol=1e-7)
    assert w[-1] == pytest.approx(-wmax, abs=SOLVER_SLACK)


def test_limits_object_overrides_arguments(sim):
    bd = sim.blockdiagram()
    veh = bd.DYNAMICUNICYCLE("p3dx_laser", velocity_output=True, speed_max=10.0, limits=Limits(speed_max=0.2))
    bd.connect(bd.CONSTANT(1.0), veh.v)
    bd.connect(bd.CONSTANT(0.0), veh[1])
    out = run(sim, bd, 3.0, [veh[1]])
    assert out.y[:, 0].max() <= 0.2 + SOLVER_SLACK
    assert out.y[-1, 0] == pytest.approx(0.2, abs=SOLVER_SLACK)


# ---------------------------------------------------------------------------
# drop-in ports and the disturbance input
# ---------------------------------------------------------------------------

def test_drop_in_ports_and_toolbox_arguments(sim):
    bd = sim.blockdiagram()
    # UNICYCLE's constructor arguments are accepted
    veh = bd.DYNAMICUNICYCLE("p3dx_laser", velocity_output=True, w=0.4, speed_max=2.0, accel_max=5.0,
                             steer_max=3.0, x0=[0.0, 0.0, 0.0])
    bd.connect(bd.CONSTANT(0.3), veh.v)      # input by label
    bd.connect(bd.CONSTANT(0.0), veh[1])     # input by number
    sx = bd.INDEX([0])
    spsi = bd.INDEX([2])
    bd.connect(veh[0], sx)
    bd.connect(veh.q, spsi)                  # output by label
    out = run(sim, bd, 2.0, [sx, spsi, veh.velocity])
    th = robots.get("p3dx_laser")
    tau = th.theta1 / th.theta4
    t = out.t
    x = 0.3 / th.theta4 * (t - tau * (1 - np.exp(-t / tau)))
    np.testing.assert_allclose(out.y[:, 0], x, atol=TOL)
    np.testing.assert_allclose(out.y[:, 1], 0.0, atol=TOL)
    np.testing.assert_allclose(out.y[:, 2], 0.3 / th.theta4 * (1 - np.exp(-t / tau)), atol=TOL)
    assert veh.inlabels == ("v", "ω") and veh.outlabels[0] == "q"


def test_disturbance_on_linear_and_position_channels(sim):
    th = robots.get("p3dx_laser")
    u_ref, dx, dy, du = 0.3, 0.05, -0.02, 0.4
    bd = sim.blockdiagram()
    veh = bd.DYNAMICUNICYCLE("p3dx_laser", velocity_output=True, disturbance=True)
    ref = bd.DYNAMICUNICYCLE("p3dx_laser", velocity_output=True)
    bd.connect(bd.CONSTANT(u_ref), veh.v, ref.v)
    bd.connect(bd.CONSTANT(0.0), veh[1], ref[1])
    bd.connect(bd.CONSTANT(np.array([dx, dy, du, 0.0])), veh[2])
    out = run(sim, bd, 4.0, [veh[0], veh[1], ref[1]])
    t = out.t
    tau = th.theta1 / th.theta4
    u_ss = u_ref / th.theta4 + du * th.theta1 / th.theta4
    u = u_ss * (1 - np.exp(-t / tau))
    np.testing.assert_allclose(out.y[:, 3], u, atol=TOL)
    np.testing.assert_allclose(out.y[:, 0], u_ss * (t - tau * (1 - np.exp(-t / tau))) + dx * t,
                               atol=TOL)
    np.testing.assert_allclose(out.y[:, 1], dy * t, atol=TOL)
    np.testing.assert_allclose(out.y[:, 2], 0.0, atol=TOL)
    # the shift of the final speed against the undisturbed robot
    shift = out.y[-1, 3] - out.y[-1, 5]
    assert shift == pytest.approx(du * th.theta1 / th.theta4 * (1 - math.exp(-4.0 / tau)),
                                  abs=TOL)


def test_disturbance_on_angular_channel(sim):
    th = np.array([0.2604, 0.2509, 0.0, 0.9965, 0.00263, 1.0768])
    dw = 0.8
    bd = sim.blockdiagram()
    veh = bd.DYNAMICUNICYCLE(th, velocity_output=True, disturbance=True)
    bd.connect(bd.CONSTANT(0.0), veh.v)
    bd.connect(bd.CONSTANT(0.0), veh[1])
    bd.connect(bd.CONSTANT(np.array([0.0, 0.0, 0.0, dw])), veh.delta)
    out = run(sim, bd, 3.0, [veh[1]])
    t = out.t
    np.testing.assert_allclose(out.y[:, 0], 0.0, atol=TOL)
    np.testing.assert_allclose(out.y[:, 1], dw * th[1] / th[5] * (1 - np.exp(-th[5] * t / th[1])),
                               atol=TOL)


# ---------------------------------------------------------------------------
# constructor validation and run-time errors
# ---------------------------------------------------------------------------

@pytest.mark.parametrize("kwargs,name", [
    (dict(robot="pioneer9"), "robot"),
    (dict(robot=[0.3, 0.2, 0.0]), "robot"),
    (dict(robot=[0.3, 0.2, 0.0, -1.0, 0.0, 1.0]), "theta4"),
    (dict(a=-0.1), "a"),
    (dict(a=math.nan), "a"),
    (dict(x0=[0.0, math.nan, 0.0]), "x0"),
    (dict(x0=[0.0, 0.0, 0.0, math.inf, 0.0]), "x0"),
    (dict(x0=[0.0, 0.0]), "x0"),
    (dict(x0=[0.0, 0.0, 0.0, 0.0]), "x0"),
    (dict(speed_max=-1.0), "speed_max"),
    (dict(speed_max=0.0), "speed_max"),
    (dict(accel_max=-0.3), "accel_max"),
    (dict(steer_max=0.0), "steer_max"),
    (dict(angular_accel_max=math.nan), "angular_accel_max"),
    (dict(w=0.0), "w"),
    (dict(w=-0.5), "w"),
    (dict(disturbance="yes"), "disturbance"),
    (dict(limits={"speed_max": 1.0}), "limits"),
])
def test_dynamic_unicycle_rejects_bad_arguments(sim, kwargs, name):
    bd = sim.blockdiagram()
    with pytest.raises(ValidationError, match=rf"\b{name}\b"):
        DynamicUnicycle(bd=bd, **kwargs)


@pytest.mark.parametrize("kwargs,name", [
    (dict(a=-1.0), "a"),
    (dict(x0=[0.0, math.nan, 0.0]), "x0"),
    (dict(x0=[1.0]), "x0"),
    (dict(speed_max=-1.0), "speed_max"),
    (dict(steer_max=0.0), "steer_max"),
])
def test_kinematic_unicycle_rejects_bad_arguments(sim, kwargs, name):
    bd = sim.blockdiagram()
    with pytest.raises(ValidationError, match=rf"\b{name}\b"):
        KinematicUnicycle(bd=bd, **kwargs)


@pytest.mark.parametrize("cls", [DynamicUnicycle, KinematicUnicycle])
def test_misspelt_keyword_fails_loudly(sim, cls):
    bd = sim.blockdiagram()
    with pytest.raises((TypeError, ValueError), match="speed_mx"):
        cls(bd=bd, speed_mx=1.0)


def _chain(exc):
    seen = []
    while exc is not None and exc not in seen:
        seen.append(exc)
        exc = exc.__cause__ or exc.__context__
    return seen


@pytest.mark.parametrize("port", [0, 1, 2])
def test_nan_command_stops_the_run_naming_block_and_time(sim, port):
    bd = sim.blockdiagram()
    veh = bd.DYNAMICUNICYCLE("p3dx_laser", velocity_output=True, name="robby", disturbance=(port == 2))
    if port == 2:
        bad = fn_of_time(bd, lambda t: np.array([0.0, 0.0, math.nan if t > 0.7 else 0.1, 0.0]))
        bd.connect(bad, veh[2])
        bd.connect(bd.CONSTANT(0.1), veh[0])
        bd.connect(bd.CONSTANT(0.1), veh[1])
    else:
        bad = fn_of_time(bd, lambda t: math.nan if t > 0.7 else 0.2)
        bd.connect(bad, veh[port])
        bd.connect(bd.CONSTANT(0.1), veh[1 - port])
    with pytest.raises(Exception) as info:
        run(sim, bd, 2.0, [])
    # bdsim wraps the block's error; the original is in the exception chain
    found = [e for e in _chain(info.value) if isinstance(e, FloatingPointError)]
    assert found, f"no FloatingPointError in the chain of {info.value!r}"
    msg = str(found[0])
    assert "'robby'" in msg
    assert ("'v'", "'ω'", "'delta'")[port] in msg
    m = re.search(r"t = ([0-9.eE+-]+) s", msg)
    assert m, msg
    assert 0.7 < float(m.group(1)) <= 0.7 + 2 * DT


# ---------------------------------------------------------------------------
# KinematicUnicycle
# ---------------------------------------------------------------------------

@pytest.mark.parametrize("a", [0.0, 0.25])
def test_kinematic_unicycle_constant_commands_circle(sim, a):
    u, w = 0.3, 0.5
    psi0 = 0.4
    h0 = np.array([1.0, -1.0])
    bd = sim.blockdiagram()
    veh = bd.KINEMATICUNICYCLE(a=a, x0=[h0[0], h0[1], psi0])
    bd.connect(bd.CONSTANT(u), veh.v)
    bd.connect(bd.CONSTANT(w), veh[1])
    out = run(sim, bd, 6.0, [veh[0]])
    t = out.t
    psi = psi0 + w * t
    c0 = h0 - a * np.array([math.cos(psi0), math.sin(psi0)])
    R = u / w
    cx = c0[0] + R * (np.sin(psi) - math.sin(psi0))
    cy = c0[1] - R * (np.cos(psi) - math.cos(psi0))
    np.testing.assert_allclose(out.y[:, 2], psi, atol=TOL)
    np.testing.assert_allclose(out.y[:, 0], cx + a * np.cos(psi), atol=TOL)
    np.testing.assert_allclose(out.y[:, 1], cy + a * np.sin(psi), atol=TOL)
    # radius of the circle of h about the turning centre: sqrt(R^2 + a^2)
    centre = c0 + R * np.array([-math.sin(psi0), math.cos(psi0)])
    np.testing.assert_allclose(np.hypot(out.y[:, 0] - centre[0], out.y[:, 1] - centre[1]),
                               math.hypot(R, a), atol=TOL)


def test_kinematic_unicycle_speed_limits(sim):
    bd = sim.blockdiagram()
    veh = bd.KINEMATICUNICYCLE(speed_max=0.2, steer_max=0.4)
    bd.connect(bd.CONSTANT(0.5), veh.v)
    bd.connect(bd.CONSTANT(-2.0), veh[1])
    out = run(sim, bd, 5.0, [veh[0]])
    t = out.t
    psi = -0.4 * t
    np.testing.assert_allclose(out.y[:, 2], psi, atol=TOL)
    R = 0.2 / -0.4   # clipped commands: u = 0.2, w = -0.4 (clockwise circle)
    np.testing.assert_allclose(out.y[:, 0], R * np.sin(psi), atol=TOL)
    np.testing.assert_allclose(out.y[:, 1], -R * (np.cos(psi) - 1), atol=TOL)


def test_kinematic_and_dynamic_blocks_swap(sim):
    # the same diagram with either robot block; the fast dynamic robot follows the
    # kinematic one, including the point of interest ahead of the axle
    fast = [1e-3, 1e-3, 0.0, 1.0, 0.0, 1.0]
    bd = sim.blockdiagram()
    kin = bd.KINEMATICUNICYCLE(a=0.2, x0=[0.2, 0.0, 0.0])
    dyn = bd.DYNAMICUNICYCLE(fast, velocity_output=True, a=0.2, x0=[0.2, 0.0, 0.0])
    bd.connect(bd.CONSTANT(0.3), kin.v, dyn.v)
    bd.connect(fn_of_time(bd, lambda t: 0.6 * math.sin(0.8 * t)), kin[1], dyn[1])
    out = run(sim, bd, 6.0, [kin[0], dyn[0]], rtol=1e-8)
    np.testing.assert_allclose(out.y[:, :3], out.y[:, 3:], atol=2e-3)
    assert np.ptp(out.y[:, 2]) > 0.5


def test_speed_limits_hold_exactly_at_bdsims_default_tolerances(sim):
    """Driven into both speed limits (u_ref = 5 m/s, w_ref = -3 rad/s) with bdsim's own
    solver settings: the state steps past a limit by up to the solver's tolerance, the
    velocity output never does, and it reaches each limit; a run at tight tolerances
    agrees with it to that tolerance."""
    def drive(solver_args):
        bd = sim.blockdiagram()
        veh = bd.DYNAMICUNICYCLE("p3dx", speed_max=1.0, steer_max=0.5, velocity_output=True)
        bd.connect(bd.CONSTANT(5.0), veh.v)
        bd.connect(bd.CONSTANT(-3.0), veh[1])
        bd.connect(veh.q, bd.NULL())
        bd.connect(veh.velocity, bd.NULL())
        bd.compile(verbose=False)
        out = sim.run(bd, T=8.0, dt=DT, watch=[veh.velocity], **solver_args)
        return np.asarray(out[".ywatch"][0], dtype=float).reshape(len(out.t), 2), out.x

    v, x = drive({})
    assert np.abs(v[:, 0]).max() == 1.0 and np.abs(v[:, 1]).max() == 0.5
    assert np.all(np.abs(x[:, 3:5]) >= np.abs(v))   # clipping only ever moves towards the limit
    v_tight, _ = drive(dict(solver_args=dict(rtol=RTOL, atol=ATOL, max_step=DT)))
    np.testing.assert_allclose(v, v_tight, rtol=0, atol=3e-3)
