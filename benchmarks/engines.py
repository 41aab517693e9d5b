"""Wall-time benchmarks of the engines, printed as a table (on the machine at hand).

    python benchmarks/engines.py            # everything (several minutes)
    python benchmarks/engines.py --quick    # fewer bdsim points for the sweep estimate

Rows:
  1. one 200 s adaptive run (paper simulation 4) through the bdsim diagram of Fig. 2
  2. the same run through a bare bdsim loop: one block holding the whole closed loop
     (the same equations, unidyn.engine.rhs) with the same noise clock and tolerances,
     i.e. what bdsim costs without our decomposition into blocks
  3. the same run through the batch engine (compiled, and the same kernels as plain Python)
  4. the full Fig. 11 sweep (4 cases x 70 gains x 250 s) through the batch engine,
     and through bdsim (estimated from a sample of points: a full bdsim sweep takes hours)
  5. import plus first run of `unidyn run --paper 4` in a fresh interpreter (cold start)
and the accuracy of the batch engine against the bdsim diagram on the sampled points;
then peak memory (resident set, VmHWM, each in a fresh process) of long batch
runs with and without thinning the log (``log_every``), in float64 and float32
(``log_dtype``), and of writing their files; the bytes per logged sample are the
result's own arrays.

    python benchmarks/engines.py --cold   # first and second result, compile included

``--cold`` times, each in fresh processes with an empty compiler cache (a fresh
``NUMBA_CACHE_DIR``), the first and then the second: ``unidyn run
examples/scenario.toml``; ``simulate_batch`` of the paper's 200 s run (simulation 4) in
a fresh Python; the Fig. 11 sweep (280 runs of 250 s). The first minus the second is
the compile (and cache writing). Run it on two versions in one sitting, each with
PYTHONPATH pointing at its ``src``, to compare them.

    python benchmarks/engines.py --memory            # the memory table only
    python benchmarks/engines.py --memory --long     # also two 10^7-sample runs (4-6 min)
"""

import argparse
import contextlib
import io
import os
import subprocess
import sys
import tempfile
import time

import numpy as np

os.environ.setdefault("MPLBACKEND", "Agg")

import unidyn  # noqa: E402
from unidyn.engine import kernels as _kernels
from unidyn.diagrams import simulate as runner  # noqa: E402
from unidyn.engine.batch import DEFAULT_SUBSTEPS, simulate_batch  # noqa: E402
from unidyn.engine.rhs import ClosedLoop  # noqa: E402
from unidyn.model.scenario import Scenario  # noqa: E402


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
    theta = unidyn.model.robots.get("p3dx_laser").theta
    out = []
    for k in np.arange(0.5, 35.0 + 1e-9, 0.5):
        base = dict(T=T, kx=float(k), ky=float(k), **({} if noise else {"noise": None}))
        out += [Scenario(case="uncompensated", **base),
                Scenario(case="compensated", theta_hat0=0.9 * theta, **base),
                Scenario(case="adaptive", theta_hat0=0.9 * theta, adapt_from=0.0, **base),
                Scenario(case="compensated", **base)]
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
    """One right-hand side of the loop (unidyn.model.equations.loop_derivative) per run: compiled,
    one run at a time (what the engine does), against numpy over 20,000 runs at once
    (runs as the vectorised dimension), on one core."""
    from unidyn.model import equations as eq
    loop = ClosedLoop([Scenario.paper(4, T=1.0, noise=None)])
    rng = np.random.default_rng(0)
    B = 20000
    X = (np.repeat(loop.initial_state(), B, axis=0) + rng.normal(scale=0.1, size=(B, 13)))
    P = np.repeat(loop.P, B, axis=0)
    noise = (0.0, 0.0, 0.0, 0.0)
    dX = np.empty(13)
    _kernels.rhs(0.5, X[0], P[0], noise, dX)
    import numba

    @numba.njit
    def compiled(X, P, dX):
        for i in range(X.shape[0]):
            _kernels.rhs(0.5, X[i], P[i], noise, dX)
    compiled(X[:2], P[:2], dX)
    t_c, _ = timed(lambda: compiled(X, P, dX), repeat=5)
    Xt, Pt, dXt = X.T.copy(), P.T.copy(), np.empty((13, B))
    ref = tuple(loop._reference_tuple(0.5)[j].repeat(B) for j in range(6))
    t_v, _ = timed(lambda: eq.loop_derivative(0.5, Xt, ref, Pt, noise, dXt), repeat=5)
    return [("one right-hand side, compiled, one run at a time (per run)", t_c / B,
             f"{t_c / B * 1e9:.0f} ns; an RK4 run-step is 4 of them"),
            ("one right-hand side, numpy, 20,000 runs at once (per run)", t_v / B,
             f"{t_v / B * 1e9:.0f} ns: runs as the vectorised dimension, with its temporaries")]


TRANSCENDENTAL = ("sin", "cos", "tanh")


def operation_counts():
    """The operations of one right-hand side of the loop (the reference of the figure
    eight plus unidyn.model.equations.loop_derivative), counted by running the equations on
    an ndarray subclass that records every ufunc (and np.where) it goes through.
    Transcendental calls on the same argument are counted once (the compiler can share
    them: cos(psi) appears in Eqs. 1 and 10)."""
    import collections

    from unidyn.model import equations as eq
    counts, seen = collections.Counter(), set()

    class Counting(np.ndarray):
        def __array_ufunc__(self, ufunc, method, *inputs, **kw):
            args = [np.asarray(a) for a in inputs]
            name = ufunc.__name__
            key = (name, tuple(np.asarray(a, dtype=float).tobytes() for a in args))
            if name not in TRANSCENDENTAL or key not in seen:
                counts[name] += 1
                seen.add(key)
            return np.asarray(getattr(ufunc, method)(*args, **kw)).view(Counting)

        def __array_function__(self, func, types, args, kwargs):
            counts[func.__name__] += 1
            out = func(*[np.asarray(a) if isinstance(a, Counting) else a for a in args],
                       **kwargs)
            return np.asarray(out).view(Counting) if isinstance(out, np.ndarray) else out

    loop = ClosedLoop([Scenario.paper(4, T=1.0)])
    rng = np.random.default_rng(1)
    X = (loop.initial_state().T + rng.normal(scale=0.1, size=(13, 1))).view(Counting)
    P = loop.P.T.copy().view(Counting)
    ref = eq.figure_eight(np.array([0.5]).view(Counting),
                          *[P[eq.P.path1 + j] for j in range(6)])
    noise = tuple(np.full(1, 0.01).view(Counting) for _ in range(4))
    eq.loop_derivative(np.array([150.0]).view(Counting), X, ref, P, noise, np.empty((13, 1)))
    return counts


def machine_rates():
    """ns per operation on one core, compiled by numba: multiply-add over an L1-resident
    array (vectorised by the compiler), divide, and each transcendental function as the
    engine evaluates it (unidyn.engine.vecmath, vectorised by the compiler), and as the
    maths library's scalar calls (``libm_sin``, ...: what numba makes of np.sin)."""
    import math

    import numba

    from unidyn.engine import vecmath as _vecmath

    @numba.njit
    def mul_add(x, a, b, R):
        for _ in range(R):
            for i in range(x.size):
                x[i] = x[i] * a + b

    @numba.njit
    def divide(x, a, b, R):
        for _ in range(R):
            for i in range(x.size):
                x[i] = b / (x[i] + a)

    def calls(f):
        @numba.njit
        def g(x, y, R):
            for _ in range(R):
                for i in range(x.size):
                    y[i] += f(x[i])
        return g

    def best(f, *a):
        f(*a)
        return min(timed(lambda: f(*a))[0] for _ in range(5))

    R = 20000
    rates = {"mul_add": best(mul_add, np.full(512, 0.3), 0.999, 1e-4, R) / (2 * 512 * R),
             "divide": best(divide, np.full(512, 0.3), 1.0, 0.5, R) / (512 * R)}
    x, y = np.random.default_rng(0).uniform(-1, 1, 4096), np.zeros(4096)
    for name in TRANSCENDENTAL:
        rates[name] = best(calls(getattr(_vecmath, name)), x, y, 500) / (4096 * 500)
        rates["libm_" + name] = best(calls(getattr(math, name)), x, y, 500) / (4096 * 500)
    return {k: v * 1e9 for k, v in rates.items()}


def arithmetic_limit(ns_measured=None):
    """The least time one RK4 run-step can take on one core of this machine: 4
    right-hand sides (operation_counts) plus the 13-state RK4 combination (12
    multiply-adds a state), each arithmetic operation at the vectorised multiply-add
    rate, each divide and transcendental call at its measured cost; printed beside the
    engine's measured ns per run-step."""
    counts, rates = operation_counts(), machine_rates()
    n_trans = {k: counts.get(k, 0) for k in TRANSCENDENTAL}
    n_div = counts.get("divide", 0)
    n_arith = sum(v for k, v in counts.items() if k not in TRANSCENDENTAL and k != "divide")
    t_trans = sum(n * rates[k] for k, n in n_trans.items())
    rhs = n_arith * rates["mul_add"] + n_div * rates["divide"] + t_trans
    combination = 13 * 12 * rates["mul_add"]
    step = 4 * rhs + combination
    print(f"\narithmetic limit of one RK4 run-step on one core: a right-hand side is {n_arith} "
          f"arithmetic/compare/select operations, {n_div} divides and "
          + ", ".join(f"{n} {k}" for k, n in n_trans.items())
          + f"; this machine does a vectorised multiply-add in {rates['mul_add']:.3f} ns an "
          f"operation, a divide in {rates['divide']:.2f} ns, "
          + ", ".join(f"{k} in {rates[k]:.1f} ns" for k in TRANSCENDENTAL)
          + " (unidyn.engine.vecmath, vectorised; the maths library's scalar calls take "
          + ", ".join(f"{rates['libm_' + k]:.1f}" for k in TRANSCENDENTAL) + " ns). So a "
          f"right-hand side takes at least {rhs:.0f} ns ({t_trans:.0f} of them the "
          f"transcendental calls), and an RK4 run-step {step:.0f} ns"
          + (f"; the engine's {ns_measured:.0f} ns is {ns_measured / step:.1f}x that"
             if ns_measured else "") + ".")
    return step


def sweep_floor(scs, step_ns):
    """The least time the Fig. 11 sweep can take on this machine with RK4: every run at
    the default step (no interval taken finer, no split), each run-step at the
    arithmetic limit, spread over the threads with the speed-up the engine gets from
    them (the noise-free sweep timed on one thread and on all)."""
    import numba
    n_all = numba.get_num_threads()
    times = {}
    try:
        for n in sorted({1, n_all}):
            numba.set_num_threads(n)
            times[n], _ = timed(lambda: simulate_batch(scs, backend="compiled", progress=False))
    finally:
        numba.set_num_threads(n_all)
    speedup = times[1] / times[n_all]
    least = sum(sc.steps for sc in scs) * DEFAULT_SUBSTEPS
    floor = least * step_ns * 1e-9 / speedup
    print(f"\nfloor of the Fig. 11 sweep with RK4 on this machine: {least / 1e6:.2f} M run-steps "
          f"(every run at {DEFAULT_SUBSTEPS} steps per 0.1 s: no interval taken finer, no "
          f"split) at the arithmetic limit ({step_ns:.0f} ns) on {n_all} threads, which speed "
          f"the noise-free sweep up {speedup:.2f}x over one ({times[1]:.1f} s against "
          f"{times[n_all]:.1f} s): {floor:.2f} s.")
    return floor


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


COLD_PROBE = """
import sys, time
t0 = time.perf_counter()
sys.path.insert(0, sys.argv[2])
from unidyn import Scenario
from unidyn.engine.batch import simulate_batch
if sys.argv[1] == "paper":
    runs = [Scenario.paper(4)]
else:
    from engines import fig11_scenarios
    runs = fig11_scenarios()
times = []
for _ in range(2):
    t, c = time.perf_counter(), time.process_time()
    simulate_batch(runs, progress=False)
    times += [time.perf_counter() - t, time.process_time() - c]
print(*times)
"""


def cold_table():
    """First and second result with an empty compiler cache, each row in fresh
    processes (see the module docstring)."""
    here = os.path.dirname(os.path.abspath(__file__))
    scenario = os.path.join(os.path.dirname(here), "examples", "scenario.toml")
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        def env(name):
            return dict(os.environ, NUMBA_CACHE_DIR=os.path.join(tmp, name), MPLBACKEND="Agg")
        import resource
        cli = []
        for i in range(2):
            t0 = time.perf_counter()
            c0 = resource.getrusage(resource.RUSAGE_CHILDREN)
            r = subprocess.run([sys.executable, "-m", "unidyn", "run", scenario, "--out",
                                os.path.join(tmp, f"run{i}")], env=env("cli"),
                               capture_output=True, text=True)
            c1 = resource.getrusage(resource.RUSAGE_CHILDREN)
            cli += [time.perf_counter() - t0,
                    c1.ru_utime + c1.ru_stime - c0.ru_utime - c0.ru_stime]
            if r.returncode != 0:
                print(f"unidyn run FAILED: {r.stderr.strip()[-300:]}")
        rows.append(("`unidyn run examples/scenario.toml` (fresh process each)", *cli))
        for what, label in (("paper", "simulate_batch([Scenario.paper(4)]) in a fresh Python"),
                            ("fig11", "Fig. 11 sweep, simulate_batch of 280 runs x 250 s")):
            r = subprocess.run([sys.executable, "-c", COLD_PROBE, what, here], env=env(what),
                               capture_output=True, text=True)
            if r.returncode != 0:
                print(f"{label} FAILED: {r.stderr.strip()[-300:]}")
                continue
            rows.append((label, *map(float, r.stdout.split()[-4:])))
    print("\n| first and second result, empty compiler cache | first [s] | second [s] "
          "| first / second | first - second (compile) [s] | CPU first, second [s] |")
    print("|---|---:|---:|---:|---:|---:|")
    for label, first, cpu1, second, cpu2 in rows:
        print(f"| {label} | {first:.1f} | {second:.2f} | {first / second:.1f} "
              f"| {first - second:.1f} | {cpu1:.1f}, {cpu2:.1f} |")


def main(argv=None):
    p = argparse.ArgumentParser(description="unidyn engine benchmarks")
    p.add_argument("--quick", action="store_true", help="sample 4 bdsim sweep points, not 12")
    p.add_argument("--memory", action="store_true", help="only the memory table")
    p.add_argument("--cold", action="store_true",
                   help="only first and second results with an empty compiler cache")
    p.add_argument("--limit", action="store_true", help="only the arithmetic limit")
    p.add_argument("--long", action="store_true",
                   help="add 10^7-sample runs (float32; float64 with log_series=()) to the memory table (4-6 min)")
    args = p.parse_args(argv)
    if args.cold:
        cold_table()
        return
    if args.memory:
        memory_table(args.long)
        return
    if args.limit:
        if not _kernels.AVAILABLE:
            sys.exit("--limit measures compiled code: it needs numba (pip install unidyn[fast])")
        arithmetic_limit()
        return
    rtol, atol = runner.DEFAULT_RTOL, runner.DEFAULT_ATOL
    rows = []
    sc = Scenario.paper(4)

    # best of two: single runs of several seconds vary by 10-20 % on a shared machine
    t_diag, _ = timed(lambda: unidyn.simulate(sc), repeat=2)
    rows.append(("paper sim. 4 (200 s), bdsim diagram (our blocks)", t_diag, ""))
    t_bare, _ = timed(lambda: bare_bdsim_run(sc, rtol, atol), repeat=2)
    rows.append(("paper sim. 4 (200 s), bare bdsim loop (one block, same equations)", t_bare,
                 f"our blocks add {100 * (t_diag / t_bare - 1):+.0f} %"))
    if _kernels.AVAILABLE:
        simulate_batch([sc.replace(T=1.0)], backend="compiled")  # compile or load the cache
        t_nb, _ = timed(lambda: simulate_batch([sc], backend="compiled"), repeat=3)
        rows.append(("paper sim. 4 (200 s), batch engine, compiled", t_nb,
                     f"{t_diag / t_nb:.0f}x faster than the diagram"))
    t_np, _ = timed(lambda: simulate_batch([sc], backend="plain"))
    rows.append(("paper sim. 4 (200 s), batch engine, plain Python", t_np,
                 f"{t_diag / t_np:.2g}x faster than the diagram"))

    scs = fig11_scenarios()
    n_pts = len(scs)
    batch_res, ns_run_step = None, None
    quiet_res = None
    if _kernels.AVAILABLE:
        for label, cases in (("", scs), (", noise-free", fig11_scenarios(noise=False))):
            times = []
            for _ in range(5):
                t, res = timed(lambda: simulate_batch(cases, backend="compiled", progress=False))
                times.append(t)
            t_run = float(np.median(times))
            run_steps = sum(r.rk4_steps for r in res)  # refined intervals and split steps included
            extra = run_steps - sum(r.substeps * r.scenario.steps for r in res)
            ns = t_run / run_steps * 1e9 * min(os.cpu_count() or 1, n_pts)
            rows.append((f"Fig. 11 sweep ({n_pts} runs x 250 s{label}), batch engine, compiled, "
                         f"median of 5", t_run,
                         f"{run_steps / 1e6:.1f} M RK4 run-steps ({DEFAULT_SUBSTEPS} to "
                         f"{max(r.substeps for r in res)} per 0.1 s; {extra / 1e6:.2f} M more in "
                         f"intervals taken finer, up to {max(r.substeps_max for r in res)} per "
                         f"0.1 s, and for {sum(r.split_steps for r in res) / 1e6:.2f} M splits at "
                         f"a change of the limits): {ns:.0f} ns per run-step per core, "
                         f"{os.cpu_count()} threads"))
            if label:
                quiet_res = res
            else:
                batch_res, t_sweep, ns_run_step = res, t_run, ns
        rows += rhs_rows()
    sample = np.unique(np.linspace(0, n_pts - 1, 4 if args.quick else 12).round().astype(int))
    t_sample, diag_res = timed(lambda: [unidyn.simulate(scs[i]) for i in sample])
    per_point = t_sample / len(sample)
    t_sweep_bdsim = per_point * n_pts
    note = f"{per_point:.1f} s per point"
    if batch_res is not None:
        note += f"; the batch engine is {t_sweep_bdsim / t_sweep:.0f}x faster"
    rows.append((f"Fig. 11 sweep, bdsim diagram (estimated from {len(sample)} points)",
                 t_sweep_bdsim, note))

    with tempfile.TemporaryDirectory() as tmp:
        cmd = [sys.executable, "-m", "unidyn", "run", "--paper", "4", "--out", os.path.join(tmp, "r")]
        t0 = time.perf_counter()
        r = subprocess.run(cmd, capture_output=True, text=True)
        t_cli = time.perf_counter() - t0
        note = "ok" if r.returncode == 0 else f"FAILED: {r.stderr.strip()[-200:]}"
        rows.append(("`unidyn run --paper 4`, cold start (import, run, files, figures)", t_cli, note))

    print(f"\nmachine: {os.cpu_count()} cores; numba {'available' if _kernels.AVAILABLE else 'absent'}; "
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
    if _kernels.AVAILABLE:
        step_ns = arithmetic_limit(ns_run_step)
        sweep_floor(fig11_scenarios(noise=False), step_ns)
    memory_table(args.long)


if __name__ == "__main__":
    main()
