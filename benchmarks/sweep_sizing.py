"""How honest a sweep's size is, and how soon a big one answers, on the machine at hand.

1. Small sweeps run to their end: the time :func:`unidyn.sweeps.sizing.size_sweep`
   estimated before the first point (measured on the first chunk, shortened) beside the
   time the points then took (``SweepRun.points_seconds``: the whole call adds the
   estimate's own runs and the figure), and the bytes estimated beside metrics.csv's.
2. A sweep file of a 1000 x 1000 grid (10^6 points of 250 s) given to ``unidyn sweep``
   in a fresh process: the wall time to its first line and to its refusal (an estimate
   of hours), the CPU time and the peak memory of the process. Building every point
   before saying anything took about 0.7 ms and 5.7 kB of memory a point (65 s and
   513 MB for 90,000 points; 10^6 points: about 12 min and 5.7 GB).

    MPLBACKEND=Agg python benchmarks/sweep_sizing.py

A busy machine stretches the times: run it idle.
"""

import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from unidyn.sweeps.sweep import Sweep, run_sweep

SMALL = {
    "40 gains, T = 20 s": Sweep(base={"case": "compensated", "T": 20.0, "noise": "off"},
                                grid={"kxy": {"start": 0.5, "stop": 20, "num": 40}}),
    "10 gains x 8 seeds, T = 20 s": Sweep(base={"case": "compensated", "T": 20.0},
                                          grid={"kxy": {"start": 0.5, "stop": 20, "num": 10},
                                                "seed": list(range(1, 9))}),
    "20 gains, T = 250 s": Sweep(base={"case": "adaptive", "T": 250.0, "noise": "off"},
                                 grid={"kxy": {"start": 0.5, "stop": 35, "num": 20}}),
    "400 gains, T = 1 s": Sweep(base={"case": "compensated", "T": 1.0, "noise": "off"},
                                grid={"kxy": {"start": 0.5, "stop": 35, "num": 400}}),
}

BIG = ('name = "big"\n[base]\ncase = "compensated"\nT = 250\nnoise = "off"\n[grid]\n'
       'kxy = {start = 0.001, stop = 1.0, num = 1000}\nku = {start = 0.001, stop = 1.0, num = 1000}\n')


def small(folder: Path):
    print("estimate before the first point, against the time the sweep then took")
    print(f"{'sweep':32s} {'estimated':>10s} {'took':>8s} {'ratio':>6s} {'bytes est.':>11s} "
          f"{'metrics.csv':>11s}")
    for name, sweep in SMALL.items():
        run = run_sweep(sweep, folder / name.replace(" ", "_"), progress=False)
        size = run.size
        took = run.points_seconds
        csv = (run.out_dir / "metrics.csv").stat().st_size
        print(f"{name:32s} {size.seconds:9.2f}s {took:7.2f}s {took / size.seconds:6.2f} "
              f"{size.bytes:11,d} {csv:11,d}")


def big(folder: Path):
    f = folder / "big.toml"
    f.write_text(BIG)
    env = {**os.environ, "MPLBACKEND": "Agg", "CI": "true"}
    start = time.perf_counter()
    p = subprocess.Popen([sys.executable, "-m", "unidyn", "sweep", str(f), "--out",
                          str(folder / "big")], stdout=subprocess.PIPE,
                         stderr=subprocess.PIPE, stdin=subprocess.DEVNULL, text=True, env=env)
    first = p.stdout.readline()
    first_at = time.perf_counter() - start
    try:
        out, err = p.communicate(timeout=120)
    except subprocess.TimeoutExpired:  # not refused: it would run for hours
        p.kill()
        raise
    end = time.perf_counter() - start
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    print(f"\n10^6-point sweep file: first line after {first_at:.1f} s ({first.strip()!r}),")
    print(f"refused after {end:.1f} s (exit {p.returncode}), "
          f"{usage.ru_utime + usage.ru_stime:.1f} s of CPU, peak memory "
          f"{usage.ru_maxrss / 1024:.0f} MB")
    print(err.strip())


if __name__ == "__main__":
    with tempfile.TemporaryDirectory() as tmp:
        small(Path(tmp))
        big(Path(tmp))
