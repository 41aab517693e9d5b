"""How soon a long batch run answers, in wall-clock time on the machine at hand: from the
start of a fresh process to its first progress report (import, the compiled engine
loaded from its cache, the first chunk), and from Ctrl-C (a real SIGINT) to the
process's exit with the part computed kept. Prints the median and the range of several
processes per row, with the CPU time each used after the SIGINT beside it (what
tests/reliability/test_interrupt_engine.py bounds).

    MPLBACKEND=Agg python benchmarks/responsiveness.py [--repeat 5]

A busy machine stretches the wall-clock times and not the CPU times: run it idle.
"""

import argparse
import os
import signal
import statistics
import subprocess
import sys
import textwrap
import time
from pathlib import Path

CHILD = textwrap.dedent("""
    import sys, time
    from unidyn import Scenario
    from unidyn.engine.batch import simulate_batch
    from unidyn.diagrams.simulate import SimulationInterrupted

    started = []
    def progress(done, total):
        if not started:
            started.append(1)
            print("started", flush=True)

    T, L = float(sys.argv[2]), int(sys.argv[3])  # hours of simulated time
    sc = Scenario.paper(4, T=T, Ts=0.1, noise=None, name="long", log_every=L)
    try:
        simulate_batch([sc], backend=sys.argv[1], progress=progress)
    except SimulationInterrupted as err:
        print("interrupted", len(err.result.t), flush=True)
        print("cpu", time.process_time(), flush=True)
""")


def cpu_seconds(pid: int) -> float:
    """The CPU time a running process has used, all its threads (Linux's /proc)."""
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def one(backend: str, T: float, L: int, run_for: float):
    """(seconds to the first progress report, seconds from SIGINT to exit, CPU seconds
    after SIGINT) of one fresh process."""
    t0 = time.perf_counter()
    p = subprocess.Popen([sys.executable, "-c", CHILD, backend, str(T), str(L)],
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                         preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    try:
        line = p.stdout.readline()
        first = time.perf_counter() - t0
        if line.strip() != "started":
            raise RuntimeError(f"{backend}: {line!r} {p.stderr.read()[-2000:]}")
        time.sleep(run_for)
        cpu = cpu_seconds(p.pid)
        sent = time.perf_counter()
        p.send_signal(signal.SIGINT)
        out, err = p.communicate(timeout=120)
        stop = time.perf_counter() - sent
    finally:
        if p.poll() is None:
            p.kill()
    if "interrupted" not in out:
        raise RuntimeError(f"{backend}: {out!r} {err[-2000:]}")
    return first, stop, float(out.split("cpu")[-1]) - cpu


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=5, help="processes per row")
    ap.add_argument("--run-for", type=float, default=1.5,
                    help="seconds between the first progress report and the SIGINT")
    args = ap.parse_args(argv)
    os.environ.setdefault("MPLBACKEND", "Agg")
    print(f"{args.repeat} fresh processes per row; median [min, max]")
    print(f"{'engine':10} {'first report, s':>24} {'SIGINT to exit, s':>24} "
          f"{'CPU after SIGINT, s':>24}")
    for backend, T, L in [("compiled", 1e6, 100), ("plain", 2e5, 5)]:
        rows = [one(backend, T, L, args.run_for) for _ in range(args.repeat)]
        cells = []
        for col in zip(*rows):
            cells.append(f"{statistics.median(col):.2f} [{min(col):.2f}, {max(col):.2f}]")
        print(f"{backend:10} " + " ".join(f"{c:>24}" for c in cells))


if __name__ == "__main__":
    main()
