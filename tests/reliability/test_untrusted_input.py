"""Scenario files are data: nothing in them is ever executed.

Values that look like code or templates, in every string-valued field of a
scenario (and in ``--set``, ``--robot``, ``--case``, sweep files, robot JSON files
and the Python API), are rejected as unknown names or values, echoed verbatim in
the one-line error, and never run: no file appears, and ``builtins.eval`` /
``builtins.exec`` (replaced by guards for the duration of each call) are never
called outside an import. A trajectory given as a formula is rejected: the
library has no formula trajectories. A static check keeps ``eval``, ``exec``,
``pickle``, ``marshal`` and ``yaml.load`` out of the package source.
"""

from __future__ import annotations

import ast
import builtins
import json
import os
import re
import sys
from pathlib import Path

import pytest

import unidyn
from unidyn import ValidationError
from unidyn.cli import main
from unidyn.model.scenario import Scenario

pytestmark = pytest.mark.reliability

ROOT = Path(__file__).resolve().parents[2]
PACKAGE_DIRS = ("src/unidyn",)

PAYLOADS = [
    "__import__('os').system('touch PWNED')",
    "__import__('os').system('touch {pwned}')",  # the test's own folder, absolute
    "{{7*7}}",
    "${7*7}",
    "#{7*7}",
    "<%= 7*7 %>",
    "eval('1')",
    "exec('import os')",
    "lambda t: (t, t)",
    "os.system('touch PWNED')",
    "$(touch PWNED)",
    "`touch PWNED`",
    "; touch PWNED",
    "!!python/object/apply:os.system ['touch PWNED']",
]
PAYLOAD_IDS = [f"payload{i}" for i in range(len(PAYLOADS))]

#: every field whose value is (or may be) a string name, and how a payload goes in
STRING_FIELDS = {
    "robot": lambda p: {"robot": p},
    "case": lambda p: {"case": p},
    "trajectory": lambda p: {"trajectory": p},
    "trajectory.type": lambda p: {"trajectory": {"type": p}},
    "leakage": lambda p: {"leakage": p},
    "control": lambda p: {"control": p},
    "theta_hat0": lambda p: {"theta_hat0": p},
    "vd_dot": lambda p: {"vd_dot": p},
    "noise": lambda p: {"noise": p},
    "limits": lambda p: {"limits": p},
    "robot-path": lambda p: {"robot": f"{p}.json"},
    "theta_hat0-path": lambda p: {"theta_hat0": f"/nonexistent/{p}.json"},
}


# ------------------------------------------------------------------------- guards

def _inside_import(frame) -> bool:
    while frame is not None:
        name = frame.f_globals.get("__name__", "")
        if name.startswith(("importlib", "_frozen_importlib")):
            return True
        frame = frame.f_back
    return False


@pytest.fixture(scope="module", autouse=True)
def _warm_up(tmp_path_factory):
    """Load every module the calls below use, before eval/exec are guarded."""
    d = tmp_path_factory.mktemp("warm")
    f = d / "s.toml"
    f.write_text('case = "compensated"\nnoise = "off"\n')
    assert main(["run", str(f), "--out", str(d / "o"), "--T", "0.3", "--engine", "batch"]) == 0
    f.write_text('kk = 1\ntrajectory = {type = "x"}\n')
    assert main(["run", str(f), "--out", str(d / "o2"), "--T", "0.3"]) == 2
    f.write_text("[grid]\nkxy = [1]\n")
    assert main(["sweep", str(f), "--out", str(d / "o3"), "--T", "0.3", "--no-progress"]) == 0
    import unidyn.blocks.controllers  # noqa: F401
    import unidyn.blocks.sources  # noqa: F401
    import unidyn.blocks.unicycles  # noqa: F401


@pytest.fixture
def sandbox(monkeypatch, tmp_path):
    """Run in an empty folder with eval, exec, os.system and os.popen guarded.

    Yields (folder, calls): ``calls`` lists every guarded call made outside an import."""
    work = tmp_path / "work"
    work.mkdir()
    monkeypatch.chdir(work)
    calls = []

    def guard(name, real):
        def guarded(*args, **kwargs):
            if _inside_import(sys._getframe(1)):
                return real(*args, **kwargs)
            calls.append((name, args[:1]))
            raise AssertionError(f"{name} called on scenario data: {args[:1]!r}")
        return guarded

    monkeypatch.setattr(builtins, "eval", guard("eval", builtins.eval))
    monkeypatch.setattr(builtins, "exec", guard("exec", builtins.exec))
    monkeypatch.setattr(os, "system", guard("os.system", os.system))
    monkeypatch.setattr(os, "popen", guard("os.popen", os.popen))
    yield work, calls
    assert not calls, calls


def _payload(p: str, work: Path) -> str:
    return p.replace("{pwned}", str(work / "PWNED"))


def _nothing_ran(work: Path, calls):
    assert not calls, calls
    assert not any(work.rglob("PWNED")) and not Path("PWNED").exists()
    assert not (ROOT / "PWNED").exists()


def test_the_guards_are_active(sandbox):
    work, calls = sandbox
    with pytest.raises(AssertionError, match="eval called"):
        eval("1")
    with pytest.raises(AssertionError, match="exec called"):
        exec("x = 1")
    assert [c[0] for c in calls] == ["eval", "exec"]
    calls.clear()


# ------------------------------------------------------------------ toml writing

def _toml_string(s: str) -> str:
    return json.dumps(s)  # the payloads are ASCII without control characters


def _toml(table: dict) -> str:
    lines = []
    for k, v in table.items():
        if isinstance(v, dict):
            inner = ", ".join(f"{kk} = {_toml_string(vv)}" for kk, vv in v.items())
            lines.append(f"{k} = {{{inner}}}")
        else:
            lines.append(f"{k} = {_toml_string(v)}")
    return "\n".join(lines) + "\n"


def _run(capsys, work: Path, argv):
    capsys.readouterr()
    status = main(argv)
    err = capsys.readouterr().err
    assert "Traceback" not in err
    return status, err


def _rejected(status, err, payload):
    errors = [line for line in err.splitlines() if line.startswith("unidyn: error:")]
    assert status == 2 and len(errors) == 1, err
    assert payload in errors[0], f"the value is not echoed verbatim: {errors[0]}"


# ------------------------------------------------------------------- scenario files

@pytest.mark.parametrize("payload", PAYLOADS, ids=PAYLOAD_IDS)
@pytest.mark.parametrize("field", list(STRING_FIELDS))
def test_code_in_string_fields_of_a_scenario_file_is_rejected(capsys, sandbox, field, payload):
    work, calls = sandbox
    payload = _payload(payload, work)
    f = work / "scenario.toml"
    f.write_text(_toml(STRING_FIELDS[field](payload)))
    status, err = _run(capsys, work, ["run", str(f), "--out", str(work / "out"), "--T", "0.5",
                                      "--engine", "batch"])
    _rejected(status, err, payload)
    _nothing_ran(work, calls)


@pytest.mark.parametrize("payload", PAYLOADS, ids=PAYLOAD_IDS)
def test_code_in_command_line_values_is_rejected(capsys, sandbox, payload):
    work, calls = sandbox
    payload = _payload(payload, work)
    out = str(work / "out")
    for argv in (["run", "--set", f"case={payload}", "--out", out],
                 ["run", "--set", f"leakage={payload}", "--out", out],
                 ["run", "--set", f"trajectory.type={payload}", "--out", out],
                 ["run", "--robot", payload, "--out", out],
                 ["run", "--case", payload, "--out", out],
                 ["properties", payload]):
        status, err = _run(capsys, work, argv + (["--T", "0.5", "--engine", "batch"]
                                                 if argv[0] == "run" else []))
        _rejected(status, err, payload)
    _nothing_ran(work, calls)


@pytest.mark.parametrize("payload", PAYLOADS, ids=PAYLOAD_IDS)
def test_code_in_a_robot_file_is_rejected(capsys, sandbox, payload):
    """A robot given as a path: a JSON file whose values, or whose whole text, is code."""
    work, calls = sandbox
    payload = _payload(payload, work)
    values = work / "values.json"
    values.write_text(json.dumps({"theta1": payload, "theta2": 0.25, "theta3": 0.0,
                                  "theta4": 1.0, "theta5": 0.0, "theta6": 1.0, "name": payload}))
    text = work / "text.json"
    text.write_text(payload)
    f = work / "scenario.toml"
    for robot, shown in ((values, payload), (text, str(text))):
        f.write_text(_toml({"robot": str(robot)}))
        status, err = _run(capsys, work, ["run", str(f), "--out", str(work / "out"),
                                          "--T", "0.5", "--engine", "batch"])
        _rejected(status, err, shown)
    with pytest.raises(ValidationError, match="theta1 must be a real number"):
        unidyn.model.robots.resolve(str(values))
    _nothing_ran(work, calls)


def test_an_invalid_robot_file_is_named_in_the_error(capsys, sandbox):
    work, calls = sandbox
    robot = work / "robot.json"
    robot.write_text(json.dumps({"theta1": "x", "theta2": 0.25, "theta3": 0.0, "theta4": 1.0,
                                 "theta5": 0.0, "theta6": 1.0}))
    f = work / "scenario.toml"
    f.write_text(_toml({"robot": str(robot)}))
    status, err = _run(capsys, work, ["run", str(f), "--out", str(work / "out"), "--T", "0.5"])
    assert status == 2
    assert str(robot) in err or "robot:" in err, err


@pytest.mark.parametrize("payload", PAYLOADS[:4], ids=PAYLOAD_IDS[:4])
def test_code_in_sweep_files_is_rejected(capsys, sandbox, payload):
    work, calls = sandbox
    payload = _payload(payload, work)
    s = json.dumps(payload)
    for text in (f"[base]\ncase = {s}\n[grid]\nkxy = [1]\n",
                 f"[grid]\nleakage = [{s}]\n",
                 f"[grid]\nkxy = [1]\n[[variants]]\nlabel = \"a\"\nrobot = {s}\n",
                 f"name = {s}\n[grid]\ntrajectory = [{{type = {s}}}]\n"):
        f = work / "sweep.toml"
        f.write_text(text)
        status, err = _run(capsys, work, ["sweep", str(f), "--out", str(work / "out"),
                                          "--T", "0.5", "--no-progress"])
        _rejected(status, err, payload)
    _nothing_ran(work, calls)


def test_a_summary_with_code_is_rejected(capsys, sandbox):
    """``unidyn run --from`` reads a summary.json: its values are data too."""
    work, calls = sandbox
    payload = _payload(PAYLOADS[1], work)
    summary = work / "summary.json"
    summary.write_text(json.dumps({"engine": "batch", "scenario": {"case": payload}}))
    status, err = _run(capsys, work, ["run", "--from", str(summary), "--out",
                                      str(work / "out"), "--T", "0.5"])
    _rejected(status, err, payload)
    _nothing_ran(work, calls)


def test_code_as_a_name_is_kept_as_a_label(capsys, sandbox):
    """``name`` is free text: a payload there runs as an ordinary label, verbatim."""
    work, calls = sandbox
    payload = _payload(PAYLOADS[1], work)
    f = work / "scenario.toml"
    f.write_text(_toml({"name": payload, "case": "compensated", "noise": "off"}))
    status, err = _run(capsys, work, ["run", str(f), "--out", str(work / "out"), "--T", "0.3",
                                      "--engine", "batch"])
    assert status == 0, err
    summary = json.loads((work / "out" / "summary.json").read_text())
    assert summary["scenario"]["name"] == payload
    _nothing_ran(work, calls)


# ------------------------------------------------------------------------ Python API

@pytest.mark.parametrize("payload", PAYLOADS, ids=PAYLOAD_IDS)
def test_code_in_the_python_api_is_rejected(sandbox, payload):
    from unidyn.blocks.controllers import DynamicCompensator, SampledDynamicCompensator
    from unidyn.blocks.sources import TrajectorySource
    from unidyn.blocks.unicycles import DynamicUnicycle
    from unidyn.diagrams import new_simulator
    work, calls = sandbox
    payload = _payload(payload, work)
    for make in STRING_FIELDS.values():
        with pytest.raises(ValidationError):
            Scenario(**make(payload))
        with pytest.raises(ValidationError):
            Scenario.from_dict(make(payload))
    bd = new_simulator().blockdiagram()
    clock = bd.clock(0.1, offset=0.0, name="untrusted")
    for build in (lambda: DynamicUnicycle(robot=payload, bd=bd),
                  lambda: DynamicCompensator(theta_hat0=payload, bd=bd),
                  lambda: DynamicCompensator(leakage=payload, bd=bd),
                  lambda: DynamicCompensator(vd_dot=payload, bd=bd),
                  lambda: SampledDynamicCompensator(clock, vd_dot=payload, bd=bd),
                  lambda: TrajectorySource(payload, bd=bd),
                  lambda: TrajectorySource({"type": payload}, bd=bd),
                  lambda: unidyn.model.robots.get(payload),
                  lambda: unidyn.model.trajectories.from_spec(payload)):
        with pytest.raises(ValidationError) as err:
            build()
        assert payload in str(err.value)
    _nothing_ran(work, calls)


# ------------------------------------------------------------- formula trajectories

FORMULAS = [
    "sin(t)",
    "lambda t: ((sin(t), cos(t)), (cos(t), -sin(t)))",
    {"type": "function", "f": "lambda t: ((t, t), (1, 1))"},
    {"type": "formula", "x": "sin(0.5*t)", "y": "cos(0.25*t) - 1"},
    {"x": "sin(0.5*t)", "y": "cos(0.25*t) - 1"},
    {"type": "circle", "radius": "2*3"},
    {"type": "circle", "omega": "__import__('os').getpid()"},
    {"type": "line", "velocity": ["0.1*2", "0"]},
]


@pytest.mark.parametrize("formula", FORMULAS, ids=[f"formula{i}" for i in range(len(FORMULAS))])
def test_formula_trajectories_are_rejected(capsys, sandbox, formula):
    work, calls = sandbox
    with pytest.raises(ValidationError, match="trajectory"):
        Scenario(trajectory=formula)
    f = work / "scenario.toml"
    if isinstance(formula, str):
        f.write_text(f"trajectory = {json.dumps(formula)}\n")
    else:
        f.write_text("[trajectory]\n" + "".join(f"{k} = {json.dumps(v)}\n"
                                                for k, v in formula.items()))
    status, err = _run(capsys, work, ["run", str(f), "--out", str(work / "out"), "--T", "0.5",
                                      "--engine", "batch"])
    assert status == 2 and err.count("unidyn: error:") == 1, err
    assert "trajectory" in err
    _nothing_ran(work, calls)


# ------------------------------------------------------------------- static check

FORBIDDEN = {
    "eval(": re.compile(r"\beval\s*\("),
    "exec(": re.compile(r"\bexec\s*\("),
    "pickle": re.compile(r"\b(c?pickle|dill|shelve)\b"),
    "marshal": re.compile(r"\bmarshal\b"),
    "yaml.load(": re.compile(r"\byaml\s*\.\s*(unsafe_)?load\s*\("),
}


def _package_files():
    for d in PACKAGE_DIRS:
        for p in sorted((ROOT / d).rglob("*")):
            if p.is_file() and "__pycache__" not in p.parts and p.suffix not in (".pyc", ".nbi",
                                                                                 ".nbc"):
                yield p


def test_package_source_has_no_eval_exec_pickle_marshal_or_yaml_load():
    """No occurrence at all (code, comments or docstrings) in src/unidyn/ (blocks and diagrams included)."""
    files = list(_package_files())
    assert len([p for p in files if p.suffix == ".py"]) >= 20
    found = []
    for p in files:
        text = p.read_text(encoding="utf-8", errors="replace")
        for what, rx in FORBIDDEN.items():
            for m in rx.finditer(text):
                line = text.count("\n", 0, m.start()) + 1
                found.append(f"{p.relative_to(ROOT)}:{line}: {what}")
    assert not found, "\n".join(found)


def test_package_source_calls_no_dynamic_code_builtins():
    """The same by syntax tree: no call of eval, exec, compile or __import__, no import of
    pickle, marshal, shelve or yaml."""
    bad = []
    for p in _package_files():
        if p.suffix != ".py":
            continue
        tree = ast.parse(p.read_text(encoding="utf-8"), filename=str(p))
        for node in ast.walk(tree):
            if (isinstance(node, ast.Call) and isinstance(node.func, ast.Name)
                    and node.func.id in ("eval", "exec", "compile", "__import__")):
                bad.append(f"{p.relative_to(ROOT)}:{node.lineno}: {node.func.id}()")
            if isinstance(node, (ast.Import, ast.ImportFrom)):
                mods = ([a.name for a in node.names] if isinstance(node, ast.Import)
                        else [node.module or ""])
                for m in mods:
                    if m.split(".")[0] in ("pickle", "cPickle", "marshal", "shelve", "yaml",
                                           "dill"):
                        bad.append(f"{p.relative_to(ROOT)}:{node.lineno}: import {m}")
    assert not bad, "\n".join(bad)


def test_the_shipped_pth_hook_only_sets_bdsimpath():
    """``unidyn-bdsim.pth`` runs at interpreter start-up (a .pth ``import`` line is executed):
    it must hold one fixed line that only edits BDSIMPATH."""
    pth = ROOT / "unidyn-bdsim.pth"
    lines = [line for line in pth.read_text().splitlines() if line.strip()]
    assert len(lines) == 1
    assert lines[0].startswith("import os;") and "BDSIMPATH" in lines[0]
    for what, rx in FORBIDDEN.items():
        assert not rx.search(lines[0]), what
    assert "open(" not in lines[0] and "__import__" not in lines[0]
