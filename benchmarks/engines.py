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

    python benchmarks/engines.py --accuracy [--against REV]

Each engine's error at its defaults against a converged solution (scipy's DOP853 at
rtol 1e-10, restarted at every sample) on scenarios no list of rates foresaw: fast
references, high gains, gamma up to 1e4, every preset robot; the batch engine of this
checkout and of REV, and the diagram.

    python benchmarks/engines.py --switching [--against REV] [--random N]

The switched loop at the gains where Fig. 11 ends: the runs whose acceleration limits
switch on and off within 15 ms, and N (default 100) seeded random scenarios at gains
20-60 with the paper's noise and limits, each at the defaults against the converged
reference (scipy's DOP853 at rtol 1e-11, its steps capped at 1 ms); the runs that are not
sensitive beyond twice their estimate, the share flagged sensitive, steps and rejected
steps per run, CPU time. Then the Fig. 11 grid of the audit (4 cases x 5 gains x 250 s)
with one seed and with five, warm. With ``--against REV`` the same rows for REV, in turn.

    python benchmarks/engines.py --memory            # the memory table only
    python benchmarks/engines.py --memory --long     # also two 10^7-sample runs (4-6 min)
"""

import argparse
import contextlib
import dataclasses
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
from unidyn.engine.batch import simulate_batch  # noqa: E402
from unidyn.engines import PLAIN_SECONDS_PER_SAMPLE  # noqa: E402
from unidyn.model.closed_loop import ClosedLoop  # noqa: E402
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
    rates = kernels.loop_rhs

    @numba.njit
    def compiled(X, P, dX):
        for i in range(X.shape[0]):
            rates(0.5, X[i], (P[i], noise, ()), dX)
    dX = np.empty(13)
    compiled(X[:2], P[:2], dX)
    t_c, _ = timed(lambda: compiled(X, P, dX), repeat=5)
    Xt, Pt, dXt = X.T.copy(), P.T.copy(), np.empty((13, B))
    ref = tuple(loop.reference(0.5)[j].repeat(B) for j in range(6))
    t_v, _ = timed(lambda: unidyn.model.equations.loop_derivative(0.5, Xt, ref, Pt, noise, dXt),
                   repeat=5)
    return [("one right-hand side, compiled, one run at a time (per run)", t_c / B,
             f"{t_c / B * 1e9:.0f} ns; a Dormand-Prince step is 6 of them"),
            ("one right-hand side, numpy, 20,000 runs at once (per run)", t_v / B,
             f"{t_v / B * 1e9:.0f} ns")]


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
    # the bdsim route per run (this checkout's diagram, at its defaults) on two Fig. 11
    # points, and how many times faster each version's warm sweep is per run
    scs = fig11_scenarios()
    sample = [scs[i] for i in (41, 202)]  # compensated at k = 5.5, adaptive at k = 25.5
    t_bd, _ = timed(lambda: [unidyn.simulate(sc, progress=False) for sc in sample])
    per_run = t_bd / len(sample)
    print(f"\nbdsim route, Fig. 11 points ({len(sample)}, 250 s, with noise): {per_run:.1f} s "
          f"per run; warm sweep per run against it: "
          + ", ".join(f"{label} {per_run * len(scs) / second:.0f}x"
                      for (what, label), (_, second) in rows.items() if what == "fig11"))


ACCURACY_SCENARIOS = """
import numpy as np
from unidyn import Scenario
from unidyn.model import robots
from unidyn.model.trajectories import Circle, FigureEight
from unidyn.model.unicycle import Limits


def accuracy_scenarios():
    \"\"\"The scenarios of the accuracy table, noise-free (public API only: each version
    builds them).\"\"\"
    f8 = dict(case="compensated", limits=Limits(), T=10.0, noise=None)
    out = {
        "compensated, figure eight 2 mm at 500/250 rad/s, no limits": Scenario(
            trajectory=FigureEight(ax=0.002, ay=0.002, wx=500.0, wy=250.0), **f8),
        "compensated, figure eight 2 cm at 50/25 rad/s, no limits": Scenario(
            trajectory=FigureEight(ax=0.02, ay=0.02, wx=50.0, wy=25.0), **f8),
        "Khepera III, circle 5 mm at 100 rad/s, a = 2 cm, k = 1": Scenario(
            robot="khepera3", trajectory=Circle(radius=0.005, omega=100.0), a=0.02, kx=1.0,
            ky=1.0, T=2.0, noise=None),
        "adaptive, gamma = 1000, paper limits, T = 20 s": Scenario(
            gamma=[1000.0] * 6, adapt_from=0.0, T=20.0, noise=None),
        "adaptive, gamma = 100, paper limits, T = 20 s": Scenario(
            gamma=[100.0] * 6, adapt_from=0.0, T=20.0, noise=None),
        "adaptive, gamma = 1e4, paper limits, T = 10 s": Scenario(
            gamma=[1e4] * 6, adapt_from=0.0, T=10.0, noise=None),
        "compensated, k = 100, paper limits, T = 20 s": Scenario(
            case="compensated", kx=100.0, ky=100.0, T=20.0, noise=None),
        "adaptive, k = 30, paper limits, T = 20 s": Scenario(
            case="adaptive", kx=30.0, ky=30.0, adapt_from=0.0, T=20.0, noise=None),
        "compensated, circle 0.2 m at 5 rad/s, no limits, T = 10 s": Scenario(
            case="compensated", trajectory=Circle(radius=0.2, omega=5.0), limits=Limits(),
            T=10.0, noise=None),
    }
    for name in robots.names():
        out[f"adaptive, robot {name}, paper limits, T = 10 s"] = Scenario(
            robot=name, case="adaptive", adapt_from=0.0, T=10.0, noise=None)
    return out
"""
ACCURACY_PROBE = ACCURACY_SCENARIOS + """
import json, warnings
from unidyn.engine.batch import simulate_batch
warnings.simplefilter("ignore")
out = {}
for name, sc in accuracy_scenarios().items():
    r, = simulate_batch([sc], progress=False)
    m = getattr(r, "partial_metrics", None) or r.metrics  # older versions: None if incomplete
    error = getattr(r, "numerical_error", None)
    out[name] = dict(complete=bool(r.complete), message=r.message, iae=m["iae"],
                     estimate=None if not error else error["iae"],
                     sensitive=bool(getattr(r, "sensitive", False)),
                     theta_hat=np.asarray(r.theta_hat, dtype=float).tolist())
print(json.dumps(out))
"""


def accuracy_table(against=None):
    """Each engine's error at its defaults against a converged solution (scipy's DOP853
    at rtol 1e-10 on the same equations, restarted at every sample): the batch engine of
    this checkout and of REV, and the diagram of this checkout; IAE relative, theta_hat
    absolute (the promise: 1e-4, or the result says it is not complete)."""
    import json
    import warnings

    from unidyn.results.result import metrics
    namespace = {}
    exec(ACCURACY_SCENARIOS, namespace)
    scs = namespace["accuracy_scenarios"]()
    with tempfile.TemporaryDirectory() as tmp:
        runs = {label: json.loads(_run(src, Path(tmp) / label.replace(" ", "-"),
                                       ["-c", ACCURACY_PROBE])[1])
                for label, src in _versions(against)}
    print("\nerror at the defaults against a converged solution (DOP853, rtol 1e-10, "
          "restarted at every sample); the batch engine's promise: a run that is not "
          "sensitive has an estimate of at most 1e-4 and is within twice it\n")
    print("| scenario | engine | complete | sensitive | IAE relative error | its estimate "
          "| theta_hat error | message |")
    print("|---|---|---|---|---:|---:|---:|---|")
    for name, sc in scs.items():
        loop = ClosedLoop(sc)
        X = loop.converged(rtol=1e-10, atol=1e-12)[0]
        t = np.arange(sc.steps + 1) * sc.Ts
        ref = np.array([np.ravel(loop.reference(tt)[:2]) for tt in t])
        iae = metrics(t, np.hypot(*(X[:, :2] - ref).T), X[:, 3:5])["iae"]
        rows = [(f"batch, {label}", r[name]["complete"], r[name].get("sensitive", ""),
                 r[name]["iae"], r[name].get("estimate"), np.array(r[name]["theta_hat"]),
                 r[name]["message"]) for label, r in runs.items()]
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            try:
                d = unidyn.simulate(sc, progress=False)
                rows.append(("bdsim diagram", d.complete, "", d.metrics["iae"], None,
                             d.theta_hat, d.message))
            except unidyn.SimulationError as err:
                rows.append(("bdsim diagram", False, "", None, None, None, str(err)))
        for engine, complete, sensitive, r_iae, estimate, theta_hat, message in rows:
            e_iae = "" if r_iae is None else f"{abs(r_iae - iae) / iae:.1e}"
            e_th = ("" if theta_hat is None or len(theta_hat) != len(X)
                    else f"{np.max(np.abs(theta_hat - X[:, 5:11])):.1e}")
            est = "" if estimate is None else f"{estimate:.1e}"
            print(f"| {name} | {engine} | {complete} | {sensitive} | {e_iae} | {est} | {e_th} "
                  f"| {message[:90]} |")
    estimate_table()


def estimate_table():
    """How the batch engine's estimate holds on the whole Fig. 11 grid, with and without
    noise: each run at the defaults against the same run at rtol 1e-11 (tightened once
    more to 1e-12 by the engine itself; within 1e-9 of scipy's DOP853 on the cases of
    tests/engine/test_accuracy.py)."""
    from unidyn.results.result import INTEGRAL_NAMES
    print("\nthe estimate on the Fig. 11 grid (280 runs x 250 s) against the runs at rtol "
          "1e-11: metric values (5 a run) within twice their estimate\n")
    print("| grid | runs | sensitive | not sensitive, estimate > 1e-4 | within twice, not "
          "sensitive | worst true / estimate, not sensitive | within twice, sensitive |")
    print("|---|---:|---:|---:|---:|---:|---:|")
    for label, scs in (("with noise", fig11_scenarios()), ("noise-free", fig11_scenarios(noise=False))):
        res = simulate_batch(scs, progress=False)
        ref = simulate_batch(scs, rtol=1e-11, atol=1e-13, progress=False)
        ratio = {True: [], False: []}
        for r, f in zip(res, ref):
            for k in INTEGRAL_NAMES:
                true = abs(r.metrics[k] - f.metrics[k]) / abs(f.metrics[k])
                ratio[r.sensitive].append(true / r.numerical_error[k] if r.numerical_error[k] else np.inf)
        steady, shaky = np.array(ratio[False]), np.array(ratio[True])
        over = sum(not r.sensitive and max(r.numerical_error.values()) > 1e-4 for r in res)
        print(f"| {label} | {len(res)} | {sum(r.sensitive for r in res)} | {over} "
              f"| {np.mean(steady <= 2):.1%} | {steady.max():.2f} "
              f"| {np.mean(shaky <= 2) if len(shaky) else float('nan'):.1%} |")


SWITCHING_SCENARIOS = """
import numpy as np
from unidyn import Scenario
from unidyn.model import robots
from unidyn.model.noise import NoiseSpec
from unidyn.model.trajectories import Circle, FigureEight


def switching_scenarios(n):
    \"\"\"The audit's runs, then n seeded random ones at gains 20-60 with the paper's noise
    and limits, all of 10 s (public API only: each version builds them).\"\"\"
    out = [Scenario(case="compensated", robot="pioneer2", kx=30.0, ky=30.0, T=10.0,
                    trajectory=Circle(radius=0.5, omega=2.0), noise=NoiseSpec(seed=3))]
    out += [Scenario(case="compensated", robot=r, kx=k, ky=k, T=10.0, trajectory=tr,
                     noise=NoiseSpec(seed=s))
            for r, k, tr, s in (("p3dx_laser", 40.0, FigureEight(wx=1.0, wy=0.5), 126),
                                ("pioneer2_computer", 25.0, Circle(radius=0.5, omega=2.0), 123),
                                ("p3dx_laser", 40.0, Circle(radius=0.5, omega=2.0), 111))]
    rng = np.random.default_rng(2026)
    names = robots.names()
    for _ in range(n):
        k = float(rng.uniform(20.0, 60.0))
        case = str(rng.choice(["compensated", "adaptive", "uncompensated"]))
        tr = (Circle(radius=float(rng.uniform(0.3, 1.0)), omega=float(rng.uniform(0.5, 2.5)))
              if rng.uniform() < 0.5 else FigureEight(wx=float(rng.uniform(0.3, 1.2)),
                                                      wy=float(rng.uniform(0.15, 0.6))))
        out.append(Scenario(case=case, robot=str(rng.choice(names)), kx=k, ky=k, T=10.0,
                            trajectory=tr, noise=NoiseSpec(seed=int(rng.integers(1000))),
                            adapt_from=0.0))
    return out
"""
SWITCHING_PROBE = SWITCHING_SCENARIOS + """
import json, sys, time, warnings
from unidyn.engine.batch import simulate_batch
warnings.simplefilter("ignore")
scs = switching_scenarios(int(sys.argv[1]))
t = time.process_time()
res = simulate_batch(scs, progress=False)
cpu = time.process_time() - t
print(json.dumps(dict(cpu=cpu, runs=[dict(
    complete=bool(r.complete), sensitive=bool(r.sensitive), metrics=r.metrics,
    estimate=r.numerical_error, steps=r.steps, rejected=r.rejected,
    pose=np.asarray(r.pose, float).tolist()) for r in res])))
"""
FIG11_PROBE = """
import json, sys, tempfile, time, warnings
warnings.simplefilter("ignore")
from unidyn.paper import paper_fig11
from unidyn.sweeps.sweep import run_sweep
out = {}
for seeds in (None, 5):
    sweep = paper_fig11(gains=[0.5, 3.0, 10.0, 20.0, 35.0], seeds=seeds)
    with tempfile.TemporaryDirectory() as d:
        run_sweep(sweep, d + "/warm", progress=False) if seeds is None else None
        t = time.perf_counter()
        run = run_sweep(sweep, d + "/o", progress=False)
        out[str(seeds)] = dict(seconds=time.perf_counter() - t, runs=len(run.rows),
                               sensitive=sum(bool(r["sensitive"]) for r in run.rows))
print(json.dumps(out))
"""


def switching_table(against=None, random=100):
    """The switched loop's audit (module docstring): this checkout and REV in turn."""
    import json
    from unidyn.results.result import INTEGRAL_NAMES, metrics
    namespace = {}
    exec(SWITCHING_SCENARIOS, namespace)
    scs = namespace["switching_scenarios"](random)
    versions = _versions(against)
    with tempfile.TemporaryDirectory() as tmp:
        runs = {label: json.loads(_run(src, Path(tmp) / "cache", ["-c", SWITCHING_PROBE,
                                                                   str(random)])[1])
                for label, src in versions}
        fig11 = {label: json.loads(_run(src, Path(tmp) / "cache", ["-c", FIG11_PROBE])[1])
                 for label, src in versions}
    loop = ClosedLoop(scs)  # one reference for all: a step for the hardest run
    X = loop.converged()
    t = np.arange(loop.steps + 1) * loop.Ts
    ref = np.array([np.array(loop.reference(tt))[:2] for tt in t]).transpose(2, 0, 1)
    truth = [metrics(t, np.hypot(*(X[i, :, :2] - ref[i]).T), X[i, :, 3:5])
             for i in range(len(scs))]
    print(f"\nthe switched loop: the audit's 4 runs and {random} random ones at gains 20-60 "
          f"with noise and the paper's limits, 10 s, against DOP853 at rtol 1e-11 with its "
          f"steps capped at 1 ms; the promise: a run that is not sensitive is within twice "
          f"its estimate (metrics, and its position over the run)\n")
    print("| version | runs | sensitive | not sensitive beyond twice | beyond by > 1e-4 "
          "| worst true / estimate | median steps | median rejected | CPU [s] |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|---:|")
    for label, out in runs.items():
        beyond = far = 0
        worst = 0.0
        for r, m, x in zip(out["runs"], truth, X):
            if r["sensitive"] or not r["complete"] or not r["estimate"]:
                continue
            true = max(abs(r["metrics"][k] - m[k]) / abs(m[k]) for k in INTEGRAL_NAMES)
            pose = np.asarray(r["pose"])[:, :2]
            true_pose = np.max(np.abs(pose - x[::1, :2][:len(pose)])) / np.max(np.abs(x[:, :2]))
            est = max(r["estimate"][k] for k in INTEGRAL_NAMES)
            est_pose = r["estimate"].get("position", est)
            ratio = max(true / est if est else np.inf, true_pose / est_pose if est_pose else 0.0)
            worst = max(worst, ratio)
            beyond += ratio > 2
            far += ratio > 2 and max(true, true_pose) > 1e-4
        rs = out["runs"]
        print(f"| {label} | {len(rs)} | {sum(r['sensitive'] for r in rs)} | {beyond} | {far} "
              f"| {worst:.2f} | {np.median([r['steps'] for r in rs]):.0f} "
              f"| {np.median([r['rejected'] for r in rs]):.0f} | {out['cpu']:.1f} |")
    print("\nthe audit's Fig. 11 grid (4 cases x gains 0.5, 3, 10, 20, 35 x 250 s), warm, "
          "through run_sweep\n")
    print("| version | one seed [s] | five seeds [s] | five / one | sensitive, one seed "
          "| sensitive, five seeds |")
    print("|---|---:|---:|---:|---:|---:|")
    for label, f in fig11.items():
        one, five = f["None"], f["5"]
        print(f"| {label} | {one['seconds']:.1f} | {five['seconds']:.1f} "
              f"| {five['seconds'] / one['seconds']:.2f} | {one['sensitive']} of {one['runs']} "
              f"| {five['sensitive']} of {five['runs']} |")


def fig11_sensitivity_table(seeds=5):
    """The audit's Fig. 11 grid (4 cases x gains 0.5, 3, 10, 20, 35 x 250 s) over seeds,
    each run estimated alone (``estimate="each"``) and as a sweep runs its seeds
    (``"per_point"``): each run against the same run at rtol 1e-11 (the switches located,
    the clipped values resolved) and against it with its start moved by 1e-12 m, at rtol
    1e-10 and 1e-11: a run is truly sensitive where that move changes a metric by more
    than 1e-4 at both. The flag against the truth, and the runs not flagged within twice
    their estimate of the tight run."""
    from unidyn.engine import kernels as k
    from unidyn.engine.batch import _Call
    from unidyn.paper import paper_fig11
    from unidyn.progress import Progress
    from unidyn.results.result import INTEGRAL_NAMES
    scs = [p.scenario for p in paper_fig11(gains=[0.5, 3.0, 10.0, 20.0, 35.0],
                                          seeds=seeds).points()]
    res, seconds = {}, {}
    for mode in ("each", "per_point"):
        t = time.perf_counter()
        res[mode] = simulate_batch(scs, progress=False, estimate=mode)
        seconds[mode] = time.perf_counter() - t
    run = _Call(k, "compiled", True, Progress(False, 1, show=False), [None] * len(scs))
    passes = {(rtol, shift): run.runs(scs, (rtol, rtol / 100), shift)
              for rtol in (1e-10, 1e-11) for shift in (0.0, 1e-12)}

    def moved(a, b):
        return max(abs(a.metrics[m] - b.metrics[m]) / abs(a.metrics[m]) for m in INTEGRAL_NAMES)
    truly = [min(moved(passes[(rt, 0.0)][i], passes[(rt, 1e-12)][i]) for rt in (1e-10, 1e-11))
             > 1e-4 for i in range(len(scs))]
    print(f"\nthe audit's Fig. 11 grid over {seeds} seeds ({len(scs)} runs of 250 s): the "
          f"sensitivity flag against the truth (a 1e-12 m move of the start changes a metric "
          f"by more than 1e-4 at rtol 1e-10 and 1e-11)\n")
    print("| estimate | seconds | runs | flagged | truly sensitive | flagged and truly "
          "| flagged, not truly | truly, not flagged | not flagged, beyond twice the estimate |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|---:|")
    for mode, rs in res.items():
        flagged = [r.sensitive for r in rs]
        steady = [i for i in range(len(scs)) if not flagged[i] and not truly[i]]
        beyond = [i for i in steady
                  if moved(passes[(1e-11, 0.0)][i], rs[i]) > 2 * max(
                      rs[i].numerical_error[m] for m in INTEGRAL_NAMES)]
        both = sum(f and s for f, s in zip(flagged, truly))
        print(f"| {mode} | {seconds[mode]:.1f} | {len(scs)} | {sum(flagged)} | {sum(truly)} "
              f"| {both} | {sum(flagged) - both} | {sum(truly) - both} "
              f"| {len(beyond)} of {len(steady)} |")


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
                 f"{t_diag / t_np:.2g}x faster than the diagram; {1e3 * t_np / sc.steps:.1f} ms "
                 f"per sample interval (the plain-Python warning estimates "
                 f"{1e3 * PLAIN_SECONDS_PER_SAMPLE:g} ms)"))

    scs = fig11_scenarios()
    batch_res = quiet_res = t_sweep = None
    if kernels.AVAILABLE:
        for label, cases in (("", scs), (", noise-free", fig11_scenarios(noise=False))):
            times = []
            for _ in range(5):
                t, res = timed(lambda: simulate_batch(cases, backend="compiled", progress=False))
                times.append(t)
            t_run = float(np.median(times))
            steps = sum(r.steps + r.rejected for r in res)  # the runs returned, not the probes
            rows.append((f"Fig. 11 sweep ({len(cases)} runs x 250 s{label}), batch engine, "
                         f"compiled, each run with its error estimate, median of 5", t_run,
                         f"{steps / 1e6:.1f} M Dormand-Prince steps in the runs returned "
                         f"({steps / (len(cases) * 2500):.1f} per 0.1 s sample); "
                         f"{sum(r.sensitive for r in res)} runs sensitive, "
                         f"{sum(not r.complete for r in res)} stopped, every one with its "
                         f"metrics; {os.cpu_count()} threads"))
            if label:
                quiet_res = res
            else:
                batch_res, t_sweep = res, t_run
        seeds = [sc.replace(noise=dataclasses.replace(sc.noise, seed=s)) for s in range(1, 6)
                 for sc in scs]
        t5, res5 = timed(lambda: simulate_batch(seeds, backend="compiled", progress=False),
                         repeat=2)
        rows.append((f"Fig. 11 sweep over 5 noise seeds ({len(seeds)} runs x 250 s), batch "
                     f"engine, compiled, best of 2", t5,
                     f"{sum(r.sensitive for r in res5)} runs sensitive: their spread over "
                     f"seeds is the error bar"))
        rows += rhs_rows()
    sample = np.unique(np.linspace(0, len(scs) - 1, 4 if quick else 12).round().astype(int))
    t_sample, diag_res = timed(lambda: [unidyn.simulate(scs[i]) for i in sample])
    per_point = t_sample / len(sample)
    note = f"{per_point:.1f} s per point"
    if t_sweep is not None:
        note += (f"; the batch engine (one seed, with its estimates) is "
                 f"{per_point * len(scs) / t_sweep:.0f}x faster")
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
        fine = simulate_batch(fig11_scenarios(noise=False), rtol=1e-11, atol=1e-13,
                              backend="compiled", progress=False)
        rel = np.array([abs(a.metrics["iae"] - b.metrics["iae"]) / b.metrics["iae"]
                        if a.complete and b.complete else np.nan
                        for a, b in zip(quiet_res, fine)]).reshape(-1, 4)
        print("noise-free Fig. 11 sweep at the defaults vs rtol 1e-11: IAE relative "
              "difference, largest over the 70 gains, by case: "
              + ", ".join(f"{c} {v:.1e}" for c, v in zip(
                  ("uncompensated", "compensated 0.9", "adaptive", "compensated exact"),
                  np.nanmax(rel, axis=0))))


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--quick", action="store_true", help="sample 4 bdsim sweep points, not 12")
    p.add_argument("--cold", action="store_true",
                   help="only first and second results with an empty compiler cache")
    p.add_argument("--section5", action="store_true", help="only the README's job")
    p.add_argument("--accuracy", action="store_true",
                   help="only each engine's error against converged solutions")
    p.add_argument("--switching", action="store_true",
                   help="only the switched loop's audit against a converged reference")
    p.add_argument("--random", type=int, default=100, metavar="N",
                   help="random scenarios of --switching (default 100)")
    p.add_argument("--against", metavar="REV",
                   help="with --cold, --section5, --accuracy or --switching: also git revision "
                        "REV, in turn")
    p.add_argument("--repeat", type=int, default=2, help="runs of each version (--section5)")
    p.add_argument("--memory", action="store_true", help="only the memory table")
    p.add_argument("--long", action="store_true",
                   help="add 10^7-sample runs (float32; float64 with log_series=()) to the memory table (4-6 min)")
    args = p.parse_args(argv)
    if args.cold:
        cold_table(args.against)
    elif args.section5:
        section5_table(args.against, args.repeat)
    elif args.accuracy:
        accuracy_table(args.against)
    elif args.switching:
        switching_table(args.against, args.random)
        fig11_sensitivity_table()
    elif args.memory:
        memory_table(args.long)
    else:
        engines_table(args.quick)
        memory_table(args.long)


if __name__ == "__main__":
    main()
