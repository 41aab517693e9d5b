"""Properties 1-7 and the linear-independence test of Section 3 of Martins et al. (2017)."""

import dataclasses
import json
import math
import subprocess
import sys

import numpy as np
import pytest

import unidyn
from unidyn import RobotParameters, ValidationError
from unidyn.model import robots
from unidyn.model import unicycle as model
from unidyn.model.properties import PropertyReport, RankTestResult, check_properties, rank_test

# Table 1 of the paper and the speed limits of Section 3.2 (0.5 m/s Khepera III,
# 1.2 m/s Pioneers, 1.5 m/s wheelchair), typed in here rather than read from the package.
TABLE1 = {
    "p3dx": ((0.5338, 0.2168, -0.0134, 0.9560, -0.0843, 1.0590), 1.2),
    "p3dx_laser": ((0.2604, 0.2509, -0.000499, 0.9965, 0.00263, 1.0768), 1.2),
    "wheelchair_55kg": ((0.3759, 0.0188, 0.0128, 1.0027, -0.0015, 0.9808), 1.5),
    "wheelchair_125kg": ((0.4263, 0.0289, 0.0058, 0.9883, 0.0134, 0.9931), 1.5),
    "khepera3": ((0.0228, 0.0568, -0.0001, 1.0030, 0.0732, 0.9981), 0.5),
}
FX_PIONEERS = ("p3dx_laut", "pioneer2", "pioneer2_computer")


# ----------------------------------------------------------------------------- property 3 by hand

def test_property3_margin_p3dx_by_hand():
    # theta5 - theta3 = -0.0843 + 0.0134 = -0.0709 < 0, so the minimum of
    # theta6 + (theta5 - theta3) u over |u| <= 1.2 is at u = +1.2:
    # 1.0590 - 0.0709 * 1.2 = 0.97392
    rep = check_properties("p3dx")
    assert rep.u_max == 1.2
    r3 = rep.result(3)
    assert r3.number == 3 and r3.holds
    assert r3.margin == pytest.approx(0.97392, rel=1e-12)
    assert "+1.2" in r3.detail


@pytest.mark.parametrize("name, expected", [
    # theta5 - theta3 = 0.0733 > 0: minimum at u = -0.5, 0.9981 - 0.0733 * 0.5
    ("khepera3", 0.9981 - 0.0733 * 0.5),
    # theta5 - theta3 = -0.0143 < 0: minimum at u = +1.5, 0.9808 - 0.0143 * 1.5
    ("wheelchair_55kg", 0.9808 - 0.0143 * 1.5),
])
def test_property3_margin_at_the_right_end_of_the_interval(name, expected):
    assert check_properties(name).result(3).margin == pytest.approx(expected, rel=1e-12)


def test_other_margins_p3dx_by_hand():
    rep = check_properties("p3dx")
    t1, t2, t3, t4, t5, t6 = TABLE1["p3dx"][0]
    assert rep.result(1).margin == pytest.approx(min(t1, t2))            # min eig H
    assert rep.result(2).margin == pytest.approx(1 / max(t1, t2))        # min eig H^-1
    assert rep.result(4).margin == pytest.approx(0.0, abs=1e-12)         # H independent of v
    assert rep.result(5).margin == pytest.approx(0.0, abs=1e-12)         # v^T C v = 0
    ratio = abs(t5 - t3) * 1.2 / t6                                       # 0.0803...
    assert rep.result(6).margin == pytest.approx(ratio, rel=1e-12)
    assert rep.result(6).holds and ratio < 0.1
    # inf lambda_min(F) over |u| <= 1.2 = min(theta4, theta6 - |theta5 - theta3| 1.2)
    assert rep.result(7).margin == pytest.approx(min(t4, t6 - abs(t5 - t3) * 1.2))
    assert rep.result(7).margin == pytest.approx(0.956)


# ----------------------------------------------------------------------------- the presets

@pytest.mark.parametrize("name", list(TABLE1))
def test_table1_robots_satisfy_properties_1_to_7(name):
    # Section 3.2: "the conditions theta6 > -(theta5 - theta3) u and
    # theta6 >> |(theta5 - theta3) u| are valid for all sets of identified
    # parameters ... with properties 1-7 valid" -- no exception is noted.
    theta, u_max = TABLE1[name]
    rep = check_properties(name)
    assert rep.u_max == u_max
    assert rep.all_hold, str(rep)
    assert [r.number for r in rep.results] == [1, 2, 3, 4, 5, 6, 7]
    t1, t2, t3, t4, t5, t6 = theta
    assert rep.result(3).margin == pytest.approx(t6 - abs(t5 - t3) * u_max, abs=1e-6)
    assert rep.result(6).margin == pytest.approx(abs(t5 - t3) * u_max / t6, abs=1e-6)


@pytest.mark.parametrize("name", FX_PIONEERS)
def test_other_pioneers_satisfy_properties_1_to_7_at_1_2_m_per_s(name):
    rep = check_properties(name)
    assert rep.u_max == 1.2
    assert rep.all_hold, str(rep)


def test_robulab10_f_is_not_approximately_constant():
    # Not in the paper's Table 1 and without a speed limit there: checked at the
    # default 1.2 m/s, F > 0 holds (1.8 - 0.72 * 1.2 = 0.936) but
    # |(theta5 - theta3) u| / theta6 = 0.72 * 1.2 / 1.8 = 0.48 is not small.
    rep = check_properties("robulab10")
    assert rep.u_max == 1.2
    assert rep.failed == [6]
    assert not rep.all_hold
    assert rep.result(3).margin == pytest.approx(1.8 - 0.72 * 1.2)
    assert rep.result(6).margin == pytest.approx(0.48)
    assert "not approximately constant" in rep.result(6).detail
    # at low speed it becomes approximately constant: 0.72 * 0.2 / 1.8 = 0.08
    slow = check_properties("robulab10", u_max=0.2)
    assert slow.all_hold
    assert slow.result(6).margin == pytest.approx(0.08)


def test_default_speed_limit_follows_the_preset_not_the_label():
    assert check_properties(robots.get("khepera3")).u_max == 0.5
    custom = RobotParameters(*TABLE1["khepera3"][0])           # same numbers, name "custom"
    rep = check_properties(custom)
    assert rep.u_max == 1.2 and "default" in rep.u_max_source
    relabelled = RobotParameters(1, 1, 0, 1, 0, 1, name="khepera3")  # not the preset's theta
    assert check_properties(relabelled).u_max == 1.2
    assert check_properties([1, 1, 0, 1, 0, 1], u_max=3.0).u_max == 3.0


# ----------------------------------------------------------------------------- violating property 3

def test_constructed_robot_violating_property3():
    # theta6 = 0.1 small, theta5 - theta3 = 1.0 large: at u = -1.2,
    # F22 = 0.1 + 1.0 * (-1.2) = -1.1 < 0
    bad = RobotParameters(0.3, 0.2, 0.0, 1.0, 1.0, 0.1, name="bad")
    rep = check_properties(bad, u_max=1.2)
    assert not rep.all_hold
    r3 = rep.result(3)
    assert not r3.holds
    assert r3.margin == pytest.approx(-1.1)
    assert "-1.2" in r3.detail
    r7 = rep.result(7)                          # passivity needs property 3
    assert not r7.holds and r7.margin == pytest.approx(-1.1)
    assert not rep.result(6).holds              # ratio 1.2 / 0.1 = 12
    assert rep.result(6).margin == pytest.approx(12.0)
    for k in (1, 2, 4, 5):
        assert rep.result(k).holds
    assert set(rep.failed) == {3, 6, 7}
    assert "NO" in str(rep)
    # the same robot below the crossing speed theta6 / (theta5 - theta3) = 0.1 m/s
    ok = check_properties(bad, u_max=0.05)
    assert ok.result(3).holds and ok.result(3).margin == pytest.approx(0.05)
    assert ok.result(7).holds


def test_violation_in_the_forward_direction():
    # theta5 - theta3 = -2 < 0: F22 = 0.5 - 2 u is smallest at u = +u_max = 1 -> -1.5
    bad = RobotParameters(0.3, 0.2, 1.0, 1.0, -1.0, 0.5)
    r3 = check_properties(bad, u_max=1.0).result(3)
    assert not r3.holds and r3.margin == pytest.approx(-1.5)
    assert "+1" in r3.detail


# ----------------------------------------------------------------------------- Theorem 1

def _eq2(theta, v, v_ref):
    """Eq. (2) written out (no disturbance)."""
    t1, t2, t3, t4, t5, t6 = theta
    u, w = v[..., 0], v[..., 1]
    ud = (t3 * w**2 - t4 * u + v_ref[..., 0]) / t1
    wd = (-t5 * u * w - t6 * w + v_ref[..., 1]) / t2
    return np.stack([ud, wd], -1)


@pytest.mark.parametrize("name", robots.names())
def test_power_balance_on_random_states(name):
    # Theorem 1, Eq. (7): V' = v^T H v' = v^T v_ref - v^T F v, with V = v^T H v / 2
    theta = robots.get(name).theta
    t1, t2, t3, t4, t5, t6 = theta
    rng = np.random.default_rng(12345)
    v = rng.uniform(-1.5, 1.5, size=(500, 2))
    v_ref = rng.uniform(-3.0, 3.0, size=(500, 2))
    vdot = _eq2(theta, v, v_ref)
    np.testing.assert_allclose(model.dynamics(v, v_ref, theta), vdot, rtol=1e-13, atol=1e-13)
    u, w = v[:, 0], v[:, 1]
    Vdot = t1 * u * vdot[:, 0] + t2 * w * vdot[:, 1]
    supply = u * v_ref[:, 0] + w * v_ref[:, 1]
    dissipation = t4 * u**2 + (t6 + (t5 - t3) * u) * w**2
    np.testing.assert_allclose(Vdot, supply - dissipation, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(model.storage(v, theta), 0.5 * (t1 * u**2 + t2 * w**2), rtol=1e-14)
    assert check_properties(name).power_balance_residual < 1e-12


def test_integrated_balance_and_passivity_inequality():
    # Eq. (8): V(T) - V(0) = int v^T v_ref - int v^T F v, and Eq. (9):
    # int v^T v_ref >= -V(0) + inf lambda_min(F) int |v|^2, along a trajectory
    # of Eq. (2) integrated here with a classical RK4.
    theta = robots.get("p3dx").theta
    t1, t2, t3, t4, t5, t6 = theta
    lam = check_properties("p3dx").result(7).margin

    def vref(t):
        return np.array([0.8 * np.sin(0.7 * t), 1.2 * np.cos(1.3 * t)])   # |u| stays < 1.2

    def f(t, z):   # z = [u, w, int supply, int dissipation, int |v|^2]
        v, r = z[:2], vref(t)
        u, w = v
        return np.array([*_eq2(theta, v, r),
                         v @ r, t4 * u**2 + (t6 + (t5 - t3) * u) * w**2, v @ v])

    z = np.array([0.3, -0.5, 0.0, 0.0, 0.0])
    V0 = 0.5 * (t1 * z[0]**2 + t2 * z[1]**2)
    h, t = 0.005, 0.0
    for _ in range(2000):
        k1 = f(t, z)
        k2 = f(t + h / 2, z + h / 2 * k1)
        k3 = f(t + h / 2, z + h / 2 * k2)
        k4 = f(t + h, z + h * k3)
        z = z + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
        t += h
    VT = 0.5 * (t1 * z[0]**2 + t2 * z[1]**2)
    assert VT - V0 == pytest.approx(z[2] - z[3], abs=1e-8)
    assert z[3] >= lam * z[4]                      # v^T F v >= lambda_min |v|^2
    assert z[2] >= -V0 + lam * z[4]                # strict output passivity, Eq. (9)


# ----------------------------------------------------------------------------- report objects

def test_report_is_frozen_and_serialisable():
    rep = check_properties("p3dx_laser")
    assert isinstance(rep, PropertyReport)
    with pytest.raises(dataclasses.FrozenInstanceError):
        rep.u_max = 2.0
    with pytest.raises(dataclasses.FrozenInstanceError):
        rep.results[0].holds = False
    d = json.loads(json.dumps(rep.as_dict(), allow_nan=False))
    assert d["robot"] == "p3dx_laser" and d["all_hold"] is True
    assert [p["number"] for p in d["properties"]] == list(range(1, 8))
    assert all(set(p) == {"number", "name", "holds", "margin", "detail"} for p in d["properties"])
    text = str(rep)
    assert len(text.splitlines()) >= 12
    for k in range(1, 8):
        assert any(line.startswith(f"{k}  ") for line in text.splitlines())
    assert "all properties hold" in text


def test_properties_module_does_not_import_bdsim(tmp_path):
    code = ("import sys, unidyn.model.properties as p; p.check_properties('p3dx'); p.rank_test(10); "
            "assert 'bdsim' not in sys.modules")
    # from an empty folder: a checkout named unidyn in the working folder must not matter
    subprocess.run([sys.executable, "-c", code], check=True, cwd=tmp_path)


def test_lazy_access_from_the_package():
    assert unidyn.check_properties is check_properties
    assert unidyn.rank_test is rank_test


# ----------------------------------------------------------------------------- rank test

@pytest.mark.parametrize("K", [1000, 5000])
def test_rank_test_reproduces_the_paper(K):
    res = rank_test(K)
    assert isinstance(res, RankTestResult)
    assert res.K == K and res.seed == 0
    assert res.ranks == {2: 6, 3: 6, 4: 6}
    assert res.full_rank
    assert "rank 6" in str(res)
    json.dumps(res.as_dict(), allow_nan=False)


def test_rank_test_repeated_with_other_seeds():
    # "This procedure was repeated several times" (Section 3)
    for seed in range(1, 6):
        assert rank_test(1000, seed=seed).full_rank


def test_rank_test_is_seeded():
    a, b = rank_test(200, seed=7), rank_test(200, seed=7)
    assert a == b
    with pytest.raises(dataclasses.FrozenInstanceError):
        a.K = 3


def test_rank_test_detects_dependence():
    # b = 0: theta3 = theta5 = 0, two zero columns -> rank 4
    res = rank_test(500, ranges={"b": (0.0, 0.0)})
    assert res.ranks == {2: 4, 3: 4, 4: 4} and not res.full_rank
    # kPT = kPR and d fixed: theta5 = (2 / d) theta3, proportional columns -> rank 5
    res = rank_test(500, ranges={"kPT": (50, 50), "kPR": (50, 50), "d": (0.4, 0.4)})
    assert res.ranks == {2: 5, 3: 5, 4: 5}


# ----------------------------------------------------------------------------- bad inputs

@pytest.mark.parametrize("u_max", [0, -1.0, float("nan"), float("inf"), "1.2", True])
def test_bad_u_max(u_max):
    with pytest.raises(ValidationError, match="u_max"):
        check_properties("p3dx", u_max=u_max)


@pytest.mark.parametrize("kwargs, param", [
    ({"w_max": 0.0}, "w_max"),
    ({"w_max": math.nan}, "w_max"),
    ({"n": 1}, "n"),
    ({"n": 10.5}, "n"),
    ({"constant_tolerance": -0.1}, "constant_tolerance"),
    ({"seed": -1}, "seed"),
])
def test_bad_check_arguments(kwargs, param):
    with pytest.raises(ValidationError, match=param):
        check_properties("p3dx", **kwargs)


@pytest.mark.parametrize("robot", ["r2d2", [1, 2, 3], [1, 1, 0, -1, 0, 1], None])
def test_bad_robot(robot):
    with pytest.raises(ValidationError, match="robot"):
        check_properties(robot)


@pytest.mark.parametrize("K", [5, 0, -10, 6.0, 1000.5, True, "1000"])
def test_bad_K(K):
    with pytest.raises(ValidationError, match="K must be an integer"):
        rank_test(K)


@pytest.mark.parametrize("decimals", [(0,), (2, -3), (2.5,), (True,), (), "abc", None, 0])
def test_bad_decimals(decimals):
    with pytest.raises(ValidationError, match="decimals"):
        rank_test(100, decimals=decimals)


@pytest.mark.parametrize("ranges, param", [
    ({"mass": (1, 2)}, "mass"),
    ({"m": (0.0, 2.0)}, "m"),
    ({"r": (0.2, 0.1)}, "r"),
    ({"Be": (-1.0, 1.0)}, "Be"),
    ({"d": (0.1, math.inf)}, "d"),
    ([("m", (1, 2))], "ranges"),
])
def test_bad_ranges(ranges, param):
    with pytest.raises(ValidationError, match="ranges") as err:
        rank_test(100, ranges=ranges)
    assert param in str(err.value)


def test_single_decimal_and_bad_seed():
    assert set(rank_test(100, decimals=3).ranks) == {3}
    with pytest.raises(ValidationError, match="seed"):
        rank_test(100, seed=-1)
