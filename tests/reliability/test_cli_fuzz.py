"""Malformed scenario and sweep files never crash the command line (hypothesis).

``unidyn run FILE --out DIR --T 0.5 --engine batch`` and ``unidyn sweep FILE --out DIR
--T 0.5`` are called in-process (``unidyn.cli.main``) on random bytes, random
text, valid TOML with random keys and values, wrong types per field, nested
tables and extreme numbers. Whatever the file, ``main`` returns (no exception
escapes it: that would be a traceback), the exit status is 0 (valid), 2 (invalid
input, one ``unidyn: error:`` line) or 1 (a valid run that stopped early, with its
``unidyn: warning:`` line), and stderr holds no traceback.

Random numbers stay within 1e-3..1e3 in magnitude (plus 0, NaN and infinities):
larger *valid* values are legal and only make a run longer (the batch engine
refines its step with the fastest rate of the loop), so extreme numbers are
tested with fixed files instead (``test_extreme_numbers_*``), and so are huge strings
(``test_long_strings_*``: a 3 MB name, 1 MB values, 100 kB keys), which must be refused
before anything is written, on one short line that names the key.
"""

from __future__ import annotations

import datetime as dt
import itertools
import math
import re

import pytest
import tomllib
from hypothesis import HealthCheck, Phase, event, given, settings
from hypothesis import strategies as st

from unidyn.cli import main
from unidyn.model import robots
from unidyn.model.scenario import CASES, Scenario
from unidyn.sweeps.sweep_files import SPECIAL_KEYS

pytestmark = pytest.mark.reliability

#: hypothesis examples per property (the README quotes these numbers)
MAX_EXAMPLES = {
    "run_random_bytes": 30,
    "run_random_text": 30,
    "run_random_tables": 50,
    "run_wrong_types_per_field": 60,
    "run_nested_tables": 20,
    "sweep_random_bytes": 15,
    "sweep_random_text": 15,
    "sweep_random_files": 50,
}
#: examples that ran to the end (passed), and how they ended: exit status -> count


def _settings(name):
    return settings(max_examples=MAX_EXAMPLES[name], deadline=None, derandomize=True,
                    database=None, phases=(Phase.explicit, Phase.generate, Phase.shrink),
                    suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much,
                                           HealthCheck.function_scoped_fixture,
                                           HealthCheck.data_too_large])


FIELDS = sorted(f for f in Scenario.__dataclass_fields__)
_counter = itertools.count()


# ----------------------------------------------------------------------- TOML text

_BARE = re.compile(r"[A-Za-z0-9_-]+")


def _key(k: str) -> str:
    return k if _BARE.fullmatch(k) else _string(k)


def _string(s: str) -> str:
    out = []
    for ch in s:
        if ch in '"\\':
            out.append("\\" + ch)
        elif ord(ch) < 0x20 or ord(ch) == 0x7F:
            out.append(f"\\u{ord(ch):04x}")
        else:
            out.append(ch)
    return '"' + "".join(out) + '"'


def toml_value(v) -> str:
    """A TOML value (inline: tables as ``{k = v}``)."""
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if math.isnan(v):
            return "nan"
        if math.isinf(v):
            return "inf" if v > 0 else "-inf"
        return repr(v)
    if isinstance(v, str):
        return _string(v)
    if isinstance(v, (dt.datetime, dt.date, dt.time)):
        return v.isoformat()
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(toml_value(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{" + ", ".join(f"{_key(k)} = {toml_value(x)}" for k, x in v.items()) + "}"
    raise TypeError(type(v))


def toml_document(d: dict) -> str:
    return "".join(f"{_key(k)} = {toml_value(v)}\n" for k, v in d.items())


# ---------------------------------------------------------------------- strategies

numbers = st.one_of(
    st.sampled_from([0.0, -0.0, math.nan, math.inf, -math.inf]),
    st.floats(1e-3, 1e3), st.floats(-1e3, -1e-3), st.integers(-1000, 1000))
names = st.sampled_from(robots.names() + list(CASES) + [
    "off", "none", "paper", "fx44850", "continuous", "sampled", "analytic", "filter",
    "difference", "default", "figure_eight", "circle", "line", ""])
scalars = st.one_of(
    numbers, st.booleans(), st.text(max_size=10), names,
    st.dates(min_value=dt.date(1, 1, 1)),
    st.datetimes(min_value=dt.datetime(1, 1, 1)).map(lambda d: d.replace(microsecond=0)),
    st.times().map(lambda t: t.replace(microsecond=0)))
field_keys = st.one_of(st.sampled_from(FIELDS + list(SPECIAL_KEYS)), st.text(max_size=8))
toml_values = st.recursive(
    scalars,
    lambda inner: st.one_of(st.lists(inner, max_size=6),
                            st.dictionaries(field_keys, inner, max_size=4)),
    max_leaves=12)

#: values of the wrong type for each kind of field
numeric_fields = ("a", "kx", "ky", "lx", "ly", "ku", "kw", "lu", "lw", "adapt_from", "T",
                  "Ts", "tau", "log_every")
vector_fields = {"x0": 3, "gamma": 6, "sigma": 6}
name_fields = ("case", "leakage", "control", "vd_dot", "name", "log_dtype")
not_numeric = st.one_of(st.text(max_size=8), st.booleans(), st.lists(numbers, max_size=4),
                        st.dictionaries(st.text(max_size=4), numbers, max_size=2),
                        st.dates(min_value=dt.date(1, 1, 1)))


def wrong_type(field):
    if field in numeric_fields:
        return not_numeric
    if field in vector_fields:
        n = vector_fields[field]
        return st.one_of(numbers, st.text(max_size=8), st.booleans(),
                         st.dictionaries(st.text(max_size=4), numbers, max_size=2),
                         st.lists(numbers, max_size=8).filter(lambda v: len(v) != n),
                         st.lists(st.one_of(st.text(max_size=3), st.booleans(),
                                            st.lists(numbers, max_size=2)),
                                  min_size=n, max_size=n))
    if field in name_fields:
        return st.one_of(numbers, st.booleans(), st.lists(st.text(max_size=4), max_size=3),
                         st.dictionaries(st.text(max_size=4), st.text(max_size=4), max_size=2),
                         st.dates(min_value=dt.date(1, 1, 1)))
    if field in ("robot", "theta_hat0"):
        return st.one_of(st.text(max_size=8).filter(lambda s: s not in robots.names()
                                                    and s not in ("", "default")),
                         numbers, st.booleans(),
                         st.lists(numbers, max_size=8).filter(lambda v: len(v) != 6),
                         st.dictionaries(st.text(max_size=6), numbers, max_size=3))
    if field == "trajectory":
        return st.one_of(numbers, st.booleans(), st.lists(numbers, max_size=3),
                         st.text(max_size=8).filter(
                             lambda s: s not in ("figure_eight", "circle", "line")),
                         st.dictionaries(st.sampled_from(["type", "radius", "omega", "ax",
                                                          "start", "velocity"]),
                                         st.one_of(not_numeric, st.just([])),
                                         min_size=1, max_size=3))
    if field == "log_series":
        return st.one_of(numbers, st.booleans(),
                         st.text(max_size=8).filter(lambda s: any(  # an unknown name in it
                             x.strip() and x.strip() not in ("v_d", "v_ref", "theta_hat", "pose",
                                                             "velocity", "reference")
                             for x in s.split(","))),
                         st.lists(numbers, min_size=1, max_size=3),
                         st.dictionaries(st.text(max_size=4), numbers, max_size=2))
    if field == "payload":  # a list of numbers is rows that are not [t, mass scale] pairs
        return st.one_of(st.text(max_size=8), st.booleans(), st.lists(numbers, min_size=1,
                                                                       max_size=4),
                         st.dictionaries(st.text(max_size=4), numbers, max_size=2),
                         st.dates(min_value=dt.date(1, 1, 1)))
    if field in ("noise", "limits"):
        return st.one_of(numbers.filter(lambda x: x != 0), st.just(True),
                         st.text(max_size=8).filter(lambda s: s not in ("none", "off")),
                         st.lists(numbers, max_size=3),
                         st.dictionaries(st.sampled_from(["position_std", "velocity_std", "seed",
                                                          "speed_max", "steer_max", "accel_max"]),
                                         not_numeric, min_size=1, max_size=2))
    raise AssertionError(field)


# -------------------------------------------------------------------------- checks

def _cli(capsys, tmp_path, command, content, extra=()):
    """Write ``content`` to a fresh file, call ``unidyn COMMAND FILE ...`` in-process and
    check the outcome. Returns (status, output folder, stderr)."""
    n = next(_counter)
    path = tmp_path / f"input{n}.toml"
    if isinstance(content, bytes):
        path.write_bytes(content)
    else:
        path.write_text(content, encoding="utf-8")
    out = tmp_path / f"out{n}"
    argv = [command, str(path), "--out", str(out), "--T", "0.5"]
    argv += ["--engine", "batch"] if command == "run" else ["--no-progress"]
    capsys.readouterr()
    status = main(argv + list(extra))  # an exception escaping main is a traceback
    captured = capsys.readouterr()
    err = captured.err
    errors = [line for line in err.splitlines() if line.startswith("unidyn: error:")]
    assert "Traceback" not in err, err
    assert len(errors) <= 1, err
    assert status in (0, 1, 2), (status, err)
    if status == 2:
        assert len(errors) == 1, err
    else:
        assert not errors, err
    if status == 1:
        assert "unidyn: warning:" in err, err
    if status == 0:
        assert (out / ("summary.json" if command == "run" else "metrics.csv")).is_file()
    return status, out, err


def _record(name, status):
    """How the example ended, in hypothesis' statistics (pytest --hypothesis-show-statistics)."""
    event(f"exit {status}")


# ------------------------------------------------------------------------ unidyn run

@_settings("run_random_bytes")
@given(content=st.binary(max_size=300))
def test_run_survives_random_bytes(capsys, tmp_path, content):
    status, _, _ = _cli(capsys, tmp_path, "run", content)
    _record("run_random_bytes", status)


@pytest.mark.slow
@_settings("run_random_text")
@given(content=st.one_of(st.text(max_size=300), st.text(alphabet="[]{}=.\"'# \n,abxk0123e+-",
                                                         max_size=120)))
def test_run_survives_random_text(capsys, tmp_path, content):
    status, _, _ = _cli(capsys, tmp_path, "run", content)
    _record("run_random_text", status)


@pytest.mark.slow
@pytest.mark.filterwarnings("ignore:Glyph .* missing from font")
@_settings("run_random_tables")
@given(table=st.dictionaries(field_keys, toml_values, max_size=6), wrap=st.booleans())
def test_run_survives_valid_toml_with_random_keys_and_values(capsys, tmp_path, table, wrap):
    text = toml_document(table)
    if wrap:  # the [scenario] form
        text = "[scenario]\n" + text
    tomllib.loads(text)  # the generator writes valid TOML
    status, _, _ = _cli(capsys, tmp_path, "run", text)
    _record("run_random_tables", status)


@_settings("run_wrong_types_per_field")
@given(data=st.data(), field=st.sampled_from(FIELDS))
def test_run_rejects_wrong_types_per_field(capsys, tmp_path, data, field):
    value = data.draw(wrong_type(field), label=field)
    text = toml_document({field: value})
    tomllib.loads(text)
    status, _, err = _cli(capsys, tmp_path, "run", text)
    assert status == 2, (field, value, err)
    message = err.split("unidyn: error:", 1)[1]
    # the message names the field (or, inside a table, the offending key)
    assert field in message or any(k in message for k in (
        "speed_max", "steer_max", "accel_max", "position_std", "velocity_std", "seed",
        "theta", "type", "radius", "omega", "ax", "start", "velocity")), message
    _record("run_wrong_types_per_field", status)


@st.composite
def nested(draw):
    """A field whose value is nested tables or arrays, 1 to 60 levels deep."""
    depth = draw(st.integers(1, 60))
    form = draw(st.sampled_from(["inline", "array", "header"]))
    field = draw(st.sampled_from(FIELDS + ["zz"]))
    leaf = draw(scalars)
    if form == "header":
        keys = draw(st.lists(st.sampled_from(["a", "kx", "type", "x"]), min_size=depth,
                             max_size=depth))
        return f"[{'.'.join([field] + keys)}]\nv = {toml_value(leaf)}\n"
    v = leaf
    for _ in range(depth):
        v = {"a": v} if form == "inline" else [v]
    return toml_document({field: v})


@_settings("run_nested_tables")
@given(text=nested())
def test_run_survives_nested_tables(capsys, tmp_path, text):
    tomllib.loads(text)
    status, _, _ = _cli(capsys, tmp_path, "run", text)
    assert status == 2
    _record("run_nested_tables", status)


@pytest.mark.parametrize("text", [
    pytest.param("x = " + "[" * 2000 + "1" + "]" * 2000 + "\n", id="array-2000-deep"),
    pytest.param("x = " + "{a = " * 2000 + "1" + "}" * 2000 + "\n", id="inline-table-2000-deep"),
    pytest.param("x = " + "[" * 600 + "1" + "]" * 600 + "\n", id="array-600-deep"),
    pytest.param("[" + ".".join(["a"] * 3000) + "]\nb = 1\n", id="table-header-3000-deep"),
    pytest.param("x = " + "[" * 100 + "1" + "]" * 100 + "\n", id="array-100-deep"),
    pytest.param("[" + ".".join(["a"] * 500) + "]\nb = 1\n", id="table-header-500-deep"),
])
def test_run_survives_deeply_nested_files(capsys, tmp_path, text):
    status, _, _ = _cli(capsys, tmp_path, "run", text)
    assert status == 2


def _huge(digits=400):
    return "1" + "0" * digits


#: files the command accepts: it simulates and writes the run's files and figures, a
#: whole-system check (the slow tier); the refusals (status 2) are checked in the fast one
WRITES = pytest.mark.slow


@pytest.mark.parametrize("text, outcome", [
    pytest.param(f"kx = {_huge()}\n", 2, id="kx=10**400"),
    pytest.param(f"x0 = [{_huge()}, 0, 0]\n", 2, id="x0=[10**400,0,0]"),
    pytest.param(f"[limits]\nspeed_max = {_huge()}\n", 2, id="limits.speed_max=10**400"),
    # the error-controlled engine runs these to the end (a saturated controller, a far
    # point h, a robot held by its acceleration limits), or stops where the state turns
    # non-finite and says so (status 1, partial results marked incomplete)
    pytest.param("kx = 1e308\nnoise = \"off\"\n", 0, marks=WRITES, id="kx=1e308"),
    pytest.param("tau = 1e-300\nvd_dot = \"filter\"\nnoise = \"off\"\n", 1, marks=WRITES, id="tau=1e-300"),
    pytest.param("robot = [1e-300, 1, 0, 1, 0, 1]\ncase = \"uncompensated\"\n", 0, marks=WRITES,
                 id="robot.theta1=1e-300"),
    pytest.param("Ts = 1e-300\n", 2, id="Ts=1e-300"),
    # (with the update on within the run: --T 0.5 ends before the default adapt_from)
    pytest.param("a = 1e300\nnoise = \"off\"\nadapt_from = 0\n", 0, marks=WRITES, id="a=1e300"),
    pytest.param("a = 1e-300\nnoise = \"off\"\nadapt_from = 0\n", 1, marks=WRITES, id="a=1e-300"),
    pytest.param("kx = 1e4\nky = 1e-300\nnoise = \"off\"\nadapt_from = 0\n", 0, marks=WRITES, id="kx=1e4,ky=1e-300"),
    pytest.param("[noise]\nposition_std = 1e300\nvelocity_std = 1e300\nseed = "
                 "99999999999999999999999999\n", 0, marks=WRITES, id="noise.std=1e300,huge-seed"),
    pytest.param("gamma = [1e300, 1e300, 1e300, 1e300, 1e300, 1e300]\nadapt_from = 0\n"
                 "noise = \"off\"\n", 1, marks=WRITES, id="gamma=1e300"),
    pytest.param("trajectory = {type = \"circle\", radius = 1e300, omega = 1e300}\n"
                 "noise = \"off\"\n", 1, marks=WRITES, id="circle 1e300 (stops early)"),
    pytest.param("kx = 1.7976931348623157e308\n", 0, marks=WRITES, id="kx=max-float"),
    pytest.param("kx = -9223372036854775808\n", 2, id="kx=int64-min"),
    pytest.param("x0 = [1e300, -1e300, 1e300]\nnoise = \"off\"\n", 2, id="x0=1e300"),
])
@pytest.mark.filterwarnings("error::RuntimeWarning", "error::UserWarning")  # never a warning
def test_extreme_numbers_in_run_files(capsys, tmp_path, text, outcome):
    status, out, err = _cli(capsys, tmp_path, "run", text)
    assert status == outcome, err
    if status == 2:  # refused before anything was written
        assert not (out / "summary.json").exists()
    if status == 1:  # stopped early: marked so, the metrics of the part computed, no estimate
        import json
        summary = json.loads((out / "summary.json").read_text())
        assert summary["complete"] is False and summary["numerical_error"] is None
        assert set(summary["metrics"]) == {"iae", "ise", "itae", "itse", "energy", "error_final",
                                                   "peak_error"}


# ---------------------------------------------------------------------- unidyn sweep

#: keys a random sweep may set (T, Ts and control are left to --T and the batch
#: engine: long bdsim runs would only make the tier slow)
sweep_keys = st.one_of(
    st.sampled_from([f for f in FIELDS if f not in ("T", "Ts", "control")]
                    + list(SPECIAL_KEYS)),
    st.text(max_size=6))
small_numbers = st.one_of(st.sampled_from([0.0, -1.0, math.nan, math.inf, 0.5, 1, 2, 3]),
                          st.integers(-3, 3))
range_table = st.dictionaries(
    st.one_of(st.sampled_from(["start", "stop", "step", "num", "log"]), st.text(max_size=4)),
    st.one_of(small_numbers, st.booleans(), st.text(max_size=3)), max_size=5).filter(
    lambda d: _range_size(d) <= 6)


def _range_size(d):
    """Points a range table would give (generous), to keep random sweeps small."""
    try:
        start, stop = float(d.get("start", 0)), float(d.get("stop", 0))
        if "num" in d:
            return float(d["num"]) if not isinstance(d["num"], str) else 0
        step = float(d.get("step", 1))
        if step <= 0 or not math.isfinite(step) or not math.isfinite(stop - start):
            return 0
        return (stop - start) / step + 1
    except (TypeError, ValueError):
        return 0


sweep_value = st.one_of(scalars, st.lists(scalars, max_size=3))
axis_values = st.one_of(st.lists(st.one_of(small_numbers, scalars), max_size=3), range_table,
                        scalars)
sweep_tables = st.fixed_dictionaries({}, optional={
    "name": st.one_of(st.text(max_size=8), numbers),
    "base": st.one_of(st.dictionaries(sweep_keys, sweep_value, max_size=4), scalars),
    "grid": st.one_of(st.dictionaries(sweep_keys, axis_values, max_size=2), scalars),
    "variants": st.one_of(
        st.lists(st.dictionaries(st.one_of(st.just("label"), sweep_keys),
                                 st.one_of(st.text(max_size=3), sweep_value), max_size=3),
                 max_size=2),
        scalars),
    "rtol": st.one_of(st.integers(-2, 20), numbers, st.text(max_size=3)),
    "extra": toml_values,
})


def sweep_document(d: dict) -> str:
    """A sweep file: [[variants]] as an array of tables, everything else inline."""
    lines = [f"{_key(k)} = {toml_value(v)}" for k, v in d.items()
             if k != "variants" or not isinstance(v, list)]
    if isinstance(d.get("variants"), list):
        for v in d["variants"]:
            lines.append("[[variants]]")
            lines += [f"{_key(k)} = {toml_value(x)}" for k, x in v.items()]
    return "\n".join(lines) + "\n"


@_settings("sweep_random_bytes")
@given(content=st.binary(max_size=300))
def test_sweep_survives_random_bytes(capsys, tmp_path, content):
    status, _, _ = _cli(capsys, tmp_path, "sweep", content)
    _record("sweep_random_bytes", status)


@_settings("sweep_random_text")
@given(content=st.text(max_size=300))
def test_sweep_survives_random_text(capsys, tmp_path, content):
    status, _, _ = _cli(capsys, tmp_path, "sweep", content)
    _record("sweep_random_text", status)


@pytest.mark.filterwarnings("ignore:Glyph .* missing from font")  # random names in titles
@_settings("sweep_random_files")
@given(table=sweep_tables)
def test_sweep_survives_valid_toml_with_random_keys_and_values(capsys, tmp_path, table):
    text = sweep_document(table)
    tomllib.loads(text)
    status, _, _ = _cli(capsys, tmp_path, "sweep", text)
    _record("sweep_random_files", status)


def test_a_valid_random_sweep_runs(capsys, tmp_path):
    """The sweep fuzz reaches the simulation: a small valid file runs and writes its rows."""
    text = ('name = "fuzz"\n[base]\ncase = "compensated"\nnoise = "off"\n'
            '[grid]\nkxy = {start = 1, stop = 3, step = 1}\nleakage = ["paper", "none"]\n'
            '[[variants]]\nlabel = "a"\ntheta_hat_scale = 0.9\n')
    status, out, _ = _cli(capsys, tmp_path, "sweep", text)
    assert status == 0
    rows = (out / "metrics.csv").read_text().splitlines()
    assert len(rows) == 1 + 3 * 2


@pytest.mark.parametrize("text", [
    pytest.param(f"[grid]\nkxy = [{_huge()}]\n", id="grid.kxy=[10**400]"),
    pytest.param(f"[grid]\nkxy = {{start = 1, stop = {_huge()}, step = 1}}\n",
                 id="range stop=10**400"),
    pytest.param(f"rtol = {_huge(30)}\n[grid]\nkxy = [1]\n", id="rtol=10**30"),
    pytest.param("[grid]\nkxy = [1e308]\n", id="grid.kxy=[1e308]"),
    pytest.param("[base]\nTs = 1e-300\n[grid]\nkxy = [1]\n", id="base.Ts=1e-300"),
    pytest.param("[grid]\nkxy = {start = 1, stop = 2, step = 1e-300}\n", id="range step=1e-300"),
    pytest.param("[grid]\nkxy = {start = 1, stop = 1e300, num = 3, log = true}\n",
                 id="log range to 1e300"),
    pytest.param("[grid]\nseed = [99999999999999999999999999]\n", id="huge seed"),
])
def test_extreme_numbers_in_sweep_files(capsys, tmp_path, text):
    _cli(capsys, tmp_path, "sweep", text)


# ------------------------------------------------------------------- long strings

_MB = 1_000_000


@pytest.mark.parametrize("text, key", [
    pytest.param(f'name = "{"n" * 3 * _MB}"\n', "name is 3000000 characters long",
                 id="name 3 MB"),
    pytest.param(f'case = "{"x" * _MB}"\n', "case must be one of", id="case 1 MB"),
    pytest.param(f'robot = "{"x" * _MB}"\n', "robot", id="robot 1 MB"),
    pytest.param(f'vd_dot = "{"x" * _MB}"\n', "vd_dot", id="vd_dot 1 MB"),
    pytest.param(f'trajectory = {{type = "{"x" * _MB}"}}\n', "trajectory type",
                 id="trajectory.type 1 MB"),
    pytest.param(f'{"k" * 100_000} = 1\n', "unknown scenario field", id="key 100 kB"),
    pytest.param(f'[noise]\n{"s" * 100_000} = 1\n', "noise", id="noise key 100 kB"),
])
def test_long_strings_in_run_files(capsys, tmp_path, text, key):
    """A huge string is refused before anything is written, with a short message that
    names the key (the value itself is shortened, not echoed in full)."""
    status, out, err = _cli(capsys, tmp_path, "run", text)
    assert status == 2, err[:300]
    line = err.strip().splitlines()[-1]
    assert key in line, line[:300]
    assert len(line) < 1000, len(line)
    assert not out.exists()


@pytest.mark.parametrize("text, key", [
    pytest.param(f'name = "{"n" * 3 * _MB}"\n[grid]\nkxy = [1]\n',
                 "name is 3000000 characters long", id="name 3 MB"),
    pytest.param(f'[grid]\nkxy = [1]\n[[variants]]\nlabel = "{"x" * _MB}"\n',
                 "variants[0].label is 1000000 characters long", id="label 1 MB"),
    pytest.param(f'[grid]\nrobot = ["{"x" * _MB}"]\n', "robot", id="grid.robot 1 MB"),
    pytest.param(f'[grid]\n{"a" * 100_000} = [1]\n', "grid: unknown key", id="axis 100 kB"),
    pytest.param(f'[base]\ncase = "{"x" * _MB}"\n', "case must be one of", id="base.case 1 MB"),
])
def test_long_strings_in_sweep_files(capsys, tmp_path, text, key):
    status, out, err = _cli(capsys, tmp_path, "sweep", text)
    assert status == 2, err[:300]
    line = err.strip().splitlines()[-1]
    assert key in line and len(line) < 1000, line[:300]
    assert not out.exists()


def test_a_huge_name_given_with_set_is_refused(capsys, tmp_path):
    status = main(["run", "--T", "0.5", "--set", "name=" + "n" * 3 * _MB,
                   "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err
    assert status == 2 and "name is 3000000 characters long" in err and len(err) < 1000
    assert not (tmp_path / "o").exists()
