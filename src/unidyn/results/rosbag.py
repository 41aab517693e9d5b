"""A run written as a ROS 2 recording (MCAP), in the messages a ROS robot uses.

``unidyn run ... --bag run.mcap`` writes, at every sample of the run:

- ``/cmd_vel`` (``geometry_msgs/Twist``): the commands applied to the robot,
  v_ref = (u_ref, w_ref) of Eq. (2) (for a kinematic run, the velocities);
- ``/odom`` (``nav_msgs/Odometry``): the pose of the point h (x, y and the
  heading psi as a rotation about z) in frame ``odom`` and the velocities (u, w)
  of Eq. (1) in ``twist.twist.linear.x`` / ``angular.z``, frame ``base_link``;
- ``/reference`` (``geometry_msgs/PoseStamped``): the desired position h_d.

Message times are the run's times (s from 0, as a simulation clock). The file
opens in Foxglove Studio or PlotJuggler, and ``unidyn identify run.mcap`` reads
it back (see :func:`unidyn.identification.read_bag`). A sampled-control run
(``control = "sampled"``) holds each command for one sample, as a robot's
firmware does: each Twist is written at the time it started to act, which is
what ``unidyn identify`` reads it as. A continuous-control run's commands vary
between samples and are written at the samples only (identifying such a bag with
held commands is biased by about half a sample). The robot follows Eq. (2) only
within its limits: a run whose accelerations are clipped (the paper's limits)
is not Eq. (2) while they clip, and identifies with a bias.
"""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np

from .._errors import MissingDependency, ValidationError
from .folders import OwnedFile

__all__ = ["write_run_bag", "check_bag_target", "BAG_NAME"]

_INSTALL = 'pip install "unidyn[ros]"'
#: The names of the recordings ``--bag`` writes (their manifest ``.unidyn-bag.json``
#: lists those unidyn wrote, with the SHA-256 of each)
BAG_NAME = re.compile(r"[^/\0]+\.mcap", re.IGNORECASE)


def check_bag_target(path, overwrite: bool = False, option: str = "--bag") -> OwnedFile:
    """The recording to write, checked before a run: an ``.mcap`` file name in an
    existing folder; not a link, a folder or a file unidyn did not write (a recording
    of yours is never replaced, with or without ``overwrite``); one unidyn wrote only
    with ``overwrite`` (see :class:`unidyn.results.folders.OwnedFile`)."""
    if not str(path).lower().endswith(".mcap") or Path(path).name.startswith(".unidyn"):
        raise ValidationError(f"{option} expects a file name ending in .mcap, got "
                              f"{str(path)[:80]!r}")
    target = OwnedFile(path, kind="bag", pattern=BAG_NAME, overwrite=overwrite,
                       option=option)
    try:
        import rosbags  # noqa: F401
    except ImportError:
        raise MissingDependency(f"{option} needs the rosbags package ({_INSTALL})") from None
    return target


def _time(Time, seconds: float):
    ns = int(round(seconds * 1e9))
    return Time(sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000)


def write_run_bag(result, path, overwrite: bool = False) -> bool:
    """Write a run (a :class:`unidyn.results.result.Result`) to ``path`` (``.mcap``,
    or the :class:`~unidyn.results.folders.OwnedFile` :func:`check_bag_target` gave),
    replacing a recording only where unidyn wrote it, once the new file is complete,
    and never with an incomplete run's. Returns whether it was written (False: an
    incomplete run beside a recording, which is kept as it was)."""
    target = path if isinstance(path, OwnedFile) else check_bag_target(path, overwrite)
    return target.write(lambda folder: _write_mcap(result, folder / "run"),
                        complete=bool(getattr(result, "complete", True)))


def _write_mcap(result, folder: Path) -> Path:
    """Write the run as a ROS 2 bag in the new ``folder`` (MCAP storage); returns the
    ``.mcap`` file."""
    try:
        from rosbags.rosbag2 import CompressionFormat, CompressionMode, StoragePlugin, Writer
        from rosbags.typesys import Stores, get_typestore
    except ImportError:
        raise MissingDependency(f"writing a ROS bag needs the rosbags package "
                                f"({_INSTALL})") from None
    ts = get_typestore(Stores.ROS2_HUMBLE)
    T = ts.types
    Time, Header = T["builtin_interfaces/msg/Time"], T["std_msgs/msg/Header"]
    Vector3, Twist = T["geometry_msgs/msg/Vector3"], T["geometry_msgs/msg/Twist"]
    Point, Quaternion = T["geometry_msgs/msg/Point"], T["geometry_msgs/msg/Quaternion"]
    Pose, PoseStamped = T["geometry_msgs/msg/Pose"], T["geometry_msgs/msg/PoseStamped"]
    PoseCov = T["geometry_msgs/msg/PoseWithCovariance"]
    TwistCov = T["geometry_msgs/msg/TwistWithCovariance"]
    Odometry = T["nav_msgs/msg/Odometry"]
    t = np.asarray(result.t, dtype=float)
    pose = np.asarray(result.pose, dtype=float)
    vel = np.asarray(result.velocity, dtype=float)
    cmd = np.asarray(result.v_ref if result.v_ref is not None else result.velocity, dtype=float)
    ref = np.asarray(result.reference, dtype=float)
    # a sampled controller's command is logged at the end of the interval it acted over
    # (the value held up to that sample): it is sent at the interval's start
    sc = result.scenario
    t_cmd = t - sc.Ts if getattr(sc, "control", "") == "sampled" else t
    first = int(np.searchsorted(t_cmd, 0.0))
    zero36 = np.zeros(36)
    # written in a private folder beside the target (see OwnedFile.write)
    w = Writer(folder, version=9, storage_plugin=StoragePlugin.MCAP)
    # zstd-compressed chunks, as ros2 bag record -s mcap writes by default
    w.set_compression(CompressionMode.STORAGE, CompressionFormat.ZSTD)
    with w:
        c_cmd = w.add_connection("/cmd_vel", Twist.__msgtype__, typestore=ts)
        c_odom = w.add_connection("/odom", Odometry.__msgtype__, typestore=ts)
        c_ref = w.add_connection("/reference", PoseStamped.__msgtype__, typestore=ts)
        for k in range(t.size):
            if k + first < t.size:    # in time order: the command sent at t[k]
                c = _time(Time, t_cmd[k + first])
                twist = Twist(linear=Vector3(x=float(cmd[k + first, 0]), y=0.0, z=0.0),
                              angular=Vector3(x=0.0, y=0.0, z=float(cmd[k + first, 1])))
                w.write(c_cmd, c.sec * 1_000_000_000 + c.nanosec,
                        ts.serialize_cdr(twist, Twist.__msgtype__))
            stamp = _time(Time, t[k])
            ns = stamp.sec * 1_000_000_000 + stamp.nanosec
            psi = float(pose[k, 2])
            odom = Odometry(
                header=Header(stamp=stamp, frame_id="odom"), child_frame_id="base_link",
                pose=PoseCov(pose=Pose(
                    position=Point(x=float(pose[k, 0]), y=float(pose[k, 1]), z=0.0),
                    orientation=Quaternion(x=0.0, y=0.0, z=math.sin(psi / 2),
                                           w=math.cos(psi / 2))), covariance=zero36),
                twist=TwistCov(twist=Twist(
                    linear=Vector3(x=float(vel[k, 0]), y=0.0, z=0.0),
                    angular=Vector3(x=0.0, y=0.0, z=float(vel[k, 1]))),
                    covariance=zero36))
            w.write(c_odom, ns, ts.serialize_cdr(odom, Odometry.__msgtype__))
            goal = PoseStamped(
                header=Header(stamp=stamp, frame_id="odom"),
                pose=Pose(position=Point(x=float(ref[k, 0]), y=float(ref[k, 1]), z=0.0),
                          orientation=Quaternion(x=0.0, y=0.0, z=0.0, w=1.0)))
            w.write(c_ref, ns, ts.serialize_cdr(goal, PoseStamped.__msgtype__))
    return folder / f"{folder.name}.mcap"
