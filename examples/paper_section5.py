"""Reproduce Section 5 of Martins et al. (2017): the four simulations of Figs. 3-10.

Runs the paper's four cases through the bdsim diagram of Fig. 2, writes each
run's time series, summary and figures, a side-by-side figure of the four
cases, and prints the paper's claims beside the measured numbers.

    python examples/paper_section5.py --out out/section5
"""

import argparse
import time
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

import unidyn  # noqa: E402
from unidyn.paper import format_claims, section5_claims  # noqa: E402
from unidyn.plots import save_figures  # noqa: E402

TITLES = {1: "kinematic robot (Figs. 3-4)", 2: "dynamic robot, no compensation (Figs. 5-6)",
          3: "exact compensation (Figs. 7-8)", 4: "adaptive compensation (Figs. 9-10)"}


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--out", default="out/section5", help="output folder")
    p.add_argument("--T", type=float, default=200.0, help="duration, s (paper: 200)")
    args = p.parse_args(argv)
    out = Path(args.out)
    results = {}
    for n in (1, 2, 3, 4):
        t0 = time.perf_counter()
        sc = unidyn.Scenario.paper(n, T=args.T)
        r = unidyn.simulate(sc)
        results[n] = r
        folder = out / f"case{n}_{sc.case}"
        r.save(folder)
        save_figures(r, folder)
        print(f"case {n} {sc.case:14s} IAE = {r.metrics['iae']:7.3f} m·s   "
              f"final error = {r.error[-1]:.4f} m   ({time.perf_counter() - t0:.1f} s)")

    # Figs. 3, 5, 7, 9(b) side by side, and Fig. 9(a): before / after updating
    fig, axes = plt.subplots(2, 4, figsize=(16, 7))
    for n, r in results.items():
        r.plot_path(ax=axes[0, n - 1])
        axes[0, n - 1].set_title(TITLES[n], fontsize=9)
        r.plot_error(ax=axes[1, n - 1])
        axes[1, n - 1].set_ylim(0, 0.8)
    fig.tight_layout()
    fig.savefig(out / "section5.png", dpi=100)
    plt.close(fig)

    r4 = results[4]
    t_on = r4.scenario.adapt_from
    fig, axes = plt.subplots(1, 3, figsize=(14, 4))
    for ax, (lo, hi, title) in zip(axes[:2], ((0, t_on, "before parameter updating"),
                                              (t_on, r4.t[-1], "after parameter updating"))):
        m = (r4.t >= lo) & (r4.t <= hi)
        ax.plot(r4.reference[m, 0], r4.reference[m, 1], "k--", lw=1, label="reference")
        ax.plot(r4.pose[m, 0], r4.pose[m, 1], lw=1, label="actual")
        ax.set_title(title)
        ax.set_aspect("equal", adjustable="datalim")
        ax.legend(fontsize="small")
    r4.plot_error(ax=axes[2])
    axes[2].axvline(t_on, color="k", lw=0.8, ls=":")
    fig.tight_layout()
    fig.savefig(out / "fig9_adaptive.png", dpi=100)
    plt.close(fig)

    if args.T >= 200:
        claims = section5_claims(*(results[n] for n in (1, 2, 3, 4)))
        table = format_claims(claims)
        (out / "claims.md").write_text(table + "\n")
        print()
        print(table)
    print(f"\nfigures and data in {out}/")


if __name__ == "__main__":
    main()
