"""A compensated loop whose estimate is far above theta is much faster than the
scenario says (the velocity loop closed by Eq. 14 scales with theta_hat / theta), and
the update law drifts theta_hat that far under noise: the batch engine checks the
loop's rate at every sample (equations.loop_step_rate) and takes the intervals that
need it with finer steps, in both backends, with the same numbers whichever runs share
a call."""

import numpy as np
import pytest

import unidyn
from unidyn import Scenario
from unidyn.model import equations
from unidyn.engine.batch import simulate_batch
from unidyn.engine.rhs import ClosedLoop
from unidyn.model.unicycle import NO_LIMITS

pytestmark = pytest.mark.reliability

P3DX = unidyn.model.robots.get("p3dx_laser")


def _far(c, **kw):
    """Compensation with an estimate c times theta, no limits (nothing clips the loop)."""
    return Scenario(case="compensated", theta_hat0=P3DX.scaled(c), limits=NO_LIMITS,
                    noise=None, **{"T": 5.0, **kw})


def _jacobian_radius(sc, X, t=0.0, k=0, e=1e-5):
    """Spectral radius of d(u', w')/d(u, w) of the whole loop (ClosedLoop.rhs, with
    the stop at the speed limits), by central differences, with numpy's eigenvalues:
    another route than velocity_loop_rate's forward differences of the accelerations
    and its closed form for the 2x2 eigenvalues."""
    loop = ClosedLoop(sc)
    J = np.zeros((2, 2))
    for j, s in enumerate((3, 4)):
        d = np.zeros(13)
        d[s] = e
        J[:, j] = (loop.rhs(t, (X + d)[None], k)[0, 3:5] - loop.rhs(t, (X - d)[None], k)[0, 3:5]) / (2 * e)
    return np.abs(np.linalg.eigvals(J)).max()


@pytest.mark.parametrize("c", [1.0, 10.0, 100.0])
def test_the_velocity_loop_rate_is_the_loops_own(c):
    rng = np.random.default_rng(int(c))
    sc = _far(c)
    loop = ClosedLoop(sc)
    for _ in range(20):
        X = loop.initial_state()[0] + rng.normal(scale=0.3, size=13)
        X[5:11] = sc.theta_hat_initial
        t = float(rng.uniform(0, 5))
        rate = equations.velocity_loop_rate(X[:, None], loop.reference(t), loop.P.T,
                                            (0.0, 0.0, 0.0, 0.0))[0][0]
        assert rate == pytest.approx(_jacobian_radius(sc, X, t), rel=1e-4)


def test_the_rate_grows_with_the_estimate():
    """v_ref = G theta_hat: scaling theta_hat by c scales the loop gain by c."""
    sc = [_far(c) for c in (10.0, 100.0, 1000.0)]
    rates = [ClosedLoop(s).step_rate(0.0, ClosedLoop(s).initial_state(), 0)[0] for s in sc]
    assert rates[1] / rates[0] == pytest.approx(10, rel=0.1)
    assert rates[2] / rates[1] == pytest.approx(10, rel=0.02)


@pytest.mark.parametrize("backend", ["compiled", "plain"])
def test_a_fast_loop_gets_finer_steps_where_it_needs_them_and_the_right_answer(backend):
    sc = _far(100.0)
    loop = ClosedLoop(sc)
    # the scenario's own rates ask for the default step, where this loop is beyond
    # RK4's stability (|lambda h| < 2.78)
    rate0 = loop.step_rate(0.0, loop.initial_state(), 0)[0]
    r, = simulate_batch([sc], backend=backend)
    assert r.substeps == 10 and sc.Ts / r.substeps * rate0 > 2.78
    assert r.complete and r.substeps_max > r.substeps
    assert r.rk4_steps > r.substeps * sc.steps  # the finer intervals are counted
    # the step of the finest interval resolves the rate met there
    fine, = simulate_batch([sc], substeps=2000, backend="compiled")
    assert fine.substeps_max == 2000  # 2000 steps resolve it everywhere: nothing finer
    assert np.abs(r.pose - fine.pose).max() < 2e-5  # m (the default step alone: 0.3 m off)
    assert np.abs(r.velocity - fine.velocity).max() < 2e-5 * np.abs(fine.velocity).max()


def test_both_backends_refine_the_same_intervals():
    sc = _far(100.0)
    a, = simulate_batch([sc], backend="compiled")
    b, = simulate_batch([sc], backend="plain")
    assert (a.substeps_max, a.rk4_steps) == (b.substeps_max, b.rk4_steps)
    assert np.abs(a.pose - b.pose).max() < 1e-9


def test_runs_refined_in_one_call_are_the_runs_alone_bit_for_bit():
    """Runs that take intervals with finer steps, in one call with runs that do not:
    each run's numbers are those of the run alone."""
    from unidyn.engine import kernels as _kernels
    if not _kernels.AVAILABLE:
        pytest.skip("numba not installed")
    pts = [_far(c, T=2.0) for c in (1.0, 60.0, 2.0, 100.0, 3.0, 150.0, 1.5, 80.0, 2.5)]
    together = simulate_batch(pts, backend="compiled")
    assert len({r.substeps for r in together}) == 1
    assert sum(r.substeps_max > r.substeps for r in together) >= 3
    for p, a in zip(pts, together):
        b, = simulate_batch([p], backend="compiled")
        for f in ("pose", "velocity", "theta_hat", "v_ref"):
            assert np.array_equal(getattr(a, f), getattr(b, f)), f
        assert (a.substeps_max, a.rk4_steps) == (b.substeps_max, b.rk4_steps)


@pytest.mark.parametrize("backend", ["compiled", "plain"])
def test_a_loop_too_fast_for_any_step_stops_with_a_reason(backend):
    r, = simulate_batch([_far(1e6, name="far")], backend=backend)
    assert not r.complete
    assert "too stiff" in r.message and "unidyn.simulate" in r.message and "far" in r.message
    assert r.metrics["iae"] is None


def test_the_check_leaves_loops_that_the_scenario_describes_alone():
    """The paper's four simulations: the loop never needs a finer step than the rule's."""
    rs = simulate_batch([Scenario.paper(n, T=30.0) for n in (1, 2, 3, 4)])
    assert all(r.complete and r.substeps_max == r.substeps for r in rs)


def test_both_backends_stop_a_loop_too_fast_at_the_same_sample_with_the_same_reason():
    sc = _far(1e6, name="far", log_every=5)
    a, = simulate_batch([sc], backend="compiled")
    b, = simulate_batch([sc], backend="plain")
    assert a.message == b.message and not a.complete
    np.testing.assert_array_equal(a.t, b.t)
    assert np.abs(a.pose - b.pose).max() < 1e-12


def test_the_plain_kernels_take_only_the_runs_that_need_it_again():
    """Its refined runs are integrated as a batch of their own; the others keep their
    numbers, and each run is the run alone, bit for bit."""
    pts = [_far(1.0, T=2.0), _far(100.0, T=2.0), _far(2.0, T=2.0), _far(150.0, T=2.0)]
    together = simulate_batch(pts, backend="plain")
    assert [r.substeps_max > r.substeps for r in together] == [False, True, False, True]
    for p, a in zip(pts, together):
        b, = simulate_batch([p], backend="plain")
        assert np.array_equal(a.pose, b.pose) and np.array_equal(a.velocity, b.velocity)
        assert (a.substeps_max, a.rk4_steps) == (b.substeps_max, b.rk4_steps)
