"""The batch engine's kernels (unidyn.engine.kernels): their right-hand side, one run at
a time with the reference evaluated from the parameter table, against the closed loop of
unidyn.model.closed_loop, all runs at once as arrays with the reference from the trajectory
objects. Both evaluate unidyn.model.equations.loop_rates, so this checks the kernels'
packing of parameters, references and noise, not the equations (which tests/model
holds to the paper's, typed in again); and the Dormand-Prince step against what the
method gives by construction."""

import numpy as np
import pytest

from unidyn.engine import kernels as _kernels
from unidyn.model.closed_loop import ClosedLoop
from unidyn.model.equations import AUTO
from unidyn.model.scenario import Scenario
from unidyn.model.trajectories import Circle, Line

# the kernel's right-hand side (one run at a time, its reference evaluated from the
# parameter table) as plain Python (what runs without numba) always, and compiled where
# numba is installed
KERNEL_RHS = [pytest.param(getattr(_kernels.loop_rhs, "py_func", _kernels.loop_rhs),
                           id="python")] + (
    [pytest.param(_kernels.loop_rhs, id="compiled")] if _kernels.AVAILABLE else [])


@pytest.mark.parametrize("rhs", KERNEL_RHS)
def test_kernel_rhs_equals_the_closed_loop_of_all_runs_as_arrays(rhs):
    rng = np.random.default_rng(7)
    scs = [Scenario.paper(n, T=5.0, adapt_from=1.0) for n in (1, 2, 3, 4)]
    scs += [Scenario.paper(4, T=5.0, vd_dot="filter", leakage=lk, adapt_from=0.0,
                           trajectory=tr, robot=r)
            for lk, tr, r in (("fx44850", Circle(radius=1.5, omega=-0.3, phase=0.4), "khepera3"),
                              ("none", Line(start=(0.1, -0.2), velocity=(0.3, 0.1)), "robulab10"),
                              ("paper", {"type": "figure_eight", "ax": 2.0, "wy": 0.3}, "p3dx"))]
    loop = ClosedLoop(scs)
    worst = 0.0
    for _ in range(100):
        X = loop.initial_state() + rng.normal(scale=0.5, size=(loop.B, 13))
        X[:, 3:5] = rng.uniform(-1.0, 1.0, size=(loop.B, 2))  # also beyond the speed limits
        t = rng.uniform(0.0, 5.0)
        k = int(rng.integers(0, loop.steps))
        ref = loop.rhs(t, X, k)
        for i in range(loop.B):
            dX, margins = np.empty(13), np.empty(12)  # the margins, then the clipped values
            mode = np.array([t] + [AUTO] * 6)  # every switch decided where it is evaluated
            rhs(t, X[i], (loop.P[i], (*loop.pos_noise[i, k], *loop.vel_noise[i, k]), ()), mode,
                dX, margins)
            worst = max(worst, np.max(np.abs(dX - ref[i]) / (1.0 + np.abs(ref[i]))))
    assert worst < 1e-12


def _linear(t, x, A, mode, out, margins):
    """dx/dt = A x (no switches)."""
    for i in range(x.size):
        out[i] = 0.0
        for j in range(x.size):
            out[i] += A[i, j] * x[j]


def _py(f):
    return getattr(f, "py_func", f)


# the step as plain Python with a Python right-hand side; compiled with a compiled one
DP = [pytest.param((_py(_kernels.dp_step), _linear), id="python")]
if _kernels.AVAILABLE:
    import numba
    DP.append(pytest.param((_kernels.dp_step, numba.njit(_linear)), id="compiled"))


def _step(dp, linear, A, x, h):
    work = _kernels.work_arrays.py_func(x.size, 0) if hasattr(_kernels.work_arrays, "py_func") \
        else _kernels.work_arrays(x.size, 0)
    work.K[0] = A @ x
    err = dp(linear, 0.0, x, h, A, work, 0.0, 1.0)  # atol 1: the error itself
    return work.Xn, err, work.K


@pytest.mark.parametrize("dp", DP)
def test_a_dormand_prince_step_is_the_method_s_polynomial_of_a_linear_system(dp):
    """For dx/dt = A x one step of the fifth-order Dormand-Prince method is R(hA) x with
    its stability polynomial R(z) = 1 + z + z^2/2 + z^3/6 + z^4/24 + z^5/120 + z^6/600
    (Hairer, Norsett, Wanner, Solving ODEs I, Sec. II.5): on seeded random A, x and h;
    and the last stage is f at the step's end (the next step's first)."""
    step, linear = dp
    rng = np.random.default_rng(3)
    for _ in range(20):
        n = int(rng.integers(1, 6))
        A, x, h = rng.normal(size=(n, n)), rng.normal(size=n), float(rng.uniform(0.01, 0.5))
        out, _, K = _step(step, linear, A, x, h)
        z, R, term = h * A, np.eye(n), np.eye(n)
        for j in range(1, 6):
            term = term @ z / j
            R = R + term
        R = R + np.linalg.matrix_power(z, 6) / 600
        np.testing.assert_allclose(out, R @ x, rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(K[6], A @ out, rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("dp", DP)
def test_the_error_estimate_is_of_fifth_order(dp):
    """The embedded estimate is the local error of a fourth-order method: O(h^5), so
    halving h divides it by about 32, on seeded random linear systems."""
    step, linear = dp
    rng = np.random.default_rng(5)
    for _ in range(10):
        n = int(rng.integers(2, 6))
        A, x = rng.normal(size=(n, n)), rng.normal(size=n)
        errs = [_step(step, linear, A, x, h)[1] for h in (0.02, 0.01)]
        assert 28 < errs[0] / errs[1] < 36


def test_two_threads_with_their_own_python_references_each_get_their_own_answer():
    """A reference that is a Python function travels with its call: two threads running
    the batch engine at once, each with its own FunctionTrajectory, get what each gets
    alone."""
    from concurrent.futures import ThreadPoolExecutor

    from unidyn.engine.batch import simulate_batch
    from unidyn.model.trajectories import FunctionTrajectory

    def line(vx):
        return FunctionTrajectory(lambda t: (np.array([vx * t, 0.0]), np.array([vx, 0.0])),
                                  acceleration=lambda t: np.zeros(2))
    scs = [Scenario.paper(3, T=3.0, noise=None, trajectory=line(v)) for v in (0.1, 0.3)]
    alone = [simulate_batch([sc])[0] for sc in scs]
    with ThreadPoolExecutor(2) as pool:
        for _ in range(3):
            together = list(pool.map(lambda sc: simulate_batch([sc])[0], scs))
            for a, b in zip(alone, together):
                assert np.array_equal(a.pose, b.pose) and np.array_equal(a.reference, b.reference)
    assert not np.allclose(alone[0].reference, alone[1].reference)


def test_a_speed_limit_reached_at_a_step_s_end_is_held_exactly():
    """The angular speed reaches its limit exactly at a sample (constant angular
    acceleration 1.745 rad/s² from 0 for 1 s, Ts = 0.05 s): the step that ends there ends
    on the switch, and the logged speed is within the limit, not one rounding beyond it."""
    from unidyn.engine.batch import simulate_batch
    from unidyn.model.trajectories import FigureEight
    from unidyn.model.unicycle import Limits
    limits = Limits(speed_max=0.75, steer_max=1.745, accel_max=0.3, angular_accel_max=1.745)
    sc = Scenario(case="uncompensated", robot="wheelchair_55kg", a=0.5, x0=(1.0, 0.0, 1.5),
                  trajectory=FigureEight(ax=1.0, ay=2.0, wx=1.0, wy=0.8125, center=(1.0, 0.0)),
                  kx=1.0, ky=1.0, lx=1.0, ly=1.0, noise=None, limits=limits, T=3.0, Ts=0.05)
    r, = simulate_batch([sc])
    assert r.complete
    assert np.all(np.abs(r.velocity[:, 0]) <= limits.speed_max)
    assert np.all(np.abs(r.velocity[:, 1]) <= limits.steer_max)
    assert np.any(np.abs(r.velocity[:, 1]) == limits.steer_max)  # it does reach the limit
