"""At high adaptation gains the bdsim diagram's numbers (unidyn.simulate) are within
their accuracy of a converged solution, or the run says it cannot vouch for them.

The converged reference is the batch engine at rtol 1e-12: its own equations' code
(component form) and its own error control, independent of the diagram's blocks. At
these gains it is within 7e-7 of scipy's DOP853 at rtol 1e-12 on the closed loop
(unidyn.model.closed_loop.ClosedLoop.converged, 30 s a run); tests/engine/test_accuracy.py
checks the engine against that reference at gamma 100 and 1000 on every run."""

import warnings

import numpy as np
import pytest

import unidyn
from unidyn._errors import AccuracyWarning
from unidyn.engine.batch import simulate_batch
from unidyn.model.scenario import Scenario

pytestmark = pytest.mark.slow


def _converged_theta_hat(sc):
    r, = simulate_batch([sc], rtol=1e-12, atol=1e-14)
    assert r.complete, r.message
    return r.theta_hat


def _scenario(gamma):
    # 10 s: the estimates' largest differences from the converged ones come in the
    # first seconds of adaptation (at both gains and both tolerances, the same maxima
    # as over 20 s)
    return Scenario(gamma=[gamma] * 6, adapt_from=0.0, T=10.0, noise=None)


def test_gamma_100_at_the_default_tolerances_is_within_its_accuracy_of_a_converged_solution():
    sc = _scenario(100.0)
    with warnings.catch_warnings():
        warnings.simplefilter("error", AccuracyWarning)
        r = unidyn.simulate(sc, progress=False)
    assert r.complete and r.message == ""
    err = np.max(np.abs(r.theta_hat - _converged_theta_hat(sc)))
    assert err < 1e-4, err


def test_gamma_1000_says_it_cannot_vouch_at_the_default_tolerances_and_is_converged_at_the_advised():
    sc = _scenario(1000.0)
    with pytest.warns(AccuracyWarning, match="not vouched.*rtol=1e-11"):
        loose = unidyn.simulate(sc, progress=False)
    assert loose.complete and "not vouched" in loose.message and "gamma" in loose.message
    with warnings.catch_warnings():
        warnings.simplefilter("error", AccuracyWarning)
        tight = unidyn.simulate(sc, rtol=1e-11, atol=1e-13, progress=False)
    assert tight.complete and tight.message == ""
    ref = _converged_theta_hat(sc)
    # the warning is earned: the default run is measurably off, the advised one is not
    assert np.max(np.abs(loose.theta_hat - ref)) > 1e-3
    err = np.max(np.abs(tight.theta_hat - ref))
    assert err < 5e-5, err


def test_where_the_limits_switch_within_15_ms_the_diagram_caps_its_steps():
    """At k = 30 with noise and the paper's limits the acceleration limits switch on and
    off within 15 ms; with steps of a sample interval bdsim's solver jumps such episodes
    (IAE off by 0.36 %). Capped, the diagram agrees with the converged reference (scipy's
    DOP853 at rtol 1e-11, its steps capped at 1 ms) to 1e-6."""
    from unidyn.model.closed_loop import ClosedLoop
    from unidyn.model.noise import NoiseSpec
    from unidyn.model.trajectories import Circle
    from unidyn.results.result import metrics
    sc = Scenario(case="compensated", robot="pioneer2", kx=30.0, ky=30.0, T=10.0,
                  trajectory=Circle(radius=0.5, omega=2.0), noise=NoiseSpec(seed=3))
    loop = ClosedLoop(sc)
    X = loop.converged()[0]
    t = np.arange(sc.steps + 1) * sc.Ts
    ref = np.array([np.ravel(loop.reference(tt)[:2]) for tt in t])
    truth = metrics(t, np.hypot(*(X[:, :2] - ref).T), X[:, 3:5])["iae"]
    r = unidyn.simulate(sc, progress=False)
    assert r.complete and abs(r.metrics["iae"] - truth) <= 1e-6 * truth
