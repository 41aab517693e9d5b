"""The run's figures of merit against a case solved in closed form.

In the kinematic case (v = v_d, no limits) Eq. (10) gives the error of h the
dynamics h_tilde' = -l tanh(k h_tilde / l), componentwise. A robot started on a
straight reference line, a distance e0 behind the reference point and heading along
the line, stays on it, and its error is

    e(t) = (l/k) asinh(sinh(k e0 / l) exp(-k t)),

so IAE, ISE, ITAE and ITSE are integrals of that expression (taken here by quad).
"""

import numpy as np
import pytest
from scipy.integrate import quad

import unidyn
from unidyn.model.trajectories import Line

E0, K, L, T = 0.3, 0.8, 0.1, 12.0


def error(t):
    return (L / K) * np.arcsinh(np.sinh(K * E0 / L) * np.exp(-K * t))


@pytest.fixture(scope="module")
def run():
    sc = unidyn.Scenario.paper(1).replace(
        trajectory=Line(start=(E0, 0.0), velocity=(0.2, 0.0)), x0=(0.0, 0.0, 0.0), kx=K, ky=K,
        lx=L, ly=L, limits=unidyn.NO_LIMITS, noise=None, T=T, Ts=0.01)
    return unidyn.run(sc, engine="batch")


def test_the_error_is_the_closed_form(run):
    np.testing.assert_allclose(run.error, error(run.t), rtol=0, atol=1e-6)


@pytest.mark.parametrize("name, integrand", [
    ("iae", lambda t: error(t)), ("ise", lambda t: error(t) ** 2),
    ("itae", lambda t: t * error(t)), ("itse", lambda t: t * error(t) ** 2)])
def test_indices_are_the_integrals_of_the_closed_form(run, name, integrand):
    exact, _ = quad(integrand, 0.0, T, epsabs=1e-13, limit=200)
    # the trapezoidal rule on a 0.01 s grid: relative error about 1e-5
    assert run.metrics[name] == pytest.approx(exact, rel=1e-4)
