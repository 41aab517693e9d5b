"""The python-control bridge (unidyn.teaching.iosys): Eqs. (1)-(2), (10), (14), (18)/(20) as
I/O systems, the Fig. 2 loop assembled with control.interconnect, and its linearisations.

Each check compares with an independent statement: the equations written out here, a
finite-difference Jacobian of the core model, the analytic first-order step response,
or the batch engine (another integrator of the same loop).
"""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

ct = pytest.importorskip("control")

import unidyn  # noqa: E402
from unidyn import NO_LIMITS, PAPER_LIMITS, ValidationError
from unidyn.model import robots
from unidyn.model import unicycle as model  # noqa: E402
from unidyn.model.trajectories import Line  # noqa: E402
from unidyn.teaching import iosys

PRESETS = robots.names()


def _th(name):
    return robots.get(name).theta


# ----------------------------------------------------------------- optional dependency
def test_import_unidyn_does_not_import_control():
    code = ("import sys, unidyn, unidyn.engine.batch, unidyn.model.unicycle, unidyn.model.laws; "
            "assert 'control' not in sys.modules, 'control imported'")
    subprocess.run([sys.executable, "-c", code], check=True)


def test_missing_control_names_the_extra():
    code = ("import sys; sys.modules['control'] = None\n"
            "try:\n    import unidyn.teaching.iosys\nexcept ImportError as e:\n    print(e)\n"
            "else:\n    raise SystemExit('no ImportError')")
    out = subprocess.run([sys.executable, "-c", code], check=True, capture_output=True, text=True)
    assert "pip install unidyn[control]" in out.stdout


# ------------------------------------------------------------------------- the robot
@pytest.mark.parametrize("name", ["p3dx_laser", "khepera3", "robulab10"])
@pytest.mark.parametrize("limits", [NO_LIMITS, PAPER_LIMITS])
def test_robot_agrees_with_eqs_1_2(name, limits):
    """100 seeded random states and commands: the I/O system's right-hand side is
    Eqs. (1)-(2) written out here (and unidyn.model.unicycle's), its outputs the states."""
    rng = np.random.default_rng(7)
    a = 0.2
    sys_ = iosys.to_iosys(name, a=a, limits=limits)
    assert sys_.input_labels == ["u_ref", "w_ref"]
    assert sys_.state_labels == sys_.output_labels == ["x", "y", "psi", "u", "w"]
    t1, t2, t3, t4, t5, t6 = _th(name)
    for _ in range(100):
        x = rng.uniform([-3, -3, -4, -0.7, -1.7], [3, 3, 4, 0.7, 1.7])
        v_ref = rng.uniform(-1.0, 1.0, 2) * [0.7, 1.7]
        f = sys_.updfcn(0.0, x, v_ref, {})
        _, _, psi, u, w = x
        expect = [u * np.cos(psi) - a * w * np.sin(psi), u * np.sin(psi) + a * w * np.cos(psi), w,
                  (t3 * w**2 - t4 * u + v_ref[0]) / t1, (-t5 * u * w - t6 * w + v_ref[1]) / t2]
        if limits.active:  # inside the speed limits; the accelerations clipped
            expect[3] = np.clip(expect[3], -limits.accel_max, limits.accel_max)
            expect[4] = np.clip(expect[4], -limits.angular_accel_max, limits.angular_accel_max)
        np.testing.assert_allclose(f, expect, rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(f, model.unicycle_deriv(x, v_ref, _th(name), a, limits),
                                   rtol=0, atol=0)
        np.testing.assert_array_equal(sys_.outfcn(0.0, x, v_ref, {}), x)


def test_robot_accepts_what_unidyn_accepts(tmp_path):
    p = robots.get("p3dx")
    f = tmp_path / "theta.json"
    f.write_text('{"theta1": 0.5338, "theta2": 0.2168, "theta3": -0.0134, "theta4": 0.956, '
                 '"theta5": -0.0843, "theta6": 1.059}')
    x, v = np.array([0.1, 0.2, 0.3, 0.4, 0.5]), np.array([0.3, -0.2])
    ref = iosys.to_iosys("p3dx").updfcn(0, x, v, {})
    for robot in (p, list(p.theta), p.as_dict(), str(f)):
        np.testing.assert_array_equal(iosys.to_iosys(robot).updfcn(0, x, v, {}), ref)
    with pytest.raises(ValidationError, match="known robots"):
        iosys.to_iosys("p3dx_lazer")


def test_velocity_step_response_is_the_first_order_lag():
    """From rest with w = 0, Eq. (2) is u' = (u_ref - theta4 u)/theta1: the nonlinear
    system's step response is (1 - exp(-theta4 t/theta1)) u_ref/theta4."""
    for name in PRESETS:
        t1, _, _, t4, _, _ = _th(name)
        sys_ = iosys.to_iosys(name)
        t = np.linspace(0, 5 * t1 / t4, 101)
        r = ct.input_output_response(sys_, t, [0.3 * np.ones_like(t), 0 * t], np.zeros(5),
                                     solve_ivp_kwargs=dict(rtol=1e-10, atol=1e-12))
        u = r.outputs[3]
        np.testing.assert_allclose(u, 0.3 / t4 * (1 - np.exp(-t4 * t / t1)), atol=1e-8)
        np.testing.assert_allclose(r.outputs[0], 0.3 / t4 * (t - t1 / t4 * (1 - np.exp(-t4 * t / t1))),
                                   atol=1e-8)  # x = integral of u (psi = 0)


# ---------------------------------------------------------------------- controllers
def test_kinematic_controller_is_eq_10():
    rng = np.random.default_rng(3)
    a, kx, ky, lx, ly = 0.2, 0.7, 1.3, 0.1, 0.2
    K = iosys.kinematic_controller(a, kx, ky, lx, ly)
    K0 = iosys.kinematic_controller(a, kx, ky, lx, ly, rate=False)
    assert K.input_labels == ["x_d", "y_d", "x_d_dot", "y_d_dot", "x_d_ddot", "y_d_ddot",
                              "x", "y", "psi", "u", "w"]
    assert K.output_labels == ["u_d", "w_d", "u_d_dot", "w_d_dot"]
    assert K0.output_labels == ["u_d", "w_d"] and K.nstates == K0.nstates == 0
    for _ in range(50):
        s = rng.normal(size=11)
        xd, yd, vxd, vyd, axd, ayd, x, y, psi, u, w = s
        nu = np.array([vxd + lx * np.tanh(kx * (xd - x) / lx), vyd + ly * np.tanh(ky * (yd - y) / ly)])
        Ainv = np.array([[np.cos(psi), np.sin(psi)], [-np.sin(psi) / a, np.cos(psi) / a]])
        out = K.outfcn(0.0, [], s, {})
        np.testing.assert_allclose(out[:2], Ainv @ nu, rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(K0.outfcn(0.0, [], np.r_[s[:4], s[6:9]], {}), Ainv @ nu,
                                   rtol=1e-12, atol=1e-12)
        # the rate: central difference of Eq. (10) along the motion (Eq. 1, psi' = w)
        h = 1e-6
        def vd(dt, x=x, y=y, psi=psi, u=u, w=w, xd=xd, yd=yd, vxd=vxd, vyd=vyd, axd=axd,
               ayd=ayd):
            hx = x + dt * (u * np.cos(psi) - a * w * np.sin(psi))
            hy = y + dt * (u * np.sin(psi) + a * w * np.cos(psi))
            ref = [xd + dt * vxd, yd + dt * vyd, vxd + dt * axd, vyd + dt * ayd]
            return K0.outfcn(0.0, [], np.r_[ref, hx, hy, psi + dt * w], {})
        np.testing.assert_allclose(out[2:], (vd(h) - vd(-h)) / (2 * h), rtol=1e-6, atol=1e-6)


def test_compensator_is_eq_14_and_adapts_by_eq_20():
    rng = np.random.default_rng(5)
    th = _th("p3dx_laser")
    ku, kw, lu, lw = 4.0, 3.0, 1.0, 0.5
    D = iosys.compensator("p3dx_laser", ku, kw, lu, lw)
    gamma = np.array([1.7, 1.1, 0.5, 0.3, 0.01, 0.5])
    sigma = np.array([5e-4, 1e-3, 1e-3, 6e-5, 1e-3, 1e-3])
    Dad = iosys.compensator("p3dx_laser", ku, kw, lu, lw, adaptive=True, gamma=gamma,
                            sigma=sigma, adapt_from=10.0)
    assert D.output_labels == ["u_ref", "w_ref"] and D.nstates == 0
    assert Dad.state_labels == [f"theta_hat{j}" for j in range(1, 7)]
    for _ in range(50):
        s = rng.normal(size=6)
        ud, wd, udd, wdd, u, w = s
        s1 = udd + lu * np.tanh(ku * (ud - u) / lu)
        s2 = wdd + lw * np.tanh(kw * (wd - w) / lw)
        G = np.array([[s1, 0, -wd * w, ud, 0, 0], [0, s2, ud * w - u * wd, 0, u * wd, wd]])
        np.testing.assert_allclose(D.outfcn(0.0, [], s, {}), G @ th, rtol=1e-12, atol=1e-13)
        th_hat = th * rng.uniform(0.5, 1.5, 6)
        np.testing.assert_allclose(Dad.outfcn(0.0, th_hat, s, {})[:2], G @ th_hat, rtol=1e-12,
                                   atol=1e-13)
        np.testing.assert_array_equal(Dad.outfcn(0.0, th_hat, s, {})[2:], th_hat)
        rate = gamma * (G.T @ np.array([ud - u, wd - w])) - gamma * sigma * th_hat  # Eq. (20)
        np.testing.assert_allclose(Dad.updfcn(12.0, th_hat, s, {}), rate, rtol=1e-12, atol=1e-14)
        np.testing.assert_array_equal(Dad.updfcn(9.0, th_hat, s, {}), np.zeros(6))


# --------------------------------------------------------------------- the Fig. 2 loop
@pytest.mark.parametrize("n, changes, tol", [
    (1, {}, 1e-7), (2, {}, 1e-7), (3, {}, 1e-7), (4, {"adapt_from": 0.0}, 1e-7),
    (4, {"adapt_from": 10.0}, 2e-5),
    (2, {"trajectory": Line(velocity=(0.3, 0.1)), "x0": (0.5, -0.3, 0.4)}, 1e-7)])
def test_fig2_loop_agrees_with_batch_engine(n, changes, tol):
    """control.interconnect of the I/O systems, integrated by solve_ivp (LSODA, rtol
    1e-9), against the batch engine (RK4, 200 steps per 0.1 s) on the same noise-free
    scenario with the paper's limits, 30 s. Switching the update on mid-run (at 10 s)
    is a jump in the right-hand side, which the fixed step crosses with an error
    proportional to the step (batch.py): a looser bound there."""
    sc = unidyn.Scenario.paper(n, noise=None, T=30.0, **changes)
    resp = iosys.simulate_fig2(sc)
    out = dict(zip(resp.output_labels, resp.outputs))
    (b,) = unidyn.simulate_batch([sc], rtol=1e-10, atol=1e-12, progress=False)
    np.testing.assert_allclose(resp.time, b.t, atol=1e-12)
    dist = np.hypot(out["x"] - b.pose[:, 0], out["y"] - b.pose[:, 1])
    assert dist.max() < tol, dist.max()
    np.testing.assert_allclose(out["psi"], b.pose[:, 2], atol=tol)
    np.testing.assert_allclose(np.c_[out["x_d"], out["y_d"]], b.reference, atol=1e-12)
    np.testing.assert_allclose(np.c_[out["u_d"], out["w_d"]], b.v_d, atol=max(1e-6, 10 * tol))
    if n == 4:
        th = np.array([out[f"theta_hat{j}"] for j in range(1, 7)]).T
        np.testing.assert_allclose(th, b.theta_hat, atol=10 * tol)
        assert np.abs(th[-1] - th[0]).max() > 1e-3  # it did adapt
    if n != 1:
        np.testing.assert_allclose(np.c_[out["u"], out["w"]], b.velocity, atol=10 * tol)


@pytest.mark.slow
@pytest.mark.parametrize("n, changes", [(1, {}), (2, {}), (3, {}), (4, {"adapt_from": 5.0})])
def test_fig2_loop_agrees_with_the_bdsim_diagram(n, changes):
    """The same loop against the bdsim diagram of unidyn.simulate (the blocks, an
    adaptive solver at rtol 1e-10), noise-free, 15 s: two independent wirings of
    Eqs. (1)-(2), (10), (14) and (20), one in python-control, one in bdsim."""
    sc = unidyn.Scenario.paper(n, noise=None, T=15.0, **changes)
    resp = iosys.simulate_fig2(sc)
    out = dict(zip(resp.output_labels, resp.outputs))
    d = unidyn.simulate(sc, rtol=1e-10, atol=1e-12)
    assert d.complete
    np.testing.assert_allclose(np.c_[out["x"], out["y"], out["psi"]], d.pose, atol=1e-6)
    if n == 4:
        th = np.array([out[f"theta_hat{j}"] for j in range(1, 7)]).T
        np.testing.assert_allclose(th, d.theta_hat, atol=1e-6)
        assert np.abs(th[-1] - th[0]).max() > 1e-4  # it did adapt


@pytest.mark.slow
def test_fig2_loop_agrees_with_batch_engine_paper_case_4_full():
    """The paper's whole simulation 4 (200 s, update switched on at 100 s), noise-free."""
    sc = unidyn.Scenario.paper(4, noise=None)
    out = dict(zip(*(lambda r: (r.output_labels, r.outputs))(iosys.simulate_fig2(sc))))
    (b,) = unidyn.simulate_batch([sc], rtol=1e-10, atol=1e-12, progress=False)
    assert np.hypot(out["x"] - b.pose[:, 0], out["y"] - b.pose[:, 1]).max() < 1e-5


def test_fig2_loop_signals_and_noise_inputs():
    loop = iosys.fig2_loop(unidyn.Scenario.paper(4))
    assert loop.input_labels == ["n_x", "n_y", "n_u", "n_w"]
    assert loop.output_labels[:9] == ["x", "y", "psi", "u", "w", "u_d", "w_d", "u_ref", "w_ref"]
    x0 = iosys.fig2_initial_state(loop)
    np.testing.assert_allclose(x0[5:], _th("p3dx_laser") / 1.5)
    np.testing.assert_allclose(x0[:3], [0.2, 0.0, 0.0])
    # a constant position noise n_x shifts what the kinematic controller sees: at t = 0
    # u_d = x_d' + lx tanh(kx (x_d - x - n_x)/lx) (Eq. 10, psi = 0)
    sc = unidyn.Scenario.paper(2)
    loop2 = iosys.fig2_loop(sc)
    for n_x in (0.0, 0.05):
        y = loop2.output(0.0, iosys.fig2_initial_state(loop2), [n_x, 0, 0, 0])
        expect = 0.5 + sc.lx * np.tanh(sc.kx * (0.0 - 0.2 - n_x) / sc.lx)
        assert y[5] == pytest.approx(expect, abs=1e-12)
    with pytest.raises(ValidationError, match="exact v_d'"):
        iosys.fig2_loop(unidyn.Scenario.paper(3, vd_dot="filter"))


# ------------------------------------------------------------------- linearisations
@pytest.mark.parametrize("name", PRESETS)
def test_velocity_loop_about_rest_has_the_analytic_poles(name):
    t1, t2, _, t4, _, t6 = _th(name)
    lin = iosys.velocity_loop(name)
    assert lin.input_labels == ["u_ref", "w_ref"] and lin.output_labels == ["u", "w"]
    np.testing.assert_allclose(np.sort(lin.poles().real), np.sort([-t4 / t1, -t6 / t2]), rtol=1e-6)
    np.testing.assert_allclose(lin.poles().imag, 0, atol=1e-12)
    np.testing.assert_allclose(lin.B, np.diag([1 / t1, 1 / t2]), rtol=1e-6)
    G_u, G_w = iosys.velocity_tf(name)
    # 1/(theta1 s + theta4) and 1/(theta2 s + theta6), normalised to a monic denominator
    np.testing.assert_allclose(np.r_[G_u.num[0][0][-1:], G_u.den[0][0][-2:]],
                               [1 / t1, 1, t4 / t1], rtol=1e-6)
    np.testing.assert_allclose(np.r_[G_w.num[0][0][-1:], G_w.den[0][0][-2:]],
                               [1 / t2, 1, t6 / t2], rtol=1e-6)
    assert ct.dcgain(G_u) == pytest.approx(1 / t4, rel=1e-6)
    # Bode: at the corner frequency theta4/theta1 the gain is 1/(theta4 sqrt 2), phase -45 deg
    mag, phase, _ = ct.frequency_response(G_u, [t4 / t1])
    assert mag[0] == pytest.approx(1 / (t4 * np.sqrt(2)), rel=1e-6)
    assert np.degrees(phase[0]) == pytest.approx(-45.0, abs=1e-4)


def test_the_velocity_transfer_functions_print_as_transfer_functions():
    text = str(iosys.velocity_tf("p3dx_laser"))
    assert "TransferFunction>: G_u" in text and "TransferFunction>: G_w" in text
    assert "['u_ref']" in text and "['w']" in text and "(<" not in text  # not a raw tuple
    assert repr(iosys.velocity_tf("p3dx_laser")) == text


@pytest.mark.parametrize("name", PRESETS)
def test_step_response_of_the_linear_loop(name):
    t1, t2, _, t4, _, t6 = _th(name)
    G_u, G_w = iosys.velocity_tf(name)
    t = np.linspace(0, 6 * t1 / t4, 200)
    r = ct.step_response(G_u, t)
    np.testing.assert_allclose(r.outputs, (1 - np.exp(-t4 * t / t1)) / t4, atol=1e-6 / t4)
    assert ct.step_info(G_w)["SteadyStateValue"] == pytest.approx(1 / t6, rel=1e-6)


def _fd_jacobian(f, x0, h=1e-6):
    f0 = f(x0)
    J = np.empty((len(f0), len(x0)))
    for i in range(len(x0)):
        e = np.zeros(len(x0))
        e[i] = h
        J[:, i] = (f(x0 + e) - f(x0 - e)) / (2 * h)
    return J


@pytest.mark.parametrize("name", ["p3dx", "p3dx_laser", "wheelchair_55kg", "khepera3", "robulab10"])
@pytest.mark.parametrize("u0, w0", [(0.5, 0.0), (0.4, 0.8), (-0.3, -1.2)])
def test_linearisation_about_a_turn_matches_finite_differences(name, u0, w0):
    """The linearisation of control.linearize against a central-difference Jacobian of
    unidyn.model.unicycle.dynamics / unicycle_deriv (an independent route) and against the
    derivatives of Eq. (2) written out."""
    th = _th(name)
    t1, t2, t3, t4, t5, t6 = th
    v0 = np.array([u0, w0])
    v_ref0 = model.inverse_dynamics(v0, [0, 0], th)
    np.testing.assert_allclose(model.dynamics(v0, v_ref0, th), 0, atol=1e-12)  # steady
    lin = iosys.velocity_loop(name, u0, w0)
    A = _fd_jacobian(lambda v: model.dynamics(v, v_ref0, th), v0)
    B = _fd_jacobian(lambda r: model.dynamics(v0, r, th), v_ref0)
    scale = np.abs(A).max()
    np.testing.assert_allclose(lin.A, A, atol=1e-5 * scale)
    np.testing.assert_allclose(lin.B, B, rtol=1e-5)
    np.testing.assert_allclose(lin.A, [[-t4 / t1, 2 * t3 * w0 / t1],
                                       [-t5 * w0 / t2, -(t6 + t5 * u0) / t2]], atol=1e-5 * scale)
    # the whole robot at a heading in the turn
    a, psi0 = 0.2, 0.7
    full = iosys.linearize_robot(name, a, u0, w0, psi0)
    x0 = np.array([0.0, 0.0, psi0, u0, w0])
    Af = _fd_jacobian(lambda x: model.unicycle_deriv(x, v_ref0, th, a), x0)
    Bf = _fd_jacobian(lambda r: model.unicycle_deriv(x0, r, th, a), v_ref0)
    np.testing.assert_allclose(full.A, Af, atol=1e-5 * max(1.0, np.abs(Af).max()))
    np.testing.assert_allclose(full.B, Bf, rtol=1e-5, atol=1e-9)
    assert full.A[0, 2] == pytest.approx(-u0 * np.sin(psi0) - a * w0 * np.cos(psi0), abs=1e-5)
    assert full.state_labels == ["x", "y", "psi", "u", "w"]


def test_tracking_loop_poles_are_analytic():
    """Linearised about a straight line at V: kinematic case -kx, -ky, -V/a; the
    uncompensated case's longitudinal pair solves theta1 s^2 + theta4 s + kx = 0; exact
    compensation adds -(ku + theta4/theta1) to the kinematic poles."""
    V, a, k = 0.3, 0.2, 2.0
    t1, t2, t3, t4, t5, t6 = _th("p3dx_laser")

    def poles(case):
        L = iosys.tracking_loop(unidyn.Scenario.paper(1, case=case), V=V, kx=k, ky=k)
        p = L.poles()
        assert np.sum(np.abs(p) < 1e-9) == 4  # the reference generator
        return np.sort_complex(p[np.abs(p) > 1e-9])

    np.testing.assert_allclose(poles("kinematic"), np.sort_complex([-V / a, -k, -k]), atol=1e-5)
    p2 = poles("uncompensated")
    for r in np.roots([t1, t4, k]):
        assert np.min(np.abs(p2 - r)) < 1e-5
    p3 = poles("compensated")
    for r in (-V / a, -k, -(4.0 + t4 / t1)):
        assert np.min(np.abs(p3 - r)) < 1e-5
    with pytest.raises(ValidationError, match="adaptation"):
        iosys.tracking_loop(unidyn.Scenario.paper(4))


def test_tracking_loop_noise_gain():
    """Kinematic case: e_x' = -kx e_x + kx n_x, so e_x/n_x = kx/(s + kx) (DC gain 1)
    and u_ref/n_x = -kx s/(s + kx) (high-frequency gain -kx: the noise reaches the
    command multiplied by the gain)."""
    k = 3.0
    L = iosys.tracking_loop(unidyn.Scenario.paper(1), V=0.3, kx=k, ky=k)
    assert L.input_labels == ["x_d_ddot", "y_d_ddot", "n_x", "n_y", "n_u", "n_w"]
    assert L.output_labels == ["e_x", "e_y", "u_ref", "w_ref", "u", "w", "psi"]
    w = np.array([0.1, 1.0, 10.0, 100.0])
    e = ct.frequency_response(L[L.output_index["e_x"], L.input_index["n_x"]], w)
    np.testing.assert_allclose(e.magnitude.ravel(), k / np.abs(1j * w + k), rtol=1e-5)
    c = ct.frequency_response(L[L.output_index["u_ref"], L.input_index["n_x"]], w)
    np.testing.assert_allclose(c.magnitude.ravel(), k * w / np.abs(1j * w + k), rtol=1e-5)


# -------------------------------------------------------------- python-control's params
def test_the_offset_a_defaults_as_in_the_blocks():
    """One default for a: each I/O system's is its bdsim block's."""
    import inspect

    from unidyn import blocks

    def default(f):
        return inspect.signature(f).parameters["a"].default

    assert default(iosys.to_iosys) == default(blocks.DynamicUnicycle) == default(iosys.linearize_robot)
    assert default(iosys.kinematic_iosys) == default(blocks.KinematicUnicycle)
    assert default(iosys.kinematic_controller) == default(blocks.KinematicController)


def _turning(sys_, params=None):
    t = np.linspace(0.0, 3.0, 31)
    u = np.vstack([0.3 * np.ones_like(t), 0.4 * np.ones_like(t)])
    return ct.input_output_response(sys_, t, u, [0, 0, 0, 0.3, 0.4], params=params,
                                    solve_ivp_kwargs=dict(rtol=1e-10, atol=1e-12)).outputs


def test_params_passed_through_python_control_are_honoured():
    """params={'a': 0.5} moves h as a robot built with a = 0.5 (h = axle centre +
    a (cos psi, sin psi), Eq. 1); 'robot' changes its dynamics as building it does."""
    base, moved = _turning(iosys.to_iosys()), _turning(iosys.to_iosys(), {"a": 0.5})
    np.testing.assert_allclose(moved, _turning(iosys.to_iosys(a=0.5)), rtol=0, atol=1e-12)
    psi = base[2]
    np.testing.assert_allclose(moved[0] - base[0], 0.5 * (np.cos(psi) - 1), atol=1e-8)
    np.testing.assert_allclose(moved[1] - base[1], 0.5 * np.sin(psi), atol=1e-8)
    np.testing.assert_allclose(_turning(iosys.to_iosys(), {"robot": "khepera3"}),
                               _turning(iosys.to_iosys("khepera3")), rtol=0, atol=1e-12)
    assert set(iosys.to_iosys().params) == {"robot", "a", "limits"}


def test_the_loops_params_reach_its_systems():
    """Given to the Fig. 2 loop, kx reaches the controller: the run is that of the
    scenario with kx changed."""
    sc = unidyn.Scenario.paper(3).replace(T=5.0, noise=None)
    t = np.arange(51) * 0.1
    loop = iosys.fig2_loop(sc)
    x0 = iosys.fig2_initial_state(loop)
    r = ct.input_output_response(loop, t, np.zeros((4, len(t))), x0, params={"kx": 0.5},
                                 solve_ivp_kwargs=dict(rtol=1e-10, atol=1e-12))
    ref = iosys.simulate_fig2(sc.replace(kx=0.5), t=t, rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(r.outputs, ref.outputs, rtol=0, atol=1e-7)
    assert not np.allclose(ref.outputs, iosys.simulate_fig2(sc, t=t).outputs, atol=1e-3)


@pytest.mark.parametrize("make, params, match", [
    (lambda: iosys.to_iosys(), {"a": -0.1}, "a must be"),
    (lambda: iosys.to_iosys(), {"robot": "p3dx_lazer"}, "known robots"),
    (lambda: iosys.kinematic_controller(), {"kx": 0.0}, "kx must be"),
    (lambda: iosys.kinematic_controller(), {"rate": False}, "'rate' shapes the system's signals"),
    (lambda: iosys.compensator(adaptive=True), {"theta_hat0": "p3dx"}, "initial state"),
    (lambda: iosys.compensator(adaptive=True), {"gamma": [1, 1, 1, 1, 1, -1]}, "gamma must be"),
])
def test_params_python_control_cannot_honour_are_refused(make, params, match):
    sys_ = make()
    x = np.zeros(sys_.nstates)
    u = np.full(sys_.ninputs, 0.1)
    with pytest.raises(ValidationError, match=match):
        sys_.output(0.0, x, u, params=params)


def test_fig2_loop_refuses_a_payload_schedule():
    """The python-control loop's robot has constant theta: a load that changes during
    the run is refused in one line, not ignored."""
    with pytest.raises(ValidationError, match="payload schedule") as err:
        iosys.fig2_loop(unidyn.Scenario.paper(3, payload=[[50.0, 2.0]]))
    assert "\n" not in str(err.value)
