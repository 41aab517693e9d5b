"""The batch engine's kernels (unidyn.engine.kernels) against an independent implementation
of the same right-hand side: the closed loop of unidyn.engine.rhs, all runs at once as
arrays with the reference from the trajectory objects; and the lane tuples written out
by hand against the lengths the equations define."""

import numpy as np
import pytest

import unidyn
from unidyn.engine import kernels as _kernels
from unidyn.engine.rhs import ClosedLoop
from unidyn.model.scenario import Scenario
from unidyn.model.trajectories import Circle, Line


# the kernel's right-hand side (one run at a time, its reference evaluated from the
# parameter table) as plain Python (what runs without numba) always, and compiled where
# numba is installed
KERNEL_RHS = [pytest.param(getattr(_kernels.rhs, "py_func", _kernels.rhs), id="python")] + (
    [pytest.param(_kernels.rhs, id="compiled")] if _kernels.AVAILABLE else [])


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
            rhs(t, X[i], loop.P[i], (*loop.pos_noise[i, k], *loop.vel_noise[i, k]), dX)
            worst = max(worst, np.max(np.abs(dX - ref[i]) / (1.0 + np.abs(ref[i]))))
    assert worst < 1e-12


def test_the_written_out_lane_tuples_cover_the_state_and_the_parameter_table():
    """The compiled engine's tuples, written out by hand, against the lengths the
    equations define and the lane-minor layout (value i of lane b at i * LANES + b)."""
    L, ns, npar = _kernels.LANES, len(unidyn.model.equations.STATE), len(unidyn.model.equations.LOOP_PARAMETERS)
    rng = np.random.default_rng(1)
    A = rng.normal(size=npar * L)
    for b in range(L):
        assert _kernels._lane_state(A, b) == tuple(A[b::L][:ns])
        assert _kernels._lane_params(A, b) == tuple(A[b::L][:npar])
    X, D1, D2, D3, D4 = (tuple(rng.normal(size=ns)) for _ in range(5))
    np.testing.assert_array_equal(_kernels._axpy(X, 0.3, D1), np.add(X, 0.3 * np.array(D1)))
    np.testing.assert_allclose(
        _kernels._rk4(X, 0.3, D1, D2, D3, D4),
        np.array(X) + 0.05 * (np.array(D1) + 2 * np.array(D2) + 2 * np.array(D3) + np.array(D4)),
        rtol=1e-15, atol=1e-15)
