"""``unidyn identify`` on logs as robots write them: held commands at 10 Hz, a gap,
a byte-order mark, extra columns, several files; results written all-or-nothing.

The logs come from ``identification.simulate_log(commands="held")`` (scipy's
DOP853 restarted at every sample; checked against an independent reference in
``test_identification_held.py``) for a robot that is not a preset.
"""

from __future__ import annotations

import functools
import json

import numpy as np
import pytest

from unidyn import RobotParameters
from unidyn import identification as ident
from unidyn.cli import main

ROBOT = RobotParameters.from_physical(m=30.0, Iz=1.2, b=0.05, d=0.33, r=0.0975, Ra=0.71,
                                      ka=0.461, kb=0.461, Be=0.0, Ie=0.0027, kPT=100.0,
                                      kDT=16.0, kPR=100.0, kDR=16.0, name="cart")
POSITIVE = [0, 1, 3, 5]


def run(capsys, *argv):
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


def one_line_error(err, *words):
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("unidyn: error: "), err
    for w in words:
        assert w in lines[0], (w, err)


@functools.lru_cache(maxsize=None)
def held_log(seed=0, T=90.0, dt=0.1):
    exc = ident.excitation(T, dt, robot=ROBOT, seed=seed)
    return ident.simulate_log(ROBOT, exc, noise_std=0.01, seed=seed + 1, commands="held")


def write(path, log, keep=None, encoding="utf-8-sig", names=ident.COLUMNS):
    keep = np.ones(log["t"].size, bool) if keep is None else keep
    lines = [",".join(list(names) + ["battery", "note"])]
    for k in np.flatnonzero(keep):
        lines.append(",".join(repr(float(log[c][k])) for c in ident.COLUMNS) + ",12.1,ok")
    path.write_bytes(("\n".join(lines) + "\n").encode(encoding))
    return path


def test_held_10_hz_log_with_a_gap_and_a_bom_needs_no_option(tmp_path, capsys):
    log = held_log()
    p = write(tmp_path / "robot.csv", log, keep=(log["t"] < 40) | (log["t"] >= 46))
    assert p.read_bytes()[:3] == b"\xef\xbb\xbf"
    code, out, err = run(capsys, "identify", p, "--out", tmp_path / "I")
    assert code == 0, err
    theta = json.loads((tmp_path / "I" / "theta.json").read_text())
    est = np.array([theta[f"theta{i}"] for i in range(1, 7)])
    assert np.all(np.abs(est - ROBOT.theta)[POSITIVE] / ROBOT.theta[POSITIVE] < 0.04)
    assert theta["commands"] == "held" and theta["segments"] == 2
    assert "2 piece(s) of 1 log(s)" in out and "validation on the same log(s)" in out
    assert (tmp_path / "I" / "validation.png").exists()
    assert json.loads((tmp_path / "I" / "validation.json").read_text())["in_sample"] is True


def test_failed_identification_keeps_the_old_results(tmp_path, capsys):
    good = write(tmp_path / "good.csv", held_log())
    out = tmp_path / "I"
    assert run(capsys, "identify", good, "--out", out, "--no-validate")[0] == 0
    before = (out / "theta.json").read_bytes()
    bad = tmp_path / "bad.csv"
    text = good.read_text(encoding="utf-8-sig").splitlines()
    cells = text[30].split(",")
    cells[1] = "oops"
    text[30] = ",".join(cells)
    bad.write_text("\n".join(text))
    code, _, err = run(capsys, "identify", bad, "--overwrite", "--out", out)
    assert code == 2
    notice, err = err.split("\n", 1)  # --overwrite says first what it would replace
    assert notice.startswith("unidyn: replacing") and "kept as they are if it fails" in notice
    one_line_error(err, "bad.csv line 31, column 'u_ref'")
    assert (out / "theta.json").read_bytes() == before
    assert sorted(p.name for p in out.iterdir()) == [".unidyn-identify.json", "theta.json"]
    # without --overwrite nothing is replaced either, and the message says how
    code, _, err = run(capsys, "identify", good, "--out", out)
    assert code == 2
    one_line_error(err, "--overwrite")


def test_several_logs_no_validate_columns_and_convention(tmp_path, capsys):
    a = write(tmp_path / "a.csv", held_log(0), names=("time", "v_cmd", "w_cmd", "v", "w"))
    b = write(tmp_path / "b.csv", held_log(1, T=60.0), names=("time", "v_cmd", "w_cmd", "v", "w"),
              encoding="latin-1")
    code, _, err = run(capsys, "identify", a, b, "--out", tmp_path / "x")
    assert code == 2
    one_line_error(err, "a.csv", "missing column(s) 't', 'u_ref'", "--columns t=...")
    cols = "t=time,u_ref=v_cmd,w_ref=w_cmd,u=v"
    code, out, err = run(capsys, "identify", a, b, "--columns", cols, "--no-validate",
                         "--out", tmp_path / "I")
    assert code == 0, err
    assert sorted(p.name for p in (tmp_path / "I").iterdir()) == [".unidyn-identify.json",
                                                                   "theta.json"]
    theta = json.loads((tmp_path / "I" / "theta.json").read_text())
    assert theta["n_logs"] == 2 and theta["segments"] == 2
    # the wrong convention is named in the command line's own words
    code, out, err = run(capsys, "identify", a, "--columns", cols, "--commands", "linear",
                         "--no-validate", "--out", tmp_path / "L")
    assert code == 0, err
    assert "--commands held" in out and "commands='held'" not in out


@pytest.mark.parametrize("argv,words", [
    (["--columns", "t=time,speed=v"], ["--columns", "'speed'", "t, u_ref, w_ref, u, w"]),
    (["--columns", "t"], ["--columns", "NAME=COLUMN", "'t'"]),
    (["--columns", "t=a,t=b"], ["--columns", "'t' twice"]),
    (["--delay", "soon"], ["--delay", "'soon'"]),
    (["--delay", "-1"], ["--delay"]),
    (["--delay", "1e9"], ["--delay", "a third of the longest piece"]),  # longer than the log
    (["--validate", "nothere.csv"], ["nothere.csv"]),
    (["--commands", "zoh"], ["--commands", "zoh"]),
    (["--gap", "0"], ["gap", "> 0"]),
    (["--gap", "nan"], ["gap"]),
])
def test_bad_options_name_the_option(tmp_path, capsys, argv, words):
    p = write(tmp_path / "a.csv", {k: v[:100] for k, v in held_log().items()})
    code, _, err = run(capsys, "identify", p, *argv, "--out", tmp_path / "I")
    assert code == 2
    one_line_error(err, *words)
    assert not (tmp_path / "I" / "theta.json").exists()


def test_delay_auto_on_the_command_line(tmp_path, capsys):
    exc = ident.excitation(60.0, 0.05, robot=ROBOT, seed=2)
    log = ident.simulate_log(ROBOT, exc, noise_std=0.01, seed=3, commands="held", delay=0.05)
    p = write(tmp_path / "late.csv", log)
    code, out, err = run(capsys, "identify", p, "--delay", "auto", "--no-validate",
                         "--out", tmp_path / "I")
    assert code == 0, err
    theta = json.loads((tmp_path / "I" / "theta.json").read_text())
    assert theta["delay"] == pytest.approx(0.05, abs=0.01)


def test_gap_sets_where_a_log_is_split(tmp_path, capsys):
    """A 5 s gap splits the log by default; --gap 10 keeps it whole (one piece, its
    held command bridging the gap), --gap 0.15 splits it too."""
    t = held_log()["t"]
    keep = np.ones(t.size, bool)
    keep[(t > 40.0) & (t < 45.0)] = False
    p = write(tmp_path / "gap.csv", held_log(), keep)
    pieces = {}
    for gap in (None, "10", "0.15"):
        argv = [] if gap is None else ["--gap", gap]
        code, _, err = run(capsys, "identify", p, *argv, "--no-validate", "--out",
                           tmp_path / f"I{gap}")
        assert code == 0, err
        pieces[gap] = json.loads((tmp_path / f"I{gap}" / "theta.json").read_text())["segments"]
    assert pieces == {None: 2, "10": 1, "0.15": 2}


def test_overwrite_says_first_what_it_replaces_and_leaves_no_stale_file(tmp_path, capsys):
    """--overwrite names the files it will replace before it starts; the new results
    replace the whole set, so no validation of the earlier identification stays beside
    the new theta.json."""
    p = write(tmp_path / "a.csv", held_log())
    code, _, err = run(capsys, "identify", p, "--out", tmp_path / "I")
    assert code == 0, err
    assert (tmp_path / "I" / "validation.json").exists()
    code, _, err = run(capsys, "identify", p, "--out", tmp_path / "I")
    assert code == 2 and "--overwrite" in err  # refused: nothing replaced silently
    code, out, err = run(capsys, "identify", p, "--no-validate", "--overwrite",
                         "--out", tmp_path / "I")
    assert code == 0, err
    assert "replacing" in err and "theta.json, validation.json, validation.png" in err
    assert "replaced   the previous theta.json, validation.json, validation.png" in out
    assert sorted(f.name for f in (tmp_path / "I").iterdir()) == [".unidyn-identify.json",
                                                                   "theta.json"]


def test_identify_tells_its_steps_and_ends_with_what_it_wrote_and_the_time(tmp_path, capsys,
                                                                          monkeypatch):
    """Off a terminal, a line as each step (the fit, the validation, its figure) ends
    (here without the first second's quiet), then a line with the steps' time; the
    summary ends with the wall time and the files written."""
    from unidyn import progress
    monkeypatch.setattr(progress, "QUIET", 0.0)
    log = write(tmp_path / "run.csv", held_log(T=30.0))
    code, out, err = run(capsys, "identify", log, "--out", tmp_path / "id")
    assert code == 0, err
    steps = [line for line in err.splitlines() if line.startswith("unidyn identify:")]
    assert [s.split(" (")[0] for s in steps[:3]] == [
        f"unidyn identify: {k} of 3 steps" for k in (1, 2, 3)]
    assert steps[-1].startswith("unidyn identify: 3 steps in ")
    tail = out.strip().splitlines()[-3:]
    assert tail[0].startswith("wall time  ") and float(tail[0].split()[2]) > 0
    assert tail[1:] == [f"written    {tmp_path / 'id' / 'theta.json'}",
                        f"written    {tmp_path / 'id' / 'validation.json'}, "
                        f"{tmp_path / 'id' / 'validation.png'}"]
    # without the validation: one step
    code, out, err = run(capsys, "identify", log, "--out", tmp_path / "id2", "--no-validate")
    assert code == 0 and "unidyn identify: 1 step in " in err
    assert out.strip().splitlines()[-2].startswith("wall time  ")
