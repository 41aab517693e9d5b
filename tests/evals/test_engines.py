"""The batch engine against the bdsim diagram and against converged solutions of the same
equations, and its compiled and plain kernels against each other."""

import numpy as np
import pytest

import unidyn
from unidyn.engine import kernels as _kernels
from unidyn.engine.batch import DECISIVE, simulate_batch
from unidyn.model.closed_loop import ClosedLoop
from unidyn.model.scenario import Scenario

pytestmark = pytest.mark.slow  # the whole-system tier (tests/README.md)


def _fig11_cases(k, T, noise=None):
    """The four cases of Fig. 11 at gain k (the paper's Section 5)."""
    base = dict(T=T, kx=k, ky=k, noise=noise)
    theta = unidyn.model.robots.get("p3dx_laser").theta
    return [Scenario(case="uncompensated", **base),
            Scenario(case="compensated", theta_hat0=0.9 * theta, **base),
            Scenario(case="adaptive", theta_hat0=0.9 * theta, adapt_from=0.0, **base),
            Scenario(case="compensated", **base)]


@pytest.mark.parametrize("noise", [None, unidyn.NoiseSpec(seed=3)])
def test_compiled_and_plain_kernels_agree(noise):
    if not _kernels.AVAILABLE:
        pytest.skip("numba not installed")
    # 10 s (100 samples) a run: the plain kernels are Python, a thousand times slower
    scs = [s for k in (0.5, 4.0) for s in _fig11_cases(k, T=10.0, noise=noise)]
    scs.append(Scenario.paper(1, T=10.0, noise=noise))
    # at rtol 1e-8, to compare the series (the defaults return 1e-7 runs)
    a = simulate_batch(scs, backend="plain", rtol=1e-8, atol=1e-10)
    b = simulate_batch(scs, backend="compiled", rtol=1e-8, atol=1e-10)
    # the same source, compiled or not, agrees to rounding; a rounding apart can flip
    # whether a step is kept, and the two then agree to the tolerance
    tol = 1e-6
    for x, y in zip(a, b):
        assert np.max(np.abs(x.pose - y.pose)) < tol
        assert np.max(np.abs(x.theta_hat - y.theta_hat)) < tol
        # the commands amplify the states' difference by the controllers' gains (Eqs. 10,
        # 12: up to ku = 4 and 1/a = 5 here), twice over
        assert np.max(np.abs(x.v_ref - y.v_ref)) < 100 * tol
        assert abs(x.metrics["iae"] - y.metrics["iae"]) <= tol * x.metrics["iae"]
        assert x.sensitive == y.sensitive


def _agreement_cases(k):
    """Every case of the Fig. 11 grid (and the kinematic robot) at gain k."""
    return _fig11_cases(k, T=30.0) + [Scenario(case="kinematic", T=30.0, kx=k, ky=k, noise=None)]


#: A known gap: the kinematic robot at k = 1 converges to its reference to the level of the
#: tolerances, and its ITAE (which weighs that tail by t up to 30 s) is off by 2.6e-7
#: (relative) at rtol 1e-7 and 1e-6 alike, against an estimate of 9.4e-8 from their
#: difference: far within the promise's 1e-4, but beyond twice the estimate.
ITAE_FLOOR = pytest.mark.xfail(strict=True, reason="an ITAE error at the tolerance's floor "
                                                   "that the two tolerances share")


@pytest.mark.parametrize("k", [1.0, 10.0, 35.0])
@pytest.mark.parametrize("i", range(5), ids=["uncompensated", "compensated, theta_hat 0.9 theta",
                                             "adaptive", "compensated", "kinematic"])
def test_batch_engine_agrees_with_the_bdsim_diagram_without_noise(k, i, request):
    if (k, i) == (1.0, 4):
        request.applymarker(ITAE_FLOOR)
    # every case of the Fig. 11 grid (and the kinematic robot) at a few gains, tight and
    # at the defaults; T = 30 s keeps the accurate bdsim reference affordable in CI. The
    # diagram at rtol 1e-10 is within 2e-9 (pose) and 1e-8 (IAE, relative) of itself at
    # 1e-11 (measured at k = 10 and 35), a hundredth of the differences allowed below
    sc = _agreement_cases(k)[i]
    rb, = simulate_batch([sc], rtol=1e-10, atol=1e-12)
    r, = simulate_batch([sc])
    rd = unidyn.simulate(sc, rtol=1e-10, atol=1e-12)
    assert rb.complete and rd.complete and r.complete
    assert np.max(np.abs(rb.pose[:, :2] - rd.pose[:, :2])) < 1e-6, sc.case
    assert abs(rb.metrics["iae"] - rd.metrics["iae"]) <= 1e-6 * rd.metrics["iae"], sc.case
    # at the defaults the metrics are within twice the engine's estimate of its converged
    # run (the two engines agree to 1e-6 above: the diagram is no closer a reference),
    # and the estimate within the promise (none of these runs is sensitive)
    assert not r.sensitive and max(r.numerical_error[k] for k in DECISIVE) <= 1e-4, sc.case
    for m in ("iae", "ise", "itae", "itse", "energy"):
        assert abs(r.metrics[m] - rb.metrics[m]) <= 2 * r.numerical_error[m] * rb.metrics[m], (sc.case, m)
    assert np.max(np.abs(r.pose[:, :2] - rd.pose[:, :2])) < 1e-4, sc.case


def test_same_seed_gives_the_same_noise_in_both_engines():
    sc = Scenario.paper(4, T=3.0, adapt_from=0.0)
    loop = ClosedLoop(sc)
    from unidyn.diagrams import build_fig2, new_simulator
    sim = new_simulator()
    fig = build_fig2(sim, sc)
    fig.bd.compile()
    out = sim.run(fig.bd, T=sc.T, dt=sc.Ts, watch=[fig.position_noise[0], fig.velocity_noise[0],
                                                   fig.robot[0], fig.robot[1]],
                  solver_args=dict(rtol=1e-10, atol=1e-12))
    ys = out[".ywatch"]
    t = np.asarray(out.t)
    grid = np.round(t / sc.Ts).astype(int)
    keep = np.r_[grid[1:] != grid[:-1], True]
    meas_q = np.asarray(ys[0]).reshape(len(t), -1)[keep]
    meas_v = np.asarray(ys[1]).reshape(len(t), -1)[keep]
    true_q = np.asarray(ys[2]).reshape(len(t), -1)[keep]
    true_v = np.asarray(ys[3]).reshape(len(t), -1)[keep]
    # held value j acts over [j Ts, (j+1) Ts); bdsim logs the sample at t_k just
    # before the tick, so sample k (k >= 1) shows value k-1 and sample 0 value 0
    expect_q = np.vstack([loop.pos_noise[0, :1], loop.pos_noise[0, :-1]])
    expect_v = np.vstack([loop.vel_noise[0, :1], loop.vel_noise[0, :-1]])
    np.testing.assert_allclose(meas_q[:, :2] - true_q[:, :2], expect_q, atol=1e-12)
    np.testing.assert_allclose(meas_v - true_v, expect_v, atol=1e-12)
    assert np.all(meas_q[:, 2] == true_q[:, 2])  # psi is fed back clean


@pytest.mark.parametrize("n", [2, pytest.param(3, marks=pytest.mark.slow),
                               pytest.param(4, marks=pytest.mark.slow)])
def test_noisy_runs_agree_between_engines_at_the_papers_gains(n):
    # with noise the loop is smooth inside each 0.1 s interval (the noise is
    # held), so both engines agree to the integration error
    sc = Scenario.paper(n, T=20.0, adapt_from=0.0)
    rb = simulate_batch([sc], rtol=1e-10, atol=1e-12)[0]
    rd = unidyn.simulate(sc, rtol=1e-11, atol=1e-13)
    assert np.max(np.abs(rb.pose[:, :2] - rd.pose[:, :2])) < 1e-6
    assert np.max(np.abs(rb.theta_hat - rd.theta_hat)) < 1e-6


def test_switching_adaptation_on_mid_run_is_resolved_at_the_defaults():
    # Switching the update on at t = adapt_from makes the right-hand side jump; at a
    # sample the engine restarts there, and between samples its error control shortens
    # the step that meets it
    for adapt_from in (5.0, 5.05):
        sc = Scenario.paper(4, T=10.0, adapt_from=adapt_from, noise=None)
        rd = unidyn.simulate(sc, rtol=1e-12, atol=1e-14)
        r, = simulate_batch([sc])
        assert r.complete and not r.sensitive, r.message
        assert np.max(np.abs(r.pose[:, :2] - rd.pose[:, :2])) < 1e-5
        assert np.max(np.abs(r.theta_hat - rd.theta_hat)) < 1e-5
        assert abs(r.metrics["iae"] - rd.metrics["iae"]) <= 2 * r.numerical_error["iae"] * rd.metrics["iae"]


def test_batch_rejects_sampled_control_and_bad_arguments():
    with pytest.raises(unidyn.ValidationError, match="continuous"):
        simulate_batch([Scenario(control="sampled", T=1.0)])
    with pytest.raises(unidyn.ValidationError, match="rtol"):
        simulate_batch([Scenario(T=1.0)], rtol=0.0)
    with pytest.raises(unidyn.ValidationError, match="rtol"):
        simulate_batch([Scenario(T=1.0)], rtol=1e-16)
    with pytest.raises(unidyn.ValidationError, match="backend"):
        simulate_batch([Scenario(T=1.0)], backend="gpu")
    assert simulate_batch([]) == []
