"""The batch engine's kernels (unidyn.engine.kernels) against an independent implementation
of the same right-hand side: the closed loop of unidyn.engine.rhs, all runs at once as
arrays with the reference from the trajectory objects; and its RK4 against what the
classical method gives by construction."""

import numpy as np
import pytest

from unidyn.engine import kernels as _kernels
from unidyn.engine.rhs import ClosedLoop
from unidyn.model.scenario import Scenario
from unidyn.model.trajectories import Circle, Line


# the kernel's right-hand side (one run at a time, its reference evaluated from the
# parameter table) as plain Python (what runs without numba) always, and compiled where
# numba is installed
KERNEL_RHS = [pytest.param(getattr(_kernels.loop_rates, "py_func", _kernels.loop_rates),
                           id="python")] + (
    [pytest.param(_kernels.loop_rates, id="compiled")] if _kernels.AVAILABLE else [])


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
            dX = np.empty(13)
            rhs(t, X[i], (loop.P[i], (*loop.pos_noise[i, k], *loop.vel_noise[i, k])), dX)
            worst = max(worst, np.max(np.abs(dX - ref[i]) / (1.0 + np.abs(ref[i]))))
    assert worst < 1e-12


def _linear(t, x, A, out):
    """dx/dt = A x."""
    for i in range(x.size):
        out[i] = 0.0
        for j in range(x.size):
            out[i] += A[i, j] * x[j]


def _cubic(t, x, args, out):
    """dx/dt = 3 t^2 (x = t^3), for each entry."""
    for i in range(x.size):
        out[i] = 3.0 * t * t


def _py(f):
    return getattr(f, "py_func", f)


# RK4 as plain Python with Python right-hand sides; compiled with compiled ones
RK4 = [pytest.param((_py(_kernels.rk4_stages), _py(_kernels.rk4_advance),
                     _py(_kernels.rk4_dense), _linear, _cubic), id="python")]
if _kernels.AVAILABLE:
    import numba
    RK4.append(pytest.param((_kernels.rk4_stages, _kernels.rk4_advance, _kernels.rk4_dense,
                             numba.njit(_linear), numba.njit(_cubic)), id="compiled"))


@pytest.mark.parametrize("rk4", RK4)
def test_an_rk4_step_is_the_fourth_order_taylor_polynomial_of_a_linear_system(rk4):
    """For dx/dt = A x one classical RK4 step is exactly (I + hA + (hA)^2/2 + (hA)^3/6
    + (hA)^4/24) x: on seeded random A, x and h."""
    stages, advance, _, linear, _ = rk4
    rng = np.random.default_rng(3)
    for _ in range(20):
        n = int(rng.integers(1, 6))
        A, x, h = rng.normal(size=(n, n)), rng.normal(size=n), float(rng.uniform(0.01, 0.5))
        K, y = np.empty((4, n + 1)), np.empty(n)  # the stages may have rows longer than x
        stages(linear, 0.0, x, h, A, K, y)
        got = x.copy()
        advance(got, h, K)
        hA = h * A
        taylor = np.eye(n) + hA + hA @ hA / 2 + hA @ hA @ hA / 6 + hA @ hA @ hA @ hA / 24
        np.testing.assert_allclose(got, taylor @ x, rtol=1e-13, atol=1e-13)


@pytest.mark.parametrize("rk4", RK4)
def test_the_continuous_extension_is_exact_for_a_cubic_and_meets_the_step_at_its_ends(rk4):
    """RK4's continuous extension is third order: exact along x = t^3, the state at
    theta = 0 and 1 the step's start and end."""
    stages, advance, dense, _, cubic = rk4
    t0, h, x = 0.7, 0.3, np.array([0.7 ** 3, 0.7 ** 3])
    K, y, out = np.empty((4, 2)), np.empty(2), np.empty(2)
    stages(cubic, t0, x, h, 0.0, K, y)
    for theta in np.linspace(0.0, 1.0, 11):
        dense(x, h, K, theta, out)
        np.testing.assert_allclose(out, (t0 + theta * h) ** 3, rtol=1e-14)
    end = x.copy()
    advance(end, h, K)
    dense(x, h, K, 1.0, out)
    np.testing.assert_allclose(out, end, rtol=1e-15)
