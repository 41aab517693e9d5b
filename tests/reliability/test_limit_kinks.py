"""The acceleration limits make the loop's right-hand side piecewise smooth: where a
limit starts or stops clipping it has a kink, and where a speed limit is reached a
jump. RK4 across such a point is only first or second order accurate, which left the
Fig. 11 IAE 1e-4 from a converged run at the default step. The batch engine splits
a step whose stages disagree on which limit acts (on the accelerations or on the
command: equations.limit_state) where the change is (located by bisection), in both backends, with the same numbers whichever
runs share a call."""

import numpy as np
import pytest

from unidyn.engine import batch
from unidyn.model import equations
from unidyn.engine.batch import simulate_batch
from unidyn.paper import paper_fig11

pytestmark = pytest.mark.reliability


def _fig11(case, k, T, noise=False):
    sw = paper_fig11(T=T, gains=[k], **({} if noise else {"noise": None}))
    return next(p.scenario for p in sw.points() if p.params["variant"] == case)


def test_limit_state_names_the_limit_that_acts():
    a, b = 0.3, 1.7
    du = np.array([0.3, -0.3, 0.0, 0.1, 0.5])
    dw = np.array([0.2, 1.7, -1.7, 0.0, 2.0])
    # (u: at +limit, at -limit, held at a speed limit, free), w likewise, times 4
    assert equations.limit_state(du, dw, a, b).tolist() == [1.0, 3.0, -2.0, 8.0, 5.0]
    # no limits: only a velocity held at a speed limit (exactly zero) counts
    assert equations.limit_state(1e9, -1e9, np.inf, np.inf) == 0.0
    # the command beyond its speed limit (+: 1, -: 2; w times 3), times 16
    u_ref = np.array([0.8, -0.8, 0.5, 0.75, 0.0])
    w_ref = np.array([0.0, 2.0, -2.0, 1.745, -1.745])
    assert (equations.limit_state(0.1, 0.1, a, b, u_ref, w_ref, 0.75, 1.745).tolist()
            == [16.0, 16.0 * 5, 16.0 * 6, 0.0, 0.0])


def test_a_step_across_a_change_of_the_command_clipping_is_split():
    """The speed limits clip the command (Eq. 2 then sees a kink where the clipping
    starts or stops). Here the turn command stops clipping at t = 1.15 s just before
    the angular acceleration limit starts to clip: split only at the latter, the
    default step was 6.6e-6 m off a converged run (and the diagram); both are located
    now."""
    from unidyn import Scenario
    sc = Scenario(case="uncompensated", robot="pioneer2", x0=(-0.3632, -0.0811, 1.8915),
                  kx=2.2836, ky=2.2836, noise=None, T=5.0)
    ref, = simulate_batch([sc], substeps=400)  # converged (the compiled backend: fast)
    for backend in ("compiled", "plain"):
        r, = simulate_batch([sc], backend=backend)
        assert r.substeps == 10 and r.split_steps > 0
        assert np.abs(r.pose[:, :2] - ref.pose[:, :2]).max() < 5e-7  # m
    # the clipping of the command alone (no acceleration limits) is a change too
    free = sc.replace(limits={"speed_max": 0.75, "steer_max": 1.745})
    assert simulate_batch([free], backend="plain")[0].split_steps > 0


@pytest.mark.parametrize("case, k", [("a", 25.5), ("d", 35.0)])
def test_split_steps_reach_a_converged_run_where_unsplit_ones_do_not(case, k, monkeypatch):
    """Noise-free Fig. 11 points (60 s) whose IAE was furthest from a converged run:
    with the split, within 1e-6 (relative) of 200 steps per sample; without it
    (parts of a whole step), ten times further or more."""
    sc = _fig11(case, k, 60.0)
    ref, = simulate_batch([sc], substeps=200)
    r, = simulate_batch([sc])
    assert r.substeps == 10 and r.split_steps > 0
    rel = abs(r.metrics["iae"] - ref.metrics["iae"]) / ref.metrics["iae"]
    assert rel < 1e-6
    assert np.abs(r.pose[:, :2] - ref.pose[:, :2]).max() < 5e-7  # m
    monkeypatch.setattr(batch, "SPLIT_PARTS", 1)
    u, = simulate_batch([sc])
    assert u.split_steps == 0
    assert abs(u.metrics["iae"] - ref.metrics["iae"]) / ref.metrics["iae"] > 5 * rel
    assert np.abs(u.pose[:, :2] - ref.pose[:, :2]).max() > 1e-5


def test_the_split_error_shrinks_as_the_square_of_the_finest_part(monkeypatch):
    """A kink located to a part of length d costs an error of order d^2: a part
    four times shorter brings the run more than five times closer to the converged
    one (an error of order d would be four times; measured 7.5, the rest of the error
    being the step's own)."""
    sc = _fig11("a", 25.5, 60.0)
    ref, = simulate_batch([sc], substeps=200)
    err = {}
    for parts in (20, 80):
        monkeypatch.setattr(batch, "SPLIT_PARTS", parts)
        r, = simulate_batch([sc])
        err[parts] = np.abs(r.pose[:, :2] - ref.pose[:, :2]).max()
    assert err[80] < err[20] / 5


def test_both_backends_split_the_same_steps():
    """With the paper's noise the limits switch often; both backends split the same
    steps, take the same number of RK4 steps and agree to rounding."""
    scs = [_fig11(c, k, 4.0, noise=True) for c in "abcd" for k in (5.0, 35.0)]
    a = simulate_batch(scs, backend="compiled")
    b = simulate_batch(scs, backend="plain")
    assert sum(r.split_steps for r in a) > 100
    for x, y in zip(a, b):
        assert (x.split_steps, x.rk4_steps, x.substeps_max) == (y.split_steps, y.rk4_steps,
                                                                y.substeps_max)
        assert np.abs(x.pose - y.pose).max() < 1e-10


def test_runs_split_in_one_call_are_the_runs_alone_bit_for_bit():
    """Runs whose steps are split at the limits, in one call: each run's numbers are
    those of the run alone."""
    from unidyn.engine import kernels as _kernels
    if not _kernels.AVAILABLE:
        pytest.skip("numba not installed")
    scs = [_fig11(c, k, 10.0, noise=True) for c in "abd" for k in (2.0, 9.0, 20.0, 35.0)]
    together = simulate_batch(scs, backend="compiled")
    assert all(r.split_steps > 0 for r in together)
    for sc, a in zip(scs, together):
        b, = simulate_batch([sc], backend="compiled")
        for f in ("pose", "velocity", "theta_hat", "v_ref"):
            assert np.array_equal(getattr(a, f), getattr(b, f)), f
        assert (a.split_steps, a.rk4_steps) == (b.split_steps, b.rk4_steps)


def test_numpy_runs_split_together_are_the_runs_alone():
    scs = [_fig11("b", k, 3.0, noise=True) for k in (3.0, 30.0)]
    together = simulate_batch(scs, backend="plain")
    assert all(r.split_steps > 0 for r in together)
    for sc, a in zip(scs, together):
        b, = simulate_batch([sc], backend="plain")
        assert np.array_equal(a.pose, b.pose) and np.array_equal(a.velocity, b.velocity)
        assert (a.split_steps, a.rk4_steps) == (b.split_steps, b.rk4_steps)
