"""The controller and source blocks, against Eqs. (10), (14), (18), (20) written out
by hand here, analytic solutions of the update law, and hand-stepped sampled updates.

The formulas below are deliberately re-typed from the paper (Eqs. 10-20), not
imported from :mod:`unidyn.model.laws`, so that a slip in the library cannot be
copied into its own reference. Continuous runs use rtol 1e-10, atol 1e-12, so the
comparison tolerances (1e-7 and tighter) measure the blocks, not the solver.

bdsim conventions used throughout: a clock with period T first ticks at t = T;
a sampled block's output is held between ticks; the sample logged exactly at a
tick is the value held *before* that tick, so the held-value checks look at the
logged samples strictly between ticks (and at the clock's own log of states).
"""

from __future__ import annotations

import importlib
import inspect
import math
import pkgutil
import re

import numpy as np
import pytest
from bdsim.block import Block

import paper_equations
import unidyn  # registers the blocks with bdsim before any BDSim is created
import unidyn.blocks
from unidyn import ValidationError
from unidyn.blocks import (
    Circle,
    DynamicCompensator,
    DynamicUnicycle,
    FigureEight,
    KinematicController,
    Line,
    MeasurementNoise,
    TrajectorySource,
)
from unidyn.blocks.controllers import SampledDynamicCompensator, SampledKinematicController
from unidyn.model import robots
from unidyn.model.trajectories import FunctionTrajectory

RTOL, ATOL = 1e-10, 1e-12
THETA = robots.get("p3dx_laser").theta  # [0.2604, 0.2509, -0.000499, 0.9965, 0.00263, 1.0768]


# ---------------------------------------------------------------------------
# the paper's equations, typed in again
# ---------------------------------------------------------------------------

def eq10(h_d, h_d_dot, q, a, k, l):
    """Eq. (10) of the pose q = (x, y, psi)."""
    return paper_equations.eq10(h_d, h_d_dot, q[:2], q[2], a, k, l)


eq14 = paper_equations.eq14


# ---------------------------------------------------------------------------
# helpers
# ---------------------------------------------------------------------------

def run(sim, bd, T, dt, watch):
    """Compile and run; return (out, list of watched signals as 2-D arrays)."""
    bd.compile()
    out = sim.run(bd, T=T, dt=dt, watch=watch, solver_args=dict(rtol=RTOL, atol=ATOL))
    ys = [np.asarray(y, dtype=float).reshape(len(out.t), -1) for y in out[".ywatch"]]
    return out, ys


def of_time(bd, f):
    """A FUNCTION block computing f(t) from a TIME block."""
    clk = bd.TIME()
    blk = bd.FUNCTION(f, nin=1, nout=1)
    bd.connect(clk, blk)
    return blk


def dense(bd):
    """A continuous state that makes bdsim log on the whole dt grid, not only at ticks."""
    integ = bd.INTEGRATOR(x0=0.0)
    bd.connect(bd.CONSTANT(1.0), integ)
    return integ


def interval_index(t, T):
    """k such that t lies strictly inside (kT, (k+1)T), or None within 1e-9 of a tick."""
    r = t / T
    k = math.floor(r)
    if min(r - k, k + 1 - r) < 1e-9:
        return None
    return k


def state_columns(out, names):
    return [list(out.xnames).index(n) for n in names]


def random_gains(rng):
    return dict(a=rng.uniform(0.05, 0.5), kx=rng.uniform(0.05, 5.0), ky=rng.uniform(0.05, 5.0),
                lx=rng.uniform(0.05, 1.0), ly=rng.uniform(0.05, 1.0))


def k_l(g):
    return (g["kx"], g["ky"]), (g["lx"], g["ly"])


# ---------------------------------------------------------------------------
# KinematicController, Eq. (10)
# ---------------------------------------------------------------------------

def test_kinematic_controller_output_is_eq10_on_random_inputs(sim):
    rng = np.random.default_rng(10)
    bd = sim.blockdiagram()
    for _ in range(100):
        g = random_gains(rng)
        K = KinematicController(**g, bd=bd)
        h_d = rng.uniform(-2, 2, 2)
        h_d_dot = rng.uniform(-1, 1, 2)
        q = np.r_[h_d + rng.normal(0, 1.0, 2), rng.uniform(-math.pi, math.pi)]
        (v_d,) = K.output(0.0, [h_d, h_d_dot, q], None)
        np.testing.assert_allclose(v_d, eq10(h_d, h_d_dot, q, g["a"], *k_l(g)),
                                   rtol=1e-13, atol=1e-14)


def test_kinematic_controller_saturates_at_l(sim):
    # a huge position error: the correction term tends to l, so u_d -> cos psi (x_d' + lx) ...
    bd = sim.blockdiagram()
    K = KinematicController(a=0.3, kx=2.0, ky=3.0, lx=0.15, ly=0.25, bd=bd)
    q = np.array([0.0, 0.0, 0.4])
    (v_d,) = K.output(0.0, [np.array([1e6, -1e6]), np.array([0.1, 0.2]), q], None)
    nu = np.array([0.1 + 0.15, 0.2 - 0.25])
    c, s = math.cos(0.4), math.sin(0.4)
    np.testing.assert_allclose(v_d, [c * nu[0] + s * nu[1], (-s * nu[0] + c * nu[1]) / 0.3],
                               rtol=1e-14)


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_kinematic_controller_in_a_running_diagram_is_eq10(sim, seed):
    rng = np.random.default_rng(seed)
    g = random_gains(rng)
    h_d, h_d_dot = rng.uniform(-2, 2, 2), rng.uniform(-1, 1, 2)
    q = np.r_[rng.uniform(-2, 2, 2), rng.uniform(-math.pi, math.pi)]
    bd = sim.blockdiagram()
    K = bd.KINEMATICCONTROLLER(**g)
    bd.connect(bd.CONSTANT(h_d), K[0])
    bd.connect(bd.CONSTANT(h_d_dot), K[1])
    bd.connect(bd.CONSTANT(q), K[2])
    dense(bd)
    out, (v_d,) = run(sim, bd, 1.0, 0.1, [K[0]])
    assert len(out.t) == 11
    expected = eq10(h_d, h_d_dot, q, g["a"], *k_l(g))
    np.testing.assert_allclose(v_d, np.tile(expected, (11, 1)), rtol=1e-13, atol=1e-14)


def test_kinematic_controller_tracks_time_varying_inputs_in_a_loop(sim):
    """K closing the loop around the dynamic robot: v_d(t) = Eq. (10)(h_d(t), q(t)) at every logged t."""
    g = dict(a=0.2, kx=0.8, ky=0.6, lx=0.3, ly=0.2)
    bd = sim.blockdiagram()
    src = bd.FIGUREEIGHT()
    K = KinematicController(**g, bd=bd)
    R = DynamicUnicycle("p3dx_laser", velocity_output=True, a=0.2, x0=(0.2, 0.0, 0.0), bd=bd)
    dm = bd.DEMUX(2)
    bd.connect(src[0], K[0])
    bd.connect(src[1], K[1])
    bd.connect(R[0], K[2])
    bd.connect(K[0], dm)
    bd.connect(dm[0], R[0])
    bd.connect(dm[1], R[1])
    out, (v_d, q, h_d, h_d_dot) = run(sim, bd, 3.0, 0.05, [K[0], R[0], src[0], src[1]])
    expected = np.array([eq10(h_d[i], h_d_dot[i], q[i], g["a"], *k_l(g)) for i in range(len(out.t))])
    np.testing.assert_allclose(v_d, expected, rtol=1e-12, atol=1e-13)
    assert np.ptp(q[:, 2]) > 0.3  # the robot actually turned


def test_kinematic_controller_rate_output_is_the_derivative_of_v_d(sim):
    """rate=True: output 1 equals a central difference of output 0 along a simulated motion."""
    g = dict(a=0.2, kx=1.0, ky=1.5, lx=0.3, ly=0.4)
    bd = sim.blockdiagram()
    src = bd.FIGUREEIGHT()
    K = KinematicController(**g, rate=True, bd=bd)
    R = DynamicUnicycle("p3dx", velocity_output=True, a=0.2, x0=(0.2, -0.1, 0.3), bd=bd)
    dm = bd.DEMUX(2)
    bd.connect(src[0], K[0])
    bd.connect(src[1], K[1])
    bd.connect(R[0], K[2])
    bd.connect(src[2], K[3])
    bd.connect(R[1], K[4])
    bd.connect(K[0], dm)
    bd.connect(dm[0], R[0])
    bd.connect(dm[1], R[1])
    h = 0.001
    out, (v_d, v_d_dot) = run(sim, bd, 3.0, h, [K[0], K[1]])
    t = out.t
    assert np.allclose(np.diff(t), h, atol=1e-12)  # a uniform grid, no duplicated samples
    central = (v_d[2:] - v_d[:-2]) / (2 * h)
    scale = np.abs(v_d_dot).max(axis=0)
    assert np.all(scale > 0.1)  # both derivatives are far from zero
    err = np.abs(central - v_d_dot[1:-1]).max(axis=0)
    # central difference error ~ h^2/6 |v_d'''| <= 5e-6 here; leaving out a term of the
    # derivative (the dA^-1/dt part, or h_d'') makes it 0.05 to 1.4
    assert np.all(err < 2e-5), err


def test_kinematic_controller_rate_adds_ports(sim):
    bd = sim.blockdiagram()
    K0 = KinematicController(bd=bd)
    K1 = KinematicController(rate=True, bd=bd)
    assert (K0.nin, K0.nout) == (3, 1)
    assert (K1.nin, K1.nout) == (5, 2)


# ---------------------------------------------------------------------------
# DynamicCompensator, Eqs. (12), (14), (18), (20)
# ---------------------------------------------------------------------------

def comp_gains(rng):
    return dict(ku=rng.uniform(0.5, 6.0), kw=rng.uniform(0.5, 6.0),
                lu=rng.uniform(0.2, 2.0), lw=rng.uniform(0.2, 2.0))


def test_compensator_output_is_G_theta_hat_on_random_inputs(sim):
    rng = np.random.default_rng(14)
    bd = sim.blockdiagram()
    for _ in range(100):
        g = comp_gains(rng)
        k, l = (g["ku"], g["kw"]), (g["lu"], g["lw"])
        theta_hat = THETA * rng.uniform(0.5, 1.5, 6)
        v_d, v, v_d_dot = rng.uniform(-1, 1, 2), rng.uniform(-1, 1, 2), rng.uniform(-2, 2, 2)
        # vd_dot="input": v_d' is input 2
        D = DynamicCompensator(theta_hat0=theta_hat, vd_dot="input", **g, bd=bd)
        v_r, th_out = D.output(0.0, [v_d, v, v_d_dot], theta_hat)
        np.testing.assert_allclose(v_r, eq14(v_d, v_d_dot, v, k, l) @ theta_hat,
                                   rtol=1e-13, atol=1e-14)
        np.testing.assert_array_equal(th_out, theta_hat)
        # vd_dot="filter": v_d' = (v_d - z) / tau from the filter state z
        tau = rng.uniform(0.01, 0.5)
        Df = DynamicCompensator(theta_hat0=theta_hat, vd_dot="filter", tau=tau, **g, bd=bd)
        z = rng.uniform(-1, 1, 2)
        v_r, _ = Df.output(0.0, [v_d, v], np.r_[theta_hat, z])
        np.testing.assert_allclose(v_r, eq14(v_d, (v_d - z) / tau, v, k, l) @ theta_hat,
                                   rtol=1e-12, atol=1e-13)


def test_compensator_in_a_running_diagram_uses_input_2(sim):
    rng = np.random.default_rng(5)
    g = comp_gains(rng)
    k, l = (g["ku"], g["kw"]), (g["lu"], g["lw"])
    theta_hat = THETA * 1.2
    bd = sim.blockdiagram()
    D = bd.DYNAMICCOMPENSATOR(theta_hat0=theta_hat, vd_dot="input", **g)
    assert D.nin == 3
    v_d = np.array([0.3, -0.2])
    v = np.array([0.1, 0.25])
    v_d_dot = lambda t: np.array([0.5 * math.sin(t), -0.3 + 0.2 * t])  # noqa: E731
    bd.connect(bd.CONSTANT(v_d), D[0])
    bd.connect(bd.CONSTANT(v), D[1])
    bd.connect(of_time(bd, v_d_dot), D[2])
    out, (v_r, th) = run(sim, bd, 2.0, 0.1, [D[0], D[1]])
    expected = np.array([eq14(v_d, v_d_dot(t), v, k, l) @ theta_hat for t in out.t])
    np.testing.assert_allclose(v_r, expected, rtol=1e-13, atol=1e-14)
    assert np.ptp(v_r[:, 1]) > 0.1  # input 2 really changed the command
    # adaptive=False (default): the estimate never moves, even with a velocity error
    np.testing.assert_array_equal(th, np.tile(theta_hat, (len(out.t), 1)))
    assert out.x.shape[1] == 6  # no filter states with vd_dot="input"


def test_non_adaptive_estimate_stays_exactly_constant_with_errors(sim):
    theta_hat = THETA / 1.5
    bd = sim.blockdiagram()
    D = DynamicCompensator(theta_hat0=theta_hat, adaptive=False, leakage="paper",
                           sigma=(0.5,) * 6, bd=bd)
    bd.connect(of_time(bd, lambda t: np.array([0.3 * math.sin(t), 0.5 * math.cos(2 * t)])), D[0])
    bd.connect(of_time(bd, lambda t: np.array([0.1 * t, -0.2])), D[1])
    out, (v_r, th) = run(sim, bd, 2.0, 0.05, [D[0], D[1]])
    cols = state_columns(out, [f"theta_hat{i}" for i in range(1, 7)])
    np.testing.assert_array_equal(out.x[:, cols], np.tile(theta_hat, (len(out.t), 1)))
    np.testing.assert_array_equal(th, np.tile(theta_hat, (len(out.t), 1)))
    assert np.ptp(v_r[:, 0]) > 0.1


def test_adaptive_without_leakage_and_zero_error_keeps_estimate(sim):
    """leakage="none", v_d == v: theta_hat' = gamma G^T 0 = 0."""
    theta_hat = THETA / 1.5
    bd = sim.blockdiagram()
    D = DynamicCompensator(theta_hat0=theta_hat, adaptive=True, leakage="none",
                           gamma=(5.0,) * 6, vd_dot="input", bd=bd)
    same = bd.CONSTANT(np.array([0.4, -0.3]))
    bd.connect(same, D[0])
    bd.connect(same, D[1])
    bd.connect(bd.CONSTANT(np.array([0.7, 0.2])), D[2])  # G is far from zero
    out, (v_r, th) = run(sim, bd, 3.0, 0.1, [D[0], D[1]])
    np.testing.assert_array_equal(th, np.tile(theta_hat, (len(out.t), 1)))
    # and the command is G theta_hat with the tanh term zero
    G = eq14([0.4, -0.3], [0.7, 0.2], [0.4, -0.3], (4.0, 4.0), (1.0, 1.0))
    np.testing.assert_allclose(v_r[-1], G @ theta_hat, rtol=1e-13)


LEAK_GAMMA = np.array([1.7, 1.1, 0.5, 0.3, 2.0, 0.8])
LEAK_SIGMA = np.array([0.05, 0.1, 0.02, 0.2, 0.08, 0.3])


@pytest.mark.parametrize("leakage, rate", [
    ("paper", LEAK_GAMMA * LEAK_SIGMA),   # Eq. (20): - gamma Sigma theta_hat
    ("fx44850", LEAK_SIGMA),              # FX44850: - Sigma theta_hat
])
def test_leakage_with_zero_error_decays_exponentially(sim, leakage, rate):
    theta0 = THETA
    bd = sim.blockdiagram()
    D = DynamicCompensator(theta_hat0=theta0, adaptive=True, gamma=LEAK_GAMMA, sigma=LEAK_SIGMA,
                           leakage=leakage, vd_dot="input", bd=bd)
    same = bd.CONSTANT(np.array([0.4, 0.3]))
    bd.connect(same, D[0])
    bd.connect(same, D[1])
    bd.connect(bd.CONSTANT(np.array([0.1, -0.1])), D[2])
    T = 5.0
    out, (th,) = run(sim, bd, T, 0.1, [D[1]])
    expected = theta0 * np.exp(-rate * T)
    np.testing.assert_allclose(th[-1], expected, rtol=1e-8, atol=0)
    np.testing.assert_allclose(th, theta0 * np.exp(-np.outer(out.t, rate)), rtol=1e-8, atol=0)
    # the two forms really differ here (gamma != 1), so this is not a vacuous check
    other = LEAK_SIGMA if leakage == "paper" else LEAK_GAMMA * LEAK_SIGMA
    assert np.abs(theta0 * np.exp(-other * T) - expected).max() > 1e-2


@pytest.mark.parametrize("leakage", ["none", "paper"])
def test_adapt_from_switches_the_update_on(sim, leakage):
    """Constant inputs make G constant, so theta_hat' = gamma g - c theta_hat is linear:
    theta_hat = theta0 before adapt_from, then the analytic solution of that ODE."""
    gamma = np.array([1.7, 1.1, 0.5, 0.3, 0.01, 0.5])
    sigma = np.array([0.05, 0.1, 0.02, 0.2, 0.08, 0.3])
    v_d, v, v_d_dot = np.array([0.4, 0.3]), np.array([0.2, 0.5]), np.array([0.1, -0.2])
    t_a, T = 0.75, 2.0
    theta0 = THETA / 1.5
    bd = sim.blockdiagram()
    D = DynamicCompensator(theta_hat0=theta0, adaptive=True, gamma=gamma, sigma=sigma,
                           leakage=leakage, adapt_from=t_a, vd_dot="input", bd=bd)
    bd.connect(bd.CONSTANT(v_d), D[0])
    bd.connect(bd.CONSTANT(v), D[1])
    bd.connect(bd.CONSTANT(v_d_dot), D[2])
    out, (th,) = run(sim, bd, T, 0.05, [D[1]])
    t = out.t
    grad = gamma * (eq14(v_d, v_d_dot, v, (4.0, 4.0), (1.0, 1.0)).T @ (v_d - v))
    s = np.clip(t - t_a, 0.0, None)[:, None]
    if leakage == "none":
        expected = theta0 + grad * s
    else:
        c = gamma * sigma
        expected = grad / c + (theta0 - grad / c) * np.exp(-c * s)
    # exactly constant before the switch (the sample at t_a itself is interpolated by the
    # solver across the switch, so it is only checked to the tolerance below)
    before = t < t_a - 1e-9
    assert before.sum() == 15
    np.testing.assert_array_equal(th[before], np.tile(theta0, (before.sum(), 1)))
    np.testing.assert_allclose(th, expected, rtol=0, atol=1e-8)
    assert np.all(np.abs(th[-1] - theta0) > 1e-4)  # every component moved after t_a


def test_derivative_filter_state_is_first_order_lag(sim):
    """vd_dot="filter": z' = (v_d - z)/tau, z(0) = 0, so z = v_d (1 - exp(-t/tau)) for constant v_d,
    and the command uses v_d' = (v_d - z)/tau = v_d exp(-t/tau)/tau."""
    tau = 0.2
    v_d, v = np.array([0.5, -0.4]), np.array([0.1, 0.2])
    theta_hat = THETA
    bd = sim.blockdiagram()
    D = DynamicCompensator(theta_hat0=theta_hat, vd_dot="filter", tau=tau, bd=bd)
    assert D.nin == 2
    bd.connect(bd.CONSTANT(v_d), D[0])
    bd.connect(bd.CONSTANT(v), D[1])
    out, (v_r,) = run(sim, bd, 1.0, 0.02, [D[0]])
    t = out.t
    z = out.x[:, state_columns(out, ["z_u", "z_w"])]
    decay = np.exp(-t / tau)[:, None]
    np.testing.assert_allclose(z, v_d * (1 - decay), rtol=0, atol=1e-9)
    expected = np.array([eq14(v_d, v_d * e / tau, v, (4.0, 4.0), (1.0, 1.0)) @ theta_hat
                         for e in decay[:, 0]])
    np.testing.assert_allclose(v_r, expected, rtol=0, atol=1e-8)


# ---------------------------------------------------------------------------
# sampled controllers on a named clock
# ---------------------------------------------------------------------------

def q_of_t(t):
    return np.array([0.2 + 0.1 * t, -0.05 * t, 0.3 * math.sin(t)])


def test_sampled_kinematic_controller_holds_eq10_of_the_last_tick(sim):
    g = dict(a=0.25, kx=0.7, ky=1.3, lx=0.2, ly=0.3)
    v_d0 = (0.05, -0.02)
    Tc = 0.1
    bd = sim.blockdiagram()
    clk = bd.clock(Tc, name="ctrl")
    K = SampledKinematicController(clk, **g, v_d0=v_d0, bd=bd)
    src = FigureEight(bd=bd)
    bd.connect(src[0], K[0])
    bd.connect(src[1], K[1])
    bd.connect(of_time(bd, q_of_t), K[2])
    dense(bd)
    out, (v_d,) = run(sim, bd, 1.0, 0.025, [K[0]])
    tr = src.trajectory

    def expected_at_tick(k):
        tk = clk.time(k)
        return eq10(tr.position(tk), tr.velocity(tk), q_of_t(tk), g["a"], *k_l(g))

    checked = set()
    for t, y in zip(out.t, v_d):
        k = interval_index(t, Tc)
        if k is None:
            continue
        checked.add(k)
        if k == 0:  # before the first tick at t = T
            np.testing.assert_array_equal(y, v_d0)
        else:
            np.testing.assert_allclose(y, expected_at_tick(k), rtol=1e-13, atol=1e-14)
    assert checked == set(range(10))
    # the clock's own log: the state after tick k is Eq. (10) at t_k
    log = out["ctrl"]
    np.testing.assert_allclose(log.t, [clk.time(k) for k in range(1, len(log.t) + 1)])
    assert len(log.t) >= 9
    for k, row in enumerate(log.X, start=1):
        np.testing.assert_allclose(row, expected_at_tick(k), rtol=1e-13, atol=1e-14)
    # and the held output really changes from tick to tick
    assert len({tuple(np.round(r, 12)) for r in log.X}) == len(log.X)


def test_sampled_kinematic_controller_default_v_d0_is_rest(sim):
    bd = sim.blockdiagram()
    clk = bd.clock(0.2, name="ctrl")
    K = bd.SAMPLEDKINEMATICCONTROLLER(clk)
    bd.connect(bd.CONSTANT(np.array([1.0, 1.0])), K[0])
    bd.connect(bd.CONSTANT(np.array([0.3, 0.0])), K[1])
    bd.connect(bd.CONSTANT(np.array([0.0, 0.0, 0.0])), K[2])
    dense(bd)
    out, (v_d,) = run(sim, bd, 0.5, 0.05, [K[0]])
    early = out.t < 0.2 - 1e-9
    np.testing.assert_array_equal(v_d[early], 0.0)
    late = out.t > 0.2 + 1e-9
    np.testing.assert_allclose(v_d[late], np.tile(eq10([1, 1], [0.3, 0], [0, 0, 0], 0.2,
                                                       (0.1, 0.1), (0.1, 0.1)), (late.sum(), 1)),
                               rtol=1e-14)


def test_sampled_compensator_backward_difference_of_a_ramp_is_its_slope(sim):
    """With v = v_d (no tanh term) and theta3 = theta5 = 0, v_r = [th1 u_d' + th4 u_d, th2 w_d' + th6 w_d],
    so the v_d' the block used can be read back from its command."""
    th = np.array([0.3, 0.2, 0.0, 0.9, 0.0, 1.1])
    c0, slope = np.array([0.2, -0.1]), np.array([0.37, -0.81])
    ramp = lambda t: c0 + slope * t  # noqa: E731
    Tc = 0.1
    bd = sim.blockdiagram()
    clk = bd.clock(Tc, name="ctrl")
    D = SampledDynamicCompensator(clk, theta_hat0=th, vd_dot="difference", bd=bd)
    r = of_time(bd, ramp)
    bd.connect(r, D[0])
    bd.connect(r, D[1])
    out, _ = run(sim, bd, 1.0, Tc, [D[0]])
    log = out["ctrl"]
    assert len(log.t) >= 9
    v_r, v_d_logged = log.X[:, 6:8], log.X[:, 8:10]
    ticks = np.array([clk.time(k) for k in range(1, len(log.t) + 1)])
    np.testing.assert_allclose(v_d_logged, c0 + np.outer(ticks, slope), rtol=0, atol=1e-15)
    used = np.column_stack([(v_r[:, 0] - th[3] * v_d_logged[:, 0]) / th[0],
                            (v_r[:, 1] - th[5] * v_d_logged[:, 1]) / th[1]])
    np.testing.assert_allclose(used[0], 0.0, atol=1e-13)  # first tick: no previous sample
    np.testing.assert_allclose(used[1:], np.tile(slope, (len(used) - 1, 1)), rtol=0, atol=1e-12)
    # the estimate is fixed (adaptive=False)
    np.testing.assert_array_equal(log.X[:, :6], np.tile(th, (len(log.t), 1)))


def test_sampled_compensator_euler_update_matches_hand_computation(sim):
    gamma = np.array([1.7, 1.1, 0.5, 0.3, 0.01, 0.5])
    sigma = np.array([0.05, 0.1, 0.02, 0.2, 0.08, 0.3])
    k, l = (3.0, 5.0), (0.8, 1.5)
    Tc, t_a = 0.1, 0.25
    v_d_of = lambda t: np.array([0.3 + 0.2 * t, 0.5 * math.sin(2 * t)])  # noqa: E731
    v_of = lambda t: np.array([0.1 * math.cos(t), -0.2 + 0.3 * t])  # noqa: E731
    theta0 = THETA / 1.5
    bd = sim.blockdiagram()
    clk = bd.clock(Tc, name="ctrl")
    D = SampledDynamicCompensator(clk, theta_hat0=theta0, ku=k[0], kw=k[1], lu=l[0], lw=l[1],
                                  adaptive=True, gamma=gamma, sigma=sigma, adapt_from=t_a,
                                  leakage="paper", bd=bd)
    bd.connect(of_time(bd, v_d_of), D[0])
    bd.connect(of_time(bd, v_of), D[1])
    dense(bd)
    out, (v_r_out, th_out) = run(sim, bd, 0.8, 0.025, [D[0], D[1]])

    # hand-stepped: v_r_k = G_k theta_k, theta_{k+1} = theta_k + T theta_hat'_k
    theta, prev, rows = theta0.copy(), None, []
    for kk in range(1, 9):
        tk = kk * Tc
        vd, v = v_d_of(tk), v_of(tk)
        vd_dot = np.zeros(2) if prev is None else (vd - prev) / Tc
        G = eq14(vd, vd_dot, v, k, l)
        v_r = G @ theta
        rate = np.zeros(6) if tk < t_a else gamma * (G.T @ (vd - v)) - gamma * sigma * theta
        theta = theta + Tc * rate
        rows.append(np.r_[theta, v_r, vd])
        prev = vd
    rows = np.array(rows)
    log = out["ctrl"]
    n = min(len(log.t), len(rows))
    assert n >= 7
    np.testing.assert_allclose(log.X[:n], rows[:n], rtol=1e-12, atol=1e-14)
    # ticks at 0.1 and 0.2 are before adapt_from: no change; from 0.3 on it moves
    np.testing.assert_array_equal(rows[1, :6], theta0)
    assert np.all(rows[2, :6] != theta0)
    # the outputs hold the tick's values between ticks
    for t, vr, th in zip(out.t, v_r_out, th_out):
        kk = interval_index(t, Tc)
        if kk is None or kk > n:
            continue
        if kk == 0:
            np.testing.assert_array_equal(vr, 0.0)
            np.testing.assert_array_equal(th, theta0)
        else:
            np.testing.assert_allclose(vr, rows[kk - 1, 6:8], rtol=1e-12, atol=1e-14)
            np.testing.assert_allclose(th, rows[kk - 1, :6], rtol=1e-12, atol=1e-14)


def test_sampled_compensator_vd_dot_input(sim):
    Tc = 0.1
    bd = sim.blockdiagram()
    clk = bd.clock(Tc, name="ctrl")
    D = bd.SAMPLEDDYNAMICCOMPENSATOR(clk, theta_hat0="p3dx_laser", vd_dot="input")
    assert D.nin == 3
    vdd = lambda t: np.array([math.sin(3 * t), t])  # noqa: E731
    bd.connect(bd.CONSTANT(np.array([0.3, 0.1])), D[0])
    bd.connect(bd.CONSTANT(np.array([0.2, 0.2])), D[1])
    bd.connect(of_time(bd, vdd), D[2])
    out, _ = run(sim, bd, 0.5, Tc, [D[0]])
    log = out["ctrl"]
    for kk, row in enumerate(log.X, start=1):
        G = eq14([0.3, 0.1], vdd(kk * Tc), [0.2, 0.2], (4.0, 4.0), (1.0, 1.0))
        np.testing.assert_allclose(row[6:8], G @ THETA, rtol=1e-13, atol=1e-15)


# ---------------------------------------------------------------------------
# sources
# ---------------------------------------------------------------------------

def source_outputs(sim, make, T=12.0, dt=0.1):
    bd = sim.blockdiagram()
    src = make(bd)
    dense(bd)
    out, ys = run(sim, bd, T, dt, [src[0], src[1], src[2]])
    assert len(out.t) == round(T / dt) + 1
    return out.t, ys


@pytest.mark.parametrize("kw", [{}, dict(ax=1.5, ay=0.7, wx=0.4, wy=0.3, center=(0.2, -0.1))])
def test_figure_eight_is_analytic(sim, kw):
    p = dict(dict(ax=1.0, ay=1.0, wx=0.5, wy=0.25, center=(0.0, 0.0)), **kw)
    t, (h, hd, hdd) = source_outputs(sim, lambda bd: bd.FIGUREEIGHT(**kw))
    ax, ay, wx, wy, (cx, cy) = p["ax"], p["ay"], p["wx"], p["wy"], p["center"]
    np.testing.assert_allclose(h, np.c_[cx + ax * np.sin(wx * t), cy + ay * (np.cos(wy * t) - 1)],
                               atol=1e-14)
    np.testing.assert_allclose(hd, np.c_[ax * wx * np.cos(wx * t), -ay * wy * np.sin(wy * t)],
                               atol=1e-14)
    np.testing.assert_allclose(hdd, np.c_[-ax * wx**2 * np.sin(wx * t),
                                          -ay * wy**2 * np.cos(wy * t)], atol=1e-14)
    if not kw:  # the paper's: starts at the origin, x_d = sin(0.5 t), y_d = cos(0.25 t) - 1
        np.testing.assert_allclose(h[0], [0.0, 0.0], atol=0)


@pytest.mark.parametrize("kw", [{}, dict(radius=0.8, omega=-0.7, center=(1.0, -2.0), phase=0.4)])
def test_circle_is_analytic(sim, kw):
    p = dict(dict(radius=1.0, omega=0.2, center=(0.0, 0.0), phase=0.0), **kw)
    t, (h, hd, hdd) = source_outputs(sim, lambda bd: bd.CIRCLE(**kw))
    R, om, (cx, cy), ph = p["radius"], p["omega"], p["center"], p["phase"]
    arg = om * t + ph
    np.testing.assert_allclose(h, np.c_[cx + R * np.cos(arg), cy + R * np.sin(arg)], atol=1e-14)
    np.testing.assert_allclose(hd, np.c_[-R * om * np.sin(arg), R * om * np.cos(arg)], atol=1e-14)
    np.testing.assert_allclose(hdd, np.c_[-R * om**2 * np.cos(arg), -R * om**2 * np.sin(arg)],
                               atol=1e-14)
    np.testing.assert_allclose(np.hypot(h[:, 0] - cx, h[:, 1] - cy), R, rtol=1e-14)


@pytest.mark.parametrize("kw", [{}, dict(start=(1.0, -0.5), velocity=(-0.3, 0.15))])
def test_line_is_analytic(sim, kw):
    p = dict(dict(start=(0.0, 0.0), velocity=(0.2, 0.0)), **kw)
    t, (h, hd, hdd) = source_outputs(sim, lambda bd: bd.LINE(**kw))
    p0, v = np.array(p["start"]), np.array(p["velocity"])
    np.testing.assert_allclose(h, p0 + np.outer(t, v), atol=1e-14)
    np.testing.assert_array_equal(hd, np.tile(v, (len(t), 1)))
    np.testing.assert_array_equal(hdd, 0.0)


def test_trajectory_source_from_spec_and_object(sim):
    spec = {"type": "circle", "radius": 0.5, "omega": 0.3, "center": [0.1, 0.2], "phase": 1.0}
    t, (h, hd, hdd) = source_outputs(sim, lambda bd: bd.TRAJECTORYSOURCE(spec), T=5.0)
    arg = 0.3 * t + 1.0
    np.testing.assert_allclose(h, np.c_[0.1 + 0.5 * np.cos(arg), 0.2 + 0.5 * np.sin(arg)], atol=1e-14)
    np.testing.assert_allclose(hdd, -0.09 * 0.5 * np.c_[np.cos(arg), np.sin(arg)], atol=1e-14)
    t2, (h2, _, _) = source_outputs(
        sim, lambda bd: TrajectorySource(unidyn.model.trajectories.Circle(0.5, 0.3, (0.1, 0.2), 1.0), bd=bd),
        T=5.0)
    np.testing.assert_array_equal(h2, h)


def spiral(t):
    r = 1.0 + 0.1 * t
    return (np.array([r * math.cos(t), r * math.sin(t)]),
            np.array([0.1 * math.cos(t) - r * math.sin(t), 0.1 * math.sin(t) + r * math.cos(t)]))


def spiral_acc(t):
    r = 1.0 + 0.1 * t
    return np.array([-0.2 * math.sin(t) - r * math.cos(t), 0.2 * math.cos(t) - r * math.sin(t)])


@pytest.mark.parametrize("with_acc", [True, False])
def test_trajectory_source_with_a_user_callable(sim, with_acc):
    acc = spiral_acc if with_acc else None
    t, (h, hd, hdd) = source_outputs(
        sim, lambda bd: bd.TRAJECTORYSOURCE(spiral, acceleration=acc), T=4.0)
    np.testing.assert_array_equal(h, np.array([spiral(ti)[0] for ti in t]))
    np.testing.assert_array_equal(hd, np.array([spiral(ti)[1] for ti in t]))
    exact = np.array([spiral_acc(ti) for ti in t])
    if with_acc:
        np.testing.assert_array_equal(hdd, exact)
    else:  # central difference with step 1e-4: error ~ h^2 |h_d''''| / 6 plus rounding
        np.testing.assert_allclose(hdd, exact, rtol=0, atol=1e-7)


# ---------------------------------------------------------------------------
# MeasurementNoise
# ---------------------------------------------------------------------------

def signal(t):
    return np.array([math.sin(t), math.cos(t), 0.5 * t])


def noise_diagram(sim, seed, std=0.3, indices=(0, 2), Tc=0.1):
    bd = sim.blockdiagram()
    clk = bd.clock(Tc, name="sensor")
    n = MeasurementNoise(clk, std=std, seed=seed, indices=indices, bd=bd)
    s = of_time(bd, signal)
    bd.connect(s, n)
    dense(bd)
    return bd, n, s


def run_noise(sim, bd, n, s, T=1.0, dt=0.025):
    out, (meas, true) = run(sim, bd, T, dt, [n[0], s[0]])
    return out, meas, true


def test_noise_values_are_the_seeded_draws_in_sequence(sim):
    std, seed, idx, Tc = 0.3, 7, (0, 2), 0.1
    bd, n, s = noise_diagram(sim, seed, std, idx, Tc)
    out, meas, true = run_noise(sim, bd, n, s)
    rng = np.random.default_rng(seed)
    draws = np.array([std * rng.standard_normal(len(idx)) for _ in range(12)])
    checked = set()
    for t, m, x in zip(out.t, meas, true):
        k = interval_index(t, Tc)
        if k is None:
            continue
        checked.add(k)
        # draw 0 over [0, T); draw k from tick k on
        np.testing.assert_allclose(m[list(idx)] - x[list(idx)], draws[k], rtol=0, atol=1e-15)
        assert m[1] == x[1]  # the clean component passes unchanged (and is not held)
    assert checked == set(range(10))
    log = out["sensor"]
    np.testing.assert_array_equal(log.X, draws[1:len(log.t) + 1])
    # the clean component follows the signal between ticks
    np.testing.assert_array_equal(meas[:, 1], np.cos(out.t))


def test_noise_same_seed_same_sequence_across_runs_and_diagrams(sim):
    bd, n, s = noise_diagram(sim, seed=11)
    _, m1, _ = run_noise(sim, bd, n, s)
    _, m2, _ = run_noise(sim, bd, n, s)          # the same diagram again
    bd3, n3, s3 = noise_diagram(sim, seed=11)    # a second diagram
    _, m3, _ = run_noise(sim, bd3, n3, s3)
    np.testing.assert_array_equal(m1, m2)
    np.testing.assert_array_equal(m1, m3)
    bd4, n4, s4 = noise_diagram(sim, seed=12)
    _, m4, _ = run_noise(sim, bd4, n4, s4)
    assert np.all(m4[:, [0, 2]] != m1[:, [0, 2]])
    np.testing.assert_array_equal(m4[:, 1], m1[:, 1])


def test_noise_seed_sequence_is_accepted_and_reproducible(sim):
    ss = np.random.SeedSequence(2017)
    bd, n, s = noise_diagram(sim, seed=ss, std=0.05, indices=(1,))
    out, meas, true = run_noise(sim, bd, n, s)
    rng = np.random.default_rng(np.random.SeedSequence(2017))
    draws = np.array([0.05 * rng.standard_normal(1) for _ in range(12)])
    np.testing.assert_array_equal(out["sensor"].X, draws[1:len(out["sensor"].t) + 1])
    np.testing.assert_array_equal(meas[:, [0, 2]], true[:, [0, 2]])


def test_noise_zero_std_is_transparent(sim):
    bd, n, s = noise_diagram(sim, seed=1, std=0.0)
    _, meas, true = run_noise(sim, bd, n, s)
    np.testing.assert_array_equal(meas, true)


def test_noise_statistics_over_many_ticks(sim):
    std, N = 0.0141, 2000
    bd = sim.blockdiagram()
    clk = bd.clock(0.1, name="sensor")
    n = MeasurementNoise(clk, std=std, seed=4, indices=(0, 1), bd=bd)
    base = np.array([0.3, -0.2])
    bd.connect(bd.CONSTANT(base), n)
    bd.compile()
    out = sim.run(bd, T=N * 0.1, watch=[n[0]])
    x = np.asarray(out["sensor"].X)
    assert x.shape == (N, 2)
    m = x.size
    # 4-sigma bounds for the sample mean, std and lag-1 correlation of white noise
    assert abs(x.mean()) < 4 * std / math.sqrt(m)
    assert abs(x.std() / std - 1) < 4 / math.sqrt(2 * m)
    for c in range(2):
        r1 = np.corrcoef(x[:-1, c], x[1:, c])[0, 1]
        assert abs(r1) < 4 / math.sqrt(N)
    assert abs(np.corrcoef(x[:, 0], x[:, 1])[0, 1]) < 4 / math.sqrt(N)
    # the watched output is base + the held draw; a sample logged at a tick is the value
    # held before it: draw 0 at t = 0 and T, then draw k-1 at tick k
    d0 = std * np.random.default_rng(4).standard_normal(2)
    y = np.asarray(out[".ywatch"][0]).reshape(len(out.t), -1)
    np.testing.assert_allclose(out.t, 0.1 * np.arange(N + 1), rtol=1e-12)
    np.testing.assert_allclose(y - base, np.r_[[d0, d0], x[:-1]], rtol=0, atol=1e-15)


# ---------------------------------------------------------------------------
# validation: every constructor rejects bad parameters, naming them
# ---------------------------------------------------------------------------

def _kc(**kw):
    return lambda bd, clk: KinematicController(bd=bd, **kw)


def _skc(**kw):
    return lambda bd, clk: SampledKinematicController(clk, bd=bd, **kw)


def _dc(**kw):
    return lambda bd, clk: DynamicCompensator(bd=bd, **kw)


def _sdc(**kw):
    return lambda bd, clk: SampledDynamicCompensator(clk, bd=bd, **kw)


def _mn(**kw):
    return lambda bd, clk: MeasurementNoise(clk, bd=bd, **kw)


NAN = float("nan")

BAD = [
    # KinematicController
    ("K a=0", _kc(a=0.0), "a"),
    ("K a<0", _kc(a=-0.2), "a"),
    ("K kx=0", _kc(kx=0.0), "kx"),
    ("K kx<0", _kc(kx=-0.1), "kx"),
    ("K ky nan", _kc(ky=NAN), "ky"),
    ("K lx=0", _kc(lx=0.0), "lx"),
    ("K ly inf", _kc(ly=float("inf")), "ly"),
    ("K kx str", _kc(kx="0.1"), "kx"),
    ("K kx bool", _kc(kx=True), "kx"),
    ("K rate", _kc(rate="yes"), "rate"),
    # SampledKinematicController
    ("SK a=0", _skc(a=0.0), "a"),
    ("SK kx<0", _skc(kx=-1.0), "kx"),
    ("SK ly nan", _skc(ly=NAN), "ly"),
    ("SK v_d0 length", _skc(v_d0=(0.0, 0.0, 0.0)), "v_d0"),
    ("SK v_d0 nan", _skc(v_d0=(NAN, 0.0)), "v_d0"),
    # DynamicCompensator
    ("D ku=0", _dc(ku=0.0), "ku"),
    ("D kw nan", _dc(kw=NAN), "kw"),
    ("D lu<0", _dc(lu=-1.0), "lu"),
    ("D lw=0", _dc(lw=0.0), "lw"),
    ("D gamma length", _dc(gamma=(1.0,) * 5), "gamma"),
    ("D gamma zero", _dc(gamma=(1.0, 1.0, 0.0, 1.0, 1.0, 1.0)), "gamma"),
    ("D gamma negative", _dc(gamma=(1.0, -1.0, 1.0, 1.0, 1.0, 1.0)), "gamma"),
    ("D gamma nan", _dc(gamma=(1.0, NAN, 1.0, 1.0, 1.0, 1.0)), "gamma"),
    ("D sigma negative", _dc(sigma=(0.0, 0.0, -1e-3, 0.0, 0.0, 0.0)), "sigma"),
    ("D sigma length", _dc(sigma=(0.001,) * 7), "sigma"),
    ("D sigma nan", _dc(sigma=(NAN,) * 6), "sigma"),
    ("D leakage", _dc(leakage="sigma"), "leakage"),
    ("D vd_dot unknown", _dc(vd_dot="numeric"), "vd_dot"),
    ("D vd_dot sampled-only", _dc(vd_dot="difference"), "vd_dot"),
    ("D tau=0", _dc(tau=0.0), "tau"),
    ("D adapt_from<0", _dc(adapt_from=-1.0), "adapt_from"),
    ("D adapt_from nan", _dc(adapt_from=NAN), "adapt_from"),
    ("D adaptive", _dc(adaptive="yes"), "adaptive"),
    ("D theta_hat0 name", _dc(theta_hat0="p3dx_lazer"), "theta_hat0"),
    ("D theta_hat0 length", _dc(theta_hat0=(0.2, 0.2, 0.0, 1.0, 0.0)), "theta_hat0"),
    ("D theta_hat0 theta1<0", _dc(theta_hat0=(-0.2, 0.2, 0.0, 1.0, 0.0, 1.0)), "theta_hat0"),
    # SampledDynamicCompensator
    ("SD vd_dot continuous-only", _sdc(vd_dot="filter"), "vd_dot"),
    ("SD leakage", _sdc(leakage="Paper"), "leakage"),
    ("SD gamma length", _sdc(gamma=(1.0,) * 7), "gamma"),
    ("SD sigma negative", _sdc(sigma=(-1.0,) * 6), "sigma"),
    ("SD ku<0", _sdc(ku=-4.0), "ku"),
    ("SD theta_hat0 name", _sdc(theta_hat0="nobody"), "theta_hat0"),
    ("SD adapt_from<0", _sdc(adapt_from=-0.1), "adapt_from"),
    # MeasurementNoise
    ("N std<0", _mn(std=-0.01), "std"),
    ("N std nan", _mn(std=NAN), "std"),
    ("N seed<0", _mn(seed=-1), "seed"),
    ("N seed float", _mn(seed=1.5), "seed"),
    ("N seed bool", _mn(seed=True), "seed"),
    ("N seed str", _mn(seed="0"), "seed"),
    ("N indices empty", _mn(indices=()), "indices"),
    ("N indices repeated", _mn(indices=(0, 0)), "indices"),
    ("N indices negative", _mn(indices=(-1,)), "indices"),
    ("N indices not ints", _mn(indices="ab"), "indices"),
    # trajectory sources
    ("F8 ax=0", lambda bd, clk: FigureEight(ax=0.0, bd=bd), "ax"),
    ("F8 wy<0", lambda bd, clk: FigureEight(wy=-0.25, bd=bd), "wy"),
    ("F8 center", lambda bd, clk: FigureEight(center=(0.0,), bd=bd), "center"),
    ("Circle omega=0", lambda bd, clk: Circle(omega=0.0, bd=bd), "omega"),
    ("Circle radius=0", lambda bd, clk: Circle(radius=0.0, bd=bd), "radius"),
    ("Circle phase nan", lambda bd, clk: Circle(phase=NAN, bd=bd), "phase"),
    ("Line start", lambda bd, clk: Line(start=(0.0, 0.0, 0.0), bd=bd), "start"),
    ("Line velocity nan", lambda bd, clk: Line(velocity=(NAN, 0.0), bd=bd), "velocity"),
    ("TS not callable", lambda bd, clk: TrajectorySource(42, bd=bd), "trajectory"),
    ("TS unknown type", lambda bd, clk: TrajectorySource({"type": "spiral"}, bd=bd), "trajectory"),
    ("TS unknown key", lambda bd, clk: TrajectorySource({"type": "circle", "raduis": 1.0}, bd=bd),
     "raduis"),
    ("TS bad value", lambda bd, clk: TrajectorySource({"type": "circle", "radius": -1.0}, bd=bd),
     "radius"),
    ("TS acceleration", lambda bd, clk: TrajectorySource(spiral, acceleration="fast", bd=bd),
     "acceleration"),
    ("TS callable bad shape", lambda bd, clk: TrajectorySource(lambda t: (0.0, 0.0), bd=bd), "h_d"),
    ("TS callable raises", lambda bd, clk: TrajectorySource(lambda t: 1 / 0, bd=bd), "f(0.0)"),
    ("FunctionTrajectory not callable", lambda bd, clk: FunctionTrajectory(42), "f"),
    ("FunctionTrajectory dt", lambda bd, clk: FunctionTrajectory(spiral, dt=0.0), "dt"),
]


@pytest.mark.parametrize("factory, name", [b[1:] for b in BAD], ids=[b[0] for b in BAD])
def test_constructors_reject_bad_parameters_by_name(sim, factory, name):
    bd = sim.blockdiagram()
    clk = bd.clock(0.1, name="ctrl")
    with pytest.raises(ValidationError) as info:
        factory(bd, clk)
    msg = str(info.value)
    # the parameter's name as a word of its own ("a" must not match "a real number")
    assert re.search(rf"(?<!\w){re.escape(name)}(?![\w(])", msg), msg
    if name == "a":
        assert msg.startswith("a must"), msg


def test_validation_errors_are_value_errors():
    assert issubclass(ValidationError, ValueError)


# ---------------------------------------------------------------------------
# docstrings, as bdsim's block loader reads them
# ---------------------------------------------------------------------------

def _block_classes():
    found = []
    for info in pkgutil.iter_modules(unidyn.blocks.__path__):
        mod = importlib.import_module(f"unidyn.blocks.{info.name}")
        for _, cls in inspect.getmembers(mod, inspect.isclass):
            if cls.__module__ == mod.__name__ and issubclass(cls, Block):
                found.append(cls)
    return found


BLOCK_CLASSES = _block_classes()


def test_block_classes_found():
    names = {c.__name__ for c in BLOCK_CLASSES}
    assert {"KinematicController", "SampledKinematicController", "DynamicCompensator",
            "SampledDynamicCompensator", "TrajectorySource", "FigureEight", "Circle", "Line",
            "MeasurementNoise", "DynamicUnicycle", "KinematicUnicycle"} <= names


def _fields(doc, field):
    return re.findall(rf"^\s*:{field}\s+(\w+)\s*:", doc or "", flags=re.M)


@pytest.mark.parametrize("cls", BLOCK_CLASSES, ids=lambda c: c.__name__)
def test_block_docstrings_pair_param_with_type(cls):
    for where, doc in (("class", cls.__doc__), ("__init__", cls.__init__.__doc__)):
        params, types = _fields(doc, "param"), _fields(doc, "type")
        missing = [p for p in params if p not in types]
        assert not missing, f"{cls.__name__}.{where}: :param without :type: {missing}"
    # every constructor argument is documented
    sig = inspect.signature(cls.__init__)
    args = [p for p in sig.parameters if p not in ("self",)]
    documented = set(_fields(cls.__init__.__doc__, "param"))
    assert set(args) <= documented, f"{cls.__name__}: undocumented {set(args) - documented}"
    # the equation it implements: an "Eq." reference or a math block
    assert "Eq." in cls.__doc__ or ".. math::" in cls.__doc__, cls.__name__
    assert f":blockname:`{cls.__name__.upper()}`" in cls.__doc__


def test_block_library_reads_every_block_with_types(sim):
    lib = sim.block_library
    for cls in BLOCK_CLASSES:
        key = cls.__name__.upper()
        assert key in lib, key
        for pname, (typ, _descr) in lib[key]["params"].items():
            assert typ is not None and typ.strip(), f"{key}.{pname} has no type"
        assert lib[key]["nin"] == cls.nin and lib[key]["nout"] == cls.nout
