"""Write src/unidyn/datasets/courier.mcap (unidyn.datasets.path("courier.mcap")): a ROS 2 recording (MCAP) of a simulated robot, as
`ros2 bag record -s mcap /cmd_vel /odom` would store it, for identification
examples.

The robot ("courier", none of the presets; theta below) is driven by the
library's excitation (unidyn.identification.excitation) sent as
geometry_msgs/Twist on /cmd_vel at 10 Hz with +-20 % jitter and 1-4 ms of
transport delay; its firmware holds each command until the next. Its odometry
(nav_msgs/Odometry on /odom, pose of the axle centre and velocities) is
measured at 30 Hz with +-20 % jitter, noise of std 0.01 m/s and 0.01 rad/s, and
stamped with the measurement time; it reaches the recorder 1-6 ms later. The
recording loses 3 s (nothing recorded from 32 s to 35 s). Eqs. (1)-(2)
are integrated by scipy's solve_ivp (DOP853) from one command to the next.

    python tools/make_sample_bag.py            # writes src/unidyn/datasets/courier.mcap
"""

from __future__ import annotations

import math
import os
import shutil
import tempfile
from pathlib import Path

import numpy as np
from rosbags.rosbag2 import CompressionFormat, CompressionMode, StoragePlugin, Writer
from rosbags.typesys import Stores, get_typestore
from scipy.integrate import solve_ivp

from unidyn import RobotParameters
from unidyn.model.equations import dynamics_components
from unidyn.identification import excitation

ROBOT = RobotParameters(0.38, 0.22, 0.01, 1.04, 0.03, 1.06, name="courier")
T = 60.0                      # s of commands
CMD_HZ, ODOM_HZ = 10.0, 30.0
NOISE = 0.01
LOST = (32.0, 35.0)           # s: nothing recorded
EPOCH_NS = 1_732_000_000 * 10**9
OUT = Path(__file__).resolve().parents[1] / "src" / "unidyn" / "datasets" / "courier.mcap"


def simulate(seed=7):
    rng = np.random.default_rng(seed)
    exc = excitation(T, 1.0 / CMD_HZ, robot=ROBOT, seed=seed)
    n = exc["t"].size
    t_cmd = exc["t"] + rng.uniform(-0.2, 0.2, n) / CMD_HZ + rng.uniform(0.001, 0.004, n)
    t_cmd[0] = 0.0
    t_odom = 0.02 + np.cumsum(rng.uniform(0.8, 1.2, int(T * ODOM_HZ * 1.2)) / ODOM_HZ)
    t_odom = t_odom[t_odom < t_cmd[-1]]
    th = ROBOT.theta
    state = np.zeros(5)                       # x, y, psi, u, w
    X = np.empty((t_odom.size, 5))
    ends = np.append(t_cmd[1:], t_cmd[-1] + 1.0)
    for j, (a, b) in enumerate(zip(t_cmd, ends)):
        cu, cw = exc["u_ref"][j], exc["w_ref"][j]

        def rhs(_, s):
            du, dw = dynamics_components(s[3], s[4], cu, cw, *th)
            return [s[3] * math.cos(s[2]), s[3] * math.sin(s[2]), s[4], du, dw]
        sel = np.flatnonzero((t_odom >= a) & (t_odom < b))
        sol = solve_ivp(rhs, (a, b), state, method="DOP853", rtol=1e-10, atol=1e-12,
                        t_eval=np.append(t_odom[sel], b))
        X[sel] = sol.y[:, :-1].T
        state = sol.y[:, -1]
    u = X[:, 3] + NOISE * rng.standard_normal(t_odom.size)
    w = X[:, 4] + NOISE * rng.standard_normal(t_odom.size)
    recv = t_odom + rng.uniform(0.001, 0.006, t_odom.size)
    return (t_cmd, exc["u_ref"], exc["w_ref"]), (t_odom, recv, X, u, w)


def write(path: Path, cmds, odom) -> None:
    (t_cmd, uc, wc), (t_odom, recv, X, u, w) = cmds, odom
    ts = get_typestore(Stores.ROS2_HUMBLE)
    T_ = ts.types
    Time, Header = T_["builtin_interfaces/msg/Time"], T_["std_msgs/msg/Header"]
    V3, Twist = T_["geometry_msgs/msg/Vector3"], T_["geometry_msgs/msg/Twist"]
    Point, Quat, Pose = (T_[f"geometry_msgs/msg/{k}"] for k in ("Point", "Quaternion", "Pose"))
    PC, TC = T_["geometry_msgs/msg/PoseWithCovariance"], T_["geometry_msgs/msg/TwistWithCovariance"]
    Odom = T_["nav_msgs/msg/Odometry"]
    ns = lambda s: EPOCH_NS + int(round(s * 1e9))  # noqa: E731
    lost = lambda s: LOST[0] <= s < LOST[1]        # noqa: E731
    events = sorted([(ns(s), 0, i) for i, s in enumerate(t_cmd) if not lost(s)]
                    + [(ns(s), 1, i) for i, s in enumerate(recv) if not lost(s)])
    cov = np.zeros(36)
    cov[0] = cov[7] = cov[35] = 1e-4
    tmp = Path(tempfile.mkdtemp(dir=path.parent))
    try:
        wr = Writer(tmp / path.stem, version=9, storage_plugin=StoragePlugin.MCAP)
        wr.set_compression(CompressionMode.STORAGE, CompressionFormat.ZSTD)  # zstd chunks
        with wr:
            cc = wr.add_connection("/cmd_vel", Twist.__msgtype__, typestore=ts)
            co = wr.add_connection("/odom", Odom.__msgtype__, typestore=ts)
            for t_ns, kind, i in events:
                if kind == 0:
                    msg = Twist(linear=V3(x=float(uc[i]), y=0.0, z=0.0),
                                angular=V3(x=0.0, y=0.0, z=float(wc[i])))
                    wr.write(cc, t_ns, ts.serialize_cdr(msg, Twist.__msgtype__))
                    continue
                st = ns(t_odom[i])
                x, y, psi = X[i, :3]
                msg = Odom(
                    header=Header(stamp=Time(sec=st // 10**9, nanosec=st % 10**9),
                                  frame_id="odom"), child_frame_id="base_link",
                    pose=PC(pose=Pose(position=Point(x=float(x), y=float(y), z=0.0),
                                      orientation=Quat(x=0.0, y=0.0, z=math.sin(psi / 2),
                                                       w=math.cos(psi / 2))), covariance=cov),
                    twist=TC(twist=Twist(linear=V3(x=float(u[i]), y=0.0, z=0.0),
                                         angular=V3(x=0.0, y=0.0, z=float(w[i]))),
                             covariance=cov))
                wr.write(co, t_ns, ts.serialize_cdr(msg, Odom.__msgtype__))
        os.replace(tmp / path.stem / f"{path.stem}.mcap", path)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


if __name__ == "__main__":
    cmds, odom = simulate()
    write(OUT, cmds, odom)
    print(f"wrote {OUT} ({OUT.stat().st_size / 1024:.0f} kB): {ROBOT.name}, theta = "
          f"{', '.join(f'{v:g}' for v in ROBOT.theta)}")
