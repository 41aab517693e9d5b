"""Make docs/figures/theta_hat_10000s.png: theta_hat / theta over 10,000 s of adaptive
compensation with the paper's gamma, Sigma and noise, update from t = 0, for the three
leakage forms, on the figure eight and on a circle (the runs of
examples/06_long_runs.ipynb).

    python docs/figures/theta_hat_10000s.py [--out docs/figures/theta_hat_10000s.png]

theta3 (true value -0.0005, near zero) is left out: its ratio says nothing.
"""

import argparse
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import unidyn  # noqa: E402
from unidyn.results import figstyle  # noqa: E402
from unidyn.engine.batch import simulate_batch  # noqa: E402
from unidyn.model.trajectories import Circle  # noqa: E402

T = 10_000.0
CIRCLE = Circle(radius=1.0, omega=0.2, center=(0.0, -1.0), phase=np.pi / 2)  # through (0, 0)
REFERENCES = {"figure eight": "figure_eight", "circle": CIRCLE}
LEAKAGES = {"paper": ("C0", r"Eq. (20), $-\gamma\Sigma\hat\theta$ (paper)"),
            "fx44850": ("C2", r"$-\Sigma\hat\theta$ (FX44850)"),
            "none": ("C3", "Eq. (18), no leakage")}
PARAMS = (0, 1, 3, 4, 5)


@figstyle.styled
def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--out", default=str(Path(__file__).with_suffix(".png")))
    args = p.parse_args(argv)
    theta = unidyn.model.robots.get("p3dx_laser").theta
    keys = [(ref, lk) for ref in REFERENCES for lk in LEAKAGES]
    scenarios = [unidyn.Scenario.paper(4, T=T, adapt_from=0.0, leakage=lk,
                                       trajectory=REFERENCES[ref]) for ref, lk in keys]
    runs = dict(zip(keys, simulate_batch(scenarios)))
    fig, axes = plt.subplots(2, len(PARAMS), figsize=(figstyle.PAGE, 3.6), sharex=True,
                             sharey=True)
    for row, ref in enumerate(REFERENCES):
        for col, i in enumerate(PARAMS):
            ax = axes[row, col]
            for lk, (color, name) in LEAKAGES.items():
                r = runs[(ref, lk)]
                ax.plot(r.t[1:], r.theta_hat[1:, i] / theta[i], color=color, lw=0.9, label=name)
            ax.axhline(1.0, **figstyle.REFERENCE, label="true value")
            ax.set_xscale("log")
            figstyle.plain_log_axis(ax, "y")
            ax.set(xlim=(1, T), ylim=(0.3, 50))
            ax.set_xticks([1, 10, 100, 1000, 10000], labels=["1", "10", "100", "1000", "10⁴"])
            if row == 0:
                ax.set_title(rf"$\hat\theta_{i + 1}/\theta_{i + 1}$ ($\theta_{i + 1}$ = "
                             f"{theta[i]:.3g})")
            else:
                ax.set_xlabel(figstyle.label("t", "s"))
        axes[row, 0].set_ylabel(f"{ref}\n" + r"$\hat\theta_i\,/\,\theta_i$")
    handles, labels = axes[0, 0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="outside upper center", ncol=4, frameon=False)
    figstyle.save(fig, args.out)
    print(f"written {args.out}")


if __name__ == "__main__":
    main()
