"""Timings of the engines on the machine at hand, printed as tables.

    python benchmarks/engines.py             # the engines side by side (several minutes)
    python benchmarks/engines.py --quick     # fewer bdsim points for the sweep estimate

Rows: the paper's simulation 4 (200 s, adaptive) through the bdsim diagram of Fig. 2,
through a bare bdsim loop (one block holding the whole loop: what bdsim costs without
the diagram's blocks), and through the batch engine, compiled and as plain Python; the
Fig. 11 sweep (4 cases x 70 gains x 250 s) through the batch engine, and through bdsim
(estimated from a sample of points); a cold ``unidyn run --paper 4``; one right-hand
side, compiled and in numpy; the compiled sin, cos and tanh against the maths library's.
Then the batch engine's accuracy against the diagram, and against 200 steps per sample.

    python benchmarks/engines.py --cold [--against REV]

The first and the second result, each in fresh processes with an empty compiler cache
(a new ``NUMBA_CACHE_DIR``): ``unidyn run examples/scenario.toml``; ``simulate_batch``
of the paper's 200 s run; the Fig. 11 sweep (the second: the median of three more in the
same process, its warm time). The first minus the second is the compile. With ``--against REV`` (a git revision of this
checkout, such as ``HEAD~3`` or a tag) the same rows for that version too, the two
versions in turn, so that both are measured in one sitting.

    python benchmarks/engines.py --section5 [--against REV] [--repeat N]

The README's job, ``examples/paper_section5.py`` (the four Section 5 runs through the
bdsim diagram), timed N times (default 2), in turn with REV's.

    python benchmarks/engines.py --memory            # the memory table only
    python benchmarks/engines.py --memory --long     # also two 10^7-sample runs (4-6 min)
"""

import argparse
import contextlib
import inspect
import io
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

os.environ.setdefault("MPLBACKEND", "Agg")

import unidyn  # noqa: E402
from unidyn.diagrams import simulate as runner  # noqa: E402
from unidyn.engine import kernels  # noqa: E402
from unidyn.engine.batch import DEFAULT_SUBSTEPS, simulate_batch  # noqa: E402
from unidyn.engine.rhs import ClosedLoop  # noqa: E402
from unidyn.model.scenario import Scenario  # noqa: E402

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent


def timed(f, repeat=1):
    best, out = np.inf, None
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = f()
        best = min(best, time.perf_counter() - t0)
    return best, out


def bare_bdsim_run(sc, rtol, atol):
    """The closed loop as a single bdsim block, with the same noise clock."""
    from bdsim.components import ContinuousBlock, SampledBlock

    from unidyn.diagrams import new_simulator

    loop = ClosedLoop(sc)

    class Loop(ContinuousBlock):
        nin = 1
        nout = 1

        def __init__(self, **kw):
            super().__init__(nstates=13, x0=loop.initial_state()[0], **kw)

        def deriv(self, t, inports, x):
            return loop.rhs(t, x[None], int(inports[0]))[0]

        def output(self, t, inports, x):
            return [x[0:3]]

    class Tick(SampledBlock):  # the interval index, held between ticks like the noise
        nin = 0
        nout = 1

        def __init__(self, clock, **kw):
            super().__init__(clock=clock, x0=[0.0], **kw)

        def output(self, t, inports, x):
            return [x[0]]

        def next(self, t, inports, x):
            return np.array([x[0] + 1.0])

    sim = new_simulator()
    bd = sim.blockdiagram()
    clock = bd.clock(sc.Ts, name="sensor")
    tick = Tick(clock, bd=bd, name="tick")
    plant = Loop(bd=bd, name="loop")
    bd.connect(tick, plant)
    bd.connect(plant, bd.NULL())
    with contextlib.redirect_stdout(io.StringIO()):
        bd.compile()
    return sim.run(bd, T=sc.T, dt=sc.Ts, watch=[plant[0]], solver_args=dict(rtol=rtol, atol=atol))


def fig11_scenarios(T=250.0, noise=True):
    """The Fig. 11 sweep: the four cases at 70 gains k = kx = ky, 250 s each (the public
    API only: the probes below run it on any version)."""
    import numpy as np
    import unidyn
    theta = unidyn.model.robots.get("p3dx_laser").theta
    out = []
    for k in np.arange(0.5, 35.0 + 1e-9, 0.5):
        base = dict(T=T, kx=float(k), ky=float(k), **({} if noise else {"noise": None}))
        out += [unidyn.Scenario(case="uncompensated", **base),
                unidyn.Scenario(case="compensated", theta_hat0=0.9 * theta, **base),
                unidyn.Scenario(case="adaptive", theta_hat0=0.9 * theta, adapt_from=0.0, **base),
                unidyn.Scenario(case="compensated", **base)]
    return out


MEMORY_PROBE = """
import os, resource, sys, tempfile
os.environ["MPLBACKEND"] = "Agg"
from unidyn import Scenario
from unidyn.engine.batch import simulate_batch
T, L, dtype = float(sys.argv[1]), int(sys.argv[2]), sys.argv[3]
series = tuple(s for s in sys.argv[4].split(",") if s) if sys.argv[4] != "all" else None
more = {} if series is None else {"log_series": series}
simulate_batch([Scenario.paper(4, T=1.0)], backend="auto", progress=False)  # load the kernel
def rss():
    # VmHWM: this process's peak resident set (ru_maxrss would include the parent's
    # peak, which Linux carries into a child started by fork and exec)
    for line in open("/proc/self/status"):
        if line.startswith("VmHWM:"):
            return int(line.split()[1]) / 1024
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
base = rss()
r, = simulate_batch([Scenario.paper(4, T=T, log_every=L, log_dtype=dtype, **more)],
                    progress=False)
run = rss()
with tempfile.TemporaryDirectory() as d:
    r.save(d)
# the result's own series: its arrays are views of one log, counted once
owners = {}
for a in (r.t, r.pose, r.velocity, r.reference, r.v_d, r.v_ref, r.theta_hat, r.error):
    if a is None:  # not logged (log_series)
        continue
    while a.base is not None:
        a = a.base
    owners[id(a)] = a.nbytes
written = rss()
print(len(r.t), base, run, written, sum(owners.values()))
"""


def rhs_rows():
    """One right-hand side of the loop per run: compiled, one run at a time (what the
    engine does), against numpy over 20,000 runs at once, on one core."""
    import numba
    loop = ClosedLoop([Scenario.paper(4, T=1.0, noise=None)])
    rng = np.random.default_rng(0)
    B = 20000
    X = (np.repeat(loop.initial_state(), B, axis=0) + rng.normal(scale=0.1, size=(B, 13)))
    P = np.repeat(loop.P, B, axis=0)
    noise = (0.0, 0.0, 0.0, 0.0)
    rates = kernels.loop_rates

    @numba.njit
    def compiled(X, P, dX):
        for i in range(X.shape[0]):
            rates(0.5, X[i], (P[i], noise), dX)
    dX = np.empty(14)
    compiled(X[:2], P[:2], dX)
    t_c, _ = timed(lambda: compiled(X, P, dX), repeat=5)
    Xt, Pt, dXt = X.T.copy(), P.T.copy(), np.empty((13, B))
    ref = tuple(loop.reference(0.5)[j].repeat(B) for j in range(6))
    t_v, _ = timed(lambda: unidyn.model.equations.loop_derivative(0.5, Xt, ref, Pt, noise, dXt),
                   repeat=5)
    return [("one right-hand side, compiled, one run at a time (per run)", t_c / B,
             f"{t_c / B * 1e9:.0f} ns; an RK4 step is 4 of them"),
            ("one right-hand side, numpy, 20,000 runs at once (per run)", t_v / B,
             f"{t_v / B * 1e9:.0f} ns")]


def elementary_rows():
    """ns per call of the compiled sin, cos and tanh (unidyn.engine.vecmath) and of the
    maths library's (what numba makes of math.sin), over 4096 arguments."""
    import math

    import numba

    from unidyn.engine import vecmath

    def calls(f):
        @numba.njit
        def g(x, y, R):
            for _ in range(R):
                for i in range(x.size):
                    y[i] += f(x[i])
        return g

    x, y = np.random.default_rng(0).uniform(-1, 1, 4096), np.zeros(4096)
    rows = []
    for name in ("sin", "cos", "tanh"):
        ns = []
        for f in (getattr(vecmath, name), getattr(math, name)):
            g = calls(f)
            g(x, y, 1)
            ns.append(min(timed(lambda: g(x, y, 200))[0] for _ in range(5)) / (4096 * 200) * 1e9)
        rows.append((f"{name}, compiled (unidyn.engine.vecmath)", ns[0] * 1e-9,
                     f"{ns[0]:.1f} ns a call; the maths library's: {ns[1]:.1f} ns"))
    return rows


def memory_table(long=False):
    """Peak resident memory of long single runs, each in a fresh interpreter."""
    # (T, log_every, log_dtype, log_series) at Ts = 0.1 s: a million samples each
    cases = [(1e5, 1, "float64", "all"), (1e5, 1, "float32", "all"),
             (1e5, 1, "float64", ""), (1e5, 1, "float32", ""),
             (1e5, 10, "float64", "all"), (1e5, 10, "float32", "all")] + (
        [(1e6, 1, "float32", "all"), (1e6, 1, "float64", "")] if long else [])
    print("\n| run (Ts = 0.1 s) | samples | logged | peak RSS before [MB] | after the run [MB] "
          "| after writing files [MB] | run [bytes per sample] | logged series [bytes per "
          "logged sample] |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|")
    for T, L, dtype, series in cases:
        what = (f"T = {T:g} s, log_every = {L}, {dtype}"
                + ("" if series == "all" else f", log_series = ({series})"))
        r = subprocess.run([sys.executable, "-c", MEMORY_PROBE, str(T), str(L), dtype, series],
                           capture_output=True, text=True)
        if r.returncode != 0:
            print(f"| {what} | FAILED: {r.stderr.strip()[-200:]} |")
            continue
        n, base, run, written, series = map(float, r.stdout.split())
        print(f"| {what} | {T / 0.1:.0f} | {n:.0f} | {base:.0f} | {run:.0f} | {written:.0f} "
              f"| {(run - base) * 2**20 / (T / 0.1):.0f} | {series / n:.0f} |")


COLD_PROBE = inspect.getsource(fig11_scenarios) + """
import sys, time
from unidyn import Scenario
from unidyn.engine.batch import simulate_batch
runs = [Scenario.paper(4)] if sys.argv[1] == "paper" else fig11_scenarios()
times = []
for _ in range(int(sys.argv[2])):
    t = time.perf_counter()
    simulate_batch(runs, progress=False)
    times.append(time.perf_counter() - t)
print(*times)
"""


def _versions(against):
    """[(label, src folder)]: this checkout, and REV's files (git archive) where given."""
    versions = [("this checkout", ROOT / "src")]
    if against:
        tmp = Path(tempfile.mkdtemp(prefix="unidyn-against-"))
        archive = subprocess.run(["git", "-C", str(ROOT), "archive", against, "src", "examples"],
                                 capture_output=True, check=True).stdout
        subprocess.run(["tar", "-x", "-C", str(tmp)], input=archive, check=True)
        versions.insert(0, (against, tmp / "src"))
    return versions


def _run(src, cache, args):
    """Wall time of a fresh Python on ``src`` with numba's cache in ``cache``, and its
    output."""
    env = dict(os.environ, PYTHONPATH=str(src), NUMBA_CACHE_DIR=str(cache), MPLBACKEND="Agg")
    t = time.perf_counter()
    r = subprocess.run([sys.executable, *args], env=env, capture_output=True, text=True,
                       cwd=tempfile.gettempdir())
    if r.returncode != 0:
        raise RuntimeError(f"{' '.join(args[:3])} failed: {r.stderr.strip()[-400:]}")
    return time.perf_counter() - t, r.stdout


def cold_table(against=None):
    """First and second results from an empty compiler cache (module docstring)."""
    versions = _versions(against)
    rows = {}
    with tempfile.TemporaryDirectory() as tmp:
        for what in ("cli", "paper", "fig11"):
            for label, src in versions:  # the versions in turn, row by row
                cache = Path(tmp) / f"{what}-{len(rows)}"
                if what == "cli":
                    toml = src.parent / "examples" / "scenario.toml"
                    times = [_run(src, cache, ["-m", "unidyn", "run", str(toml), "--out",
                                               str(Path(tmp) / f"run{len(rows)}-{i}")])[0]
                             for i in range(2)]
                elif what == "paper":  # each in a fresh Python
                    times = [float(_run(src, cache, ["-c", COLD_PROBE, "paper", "1"])[1])
                             for _ in range(2)]
                else:  # then three more in the same process: the warm time is their median
                    first, *warm = map(float, _run(src, cache, ["-c", COLD_PROBE, "fig11", "4"])[1].split())
                    times = [first, float(np.median(warm))]
                rows[what, label] = times
    names = {"cli": "`unidyn run examples/scenario.toml`, a fresh process each",
             "paper": "`simulate_batch([Scenario.paper(4)])`, a fresh Python each",
             "fig11": "Fig. 11 sweep, 280 runs x 250 s (second: the median of three more in "
                      "the same process)"}
    print(f"\n{os.cpu_count()} cores; empty compiler cache before the first result\n")
    print("| result | version | first [s] | second [s] | first / second | first - second [s] |")
    print("|---|---|---:|---:|---:|---:|")
    for (what, label), (first, second) in rows.items():
        print(f"| {names[what]} | {label} | {first:.1f} | {second:.1f} | {first / second:.1f} "
              f"| {first - second:.1f} |")


def section5_table(against=None, repeat=2):
    """The README's job, this checkout and REV in turn (module docstring)."""
    versions = _versions(against)
    times = {label: [] for label, _ in versions}
    with tempfile.TemporaryDirectory() as tmp:
        for i in range(repeat):
            for label, src in versions:
                job = src.parent / "examples" / "paper_section5.py"
                t, _ = _run(src, Path(tmp) / "cache", [str(job), "--out",
                                                        str(Path(tmp) / f"out-{label}-{i}")])
                times[label].append(t)
    print(f"\n`python examples/paper_section5.py` ({os.cpu_count()} cores), {repeat} runs each, "
          f"in turn\n")
    print("| version | runs [s] | median [s] |")
    print("|---|---|---:|")
    for label, ts in times.items():
        print(f"| {label} | {', '.join(f'{t:.1f}' for t in ts)} | {np.median(ts):.1f} |")
    if against:
        print(f"\nthis checkout / {against}: {np.median(times['this checkout']) / np.median(times[against]):.2f}")


def engines_table(quick=False):
    rtol, atol = runner.DEFAULT_RTOL, runner.DEFAULT_ATOL
    rows = []
    sc = Scenario.paper(4)
    # best of two: single runs of several seconds vary by 10-20 % on a shared machine
    t_diag, _ = timed(lambda: unidyn.simulate(sc), repeat=2)
    rows.append(("paper sim. 4 (200 s), bdsim diagram (our blocks)", t_diag, ""))
    t_bare, _ = timed(lambda: bare_bdsim_run(sc, rtol, atol), repeat=2)
    rows.append(("paper sim. 4 (200 s), bare bdsim loop (one block, same equations)", t_bare,
                 f"our blocks add {100 * (t_diag / t_bare - 1):+.0f} %"))
    if kernels.AVAILABLE:
        simulate_batch([sc.replace(T=1.0)], backend="compiled")  # compile or load the cache
        t_nb, _ = timed(lambda: simulate_batch([sc], backend="compiled"), repeat=3)
        rows.append(("paper sim. 4 (200 s), batch engine, compiled", t_nb,
                     f"{t_diag / t_nb:.0f}x faster than the diagram"))
    t_np, _ = timed(lambda: simulate_batch([sc], backend="plain"))
    rows.append(("paper sim. 4 (200 s), batch engine, plain Python", t_np,
                 f"{t_diag / t_np:.2g}x faster than the diagram"))

    scs = fig11_scenarios()
    batch_res = quiet_res = t_sweep = None
    if kernels.AVAILABLE:
        for label, cases in (("", scs), (", noise-free", fig11_scenarios(noise=False))):
            times = []
            for _ in range(5):
                t, res = timed(lambda: simulate_batch(cases, backend="compiled", progress=False))
                times.append(t)
            t_run = float(np.median(times))
            steps = sum(r.rk4_steps for r in res)  # finer intervals and split steps included
            ns = t_run / steps * 1e9 * min(os.cpu_count() or 1, len(cases))
            rows.append((f"Fig. 11 sweep ({len(cases)} runs x 250 s{label}), batch engine, "
                         f"compiled, median of 5", t_run,
                         f"{steps / 1e6:.1f} M RK4 steps ({DEFAULT_SUBSTEPS} to "
                         f"{max(r.substeps for r in res)} per 0.1 s, up to "
                         f"{max(r.substeps_max for r in res)} in intervals taken finer; "
                         f"{sum(r.split_steps for r in res) / 1e6:.2f} M splits at a change of "
                         f"the limits): {ns:.0f} ns per step per core, {os.cpu_count()} threads"))
            if label:
                quiet_res = res
            else:
                batch_res, t_sweep = res, t_run
        rows += rhs_rows() + elementary_rows()
    sample = np.unique(np.linspace(0, len(scs) - 1, 4 if quick else 12).round().astype(int))
    t_sample, diag_res = timed(lambda: [unidyn.simulate(scs[i]) for i in sample])
    per_point = t_sample / len(sample)
    note = f"{per_point:.1f} s per point"
    if t_sweep is not None:
        note += f"; the batch engine is {per_point * len(scs) / t_sweep:.0f}x faster"
    rows.append((f"Fig. 11 sweep, bdsim diagram (estimated from {len(sample)} points)",
                 per_point * len(scs), note))
    with tempfile.TemporaryDirectory() as tmp:
        cmd = [sys.executable, "-m", "unidyn", "run", "--paper", "4", "--out", os.path.join(tmp, "r")]
        t0 = time.perf_counter()
        r = subprocess.run(cmd, capture_output=True, text=True)
        note = "ok" if r.returncode == 0 else f"FAILED: {r.stderr.strip()[-200:]}"
        rows.append(("`unidyn run --paper 4`, cold start (import, run, files, figures)",
                     time.perf_counter() - t0, note))

    print(f"\nmachine: {os.cpu_count()} cores; numba {'available' if kernels.AVAILABLE else 'absent'}; "
          f"bdsim tolerances rtol={rtol:g}, atol={atol:g}\n")
    print("| what | wall time [s] | note |")
    print("|---|---:|---|")
    for what, t, note in rows:
        print(f"| {what} | {t:.3f} | {note} |" if t >= 1e-3 else f"| {what} | {t:.2g} | {note} |")
    if batch_res is not None:
        errs = [abs(batch_res[i].metrics["iae"] - r.metrics["iae"]) / r.metrics["iae"]
                for i, r in zip(sample, diag_res)]
        pos = [np.max(np.abs(batch_res[i].pose[:, :2] - r.pose[:, :2]))
               for i, r in zip(sample, diag_res)]
        print(f"\nbatch engine vs bdsim diagram on the {len(sample)} sampled Fig. 11 points (with "
              f"noise): IAE relative difference median {np.median(errs):.1e}, max {max(errs):.1e}; "
              f"position difference max {max(pos):.1e} m")
    if quiet_res is not None:
        fine = simulate_batch(fig11_scenarios(noise=False), substeps=200, backend="compiled",
                              progress=False)
        rel = np.array([abs(a.metrics["iae"] - b.metrics["iae"]) / b.metrics["iae"]
                        for a, b in zip(quiet_res, fine)]).reshape(-1, 4)
        print("noise-free Fig. 11 sweep at the default step vs 200 steps per sample: IAE "
              "relative difference, largest over the 70 gains, by case: "
              + ", ".join(f"{c} {v:.1e}" for c, v in zip(
                  ("uncompensated", "compensated 0.9", "adaptive", "compensated exact"),
                  rel.max(axis=0))))


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--quick", action="store_true", help="sample 4 bdsim sweep points, not 12")
    p.add_argument("--cold", action="store_true",
                   help="only first and second results with an empty compiler cache")
    p.add_argument("--section5", action="store_true", help="only the README's job")
    p.add_argument("--against", metavar="REV",
                   help="with --cold or --section5: also git revision REV, in turn")
    p.add_argument("--repeat", type=int, default=2, help="runs of each version (--section5)")
    p.add_argument("--memory", action="store_true", help="only the memory table")
    p.add_argument("--long", action="store_true",
                   help="add 10^7-sample runs (float32; float64 with log_series=()) to the memory table (4-6 min)")
    args = p.parse_args(argv)
    if args.cold:
        cold_table(args.against)
    elif args.section5:
        section5_table(args.against, args.repeat)
    elif args.memory:
        memory_table(args.long)
    else:
        engines_table(args.quick)
        memory_table(args.long)


if __name__ == "__main__":
    main()
