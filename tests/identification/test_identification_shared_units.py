"""Units and layouts the header does not show, simulated from every preset robot:
both sides of a log in one wrong unit (u_ref and u in cm/s or mm/s, w_ref and w in
deg/s or rpm), which no gain between them can reveal; u and w, u_ref and w_ref, or
both exchanged, with the pose in any unit or without one. Each is refused or warned
naming the likely unit or mapping, and every fix a message suggests is followed and
must give back the robot identified from the log in SI units."""

from __future__ import annotations

import ast
import functools
import json
import math
import re
import warnings

import numpy as np
import pytest

from unidyn import ValidationError
from unidyn import identification as ident
from unidyn.identification.checks import B_MAX, L_MAX, L_MIN, U_MAX, W_MAX, fit_refused
from unidyn.model import robots

DT, T, NOISE = 0.05, 60.0, 0.005
FAST = dict(validate=False, check_commands=False, commands="linear")
#: unit -> (the columns in it, its factor from SI)
SHARED = {"cm/s": (("u_ref", "u"), 100.0), "mm/s": (("u_ref", "u"), 1000.0),
          "deg/s": (("w_ref", "w"), 180 / math.pi), "rpm": (("w_ref", "w"), 30 / math.pi)}


@functools.lru_cache(maxsize=None)
def simulated(name):
    truth = robots.get(name)
    exc = ident.excitation(T, DT, robot=truth, seed=0)
    return ident.simulate_log(truth, exc, noise_std=NOISE, seed=1, commands="held")


def run(log, **kw):
    with warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("always", ident.IdentificationWarning)
        res = ident.identify(log, **{**FAST, **kw})
    return res, [str(w.message) for w in seen if issubclass(w.category,
                                                            ident.IdentificationWarning)]


def same_robot(fixed, right):
    """The same estimate up to the fit's rounding: within a thousandth of each
    parameter's standard error."""
    gap = np.abs(fixed.theta.theta - right.theta.theta)
    assert np.all(gap <= 1e-3 * np.asarray(right.stderr) + 1e-12), (fixed.theta.theta,
                                                                    right.theta.theta)


def velocities(log, pose=False):
    keys = ("t", "u_ref", "w_ref", "u", "w") + (("x", "y", "psi") if pose else ())
    return {k: np.array(log[k]) for k in keys}


@functools.lru_cache(maxsize=None)
def in_si(name):
    return run(velocities(simulated(name)))


@pytest.mark.parametrize("name", robots.names())
def test_a_log_in_si_units_raises_no_unit_warning(name):
    _, said = in_si(name)
    assert not [w for w in said if "look like they are both in a unit" in w], said


@pytest.mark.parametrize("unit", SHARED)
@pytest.mark.parametrize("name", robots.names())
def test_both_sides_in_one_wrong_unit_are_warned_and_the_fix_named_recovers_the_robot(
        name, unit):
    cols, factor = SHARED[unit]
    log = velocities(simulated(name))
    for c in cols:
        log[c] = log[c] * factor
    res, said = run(log)
    # the steady gains cannot show it: theta1, theta2, theta4, theta6 as in SI units
    right, _ = in_si(name)
    for i in (0, 1, 3, 5):
        assert res.theta.theta[i] == pytest.approx(right.theta.theta[i], rel=1e-6)
    found = [w for w in said if "look like they are both in a unit" in w]
    assert len(found) == 1 and f"{cols[0]} and {cols[1]}" in found[0], said
    fix = re.search(rf"in {re.escape(unit)}\? pass scale=(\{{[^}}]*\}})", found[0])
    assert fix, found[0]
    fixed, said = run(log, scale=ast.literal_eval(fix.group(1)))
    same_robot(fixed, right)
    assert not [w for w in said if "look like they are both in a unit" in w]


def test_the_bounds_hold_for_every_preset_by_a_margin():
    """The physical bounds the check uses, against the presets' own parameters
    (Section 2: |theta3|/theta1 <= |b|) and their speed limits (1.5 m/s at most)."""
    for name in robots.names():
        th = robots.get(name).theta
        assert abs(th[2]) / th[0] < B_MAX / 5
        length = math.sqrt(abs(th[2] * th[1] / (th[0] * th[4])))
        assert L_MIN * 2 < length < L_MAX / 3, name
    assert U_MAX >= 2 * 1.5 and W_MAX > math.pi


def swap(log, *pairs):
    out = dict(log)
    for a, b in pairs:
        out[a], out[b] = log[b], log[a]
    return out


MEASURED, COMMANDS = ("u", "w"), ("u_ref", "w_ref")
POSES = {"none": None, "m, rad": (1.0, False), "mm, rad": (1000.0, False),
         "m, deg": (1.0, True), "mm, deg": (1000.0, True)}


@pytest.mark.parametrize("pose", POSES)
@pytest.mark.parametrize("pairs", [(MEASURED,), (COMMANDS,), (MEASURED, COMMANDS)],
                         ids=["measured", "commands", "both"])
@pytest.mark.parametrize("name", ["p3dx", "khepera3", "wheelchair_55kg", "robulab10"])
def test_exchanged_columns_are_refused_in_any_unit_of_the_pose_and_the_fix_is_right(
        name, pairs, pose):
    log = velocities(simulated(name), pose=POSES[pose] is not None)
    if POSES[pose] is not None:
        length, degrees = POSES[pose]
        log["x"], log["y"] = log["x"] * length, log["y"] * length
        if degrees:
            log["psi"] = np.degrees(np.angle(np.exp(1j * log["psi"])))  # wrapped, in deg
    bad = swap(log, *pairs)
    with pytest.raises(ValidationError, match="look exchanged") as err:
        run(bad)
    text = str(err.value)
    assert "\n" not in text
    mapping = ast.literal_eval(re.search(r"columns=(\{[^}]*\})", text).group(1))
    expected = {}
    for a, b in pairs:
        expected.update({a: b, b: a})
    assert mapping == expected
    fixed, _ = run(bad, columns=mapping)
    right, _ = in_si(name)
    same_robot(fixed, right)


def test_a_log_that_cannot_tell_says_so_and_names_both_fixes():
    """Without a pose, a robot that drives forwards and backwards as much as it turns
    either way: shapes cannot tell u from w. Commands paired crosswise are refused
    with both mappings; named alike, a warning says the log cannot tell."""
    truth = robots.get("p3dx")
    exc = ident.excitation(T, DT, robot=truth, seed=3, u_mean=0.0)
    log = velocities(ident.simulate_log(truth, exc, noise_std=NOISE, seed=1,
                                        commands="held"))
    with pytest.raises(ValidationError, match="cannot tell which") as err:
        run(swap(log, COMMANDS))
    text = str(err.value)
    fixes = [ast.literal_eval(f) for f in re.findall(r"columns=(\{[^}]*\})", text)]
    assert fixes == [{"u_ref": "w_ref", "w_ref": "u_ref"}, {"u": "w", "w": "u"}]
    right, said = run(log)
    assert [w for w in said if "cannot tell u from w" in w]
    fixed, _ = run(swap(log, COMMANDS), columns=fixes[0])  # the commands were exchanged
    same_robot(fixed, right)


def test_a_singular_fit_is_one_line_naming_the_likely_cause():
    with pytest.raises(ValidationError, match="exchanged or in different units") as err:
        with fit_refused():
            np.linalg.eigvals(np.array([[np.nan, 1.0], [1.0, 0.0]]))
    assert "\n" not in str(err.value) and "Eq. (2)" in str(err.value)


def _csv(path, log, header):
    keys = list(log)
    with open(path, "w") as fh:
        fh.write(",".join(header) + "\n")
        for row in zip(*(log[k] for k in keys)):
            fh.write(",".join(f"{v:.10g}" for v in row) + "\n")


@pytest.mark.slow
@pytest.mark.parametrize("case", ["measured, with a pose", "commands, no pose, --no-validate"])
def test_the_command_line_fix_it_suggests_is_the_right_one(tmp_path, case):
    """``unidyn identify`` on a CSV whose header names columns the wrong way round:
    one line, whose ``--columns`` (followed as printed) identifies the robot."""
    import shlex
    import subprocess
    import sys
    log = velocities(simulated("p3dx"), pose=case.startswith("measured"))
    header = list(log)
    pair = MEASURED if case.startswith("measured") else COMMANDS
    i, j = header.index(pair[0]), header.index(pair[1])
    header[i], header[j] = header[j], header[i]
    _csv(tmp_path / "log.csv", log, header)
    extra = ["--no-validate"] if "no-validate" in case else []

    def identify(*more):
        p = subprocess.run([sys.executable, "-m", "unidyn", "identify", "log.csv",
                            "--commands", "linear", *extra, *more], cwd=tmp_path,
                           capture_output=True, text=True, timeout=600,
                           env={**__import__("os").environ, "MPLBACKEND": "Agg"})
        return p.returncode, p.stdout, p.stderr
    code, _, err = identify("--out", "first")
    assert code == 2 and len(err.strip().splitlines()) == 1 and "Traceback" not in err, err
    fix = re.search(r"--columns (\S+)", err)
    assert fix and fix.group(1) == f"{pair[0]}={pair[1]},{pair[1]}={pair[0]}", err
    code, out, err = identify("--out", "fixed", *shlex.split(f"--columns {fix.group(1)}"))
    assert code == 0, err
    theta = json.loads((tmp_path / "fixed" / "theta.json").read_text())
    truth = robots.get("p3dx").theta
    for k in (1, 2, 4, 6):  # not exchanged: theta1 with theta2, theta4 with theta6
        assert theta[f"theta{k}"] == pytest.approx(truth[k - 1], rel=0.15), (k, theta)


@pytest.mark.parametrize("unit", SHARED)
def test_a_pose_in_m_and_radians_names_slow_velocities_in_other_units(unit):
    """Velocities too slow for their range to show the unit (a robot creeping at
    1.5 cm/s, turning at 0.04 rad/s), beside a pose in m and rad: the pose gives the
    speeds in its own units, and the warning names the unit and a fix that works (in
    mm/s the range shows it too)."""
    truth = robots.get("p3dx")
    exc = ident.excitation(T, DT, robot=truth, seed=0, amplitude=0.02)
    log = velocities(ident.simulate_log(truth, exc, noise_std=NOISE / 20, seed=1,
                                        commands="held"), pose=True)
    right, said = run(log)
    assert not [w for w in said if "look like they are both in a unit" in w], said
    cols, factor = SHARED[unit]
    for c in cols:
        log[c] = log[c] * factor
    _, said = run(log)
    found = [w for w in said if "look like they are both in a unit" in w]
    assert len(found) == 1, said
    pose_only = found[0].split("(", 1)[1].split("), so")[0]  # the evidence
    assert "from the pose" in pose_only or "from psi" in pose_only, found
    assert unit == "mm/s" or "reaches" not in pose_only, found
    fix = re.search(rf"in {re.escape(unit)}\? pass scale=(\{{[^}}]*\}})", found[0])
    fixed, _ = run(log, scale=ast.literal_eval(fix.group(1)))
    same_robot(fixed, right)
