"""Scenario: the paper's settings as defaults (the paper's Section 5, typed in again here),
the four cases of Section 5, plain-data round trips (dict, JSON, TOML), and loud
validation of every field."""

from __future__ import annotations

import dataclasses
import json
import math
import re

import numpy as np
import pytest

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10
    import tomli as tomllib

from unidyn import Limits, NoiseSpec, RobotParameters, ValidationError
from unidyn.model import robots, trajectories
from unidyn.model.scenario import Scenario

# Table 1 and Section 5: the Pioneer 3-DX with laser of the paper's simulations
P3DX_LASER = [0.2604, 0.2509, -0.000499, 0.9965, 0.00263, 1.0768]
PAPER_GAMMA = [1.7, 1.1, 0.5, 0.3, 0.01, 0.5]
PAPER_SIGMA = [0.0005, 0.001, 0.001, 0.00006, 0.001, 0.001]
# theta / 1.5 as printed in Section 5
PAPER_THETA_HAT0 = [0.1736, 0.1673, -0.0003, 0.6643, 0.0018, 0.7179]

FIELDS = [f.name for f in dataclasses.fields(Scenario)]


def names_in(msg: str, name: str) -> bool:
    """``name`` occurs in ``msg`` as a word of its own (not inside another word or a call)."""
    return re.search(rf"(?<!\w){re.escape(name)}(?![\w(])", msg) is not None


# ---------------------------------------------------------------------------
# defaults = the paper's settings
# ---------------------------------------------------------------------------

def test_defaults_are_the_papers_settings():
    s = Scenario()
    assert s.robot == robots.get("p3dx_laser")
    np.testing.assert_array_equal(s.robot.theta, P3DX_LASER)
    assert s.a == 0.2
    assert s.x0 == (0.2, 0.0, 0.0)
    assert (s.kx, s.ky, s.lx, s.ly) == (0.1, 0.1, 0.1, 0.1)
    assert (s.ku, s.kw, s.lu, s.lw) == (4.0, 4.0, 1.0, 1.0)
    assert list(s.gamma) == PAPER_GAMMA
    assert list(s.sigma) == PAPER_SIGMA
    assert s.leakage == "paper"  # Eq. (20)
    assert (s.limits.speed_max, s.limits.steer_max) == (0.75, 1.745)
    assert (s.limits.accel_max, s.limits.angular_accel_max) == (0.3, 1.745)
    assert s.noise is not None
    assert (s.noise.position_std, s.noise.velocity_std) == (0.01, 0.0141)
    assert s.T == 200.0 and s.Ts == 0.1 and s.steps == 2000
    assert s.adapt_from == 100.0
    assert s.control == "continuous" and s.vd_dot is None and s.derivative == "analytic"


def test_default_trajectory_is_the_papers_figure_eight():
    tr = Scenario().trajectory
    t = np.linspace(0.0, 60.0, 601)
    np.testing.assert_allclose(tr.position(t), np.c_[np.sin(0.5 * t), np.cos(0.25 * t) - 1],
                               atol=1e-15)
    np.testing.assert_allclose(tr.velocity(t), np.c_[0.5 * np.cos(0.5 * t), -0.25 * np.sin(0.25 * t)],
                               atol=1e-15)
    np.testing.assert_array_equal(tr.position(0.0), [0.0, 0.0])  # starts at the origin
    np.testing.assert_allclose(tr.position(t + 8 * math.pi), tr.position(t), atol=1e-12)  # period 8 pi


CASE_NAMES = {1: "kinematic", 2: "uncompensated", 3: "compensated", 4: "adaptive"}


@pytest.mark.parametrize("n", [1, 2, 3, 4])
def test_paper_cases(n):
    s = Scenario.paper(n)
    assert s.case == CASE_NAMES[n]
    # everything else is the paper's common setting
    ref = Scenario().to_dict()
    got = s.to_dict()
    for k in ("case", "name"):
        ref.pop(k), got.pop(k)
    assert got == ref
    assert s.adapt_from == 100.0
    assert s.name  # labelled


def test_paper_case_with_changes():
    s = Scenario.paper(4, kx=0.5, T=50.0)
    assert (s.case, s.kx, s.T) == ("adaptive", 0.5, 50.0)
    assert Scenario.paper(2, case="kinematic").case == "kinematic"


@pytest.mark.parametrize("n", [0, 5, -1, True, 2.5, "1", None])
def test_paper_rejects_other_numbers(n):
    with pytest.raises(ValidationError, match="paper simulation n"):
        Scenario.paper(n)


def test_paper_with_integral_float_is_case_or_validation_error():
    # either reading: the float 2.0 means case 2, or it is rejected like other bad n
    try:
        s = Scenario.paper(2.0)
    except ValidationError:
        return
    assert s == Scenario.paper(2)


def test_theta_hat_initial_compensated_is_theta():
    s = Scenario.paper(3)
    np.testing.assert_array_equal(s.theta_hat_initial, P3DX_LASER)


def test_theta_hat_initial_adaptive_is_theta_over_1_5():
    th = Scenario.paper(4).theta_hat_initial
    np.testing.assert_allclose(th, np.array(P3DX_LASER) / 1.5, rtol=1e-15)
    np.testing.assert_allclose(np.round(th, 4), PAPER_THETA_HAT0, rtol=0, atol=1e-12)


def test_theta_hat0_overrides_and_is_a_copy():
    s = Scenario(case="adaptive", theta_hat0="p3dx")
    np.testing.assert_array_equal(s.theta_hat_initial, robots.get("p3dx").theta)
    s2 = Scenario(case="compensated", theta_hat0=[0.3, 0.2, 0.0, 1.0, 0.0, 1.0])
    np.testing.assert_array_equal(s2.theta_hat_initial, [0.3, 0.2, 0.0, 1.0, 0.0, 1.0])
    # mutating the returned array does not touch the scenario
    arr = Scenario.paper(4).theta_hat_initial
    arr[:] = 0.0
    np.testing.assert_allclose(Scenario.paper(4).theta_hat_initial, np.array(P3DX_LASER) / 1.5)


# ---------------------------------------------------------------------------
# plain-data round trips
# ---------------------------------------------------------------------------

def _custom():
    return Scenario(
        case="compensated",
        robot=RobotParameters.from_vector([0.3, 0.2, 0.01, 0.95, -0.02, 1.05], name="my_robot"),
        a=0.15, x0=(0.1, -0.2, 0.3),
        trajectory=trajectories.Circle(radius=0.8, omega=-0.3, center=(1.0, 2.0), phase=0.5),
        kx=0.7, ky=0.8, lx=0.2, ly=0.3, ku=3.0, kw=5.0, lu=0.5, lw=2.0,
        theta_hat0=[0.25, 0.22, 0.0, 0.9, 0.0, 1.0],
        gamma=(1.0, 2.0, 3.0, 4.0, 5.0, 6.0), sigma=(0.0, 0.1, 0.0, 0.2, 0.0, 0.3),
        adapt_from=12.5, leakage="fx44850", noise=None,
        limits=Limits(speed_max=1.0, steer_max=2.0),  # accelerations unlimited (inf)
        T=30.0, Ts=0.05, control="sampled", vd_dot="difference", tau=0.1, name="custom run")


ROUND_TRIP = {
    "default": Scenario,
    "paper1": lambda: Scenario.paper(1),
    "paper2": lambda: Scenario.paper(2),
    "paper3": lambda: Scenario.paper(3),
    "paper4": lambda: Scenario.paper(4),
    "custom": _custom,
    "line": lambda: Scenario(trajectory=trajectories.Line((0.5, 0.5), (0.1, -0.2)),
                             noise=NoiseSpec(0.02, 0.03, 17), robot="khepera3", a=0.05),
}


def _plain(v):
    if isinstance(v, dict):
        return all(isinstance(k, str) and _plain(x) for k, x in v.items())
    if isinstance(v, list):
        return all(_plain(x) for x in v)
    return v is None or isinstance(v, (str, int, float, bool))


@pytest.mark.parametrize("make", ROUND_TRIP.values(), ids=ROUND_TRIP.keys())
def test_dict_and_json_round_trip(make):
    s = make()
    d = s.to_dict()
    assert set(d) == set(FIELDS)
    assert _plain(d), d
    back = Scenario.from_dict(d)
    assert back == s
    assert back.to_dict() == d
    via_json = Scenario.from_dict(json.loads(json.dumps(d)))
    assert via_json == s
    assert via_json.robot.name == s.robot.name
    np.testing.assert_array_equal(via_json.theta_hat_initial, s.theta_hat_initial)


def test_from_dict_does_not_mutate_its_input():
    d = _custom().to_dict()
    snapshot = json.dumps(d, sort_keys=True)
    Scenario.from_dict(d)
    assert json.dumps(d, sort_keys=True) == snapshot


PAPER4_TOML = """
# The paper's simulation 4 (Section 5), written out
case = "adaptive"
name = "paper simulation 4 (adaptive)"
robot = "p3dx_laser"
a = 0.2
x0 = [0.2, 0.0, 0.0]
kx = 0.1
ky = 0.1
lx = 0.1
ly = 0.1
ku = 4.0
kw = 4.0
lu = 1.0
lw = 1.0
theta_hat0 = "default"
gamma = [1.7, 1.1, 0.5, 0.3, 0.01, 0.5]
sigma = [0.0005, 0.001, 0.001, 0.00006, 0.001, 0.001]
adapt_from = 100.0
leakage = "paper"
T = 200.0
Ts = 0.1
control = "continuous"
tau = 0.05

[trajectory]
type = "figure_eight"
ax = 1.0
ay = 1.0
wx = 0.5
wy = 0.25
center = [0.0, 0.0]

[noise]
position_std = 0.01
velocity_std = 0.0141
seed = 0

[limits]
speed_max = 0.75
steer_max = 1.745
accel_max = 0.3
angular_accel_max = 1.745
"""

CUSTOM_TOML = """
case = "compensated"
name = "custom run"
a = 0.15
x0 = [0.1, -0.2, 0.3]
kx = 0.7
ky = 0.8
lx = 0.2
ly = 0.3
ku = 3.0
kw = 5.0
lu = 0.5
lw = 2.0
theta_hat0 = [0.25, 0.22, 0.0, 0.9, 0.0, 1.0]
gamma = [1, 2, 3, 4, 5, 6]
sigma = [0, 0.1, 0, 0.2, 0, 0.3]
adapt_from = 12.5
leakage = "fx44850"
noise = "off"
T = 30
Ts = 0.05
control = "sampled"
vd_dot = "difference"
tau = 0.1

[robot]
name = "my_robot"
theta1 = 0.3
theta2 = 0.2
theta3 = 0.01
theta4 = 0.95
theta5 = -0.02
theta6 = 1.05

[trajectory]
type = "circle"
radius = 0.8
omega = -0.3
center = [1.0, 2.0]
phase = 0.5

[limits]
speed_max = 1.0
steer_max = 2.0
accel_max = inf
angular_accel_max = inf
"""


def test_toml_paper_case_4():
    s = Scenario.from_dict(tomllib.loads(PAPER4_TOML))
    assert s == Scenario.paper(4)
    assert s.to_dict() == Scenario.paper(4).to_dict()


def test_toml_custom_scenario():
    s = Scenario.from_dict(tomllib.loads(CUSTOM_TOML))
    assert s == _custom()
    assert s.robot.name == "my_robot"
    assert s.noise is None


def test_toml_minimal_file_gives_defaults():
    assert Scenario.from_dict(tomllib.loads('case = "adaptive"\n')) == Scenario()
    assert Scenario.from_dict({}) == Scenario()


@pytest.mark.parametrize("off", [False, "none", "off"])
def test_noise_can_be_switched_off_in_files_and_in_python_alike(off):
    assert Scenario.from_dict({"noise": off}).noise is None
    assert Scenario(noise=off) == Scenario(noise=None) == Scenario.paper(4, noise=off).replace(
        case="adaptive", name="")


@pytest.mark.parametrize("on", [True, "on", "yes", 0.01])
def test_noise_other_than_off_is_refused_naming_what_is_allowed(on):
    with pytest.raises(ValidationError, match=r"^noise must be None \(or \"off\"\), a NoiseSpec"):
        Scenario(noise=on)


# ---------------------------------------------------------------------------
# unknown fields
# ---------------------------------------------------------------------------

def test_unknown_field_suggests_the_right_one():
    with pytest.raises(ValidationError) as info:
        Scenario.from_dict({"kxx": 0.2})
    msg = str(info.value)
    assert "'kxx'" in msg and "did you mean 'kx'?" in msg


@pytest.mark.parametrize("how", ["from_dict", "replace", "paper", "Scenario"])
@pytest.mark.parametrize("bad, good", [("kxx", "kx"), ("adapt_form", "adapt_from"),
                                       ("theta_hat_0", "theta_hat0"), ("sigmma", "sigma")])
def test_misspelt_fields_raise_with_hint(how, bad, good):
    with pytest.raises(ValidationError) as info:
        if how == "from_dict":
            Scenario.from_dict({bad: 1.0})
        elif how == "replace":
            Scenario().replace(**{bad: 1.0})
        elif how == "paper":
            Scenario.paper(4, **{bad: 1.0})
        else:
            Scenario(case="compensated", **{bad: 1.0})
    msg = str(info.value)
    assert names_in(msg, bad) and f"did you mean {good!r}?" in msg, msg


def test_a_keyword_that_is_no_field_is_named_with_the_fields_in_one_line():
    with pytest.raises(ValidationError) as info:
        Scenario(case="compensated", tiem=10)
    msg = str(info.value)
    assert "\n" not in msg and "'tiem'" in msg
    listed = set(re.split(r",\s*", msg.split("known fields: ")[1]))
    assert listed == {f.name for f in dataclasses.fields(Scenario)}


def test_the_signature_is_short_and_shows_every_field_with_its_default():
    import inspect
    import pydoc
    sig = inspect.signature(Scenario)
    assert len(str(sig)) < 500, len(str(sig))
    assert list(sig.parameters) == [f.name for f in dataclasses.fields(Scenario)]
    from unidyn.model import scenario
    default = Scenario()
    for name, p in sig.parameters.items():
        text = repr(p.default)
        if text.isupper():  # a long default, by its name in unidyn.model.scenario
            value = getattr(scenario, text)
        elif text.endswith("()") and text != "()":  # made by a factory: its type
            assert type(getattr(default, name)).__name__ == text[:-2], (name, text)
            continue
        else:
            value = eval(text, {})
        assert Scenario(**{name: value}) == default, (name, text)
    assert max(map(len, pydoc.render_doc(Scenario, renderer=pydoc.plaintext).splitlines())) < 500


def test_unrelated_unknown_field_raises_without_hint():
    with pytest.raises(ValidationError) as info:
        Scenario.from_dict({"zzzzzz": 1})
    assert "zzzzzz" in str(info.value) and "did you mean" not in str(info.value)


@pytest.mark.parametrize("data, name", [
    ({"noise": {"position_stdd": 0.01}}, "position_stdd"),
    ({"limits": {"speed_maxx": 1.0}}, "speed_maxx"),
    ({"trajectory": {"type": "circle", "raduis": 1.0}}, "raduis"),
    ({"trajectory": {"type": "spiral"}}, "trajectory"),
    ({"robot": {"theta1": 0.3}}, "theta2"),  # missing parameter
])
def test_unknown_nested_keys_raise(data, name):
    with pytest.raises(ValidationError) as info:
        Scenario.from_dict(data)
    assert names_in(str(info.value), name), str(info.value)


@pytest.mark.parametrize("data", [[1, 2], "adaptive", None, 3.0])
def test_from_dict_needs_a_table(data):
    with pytest.raises(ValidationError):
        Scenario.from_dict(data)


# ---------------------------------------------------------------------------
# every field rejects out-of-range values, naming the field
# ---------------------------------------------------------------------------

NAN, INF = float("nan"), float("inf")
BAD_VALUES = [
    ("case", "adaptve", "case"),
    ("case", 4, "case"),
    ("robot", "p3dx_lazer", "robot"),
    ("robot", [0.2, 0.2, 0.0], "robot"),
    ("robot", [-0.2, 0.2, 0.0, 1.0, 0.0, 1.0], "robot"),
    ("a", 0.0, "a"),
    ("a", -0.2, "a"),
    ("a", NAN, "a"),
    ("a", "0.2", "a"),
    ("x0", (0.0, 0.0), "x0"),
    ("x0", (NAN, 0.0, 0.0), "x0"),
    ("x0", "origin", "x0"),
    ("trajectory", {"type": "circle", "omega": 0.0}, "omega"),
    ("trajectory", {"type": "figure_eight", "wx": -0.5}, "wx"),
    ("trajectory", 42, "trajectory"),
    ("kx", 0.0, "kx"),
    ("kx", True, "kx"),
    ("ky", -0.1, "ky"),
    ("lx", NAN, "lx"),
    ("ly", INF, "ly"),
    ("ku", 0.0, "ku"),
    ("kw", -4.0, "kw"),
    ("lu", 0.0, "lu"),
    ("lw", NAN, "lw"),
    ("theta_hat0", "nobody", "theta_hat0"),
    ("theta_hat0", [0.1, 0.2], "theta_hat0"),
    ("gamma", (1.0,) * 5, "gamma"),
    ("gamma", (1.0, 1.0, 0.0, 1.0, 1.0, 1.0), "gamma"),
    ("gamma", (1.0, -1.0, 1.0, 1.0, 1.0, 1.0), "gamma"),
    ("sigma", (0.0, 0.0, -0.001, 0.0, 0.0, 0.0), "sigma"),
    ("sigma", (0.001,) * 7, "sigma"),
    ("sigma", (NAN,) * 6, "sigma"),
    ("adapt_from", -1.0, "adapt_from"),
    ("adapt_from", NAN, "adapt_from"),
    ("leakage", "sigma", "leakage"),
    ("noise", {"position_std": -0.01}, "position_std"),
    ("noise", {"velocity_std": NAN}, "velocity_std"),
    ("noise", {"seed": -1}, "seed"),
    ("noise", {"seed": 1.5}, "seed"),
    ("noise", "loud", "noise"),
    ("limits", {"speed_max": 0.0}, "speed_max"),
    ("limits", {"angular_accel_max": -1.0}, "angular_accel_max"),
    ("limits", 5, "limits"),
    ("T", 0.0, "T"),
    ("T", -200.0, "T"),
    ("Ts", 0.0, "Ts"),
    ("Ts", 300.0, "Ts"),  # longer than T
    ("control", "discrete", "control"),
    ("vd_dot", "numeric", "vd_dot"),
    ("tau", 0.0, "tau"),
    ("name", 5, "name"),
    ("log_every", 0, "log_every"),
    ("log_every", 1.5, "log_every"),
    ("log_every", True, "log_every"),
    ("log_every", 3, "log_every"),  # does not divide T/Ts = 2000
    ("log_dtype", "float16", "log_dtype"),
    ("log_dtype", 32, "log_dtype"),
    ("log_series", ("theta",), "log_series"),
    ("log_series", 3, "log_series"),
    ("log_series", [None], "log_series"),
    ("payload", [[30.0, 2.0], [10.0, 1.0]], "payload"),
    ("payload", [[30.0, 0.0]], "payload"),
    ("x0", (1e300, 0.0, 0.0), "x0"),
    ("x0", (0.0, 0.0, 1e300), "x0"),
]


def test_every_field_has_a_bad_value_case():
    assert {b[0] for b in BAD_VALUES} == set(FIELDS)


@pytest.mark.parametrize("how", ["constructor", "from_dict", "replace"])
@pytest.mark.parametrize("field, value, name", BAD_VALUES,
                         ids=[f"{f}={v!r}" for f, v, _ in BAD_VALUES])
def test_field_rejects_bad_value_naming_it(how, field, value, name):
    with pytest.raises(ValidationError) as info:
        if how == "constructor":
            Scenario(**{field: value})
        elif how == "from_dict":
            Scenario.from_dict({field: value})
        else:
            Scenario().replace(**{field: value})
    msg = str(info.value)
    assert names_in(msg, name), msg
    if name == "a":  # "a" is also an English word
        assert msg.startswith("a must"), msg


def test_limits_accept_infinity():
    # the dict form starts from no limits: only the keys given are set
    s = Scenario(limits={"speed_max": INF, "steer_max": 2.0})
    assert math.isinf(s.limits.speed_max) and s.limits.steer_max == 2.0
    assert math.isinf(s.limits.accel_max) and math.isinf(s.limits.angular_accel_max)


# ---------------------------------------------------------------------------
# control / vd_dot combinations
# ---------------------------------------------------------------------------

@pytest.mark.parametrize("control, vd_dot", [("continuous", "difference"), ("sampled", "filter")])
def test_incompatible_control_and_vd_dot_raise(control, vd_dot):
    with pytest.raises(ValidationError) as info:
        Scenario(control=control, vd_dot=vd_dot)
    msg = str(info.value)
    assert names_in(msg, "vd_dot") and control in msg, msg
    with pytest.raises(ValidationError):
        Scenario.from_dict({"control": control, "vd_dot": vd_dot})


def test_vd_dot_default_follows_control():
    assert Scenario(control="continuous").derivative == "analytic"
    assert Scenario(control="sampled").derivative == "difference"
    assert Scenario(control="continuous", vd_dot="filter").derivative == "filter"


ACCEPTED = [(case, control, vd_dot)
            for case in CASE_NAMES.values()
            for control in ("continuous", "sampled")
            for vd_dot in ("analytic", "filter", "difference")
            if (control, vd_dot) not in {("continuous", "difference"), ("sampled", "filter"),
                                         ("sampled", "analytic")}]


def test_sampled_control_with_the_analytic_derivative_is_rejected_up_front():
    # the sampled kinematic controller has no rate output
    with pytest.raises(ValidationError, match="vd_dot"):
        Scenario(control="sampled", vd_dot="analytic")


@pytest.mark.parametrize("case, control, vd_dot", ACCEPTED, ids=["-".join(c) for c in ACCEPTED])
def test_a_valid_scenario_can_be_wired(sim, case, control, vd_dot):
    """Whatever Scenario accepts, the Fig. 2 builder can wire (validation happens up front)."""
    from unidyn.diagrams import build_fig2
    s = Scenario(case=case, control=control, vd_dot=vd_dot, T=1.0)
    fig = build_fig2(sim, s)
    assert "robot" in fig.blocks


def test_switching_the_default_scenario_to_sampled_control_can_be_wired(sim):
    """vd_dot left unset follows the control mode, so replace(control=...) keeps working."""
    from unidyn.diagrams import build_fig2
    s = Scenario(T=1.0).replace(control="sampled")
    build_fig2(sim, s)


# ---------------------------------------------------------------------------
# immutability and replace()
# ---------------------------------------------------------------------------

@pytest.mark.parametrize("field", FIELDS)
def test_scenario_is_immutable(field):
    s = Scenario()
    with pytest.raises(dataclasses.FrozenInstanceError):
        setattr(s, field, getattr(s, field))
    with pytest.raises(dataclasses.FrozenInstanceError):
        delattr(s, field)


def test_nested_values_are_immutable_too():
    s = Scenario()
    with pytest.raises(TypeError):
        s.gamma[0] = 2.0  # a tuple
    with pytest.raises(TypeError):
        s.x0[0] = 1.0
    with pytest.raises(dataclasses.FrozenInstanceError):
        s.robot.theta1 = 1.0
    with pytest.raises(dataclasses.FrozenInstanceError):
        s.noise.position_std = 0.0
    with pytest.raises(dataclasses.FrozenInstanceError):
        s.limits.speed_max = 10.0
    with pytest.raises(ValueError):
        s.limits.speed[0] = 10.0  # read-only array
    s.robot.theta[0] = 99.0  # a fresh copy each time
    assert s.robot.theta1 == 0.2604
    assert hash(s) == hash(Scenario())  # usable as a key


def test_replace_returns_a_validated_copy():
    s = Scenario()
    r = s.replace(kx=0.5, case="compensated", noise={"position_std": 0.02, "velocity_std": 0.0,
                                                      "seed": 3})
    assert (r.kx, r.case) == (0.5, "compensated")
    assert r.noise == NoiseSpec(0.02, 0.0, 3)
    assert s == Scenario() and s.kx == 0.1  # the original is untouched
    np.testing.assert_array_equal(r.theta_hat_initial, P3DX_LASER)
    assert s.replace() == s
    with pytest.raises(ValidationError, match="kx"):
        s.replace(kx=-1.0)
    with pytest.raises(ValidationError, match="Ts"):
        s.replace(T=0.05)  # Ts = 0.1 > T
    with pytest.raises(ValidationError, match="vd_dot"):
        s.replace(vd_dot="difference")  # with continuous control


@pytest.mark.parametrize("T, Ts, lo, hi", [(1.05, 0.1, "1", "1.1"), (20.0, 0.3, "19.8", "20.1"),
                                           (0.25, 0.1, "0.2", "0.3")])
def test_T_must_be_a_whole_number_of_samples(T, Ts, lo, hi):
    with pytest.raises(ValidationError) as info:
        Scenario(T=T, Ts=Ts)
    msg = str(info.value)
    assert "T = " in msg and "Ts = " in msg, msg
    assert f"T = {lo} s" in msg and f"T = {hi} s" in msg, msg  # the nearest valid T


@pytest.mark.parametrize("T, Ts, n", [(0.3, 0.1, 3), (0.7, 0.1, 7), (20.0, 0.1, 200),
                                      (1.0, 1 / 3, 3), (2e5, 0.02, 10_000_000)])
def test_T_a_whole_number_of_samples_up_to_rounding_is_accepted(T, Ts, n):
    assert Scenario(T=T, Ts=Ts, log_every=10 if n > 1e6 else 1).steps == n


def test_long_runs_must_thin_their_log_to_fit_in_memory():
    with pytest.raises(ValidationError) as info:
        Scenario(T=1e6, Ts=0.1)  # 1e7 samples, all logged in float64: about 1.6 GB
    assert "log_every >= 2" in str(info.value)
    assert "log_dtype='float32'" in str(info.value)
    assert Scenario(T=1e6, Ts=0.1, log_every=2).steps == 10_000_000
    assert Scenario(T=1e6, Ts=0.1, log_dtype="float32").steps == 10_000_000
    with pytest.raises(ValidationError) as info:  # 2 does not divide 9999999: the next divisor
        Scenario(T=999999.9, Ts=0.1)
    assert "log_every >= 3 (a divisor of 9999999)" in str(info.value)
    assert Scenario(T=999999.9, Ts=0.1, log_every=3).steps == 9_999_999


def test_divergence_bounds_follow_the_limits_or_the_reference():
    from unidyn.model.unicycle import NO_LIMITS
    sc = Scenario()  # paper limits 0.75 m/s, 1.745 rad/s; figure eight of 1 m amplitude
    pos, u, w = sc.divergence_bounds()
    assert u == pytest.approx(0.75e6) and w == pytest.approx(1.745e6)
    # the figure eight reaches |h_d| = sqrt(1 + 4) m (x = +-1 when y = -2 is never
    # simultaneous; the sampled maximum lies between 2 and sqrt(5))
    assert 2e6 <= pos <= 5 ** 0.5 * 1e6
    free = sc.replace(limits=NO_LIMITS)
    _, u, w = free.divergence_bounds()
    # max |h_d'| = 0.5 m/s (x' = 0.5 cos(0.5 t)) plus the saturation l = 0.1 m/s,
    # floored at 1 m/s; the turn rate is that speed over a = 0.2 m
    assert u == pytest.approx(1e6) and w == pytest.approx(1.0 / 0.2 * 1e6)
    fast = free.replace(trajectory={"type": "circle", "radius": 10.0, "omega": 0.5})
    _, u, w = fast.divergence_bounds()
    assert u == pytest.approx(5.1e6, rel=1e-3) and w == pytest.approx(5.1e6 / 0.2, rel=1e-3)


@pytest.mark.parametrize("data, meant", [
    ({"kx_": 1.0}, "kx"),
    ({"trajectory": {"type": "circle", "raduis": 2.0}}, "radius"),
    ({"trajectory": {"type": "circel"}}, "circle"),
    ({"noise": {"positon_std": 0.1}}, "position_std"),
    ({"limits": {"speed_mx": 1.0}}, "speed_max"),
    ({"robot": {**robots.get("p3dx").as_dict(), "thetaa4": 1.0}}, "theta4"),
    ({"log_series": ["theta_hats"]}, "theta_hat"),
])
def test_a_misspelled_key_at_any_depth_is_named_with_the_one_meant(data, meant):
    with pytest.raises(ValidationError) as err:
        Scenario.from_dict(data)
    assert f"(did you mean {meant!r}?)" in str(err.value) and "\n" not in str(err.value)
