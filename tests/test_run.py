"""``unidyn.run`` chooses the engine as ``unidyn run`` does, and runs what it chose."""

import json

import numpy as np
import pytest

import unidyn
from unidyn import Scenario, ValidationError
from unidyn.cli import main
from unidyn.engines import choose


def test_auto_is_the_batch_engine_for_continuous_control_and_the_diagram_for_sampled():
    continuous = Scenario.paper(4, T=1.0)
    sampled = Scenario.paper(4, T=1.0, control="sampled", vd_dot="difference")
    assert choose(continuous) == "batch"
    assert choose(sampled) == "bdsim"
    assert choose(continuous, "bdsim") == "bdsim"


def test_an_unknown_engine_is_refused_naming_the_parameter():
    with pytest.raises(ValidationError, match="engine"):
        choose(Scenario.paper(4, T=1.0), "fast")


def test_run_is_the_chosen_engine_itself():
    sc = Scenario.paper(3, T=2.0, noise=None)
    r = unidyn.run(sc)
    direct = unidyn.simulate_batch([sc])[0]
    assert r.engine == "batch"
    np.testing.assert_array_equal(r.pose, direct.pose)


def test_the_command_line_chooses_as_python_does(tmp_path):
    sc = Scenario.paper(3, T=1.0, noise=None)
    assert main(["run", "--paper", "3", "--T", "1", "--set", "noise=off",
                 "--out", str(tmp_path)]) == 0
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["engine"] == unidyn.run(sc).engine == "batch"


def test_run_names_a_scenario_field_given_as_an_option():
    sc = unidyn.Scenario.paper(3, T=0.5)
    with pytest.raises(unidyn.ValidationError, match=r"'T' is a field of the scenario.*replace\(T="):
        unidyn.run(sc, T=-5)
    with pytest.raises(unidyn.ValidationError, match=r"takes rtol, atol, backend, progress; got 'rtl' \(did you mean 'rtol'\?\)"):
        unidyn.run(sc, rtl=1e-6)
    with pytest.raises(unidyn.ValidationError, match="'method'"):
        unidyn.run(sc, engine="batch", method="Radau")  # the diagram's option
