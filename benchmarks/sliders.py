"""Redraw time of the live sliders (unidyn.teaching.widgets.LoopExplorer.update): one batch-engine
run of the paper's 200 s loop and the redraw of the path and error plots, for each
control the sliders move. Prints the median of several calls per row.

    MPLBACKEND=Agg python benchmarks/sliders.py [--repeat 5]
"""

import argparse
import os
import statistics
import time

import unidyn
from unidyn.engine import kernels as _kernels
from unidyn.teaching.widgets import LoopExplorer


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=5, help="calls per row (median reported)")
    args = ap.parse_args(argv)
    t0 = time.perf_counter()
    ex = LoopExplorer()  # the paper's case 4; compiles or loads the engine
    first = time.perf_counter() - t0
    moves = [("k = 1 (gain slider)", dict(k=1.0)), ("k = 0.1", dict(k=0.1)),
             ("payload x2", dict(payload=2.0)), ("payload x1", dict(payload=1.0)),
             ("noise off", dict(noise=False)), ("noise on", dict(noise=True)),
             ("case 1", dict(case=1)), ("case 2", dict(case=2)), ("case 3", dict(case=3)),
             ("case 4", dict(case=4))]
    rows = []
    for label, kw in moves:
        total, sim, draw = [], [], []
        for _ in range(args.repeat):
            t = time.perf_counter()
            ex.update(**kw)
            total.append(time.perf_counter() - t)
            sim.append(ex.seconds["simulate"])
            draw.append(ex.seconds["draw"])
        rows.append((label, statistics.median(total), statistics.median(sim),
                     statistics.median(draw)))
    print("| slider move | redraw [s] | of which simulate [s] | of which draw [s] |")
    print("|---|---:|---:|---:|")
    for label, tot, sim, draw in rows:
        print(f"| {label} | {tot:.3f} | {sim:.3f} | {draw:.3f} |")
    print(f"\nmedian of {args.repeat} calls per row; first call (engine compile or cache load, "
          f"figure) {first:.2f} s")
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    print(f"machine: {os.cpu_count()} cores, load average {load:.2f}; batch backend "
          f"{'numba' if _kernels.AVAILABLE else 'numpy'}; unidyn {unidyn.__version__}")


if __name__ == "__main__":
    main()
