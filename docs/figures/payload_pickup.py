"""Make docs/figures/payload_pickup.png and payload_sweep.png (docs/guides/payload.md):
a robot on the paper's figure eight picks up a load of twice its mass at t = 100 s,
under the kinematic controller, exact compensation for the empty robot and adaptive
compensation; and the IAE over the last 25 s against the load's mass.

    python docs/figures/payload_pickup.py [--out docs/figures]
"""

import argparse
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from unidyn.engine.batch import simulate_batch  # noqa: E402
from unidyn.results import figstyle  # noqa: E402
from unidyn.teaching.payload import (PICKUP_CONTROLLERS, pickup_iae, pickup_scenarios,  # noqa: E402
                                     pickup_sweep, plot_pickup)

MASSES = [1.0, 1.25, 1.5, 2.0, 2.5, 3.0]


def main(out: Path) -> None:
    scs = pickup_scenarios(mass=2.0, at=100.0)
    results = dict(zip(scs, simulate_batch(list(scs.values()), progress=False)))
    plot_pickup(results, out / "payload_pickup.png", at=100.0)
    for case, (before, after) in pickup_iae(results, at=100.0).items():
        print(f"{case:14s} IAE 75-100 s {before:.3f} m·s, 175-200 s {after:.3f} m·s")
    iae = pickup_sweep(MASSES)
    with figstyle.style():
        fig, ax = plt.subplots(figsize=figstyle.size(1, 0.8))
        for case, desc in PICKUP_CONTROLLERS.items():
            ax.plot(MASSES, iae[case], "o-", ms=3, label=desc)
        ax.set_xlabel("load: mass / empty robot's mass")
        ax.set_ylabel("IAE over 175-200 s (m·s)")
        figstyle.legend(ax, outside="below")
        figstyle.save(fig, out / "payload_sweep.png")
    for i, m in enumerate(MASSES):
        print(f"mass x{m:g}: " + ", ".join(f"{c} {iae[c][i]:.3f}" for c in PICKUP_CONTROLLERS))


if __name__ == "__main__":
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--out", type=Path, default=Path(__file__).parent)
    main(p.parse_args().out)
