"""Reading a robot's ROS recordings as identification logs.

A robot driven through ROS receives its commands as ``geometry_msgs/Twist`` (or
``TwistStamped``) on a topic such as ``/cmd_vel`` and reports its velocities in
``nav_msgs/Odometry`` on ``/odom``. ``rosbag record`` (ROS 1, a ``.bag`` file)
or ``ros2 bag record`` (ROS 2, a folder holding ``metadata.yaml`` and sqlite3
``.db3`` or MCAP ``.mcap`` files; a lone ``.mcap`` file is read too) stores
both. :func:`read_bag` turns such a recording into the log that
:func:`~unidyn.identification.identify` takes (the dict that
:func:`~unidyn.identification.load_log` returns: t, u_ref, w_ref, u, w).

Time as the robot saw it
------------------------
The commands arrive at 10-20 Hz and the firmware holds each one until the next;
odometry arrives at 20-50 Hz with jitter, and neither clock is a multiple of the
other. Resampling both onto one grid would shift every command change by up to
a grid step, which biases theta1 and theta2 like a delay (by about theta4 dt / 2
and theta6 dt / 2). Instead:

- each command acts from its time (the header stamp of a ``TwistStamped``, the
  time the recorder received a ``Twist``) until the next command, or until
  ``cmd_timeout`` seconds have passed without one, after which the robot's
  driver stops it (command zero);
- the rows of the log are the odometry messages at their header stamps (u =
  ``twist.twist.linear.x``, w = ``twist.twist.angular.z``), never interpolated;
- the command of row k, which :func:`identify` holds from t[k] to t[k+1], is the
  mean over that interval of the commands as the robot applied them (the exact
  integral of the piecewise-constant command). Over an interval dt short against
  the time constant tau = theta1 / theta4 of Eq. (2), a held input with the same
  integral gives the same velocity at t[k+1] to within (dt / tau)^2 / 8 of a
  command step (0.2 % at 40 Hz odometry and tau = 0.2 s), where taking the
  command in force at t[k] would be off by up to dt / tau (12 %).

Messages are read one at a time (a large bag is streamed, never loaded whole);
only the two topics' stamps and velocities are kept.

Recording gaps
--------------
Where no message of either topic was recorded for ``GAP_PERIODS`` command
periods, the recording has a gap: the commands sent meanwhile are unknown. The
log keeps the odometry on both sides; the rows after the gap start with the
first odometry following the first command after it. :func:`identify` splits
the log there into pieces, each with its own initial state, as it does at the
gaps of a CSV log; the dict's ``"gap"`` entry is the threshold (s) that
:func:`identify` uses for it, so that only such gaps split it (and not a single
late odometry message, across which the commands are still known).
"""

from __future__ import annotations

import math
import os
import warnings
from array import array
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .._errors import MissingDependency
from .._validate import ValidationError, positive
from .logs import IdentificationWarning, check_measured

__all__ = ["read_bag", "is_bag", "held_mean", "held_weighted", "COMMAND_TYPES", "ODOMETRY_TYPE",
           "JOINT_STATE_TYPE", "GAP_PERIODS"]

#: Message types read as commands (u_ref = linear.x, w_ref = angular.z).
COMMAND_TYPES = ("geometry_msgs/msg/Twist", "geometry_msgs/msg/TwistStamped")
#: Message type read as the measured velocities (twist.twist.linear.x, angular.z).
ODOMETRY_TYPE = "nav_msgs/msg/Odometry"
#: Message type read as the wheel speeds (velocity, rad/s, of the wheel joints).
JOINT_STATE_TYPE = "sensor_msgs/msg/JointState"
#: No message of either topic for this many median command periods is a recording gap.
GAP_PERIODS = 5.0
# the recorder's and the header stamps' clocks are taken as different clocks when
# odometry is received more than this long (s, median) after its stamp
_CLOCK_OFFSET = 1.0
# at least this many commands, and odometry rows with known commands (load_log needs 20)
_MIN_ROWS = 20
_INSTALL = 'pip install "unidyn[ros]"'


def is_bag(path) -> bool:
    """Whether ``path`` names a ROS recording rather than a CSV log: a folder (a
    ROS 2 bag), or a ``.bag``, ``.mcap`` or ``.db3`` file."""
    p = Path(path)
    return p.is_dir() or p.suffix.lower() in (".bag", ".mcap", ".db3")


def _rosbags():
    try:
        from rosbags.highlevel import AnyReader
        from rosbags.typesys import Stores, get_typestore
    except ImportError:
        raise MissingDependency(f"reading ROS bags needs the rosbags package "
                                f"({_INSTALL})") from None
    return AnyReader, get_typestore(Stores.LATEST)


def _check_path(path: Path) -> None:
    if not path.exists():
        raise ValidationError(f"bag {path} does not exist")
    if path.is_dir():
        if not (path / "metadata.yaml").is_file():
            raise ValidationError(
                f"bag {path} is a folder without metadata.yaml: a ROS 2 bag is the folder "
                f"'ros2 bag record' writes (metadata.yaml with .db3 or .mcap files); give "
                f"an .mcap file or a ROS 1 .bag file directly")
        return
    if path.suffix.lower() not in (".bag", ".mcap", ".db3"):
        raise ValidationError(f"bag {path}: not a ROS recording; expected a ROS 2 bag folder, "
                              f"an .mcap or .db3 file or a ROS 1 .bag file")
    if path.stat().st_size == 0:
        raise ValidationError(f"bag {path} is empty (0 bytes)")


def _describe(name, info, duration) -> str:
    rate = f", {info.msgcount / duration:.3g} Hz" if duration > 0 and info.msgcount > 1 else ""
    return f"{name} ({info.msgtype}, {info.msgcount} messages{rate})"


def _choose(path, topics, wanted, types, what, flag, duration) -> tuple[str, str]:
    """(the topic to read ``what`` from, why): ``wanted`` if given, else the one
    topic of one of ``types``, or among several the one ros2_control's
    diff_drive_controller publishes as the command it applied (``cmd_vel_out``,
    after its limits); one line listing the candidates otherwise."""
    cands = {n: i for n, i in topics.items() if i.msgtype in types}
    applied = [n for n, i in cands.items()
               if n.rstrip("/").rsplit("/", 1)[-1] == "cmd_vel_out" and i.msgcount]
    if wanted is None and len(cands) > 1 and len(applied) == 1:
        others = ", ".join(n for n in cands if n != applied[0])
        return applied[0], (f"the command after the controller's limits, which the robot "
                            f"applied, preferred to {others}")
    typename = " or ".join(t.replace("/msg/", "/") for t in types)
    if wanted is not None:
        if wanted not in topics:
            have = "; ".join(_describe(n, i, duration) for n, i in cands.items()) or "none"
            raise ValidationError(f"bag {path} has no topic {wanted} ({flag}); its {typename} "
                                  f"topics: {have}")
        if topics[wanted].msgtype not in types:
            raise ValidationError(f"bag {path}: {flag} {wanted} is of type "
                                  f"{topics[wanted].msgtype}, not {typename}")
        name, why = wanted, f"given as {flag}"
    elif len(cands) == 1:
        name = next(iter(cands))
        why = f"the bag's one {typename} topic"
    elif not cands:
        have = "; ".join(_describe(n, i, duration) for n, i in topics.items()) or "no topics"
        raise ValidationError(f"bag {path} has no {typename} topic ({what}); it has {have}")
    else:
        listing = "; ".join(_describe(n, i, duration) for n, i in cands.items())
        raise ValidationError(f"bag {path} has {len(cands)} {typename} topics ({what}): "
                              f"{listing}; choose one with {flag} TOPIC")
    if topics[name].msgcount == 0:
        raise ValidationError(f"bag {path}: topic {name} ({topics[name].msgtype}) holds no "
                              f"messages")
    return name, why


def _stamp(msg, received_ns: int) -> int:
    """A header stamp in ns, or the receive time where the stamp was left at zero."""
    st = msg.header.stamp
    ns = int(st.sec) * 1_000_000_000 + int(st.nanosec)
    return ns if ns > 0 else received_ns


def _wheels(radius, separation, joints):
    """(r, D, (left, right) or None) from read_bag's wheel options, or None."""
    if radius is None and separation is None and joints is None:
        return None
    if radius is None or separation is None:
        raise ValidationError("wheel_radius and wheel_separation are needed together (both "
                              "in m) to read the wheel speeds of /joint_states")
    r, d = positive("wheel_radius", radius), positive("wheel_separation", separation)
    if joints is not None:
        if isinstance(joints, str) or len(joints) != 2 or \
                not all(isinstance(j, str) and j.strip() for j in joints):
            raise ValidationError(f"wheel_joints must be two joint names (left, right), "
                                  f"got {joints!r}")
        joints = (joints[0].strip(), joints[1].strip())
    return r, d, joints


def _wheel_joints(path, topic, names, given):
    """The (left, right) wheel joints among a JointState message's ``names``."""
    if given is not None:
        missing = [j for j in given if j not in names]
        if missing:
            raise ValidationError(f"bag {path}: {topic} has no joint {missing[0]!r} "
                                  f"(wheel joints); its joints: {', '.join(names)}")
        return given
    out = []
    for side in ("left", "right"):
        found = [n for n in names if side in n.lower()]
        wheel = [n for n in found if "wheel" in n.lower()]
        found = wheel if len(wheel) == 1 else found
        if len(found) != 1:
            raise ValidationError(
                f"bag {path}: cannot tell the {side} wheel joint among the joints of {topic} "
                f"({', '.join(names) or 'none'}); name them with --wheel-joints LEFT,RIGHT")
        out.append(found[0])
    return tuple(out)


def _read_messages(path, reader, cmd_name, odom_name, wheels=None):
    """Stream the two topics: (command times ns, u_ref, w_ref, odometry stamps ns,
    odometry receive times ns, u, w, whether the commands carry stamps)."""
    conns = [c for c in reader.connections if c.topic in (cmd_name, odom_name)]
    # compact growing arrays: 8 bytes a number, not a Python float's 24 or more
    tc, tcr, to, tr = array("q"), array("q"), array("q"), array("q")
    uc, wc, uo, wo = array("d"), array("d"), array("d"), array("d")
    vy, yaw = array("d"), array("d")
    stamped, frames = False, None
    for conn, t_ns, raw in reader.messages(connections=conns):
        msg = reader.deserialize(raw, conn.msgtype)
        if conn.topic == cmd_name:
            if conn.msgtype.endswith("TwistStamped"):
                tc.append(_stamp(msg, t_ns))
                stamped = stamped or tc[-1] != t_ns    # a stamp left at zero is none
                msg = msg.twist
            else:
                tc.append(t_ns)
            tcr.append(t_ns)
            uc.append(float(msg.linear.x))
            wc.append(float(msg.angular.z))
        elif wheels:
            names = list(msg.name)
            if frames is None:
                frames = _wheel_joints(path, odom_name, names, wheels[2])
            try:
                wl, wr = (float(msg.velocity[names.index(j)]) for j in frames)
            except (ValueError, IndexError):
                continue     # a message of other joints (several broadcasters)
            to.append(_stamp(msg, t_ns))
            tr.append(t_ns)
            uo.append(wheels[0] * (wl + wr) / 2.0)
            wo.append(wheels[0] * (wr - wl) / wheels[1])
            vy.append(0.0)
            yaw.append(0.0)
        else:
            to.append(_stamp(msg, t_ns))
            tr.append(t_ns)
            tw = msg.twist.twist
            uo.append(float(tw.linear.x))
            wo.append(float(tw.angular.z))
            vy.append(float(tw.linear.y))
            q = msg.pose.pose.orientation
            yaw.append(math.atan2(2.0 * (q.w * q.z + q.x * q.y),
                                  1.0 - 2.0 * (q.y * q.y + q.z * q.z)))
            if frames is None:
                frames = (str(msg.header.frame_id), str(msg.child_frame_id))
    cmds = _Commands(np.frombuffer(tc, np.int64), np.frombuffer(tcr, np.int64),
                     np.frombuffer(uc), np.frombuffer(wc), stamped)
    odom = _Odometry(np.frombuffer(to, np.int64), np.frombuffer(tr, np.int64),
                     np.frombuffer(uo), np.frombuffer(wo), np.frombuffer(vy),
                     np.frombuffer(yaw), frames or ("", ""))
    return cmds, odom


@dataclass
class _Commands:
    """The commands as recorded: times (stamps, or receive times) and receive
    times, ns; u_ref, w_ref; whether they carry stamps (TwistStamped whose stamps
    are not left at zero)."""
    t: np.ndarray
    received: np.ndarray
    u: np.ndarray
    w: np.ndarray
    stamped: bool


@dataclass
class _Odometry:
    """The odometry as recorded: stamps and receive times, ns; the twist's
    linear.x, angular.z and linear.y; the pose's heading, rad; the first message's
    (frame_id, child_frame_id)."""
    t: np.ndarray
    received: np.ndarray
    u: np.ndarray
    w: np.ndarray
    vy: np.ndarray
    yaw: np.ndarray
    frames: tuple


# frame names that are a fixed (world) frame, never the robot's body (REP 105)
_WORLD_FRAMES = ("odom", "map", "world", "earth")
# a twist whose sideways part is this large against its length is not in the body
# frame of a differential-drive robot (which cannot move sideways)
_SIDEWAYS = 0.2


def _body_twist(path, odom_name, od: _Odometry):
    """(u, w, note or None): the odometry's forward speed in the robot's frame.

    A twist is in the frame ``child_frame_id`` (REP 105), the robot's body. Some
    drivers publish it in the world frame instead (``child_frame_id`` empty or a
    fixed frame, or mislabelled): then its linear part turns with the heading, and
    linear.x is the speed times cos(heading). It is turned into the body frame
    with the pose's heading when the frame ids say so, or when the twist has a
    large sideways part that the rotation removes; refused when that is not
    possible."""
    frame, child = (f.strip().lstrip("/") for f in od.frames)
    said_world = child == "" or child == frame or child in _WORLD_FRAMES
    c, s_ = np.cos(od.yaw), np.sin(od.yaw)
    ub, lat_b = c * od.u + s_ * od.vy, -s_ * od.u + c * od.vy
    size = max(float(np.sqrt(np.mean(od.u ** 2 + od.vy ** 2))), 1e-12)
    side_given = float(np.sqrt(np.mean(od.vy ** 2))) / size
    side_body = float(np.sqrt(np.mean(lat_b ** 2))) / size
    turned = float(np.ptp(np.unwrap(od.yaw))) if od.yaw.size else 0.0
    body_ok, world_ok = side_given <= _SIDEWAYS, side_body <= _SIDEWAYS
    if body_ok and (not said_world or not world_ok):
        # in the robot's frame (whatever the label says, if turning it would not be)
        return od.u, od.w, None
    why = (f"its child_frame_id is {child!r}" if said_world else
           f"its sideways speed linear.y is {100 * side_given:.0f} % of the speed, which "
           f"a differential-drive robot cannot have in its own frame")
    if world_ok:
        return ub, od.w, (f"bag {path}: the odometry on {odom_name} gives its twist in "
                          f"the world frame ({why}); turned into the robot's frame with "
                          f"the pose's heading (heading range {turned:.2g} rad)")
    raise ValidationError(
        f"bag {path}: the odometry on {odom_name} gives its twist in the world frame "
        f"{frame or child or '?'!r} ({why}), and its pose's heading does not turn it into "
        f"the robot's frame (base_link): publish the twist in the robot's frame "
        f"(REP 105), or record /joint_states and pass the wheel radius and separation")


def read_bag(path, cmd: str | None = None, odom: str | None = None,
             cmd_timeout: float | None = None, wheel_radius: float | None = None,
             wheel_separation: float | None = None, wheel_joints=None) -> dict:
    """Read a ROS recording of a robot as an identification log.

    :param path: a ROS 2 bag folder (sqlite3 or MCAP), a single ``.mcap`` (or
        ``.db3``) file, or a ROS 1 ``.bag`` file
    :param cmd: the command topic; default the bag's one topic of type
        ``geometry_msgs/Twist`` or ``TwistStamped``
    :param odom: the odometry topic; default the bag's one ``nav_msgs/Odometry``
        topic
    :param cmd_timeout: seconds after the last command at which the robot's
        driver stops it (command zero until the next one), > 0; default None:
        each command is held until the next
    :param wheel_radius: r, m: with ``wheel_separation``, the measured velocities
        are read from the wheel speeds wL, wR (rad/s) of a
        ``sensor_msgs/JointState`` topic (``/joint_states``, as ros2_control's
        joint_state_broadcaster publishes; ``odom`` names it when there are
        several) instead of odometry: u = r (wL + wR) / 2, w = r (wR - wL) / D
    :param wheel_separation: D, m, the distance between the wheels' contact points
    :param wheel_joints: (left, right) joint names; default the one joint whose
        name holds "left" and the one whose name holds "right" (preferring names
        with "wheel")
    :raises unidyn.MissingDependency: without the rosbags package (``pip install
        "unidyn[ros]"``)
    :raises ValidationError: one line naming the file and what is wrong: not a
        bag, unreadable (truncated or corrupt), no command or odometry topic (or
        several, listed with type, message count and rate), an empty topic, or
        too short to identify
    :return: a dict of float arrays t (s, from the first command), u_ref, w_ref
        (m/s, rad/s: the commands as held over each row's interval, see the
        module's notes), u, w (m/s, rad/s: the odometry), as
        :func:`~unidyn.identification.load_log` returns, plus ``"gap"`` (s, the
        recording-gap threshold :func:`identify` uses), ``"stamp_jitter"`` (0:
        samples are at their header stamps), ``"source"``
        (the path), ``"cmd_topic"``, ``"cmd_type"``, ``"odom_topic"``, ``"cmd_why"``
        and ``"odom_why"`` (why these topics were read),
        ``"cmd_timeout"`` and ``"t0"`` (the first command's time, ns since the
        epoch)

    Example::

        >>> log = read_bag("run1/")                          # doctest: +SKIP
        >>> res = identify(log)                              # doctest: +SKIP
    """
    path = Path(os.fspath(path))
    if cmd_timeout is not None:
        cmd_timeout = positive("cmd_timeout", cmd_timeout)
    for flag, v in (("cmd", cmd), ("odom", odom)):
        if v is not None and (not isinstance(v, str) or not v.strip()):
            raise ValidationError(f"{flag} must be a topic name such as /cmd_vel, got {v!r}")
    wheels = _wheels(wheel_radius, wheel_separation, wheel_joints)
    _check_path(path)
    AnyReader, typestore = _rosbags()
    try:
        with AnyReader([path], default_typestore=typestore) as reader:
            topics = reader.topics
            duration = reader.duration * 1e-9 if reader.message_count else 0.0
            cmd_name, cmd_why = _choose(path, topics, cmd, COMMAND_TYPES, "the commands",
                                        "--cmd", duration)
            odom_name, odom_why = _choose(
                path, topics, odom, (JOINT_STATE_TYPE,) if wheels else (ODOMETRY_TYPE,),
                "the measured velocities", "--odom", duration)
            cmd_type = topics[cmd_name].msgtype
            data = _read_messages(path, reader, cmd_name, odom_name, wheels)
    except (ValidationError, MissingDependency, KeyboardInterrupt, MemoryError):
        raise
    except Exception as err:  # noqa: BLE001 - a damaged file fails in many ways
        reason = " ".join(str(err).split()) or type(err).__name__
        hint = " (a ROS 1 bag cut short needs 'rosbag reindex')" \
            if path.suffix.lower() == ".bag" else ""
        raise ValidationError(f"bag {path} cannot be read, truncated or corrupt?{hint}: "
                              f"{reason[:200]}") from None
    cmds, od = data
    if wheels:
        uo, wo = od.u, od.w
        odom_why += (f"; u = r (wL + wR) / 2, w = r (wR - wL) / D from joints "
                     f"{od.frames[0]} (left), {od.frames[1]} (right), r = {wheels[0]:g} m, "
                     f"D = {wheels[1]:g} m")
    else:
        uo, wo, note = _body_twist(path, odom_name, od)
        if note:
            warnings.warn(note, IdentificationWarning, stacklevel=2)
    _check_clocks(path, cmd_name, odom_name, cmds, od)
    return _log_from_messages(path, cmds.t, cmds.u, cmds.w, od.t, od.received, uo, wo,
                              cmds.stamped, cmd_timeout,
                              {"cmd_topic": cmd_name, "cmd_type": cmd_type,
                               "odom_topic": odom_name, "cmd_why": cmd_why,
                               "odom_why": odom_why})


def _clock_name(ns) -> str:
    """What clock a time (ns) is most likely on."""
    s = float(ns) * 1e-9
    if s > 1e9:      # after 2001: the wall clock
        import datetime
        when = datetime.datetime.fromtimestamp(s, datetime.timezone.utc)
        return f"the wall clock ({when:%Y-%m-%d %H:%M:%S} UTC)"
    return f"a clock from zero such as simulation time ({s:.1f} s)"


def _check_clocks(path, cmd_name, odom_name, cmds, od):
    """Refuse stamped commands and odometry whose stamps do not overlap in time:
    they are on different clocks (one on the wall clock, one on simulation
    time, as when use_sim_time is set on one node only)."""
    if not cmds.stamped or cmds.t.size < 2 or od.t.size < 2:
        return
    a0, a1, b0, b1 = int(cmds.t.min()), int(cmds.t.max()), int(od.t.min()), int(od.t.max())
    if a0 <= b1 and b0 <= a1:
        return
    raise ValidationError(
        f"bag {path}: the stamps of the commands on {cmd_name} and of the odometry on "
        f"{odom_name} do not overlap in time: the commands are stamped on "
        f"{_clock_name(a0)}, the odometry on {_clock_name(b0)}; the nodes stamp on "
        f"different clocks (use_sim_time set on one of them only?): stamp both on one "
        f"clock")


def _log_from_messages(path, tc, uc, wc, to, tr, uo, wo, stamped, cmd_timeout, meta) -> dict:
    """The log of the commands (times tc ns) and odometry (stamps to ns, received
    tr ns): see :func:`read_bag`."""
    cmd_name, odom_name = meta["cmd_topic"], meta["odom_topic"]
    for name, arr in ((cmd_name, tc), (odom_name, to)):
        if arr.size < 2:
            raise ValidationError(f"bag {path}: topic {name} holds {arr.size} message(s); "
                                  f"too short to identify")
    # the recorder's clock against the odometry's stamps (a simulator's clock in the
    # stamps, the wall clock in the bag): unstamped commands moved onto the stamps' clock
    offset = int(np.median(tr - to))
    if not stamped and abs(offset) > _CLOCK_OFFSET * 1e9:
        warnings.warn(f"bag {path}: the odometry's stamps are {offset * 1e-9:.3g} s from the "
                      f"times it was recorded (another clock, e.g. simulation time); the "
                      f"unstamped commands of {cmd_name} are moved onto the stamps' clock "
                      f"by that much", IdentificationWarning, stacklevel=3)
        tc = tc - offset
    # time order; a later message with the same stamp replaces an earlier command and
    # repeats an odometry sample
    oc = np.argsort(tc, kind="stable")
    tc, uc, wc = tc[oc], uc[oc], wc[oc]
    keep = np.append(tc[1:] != tc[:-1], True)
    tc, uc, wc = tc[keep], uc[keep], wc[keep]
    oo = np.argsort(to, kind="stable")
    to, uo, wo = to[oo], uo[oo], wo[oo]
    keep = np.insert(to[1:] != to[:-1], 0, True)
    to, uo, wo = to[keep], uo[keep], wo[keep]
    bad = ~(np.isfinite(uc) & np.isfinite(wc))
    if bad.any():
        raise ValidationError(f"bag {path}: {int(bad.sum())} command(s) on {cmd_name} are "
                              f"NaN or inf")
    bad = ~(np.isfinite(uo) & np.isfinite(wo))
    if bad.any():
        raise ValidationError(f"bag {path}: {int(bad.sum())} odometry message(s) on "
                              f"{odom_name} hold NaN or inf velocities")
    t0 = int(tc[0])
    c_t = (tc - t0) * 1e-9
    o_t = (to - t0) * 1e-9
    if c_t.size < 2:
        raise ValidationError(f"bag {path}: topic {cmd_name} holds one distinct command; too "
                              f"short to identify")
    period = float(np.median(np.diff(c_t)))
    gap = GAP_PERIODS * period
    # recording gaps: no message of either topic for GAP_PERIODS command periods
    every = np.union1d(c_t, o_t)
    steps = np.diff(every)
    gaps = [(float(every[i]), float(every[i + 1])) for i in np.flatnonzero(steps > gap)]
    # odometry rows are usable once a command is in force: after the first command,
    # and after each gap from the first command following it
    usable = o_t >= c_t[0]
    for _, end in gaps:
        j = np.searchsorted(c_t, end, "left")
        first = c_t[j] if j < c_t.size else math.inf
        usable &= ~((o_t >= end) & (o_t < first))
    t, u, w = o_t[usable], uo[usable], wo[usable]
    if t.size < _MIN_ROWS or c_t.size < _MIN_ROWS:
        raise ValidationError(
            f"bag {path}: too short to identify: {c_t.size} command(s) on {cmd_name} over "
            f"{c_t[-1] - c_t[0]:.3g} s and {t.size} odometry message(s) on {odom_name} while "
            f"commands were known; at least {_MIN_ROWS} of each are needed, and an accurate "
            f"estimate needs a minute or more of varied commands")
    u_ref = held_mean(c_t, uc, t, cmd_timeout)
    w_ref = held_mean(c_t, wc, t, cmd_timeout)
    check_measured(u_ref, w_ref, u, w, f"bag {path}: {odom_name}")
    return {"t": t, "u_ref": u_ref, "w_ref": w_ref, "u": u, "w": w, "gap": gap,
            "stamp_jitter": 0.0, "source": str(path), **meta, "cmd_timeout": cmd_timeout, "t0": t0,
            "commands": {"t": c_t, "u_ref": uc, "w_ref": wc, "stamped": bool(stamped)}}


def held_mean(c_t, c, t, timeout=None) -> np.ndarray:
    """The commands a robot applied, as held values over the intervals of other
    sample times: for each [t[k], t[k+1]) the mean of the command signal that
    holds c[j] from c_t[j] until c_t[j+1] (until c_t[j] + ``timeout`` with a
    timeout, zero after), computed exactly from its piecewise-linear integral;
    for the last sample the command in force at t[-1].

    :param c_t: command times, s, increasing
    :param c: the commands (one of u_ref, m/s, or w_ref, rad/s), same length
    :param t: sample times, s, increasing, none before c_t[0]
    :param timeout: seconds after a command at which it stops acting, or None
    """
    span = np.diff(c_t)
    if timeout is not None:
        span = np.minimum(span, timeout)
    F = np.concatenate([[0.0], np.cumsum(c[:-1] * span)])     # integral up to c_t[j]
    j = np.searchsorted(c_t, t, "right") - 1
    since = t - c_t[j]
    active = since if timeout is None else np.minimum(since, timeout)
    G = F[j] + c[j] * active                                  # integral up to t
    out = np.empty(t.size)
    out[:-1] = np.diff(G) / np.diff(t)
    out[-1] = c[j[-1]] if timeout is None or since[-1] < timeout else 0.0
    return out



def held_weighted(c_t, c, t, tau, timeout=None) -> np.ndarray:
    """Like :func:`held_mean`, the commands over the intervals [t[k], t[k+1]) of
    other sample times, but each the mean weighted by exp(-(t[k+1] - s) / tau):
    the held value that brings a first-order response of time constant ``tau``
    (s) to the same value at t[k+1] as the commands as applied. The plain mean
    is this for tau much longer than the interval; for an interval of a sixth
    of tau (30 Hz odometry, tau = 0.2 s) the plain mean is off by about
    (dt / tau)^2 / 8 = 0.3 % of a command step, which biases theta1 and theta2
    by more than their standard errors in a long log. ``tau`` = inf gives
    :func:`held_mean`."""
    if not np.isfinite(tau) or tau <= 0:
        return held_mean(c_t, c, t, timeout)
    bp = [c_t, t] + ([c_t + timeout] if timeout is not None else [])
    bp = np.unique(np.concatenate(bp))
    bp = bp[(bp >= t[0]) & (bp <= t[-1])]
    a, b = bp[:-1], bp[1:]
    row = np.searchsorted(t, a, "right") - 1
    j = np.searchsorted(c_t, a, "right") - 1
    val = c[j]
    if timeout is not None:
        val = np.where(a < c_t[j] + timeout, val, 0.0)
    # the integral of exp((s - t[k+1]) / tau) over [a, b), exponents <= 0
    wgt = -tau * np.exp((b - t[row + 1]) / tau) * np.expm1(-(b - a) / tau)
    num = np.bincount(row, wgt * val, minlength=t.size - 1)
    den = np.bincount(row, wgt, minlength=t.size - 1)
    out = held_mean(c_t, c, t, timeout)        # its last sample: the command in force
    out[:-1] = num[:t.size - 1] / den[:t.size - 1]
    return out


def row_commands(recorded, theta, lags=None):
    """u_ref, w_ref of the rows of logs read from bags, from their commands as
    recorded (each delayed by ``lags``, one array per log, s), each row's held value
    weighted by the response of time constant theta1/theta4 (u) or theta2/theta6
    (w): see :func:`~unidyn.identification.bags.held_weighted`."""
    tau_u = theta[0] / theta[3] if theta[3] > 0 else math.inf
    tau_w = theta[1] / theta[5] if theta[5] > 0 else math.inf
    out = {"u_ref": [], "w_ref": []}
    for k, log in enumerate(recorded):
        c = log["commands"]
        c_t = c["t"] if lags is None else np.sort(c["t"] + lags[k])
        for key, tau in (("u_ref", tau_u), ("w_ref", tau_w)):
            out[key].append(held_weighted(c_t, c[key], log["t"], tau, log.get("cmd_timeout")))
    return {k: np.concatenate(v) for k, v in out.items()}
