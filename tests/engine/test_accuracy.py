"""The batch engine's promise: a run that is not sensitive has a numerical error estimate
of at most 1e-4 (relative) and its true error is within twice its estimate; a run that
amplifies perturbations says so (``sensitive``) and keeps its metrics.

The true error is measured against an independent converged solution: scipy's DOP853 at
rtol 1e-11 on the loop's right-hand side as arrays (unidyn.model.closed_loop), restarted at
every sample with the noise held, as bdsim restarts its solver at every clock tick, its
steps capped at 1 ms so that no episode of the limits' clipping is jumped over
(ClosedLoop.converged: it evaluates the limits where it evaluates the loop, and shares
nothing with the batch engine's location of the switches)."""

import functools

import numpy as np
import pytest

import unidyn
from unidyn._errors import AccuracyWarning
from unidyn.engine import kernels as _kernels
from unidyn.engine.batch import ACCURACY, DECISIVE, SERIES, simulate_batch
from unidyn.model.closed_loop import ClosedLoop
from unidyn.model.noise import NoiseSpec
from unidyn.model.scenario import Scenario
from unidyn.model.trajectories import Circle, FigureEight
from unidyn.model.unicycle import Limits
from unidyn.results.result import INTEGRAL_NAMES, metrics

#: Scenarios whose rates no list of the loop's rates foresaw: a reference faster than the
#: robot, a fast circle at high gains, the paper's run with noise, and adaptation at high
#: gains with the paper's limits. The last two take seconds of scipy each: whole-system.
SCENARIOS = {
    "fast figure eight": Scenario(case="compensated", limits=Limits(), T=2.0, noise=None,
                                  trajectory=FigureEight(ax=0.02, ay=0.02, wx=50.0, wy=25.0)),
    "paper 4 with noise": Scenario.paper(4, T=10.0, adapt_from=0.0),
    "fast circle at kx = ky = 50": Scenario(case="compensated", kx=50.0, ky=50.0, T=5.0,
                                            trajectory=Circle(radius=0.3, omega=5.0),
                                            noise=None),
    "gamma 100 with limits": Scenario(gamma=[100.0] * 6, adapt_from=0.0, T=10.0, noise=None),
    "gamma 1000 with limits": Scenario(gamma=[1000.0] * 6, adapt_from=0.0, T=6.0, noise=None),
}
SLOW = ("fast circle at kx = ky = 50", "gamma 100 with limits", "gamma 1000 with limits")
#: Where the acceleration limits switch on and off within 15 ms, at the gains where Fig.
#: 11 ends, with the paper's noise: a step that jumps such an episode sees nothing of it
#: (runs that were off by 0.36 %, 0.5 % and 5e-4 with estimates of 2-3e-5, and one
#: wrongly flagged sensitive and off by 4 %).
SWITCHING = {
    "pioneer2 circle k = 30, seed 3": Scenario(
        case="compensated", robot="pioneer2", kx=30.0, ky=30.0, T=10.0,
        trajectory=Circle(radius=0.5, omega=2.0), noise=NoiseSpec(seed=3)),
    "p3dx_laser figure eight k = 40, seed 126": Scenario(
        case="compensated", robot="p3dx_laser", kx=40.0, ky=40.0, T=20.0,
        trajectory=FigureEight(wx=1.0, wy=0.5), noise=NoiseSpec(seed=126)),
    "pioneer2_computer circle k = 25, seed 123": Scenario(
        case="compensated", robot="pioneer2_computer", kx=25.0, ky=25.0, T=20.0,
        trajectory=Circle(radius=0.5, omega=2.0), noise=NoiseSpec(seed=123)),
    "p3dx_laser circle k = 40, seed 111": Scenario(
        case="compensated", robot="p3dx_laser", kx=40.0, ky=40.0, T=20.0,
        trajectory=Circle(radius=0.5, omega=2.0), noise=NoiseSpec(seed=111)),
}
SCENARIOS.update(SWITCHING)
SLOW += tuple(SWITCHING)
#: The audit's runs of 20 s, checked against one converged solution of the three.
JOINT = tuple(n for n, sc in SWITCHING.items() if sc.T == 20.0)


def _converged(scs, rtol=1e-11, atol=1e-13, **options):
    """For each of ``scs`` (one ClosedLoop): its metrics and states (steps + 1, 13) by
    ClosedLoop.converged at these tolerances."""
    loop = ClosedLoop(scs)
    X = loop.converged(rtol=rtol, atol=atol, **options)
    t = np.arange(loop.steps + 1) * loop.Ts
    ref = np.array([np.array(loop.reference(tt))[:2] for tt in t]).transpose(2, 0, 1)
    return [(metrics(t, np.hypot(*(x[:, :2] - h).T), x[:, 3:5]), x) for x, h in zip(X, ref)]


@pytest.fixture(scope="module")
def converged():
    """The converged solution of a scenario of SCENARIOS by its name, computed once per
    process and only for the scenarios the tests that run there ask for."""
    return functools.cache(lambda name: _converged([SCENARIOS[name]])[0])


@pytest.mark.parametrize("name", [pytest.param(n, marks=[pytest.mark.slow] if n in SLOW else [])
                                  for n in SCENARIOS if n not in JOINT])
def test_a_run_that_is_not_sensitive_is_within_twice_its_estimate(name, converged):
    """The metrics, and the series over every logged sample: the pose, the distance error
    and theta_hat (relative to the series' largest value), each within twice its
    estimate."""
    truth, X = converged(name)
    backends = ["plain"] + (["compiled"] if _kernels.AVAILABLE else [])
    if name in SWITCHING:  # plain Python takes minutes on these: the compiled engine's
        backends = backends[-1:]
    for backend in backends:
        r, = simulate_batch([SCENARIOS[name]], backend=backend)
        _within_twice(r, truth, X, backend)


@pytest.mark.slow
def test_where_the_limits_switch_runs_of_20_s_are_within_twice_their_estimates():
    """The audit's runs of 20 s (JOINT), as the test above, against one converged solution
    of the three: scipy's error norm is the RMS over all their components, so its
    tolerances are divided by sqrt(3) to hold each run's within the single run's."""
    scs = [SCENARIOS[n] for n in JOINT]
    root = np.sqrt(len(scs))
    for r, (truth, x) in zip(simulate_batch(scs),
                             _converged(scs, rtol=1e-11 / root, atol=1e-13 / root)):
        _within_twice(r, truth, x, "compiled")


def _within_twice(r, truth, X, backend):
    """``r`` not sensitive, its estimates within the promise, and its metrics and series
    within twice them of ``truth`` and ``X`` (the converged metrics and states)."""
    assert r.complete and not r.sensitive, r.message
    # the metrics within the promise; a logged series beyond it is named in the message
    assert max(r.numerical_error[k] for k in DECISIVE) <= ACCURACY, r.numerical_error
    for k in SERIES:
        assert r.numerical_error[k] <= ACCURACY or f"logged {k}" in r.message, (k, r.message)
    for k in INTEGRAL_NAMES:
        true = abs(r.metrics[k] - truth[k]) / abs(truth[k])
        assert true <= 2 * r.numerical_error[k], (backend, k, true, r.numerical_error[k])
    series = {"position": (r.pose[:, :2], X[:, :2]), "heading": (r.pose[:, 2], X[:, 2]),
              "theta_hat": (r.theta_hat, X[:, 5:11])}
    for k, (got, want) in series.items():
        true = np.max(np.abs(got - want)) / np.max(np.abs(want))
        assert true <= max(2 * r.numerical_error[k], 1e-12), (backend, k, true,
                                                             r.numerical_error[k])


#: Fig. 11's case (a) at k = 30 with the paper's noise: its trajectories separate
#: exponentially where the acceleration limits clip (no tolerance converges it); without
#: the acceleration limits the same run converges.
FIG11_A30 = unidyn.paper.paper_fig11(T=100.0, gains=[30.0]).points()[0].scenario
FREE = Limits(speed_max=FIG11_A30.limits.speed[0], steer_max=FIG11_A30.limits.speed[1])


def test_a_loop_that_amplifies_perturbations_is_flagged_with_its_metrics_kept():
    r, = simulate_batch([FIG11_A30])
    assert r.complete and r.sensitive
    assert "moves" in r.message and "perturbation" in r.message and "seeds" in r.message
    assert all(np.isfinite(v) for v in r.metrics.values())
    # the estimate is how far the perturbation moved it: far beyond the promise
    assert max(r.numerical_error.values()) > ACCURACY


def test_the_same_loop_without_acceleration_limits_is_not_flagged():
    r, = simulate_batch([FIG11_A30.replace(limits=FREE)])
    assert r.complete and not r.sensitive, r.message
    assert max(r.numerical_error[k] for k in DECISIVE) <= ACCURACY


@pytest.mark.slow
def test_the_flag_agrees_with_an_independent_solver():
    """scipy's DOP853 at two tolerances: the flagged loop's IAE moves between them by more
    than the promise, the other's agrees far within it."""
    def iae(sc, rtol, max_step):
        X = ClosedLoop(sc).converged(rtol=rtol, atol=rtol / 100, max_step=max_step)[0]
        loop = ClosedLoop(sc)
        t = np.arange(sc.steps + 1) * sc.Ts
        ref = np.array([np.ravel(loop.reference(tt)[:2]) for tt in t])
        return metrics(t, np.hypot(*(X[:, :2] - ref).T), X[:, 3:5])["iae"]
    # steps of at most 5 ms keep every episode of clipping longer than two steps in view
    # (the diagram's cap at these gains); without acceleration limits nothing clips
    for sc, sensitive, cap in ((FIG11_A30, True, 5e-3),
                               (FIG11_A30.replace(limits=FREE), False, np.inf)):
        a, b = iae(sc, 1e-8, cap), iae(sc, 1e-10, cap)
        assert (abs(a - b) / abs(b) > ACCURACY) is sensitive, (a, b)


@pytest.mark.slow
def test_the_diagram_says_when_its_accuracy_is_not_vouched_for():
    with pytest.warns(AccuracyWarning, match="not vouched"):
        r = unidyn.simulate(SCENARIOS["gamma 1000 with limits"])
    assert r.complete and "rtol" in r.message and r.numerical_error is None


def test_identical_calls_give_identical_bits_whatever_ran_before():
    """The backend is chosen from the call alone: the same call, before and after other
    work in the process (other scenarios, the other backend, a large call), gives the
    same bits."""
    sc = Scenario.paper(4, T=5.0, adapt_from=1.0)
    first, = simulate_batch([sc])
    simulate_batch([Scenario.paper(n, T=30.0) for n in (1, 2, 3)] * 20, progress=False)
    simulate_batch([sc], backend="plain")
    again, = simulate_batch([sc])
    assert first.backend == again.backend
    for k in ("pose", "velocity", "theta_hat", "v_ref"):
        assert np.array_equal(getattr(first, k), getattr(again, k)), k
    assert (first.steps, first.rejected) == (again.steps, again.rejected)
    assert first.numerical_error == again.numerical_error and first.metrics == again.metrics


def _seed_runs_keep_the_promise(scs):
    """estimate="per_point" over ``scs`` (one scenario over seeds, the smallest second):
    the smallest seed as it is alone; every other seed with an estimate of its own, made
    from a decade looser than the smallest seed's tolerance on, and its metrics and
    position within twice it of the converged solution, whatever else is in the call."""
    out = simulate_batch(scs, estimate="per_point")
    alone, = simulate_batch([scs[1]])
    assert out[1].metrics == alone.metrics and out[1].numerical_error == alone.numerical_error
    # a 5 ms cap: within 1e-9 of the 1 ms one on these runs, in a quarter of the time
    for r, (truth, x) in zip(out, _converged(scs, rtol=1e-10, atol=1e-12, max_step=5e-3)):
        assert r.estimate == "tightened" and r.rtol <= alone.rtol, (r.estimate, r.rtol)
        _within_twice(r, truth, x, r.scenario.name)
    fewer = simulate_batch([scs[2], scs[1]], estimate="per_point")
    assert fewer[0].metrics == out[2].metrics


def test_runs_over_noise_seeds_each_keep_the_promise():
    _seed_runs_keep_the_promise([Scenario.paper(3, T=3.0, noise=NoiseSpec(seed=s), name=f"seed {s}")
                                 for s in (4, 2, 9)])
