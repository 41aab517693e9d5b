"""The cases of the Fig. 2 loop as data (unidyn.model.cases): what Section 5 says each
case is, and that the rest of the package reads that table instead of the case's name."""

import ast
from pathlib import Path

import numpy as np
import pytest

from unidyn import Scenario
from unidyn.model.cases import CASE_SPECS, CASES, CaseSpec

SRC = Path(__file__).resolve().parents[2] / "src" / "unidyn"

#: Modules that still decode a case from its name, outside the model: each is to read
#: ``scenario.case_spec`` instead (``unidyn/model/`` is where names are decoded).
PENDING = set()


def test_section5_cases():
    """Section 5's four simulations: a kinematic robot (1), the dynamic robot with the
    kinematic controller alone (2), exact compensation (3), adaptive compensation (4)."""
    s = [Scenario.paper(n).case_spec for n in (1, 2, 3, 4)]
    assert [c.dynamic for c in s] == [False, True, True, True]
    assert [c.compensated for c in s] == [False, False, True, True]
    assert [c.adaptive for c in s] == [False, False, False, True]
    assert [c.name for c in s] == list(CASES)


def test_default_estimate_follows_the_case():
    """theta_hat(0) unset: the robot's theta, except adaptive compensation's theta/1.5
    (simulation 4)."""
    for name in CASES:
        sc = Scenario(case=name)
        want = sc.robot.theta / 1.5 if name == "adaptive" else sc.robot.theta
        np.testing.assert_array_equal(sc.theta_hat_initial, want)


def test_a_kinematic_robot_has_nothing_to_compensate():
    with pytest.raises(ValueError, match="kinematic robot"):
        CaseSpec("x", "kinematic", "exact", 1.0, "")
    with pytest.raises(ValueError, match="compensation"):
        CaseSpec("x", "dynamic", "partial", 1.0, "")


def test_every_case_has_a_spec_of_its_name():
    assert all(spec.name == name for name, spec in CASE_SPECS.items())


def _case_comparisons(path):
    """Lines where ``case`` (a name or an attribute) is compared with a case's name."""
    names = set(CASES)

    def is_case(node):
        return (isinstance(node, ast.Name) and node.id == "case"
                or isinstance(node, ast.Attribute) and node.attr == "case")

    def case_names(node):
        if isinstance(node, ast.Constant):
            return node.value in names
        if isinstance(node, (ast.Tuple, ast.List, ast.Set)):
            return any(case_names(e) for e in node.elts)
        return False

    out = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Compare):
            sides = [node.left, *node.comparators]
            if any(is_case(s) for s in sides) and any(case_names(s) for s in sides):
                out.append(node.lineno)
    return out


def test_the_scan_finds_a_comparison(tmp_path):
    f = tmp_path / "m.py"
    f.write_text("x = sc.case == 'adaptive'\ny = case in ('kinematic', 'other')\n"
                 "z = sc.case_spec.adaptive\n")
    assert _case_comparisons(f) == [1, 2]


def test_only_the_model_decodes_a_case_from_its_name():
    found = {}
    for path in sorted(SRC.rglob("*.py")):
        rel = path.relative_to(SRC).as_posix()
        if rel.startswith("model/") or rel in PENDING:
            continue
        lines = _case_comparisons(path)
        if lines:
            found[rel] = lines
    assert found == {}, "read scenario.case_spec instead of comparing case with a name"


def test_pending_modules_still_need_it():
    """A module off PENDING once it reads the table: the list only shrinks."""
    assert sorted(m for m in PENDING if not _case_comparisons(SRC / m)) == []
