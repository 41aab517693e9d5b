"""Draw bdedit's icons for unidyn's blocks with matplotlib.

    python tools/make_icons.py            # into src/unidyn/blocks/Icons/
    python tools/make_icons.py OUT_DIR

bdedit shows a block's icon from ``<blocks folder>/Icons/<block type in lower
case>.png`` (``bdedit.block_importer.import_blocks``), drawn 50 px square from a
250 x 250 px image; bdsim's icons are black ink on a transparent background
(``bdsim/blocks/Icons/README.md``). These follow that style: the paper's Fig. 2
letters K, D, R for the controller, the compensator and the robot, a robot seen
from above, the reference paths, and held noise.
"""

import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.patches import Circle, FancyArrowPatch, Rectangle  # noqa: E402

SIZE = 250  # px
LW = 14     # line width in points at 100 dpi: about 7 px at bdedit's 50 px
INK = "black"


def _canvas():
    fig = plt.figure(figsize=(SIZE / 100, SIZE / 100), dpi=100)
    ax = fig.add_axes([0, 0, 1, 1])
    ax.set_xlim(0, 1)
    ax.set_ylim(0, 1)
    ax.set_aspect("equal")
    ax.axis("off")
    return fig, ax


def _robot(ax, cx=0.5, cy=0.5, r=0.3, dynamic=True):
    """A differential-drive robot seen from above, heading right, with the point h ahead."""
    ax.add_patch(Circle((cx, cy), r, fill=False, lw=LW * 0.6, ec=INK))
    for s in (-1, 1):  # wheels
        ax.add_patch(Rectangle((cx - 0.14, cy + s * r - 0.05), 0.28, 0.10, color=INK))
    ax.plot([cx, cx + r + 0.12], [cy, cy], color=INK, lw=LW * 0.4)
    ax.add_patch(Circle((cx + r + 0.12, cy), 0.05, color=INK))
    if dynamic:  # the dynamics of Eq. (2), theta
        ax.text(cx - 0.12, cy, r"$\theta$", ha="center", va="center", fontsize=60, color=INK)


def _letter(ax, text, size=130, y=0.5):
    ax.text(0.5, y, text, ha="center", va="center", fontsize=size, color=INK,
            fontweight="bold", family="DejaVu Sans")


def _badge(ax, text, x=0.82, y=0.2, size=44):
    ax.text(x, y, text, ha="center", va="center", fontsize=size, color=INK)


def _clock(ax, x=0.82, y=0.82, r=0.13):
    ax.add_patch(Circle((x, y), r, fill=False, lw=LW * 0.4, ec=INK))
    ax.plot([x, x], [y, y + r * 0.7], color=INK, lw=LW * 0.35)
    ax.plot([x, x + r * 0.55], [y, y], color=INK, lw=LW * 0.35)


def _held_noise(ax, seed=3, x0=0.08, x1=0.92, y=0.5, amp=0.3, n=9):
    rng = np.random.default_rng(seed)
    xs = np.linspace(x0, x1, n + 1)
    ys = y + amp * np.clip(rng.standard_normal(n) / 1.5, -1, 1)
    ax.step(xs, np.r_[ys, ys[-1]], where="post", color=INK, lw=LW * 0.5)


def robot_dynamic(ax):
    _robot(ax)


def robot_dynamic_velocity(ax):
    _robot(ax, cx=0.42)
    _badge(ax, r"$v$", x=0.85, y=0.15, size=56)


def robot_kinematic(ax):
    _robot(ax, dynamic=False)


def controller(ax):
    _letter(ax, "K")


def controller_rate(ax):
    _letter(ax, "K", y=0.55)
    _badge(ax, r"$\dot v_d$", x=0.8, y=0.14)


def controller_sampled(ax):
    _letter(ax, "K")
    _clock(ax)


def compensator(ax):
    _letter(ax, "D")


def compensator_rate(ax):
    _letter(ax, "D", y=0.55)
    _badge(ax, r"$\dot v_d$", x=0.2, y=0.14)


def compensator_sampled(ax):
    _letter(ax, "D")
    _clock(ax)


def figure_eight(ax):
    t = np.linspace(0, 2 * np.pi, 300)
    ax.plot(0.5 + 0.4 * np.sin(t), 0.5 + 0.28 * np.sin(2 * t), color=INK, lw=LW * 0.55)


def circle(ax):
    ax.add_patch(Circle((0.5, 0.5), 0.34, fill=False, lw=LW * 0.55, ec=INK))
    ax.add_patch(FancyArrowPatch((0.84, 0.46), (0.84, 0.6), arrowstyle="-|>", mutation_scale=70,
                                 color=INK, lw=0))


def line(ax):
    ax.add_patch(FancyArrowPatch((0.1, 0.2), (0.9, 0.8), arrowstyle="-|>", mutation_scale=70,
                                 color=INK, lw=LW * 0.55))


def point(ax):
    ax.plot([0.5, 0.5], [0.12, 0.88], color=INK, lw=LW * 0.3)
    ax.plot([0.12, 0.88], [0.5, 0.5], color=INK, lw=LW * 0.3)
    ax.add_patch(Circle((0.5, 0.5), 0.2, fill=False, lw=LW * 0.55, ec=INK))


def segment(ax):
    ax.plot([0.1, 0.78], [0.2, 0.72], color=INK, lw=LW * 0.55)
    ax.add_patch(Circle((0.78, 0.72), 0.1, color=INK))


def trajectory(ax):
    t = np.linspace(0.0, 1.0, 200)
    ax.plot(0.1 + 0.8 * t, 0.5 + 0.25 * np.sin(2 * np.pi * t) * (1 - 0.3 * t), color=INK, lw=LW * 0.55)
    _badge(ax, r"$h_d$", x=0.5, y=0.12, size=50)


def noise(ax):
    _held_noise(ax)


def noise_named_clock(ax):
    _held_noise(ax, y=0.42, amp=0.25)
    _clock(ax)


#: icon file stem (bdedit's rule: the block type in lower case) -> drawing
ICONS = {
    "dynamicunicycle": robot_dynamic,
    "dynamicunicyclewithvelocity": robot_dynamic_velocity,
    "kinematicunicycle": robot_kinematic,
    "kinematiccontroller": controller,
    "kinematiccontrollerwithrate": controller_rate,
    "sampledkinematiccontroller": controller_sampled,
    "dynamiccompensator": compensator,
    "dynamiccompensatorwithrateinput": compensator_rate,
    "sampleddynamiccompensator": compensator_sampled,
    "figureeight": figure_eight,
    "circle": circle,
    "line": line,
    "point": point,
    "segment": segment,
    "trajectorysource": trajectory,
    "measurementnoise": noise,
    "sensornoise": noise_named_clock,
}


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    folder = (Path(argv[0]) if argv else
              Path(__file__).resolve().parents[1] / "src" / "unidyn" / "blocks" / "Icons")
    folder.mkdir(parents=True, exist_ok=True)
    for stem, draw in ICONS.items():
        fig, ax = _canvas()
        draw(ax)
        path = folder / f"{stem}.png"
        fig.savefig(path, dpi=100, transparent=True)
        plt.close(fig)
        print(path)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
