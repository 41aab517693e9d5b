"""Every parameter rejects invalid values with a ValidationError that names it (hypothesis).

Targets: every field of :class:`unidyn.Scenario` (through the constructor and
through ``Scenario.from_dict``), every constructor parameter of every unidyn
block, :class:`unidyn.RobotParameters` and its ``from_vector``, ``scaled`` and
``from_physical``. Each target gets random invalid values of its kind (wrong
types, NaN, inf, negative or zero where > 0 is required, vectors of the wrong
length, unknown names); the call must raise :class:`unidyn.ValidationError`,
never TypeError, AttributeError, KeyError, OverflowError or a numpy warning
(every call runs under ``warnings.simplefilter("error")``), and the message must
name the parameter.

Kinds of input that are easy to get past a validator have their own tests:
integers beyond the float range, complex arrays, numpy arrays for names and
flags, unhashable trajectory types, tables with non-string keys, values of the
wrong type inside vectors and tables.
"""

from __future__ import annotations

import math
import re
import string
import warnings
from dataclasses import dataclass
from functools import lru_cache

import numpy as np
import pytest
from hypothesis import HealthCheck, Phase, given, settings
from hypothesis import strategies as st

from unidyn import RobotParameters, ValidationError
from unidyn.model import robots
from unidyn.model.laws import LEAKAGE_FORMS
from unidyn.model.scenario import (
    ALWAYS_LOGGED,
    CASES,
    CONTROL_MODES,
    LOG_DTYPES,
    OPTIONAL_SERIES,
    VD_DOT_METHODS,
    Scenario,
)

pytestmark = pytest.mark.reliability

#: hypothesis examples per target and property (the README quotes these numbers)
MAX_EXAMPLES = {
    "invalid_values": 30,
    "huge_integers": 10,
    "complex_arrays": 10,
    "numpy_arrays_for_names_and_flags": 10,
    "unhashable_trajectory_type": 10,
    "tables_with_non_string_keys": 10,
    "robot_parameters_invalid": 60,
}
#: examples that ran to the end (passed) in this session, summed over targets
#: targets each property was run on


#: the kinds of input with known gaps fail at once; their tests skip shrinking
KNOWN_GAPS = set()


def _settings(name):
    phases = ((Phase.explicit, Phase.generate) if name in KNOWN_GAPS
              else (Phase.explicit, Phase.generate, Phase.shrink))
    return settings(max_examples=MAX_EXAMPLES[name], deadline=None, derandomize=True,
                    database=None, phases=phases,
                    suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much])


# ------------------------------------------------------------------ invalid values

THETAS = ("theta1", "theta2", "theta3", "theta4", "theta5", "theta6")
VALID_THETA = (0.26, 0.25, -0.0005, 1.0, 0.0026, 1.08)
NAMES = tuple(robots.names())

finite = st.floats(allow_nan=False, allow_infinity=False)
small_ints = st.integers(-2**63, 2**63 - 1)
words = st.sampled_from(["", "abc", "x", "None", "robot", "one", "{}", "[]"])
texts = st.one_of(st.text(max_size=12), words)
not_a_number = st.one_of(
    st.none(), st.booleans(), texts, st.binary(max_size=4),
    st.lists(finite, max_size=3), st.lists(texts, min_size=1, max_size=2),
    st.dictionaries(st.text(max_size=4), small_ints, max_size=2),
    st.complex_numbers(allow_nan=False, allow_infinity=False).filter(lambda z: z.imag != 0),
    st.builds(object), st.tuples(), st.just(np.array([1.0, 2.0])),
    st.just(np.array(["a"])))
nan = st.one_of(st.just(math.nan), st.just(np.float64("nan")), st.just(-math.nan))
inf = st.sampled_from([math.inf, np.float64("inf")])
neg_inf = st.sampled_from([-math.inf, np.float64("-inf")])
negative = st.one_of(st.floats(max_value=-5e-324, allow_nan=False, allow_infinity=False),
                     st.integers(-2**63, -1), st.floats(-1e3, -1e-9).map(np.float64),
                     st.integers(-1000, -1).map(np.int64))
zero = st.sampled_from([0, 0.0, -0.0, np.float64(0.0), np.int64(0)])


def _is_num(s):
    try:
        float(s)
        return True
    except ValueError:
        return False


#: strings that are not numbers (numeric strings are a separate, known gap)
non_numeric_text = st.one_of(
    words.filter(lambda s: s != ""),
    st.text(alphabet=string.ascii_letters + " _-", min_size=1, max_size=8).filter(
        lambda s: not _is_num(s)))


def bad_vectors(lengths, element_ok=None):
    """Values that are not a finite vector of one of ``lengths``."""
    n = lengths[0]
    wrong_length = st.integers(0, 8).filter(lambda k: k not in lengths).flatmap(
        lambda k: st.lists(st.floats(-10, 10), min_size=k, max_size=k))
    bad_entry = st.one_of(nan, inf, neg_inf, st.none(), non_numeric_text,
                          st.dictionaries(st.text(max_size=2), small_ints, min_size=1,
                                          max_size=1), st.lists(finite, min_size=2, max_size=2))

    @st.composite
    def with_bad_entry(draw):
        v = draw(st.lists(st.floats(-10, 10), min_size=n, max_size=n))
        v[draw(st.integers(0, n - 1))] = draw(bad_entry)
        return v

    nested = st.lists(st.floats(-10, 10), min_size=n, max_size=n).map(lambda v: [v, v])
    options = [st.none(), st.booleans(), texts, st.binary(max_size=4),
               st.dictionaries(st.text(max_size=4), small_ints, max_size=3), finite,
               wrong_length, with_bad_entry(), nested, st.builds(object),
               wrong_length.map(np.array), nested.map(np.array)]
    if element_ok is not None:
        @st.composite
        def with_out_of_range(draw):
            v = draw(st.lists(st.floats(-10, 10), min_size=n, max_size=n))
            v[draw(st.integers(0, n - 1))] = draw(element_ok)
            return v
        options.append(with_out_of_range())
    return st.one_of(*options)


def bad_choice(allowed, none_ok=False):
    near = st.sampled_from(allowed).flatmap(lambda a: st.sampled_from(
        [a.upper(), a.title(), f" {a}", f"{a} ", a[:-1], f"{a}x", a.replace("_", "-")]))
    options = [texts, near, small_ints, finite, st.booleans(), st.lists(texts, max_size=2),
               st.dictionaries(st.text(max_size=3), small_ints, max_size=2), st.builds(object)]
    if not none_ok:
        options.append(st.none())
    return st.one_of(*options).filter(lambda v: not (isinstance(v, str) and v in allowed))


bad_flag = st.one_of(texts, st.none(), st.lists(st.booleans(), max_size=2),
                     st.dictionaries(st.text(max_size=3), st.booleans(), max_size=2),
                     small_ints.filter(lambda i: i not in (0, 1)),
                     finite.filter(lambda x: x not in (0.0, 1.0)), st.builds(object))


def _theta_table(**changes):
    return {**dict(zip(THETAS, VALID_THETA)), **changes}


def bad_robot(none_ok=False):
    unknown = texts.filter(lambda s: s not in NAMES and not s.endswith(".json"))
    near = st.sampled_from(NAMES).map(str.upper)
    missing_json = texts.map(lambda s: f"/nonexistent-unidyn-dir/{s}.json")
    missing_key = st.sampled_from(THETAS).map(lambda k: {t: v for t, v in
                                                         zip(THETAS, VALID_THETA) if t != k})

    @st.composite
    def bad_six(draw):
        v = list(VALID_THETA)
        i = draw(st.integers(0, 5))
        if i in (0, 1, 3, 5):
            v[i] = draw(st.one_of(zero, negative, nan, inf))
        else:
            v[i] = draw(st.one_of(nan, inf, neg_inf))
        return v

    options = [unknown, near, missing_json, missing_key, bad_six(),
               bad_vectors((6,)), small_ints, st.booleans(), st.builds(object)]
    if not none_ok:
        return st.one_of(*options, st.none())
    return st.one_of(*options).filter(lambda v: v is not None)


def bad_trajectory():
    kinds = ("figure_eight", "circle", "line")
    unknown_type = texts.filter(lambda s: s not in kinds)
    field_of = {"figure_eight": ("ax", "ay", "wx", "wy"), "circle": ("radius",),
                "line": ("start", "velocity")}

    @st.composite
    def bad_parameter(draw):
        kind = draw(st.sampled_from(kinds))
        key = draw(st.sampled_from(field_of[kind]))
        if kind == "line":
            value = draw(bad_vectors((2,)))
        else:
            value = draw(st.one_of(zero, negative, nan, inf, not_a_number))
        return {"type": kind, key: value}

    unknown_key = st.tuples(st.sampled_from(kinds), st.text(min_size=1, max_size=6)).filter(
        lambda p: p[1] not in ("type", "ax", "ay", "wx", "wy", "center", "radius", "omega",
                               "phase", "start", "velocity")).map(
        lambda p: {"type": p[0], p[1]: 1.0})
    return st.one_of(
        unknown_type, unknown_type.map(lambda s: {"type": s}),
        st.dictionaries(st.sampled_from(["radius", "omega", "ax", "start"]), finite, max_size=2),
        bad_parameter(), unknown_key, st.just({"type": "circle", "omega": 0.0}),
        small_ints, finite, st.booleans(), st.none(), st.lists(finite, max_size=3),
        st.builds(object))


def bad_noise():
    off = ("none", "off")  # and False: noise-free, in Python as in files
    table = st.one_of(
        st.fixed_dictionaries({"position_std": st.one_of(negative, nan, inf, not_a_number)}),
        st.fixed_dictionaries({"velocity_std": st.one_of(negative, nan, inf, not_a_number)}),
        st.fixed_dictionaries({"seed": st.one_of(
            st.integers(-2**63, -1), finite, st.booleans(), texts, st.none())}),
        st.text(min_size=1, max_size=8).filter(
            lambda k: k not in ("position_std", "velocity_std", "seed")).map(lambda k: {k: 1}))
    return st.one_of(table, texts.filter(lambda s: s not in off), small_ints, finite,
                     st.just(True), st.lists(finite, max_size=3), st.builds(object))


LIMIT_KEYS = ("speed_max", "steer_max", "accel_max", "angular_accel_max")


def bad_limits_table():
    table = st.one_of(
        st.tuples(st.sampled_from(LIMIT_KEYS),
                  st.one_of(zero, negative, neg_inf, nan,  # None (null) is "no limit"
                            not_a_number.filter(lambda v: v is not None))).map(
            lambda p: {p[0]: p[1]}),
        st.text(min_size=1, max_size=8).filter(lambda k: k not in LIMIT_KEYS).map(
            lambda k: {k: 1.0}))
    return st.one_of(table, texts, small_ints, finite, st.booleans(), st.none(),
                     st.lists(finite, max_size=4), st.builds(object))


bad_limits_object = st.one_of(texts, small_ints, finite, st.booleans(),
                              st.lists(finite, max_size=4), st.builds(object),
                              st.dictionaries(st.sampled_from(LIMIT_KEYS), finite, max_size=2))
bad_name = st.one_of(small_ints, finite, st.booleans(), st.none(), st.lists(texts, max_size=2),
                     st.dictionaries(st.text(max_size=3), texts, max_size=2), st.binary(max_size=3))
bad_seed = st.one_of(st.integers(-2**63, -1), finite, st.booleans(), texts, st.none(),
                     st.lists(small_ints, max_size=2), st.just(np.float64(1.0)))
bad_indices = st.one_of(
    st.just([]), st.just(()), st.lists(st.integers(-2**63, -1), min_size=1, max_size=3),
    st.integers(0, 5).map(lambda i: [i, i]), st.none(), small_ints,
    st.lists(non_numeric_text, min_size=1, max_size=2), st.lists(st.none(), min_size=1, max_size=2),
    st.lists(nan, min_size=1, max_size=1), st.builds(object))
bad_callable = st.one_of(texts, small_ints, finite, st.booleans(), st.lists(finite, max_size=2),
                         st.dictionaries(st.text(max_size=3), small_ints, max_size=2))

#: invalid values by kind of parameter
INVALID = {
    "positive": st.one_of(not_a_number, zero, negative, neg_inf, nan, inf),
    "positive_or_none": st.one_of(not_a_number.filter(lambda v: v is not None), zero, negative,
                                  neg_inf, nan, inf),
    # a limit: inf, or None (JSON's null), is "no limit"
    "positive_or_inf": st.one_of(not_a_number.filter(lambda v: v is not None), zero, negative,
                                 neg_inf, nan),
    "positive_int": st.one_of(not_a_number, zero, negative, neg_inf, nan, inf,
                              st.just(1.5), st.just(True)),
    "nonnegative": st.one_of(not_a_number, negative, neg_inf, nan, inf),
    "real": st.one_of(not_a_number, nan, inf, neg_inf),
    "nonzero_real": st.one_of(not_a_number, nan, inf, neg_inf, zero),
    "vector2": bad_vectors((2,)),
    "vector3": bad_vectors((3,)),
    "vector3or5_or_none": bad_vectors((3, 5)).filter(lambda v: v is not None),
    "positive_vector6": bad_vectors((6,), st.one_of(zero, negative)),
    "nonnegative_vector6": bad_vectors((6,), negative),
    "case": bad_choice(CASES),
    "control": bad_choice(CONTROL_MODES),
    "leakage": bad_choice(LEAKAGE_FORMS),
    "log_dtype": bad_choice(LOG_DTYPES),
    "log_series": st.one_of(
        # a string is a comma-separated list of names: one unknown name in it
        st.text(max_size=8).filter(lambda v: any(
            x.strip() and x.strip() not in OPTIONAL_SERIES + ALWAYS_LOGGED for x in v.split(","))),
        st.lists(st.text(max_size=8), min_size=1, max_size=3).filter(
            lambda v: any(x not in OPTIONAL_SERIES + ALWAYS_LOGGED for x in v)),
        st.lists(st.one_of(small_ints, finite, st.none(), st.booleans()), min_size=1,
                 max_size=2),
        small_ints, finite, st.booleans(), st.none(), st.builds(object),
        st.dictionaries(st.sampled_from(OPTIONAL_SERIES), st.booleans(), max_size=2)),
    # a payload schedule: junk, a bad number, a row of another shape, a bad time or mass
    # in one row, times that do not increase, more rows than the engines hold
    "payload": st.one_of(
        texts, st.booleans(), st.builds(object), st.dictionaries(texts, finite, max_size=2),
        zero, negative, nan, inf, neg_inf,
        st.lists(st.lists(finite, max_size=3).filter(lambda r: len(r) != 2), min_size=1,
                 max_size=3),
        st.tuples(st.one_of(negative, nan, inf, not_a_number.filter(lambda v: v is not None)),
                  st.just(2.0)).map(lambda r: [[1.0, 1.5], list(r)]),
        st.tuples(st.just(5.0), st.one_of(zero, negative, nan, inf, neg_inf)).map(
            lambda r: [list(r)]),
        st.floats(0.0, 5.0).map(lambda t: [[5.0, 2.0], [t, 1.0]]),
        st.integers(9, 20).map(lambda n: [[float(k), 1.5] for k in range(n)])),
    "vd_dot": st.one_of(bad_choice(VD_DOT_METHODS, none_ok=True), st.just("difference")),
    "vd_dot_continuous": bad_choice(("input", "filter")),
    "vd_dot_sampled": bad_choice(("input", "difference")),
    "flag": bad_flag,
    "robot": bad_robot(),
    "robot_or_none": bad_robot(none_ok=True),
    "robot_or_none_from_dict": bad_robot(none_ok=True).filter(
        lambda v: not (isinstance(v, str) and v in ("default", ""))),
    "trajectory": bad_trajectory(),
    "noise": bad_noise(),
    "noise_from_dict": bad_noise(),
    "limits_table": bad_limits_table(),
    "limits_object": bad_limits_object,
    "name": bad_name,
    "seed": bad_seed,
    "indices": bad_indices,
    "callable": bad_callable,
    "clock": st.one_of(st.none(), texts, small_ints, finite, st.lists(finite, max_size=2),
                       st.builds(object)),
}


# ------------------------------------------------------------------------- targets

@lru_cache(maxsize=None)
def _diagram():
    from unidyn.diagrams import new_simulator
    sim = new_simulator()
    bd = sim.blockdiagram()
    return bd, bd.clock(0.1, offset=0.0, name="reliability")


@dataclass(frozen=True)
class Target:
    """One parameter of one constructor: ``build(value)`` calls it with that value."""

    id: str
    param: str
    kind: str
    build: object
    names: tuple = ()

    @property
    def message_names(self):
        return self.names or (self.param,)


#: every Scenario field, with its kind
SCENARIO_FIELDS = {"case": "case", "robot": "robot", "a": "positive", "x0": "vector3",
                   "trajectory": "trajectory", "theta_hat0": "robot_or_none",
                   "gamma": "positive_vector6", "sigma": "nonnegative_vector6",
                   "adapt_from": "nonnegative", "leakage": "leakage", "noise": "noise",
                   "limits": "limits_table", "control": "control", "vd_dot": "vd_dot",
                   "name": "name", "log_every": "positive_int", "log_dtype": "log_dtype",
                   "log_series": "log_series", "payload": "payload",
                   **{k: "positive" for k in ("kx", "ky", "lx", "ly", "ku", "kw", "lu", "lw",
                                              "T", "Ts", "tau")}}


def test_scenario_field_table_is_complete():
    import dataclasses
    assert sorted(SCENARIO_FIELDS) == sorted(f.name for f in dataclasses.fields(Scenario))


def _scenario_targets():
    out = []
    for field, kind in SCENARIO_FIELDS.items():
        names = LIMIT_KEYS + ("limits",) if field == "limits" else ()
        out.append(Target(f"Scenario.{field}", field, kind,
                          lambda v, f=field: Scenario(**{f: v}), names))
        dict_kind = {"noise": "noise_from_dict",
                     "theta_hat0": "robot_or_none_from_dict"}.get(field, kind)
        out.append(Target(f"Scenario.from_dict.{field}", field, dict_kind,
                          lambda v, f=field: Scenario.from_dict({f: v}), names))
    return out


def _block(cls_name, **fixed):
    def build(param, value):
        from unidyn.blocks import controllers, sources
        from unidyn.blocks import unicycles as robot_blocks
        cls = (getattr(robot_blocks, cls_name, None) or getattr(controllers, cls_name, None)
               or getattr(sources, cls_name))
        bd, clock = _diagram()
        args = dict(fixed)
        if "clock" in args:
            args["clock"] = clock
        args[param] = value
        return cls(**args, bd=bd)
    return build


#: every constructor parameter of every block, with its kind
BLOCK_PARAMETERS = {
    "DynamicUnicycle": ({}, {"robot": "robot", "a": "nonnegative", "x0": "vector3or5_or_none",
                             "speed_max": "positive_or_inf", "accel_max": "positive_or_inf",
                             "steer_max": "positive_or_inf",
                             "angular_accel_max": "positive_or_inf",
                             "limits": "limits_object", "disturbance": "flag",
                             "velocity_output": "flag", "w": "positive_or_none",
                             "payload": "payload"}),
    "KinematicUnicycle": ({}, {"a": "nonnegative", "x0": "vector3or5_or_none",
                               "speed_max": "positive_or_inf", "steer_max": "positive_or_inf",
                               "limits": "limits_object"}),
    "KinematicController": ({}, {"a": "positive", "kx": "positive", "ky": "positive",
                                 "lx": "positive", "ly": "positive", "rate": "flag"}),
    "SampledKinematicController": ({"clock": None}, {
        "clock": "clock", "a": "positive", "kx": "positive", "ky": "positive",
        "lx": "positive", "ly": "positive", "v_d0": "vector2"}),
    "DynamicCompensator": ({}, {
        "theta_hat0": "robot", "ku": "positive", "kw": "positive", "lu": "positive",
        "lw": "positive", "adaptive": "flag", "gamma": "positive_vector6",
        "sigma": "nonnegative_vector6", "adapt_from": "nonnegative", "leakage": "leakage",
        "vd_dot": "vd_dot_continuous", "tau": "positive"}),
    "SampledDynamicCompensator": ({"clock": None}, {
        "clock": "clock", "theta_hat0": "robot", "ku": "positive", "kw": "positive",
        "lu": "positive", "lw": "positive", "adaptive": "flag", "gamma": "positive_vector6",
        "sigma": "nonnegative_vector6", "adapt_from": "nonnegative", "leakage": "leakage",
        "vd_dot": "vd_dot_sampled"}),
    "FigureEight": ({}, {"ax": "positive", "ay": "positive", "wx": "positive",
                         "wy": "positive", "center": "vector2"}),
    "Circle": ({}, {"radius": "positive", "omega": "nonzero_real", "center": "vector2",
                    "phase": "real"}),
    "Line": ({}, {"start": "vector2", "velocity": "vector2"}),
    "TrajectorySource": ({"trajectory": {"type": "circle"}}, {
        "trajectory": "trajectory", "acceleration": "callable"}),
    "MeasurementNoise": ({"clock": None}, {"clock": "clock", "std": "nonnegative",
                                           "seed": "seed", "indices": "indices"}),
}


def _block_targets():
    out = []
    for cls_name, (fixed, params) in BLOCK_PARAMETERS.items():
        fixed = dict(fixed)
        for param, kind in params.items():
            base = dict(fixed)
            if cls_name == "TrajectorySource" and param == "acceleration":
                # acceleration applies to a callable trajectory
                base["trajectory"] = lambda t: ((0.0, 0.0), (0.0, 0.0))
            build = _block(cls_name, **base)
            out.append(Target(f"{cls_name}.{param}", param, kind,
                              lambda v, b=build, p=param: b(p, v)))
    return out


def test_block_parameter_table_is_complete():
    """BLOCK_PARAMETERS lists every explicit constructor parameter of every block."""
    import inspect

    from unidyn.blocks import controllers, sources
    from unidyn.blocks import unicycles as robot_blocks
    for cls_name, (_, params) in BLOCK_PARAMETERS.items():
        cls = (getattr(robot_blocks, cls_name, None) or getattr(controllers, cls_name, None)
               or getattr(sources, cls_name))
        sig = inspect.signature(cls.__init__)
        declared = [p for p, v in sig.parameters.items()
                    if p != "self" and v.kind is not inspect.Parameter.VAR_KEYWORD]
        assert sorted(declared) == sorted(params), cls_name


ALL_TARGETS = _scenario_targets() + _block_targets()
BY_ID = {t.id: t for t in ALL_TARGETS}


# -------------------------------------------------------------------------- checks

_FOLLOW = r"(?= must| type|:|=|\.| is| cannot|\[)"


def _names_any(message, names):
    return any(re.search(rf"(?<![\w.]){re.escape(n)}{_FOLLOW}", message) for n in names)


def _rejects(target: Target, value):
    """``target.build(value)`` raises ValidationError naming the parameter (no warning)."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        try:
            target.build(value)
        except ValidationError as err:
            message = str(err)
        else:
            pytest.fail(f"{target.id} accepted the invalid value {value!r}")
    assert _names_any(message, target.message_names), (
        f"{target.id}: the message does not name {target.param!r}: {message}")


FAILED = pytest.fail.Exception  # what _rejects raises for an accepted value


def _param(target_ids, known: dict, raises=None):
    """pytest params over target ids, strict xfail where ``known`` gives a reason;
    ``raises``: the exception the gap shows (a type, or a dict by target id)."""
    out = []
    for tid in target_ids:
        marks = []
        if tid in known:
            exc = raises.get(tid) if isinstance(raises, dict) else raises
            marks = [pytest.mark.xfail(strict=True, reason=known[tid], raises=exc)]
        out.append(pytest.param(BY_ID[tid], id=tid, marks=marks))
    return out


@pytest.mark.parametrize("target", _param([t.id for t in ALL_TARGETS], {}))
def test_invalid_values_raise_validation_error(target):
    @_settings("invalid_values")
    @given(value=INVALID[target.kind])
    def check(value):
        _rejects(target, value)

    check()


# ------------------------------------------------------- known gaps, one kind each

NUMERIC_KINDS = ("positive", "positive_or_none", "positive_or_inf", "nonnegative", "real",
                 "nonzero_real")
VECTOR_KINDS = {"vector2": 2, "vector3": 3, "vector3or5_or_none": 3, "positive_vector6": 6,
                "nonnegative_vector6": 6, "robot": 6, "robot_or_none": 6,
                "robot_or_none_from_dict": 6}

huge_int = st.one_of(st.integers(min_value=2**1024, max_value=2**1100),
                     st.integers(min_value=-2**1100, max_value=-2**1024))

_HUGE_TARGETS = [t.id for t in ALL_TARGETS if t.kind in NUMERIC_KINDS or t.kind in VECTOR_KINDS]


@pytest.mark.parametrize("target", _param(_HUGE_TARGETS, {}))
def test_integers_beyond_the_float_range_raise_validation_error(target):
    @_settings("huge_integers")
    @given(data=st.data())
    def check(data):
        big = data.draw(huge_int)
        if target.kind in VECTOR_KINDS:
            n = VECTOR_KINDS[target.kind]
            value = [VALID_THETA[i] if n == 6 else 0.5 for i in range(n)]
            value[data.draw(st.integers(0, n - 1))] = big
        else:
            value = big
        _rejects(target, value)

    check()


_COMPLEX_TARGETS = [t.id for t in ALL_TARGETS if t.kind in VECTOR_KINDS]


@pytest.mark.parametrize("target", _param(_COMPLEX_TARGETS, {}))
def test_complex_arrays_raise_validation_error(target):
    @_settings("complex_arrays")
    @given(data=st.data())
    def check(data):
        n = VECTOR_KINDS[target.kind]
        re_ = data.draw(st.lists(st.floats(0.1, 10), min_size=n, max_size=n))
        im = data.draw(st.lists(st.floats(0.1, 10), min_size=n, max_size=n))
        _rejects(target, np.array(re_) + 1j * np.array(im))

    check()


_CHOICE_TARGETS = [t.id for t in ALL_TARGETS
                   if t.kind in ("case", "control", "leakage", "log_dtype", "vd_dot", "vd_dot_continuous",
                                 "vd_dot_sampled", "flag")
                   or t.id in ("Scenario.from_dict.noise", "Scenario.from_dict.theta_hat0")]


@pytest.mark.parametrize("target", _param(_CHOICE_TARGETS, {}))
def test_numpy_arrays_for_names_and_flags_raise_validation_error(target):
    @_settings("numpy_arrays_for_names_and_flags")
    @given(value=st.one_of(
        st.lists(st.sampled_from(["paper", "adaptive", "none", "input", "x"]), min_size=0,
                 max_size=3).map(np.array),
        st.lists(st.booleans(), min_size=0, max_size=3).map(np.array)))
    def check(value):
        _rejects(target, value)

    check()


_TRAJ_TARGETS = ["Scenario.trajectory", "Scenario.from_dict.trajectory",
                 "TrajectorySource.trajectory"]


@pytest.mark.parametrize("target", _param(_TRAJ_TARGETS, {}))
def test_unhashable_trajectory_types_raise_validation_error(target):
    @_settings("unhashable_trajectory_type")
    @given(kind=st.one_of(st.lists(st.sampled_from(["circle", "line"]), max_size=2),
                          st.dictionaries(st.text(max_size=3), small_ints, max_size=2)))
    def check(kind):
        _rejects(target, {"type": kind})

    check()


_TABLE_TARGETS = ["Scenario.noise", "Scenario.limits", "Scenario.trajectory",
                  "Scenario.from_dict.noise", "Scenario.from_dict.limits",
                  "Scenario.from_dict.trajectory", "TrajectorySource.trajectory"]


@pytest.mark.parametrize("target", _param(_TABLE_TARGETS, {}))
def test_tables_with_non_string_keys_raise_validation_error(target):
    @_settings("tables_with_non_string_keys")
    @given(ints=st.lists(small_ints, min_size=1, max_size=2, unique=True),
           strs=st.lists(st.text(alphabet="qz", min_size=1, max_size=3), min_size=1,
                         max_size=2, unique=True))
    def check(ints, strs):
        table = {**{i: 1.0 for i in ints}, **{s: 1.0 for s in strs}}
        if "trajectory" in target.id:
            table["type"] = "circle"
        _rejects(target, table)

    check()


@pytest.mark.parametrize("data", [{1: 2}, {1: 2, "zz": 3}, {None: 1}], ids=repr)
def test_scenario_from_dict_with_non_string_field_names_raises_validation_error(data):
    with pytest.raises(ValidationError, match="field"):
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            Scenario.from_dict(data)


def test_misspelt_block_keywords_fail_loudly():
    """A misspelt keyword is not swallowed by **blockargs (bdsim raises ValueError)."""
    from unidyn.blocks.controllers import DynamicCompensator, KinematicController
    from unidyn.blocks.unicycles import DynamicUnicycle
    bd, _ = _diagram()
    for cls, kw in ((DynamicUnicycle, "speedmax"), (KinematicController, "kxx"),
                    (DynamicCompensator, "gama")):
        with pytest.raises((ValueError, TypeError), match=kw):
            cls(**{kw: 1.0}, bd=bd)


# --------------------------------------------------- values accepted that should not be

SILENTLY_ACCEPTED = [
    ("Scenario.x0", ["1", "2", "3"],
     "numeric strings inside a vector are converted by np.asarray(dtype=float)"),
    ("Scenario.x0", [True, False, True], "booleans inside a vector are taken as 1.0 / 0.0"),
    ("Scenario.gamma", [True] * 6, "booleans inside a vector are taken as 1.0"),
    ("FigureEight.center", ["0", "1"], "numeric strings inside a vector are converted"),
    ("Scenario.robot", _theta_table(theta7=1.0),
     "unknown keys of a robot table are ignored (robots.resolve picks theta1..theta6)"),
    ("DynamicUnicycle.robot", _theta_table(thetta1=1.0),
     "unknown keys of a robot table are ignored (robots.resolve picks theta1..theta6)"),
    ("MeasurementNoise.indices", "01", "a string is iterated: indices '01' -> (0, 1)"),
    ("MeasurementNoise.indices", [1.5], "non-integers are truncated by int(): [1.5] -> [1]"),
    ("MeasurementNoise.indices", [True], "booleans are taken as integers"),
]


@pytest.mark.parametrize("target_id, value, reason", [
    pytest.param(t, v, r, id=f"{t}={v!r}"[:60]) for t, v, r in SILENTLY_ACCEPTED])
def test_values_of_the_wrong_type_are_not_silently_accepted(target_id, value, reason):
    _rejects(BY_ID[target_id], value)


def test_trajectory_source_rejects_an_acceleration_it_would_ignore():
    _rejects(Target("TrajectorySource.acceleration", "acceleration", "callable",
                    lambda v: _block("TrajectorySource", trajectory={"type": "circle"})(
                        "acceleration", v)), "not callable")


def test_robot_parameters_source_must_be_a_string():
    with pytest.raises(ValidationError, match="source"):
        RobotParameters(*VALID_THETA, source=5)




@pytest.mark.parametrize("target_id", [
    t for t in ("Scenario.robot", "Scenario.theta_hat0", "Scenario.from_dict.robot",
              "DynamicUnicycle.robot", "DynamicCompensator.theta_hat0",
              "SampledDynamicCompensator.theta_hat0")])
def test_robot_tables_with_an_invalid_theta_name_the_field(target_id):
    _rejects(BY_ID[target_id], _theta_table(theta1=-1.0))


# ----------------------------------------------------------------- RobotParameters

PHYSICAL = dict(m=30.0, Iz=1.0, Ra=1.0, ka=0.05, kb=0.05, Be=0.01, Ie=0.001, r=0.1, b=0.02,
                d=0.33, kPT=100.0, kPR=100.0, kDT=0.0, kDR=0.0)
PHYSICAL_KINDS = dict(m="positive", Iz="nonnegative", Ra="positive", ka="positive",
                      kb="nonnegative", Be="nonnegative", Ie="nonnegative", r="positive",
                      b="real", d="positive", kPT="positive", kPR="positive",
                      kDT="nonnegative", kDR="nonnegative")


def _robot_targets():
    out = []
    for k in THETAS:
        kind = "positive" if k in ("theta1", "theta2", "theta4", "theta6") else "real"
        out.append(Target(f"RobotParameters.{k}", k, kind, lambda v, k=k: RobotParameters(
            **{**dict(zip(THETAS, VALID_THETA)), k: v})))
    out.append(Target("RobotParameters.name", "name", "name",
                      lambda v: RobotParameters(*VALID_THETA, name=v)))
    out.append(Target("RobotParameters.from_vector.theta", "theta", "robot_vector",
                      lambda v: RobotParameters.from_vector(v)))
    out.append(Target("RobotParameters.from_vector.name", "name", "name",
                      lambda v: RobotParameters.from_vector(VALID_THETA, name=v)))
    out.append(Target("RobotParameters.scaled.factor", "factor", "positive",
                      lambda v: RobotParameters(*VALID_THETA).scaled(v)))
    for k, kind in PHYSICAL_KINDS.items():
        out.append(Target(f"RobotParameters.from_physical.{k}", k, kind,
                          lambda v, k=k: RobotParameters.from_physical(**{**PHYSICAL, k: v})))
    out.append(Target("RobotParameters.from_physical.name", "name", "name",
                      lambda v: RobotParameters.from_physical(**PHYSICAL, name=v)))
    return out


INVALID["robot_vector"] = bad_vectors((6,))
ROBOT_TARGETS = _robot_targets()
BY_ID.update({t.id: t for t in ROBOT_TARGETS})


@pytest.mark.parametrize("target", [pytest.param(t, id=t.id) for t in ROBOT_TARGETS])
def test_robot_parameters_reject_invalid_values(target):
    @_settings("robot_parameters_invalid")
    @given(value=INVALID[target.kind])
    def check(value):
        _rejects(target, value)

    check()


_RP_HUGE = [t.id for t in ROBOT_TARGETS if t.kind in NUMERIC_KINDS]


@pytest.mark.parametrize("target", _param(_RP_HUGE, {}))
def test_robot_parameters_reject_integers_beyond_the_float_range(target):
    @_settings("huge_integers")
    @given(value=huge_int)
    def check(value):
        _rejects(target, value)

    check()


def test_from_physical_rejects_parameters_that_give_an_invalid_theta():
    """Valid-looking physical inputs whose theta is not a robot (no rotational inertia,
    or an overflow) raise ValidationError, not a silently broken model."""
    with pytest.raises(ValidationError, match="theta2"):
        RobotParameters.from_physical(**{**PHYSICAL, "Iz": 0.0, "Ie": 0.0, "b": 0.0})
    with pytest.raises(ValidationError, match="theta1"):
        RobotParameters.from_physical(**{**PHYSICAL, "m": 1e300, "Ra": 1e300, "ka": 1e-300})
