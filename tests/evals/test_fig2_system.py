"""Whole-system evaluations of the Fig. 2 diagram against reference solutions."""

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import unidyn
from unidyn import NO_LIMITS
from unidyn.model.closed_loop import ClosedLoop
from unidyn.model.scenario import Scenario

pytestmark = pytest.mark.slow  # the whole-system tier (tests/README.md)

TOL = dict(rtol=1e-10, atol=1e-12)


def _reference_run(sc):
    """One solve_ivp run of the closed loop, restarted at every noise interval."""
    loop = ClosedLoop(sc)
    X = loop.initial_state()[0]
    xs = [X]
    for k in range(loop.steps):
        r = solve_ivp(lambda t, y, k=k: loop.rhs(t, y[None], k)[0], (k * sc.Ts, (k + 1) * sc.Ts), X,
                      method="DOP853", **TOL)
        X = r.y[:, -1]
        xs.append(X)
    return np.array(xs)


@pytest.mark.parametrize("n", [1, 2, pytest.param(3, marks=pytest.mark.slow),
                               pytest.param(4, marks=pytest.mark.slow)])
@pytest.mark.parametrize("noisy", [False, True])
def test_diagram_agrees_with_one_solve_ivp_of_the_core(n, noisy):
    sc = Scenario.paper(n, T=15.0, adapt_from=5.0)
    if not noisy:
        sc = sc.replace(noise=None)
    res = unidyn.simulate(sc, **TOL)
    ref = _reference_run(sc)
    assert res.t.shape == (sc.steps + 1,)
    assert np.allclose(res.t, np.arange(sc.steps + 1) * sc.Ts)
    assert np.max(np.abs(res.pose - ref[:, 0:3])) < 1e-7
    if sc.case != "kinematic":
        assert np.max(np.abs(res.velocity - ref[:, 3:5])) < 1e-7
    assert np.max(np.abs(res.theta_hat - ref[:, 5:11])) < 1e-7
    if sc.case == "adaptive":
        # the update is off before adapt_from and on after
        before = res.t < 5.0 - 1e-9
        assert np.all(res.theta_hat[before] == res.theta_hat[0])
        assert np.max(np.abs(res.theta_hat[-1] - res.theta_hat[0])) > 1e-4


def test_kinematic_error_obeys_the_designed_dynamics():
    # With ideal kinematics, no limits and no noise, Eq. (10) gives
    # x~' = -l_x tanh(k_x x~ / l_x) (and the same for y), whose solution is
    # sinh(k x~(t) / l) = sinh(k x~(0) / l) exp(-k t).
    kx, ky, lx, ly = 0.8, 0.5, 0.1, 0.15
    sc = Scenario(case="kinematic", noise=None, limits=NO_LIMITS, kx=kx, ky=ky, lx=lx, ly=ly,
                  x0=(0.5, -0.3, 0.4), T=12.0)
    res = unidyn.simulate(sc, **TOL)
    e = res.reference - res.pose[:, :2]
    e0 = e[0]
    for i, (k, l) in enumerate(((kx, lx), (ky, ly))):
        analytic = l / k * np.arcsinh(np.sinh(k * e0[i] / l) * np.exp(-k * res.t))
        assert np.max(np.abs(e[:, i] - analytic)) < 1e-7


def test_exact_compensation_restores_the_kinematic_design():
    # theta_hat = theta and the exact v_d' (analytic): the velocity error obeys
    # v~' = -L tanh(K v~/L) - H^-1 (C(v) + F(v)) v~ and vanishes; from then on
    # v = v_d and the position error follows the kinematic design
    # sinh(k x~(t)/l) = sinh(k x~(t0)/l) exp(-k (t - t0)), as with an ideal robot.
    sc = Scenario(case="compensated", noise=None, limits=NO_LIMITS, kx=0.5, ky=0.5, T=30.0)
    res = unidyn.simulate(sc, **TOL)
    v_tilde = res.v_d - res.velocity
    assert np.max(np.abs(v_tilde[0])) > 0.1            # the robot starts at rest
    assert np.max(np.abs(v_tilde[res.t > 8])) < 1e-6
    t0 = 10.0
    i0 = int(round(t0 / sc.Ts))
    e = res.reference - res.pose[:, :2]
    t = res.t[i0:] - t0
    for i in range(2):
        analytic = 0.1 / 0.5 * np.arcsinh(np.sinh(0.5 * e[i0, i] / 0.1) * np.exp(-0.5 * t))
        assert np.max(np.abs(e[i0:, i] - analytic)) < 1e-6


def test_same_seed_same_numbers_and_different_seed_different_numbers():
    sc = Scenario.paper(4, T=5.0, adapt_from=1.0)
    a = unidyn.simulate(sc)
    b = unidyn.simulate(sc)
    c = unidyn.simulate(sc.replace(noise=unidyn.NoiseSpec(seed=1)))
    assert np.array_equal(a.pose, b.pose) and np.array_equal(a.theta_hat, b.theta_hat)
    assert np.max(np.abs(a.pose - c.pose)) > 1e-5
