"""Identification from bags as ros2_control robots record them (ROS 2 Jazzy).

A diff_drive_controller in the namespace /diff_drive_controller takes TwistStamped
commands on .../cmd_vel, publishes the command it applied on .../cmd_vel_out and
odometry on .../odom; joint_state_broadcaster publishes the wheel speeds on
/joint_states. The robot (none of the presets) is Eq. (2) integrated here by
scipy's solve_ivp (DOP853) with each command held from its stamp, independent of
the estimator's compiled RK4; the bags are written with rosbags' MCAP writer in
receive order, as ``ros2 bag record`` writes them.
"""

from __future__ import annotations

import functools

import numpy as np
import pytest

pytest.importorskip("rosbags")

from rosbags.rosbag2 import StoragePlugin, Writer  # noqa: E402
from rosbags.typesys import Stores, get_typestore  # noqa: E402

from unidyn import RobotParameters, ValidationError  # noqa: E402
from unidyn import identification as ident  # noqa: E402

ROBOT = RobotParameters(0.42, 0.27, 0.012, 1.05, 0.035, 1.08, name="courier")
EPOCH = 1_700_000_000          # s: the wall clock at the start of the recording
R_WHEEL, SEPARATION = 0.08, 0.42
NS = "/diff_drive_controller"
POSITIVE = [0, 1, 3, 5]


def held(theta, t_cmd, uc, wc, t_out):
    """(u, w) of Eq. (2) at t_out from rest, commands held from t_cmd: solve_ivp."""
    from scipy.integrate import solve_ivp
    t1, t2, t3, t4, t5, t6 = theta
    out, v = np.empty((t_out.size, 2)), np.zeros(2)
    ends = np.append(t_cmd[1:], t_out[-1] + 1.0)
    for j, (a, b) in enumerate(zip(t_cmd, ends)):
        sel = np.flatnonzero((t_out >= a) & (t_out < b))

        def rhs(_, x, cu=uc[j], cw=wc[j]):
            return [(t3 * x[1] ** 2 - t4 * x[0] + cu) / t1,
                    (-t5 * x[0] * x[1] - t6 * x[1] + cw) / t2]
        sol = solve_ivp(rhs, (a, b), v, method="DOP853", rtol=1e-10, atol=1e-12,
                        t_eval=np.append(t_out[sel], b))
        out[sel] = sol.y[:, :-1].T
        v = sol.y[:, -1]
    return out


@functools.lru_cache(maxsize=None)
def robot_run(seed=3, T=60.0, cmd_hz=10.0, odom_hz=50.0, noise=0.005):
    """(commands: t, u, w; odometry: t, u, w, heading) of the robot."""
    rng = np.random.default_rng(seed)
    exc = ident.excitation(T, 1.0 / cmd_hz, robot=ROBOT, seed=seed)
    t_cmd = exc["t"] + rng.uniform(0.0, 0.01, exc["t"].size)
    t_cmd[0] = 0.0
    t_odom = np.arange(0.011, t_cmd[-1], 1.0 / odom_hz)
    v = held(ROBOT.theta, t_cmd, exc["u_ref"], exc["w_ref"], t_odom)
    psi = np.concatenate([[0.0], np.cumsum(v[:-1, 1] * np.diff(t_odom))])
    v = v + noise * rng.standard_normal(v.shape)
    return (t_cmd, exc["u_ref"], exc["w_ref"]), (t_odom, v[:, 0], v[:, 1], psi)


def write(path, run, odom="measured", world=False, odom_clock=0.0, joints=False,
          cmd_out=True, unstamped_lag=None, heading=True, zero_stamps=False):
    """Write the run as a ros2_control robot records it. ``odom``: "measured" or
    "open-loop" (the commands themselves, as open_loop: true publishes); ``world``:
    the twist in the odom frame (child_frame_id "odom"); ``odom_clock``: the
    odometry stamped on a clock this many s behind (simulation time from 0 when
    EPOCH); ``joints``: /joint_states with the wheel speeds instead of odometry;
    ``unstamped_lag``: the commands as Twist on /cmd_vel only, received this many s
    (one per command) after the robot applied them; ``heading`` False: the pose's
    orientation left at identity; ``zero_stamps``: TwistStamped commands whose
    stamps are left at zero, as some teleop nodes send them."""
    (tc, uc, wc), (to, uo, wo, psi) = run
    ts = get_typestore(Stores.ROS2_JAZZY)
    T = ts.types
    Time, Header, V3 = (T[k] for k in ("builtin_interfaces/msg/Time", "std_msgs/msg/Header",
                                       "geometry_msgs/msg/Vector3"))
    Twist, TwistS = T["geometry_msgs/msg/Twist"], T["geometry_msgs/msg/TwistStamped"]
    Odom, JS = T["nav_msgs/msg/Odometry"], T["sensor_msgs/msg/JointState"]
    Pose, Point, Q = (T[f"geometry_msgs/msg/{k}"] for k in ("Pose", "Point", "Quaternion"))
    PC, TC = T["geometry_msgs/msg/PoseWithCovariance"], T["geometry_msgs/msg/TwistWithCovariance"]

    def ns(s):
        return EPOCH * 10**9 + int(round(s * 1e9))

    def header(s, frame, clock=0.0):
        n = ns(s) - int(round(clock * 1e9))
        return Header(stamp=Time(sec=n // 10**9, nanosec=n % 10**9), frame_id=frame)

    if odom == "open-loop":     # the command in force at each stamp
        j = np.searchsorted(tc, to, "right") - 1
        uo, wo = uc[j], wc[j]
    lag = np.full(tc.size, 0.002) if unstamped_lag is None else unstamped_lag
    events = [(ns(t + lag[i]), 0, i) for i, t in enumerate(tc)]
    events += [(ns(t) + 1_000_000, 1, i) for i, t in enumerate(to)]
    w = Writer(path, version=9, storage_plugin=StoragePlugin.MCAP)
    with w:
        if unstamped_lag is not None:
            cmd_out = False
            c_in = w.add_connection("/cmd_vel", Twist.__msgtype__, typestore=ts)
        else:
            c_in = w.add_connection(f"{NS}/cmd_vel", TwistS.__msgtype__, typestore=ts)
        c_out = w.add_connection(f"{NS}/cmd_vel_out", TwistS.__msgtype__, typestore=ts) \
            if cmd_out else None
        c_od = w.add_connection("/joint_states" if joints else f"{NS}/odom",
                                (JS if joints else Odom).__msgtype__, typestore=ts)
        for t_ns, kind, i in sorted(events):
            if kind == 0:
                tw = Twist(linear=V3(x=float(uc[i]), y=0.0, z=0.0),
                           angular=V3(x=0.0, y=0.0, z=float(wc[i])))
                if unstamped_lag is not None:
                    w.write(c_in, t_ns, ts.serialize_cdr(tw, Twist.__msgtype__))
                    continue
                msg = TwistS(header=header(tc[i], "base_link"), twist=tw)
                if zero_stamps:
                    msg = TwistS(header=Header(stamp=Time(sec=0, nanosec=0),
                                               frame_id="base_link"), twist=tw)
                # the teleop sends a little more than the controller's limits let through
                fast = TwistS(header=msg.header, twist=Twist(
                    linear=V3(x=1.3 * float(uc[i]), y=0.0, z=0.0), angular=tw.angular))
                w.write(c_in, t_ns, ts.serialize_cdr(fast if cmd_out else msg,
                                                     TwistS.__msgtype__))
                if cmd_out:
                    w.write(c_out, t_ns, ts.serialize_cdr(msg, TwistS.__msgtype__))
            elif joints:
                wl = (uo[i] - wo[i] * SEPARATION / 2) / R_WHEEL
                wr = (uo[i] + wo[i] * SEPARATION / 2) / R_WHEEL
                msg = JS(header=header(to[i], ""), name=["left_wheel_joint", "right_wheel_joint"],
                         position=np.zeros(2), velocity=np.array([wl, wr]), effort=np.zeros(0))
                w.write(c_od, t_ns, ts.serialize_cdr(msg, JS.__msgtype__))
            else:
                c, s = (np.cos(psi[i]), np.sin(psi[i])) if world else (1.0, 0.0)
                tw = Twist(linear=V3(x=float(c * uo[i]), y=float(s * uo[i]), z=0.0),
                           angular=V3(x=0.0, y=0.0, z=float(wo[i])))
                pose = Pose(position=Point(x=0.0, y=0.0, z=0.0),
                            orientation=Q(x=0.0, y=0.0, z=float(np.sin(psi[i] / 2) * heading),
                                          w=float(np.cos(psi[i] / 2) if heading else 1.0)))
                msg = Odom(header=header(to[i], "odom", odom_clock),
                           child_frame_id="odom" if world else "base_link",
                           pose=PC(pose=pose, covariance=np.zeros(36)),
                           twist=TC(twist=tw, covariance=np.zeros(36)))
                w.write(c_od, t_ns, ts.serialize_cdr(msg, Odom.__msgtype__))
    return path


def assert_identified(res, tol=0.05):
    err = np.abs(res.theta.theta - ROBOT.theta)[POSITIVE] / ROBOT.theta[POSITIVE]
    assert np.all(err < tol), (res.theta.theta, err)


def test_namespaced_stamped_commands_read_from_cmd_vel_out(tmp_path):
    """Among .../cmd_vel (what the teleop asked, 30 % faster than allowed) and
    .../cmd_vel_out (what the controller applied), the applied one is read, and
    the log says why; reading the asked-for one would make theta4 30 % too large."""
    log = ident.read_bag(write(tmp_path / "bag", robot_run()))
    assert log["cmd_topic"] == f"{NS}/cmd_vel_out"
    assert "applied" in log["cmd_why"] and f"{NS}/cmd_vel" in log["cmd_why"]
    assert log["odom_topic"] == f"{NS}/odom"
    assert_identified(ident.identify(log, validate=False, check_commands=False))


def test_wheel_speeds_of_joint_states_give_the_robots_velocities(tmp_path):
    """u = r (wL + wR) / 2 and w = r (wR - wL) / D recover the velocities the
    wheel speeds were made from, and the robot is identified from them."""
    bag = write(tmp_path / "bag", robot_run(), joints=True)
    log = ident.read_bag(bag, wheel_radius=R_WHEEL, wheel_separation=SEPARATION)
    assert log["odom_topic"] == "/joint_states"
    (_, _, _), (to, uo, wo, _) = robot_run()
    k = np.searchsorted(to, log["t"] + (log["t0"] - EPOCH * 10**9) * 1e-9 - 1e-7)
    np.testing.assert_allclose(log["u"], uo[k], atol=1e-9)
    np.testing.assert_allclose(log["w"], wo[k], atol=1e-9)
    assert_identified(ident.identify(log, validate=False, check_commands=False))
    named = ident.read_bag(bag, wheel_radius=R_WHEEL, wheel_separation=SEPARATION,
                           wheel_joints=("left_wheel_joint", "right_wheel_joint"))
    np.testing.assert_array_equal(named["u"], log["u"])
    with pytest.raises(ValidationError, match="wheel_radius and wheel_separation"):
        ident.read_bag(bag, wheel_radius=R_WHEEL)
    with pytest.raises(ValidationError, match="no joint 'left'"):
        ident.read_bag(bag, wheel_radius=R_WHEEL, wheel_separation=SEPARATION,
                       wheel_joints=("left", "right"))


def test_open_loop_odometry_is_refused_naming_it(tmp_path):
    """Read from a bag, or as a log of its own (the velocities one row behind)."""
    with pytest.raises(ValidationError, match=r"bag .*/diff_drive_controller/odom: .*"
                                              r"open-loop odometry"):
        ident.read_bag(write(tmp_path / "bag", robot_run(), odom="open-loop"))
    (tc, uc, wc), _ = robot_run()
    log = {"t": tc, "u_ref": uc, "w_ref": wc, "u": np.append(0.0, uc[:-1]),
           "w": np.append(0.0, wc[:-1])}
    with pytest.raises(ValidationError, match="open-loop odometry"):
        ident.identify(log, validate=False)


def test_world_frame_twist_is_turned_into_the_robots_frame(tmp_path):
    """A twist in the odom frame (linear.x = u cos psi, linear.y = u sin psi) is
    turned back with the pose's heading: the same log as the body-frame bag."""
    body = ident.read_bag(write(tmp_path / "body", robot_run()))
    with pytest.warns(ident.IdentificationWarning, match="world frame"):
        world = ident.read_bag(write(tmp_path / "world", robot_run(), world=True))
    np.testing.assert_allclose(world["u"], body["u"], atol=1e-9)
    assert_identified(ident.identify(world, validate=False, check_commands=False))


def test_world_frame_twist_without_a_heading_is_refused_naming_the_frame(tmp_path):
    with pytest.raises(ValidationError, match="world frame 'odom'.*child_frame_id is 'odom'"):
        ident.read_bag(write(tmp_path / "bag", robot_run(), world=True, heading=False))


def test_commands_on_the_wall_clock_and_odometry_on_sim_time_are_named(tmp_path):
    bag = write(tmp_path / "bag", robot_run(), odom_clock=EPOCH)
    with pytest.raises(ValidationError, match="wall clock.*simulation time"):
        ident.read_bag(bag)


def test_zero_stamps_are_timed_as_unstamped_commands_on_another_clock(tmp_path):
    """TwistStamped commands with zero stamps, odometry on simulation time: the
    commands are timed by the recorder and moved onto the odometry's clock, not
    refused as stamped on another clock."""
    bag = write(tmp_path / "bag", robot_run(), odom_clock=EPOCH, zero_stamps=True)
    with pytest.warns(ident.IdentificationWarning, match="another clock"):
        log = ident.read_bag(bag)
    assert log["commands"]["stamped"] is False
    with pytest.warns(ident.IdentificationWarning, match="carry no stamps"):
        assert_identified(ident.identify(log, validate=False, check_commands=False))


def test_a_parameter_excited_only_by_blips_gets_no_interval():
    """Constant commands with three one-sample blips: the share of the samples that
    theta2 rests on is below half a percent, and it is reported without an interval
    rather than with a confident one."""
    from unidyn.identification.replay import simulate_held
    rp = RobotParameters(0.42, 0.27, 0.02, 1.05, 0.035, 1.08)
    t = np.arange(0, 90, 1 / 30)
    rng = np.random.default_rng(0)
    ur, wr = np.full(t.size, 0.5), np.full(t.size, 0.3)
    k = rng.choice(t.size, 3, replace=False)
    ur[k] += 0.3
    wr[k] -= 0.4
    v = simulate_held(rp.theta, t, ur, wr, [(0, t.size)], [[0.5, 0.3]])
    log = {"t": t, "u_ref": ur, "w_ref": wr, "u": v[:, 0] + 0.01 * rng.standard_normal(t.size),
           "w": v[:, 1] + 0.01 * rng.standard_normal(t.size)}
    with pytest.warns(ident.IdentificationWarning):
        res = ident.identify(log, validate=False, check_commands=False)
    flagged = [i for i in range(6) if not np.isfinite(res.stderr[i])]
    assert flagged, res.stderr
    for i in flagged:
        assert any(f"theta{i + 1} is not identifiable" in w for w in res.warnings)


@pytest.mark.slow
def test_intervals_hold_the_truth_at_30_hz_with_unstamped_commands(tmp_path):
    """Ten seeded bags: unstamped Twist commands at 10 Hz received 1-3 ms after the
    robot applied them, odometry at 30 Hz. Without weighting the rows' commands by
    the response and widening the intervals for the recorder's lag, theta1's
    interval held the truth in 4 of these ten bags and theta2's in none (errors
    -0.5 to -0.9 %, half-widths 0.12 %); theta1, theta2, theta4 and theta6 must
    each be held in at least 9 of 10 (95 % coverage gives 9 or 10 in 91 % of runs
    of ten)."""
    truth = ROBOT.theta
    cover = []
    for seed in range(10):
        run = robot_run(seed=10 + seed, T=60.0, odom_hz=30.0, noise=0.002)
        lag = np.random.default_rng(seed).uniform(0.001, 0.003, run[0][0].size)
        log = ident.read_bag(write(tmp_path / f"bag{seed}", run, unstamped_lag=lag))
        with pytest.warns(ident.IdentificationWarning, match="carry no stamps"):
            res = ident.identify(log, validate=False, check_commands=False)
        assert_identified(res, tol=0.02)
        cover.append((res.ci95[:, 0] <= truth) & (truth <= res.ci95[:, 1]))
    held_ = np.sum(cover, axis=0)
    assert np.all(held_[POSITIVE] >= 9), held_


@pytest.mark.slow
def test_cli_reads_wheel_speeds_and_says_which_topics_and_why(tmp_path):
    import json
    import os
    import subprocess
    import sys
    from pathlib import Path
    bag = write(tmp_path / "bag", robot_run(), joints=True)
    env = {**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parents[2] / "src"),
           "MPLBACKEND": "Agg"}
    p = subprocess.run([sys.executable, "-m", "unidyn", "identify", str(bag), "--wheel-radius",
                        str(R_WHEEL), "--wheel-separation", str(SEPARATION), "--no-validate",
                        "--out", str(tmp_path / "out")], capture_output=True, text=True,
                       env=env, timeout=600)
    assert p.returncode == 0, p.stderr
    line = next(x for x in p.stdout.splitlines() if x.startswith("bag"))
    assert f"{NS}/cmd_vel_out" in line and "applied" in line
    assert "/joint_states" in line and "left_wheel_joint (left)" in line
    theta = json.loads((tmp_path / "out" / "theta.json").read_text())
    assert abs(theta["theta1"] / ROBOT.theta1 - 1) < 0.05
    p = subprocess.run([sys.executable, "-m", "unidyn", "identify", str(bag), "--wheel-radius",
                        "0.08", "--out", str(tmp_path / "out2")], capture_output=True,
                       text=True, env=env, timeout=600)
    assert p.returncode != 0 and "wheel_separation" in p.stderr


def test_progress_bar_counts_the_fits_simulations(capsys):
    exc = ident.excitation(30.0, 0.05, robot=ROBOT, seed=0)
    log = ident.simulate_log(ROBOT, exc, noise_std=0.01, seed=1, commands="held")
    import warnings
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ident.IdentificationWarning)   # not the subject
        ident.identify(log, validate=False, check_commands=False, progress=True)
        assert "simulations" in capsys.readouterr().err
        ident.identify(log, validate=False, check_commands=False)   # short: no bar
        assert "simulations" not in capsys.readouterr().err
