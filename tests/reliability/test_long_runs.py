"""Long noisy adaptive runs: sigma-modification keeps theta_hat bounded (Eq. 20);
without it the estimate drifts when the reference does not excite it."""

import numpy as np
import pytest

from unidyn.engine.batch import simulate_batch
from unidyn.model.scenario import Scenario
from unidyn.model.trajectories import Circle

# thousands of simulated seconds per run: the whole-system tier
pytestmark = [pytest.mark.reliability, pytest.mark.slow]

T = 10_000.0
# a circle: u_d and w_d are constant, so u_d' = w_d' = 0 and the theta1, theta2
# columns of G (Eq. 14) see only noise: the classic setting for parameter drift
CIRCLE = Circle(radius=1.0, omega=0.2, center=(0.0, -1.0), phase=np.pi / 2)


@pytest.fixture(scope="module")
def runs():
    scs = {(tr, lk): Scenario.paper(4, T=T, adapt_from=0.0, leakage=lk,
                                    trajectory=CIRCLE if tr == "circle" else "figure_eight")
           for tr in ("figure_eight", "circle") for lk in ("paper", "fx44850", "none")}
    res = simulate_batch(list(scs.values()))
    return dict(zip(scs, res))


def _norm_at(r, t):
    return float(np.linalg.norm(r.theta_hat[int(round(t / r.scenario.Ts))]))


def test_long_runs_complete_and_stay_finite(runs):
    for key, r in runs.items():
        assert r.complete, key
        assert np.all(np.isfinite(r.theta_hat)) and np.all(np.isfinite(r.pose)), key


@pytest.mark.parametrize("trajectory", ["figure_eight", "circle"])
@pytest.mark.parametrize("leakage", ["paper", "fx44850"])
def test_sigma_modification_keeps_theta_hat_bounded(runs, trajectory, leakage):
    r = runs[(trajectory, leakage)]
    th = np.abs(r.theta_hat)
    # ultimately bounded (Eq. 20): the size of the estimate has settled, the last
    # 2000 s reach no further than the 2000 s before them (2 % slack). Single small
    # components may still creep: with the paper's form the leakage of theta5 acts
    # at gamma5*Sigma5 = 1e-5 1/s, a time constant of 1e5 s.
    norm = np.linalg.norm(r.theta_hat, axis=1)
    late = norm[r.t >= T - 2000].max()
    before = norm[(r.t >= T - 4000) & (r.t < T - 2000)].max()
    assert late <= 1.02 * before, (late, before)
    # the bound itself (reported in the README): below 2 for every component
    assert th.max() < 2.0
    # and the tracking stays good
    assert np.mean(r.error[r.t > T - 1000]) < 0.05


def test_without_leakage_theta_hat_drifts_on_a_poorly_exciting_reference(runs):
    r = runs[("circle", "none")]
    bounded = runs[("circle", "paper")]
    th1 = np.abs(r.theta_hat[:, 0])
    true1 = r.scenario.robot.theta1
    # the estimate keeps growing: larger in each successive window ...
    windows = [th1[(r.t >= a) & (r.t < a + 2000)].max() for a in (0, 2000, 4000, 6000, 8000)]
    assert all(b > a for a, b in zip(windows, windows[1:])), windows
    # ... and ends far beyond both the true value and the sigma-modified estimate
    assert th1[-1] > 10 * true1
    assert th1[-1] > 5 * np.max(np.abs(bounded.theta_hat[:, 0]))


def test_a_persistently_exciting_reference_needs_no_leakage_over_this_horizon(runs):
    # the paper's figure eight excites every column of G: even without leakage the
    # estimate converges and stays put (reported as it is, not as the paper's warning)
    r = runs[("figure_eight", "none")]
    norms = [_norm_at(r, t) for t in (2000, 5000, 10000)]
    assert max(norms) - min(norms) < 0.05
