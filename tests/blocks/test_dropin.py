"""DYNAMICUNICYCLE as a drop-in for roboticstoolbox's kinematic UNICYCLE, and unidyn.teaching.animation.

The diagrams here are written the way Robotics Toolbox diagrams drive a
``UNICYCLE`` (RVC's drive-to-a-point model): the robot built with ``x0``,
``speed_max``, ``accel_max``, ``steer_max`` and ``name``; its inputs reached by
label (``.v``, ``.ω``), by index (``[1]``) or by assignment; its pose split by
``INDEX`` blocks; the controller made of ``CONSTANT``, ``SUM``, ``FUNCTION`` and
``GAIN`` blocks. :func:`drivepoint` takes the robot's block name and nothing
else changes between the two robots.

What is verified:

- the same diagram compiles and runs with either robot, for every wiring style,
  and both drive to the goal; the dynamic robot honours ``accel_max``;
- a very fast dynamic robot (theta1 = theta2 = eps, theta4 = theta6 = 1,
  theta3 = theta5 = 0: a first-order velocity lag of eps seconds) follows the
  kinematic robot's path, the largest pose difference shrinking monotonically
  and in proportion to eps (eps = 0.1, 0.01, 0.001 s);
- ``VEHICLEPLOT`` accepts the dynamic robot's pose output: with graphics off it
  constructs, connects, compiles and runs (it is inert, and the result is
  unchanged); with graphics on (headless Agg backend) the path it records is the
  robot's logged pose;
- ``bd.connect(vehicle, ...)`` on the whole block, which RVC's models use, is
  not accepted yet (the robot has a second output): an expected failure;
- ``unidyn.teaching.animation.animate`` writes a GIF with the expected number of frames
  (read back with Pillow) and rejects bad arguments with ``ValidationError``.
"""

import contextlib
import io
import math
from pathlib import Path

import numpy as np
import pytest

import unidyn
from unidyn import ValidationError
from unidyn.diagrams import new_simulator
from unidyn.teaching.animation import DEFAULT_MAX_FRAMES, Motion, animate

X0 = (8.0, 5.0, math.pi / 2)   # start pose (x, y, heading), as in RVC's drive-to-a-point
GOAL = (5.0, 5.0)
KV, KH = 0.5, 4.0              # speed and heading gains
SPEED_MAX, STEER_MAX = 1.0, 2.0
SOLVER = dict(rtol=1e-8, atol=1e-10)
WIRINGS = ("labels", "index", "assign")


def quiet_compile(bd):
    with contextlib.redirect_stdout(io.StringIO()):  # bdsim's notes on unconnected outputs
        bd.compile()


def drivepoint(sim, vehicle_type, *, wiring="labels", accel_max=np.inf, plot=False,
               robot_args=None, x0=X0):
    """RVC's drive-to-a-point diagram around the vehicle block ``bd.<vehicle_type>``.

    :return: (block diagram, vehicle block, VEHICLEPLOT block or None), compiled
    """
    bd = sim.blockdiagram()
    vehicle = getattr(bd, vehicle_type)(x0=list(x0), speed_max=SPEED_MAX, accel_max=accel_max,
                                        steer_max=STEER_MAX, name="vehicle",
                                        **(robot_args or {}))
    goal = bd.CONSTANT(list(GOAL), name="goal")
    xy = bd.INDEX([0, 1], name="xy")
    theta = bd.INDEX([2], name="theta")
    error = bd.SUM("+-", name="error")
    d2goal = bd.FUNCTION(lambda d: math.sqrt(d[0] ** 2 + d[1] ** 2), name="d2goal")
    h2goal = bd.FUNCTION(lambda d: math.atan2(d[1], d[0]), name="h2goal")
    heading_error = bd.SUM("+-", mode="c", name="heading_error")
    speed = bd.GAIN(KV, name="Kv")
    turn = bd.GAIN(KH, name="Kh")

    bd.connect(goal, error[0])
    bd.connect(xy, error[1])
    bd.connect(error, d2goal, h2goal)
    bd.connect(d2goal, speed)
    bd.connect(h2goal, heading_error[0])
    bd.connect(theta, heading_error[1])
    bd.connect(heading_error, turn)
    if wiring == "labels":
        bd.connect(vehicle.q, xy, theta)
        bd.connect(speed, vehicle.v)
        bd.connect(turn, vehicle.ω)
    elif wiring == "index":
        bd.connect(vehicle[0], xy, theta)
        bd.connect(speed, vehicle[0])
        bd.connect(turn, vehicle[1])
    else:  # wiring by assignment
        xy[0] = vehicle[0]
        theta[0] = vehicle[0]
        vehicle.v = speed
        vehicle[1] = turn
    vplot = None
    if plot:
        vplot = bd.VEHICLEPLOT(scale=[0, 10], size=0.7, shape="box", path="b:", name="vplot")
        bd.connect(vehicle[0], vplot)
    quiet_compile(bd)
    return bd, vehicle, vplot


def run(sim, bd, vehicle, T=10.0, dt=0.05):
    out = sim.run(bd, T, dt=dt, watch=[vehicle[0]], solver_args=SOLVER)
    return np.asarray(out.t), np.asarray(out[".ywatch"][0], dtype=float).reshape(len(out.t), 3), out


# --------------------------------------------------------------------------- drop-in

@pytest.mark.parametrize("wiring", WIRINGS)
def test_toolbox_diagram_runs_unchanged(wiring):
    """The diagram written for UNICYCLE runs with DYNAMICUNICYCLE, same arguments and
    wiring, and both robots reach the goal."""
    sim = new_simulator()
    final = {}
    for vehicle_type in ("UNICYCLE", "DYNAMICUNICYCLE"):
        bd, vehicle, _ = drivepoint(sim, vehicle_type, wiring=wiring, accel_max=2.0)
        t, q, out = run(sim, bd, vehicle, T=15.0)
        assert np.all(np.isfinite(q))
        assert t[-1] == pytest.approx(15.0)
        final[vehicle_type] = q[-1]
        if vehicle_type == "DYNAMICUNICYCLE":
            # the limits are honoured, to the solver's tolerance (the clipping is a kink
            # the adaptive solver steps across); u is state 3 of the only stateful block
            u = np.asarray(out.x)[:, 3]
            assert np.max(np.abs(np.diff(u) / np.diff(t))) <= 2.0 * (1 + 1e-6)
            assert np.max(np.abs(u)) <= SPEED_MAX * (1 + 1e-6)
    for vehicle_type, q in final.items():
        assert np.hypot(q[0] - GOAL[0], q[1] - GOAL[1]) < 0.05, vehicle_type


def test_whole_block_connect_as_in_rvc_models():
    sim = new_simulator()
    bd = sim.blockdiagram()
    vehicle = bd.DYNAMICUNICYCLE(x0=list(X0), speed_max=SPEED_MAX, name="vehicle")
    xy = bd.INDEX([0, 1], name="xy")
    theta = bd.INDEX([2], name="theta")
    bd.connect(vehicle, xy, theta)


@pytest.mark.slow
def test_fast_robot_approaches_kinematic_unicycle():
    """theta1 = theta2 = eps, theta4 = theta6 = 1, theta3 = theta5 = 0 is the kinematic
    unicycle behind a first-order velocity lag of eps seconds: the pose lags by about
    speed x eps (heading: turn rate x eps), so the largest difference from UNICYCLE's
    run shrinks in proportion to eps."""
    sim = new_simulator()
    bd, vehicle, _ = drivepoint(sim, "UNICYCLE")
    t_kin, q_kin, _ = run(sim, bd, vehicle)
    pos_diff, psi_diff = [], []
    for eps in (1e-1, 1e-2, 1e-3):
        bd, vehicle, _ = drivepoint(sim, "DYNAMICUNICYCLE",
                                    robot_args=dict(robot=[eps, eps, 0.0, 1.0, 0.0, 1.0]))
        t, q, _ = run(sim, bd, vehicle)
        np.testing.assert_array_equal(t, t_kin)
        pos_diff.append(float(np.max(np.hypot(*(q[:, :2] - q_kin[:, :2]).T))))
        psi_diff.append(float(np.max(np.abs(q[:, 2] - q_kin[:, 2]))))
        # first order in eps, bounded by the speed limits times the lag
        assert pos_diff[-1] <= 1.2 * SPEED_MAX * eps
        assert psi_diff[-1] <= 1.2 * STEER_MAX * eps
    for d in (pos_diff, psi_diff):
        assert d[0] > d[1] > d[2] > 0
        assert d[1] / d[0] < 0.2 and d[2] / d[1] < 0.2, d


# --------------------------------------------------------------------------- VEHICLEPLOT

def test_vehicleplot_graphics_off_is_inert():
    """With graphics disabled VEHICLEPLOT constructs, takes the pose output, compiles and
    runs; it draws nothing and the run is the same as without it."""
    sim = new_simulator()
    bd, vehicle, vplot = drivepoint(sim, "DYNAMICUNICYCLE", plot=True)
    assert vplot in bd.blocklist
    wires = [w for w in bd.wirelist if w.end.block is vplot]
    assert len(wires) == 1
    assert wires[0].start.block is vehicle and wires[0].start.port == 0
    _, q_plot, _ = run(sim, bd, vehicle)
    bd2, vehicle2, _ = drivepoint(sim, "DYNAMICUNICYCLE")
    _, q, _ = run(sim, bd2, vehicle2)
    np.testing.assert_array_equal(q_plot, q)
    assert vplot.xdata == []


def test_vehicleplot_draws_the_dynamic_pose():
    """With graphics on (Agg, headless) VEHICLEPLOT records the path it draws: it is the
    dynamic robot's logged pose at every output step after t = 0."""
    import matplotlib.pyplot as plt
    sim = new_simulator(graphics=True, animation=False)
    bd, vehicle, vplot = drivepoint(sim, "DYNAMICUNICYCLE", plot=True)
    try:
        with contextlib.redirect_stdout(io.StringIO()):
            t, q, _ = run(sim, bd, vehicle, T=3.0, dt=0.1)
    finally:
        plt.close("all")
    assert len(vplot.xdata) == len(t) - 1
    np.testing.assert_allclose(vplot.xdata, q[1:, 0], rtol=0, atol=1e-12)
    np.testing.assert_allclose(vplot.ydata, q[1:, 1], rtol=0, atol=1e-12)


# --------------------------------------------------------------------------- animation

def _n_frames(path):
    from PIL import Image
    with Image.open(path) as im:
        return im.n_frames, im.info.get("duration")


def _motion(T=5.0, n=101, a=0.0, label=""):
    t = np.linspace(0.0, T, n)
    pose = np.column_stack([np.sin(0.5 * t), np.cos(0.25 * t) - 1.0, 0.3 * t])
    return Motion(t, pose, reference=pose[:, :2] + 0.05, a=a, label=label)


@pytest.mark.slow
def test_animate_result_writes_gif(tmp_path):
    import matplotlib.pyplot as plt
    r = unidyn.simulate(unidyn.Scenario.paper(2, T=3.0, noise=None))
    figs = plt.get_fignums()
    path = animate(r, tmp_path / "run.gif", frames=12, fps=10)
    assert path == tmp_path / "run.gif"
    assert path.stat().st_size > 0
    assert _n_frames(path) == (12, 100)
    assert plt.get_fignums() == figs          # drawn off-screen, no pyplot figure left
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run.gif"]  # no temporary files


@pytest.mark.slow
def test_animate_frame_counts(tmp_path):
    # real time when it fits in the default budget: 5 s at 20 fps -> 101 frames
    assert _n_frames(animate(_motion(5.0), tmp_path / "a.gif"))[0] == 101
    # otherwise the default budget of frames over the whole run
    long = _motion(60.0, 601)
    assert _n_frames(animate(long, tmp_path / "b.gif"))[0] == DEFAULT_MAX_FRAMES
    # speedup: simulated seconds per second of playback
    assert _n_frames(animate(_motion(5.0), tmp_path / "c.gif", speedup=2.0))[0] == 51
    # several robots, trail limited to the last second, replaced in place
    both = [_motion(5.0, label="one"), _motion(4.0, 41, a=0.2, label="two")]
    p = animate(both, tmp_path / "c.gif", frames=7, trail=1.0)
    assert _n_frames(p)[0] == 7
    # a single frame, and an animation from a bdsim run's arrays
    assert _n_frames(animate(_motion(), tmp_path / "d.gif", frames=1, trail=False))[0] == 1


@pytest.mark.slow
def test_animate_bdsim_run(tmp_path):
    sim = new_simulator()
    bd, vehicle, _ = drivepoint(sim, "DYNAMICUNICYCLE")
    t, q, _ = run(sim, bd, vehicle, T=4.0)
    p = animate(Motion(t, q, label="DYNAMICUNICYCLE"), tmp_path / "drive.gif", frames=9)
    assert _n_frames(p)[0] == 9


@pytest.mark.parametrize("kwargs, match", [
    (dict(fps=0), "fps"),
    (dict(fps=-5), "fps"),
    (dict(fps=float("nan")), "fps"),
    (dict(fps="20"), "fps"),
    (dict(frames=0), "frames"),
    (dict(frames=2.5), "frames"),
    (dict(frames=True), "frames"),
    (dict(speedup=0), "speedup"),
    (dict(speedup=2, frames=10), "not both"),
    (dict(speedup=1e-4), "frames"),
    (dict(trail=-1), "trail"),
    (dict(robot_size=0), "robot_size"),
    (dict(dpi=0), "dpi"),
    (dict(figsize=(5, 0)), "figsize"),
    (dict(reference="yes"), "reference"),
])
def test_animate_rejects_bad_arguments(tmp_path, kwargs, match):
    with pytest.raises(ValidationError, match=match):
        animate(_motion(), tmp_path / "x.gif", **kwargs)
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("name", ["x.png", "x", "x.gif.txt", "x.avi"])
def test_animate_rejects_suffix(tmp_path, name):
    with pytest.raises(ValidationError, match=r"\.gif or \.mp4"):
        animate(_motion(), tmp_path / name)


def test_animate_rejects_bad_inputs(tmp_path):
    with pytest.raises(ValidationError, match="does not exist"):
        animate(_motion(), tmp_path / "missing" / "x.gif")
    with pytest.raises(ValidationError, match="path"):
        animate(_motion(), 42)
    with pytest.raises(ValidationError, match="Result"):
        animate(np.zeros((10, 3)), tmp_path / "x.gif")
    with pytest.raises(ValidationError, match="empty"):
        animate([], tmp_path / "x.gif")
    t = np.linspace(0, 1, 5)
    with pytest.raises(ValidationError, match="NaN"):
        Motion(t, np.full((5, 3), np.nan))
    with pytest.raises(ValidationError, match="shape"):
        Motion(t, np.zeros((4, 3)))
    with pytest.raises(ValidationError, match="non-decreasing"):
        Motion(t[::-1], np.zeros((5, 3)))
    with pytest.raises(ValidationError, match="a must be"):
        Motion(t, np.zeros((5, 3)), a=-0.1)


def test_animate_mp4_needs_ffmpeg(tmp_path, monkeypatch):
    from matplotlib import animation as mpl_animation
    if mpl_animation.writers.is_available("ffmpeg"):
        p = animate(_motion(), tmp_path / "x.mp4", frames=5)
        assert p.stat().st_size > 0
    monkeypatch.setattr(mpl_animation.writers, "is_available", lambda name: False)
    with pytest.raises(ValidationError, match="ffmpeg"):
        animate(_motion(), tmp_path / "y.mp4")
    assert not Path(tmp_path / "y.mp4").exists()


# --------------------------------------------------------------------------- RVC3's idioms

@pytest.mark.parametrize("vehicle_type", ["UNICYCLE", "DYNAMICUNICYCLE"])
def test_start_pose_set_after_building_as_rvc3_fig4_8(vehicle_type):
    """RVC3's fig4_8 builds drivepoint once, then per start pose sets
    ``bd['vehicle']._x0 = (x, y, theta)`` and runs: each run starts at that pose (the
    dynamic robot at rest) and gives what a diagram built with ``x0=`` gives."""
    sim = new_simulator()
    bd, vehicle, _ = drivepoint(sim, vehicle_type)
    for th in (0.0, 2.0):
        x0 = np.r_[5 + 3 * math.cos(th), 5 + 3 * math.sin(th), th + math.pi / 2]
        bd["vehicle"]._x0 = x0
        out = sim.run(bd, 4.0, dt=0.05, solver_args=SOLVER)
        start = np.r_[x0, 0.0, 0.0] if vehicle_type == "DYNAMICUNICYCLE" else x0
        np.testing.assert_array_equal(out.x[0], start)
        sim2 = new_simulator()
        bd2, _, _ = drivepoint(sim2, vehicle_type, x0=x0)
        out2 = sim2.run(bd2, 4.0, dt=0.05, solver_args=SOLVER)
        np.testing.assert_allclose(out.x, out2.x, rtol=0, atol=1e-12)
        assert np.hypot(*(out.x[-1, :2] - GOAL)) < 0.5 * np.hypot(*(x0[:2] - GOAL))


def test_a_start_pose_beyond_the_limits_or_of_a_wrong_size_is_refused():
    veh = unidyn.blocks.DynamicUnicycle(speed_max=0.5)
    with pytest.raises(ValidationError, match="x0"):
        veh._x0 = (1.0, 2.0)
    with pytest.raises(ValidationError, match="u = 0.8"):
        veh._x0 = (0, 0, 0, 0.8, 0)
    np.testing.assert_array_equal(veh.x0, np.zeros(5))   # unchanged
    veh.x0 = (1.0, 2.0, 0.5)                              # the public name of _x0
    np.testing.assert_array_equal(veh._x0, [1.0, 2.0, 0.5, 0.0, 0.0])


def test_out_x_recipe_for_scripts_written_for_three_states():
    """The drop-in guide's recipe: the dynamic robot's states are x, y, psi, u, w, so
    code written for UNICYCLE's three (RVC3's fig4_6 slices ``out.x[:, 1:]`` into y,
    theta) takes ``out.x[:, :3]`` for the pose; the columns are the pose output."""
    sim = new_simulator()
    bd, vehicle, _ = drivepoint(sim, "DYNAMICUNICYCLE")
    t, pose, out = run(sim, bd, vehicle, T=3.0)
    assert list(out.xnames) == ["vehicle:x", "vehicle:y", "vehicle:psi", "vehicle:u", "vehicle:w"]
    np.testing.assert_allclose(out.x[:, :3], pose, rtol=0, atol=1e-12)
    np.testing.assert_allclose(out.x[:, 1:3], pose[:, 1:], rtol=0, atol=1e-12)  # fig4_6's y, theta


def test_states_of_several_vehicles_are_named_per_block():
    sim = new_simulator()
    bd = sim.blockdiagram()
    for name, u in (("leader", 0.3), (None, 0.1)):
        veh = bd.DYNAMICUNICYCLE(name=name) if name else bd.KINEMATICUNICYCLE()
        bd.connect(bd.CONSTANT(u), veh.v)
        bd.connect(bd.CONSTANT(0.0), veh[1])
        bd.connect(veh, bd.NULL())
    quiet_compile(bd)
    out = sim.run(bd, 1.0, dt=0.5, solver_args=SOLVER)
    assert list(out.xnames) == ["leader:x", "leader:y", "leader:psi", "leader:u", "leader:w",
                                "kinematicunicycle.0:x", "kinematicunicycle.0:y",
                                "kinematicunicycle.0:psi"]
    # the kinematic robot moves at its command from the start: x = 0.1 t
    assert out.x[-1, 5] == pytest.approx(0.1, abs=1e-9)
