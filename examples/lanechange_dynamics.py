"""A lane change with real dynamics: RVC3's lanechange.py (Fig. 4.5) as the authors'
MATLAB package drives it (sl_lanechange_unicycle_dynamics), with DYNAMICUNICYCLE.

RVC3's diagram steers a kinematic bicycle open loop: a constant speed and a steering
pulse. The authors' package does the same to their dynamic unicycle: a speed command of
1 m/s (held to the Pioneer's 0.75 m/s by its limits) and an angular-velocity command of
+0.5 rad/s from 3 s to 6 s and -0.5 rad/s from 9 s to 12 s. Here the same commands
drive the Pioneer 3-DX of the paper's Table 1, with the paper's limits, through
bdsim's own source blocks, as in RVC3's script:

    python examples/lanechange_dynamics.py

It prints where the robot ends and how far its velocities lag the commands (the
dynamics a kinematic model leaves out), and saves the path to out/lanechange.png. tests/test_examples.py checks the path against an independent
integration of Eqs. (1)-(2).
"""

import numpy as np

import unidyn  # noqa: F401  (unidyn's blocks for bdsim)
from unidyn.diagrams import new_simulator

T = 16.0  # s: the commands' one period, 17 s in the package, less its last idle second
#: (time s, angular-velocity command rad/s): the package's repeating staircase, one step a second
STEERING = [(0.0, 0.0), (3.0, 0.5), (6.0, 0.0), (9.0, -0.5), (12.0, 0.0)]


def lanechange(T=T, limits=unidyn.PAPER_LIMITS):
    """Build and run the diagram; returns (t, pose q (N, 3), velocity (N, 2))."""
    sim = new_simulator()
    bd = sim.blockdiagram()
    speed = bd.CONSTANT(1.0, name="speed")
    steering = bd.PIECEWISE(seq=STEERING, name="steering")
    vehicle = bd.DYNAMICUNICYCLE(robot="p3dx_laser", a=0.2, x0=[0.0, 0.0, 0.0],
                                 limits=limits, velocity_output=True,
                                 name="vehicle")
    bd.connect(speed, vehicle[0])
    bd.connect(steering, vehicle[1])
    bd.NULL(nin=2, inputs=[vehicle.q, vehicle.velocity], name="watched")  # logged only
    bd.compile()
    out = sim.run(bd, T=T, dt=0.05, watch=[vehicle.q, vehicle.velocity],
                  solver_args=dict(rtol=1e-8, atol=1e-10, max_step=0.05))
    y = np.asarray(out.y)  # the watched signals' columns: x, y, psi, then u, w
    return np.asarray(out.t), y[:, :3], y[:, 3:5]


def main() -> int:
    t, q, v = lanechange()
    print(f"after {t[-1]:g} s: h = ({q[-1, 0]:.3f}, {q[-1, 1]:.3f}) m, "
          f"heading {q[-1, 2]:.3f} rad; the lane moved by {q[-1, 1]:.3f} m")
    lag = t[np.argmax(v[:, 1] > 0.45)] - 3.0
    print(f"the angular velocity reaches 90 % of its 0.5 rad/s command {lag:.2f} s after it")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(6, 2.5), layout="constrained")
    ax.plot(q[:, 0], q[:, 1])
    ax.set(xlabel="x (m)", ylabel="y (m)", title="lane change, dynamic unicycle (Pioneer 3-DX)")
    ax.set_aspect("equal")
    from pathlib import Path
    path = Path("out") / "lanechange.png"
    path.parent.mkdir(exist_ok=True)
    fig.savefig(path, dpi=150)
    print(f"written {path}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
