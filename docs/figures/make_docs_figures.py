"""Draw the figures of the documentation that show what the code does, at build time.

    python docs/figures/make_docs_figures.py [OUT_FOLDER]

The Sphinx build calls :func:`main` with ``docs/_generated``; each figure takes well
under a second (the model's equations only, integrated by scipy), and a figure is
drawn again only when it is missing or this script is newer.

- ``step_responses.png``: every preset robot's velocities after a step of its
  commands from rest (u_ref = 0.3 m/s, w_ref = 0.5 rad/s), Eq. (2) as
  :func:`unidyn.model.unicycle.dynamics` computes it.
"""

import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from scipy.integrate import solve_ivp  # noqa: E402

from unidyn.results import figstyle
from unidyn.model import unicycle as model, robots  # noqa: E402

U_REF, W_REF = 0.3, 0.5  # m/s, rad/s


def step_responses(path: Path) -> None:
    t_eval = np.linspace(0.0, 3.0, 301)
    with figstyle.style():
        fig, (ax_u, ax_w) = plt.subplots(1, 2, figsize=(7.0, 2.6), sharex=True)
        for name in robots.names():
            theta = robots.get(name).theta
            sol = solve_ivp(lambda t, v: model.dynamics(v, (U_REF, W_REF), theta),
                            (0.0, 3.0), [0.0, 0.0], t_eval=t_eval, rtol=1e-8, atol=1e-10)
            ax_u.plot(sol.t, sol.y[0], label=name)
            ax_w.plot(sol.t, sol.y[1])
        ax_u.set_xlabel("t (s)")
        ax_w.set_xlabel("t (s)")
        ax_u.set_ylabel("u (m/s)")
        ax_w.set_ylabel("ω (rad/s)")
        ax_u.set_title(f"step of u_ref to {U_REF} m/s")
        ax_w.set_title(f"step of ω_ref to {W_REF} rad/s")
        fig.legend(loc="outside right center")
        fig.savefig(path)
        plt.close(fig)


FIGURES = {"step_responses.png": step_responses}


def main(out) -> None:
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    newest = Path(__file__).stat().st_mtime
    for name, draw in FIGURES.items():
        path = out / name
        if not path.exists() or path.stat().st_mtime < newest:
            draw(path)


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else Path(__file__).resolve().parents[1] / "_generated")
