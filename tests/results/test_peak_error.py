"""The peak distance error, a metric of one entry (unidyn.model.metrics.METRICS), in
both engines, against an independent computation: the largest distance error over the
samples of scipy's converged solution of the same loop (unidyn.model.closed_loop.ClosedLoop,
solve_ivp at rtol 1e-11), and over every sample each engine logs.

The robot starts at rest where the figure eight starts, which moves off at 0.5 m/s: the
error grows from zero and falls again as the controller catches up, so the peak lies
inside the run (not at a sample the rule could get by its first or last value)."""

import numpy as np
import pytest

import unidyn
from unidyn.engine import kernels as _kernels
from unidyn.engine.batch import ACCURACY, DECISIVE, simulate_batch
from unidyn.model.closed_loop import ClosedLoop
from unidyn.model.trajectories import FigureEight

SCENARIO = unidyn.Scenario(case="compensated", noise=None, T=4.0, x0=(0.0, 0.0, 0.0),
                           kx=1.0, ky=1.0, trajectory=FigureEight(), limits=unidyn.NO_LIMITS)


@pytest.fixture(scope="module")
def converged():
    """The converged distance error at every sample, m (no limits: no episode of
    clipping for its steps to jump)."""
    X = ClosedLoop(SCENARIO).converged(rtol=1e-11, atol=1e-13, max_step=0.1)[0]
    loop = ClosedLoop(SCENARIO)
    t = np.arange(SCENARIO.steps + 1) * SCENARIO.Ts
    ref = np.array([np.ravel(loop.reference(tt)[:2]) for tt in t])
    return np.hypot(*(X[:, :2] - ref).T)


def test_the_peak_lies_inside_the_run(converged):
    i = int(np.argmax(converged))
    assert 0 < i < len(converged) - 1 and converged[i] > 2 * max(converged[0], converged[-1])


@pytest.mark.parametrize("backend", ["plain", "compiled"])
def test_the_batch_engine_s_peak_is_the_converged_one_within_its_estimate(backend, converged):
    if backend == "compiled" and not _kernels.AVAILABLE:
        pytest.skip("numba is not installed")
    r, = simulate_batch([SCENARIO], backend=backend)
    peak, truth = r.metrics["peak_error"], float(np.max(converged))
    # accumulated at every sample: the largest of the logged series at log_every 1
    assert peak == float(np.max(r.error))
    # its own estimate, as every metric's; it does not choose the tolerance
    assert "peak_error" in r.numerical_error and "peak_error" not in DECISIVE
    assert abs(peak - truth) / truth <= max(2 * r.numerical_error["peak_error"], 1e-12)
    assert abs(peak - truth) / truth <= ACCURACY
    # thinning the log keeps the peak over every sample
    thin, = simulate_batch([SCENARIO.replace(log_every=8)], backend=backend)
    assert thin.metrics["peak_error"] == peak and np.max(thin.error) < peak


def test_the_diagram_s_peak_is_the_converged_one(converged):
    r = unidyn.simulate(SCENARIO, rtol=1e-9, atol=1e-11)
    peak, truth = r.metrics["peak_error"], float(np.max(converged))
    assert peak == float(np.max(r.error))
    assert abs(peak - truth) / truth <= 1e-6
    thin = unidyn.simulate(SCENARIO.replace(log_every=8), rtol=1e-9, atol=1e-11)
    assert thin.metrics["peak_error"] == peak and np.max(thin.error) < peak


def test_the_peak_is_printed_saved_swept_and_plotted(tmp_path):
    r, = simulate_batch([SCENARIO.replace(T=2.0)], backend="plain")
    assert "peak_error" in repr(r) and "m  (numerical error" in repr(r).split("peak_error")[1]
    assert r.summary()["metrics"]["peak_error"] == r.metrics["peak_error"]
    assert "peak_error" in r.summary()["numerical_error"]
    from unidyn.sweeps.plots import plot_metrics
    from unidyn.sweeps.sweep import Sweep, run_sweep
    from unidyn.sweeps.sweep_files import read_metrics
    sweep = Sweep(base={"T": 1.0, "case": "compensated", "x0": [0.0, 0.0, 0.0]},
                  grid={"kxy": [0.5, 1.0], "seed": [1, 2]})
    run_sweep(sweep, tmp_path / "out", progress=False)
    rows = read_metrics(tmp_path / "out")
    assert all(row["peak_error"] > 0 for row in rows)
    statistics = (tmp_path / "out" / "statistics.csv").read_text().splitlines()[0]
    assert "peak_error_mean" in statistics and "peak_error_sem" in statistics
    plot_metrics(sweep, rows, tmp_path / "peak.png", metric="peak_error")
    assert (tmp_path / "peak.png").stat().st_size > 0
