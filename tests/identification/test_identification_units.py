"""Logs in the wrong units or layout, as users get them wrong, simulated from robots
whose parameters are known: commands in cm/s or mm/s beside odometry in m/s (and the
reverse), angular commands in deg/s, u and w exchanged in the header. Each is refused
naming the parameter, the likely cause and the option that fixes it, and the fix it
names recovers the robot."""

from __future__ import annotations

import functools
import json
import math
import re
import warnings

import numpy as np
import pytest

from unidyn import ValidationError
from unidyn import identification as ident
from unidyn.identification.checks import envelope_warnings
from unidyn.model import robots

DT, T, NOISE = 0.05, 60.0, 0.005
FAST = dict(validate=False, check_commands=False, commands="linear")


@functools.lru_cache(maxsize=None)
def simulated(name):
    truth = robots.get(name)
    exc = ident.excitation(T, DT, robot=truth, seed=0)
    return truth, ident.simulate_log(truth, exc, noise_std=NOISE, seed=1)


def quiet_identify(log, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ident.IdentificationWarning)
        return ident.identify(log, **{**FAST, **kw})


def columns(log, pose=False):
    keys = ("t", "u_ref", "w_ref", "u", "w") + (("x", "y", "psi") if pose else ())
    return {k: log[k] for k in keys}


#: (column scaled, its factor from SI, the parameter that shows it, the unit the
#: message must name)
MISMATCHES = [("u_ref", 100.0, "theta4", "cm/s"), ("u_ref", 1000.0, "theta4", "mm/s"),
              ("u", 100.0, "theta4", "cm/s"), ("w_ref", 180 / math.pi, "theta6", "deg/s"),
              ("w", 180 / math.pi, "theta6", "deg/s")]


@pytest.mark.parametrize("name", ["p3dx", "khepera3", "wheelchair_125kg"])
@pytest.mark.parametrize("column, factor, param, unit", MISMATCHES)
def test_columns_in_other_units_are_refused_and_the_named_scale_recovers_the_robot(
        name, column, factor, param, unit):
    truth, log = simulated(name)
    bad = columns(log)
    bad[column] = bad[column] * factor
    with pytest.raises(ValidationError) as err:
        quiet_identify(bad)
    text = str(err.value)
    assert "\n" not in text and f"identified {param} = " in text and unit in text, text
    # the scale the message proposes, read from it, undoes the mismatch
    proposed = re.search(r"scale=\{'(\w+)': ([0-9.e+-]+)\}", text)
    assert proposed and proposed.group(1) == column, text
    assert float(proposed.group(2)) == pytest.approx(1 / factor, rel=1e-3)
    res = quiet_identify(bad, scale={column: float(proposed.group(2))})
    good = quiet_identify(columns(log))
    assert np.allclose(res.theta.theta, good.theta.theta, rtol=2e-3, atol=1e-5)
    for i in (0, 1, 3, 5):  # and it is the robot (theta3, theta5 may be ~0)
        assert res.theta.theta[i] == pytest.approx(truth.theta[i], rel=0.1)


def test_a_gain_near_one_is_not_taken_for_a_unit_mismatch():
    # measured speeds 1.5 times too large (a wheel-radius error): a warning, not a refusal
    truth, log = simulated("p3dx")
    res = quiet_identify({**columns(log), "u": 1.5 * log["u"]})
    assert res.theta.theta4 == pytest.approx(truth.theta4 / 1.5, rel=0.03)


@pytest.mark.parametrize("name", ["p3dx", "khepera3", "wheelchair_55kg"])
def test_u_and_w_exchanged_with_a_pose_are_refused_naming_the_mapping(name):
    truth, log = simulated(name)
    # the header names the columns the wrong way round: t,w_ref,u_ref,w,u
    swapped = {"t": log["t"], "w_ref": log["u_ref"], "u_ref": log["w_ref"], "w": log["u"],
               "u": log["w"], "x": log["x"], "y": log["y"], "psi": log["psi"]}
    with pytest.raises(ValidationError, match="look exchanged") as err:
        quiet_identify(swapped)
    text = str(err.value)
    mapping = dict(re.findall(r"'(\w+)': '(\w+)'", text.split("columns=")[1]))
    assert mapping == {"u_ref": "w_ref", "w_ref": "u_ref", "u": "w", "w": "u"}
    res = quiet_identify(swapped, columns=mapping)
    for i in (0, 1, 3, 5):
        assert res.theta.theta[i] == pytest.approx(truth.theta[i], rel=0.1)


def test_a_pose_that_agrees_with_u_and_w_passes():
    truth, log = simulated("p3dx")
    with_pose = quiet_identify(columns(log, pose=True))
    without = quiet_identify(columns(log))
    assert np.array_equal(with_pose.theta.theta, without.theta.theta)


def test_no_preset_lies_outside_the_envelope_and_each_parameter_far_outside_is_named():
    for name in robots.names():
        assert envelope_warnings(robots.get(name).theta) == [], name
    base = robots.get("p3dx").theta
    # beyond every preset: theta1 of 50 s (the RobuLAB-10's is 6.06 s), theta3 of 5
    for i, value, words in ((0, 50.0, "theta1 = 50 s is 8.25 times the largest"),
                            (2, -5.0, "theta3 = -5 s·m/rad² is 9.26 times the largest "
                                      "magnitude"),
                            (1, 0.001, "theta2 = 0.001 s is 1/18.8 of the smallest")):
        theta = base.copy()
        theta[i] = value
        found = envelope_warnings(theta)
        assert len(found) == 1 and found[0].startswith(words), found
        assert "outside the range of physical robots" in found[0]


def test_bad_scales_are_refused_in_one_line():
    _, log = simulated("p3dx")
    for scale, words in (({"t": 2.0}, "unknown key 't'"), ({"u": 0.0}, "finite factor > 0"),
                         ({"u": math.inf}, r"scale\['u'\] must be finite"), ([0.01], "must be a mapping")):
        with pytest.raises(ValidationError, match=words):
            quiet_identify(columns(log), scale=scale)


def _write_csv(path, log, order):
    with open(path, "w") as fh:
        fh.write(",".join(order) + "\n")
        for row in zip(*(log[k] for k in order)):
            fh.write(",".join(repr(float(x)) for x in row) + "\n")


def test_the_command_line_names_its_own_options_and_they_fix_the_log(tmp_path, capsys):
    from unidyn.cli import main
    truth, log = simulated("p3dx")
    cm = {**columns(log), "u_ref": 100 * log["u_ref"]}  # commands in cm/s
    _write_csv(tmp_path / "cm.csv", cm, ("t", "u_ref", "w_ref", "u", "w"))
    assert main(["identify", str(tmp_path / "cm.csv"), "--out", str(tmp_path / "a"),
                 "--no-validate"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "Pass --scale u_ref=0.01 to bring u_ref" in err, err
    assert "scale={" not in err
    assert main(["identify", str(tmp_path / "cm.csv"), "--out", str(tmp_path / "a"),
                 "--no-validate", "--scale", "u_ref=0.01", "--commands", "linear"]) == 0
    theta = json.loads((tmp_path / "a" / "theta.json").read_text())
    assert theta["theta4"] == pytest.approx(truth.theta4, rel=0.05)  # the robot, in m/s
    assert theta["theta1"] == pytest.approx(truth.theta1, rel=0.1)
    # u and w exchanged in the header, with the pose: the mapping as --columns pairs
    swapped = {"t": log["t"], "w_ref": log["u_ref"], "u_ref": log["w_ref"], "w": log["u"],
               "u": log["w"], "x": log["x"], "y": log["y"], "psi": log["psi"]}
    _write_csv(tmp_path / "sw.csv", swapped, ("t", "w_ref", "u_ref", "w", "u", "x", "y", "psi"))
    capsys.readouterr()
    assert main(["identify", str(tmp_path / "sw.csv"), "--out", str(tmp_path / "b"),
                 "--no-validate"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.endswith("map them: --columns u_ref=w_ref,w_ref=u_ref,u=w,w=u"), err
    assert main(["identify", str(tmp_path / "sw.csv"), "--out", str(tmp_path / "b"),
                 "--no-validate", "--columns", "u_ref=w_ref,w_ref=u_ref,u=w,w=u",
                 "--commands", "linear"]) == 0
    theta = json.loads((tmp_path / "b" / "theta.json").read_text())
    assert theta["theta2"] == pytest.approx(truth.theta2, rel=0.1)  # not theta1
