"""Atomic tests of the numerical core (pure numpy, no bdsim).

Every check compares the code with an independent statement of the same
equation written out here (Martins et al. 2017, Eqs. 1, 2, 6, 10, 11, 14, 18,
20 and Section 2), on seeded random states, or with a property that must hold
pointwise (skew-symmetry, the power balance of Theorem 1, finite differences).
"""

from __future__ import annotations

import dataclasses
import json
import math

import numpy as np
import pytest

import paper_equations
import unidyn
from unidyn import Limits, RobotParameters, ValidationError
from unidyn.model import laws as control
from unidyn.model import robots, trajectories
from unidyn.model import unicycle as model

THETA_NAMES = ("theta1", "theta2", "theta3", "theta4", "theta5", "theta6")

# Table 1 and MATLAB Central File Exchange 44850: name -> (theta1..theta6, comes from Table 1 of the paper)
PRESETS = {
    "p3dx": ((0.5338, 0.2168, -0.0134, 0.9560, -0.0843, 1.0590), True),
    "p3dx_laser": ((0.2604, 0.2509, -0.000499, 0.9965, 0.00263, 1.0768), True),
    "wheelchair_55kg": ((0.3759, 0.0188, 0.0128, 1.0027, -0.0015, 0.9808), True),
    "wheelchair_125kg": ((0.4263, 0.0289, 0.0058, 0.9883, 0.0134, 0.9931), True),
    "khepera3": ((0.0228, 0.0568, -0.0001, 1.0030, 0.0732, 0.9981), True),
    "p3dx_laut": ((0.2183, 0.1918, -0.0050, 0.9993, -0.0279, 1.0142), False),
    "pioneer2": ((0.1992, 0.13736, 0.001954, 0.9907, 0.01554, 0.9866), False),
    "pioneer2_computer": ((0.3037, 0.2768, -0.0004018, 0.9835, 0.003818, 1.0725), False),
    "robulab10": ((6.06, 0.284, 0.54, 6.48, 1.26, 1.8), False),
}
PRESET_THETAS = np.array([v[0] for v in PRESETS.values()])


def random_theta(rng, n):
    """n parameter vectors: presets and random ones with either sign of theta3, theta5."""
    out = np.empty((n, 6))
    for i in range(n):
        if i % 2 == 0:
            out[i] = PRESET_THETAS[rng.integers(len(PRESET_THETAS))]
        else:
            out[i] = [rng.uniform(0.01, 2.0), rng.uniform(0.01, 2.0), rng.uniform(-0.5, 0.5),
                      rng.uniform(0.5, 3.0), rng.uniform(-0.5, 0.5), rng.uniform(0.5, 3.0)]
    return out


def random_states(rng, n):
    x = np.column_stack([rng.uniform(-5, 5, n), rng.uniform(-5, 5, n),
                         rng.uniform(-math.pi, math.pi, n),
                         rng.uniform(-1.5, 1.5, n), rng.uniform(-2.0, 2.0, n)])
    return x


# ---------------------------------------------------------------------------
# RobotParameters
# ---------------------------------------------------------------------------

GOOD = dict(theta1=0.3, theta2=0.2, theta3=-0.01, theta4=1.0, theta5=0.02, theta6=1.1)


@pytest.mark.parametrize("name", THETA_NAMES)
@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf])
def test_parameters_reject_nonfinite(name, bad):
    with pytest.raises(ValidationError, match=name):
        RobotParameters(**{**GOOD, name: bad})


@pytest.mark.parametrize("name", ["theta1", "theta2", "theta4", "theta6"])
@pytest.mark.parametrize("bad", [0.0, -1e-9, -0.5])
def test_parameters_reject_nonpositive(name, bad):
    with pytest.raises(ValidationError, match=name):
        RobotParameters(**{**GOOD, name: bad})


@pytest.mark.parametrize("name", ["theta1", "theta3"])
@pytest.mark.parametrize("bad", ["0.3", None, True, [0.3]])
def test_parameters_reject_non_numbers(name, bad):
    with pytest.raises(ValidationError, match=name):
        RobotParameters(**{**GOOD, name: bad})


def test_parameters_theta3_theta5_any_sign_and_zero():
    p = RobotParameters(**{**GOOD, "theta3": -2.0, "theta5": 0.0})
    assert p.theta3 == -2.0 and p.theta5 == 0.0


def test_parameters_immutable_and_theta_is_a_copy():
    p = RobotParameters(**GOOD)
    with pytest.raises(dataclasses.FrozenInstanceError):
        p.theta1 = 5.0
    th = p.theta
    np.testing.assert_array_equal(th, [GOOD[k] for k in THETA_NAMES])
    th[0] = 99.0
    assert p.theta1 == 0.3
    assert p.theta[0] == 0.3


def test_parameters_vector_roundtrips():
    p = RobotParameters(**GOOD, name="x")
    assert RobotParameters.from_vector(p.theta) == p
    assert robots.resolve(p.as_dict()) == p
    with pytest.raises(ValidationError, match="theta"):
        RobotParameters.from_vector([1.0, 2.0, 3.0])
    with pytest.raises(ValidationError, match="theta"):
        RobotParameters.from_vector([1.0, 2.0, 0.0, -1.0, 0.0, 1.0])  # theta4 < 0


def test_scaled_gives_the_papers_initial_estimate():
    # Section 5 of the paper: theta_hat(0) = theta/1.5 = [0.1736 0.1673 -0.0003 0.6643 0.0018 0.7179]
    est = robots.get("p3dx_laser").scaled(1 / 1.5)
    np.testing.assert_allclose(est.theta, [0.1736, 0.1673, -0.0003, 0.6643, 0.0018, 0.7179],
                               atol=5e-5)
    with pytest.raises(ValidationError, match="factor"):
        robots.get("p3dx").scaled(0.0)


# ---------------------------------------------------------------------------
# presets
# ---------------------------------------------------------------------------

def test_preset_names_in_spec_order():
    assert robots.names() == list(PRESETS)


@pytest.mark.parametrize("name", list(PRESETS))
def test_preset_values_and_sources(name):
    theta, from_table1 = PRESETS[name]
    p = robots.get(name)
    assert isinstance(p, RobotParameters)
    assert p.name == name
    np.testing.assert_array_equal(p.theta, theta)
    if from_table1:
        assert "Table 1" in p.source
    else:
        assert "44850" in p.source
    assert robots.resolve(name) == p
    if name == "p3dx_laut":  # FX44850 labels it twice; the source says so
        assert "Pioneer 3-DX" in p.source and "Khepera III" in p.source
    # Section 2: these four are positive for every physical robot
    assert p.theta1 > 0 and p.theta2 > 0 and p.theta4 > 0 and p.theta6 > 0


@pytest.mark.parametrize("bad", ["pioneer", "P3DX", "", 42])
def test_unknown_robot_lists_known_names(bad):
    with pytest.raises(ValidationError) as err:
        robots.get(bad)
    msg = str(err.value)
    assert repr(bad) in msg
    for n in PRESETS:
        assert n in msg


def test_resolve_accepts_all_forms_and_names_what(tmp_path):
    p = robots.get("khepera3")
    assert robots.resolve(p) is p
    assert robots.resolve(list(p.theta)) == p
    path = tmp_path / "robot.json"
    path.write_text(json.dumps(p.as_dict()))
    assert robots.resolve(str(path)) == p
    with pytest.raises(ValidationError, match=r"^myrobot: unknown robot 'nope'"):
        robots.resolve("nope", what="myrobot")
    with pytest.raises(ValidationError, match="myrobot"):
        robots.resolve([1.0, 2.0], what="myrobot")
    with pytest.raises(ValidationError, match="missing theta6"):
        robots.resolve({k: 1.0 for k in THETA_NAMES[:5]})


# ---------------------------------------------------------------------------
# from_physical (Section 2)
# ---------------------------------------------------------------------------

PHYS = dict(m=12.0, Iz=0.31, Ra=0.71, ka=0.034, kb=0.028, Be=0.0021, Ie=0.0016, r=0.095,
            b=0.045, d=0.33, kPT=48.0, kPR=37.0, kDT=0.55, kDR=0.27)


def test_from_physical_matches_hand_computation():
    m, Iz, Ra, ka, kb, Be, Ie, r, b, d, kPT, kPR, kDT, kDR = (
        12.0, 0.31, 0.71, 0.034, 0.028, 0.0021, 0.0016, 0.095, 0.045, 0.33, 48.0, 37.0,
        0.55, 0.27)
    t1 = (Ra / ka) * (m * r * r + 2.0 * Ie + 2.0 * r * kDT) / (2.0 * r * kPT)
    t2 = (Ra / ka) * (Ie * d * d + 2.0 * r * r * (Iz + m * b * b) + 2.0 * r * d * kDR) / (
        2.0 * r * d * kPR)
    t3 = (Ra / ka) * m * b * r / (2.0 * kPT)
    t4 = (Ra / ka) * (ka * kb / Ra + Be) / (r * kPT) + 1.0
    t5 = (Ra / ka) * m * b * r / (d * kPR)
    t6 = (Ra / ka) * (ka * kb / Ra + Be) * d / (2.0 * r * kPR) + 1.0
    p = RobotParameters.from_physical(**PHYS)
    np.testing.assert_allclose(p.theta, [t1, t2, t3, t4, t5, t6], rtol=1e-13, atol=0)
    # a rough order-of-magnitude anchor, so a consistent typo in both copies shows
    assert 0.1 < t1 < 1.0 and 0.01 < t2 < 1.0 and 1.0 < t4 < 1.2 and 1.0 < t6 < 1.2


def test_from_physical_derivative_gains_default_to_zero():
    base = {k: v for k, v in PHYS.items() if k not in ("kDT", "kDR")}
    p0 = RobotParameters.from_physical(**base)
    p1 = RobotParameters.from_physical(**base, kDT=0.0, kDR=0.0)
    assert p0 == p1
    # kDT enters theta1 only, kDR theta2 only
    p2 = RobotParameters.from_physical(**base, kDT=1.0, kDR=0.0)
    g = base["Ra"] / base["ka"]
    assert p2.theta1 - p0.theta1 == pytest.approx(g * 2 * base["r"] * 1.0 / (2 * base["r"] * base["kPT"]))
    np.testing.assert_array_equal(p2.theta[1:], p0.theta[1:])


def test_from_physical_signs_on_random_robots():
    rng = np.random.default_rng(20170001)
    for _ in range(300):
        kw = dict(m=rng.uniform(0.1, 200), Iz=rng.uniform(0, 20), Ra=rng.uniform(0.1, 5),
                  ka=rng.uniform(0.005, 0.5), kb=rng.uniform(0, 0.5), Be=rng.uniform(0, 0.1),
                  Ie=rng.uniform(0, 0.05), r=rng.uniform(0.01, 0.3),
                  b=rng.choice([0.0, rng.uniform(-0.3, 0.3)]), d=rng.uniform(0.05, 0.8),
                  kPT=rng.uniform(1, 200), kPR=rng.uniform(1, 200), kDT=rng.uniform(0, 5),
                  kDR=rng.uniform(0, 5))
        p = RobotParameters.from_physical(**kw)
        assert p.theta1 > 0 and p.theta2 > 0
        assert p.theta4 >= 1 and p.theta6 >= 1
        if kw["b"] == 0.0:
            assert p.theta3 == 0.0 and p.theta5 == 0.0
        else:
            assert np.sign(p.theta3) == np.sign(kw["b"]) == np.sign(p.theta5)


@pytest.mark.parametrize("name,bad", [("m", 0.0), ("Iz", -1.0), ("Ra", -0.1), ("ka", 0.0),
                                      ("kb", -1e-3), ("Be", math.nan), ("Ie", -1.0),
                                      ("r", 0.0), ("b", math.inf), ("d", -0.3),
                                      ("kPT", 0.0), ("kPR", -1.0), ("kDT", -0.1),
                                      ("kDR", math.nan)])
def test_from_physical_rejects_bad_input_by_name(name, bad):
    with pytest.raises(ValidationError, match=rf"^{name} "):
        RobotParameters.from_physical(**{**PHYS, name: bad})


# ---------------------------------------------------------------------------
# Eq. (6), (11): regressor, inverse dynamics, dynamics
# ---------------------------------------------------------------------------

def hand_inverse_dynamics(v, vd, th):
    """H v' + C(v) v + F(v) v, matrices written out from Eq. (6)."""
    t1, t2, t3, t4, t5, t6 = (float(x) for x in th)
    u, w = float(v[0]), float(v[1])
    H = np.array([[t1, 0.0], [0.0, t2]])
    C = np.array([[0.0, -t3 * w], [t3 * w, 0.0]])
    F = np.array([[t4, 0.0], [0.0, t6 + (t5 - t3) * u]])
    return H @ np.asarray(vd) + C @ np.asarray(v) + F @ np.asarray(v)


def hand_eq2(v, v_ref, th):
    t1, t2, t3, t4, t5, t6 = (float(x) for x in th)
    u, w = v
    ur, wr = v_ref
    return np.array([t3 / t1 * w * w - t4 / t1 * u + ur / t1,
                     -t5 / t2 * u * w - t6 / t2 * w + wr / t2])


def test_regressor_times_theta_is_inverse_dynamics():
    rng = np.random.default_rng(11)
    thetas = random_theta(rng, 100)
    for th in thetas:
        v = rng.uniform(-2, 2, 2)
        vd = rng.uniform(-3, 3, 2)
        Y = model.regressor(v, vd)
        assert Y.shape == (2, 6)
        ref = hand_inverse_dynamics(v, vd, th)
        np.testing.assert_allclose(Y @ th, ref, rtol=1e-12, atol=1e-13)
        np.testing.assert_allclose(model.inverse_dynamics(v, vd, th), ref, rtol=1e-12, atol=1e-13)


def test_dynamics_is_eq2_and_inverts_inverse_dynamics():
    rng = np.random.default_rng(12)
    for th in random_theta(rng, 100):
        v = rng.uniform(-2, 2, 2)
        vd = rng.uniform(-3, 3, 2)
        v_ref = rng.uniform(-2, 2, 2)
        np.testing.assert_allclose(model.dynamics(v, v_ref, th), hand_eq2(v, v_ref, th),
                                   rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(
            model.dynamics(v, model.inverse_dynamics(v, vd, th), th), vd, rtol=1e-10, atol=1e-10)
        np.testing.assert_allclose(
            model.inverse_dynamics(v, model.dynamics(v, v_ref, th), th), v_ref,
            rtol=1e-10, atol=1e-12)


def test_matrices_properties():
    rng = np.random.default_rng(13)
    for th in random_theta(rng, 100):
        v = rng.uniform(-2, 2, 2)
        H = model.inertia(th)
        C = model.coriolis(v, th)
        F = model.damping(v, th)
        np.testing.assert_array_equal(H, np.diag(th[:2]))                     # (1), (4)
        np.testing.assert_allclose(C, -C.T, atol=0)                            # (5)
        assert abs(v @ C @ v) <= 1e-15 * (1 + abs(th[2]) * np.dot(v, v) * abs(v[1]))
        np.testing.assert_allclose(F, F.T, atol=0)
        expected_f22 = th[5] + (th[4] - th[2]) * v[0]
        assert F[1, 1] == pytest.approx(expected_f22, rel=1e-14, abs=1e-15)
        # property (3): F > 0 exactly when theta6 > -(theta5 - theta3) u
        assert (np.linalg.eigvalsh(F).min() > 0) == (th[5] > -(th[4] - th[2]) * v[0])


def test_power_balance_theorem1_pointwise():
    rng = np.random.default_rng(14)
    for th in random_theta(rng, 100):
        v = rng.uniform(-2, 2, 2)
        v_ref = rng.uniform(-2, 2, 2)
        vdot = model.dynamics(v, v_ref, th)
        V = model.storage(v, th)
        assert V == pytest.approx(0.5 * v @ np.diag(th[:2]) @ v, rel=1e-14)
        dV = v @ np.diag(th[:2]) @ vdot
        F = model.damping(v, th)
        np.testing.assert_allclose(dV, v @ v_ref - v @ F @ v, rtol=1e-10, atol=1e-12)
        # and dV/dt as a central difference of storage along v(t)
        eps = 1e-6
        fd = (model.storage(v + eps * vdot, th) - model.storage(v - eps * vdot, th)) / (2 * eps)
        assert fd == pytest.approx(dV, rel=1e-7, abs=1e-9)


# ---------------------------------------------------------------------------
# batch axis
# ---------------------------------------------------------------------------

def test_batch_calls_equal_single_calls():
    rng = np.random.default_rng(15)
    N = 40
    X = random_states(rng, N)
    VR = rng.uniform(-2, 2, (N, 2))
    VD = rng.uniform(-2, 2, (N, 2))
    TH = random_theta(rng, N)
    DEL = rng.uniform(-0.2, 0.2, (N, 4))
    lim = Limits(0.8, 1.5, 0.5, 2.0)
    a = 0.17
    th0 = TH[0]
    batch = {
        "deriv_theta_batch": model.unicycle_deriv(X, VR, TH, a, lim, DEL),
        "deriv_theta_single": model.unicycle_deriv(X, VR, th0, a, lim, DEL),
        "deriv_nolim": model.unicycle_deriv(X, VR, TH, a),
        "kin": model.kinematics(X, a),
        "dyn": model.dynamics(X[:, 3:], VR, TH),
        "Y": model.regressor(X[:, 3:], VD),
        "inv": model.inverse_dynamics(X[:, 3:], VD, TH),
        "C": model.coriolis(X[:, 3:], TH),
        "F": model.damping(X[:, 3:], TH),
        "H": model.inertia(TH),
        "V": model.storage(X[:, 3:], TH),
        "kdot": model.kinematic_unicycle_deriv(X[:, :3], VR, a, lim),
    }
    for i in range(N):
        single = {
            "deriv_theta_batch": model.unicycle_deriv(X[i], VR[i], TH[i], a, lim, DEL[i]),
            "deriv_theta_single": model.unicycle_deriv(X[i], VR[i], th0, a, lim, DEL[i]),
            "deriv_nolim": model.unicycle_deriv(X[i], VR[i], TH[i], a),
            "kin": model.kinematics(X[i], a),
            "dyn": model.dynamics(X[i, 3:], VR[i], TH[i]),
            "Y": model.regressor(X[i, 3:], VD[i]),
            "inv": model.inverse_dynamics(X[i, 3:], VD[i], TH[i]),
            "C": model.coriolis(X[i, 3:], TH[i]),
            "F": model.damping(X[i, 3:], TH[i]),
            "H": model.inertia(TH[i]),
            "V": model.storage(X[i, 3:], TH[i]),
            "kdot": model.kinematic_unicycle_deriv(X[i, :3], VR[i], a, lim),
        }
        for key, val in single.items():
            np.testing.assert_allclose(batch[key][i], val, rtol=1e-14, atol=1e-15, err_msg=key)


# ---------------------------------------------------------------------------
# Eq. (1) and the full derivative
# ---------------------------------------------------------------------------

def test_kinematics_eq1_by_hand():
    rng = np.random.default_rng(16)
    for x in random_states(rng, 50):
        a = float(rng.uniform(0, 0.5))
        X, Y, psi, u, w = (float(s) for s in x)
        hand = [u * math.cos(psi) - a * w * math.sin(psi),
                u * math.sin(psi) + a * w * math.cos(psi),
                w]
        np.testing.assert_allclose(model.kinematics(x, a), hand, rtol=1e-14, atol=1e-15)
        np.testing.assert_allclose(model.kinematic_unicycle_deriv(x[:3], x[3:], a), hand,
                                   rtol=1e-14, atol=1e-15)
        np.testing.assert_allclose(model.point_velocity(psi, x[3:], a), hand[:2],
                                   rtol=1e-14, atol=1e-15)


def test_kinematics_is_velocity_of_offset_point():
    # h = c + a (cos psi, sin psi) with c' = u (cos psi, sin psi): differentiate numerically
    rng = np.random.default_rng(17)
    for x in random_states(rng, 20):
        a = 0.3
        psi, u, w = x[2:]
        c = np.array([1.0, -2.0])

        def h_at(s, c=c, u=u, psi=psi, w=w, a=a):
            # axle centre moving on a straight line to first order, heading rotating at w
            cs = c + u * s * np.array([math.cos(psi), math.sin(psi)])
            p = psi + w * s
            return cs + a * np.array([math.cos(p), math.sin(p)])

        eps = 1e-6
        fd = (h_at(eps) - h_at(-eps)) / (2 * eps)
        np.testing.assert_allclose(model.kinematics(x, a)[:2], fd, rtol=1e-7, atol=1e-8)


def test_unicycle_deriv_without_limits_is_eq1_eq2_plus_delta():
    rng = np.random.default_rng(18)
    for th in random_theta(rng, 30):
        x = random_states(rng, 1)[0]
        v_ref = rng.uniform(-2, 2, 2)
        delta = rng.uniform(-1, 1, 4)
        a = 0.2
        xd = model.unicycle_deriv(x, v_ref, th, a, delta=delta)
        kin = model.kinematics(x, a)
        np.testing.assert_allclose(xd[:2], kin[:2] + delta[:2], rtol=1e-14, atol=1e-15)
        assert xd[2] == x[4]  # psi' = w, no disturbance on psi
        np.testing.assert_allclose(xd[3:], hand_eq2(x[3:], v_ref, th) + delta[2:],
                                   rtol=1e-12, atol=1e-12)


# ---------------------------------------------------------------------------
# limits
# ---------------------------------------------------------------------------

def test_limits_validation():
    for k in ("speed_max", "steer_max", "accel_max", "angular_accel_max"):
        for bad in (0.0, -1.0, math.nan):
            with pytest.raises(ValidationError, match=k):
                Limits(**{k: bad})
    assert not Limits().active
    assert Limits(accel_max=1.0).active
    assert unidyn.PAPER_LIMITS.as_dict() == {"speed_max": 0.75, "steer_max": 1.745,
                                             "accel_max": 0.3, "angular_accel_max": 1.745}


def test_limits_hold_for_random_inputs():
    rng = np.random.default_rng(19)
    lim = Limits(speed_max=0.5, steer_max=1.0, accel_max=0.3, angular_accel_max=2.0)
    vmax = np.array([0.5, 1.0])
    amax = np.array([0.3, 2.0])
    n_bound_inward = 0
    for th in random_theta(rng, 400):
        x = random_states(rng, 1)[0]
        # velocities inside or exactly on the limits
        x[3:] = rng.uniform(-1, 1, 2) * vmax
        on = rng.integers(0, 3, 2)  # 0: inside, 1: +limit, 2: -limit
        x[3:] = np.where(on == 1, vmax, np.where(on == 2, -vmax, x[3:]))
        v_ref = rng.uniform(-4, 4, 2)
        delta = np.r_[0.0, 0.0, rng.uniform(-1, 1, 2)] if rng.random() < 0.3 else None
        a = 0.2
        xd = model.unicycle_deriv(x, v_ref, th, a, lim, delta)
        vdot = xd[3:]
        # accelerations bounded
        assert np.all(np.abs(vdot) <= amax + 1e-15)
        # a velocity at its limit is never pushed outwards
        for j in range(2):
            if x[3 + j] >= vmax[j]:
                assert vdot[j] <= 0.0
            if x[3 + j] <= -vmax[j]:
                assert vdot[j] >= 0.0
        # and the documented law exactly: Eq. 2 with commands clipped to the speed
        # limits, the result clipped to the acceleration limits, outward motion at
        # a limit stopped (inward motion from a limit is kept)
        raw = hand_eq2(x[3:], np.clip(v_ref, -vmax, vmax), th)
        if delta is not None:
            raw = raw + delta[2:]
        expect = np.clip(raw, -amax, amax)
        for j in range(2):
            at_hi = x[3 + j] >= vmax[j] and expect[j] > 0
            at_lo = x[3 + j] <= -vmax[j] and expect[j] < 0
            if at_hi or at_lo:
                expect[j] = 0.0
            elif abs(x[3 + j]) >= vmax[j]:
                n_bound_inward += 1
        np.testing.assert_allclose(vdot, expect, rtol=1e-12, atol=1e-14)
        # the kinematic rows are not limited
        np.testing.assert_allclose(xd[:3], model.kinematics(x, a), rtol=0, atol=0)
    assert n_bound_inward > 20  # the "moving back from a limit" case was exercised


def test_kinematic_unicycle_clips_commands_to_speed_limits():
    lim = Limits(speed_max=0.5, steer_max=1.0, accel_max=0.01)
    q = np.array([0.0, 0.0, 0.3])
    got = model.kinematic_unicycle_deriv(q, [2.0, -3.0], 0.1, lim)
    hand = [0.5 * math.cos(0.3) - 0.1 * (-1.0) * math.sin(0.3),
            0.5 * math.sin(0.3) + 0.1 * (-1.0) * math.cos(0.3), -1.0]
    np.testing.assert_allclose(got, hand, rtol=1e-14)


# ---------------------------------------------------------------------------
# trajectories
# ---------------------------------------------------------------------------

def _fd(f, t, h):
    return (f(t + h) - f(t - h)) / (2 * h)


TRAJS = [
    trajectories.FigureEight(),
    trajectories.FigureEight(ax=2.0, ay=0.5, wx=0.3, wy=0.7, center=(1.0, -2.0)),
    trajectories.Circle(),
    trajectories.Circle(radius=1.7, omega=-0.4, center=(0.5, 0.25), phase=0.9),
    trajectories.Line(),
    trajectories.Line(start=(1.0, 2.0), velocity=(-0.3, 0.45)),
    trajectories.FunctionTrajectory(
        lambda t: ((math.cos(t), math.sin(2 * t)), (-math.sin(t), 2 * math.cos(2 * t)))),
    trajectories.FunctionTrajectory(
        lambda t: ((t * t, 1.0), (2 * t, 0.0)), acceleration=lambda t: (2.0, 0.0)),
]


@pytest.mark.parametrize("traj", TRAJS, ids=lambda tr: type(tr).__name__)
def test_trajectory_derivatives_match_finite_differences(traj):
    ts = np.linspace(-3.0, 30.0, 23)
    h = 1e-5
    for t in ts:
        np.testing.assert_allclose(_fd(traj.position, t, h), traj.velocity(t), rtol=1e-7, atol=1e-8)
        tol = 1e-6 if isinstance(traj, trajectories.FunctionTrajectory) else 1e-8
        np.testing.assert_allclose(_fd(traj.velocity, t, h), traj.acceleration(t), rtol=1e-6, atol=tol)
    # array time input: same values as scalar calls
    T = ts.reshape(-1, 1)[:6]
    for fn in (traj.position, traj.velocity, traj.acceleration):
        arr = fn(T)
        for i in range(T.shape[0]):
            np.testing.assert_allclose(arr[i, 0], fn(T[i, 0]), rtol=1e-14, atol=1e-15)
    p, v = traj(2.0)
    np.testing.assert_array_equal(p, traj.position(2.0))
    np.testing.assert_array_equal(v, traj.velocity(2.0))


def test_function_trajectory_numeric_acceleration_is_accurate():
    tr = TRAJS[6]
    for t in np.linspace(0, 10, 11):
        np.testing.assert_allclose(tr.acceleration(t), [-math.cos(t), -4 * math.sin(2 * t)],
                                   atol=1e-7)


def test_figure_eight_defaults_are_the_papers():
    tr = trajectories.FigureEight()
    for t in np.linspace(0, 8 * math.pi, 17):
        np.testing.assert_allclose(tr.position(t), [math.sin(0.5 * t), math.cos(0.25 * t) - 1],
                                   atol=1e-15)
        np.testing.assert_allclose(tr.velocity(t), [0.5 * math.cos(0.5 * t),
                                                    -0.25 * math.sin(0.25 * t)], atol=1e-15)
    np.testing.assert_allclose(tr.position(8 * math.pi), tr.position(0.0), atol=1e-12)


@pytest.mark.parametrize("traj", TRAJS[:6], ids=lambda tr: type(tr).__name__)
def test_from_spec_roundtrip(traj):
    spec = traj.to_spec()
    # survives a JSON round trip (what a scenario file holds)
    spec2 = json.loads(json.dumps(spec))
    for s in (spec, spec2):
        back = trajectories.from_spec(s)
        assert type(back) is type(traj)
        assert back == traj
        t = np.linspace(0, 20, 9)
        np.testing.assert_array_equal(back.position(t), traj.position(t))
    assert trajectories.from_spec(traj) is traj


def test_from_spec_names_and_errors():
    assert trajectories.from_spec("circle") == trajectories.Circle()
    assert trajectories.from_spec({"type": "figure_eight", "wx": 0.2}).wx == 0.2
    with pytest.raises(ValidationError, match="spiral"):
        trajectories.from_spec({"type": "spiral"})
    with pytest.raises(ValidationError, match="type must be one of"):
        trajectories.from_spec({"radius": 1.0})
    with pytest.raises(ValidationError, match="radius"):
        trajectories.from_spec({"type": "circle", "radius": -1.0})
    with pytest.raises(ValidationError, match="omega"):
        trajectories.from_spec({"type": "circle", "omega": 0.0})
    with pytest.raises(ValidationError, match="radus"):
        trajectories.from_spec({"type": "circle", "radus": 2.0})
    with pytest.raises(ValidationError, match="center"):
        trajectories.from_spec({"type": "figure_eight", "center": [1.0]})
    with pytest.raises(ValidationError, match="velocity"):
        trajectories.from_spec({"type": "line", "velocity": [0.1, math.nan]})
    with pytest.raises(ValidationError):
        trajectories.from_spec(3.0)
    # a wrapped callable is recorded (for summaries) but never rebuilt from data
    spec = TRAJS[6].to_spec()
    assert spec["type"] == "function"
    with pytest.raises(ValidationError, match="FunctionTrajectory"):
        trajectories.from_spec(spec)


def test_function_trajectory_validation():
    with pytest.raises(ValidationError, match="callable"):
        trajectories.FunctionTrajectory(3.0)
    with pytest.raises(ValidationError, match="h_d"):
        trajectories.FunctionTrajectory(lambda t: ((0.0, 0.0, 0.0), (0.0, 0.0)))
    with pytest.raises(ValidationError, match="acceleration"):
        trajectories.FunctionTrajectory(lambda t: ((0, 0), (0, 0)), acceleration=1.0)
    with pytest.raises(ValidationError, match="dt"):
        trajectories.FunctionTrajectory(lambda t: ((0, 0), (0, 0)), dt=0.0)


# ---------------------------------------------------------------------------
# controllers
# ---------------------------------------------------------------------------

hand_eq10 = paper_equations.eq10


def test_kinematic_control_eq10_by_hand():
    rng = np.random.default_rng(21)
    for _ in range(100):
        h_d, h_d_dot, h = rng.uniform(-2, 2, 2), rng.uniform(-1, 1, 2), rng.uniform(-2, 2, 2)
        psi = float(rng.uniform(-4, 4))
        a = float(rng.uniform(0.05, 0.5))
        k = rng.uniform(0.1, 5, 2)
        l = rng.uniform(0.05, 2, 2)
        np.testing.assert_allclose(control.kinematic_control(h_d, h_d_dot, h, psi, a, k, l),
                                   hand_eq10(h_d, h_d_dot, h, psi, a, k, l),
                                   rtol=1e-12, atol=1e-13)


def test_kinematic_control_makes_h_follow_the_commanded_velocity():
    # Eq. 10 inverts Eq. 1: with v = v_d the point h moves at h_d' + L tanh(K h~/L)
    rng = np.random.default_rng(22)
    for _ in range(50):
        h_d, h_d_dot, h = rng.uniform(-2, 2, 2), rng.uniform(-1, 1, 2), rng.uniform(-2, 2, 2)
        psi, a = float(rng.uniform(-4, 4)), float(rng.uniform(0.05, 0.5))
        k, l = rng.uniform(0.1, 5, 2), rng.uniform(0.05, 2, 2)
        vd = control.kinematic_control(h_d, h_d_dot, h, psi, a, k, l)
        np.testing.assert_allclose(model.point_velocity(psi, vd, a),
                                   h_d_dot + l * np.tanh(k * (h_d - h) / l), rtol=1e-10, atol=1e-12)


def _eq1_rk4(h, psi, u, w, a, dt):
    """One RK4 step of Eq. (1) for constant u, w (written out independently)."""
    def f(s):
        return np.array([u * math.cos(s[2]) - a * w * math.sin(s[2]),
                         u * math.sin(s[2]) + a * w * math.cos(s[2]), w])
    s = np.array([h[0], h[1], psi])
    k1 = f(s)
    k2 = f(s + dt / 2 * k1)
    k3 = f(s + dt / 2 * k2)
    k4 = f(s + dt * k3)
    s = s + dt / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    return s[:2], s[2]


def test_kinematic_control_rate_matches_finite_difference_along_motion():
    rng = np.random.default_rng(23)
    traj = trajectories.FigureEight(ax=1.3, ay=0.8, wx=0.6, wy=0.35)
    dt = 1e-5
    for _ in range(60):
        t = float(rng.uniform(0, 30))
        h = traj.position(t) + rng.uniform(-0.4, 0.4, 2)
        psi = float(rng.uniform(-4, 4))
        u, w = float(rng.uniform(-0.8, 0.8)), float(rng.uniform(-1.5, 1.5))
        a = float(rng.uniform(0.1, 0.4))
        k, l = rng.uniform(0.1, 3, 2), rng.uniform(0.1, 1, 2)

        def vd_at(s, h=h, psi=psi, u=u, w=w, a=a, t=t, k=k, l=l):
            hs, ps = _eq1_rk4(h, psi, u, w, a, s)
            return control.kinematic_control(traj.position(t + s), traj.velocity(t + s),
                                             hs, ps, a, k, l)

        fd = (vd_at(dt) - vd_at(-dt)) / (2 * dt)
        rate = control.kinematic_control_rate(traj.position(t), traj.velocity(t),
                                              traj.acceleration(t), h, psi, [u, w], a, k, l)
        np.testing.assert_allclose(rate, fd, rtol=1e-6, atol=1e-6)


hand_G = paper_equations.eq14


def test_compensation_regressor_eq14_by_hand():
    rng = np.random.default_rng(24)
    for _ in range(100):
        v_d, v_d_dot, v = rng.uniform(-1, 1, 2), rng.uniform(-1, 1, 2), rng.uniform(-1, 1, 2)
        k, l = rng.uniform(0.5, 5, 2), rng.uniform(0.2, 2, 2)
        np.testing.assert_allclose(control.compensation_regressor(v_d, v_d_dot, v, k, l),
                                   hand_G(v_d, v_d_dot, v, k, l), rtol=1e-13, atol=1e-15)


def test_exact_compensation_gives_the_closed_loop_error_equation():
    rng = np.random.default_rng(25)
    for th in random_theta(rng, 100):
        v_d, v_d_dot, v = rng.uniform(-1, 1, 2), rng.uniform(-1, 1, 2), rng.uniform(-1, 1, 2)
        k, l = rng.uniform(0.5, 5, 2), rng.uniform(0.2, 2, 2)
        G = control.compensation_regressor(v_d, v_d_dot, v, k, l)
        v_ref = control.compensation(G, th)
        np.testing.assert_allclose(v_ref, G @ th, rtol=1e-14, atol=1e-15)
        v_dot = model.dynamics(v, v_ref, th)
        vt = v_d - v
        t1, t2, t3, t4, t5, t6 = th
        H = np.diag([t1, t2])
        C = np.array([[0.0, -t3 * v[1]], [t3 * v[1], 0.0]])
        F = np.diag([t4, t6 + (t5 - t3) * v[0]])
        expect = -l * np.tanh(k * vt / l) - np.linalg.solve(H, (C + F) @ vt)
        np.testing.assert_allclose(v_d_dot - v_dot, expect, rtol=1e-9, atol=1e-11)


GAMMA = np.array([1.7, 1.1, 0.5, 0.3, 0.01, 0.5])
SIGMA = np.array([0.0005, 0.001, 0.001, 0.00006, 0.001, 0.001])


def test_adaptation_rate_leakage_forms():
    rng = np.random.default_rng(26)
    for _ in range(30):
        G = hand_G(rng.uniform(-1, 1, 2), rng.uniform(-1, 1, 2), rng.uniform(-1, 1, 2),
                   [4.0, 4.0], [1.0, 1.0])
        th_hat = rng.uniform(-1, 1, 6)
        zero = np.zeros(2)
        np.testing.assert_array_equal(
            control.adaptation_rate(G, zero, th_hat, GAMMA, SIGMA, leakage="none"), np.zeros(6))
        np.testing.assert_allclose(
            control.adaptation_rate(G, zero, th_hat, GAMMA, SIGMA, leakage="paper"),
            -GAMMA * SIGMA * th_hat, rtol=1e-15, atol=0)
        np.testing.assert_allclose(
            control.adaptation_rate(G, zero, th_hat, GAMMA, SIGMA, leakage="fx44850"),
            -SIGMA * th_hat, rtol=1e-15, atol=0)
        # with an error: Eq. (18) gamma G^T v~, plus the leakage
        vt = rng.uniform(-1, 1, 2)
        grad = np.array([sum(G[i, j] * vt[i] for i in range(2)) for j in range(6)])
        np.testing.assert_allclose(
            control.adaptation_rate(G, vt, th_hat, GAMMA, SIGMA, leakage="none"),
            GAMMA * grad, rtol=1e-13, atol=1e-15)
        np.testing.assert_allclose(
            control.adaptation_rate(G, vt, th_hat, GAMMA, SIGMA),  # default is Eq. 20
            GAMMA * grad - GAMMA * SIGMA * th_hat, rtol=1e-13, atol=1e-15)


@pytest.mark.parametrize("bad", ["Paper", "sigma", "", None])
def test_adaptation_rate_rejects_unknown_leakage(bad):
    with pytest.raises(ValueError, match="leakage"):
        control.adaptation_rate(np.zeros((2, 6)), np.zeros(2), np.zeros(6), GAMMA, SIGMA,
                                leakage=bad)


def test_controller_batch_calls_equal_single_calls():
    rng = np.random.default_rng(27)
    N = 25
    h_d, h_d_dot, h_d_ddot, h = (rng.uniform(-1, 1, (N, 2)) for _ in range(4))
    psi = rng.uniform(-3, 3, N)
    v, v_d, v_d_dot = (rng.uniform(-1, 1, (N, 2)) for _ in range(3))
    th_hat = rng.uniform(-1, 1, (N, 6))
    k, l, a = np.array([0.5, 1.5]), np.array([0.3, 0.2]), 0.2
    KC = control.kinematic_control(h_d, h_d_dot, h, psi, a, k, l)
    KR = control.kinematic_control_rate(h_d, h_d_dot, h_d_ddot, h, psi, v, a, k, l)
    G = control.compensation_regressor(v_d, v_d_dot, v, k, l)
    VR = control.compensation(G, th_hat)
    AR = control.adaptation_rate(G, v_d - v, th_hat, GAMMA, SIGMA)
    for i in range(N):
        np.testing.assert_allclose(KC[i], control.kinematic_control(h_d[i], h_d_dot[i], h[i],
                                                                    psi[i], a, k, l), rtol=1e-14)
        np.testing.assert_allclose(KR[i], control.kinematic_control_rate(
            h_d[i], h_d_dot[i], h_d_ddot[i], h[i], psi[i], v[i], a, k, l), rtol=1e-13, atol=1e-15)
        Gi = control.compensation_regressor(v_d[i], v_d_dot[i], v[i], k, l)
        np.testing.assert_allclose(G[i], Gi, rtol=1e-14)
        np.testing.assert_allclose(VR[i], control.compensation(Gi, th_hat[i]), rtol=1e-14)
        np.testing.assert_allclose(AR[i], control.adaptation_rate(Gi, v_d[i] - v[i], th_hat[i],
                                                                  GAMMA, SIGMA), rtol=1e-14)


@pytest.mark.parametrize("seed,std,n,dim", [(0, 0.01, 2501, 2), (7, 0.0141, 999, 2), (3, 1.0, 17, 3)])
def test_held_noise_is_the_tick_by_tick_draws_of_the_noise_block(seed, std, n, dim):
    """noise.held_sequence draws all rows at once; the noise block draws one row per
    clock tick from the same generator: the numbers must be the same, in order."""
    from unidyn.model.noise import held_sequence, noise_seeds
    pos_seed, _ = noise_seeds(seed)
    rng = np.random.default_rng(pos_seed)
    tick_by_tick = np.array([std * rng.standard_normal(dim) for _ in range(n)])
    np.testing.assert_array_equal(held_sequence(pos_seed, std, n, dim), tick_by_tick)
    into = np.full((n, dim), np.nan)
    assert held_sequence(pos_seed, std, n, dim, out=into) is into
    np.testing.assert_array_equal(into, tick_by_tick)
