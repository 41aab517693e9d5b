"""At high adaptation gains the batch engine's numbers are within its accuracy of a
converged solution, or the run says it cannot vouch for them.

The converged reference is scipy's DOP853 at rtol 1e-12 on the same equations
(:class:`unidyn.engine.rhs.ClosedLoop`, noise-free), restarted at every sample as the
diagram is; an independent integrator of the loop, not the engine's RK4."""

import warnings

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from unidyn.engine.batch import AccuracyWarning, simulate_batch
from unidyn.engine.rhs import ClosedLoop
from unidyn.model.scenario import Scenario

pytestmark = pytest.mark.slow


def _converged_theta_hat(sc):
    loop = ClosedLoop(sc)
    x = loop.initial_state()[0]
    out = [x[5:11].copy()]
    for k in range(sc.steps):
        sol = solve_ivp(lambda t, y: loop.rhs(t, y[None], k)[0], (k * sc.Ts, (k + 1) * sc.Ts), x,
                        method="DOP853", rtol=1e-12, atol=1e-12)
        x = sol.y[:, -1]
        x[3:5] = np.clip(x[3:5], -loop.vmax[0], loop.vmax[0])
        out.append(x[5:11].copy())
    return np.array(out)


def test_gamma_100_is_within_its_accuracy_of_a_converged_solution():
    sc = Scenario(gamma=[100.0] * 6, adapt_from=0.0, T=20.0, noise=None)
    with warnings.catch_warnings():
        warnings.simplefilter("error", AccuracyWarning)
        r, = simulate_batch([sc], progress=False)
    assert r.complete and r.message == ""
    err = np.max(np.abs(r.theta_hat - _converged_theta_hat(sc)))
    assert err < 5e-5, err


def test_gamma_1000_says_it_cannot_vouch_for_its_accuracy():
    sc = Scenario(gamma=[1000.0] * 6, adapt_from=0.0, T=20.0, noise=None)
    with pytest.warns(AccuracyWarning, match="not vouched"):
        r, = simulate_batch([sc], progress=False)
    assert r.complete and "not vouched" in r.message and "gamma" in r.message
