"""Sweeps: spec and grid expansion, TOML errors, resumable runs, the Dask route,
the paper's Fig. 11 sweep and its claims."""

import csv
import io
import json
import math
import os
import re
import sys

import numpy as np
import pytest

import unidyn
from unidyn import ValidationError
from unidyn._errors import Interrupted
from unidyn.cli import main
from unidyn.engine.batch import simulate_batch
from unidyn.model import robots
from unidyn.paper import fig11_claims, format_fig11_claims, paper_fig11
from unidyn.results import folders as outdir
from unidyn.sweeps import sweep as sw
from unidyn.sweeps import sweep_files as files
from unidyn.sweeps.sweep import Sweep, run_sweep
from unidyn.sweeps.sweep_files import read_metrics, rows_text

SHORT = {"T": 1.0}


def small_sweep(**kw):
    """Eight points of one second each: two variants x two gains x two seeds."""
    return Sweep(base={**SHORT, "case": "compensated"},
                 grid={"kxy": [0.5, 2.0], "seed": [0, 1]},
                 variants=[{"label": "exact", "theta_hat_scale": 1.0},
                           {"label": "off", "theta_hat_scale": 0.8}], name="small", **kw)


def csv_rows(path):
    return (path / "metrics.csv").read_text().splitlines()


# ------------------------------------------------------------------ spec and grid

def test_grid_expansion_order_and_special_axes():
    s = Sweep(base={"T": 2, "case": "adaptive"},
              grid={"kxy": {"start": 0.5, "stop": 2.0, "step": 0.5}, "seed": [0, 1, 2]},
              variants=[{"label": "p", "theta_hat_scale": 0.9}, {"label": "q", "robot": "p3dx"}])
    pts = s.points()
    assert len(s) == len(pts) == 2 * 4 * 3
    assert [p.index for p in pts] == list(range(24))
    # variants slowest, then the axes in order, the last fastest
    assert pts[0].params == {"variant": "p", "kxy": 0.5, "seed": 0}
    assert pts[1].params == {"variant": "p", "kxy": 0.5, "seed": 1}
    assert pts[3].params == {"variant": "p", "kxy": 1.0, "seed": 0}
    assert pts[12].params == {"variant": "q", "kxy": 0.5, "seed": 0}
    i, params, sc = pts[5]
    assert (sc.kx, sc.ky) == (1.0, 1.0) and sc.noise.seed == 2 and sc.T == 2.0
    np.testing.assert_allclose(sc.theta_hat_initial, 0.9 * robots.get("p3dx_laser").theta,
                               rtol=1e-15)
    q = pts[12].scenario
    assert q.robot.name == "p3dx" and q.theta_hat0 is None
    np.testing.assert_allclose(q.theta_hat_initial, robots.get("p3dx").theta / 1.5)
    assert s.columns == ["index", "variant", "kxy", "seed", "case", "iae", "ise", "itae",
                         "itse", "energy", "error_final", "peak_error", "numerical_error",
                         "estimate", "sensitive", "complete", "message"]
    # the same spec gives the same points, and round-trips through plain data
    assert Sweep.from_dict(json.loads(json.dumps(s.to_dict()))) == s


def test_ranges_are_clean_numbers():
    s = Sweep(base=SHORT, grid={"kx": {"start": 0.1, "stop": 0.5, "step": 0.1},
                                "ky": {"start": 0.1, "stop": 10, "num": 3, "log": True}})
    assert s.grid["kx"] == (0.1, 0.2, 0.3, 0.4, 0.5)
    assert s.grid["ky"] == (0.1, 1.0, 10.0)
    assert "case" in s.columns and len(s) == 15


def test_case_axis_is_one_column():
    s = Sweep(base=SHORT, grid={"case": ["uncompensated", "compensated"]})
    assert s.columns.count("case") == 1
    assert [p.scenario.case for p in s.points()] == ["uncompensated", "compensated"]


def test_sweep_from_toml(tmp_path):
    f = tmp_path / "s.toml"
    f.write_text('name = "t"\nrtol = 1e-6\n[base]\ncase = "compensated"\nT = 1\nnoise = "off"\n'
                 '[grid]\nkxy = {start = 0.5, stop = 1.5, step = 0.5}\n'
                 'theta_hat_scale = [0.9, 1.0]\n[[variants]]\nlabel = "a"\n'
                 '[[variants]]\nlabel = "b"\nku = 2.0\n')
    s = Sweep.from_toml(f)
    assert len(s) == 12 and s.rtol == 1e-6 and s.name == "t"
    assert s.points()[-1].scenario.ku == 2.0 and s.points()[0].scenario.noise is None


@pytest.mark.parametrize("text, words", [
    ("[grid]\nkxy = [0.5, \nname = 'x'\n", ["malformed TOML", "line 3"]),
    ("color = 1\n", ["unknown sweep key 'color'"]),
    ("[base]\nkz = 1\n", ["base", "'kz'"]),
    ("[grid]\nkxz = [1]\n", ["grid", "'kxz'"]),
    ("[grid]\nkz = [1]\n", ["grid", "'kz' (did you mean"]),
    ("[grid]\nkxy = 3\n", ["grid.kxy", "list"]),
    ("[grid]\nkxy = []\n", ["grid.kxy", "empty"]),
    ("[grid]\nkxy = [1, 'fast']\n", ["kxy", "real number", "'fast'"]),
    ("[grid]\nkxy = [1, -2]\n", ["kxy", "> 0"]),
    ("[grid]\nkxy = {start = 1, stop = 2}\n", ["grid.kxy", "step"]),
    ("[grid]\nkxy = {start = 1, stop = 2, step = 0}\n", ["grid.kxy.step", "> 0"]),
    ("[grid]\nkxy = {start = 2, stop = 1, step = 1}\n", ["grid.kxy", "stop"]),
    ("[grid]\nkxy = {start = 1, stop = 2, stp = 1}\n", ["grid.kxy", "'stp'"]),
    ("[grid]\nT = [1, 1]\n", ["grid.T", "twice"]),
    ("[grid]\nseed = [1.5]\n", ["seed", "integer"]),
    ("[base]\nkx = 0.2\n[grid]\nkxy = [1]\n", ["kxy", "kx", "both"]),
    ("[base]\nnoise = 'off'\n[grid]\nseed = [1]\n", ["seed", "noise is off"]),
    ("[[variants]]\nku = 1\n", ["variants[0]", "label"]),
    ("[base]\ncontrol = 'sampled'\nvd_dot = 'analytic'\n", ["vd_dot", "sampled"]),
])
def test_bad_sweep_files_name_the_key(tmp_path, capsys, text, words):
    f = tmp_path / "bad.toml"
    f.write_text(text)
    with pytest.raises(ValidationError) as exc:
        Sweep.from_toml(f)
    for w in words:
        assert w in str(exc.value), (w, str(exc.value))
    code = main(["sweep", str(f), "--out", str(tmp_path / "o"), "--no-progress"])
    out, err = capsys.readouterr()
    assert code == 2
    assert len(err.strip().splitlines()) == 1 and err.startswith("unidyn: error: ")
    assert "Traceback" not in err
    assert not (tmp_path / "o").exists()


def test_paper_fig11_spec():
    s = paper_fig11()
    assert len(s) == 4 * 70
    assert s.grid["kxy"] == tuple(0.5 * np.arange(1, 71))
    assert [v["label"] for v in s.variants] == ["a", "b", "c", "d"]
    theta = robots.get("p3dx_laser").theta
    by = {}
    for _, params, sc in s.points():
        by.setdefault(params["variant"], []).append(sc)
        assert sc.kx == sc.ky == params["kxy"]
        assert sc.T == 250.0 and sc.robot.name == "p3dx_laser" and sc.control == "continuous"
        assert sc.noise == unidyn.NoiseSpec()  # the paper's stated noise
        assert sc.limits == unidyn.PAPER_LIMITS and sc.lx == sc.ly == 0.1
        assert (sc.ku, sc.kw, sc.lu, sc.lw) == (4.0, 4.0, 1.0, 1.0)
    assert {sc.case for sc in by["a"]} == {"uncompensated"}
    assert {sc.case for sc in by["b"]} == {"compensated"}
    assert {sc.case for sc in by["c"]} == {"adaptive"}
    assert {sc.case for sc in by["d"]} == {"compensated"}
    assert {sc.adapt_from for sc in by["c"]} == {0.0}
    for label, scale in (("b", 0.9), ("c", 0.9), ("d", 1.0)):
        for sc in by[label]:
            np.testing.assert_allclose(sc.theta_hat_initial, scale * theta, rtol=1e-15)
    quiet = paper_fig11(T=10, gains=[1, 2], noise=None)
    assert len(quiet) == 8 and all(p.scenario.noise is None for p in quiet.points())
    assert all(p.scenario.T == 10 for p in quiet.points())


# ------------------------------------------------------------------------ running

def test_run_sweep_writes_one_row_per_point(tmp_path):
    s = small_sweep()
    run = run_sweep(s, tmp_path, chunk_size=3, progress=False)
    assert run.ran == 8 and run.skipped == 0 and run.failed == []
    lines = csv_rows(tmp_path)
    assert lines[0].split(",") == s.columns and len(lines) == 1 + 8
    rows = read_metrics(tmp_path)
    assert [r["index"] for r in rows] == list(range(8))
    assert rows[5]["variant"] == "off" and rows[5]["kxy"] == 0.5 and rows[5]["seed"] == 1
    assert all(r["case"] == "compensated" and r["complete"] is True for r in rows)
    # the numbers are the batch engine's for each scenario
    direct = simulate_batch([p.scenario for p in s.points()])
    for r, d in zip(rows, direct):
        for m in files.METRICS:
            assert r[m] == d.metrics[m]
    spec = json.loads((tmp_path / "sweep.json").read_text())
    assert spec["sweep"] == s.to_dict() and spec["engine"] == "batch"
    assert spec["unidyn_version"] == unidyn.__version__ and spec["finished"] is True
    assert (tmp_path / "metrics.png").stat().st_size > 1000


def test_interrupted_sweep_resumes_with_identical_results(tmp_path, monkeypatch):
    s = small_sweep()
    run_sweep(s, tmp_path / "whole", chunk_size=2, progress=False)

    real = sw._run_chunk
    calls = []

    def crash_after_first_chunk(*args, **kw):
        calls.append(1)
        if len(calls) > 1:
            raise RuntimeError("simulated crash")
        return real(*args, **kw)

    monkeypatch.setattr(sw, "_run_chunk", crash_after_first_chunk)
    with pytest.raises(RuntimeError, match="simulated crash") as exc:
        run_sweep(s, tmp_path / "cut", chunk_size=2, progress=False)
    assert any("2 of 8 points are in" in note for note in exc.value.__notes__)  # traceback
    kept = csv_rows(tmp_path / "cut")
    assert len(kept) == 1 + 2  # header and the first chunk
    assert json.loads((tmp_path / "cut" / "sweep.json").read_text())["finished"] is False
    monkeypatch.setattr(sw, "_run_chunk", real)

    ran = []
    monkeypatch.setattr(sw, "_run_chunk", lambda pts, *a: ran.extend(p[0] for p in pts)
                        or real(pts, *a))
    run = run_sweep(s, tmp_path / "cut", chunk_size=2, progress=False)
    assert run.skipped == 2 and run.ran == 6 and sorted(ran) == list(range(2, 8))
    assert csv_rows(tmp_path / "cut") == csv_rows(tmp_path / "whole")
    # nothing left to do
    ran.clear()
    again = run_sweep(s, tmp_path / "cut", chunk_size=2, progress=False)
    assert again.ran == 0 and again.skipped == 8 and ran == []


def _interrupted(s, out, chunks, monkeypatch, chunk_size):
    """Run ``s`` into ``out`` and stop it with Ctrl-C after ``chunks`` chunks."""
    real, calls = sw._run_chunk, []

    def stopping(*args, **kwargs):
        if len(calls) == chunks:
            raise KeyboardInterrupt
        calls.append(1)
        return real(*args, **kwargs)
    with monkeypatch.context() as m:
        m.setattr(sw, "_run_chunk", stopping)
        with pytest.raises(Interrupted, match="run the same command again to resume"):
            run_sweep(s, out, progress=False, chunk_size=chunk_size)


def test_an_interrupted_sweep_resumes_and_an_edited_one_is_refused(tmp_path, monkeypatch):
    s = small_sweep()
    run_sweep(s, tmp_path / "whole", progress=False)
    cut = tmp_path / "cut"
    _interrupted(s, cut, 2, monkeypatch, chunk_size=3)  # chunks of one point's two seeds
    assert len(csv_rows(cut)) == 1 + 4
    run = run_sweep(s, cut, progress=False)
    assert run.skipped == 4 and run.ran == 4
    assert csv_rows(cut) == csv_rows(tmp_path / "whole")
    lines = csv_rows(cut)  # a line cut short by hand: not what unidyn wrote
    (cut / "metrics.csv").write_text("\n".join(lines[:6]) + "\n" + lines[6][:12])
    before = (cut / "metrics.csv").read_bytes()
    for overwrite in (False, True):
        with pytest.raises(ValidationError, match="metrics.csv, named like unidyn's sweep"):
            run_sweep(s, cut, progress=False, overwrite=overwrite)
    assert (cut / "metrics.csv").read_bytes() == before


LOOKALIKE = ["null", "1.50", "007", "Infinity", "true", "[1]", 'say "hi"', "x,y",
             '=HYPERLINK("http://example.com")', "+1", "-x", "@SUM(A1)", "'quoted"]


def test_labels_and_strings_that_look_like_numbers_stay_as_written(tmp_path, monkeypatch):
    """A variant's label is text: "007" is not 7.0, "null" not empty, and a resumed
    sweep's metrics.csv is byte for byte that of an uninterrupted one."""
    s = Sweep(base={"T": 0.3, "noise": "off", "case": "kinematic"}, grid={"kx": [1.0, 2.0]},
              variants=[{"label": lab} for lab in LOOKALIKE])
    whole = run_sweep(s, tmp_path / "whole", progress=False)
    text = (tmp_path / "whole" / "metrics.csv").read_bytes()
    assert [r["variant"] for r in read_metrics(tmp_path / "whole")] == [
        lab for lab in LOOKALIKE for _ in range(2)]
    assert [r["variant"] for r in whole.rows] == [lab for lab in LOOKALIKE for _ in range(2)]
    again = run_sweep(s, tmp_path / "whole", progress=False)
    assert (again.ran, (tmp_path / "whole" / "metrics.csv").read_bytes()) == (0, text)
    cut = tmp_path / "cut"
    _interrupted(s, cut, 2, monkeypatch, chunk_size=3)
    assert run_sweep(s, cut, progress=False).ran == len(LOOKALIKE) * 2 - 6
    assert (cut / "metrics.csv").read_bytes() == text


def test_text_cells_that_spreadsheets_would_run_as_formulas_are_written_as_text(tmp_path):
    """OWASP's CSV-injection rule: a text cell starting with = + - @ (or the quote
    itself) gets a leading quote, which spreadsheets show as text; unidyn reads the
    label back as it was given."""
    labels = ['=HYPERLINK("http://example.com","x")', "+cmd", "-2+3", "@A1", "'x", "plain"]
    s = Sweep(base={"T": 0.3, "noise": "off", "case": "kinematic"}, grid={"kx": [1.0]},
              variants=[{"label": lab} for lab in labels])
    run_sweep(s, tmp_path / "o", progress=False)
    with open(tmp_path / "o" / "metrics.csv", newline="") as fh:
        cells = [row[1] for row in list(csv.reader(fh))[1:]]
    assert cells == ["'" + lab for lab in labels[:5]] + ["plain"]
    assert [r["variant"] for r in read_metrics(tmp_path / "o")] == labels


@pytest.mark.parametrize("bad", ["a\rb", "a\u2028b", "a\tb", "a\nb", ""])
def test_a_label_with_a_line_break_or_control_is_refused(bad):
    with pytest.raises(ValidationError, match=r"variants\[0\] needs a label .*one line"):
        Sweep(base=SHORT, grid={"kx": [1.0]}, variants=[{"label": bad}])


def test_a_grid_value_given_twice_as_int_and_float_is_refused():
    with pytest.raises(ValidationError, match=r"grid.kx has the value 1.0 twice"):
        Sweep(base=SHORT, grid={"kx": [1, 1.0]})


def test_string_grid_values_round_trip_through_metrics_csv(tmp_path):
    from unidyn.sweeps.sweep_files import cell, read_rows
    for v in LOOKALIKE + ["p3dx_laser", "", 1.5, 7, None, [1, 2]]:
        buf = rows_text(["index", "v", "iae", "complete"],
                        [{"index": 0, "v": v, "iae": 1.0, "complete": True}])
        (tmp_path / "m.csv").write_text(buf)
        rows, clean = read_rows(tmp_path / "m.csv", ["index", "v", "iae", "complete"])
        assert clean and rows[0]["v"] == v, (v, cell(v), rows)


CRASH = RuntimeError("simulated crash")


def crash_after(monkeypatch, n_chunks, exc=CRASH):
    """Make run_sweep's chunk runner raise after ``n_chunks`` real chunks."""
    real = sw._run_chunk
    calls = []

    def run(*args, **kw):
        calls.append(1)
        if len(calls) > n_chunks:
            raise exc
        return real(*args, **kw)

    monkeypatch.setattr(sw, "_run_chunk", run)
    return lambda: monkeypatch.setattr(sw, "_run_chunk", real)


def test_a_different_sweep_in_the_same_folder_is_refused(tmp_path):
    run_sweep(small_sweep(), tmp_path, progress=False)
    before = (tmp_path / "metrics.csv").read_bytes()
    other = small_sweep().with_base(T=2.0)
    with pytest.raises(ValidationError, match="different sweep") as exc:
        run_sweep(other, tmp_path, progress=False)
    assert "base.T" in str(exc.value) and "8 finished row(s)" in str(exc.value)
    # a Python message speaks Python (the command line's says --overwrite)
    assert "points 0-7" in str(exc.value) and "overwrite=True" in str(exc.value)
    with pytest.raises(ValidationError, match="another engine"):
        run_sweep(small_sweep(), tmp_path, engine="bdsim", progress=False)
    # starting over deletes finished rows, so it needs overwrite too
    for s in (other, small_sweep()):
        with pytest.raises(ValidationError, match="8 finished row") as exc:
            run_sweep(s, tmp_path, resume=False, progress=False)
        assert "overwrite" in str(exc.value)
    assert (tmp_path / "metrics.csv").read_bytes() == before
    run = run_sweep(other, tmp_path, overwrite=True, progress=False)
    assert run.ran == 8 and run.replaced == tuple(range(8)) and len(csv_rows(tmp_path)) == 9
    assert json.loads((tmp_path / "sweep.json").read_text())["sweep"]["base"]["T"] == 2.0
    assert [p.name for p in tmp_path.parent.iterdir() if p.name.startswith(f".{tmp_path.name}")] == []


def test_sweep_id_is_the_definition_not_the_engine_or_columns():
    a, b = small_sweep(), small_sweep()
    assert sw.sweep_id(a) == sw.sweep_id(b) and sw.sweep_id(a).startswith("sha256:")
    changed = [a.with_base(T=2.0), small_sweep(rtol=1e-7), a.with_base(robot="p3dx"),
               a.with_base(log_dtype="float32")]
    ids = {sw.sweep_id(s) for s in changed} | {sw.sweep_id(a)}
    assert len(ids) == 5  # same columns, different sweeps
    assert all(s.columns == a.columns for s in changed)


def test_a_label_that_looks_like_a_number_keeps_its_text():
    """Labels are text in point names and legends as in metrics.csv: a first label
    "1.50" names its points "variant=1.50", and "1.5" is another sweep."""
    def sweep(label):
        return Sweep(base={"T": 0.3, "noise": "off", "case": "kinematic"},
                     grid={"kx": [1.0, 2.0]}, variants=[{"label": label}, {"label": "b"}])
    s = sweep("1.50")
    assert s.points()[0].scenario.name == "#0 (variant=1.50, kx=1.0)"
    assert sw.sweep_id(s) != sw.sweep_id(sweep("1.5"))


def test_a_label_may_hold_any_printable_space():
    s = Sweep(base=SHORT, grid={"kx": [1.0]},
              variants=[{"label": "k\u00a0=\u202f1\u3000000"}])  # no-break and ideographic
    assert s.variants[0]["label"] == "k\u00a0=\u202f1\u3000000"


def test_rows_without_sweep_json_are_tied_to_their_sweep(tmp_path):
    s = small_sweep()
    run_sweep(s, tmp_path, chunk_size=3, progress=False)
    before = (tmp_path / "metrics.csv").read_bytes()
    (tmp_path / "sweep.json").unlink()
    other = s.with_base(T=2.0)  # the same columns, another T
    with pytest.raises(ValidationError, match="different sweep"):
        run_sweep(other, tmp_path, progress=False)
    run = run_sweep(s, tmp_path, progress=False)  # the same sweep still resumes
    assert run.skipped == 8 and run.ran == 0
    assert (tmp_path / "metrics.csv").read_bytes() == before
    (tmp_path / "sweep.json").unlink()
    (tmp_path / files.ID_NAME).unlink()
    for t in (s, other):  # rows with no record of their sweep are never adopted
        with pytest.raises(ValidationError, match="unknown origin") as exc:
            run_sweep(t, tmp_path, progress=False)
        assert "8 finished row(s)" in str(exc.value)
    assert (tmp_path / "metrics.csv").read_bytes() == before
    assert run_sweep(other, tmp_path, overwrite=True, progress=False).ran == 8


def test_an_interrupted_restart_keeps_the_old_rows(tmp_path, monkeypatch):
    out = tmp_path / "o"
    run_sweep(small_sweep(), out, chunk_size=2, progress=False)
    before = {p.name: p.read_bytes() for p in out.iterdir()}
    (out / "notes.txt").write_text("mine")
    restore = crash_after(monkeypatch, 2)
    for kw in ({"resume": False}, {}):
        with pytest.raises(RuntimeError, match="simulated crash"):
            run_sweep(small_sweep().with_base(T=2.0) if not kw else small_sweep().with_base(T=3.0),
                      out, chunk_size=2, progress=False, overwrite=True, **kw)
        assert {p.name: p.read_bytes() for p in out.iterdir() if p.name != "notes.txt"} == before
    for exc in (KeyboardInterrupt(),):
        restore()
        restore = crash_after(monkeypatch, 1, exc)
        with pytest.raises(Interrupted) as err:
            run_sweep(small_sweep(), out, chunk_size=2, resume=False, overwrite=True,
                      progress=False)
        assert "is as it was (8 finished row(s)" in err.value.kept  # the command prints it
        assert {p.name: p.read_bytes() for p in out.iterdir() if p.name != "notes.txt"} == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["o"]  # no staging folder left
    restore()
    run = run_sweep(small_sweep(), out, chunk_size=2, resume=False, overwrite=True,
                    progress=False)
    assert run.ran == 8 and (out / "notes.txt").read_text() == "mine"
    assert (out / "metrics.csv").read_bytes() == before["metrics.csv"]  # same sweep, same rows


def test_a_sweep_that_fails_before_its_first_row_leaves_nothing(tmp_path, monkeypatch):
    restore = crash_after(monkeypatch, 0)
    with pytest.raises(RuntimeError):
        run_sweep(small_sweep(), tmp_path / "new", progress=False)
    assert not (tmp_path / "new").exists()
    (tmp_path / "mine").mkdir()
    (tmp_path / "mine" / "notes.txt").write_text("x")
    with pytest.raises(RuntimeError):
        run_sweep(small_sweep(), tmp_path / "mine", progress=False)
    assert [p.name for p in (tmp_path / "mine").iterdir()] == ["notes.txt"]
    restore()


@pytest.mark.slow  # waits out Dask's connection timeout
def test_a_sweep_that_cannot_reach_its_cluster_leaves_nothing(tmp_path):
    pytest.importorskip("distributed")
    with pytest.raises(ValidationError, match="cannot connect"):
        run_sweep(small_sweep(), tmp_path / "dask", progress=False,
                  dask_address="tcp://127.0.0.1:9")
    assert not (tmp_path / "dask").exists()


def test_the_folder_lock_refuses_a_second_writer_and_names_its_pid(tmp_path):
    out = tmp_path / "o"
    out.mkdir()
    with outdir.FolderLock(out):
        assert f"pid {os.getpid()}" in (out / outdir.LOCK_NAME).read_text().splitlines()
        with pytest.raises(outdir.FolderInUse, match=f"PID {os.getpid()}") as exc:
            run_sweep(small_sweep(), out, progress=False)
        assert "another unidyn process" in str(exc.value)
        assert not (out / "metrics.csv").exists()
    assert not (out / outdir.LOCK_NAME).exists()  # released and removed
    # a lock file left by a unidyn process that is gone (no flock held) is taken over
    (out / outdir.LOCK_NAME).write_text(f"unidyn lock {'0' * 32}\npid 999999999\n")
    assert run_sweep(small_sweep(), out, progress=False).ran == 8
    assert not (out / outdir.LOCK_NAME).exists()
    # a file unidyn did not write under the lock's name is refused, and kept
    (out / outdir.LOCK_NAME).write_text("999999999\n")
    with pytest.raises(ValidationError, match="not a lock unidyn made"):
        run_sweep(small_sweep(), out, progress=False, overwrite=True)
    assert (out / outdir.LOCK_NAME).read_text() == "999999999\n"


def test_incomplete_points_keep_the_metrics_of_the_part_computed(tmp_path):
    from unidyn.model.scenario import Scenario
    from unidyn.model.trajectories import FigureEight, FunctionTrajectory
    f8 = FigureEight()

    def nan_after_2s(t):
        p = f8.position(t)
        return (np.array([np.nan, p[1]]) if t > 2.0 else p), f8.velocity(t)

    bad = Scenario.paper(3, T=4.0, noise=None,
                         trajectory=FunctionTrajectory(nan_after_2s, acceleration=f8.acceleration))
    good = Scenario.paper(3, T=4.0, noise=None)
    rows = sw._run_chunk([(0, {"k": 1}, bad, True), (1, {"k": 2}, good, True)], "batch",
                         1e-8, 1e-10)
    columns = ["index", "k", "case", *files.METRICS, "numerical_error", "estimate", "sensitive",
               "complete", "message"]
    path = tmp_path / "metrics.csv"
    path.write_text(rows_text(columns, rows))
    back = read_metrics(path)
    # the metrics of the part computed, marked incomplete, its error not estimated
    assert back[0]["complete"] is False and "non-finite" in back[0]["message"]
    assert all(math.isfinite(back[0][m]) for m in files.METRICS)
    assert back[0]["numerical_error"] is None and back[0]["sensitive"] is False
    assert back[1]["complete"] is True and 0 < back[1]["numerical_error"] <= 1e-4
    ref = simulate_batch([good], rtol=1e-8, atol=1e-10)[0].metrics  # compiled, alone; plain beside `bad`
    assert back[1]["complete"] is True
    assert [back[1][m] for m in files.METRICS] == pytest.approx([ref[m] for m in files.METRICS],
                                                             rel=1e-6)


def test_sampled_points_run_through_bdsim_in_a_batch_sweep(tmp_path):
    s = Sweep(base={**SHORT, "case": "compensated", "noise": "off"},
              grid={"control": ["continuous", "sampled"]})
    rows = run_sweep(s, tmp_path, progress=False).rows
    assert [r["control"] for r in rows] == ["continuous", "sampled"]
    sampled = unidyn.simulate(s.points()[1].scenario)
    assert rows[1]["iae"] == sampled.metrics["iae"]
    assert rows[0]["iae"] == simulate_batch([s.points()[0].scenario])[0].metrics["iae"]


def test_dask_route_gives_the_local_metrics(tmp_path):
    distributed = pytest.importorskip("distributed")
    s = small_sweep()
    run_sweep(s, tmp_path / "local", chunk_size=3, progress=False)
    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=False,
                                  dashboard_address=None) as cluster:
        with distributed.Client(cluster) as client:
            by_client = run_sweep(s, tmp_path / "client", chunk_size=3, progress=False,
                                  dask_address=client)
            assert client.status == "running"  # a client passed in stays open
        by_address = run_sweep(s, tmp_path / "address", chunk_size=3, progress=False,
                               dask_address=cluster.scheduler_address)
    assert by_client.ran == by_address.ran == 8
    assert csv_rows(tmp_path / "client") == csv_rows(tmp_path / "local")
    assert csv_rows(tmp_path / "address") == csv_rows(tmp_path / "local")


@pytest.mark.slow
def test_dask_local_starts_a_cluster_of_processes(tmp_path, capsys):
    pytest.importorskip("distributed")
    s = small_sweep()
    local = run_sweep(s, tmp_path / "here", chunk_size=3, progress=False)
    on_dask = run_sweep(s, tmp_path / "dask", chunk_size=3, progress=False,
                        dask_address="local")
    assert on_dask.ran == 8
    assert csv_rows(tmp_path / "dask") == csv_rows(tmp_path / "here")
    assert local.rows == on_dask.rows
    f = tmp_path / "s.toml"
    f.write_text('[base]\ncase = "uncompensated"\nT = 1\n[grid]\nkxy = [0.5, 1.0]\n')
    assert main(["sweep", str(f), "--dask", "local", "--no-progress",
                 "--out", str(tmp_path / "cli")]) == 0
    assert "Dask at local" in capsys.readouterr().out
    assert len(csv_rows(tmp_path / "cli")) == 3


def test_a_wrong_dask_address_is_one_line_naming_the_option(tmp_path, capsys):
    pytest.importorskip("distributed")
    f = tmp_path / "s.toml"
    f.write_text('[base]\nT = 1\n[grid]\nkxy = [0.5]\n')
    code = main(["sweep", str(f), "--dask", "no-port-here", "--no-progress",
                 "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err
    assert code == 2 and len(err.strip().splitlines()) == 1
    assert err.startswith("unidyn: error: --dask no-port-here: cannot connect") and "'local'" in err
    assert not (tmp_path / "o").exists()


def test_bad_run_arguments(tmp_path):
    with pytest.raises(ValidationError, match="engine"):
        run_sweep(small_sweep(), tmp_path, engine="fast")
    with pytest.raises(ValidationError, match="chunk_size"):
        run_sweep(small_sweep(), tmp_path, chunk_size=0)
    with pytest.raises(ValidationError, match="dask_address"):
        run_sweep(small_sweep(), tmp_path, dask_address=42, progress=False)


def test_progress_is_a_tqdm_bar_on_a_terminal_and_quiet_elsewhere(tmp_path, monkeypatch):
    pytest.importorskip("tqdm")

    class Terminal(io.StringIO):
        def isatty(self):
            return True

    term = Terminal()
    monkeypatch.setattr(sys, "stderr", term)
    run_sweep(small_sweep(), tmp_path / "a", chunk_size=4, progress=True)
    assert "sweep: 100%" in term.getvalue() and "8/8" in term.getvalue()
    pipe = io.StringIO()  # not a terminal: nothing
    monkeypatch.setattr(sys, "stderr", pipe)
    run_sweep(small_sweep(), tmp_path / "b", chunk_size=4, progress=True)
    assert pipe.getvalue() == ""
    monkeypatch.setattr(sys, "stderr", term := Terminal())
    run_sweep(small_sweep(), tmp_path / "c", chunk_size=4, progress=False)
    assert term.getvalue() == ""


# ---------------------------------------------------------------------- Fig. 11

def synthetic(a, b, c, d, ks):
    rows, i = [], 0
    for label, series in zip("abcd", (a, b, c, d)):
        for k, v in zip(ks, series):
            rows.append({"index": i, "variant": label, "kxy": k, "case": "x", "iae": v,
                         "complete": True})
            i += 1
    return rows


KS = [0.5, 1.0, 10.0, 23.0, 30.0]


def test_fig11_claims_all_hold_on_a_table_shaped_like_the_paper():
    a = [12.0, 9.0, 2.0, 1.24, 1.5]
    b = [6.0, 5.0, 1.5, 1.0, 1.2]
    c = [5.0, 4.0, 1.4, 0.9, 1.1]
    d = [1.0, 0.9, 0.5, 0.4, 0.45]
    claims = fig11_claims(synthetic(a, b, c, d, KS))
    assert [cl.holds for cl in claims] == [True] * 5
    assert "IAE_a(1) = 9.000 ± 0" in claims[0].measured
    assert "minimum 1.240 ± 0 at k = 23" in claims[1].measured
    md = format_fig11_claims(claims)
    assert md.count("| holds |") == 5 and "does not hold" not in md


def test_fig11_claims_report_failures_with_numbers():
    a = [12.0, 7.0, 2.0, 1.5, 1.2]        # below 8 at k = 1; still falling at the end
    b = [6.0, 5.0, 2.5, 1.0, 1.1]         # above (a) at k = 10
    c = [5.0, 4.0, 1.4, 0.9, 1.1]
    d = [1.0, 0.9, 1.45, 0.95, 0.45]      # not lowest at k = 10 and 23 (c: 1.4, 0.9)
    claims = fig11_claims(synthetic(a, b, c, d, KS))
    assert [cl.holds for cl in claims] == [False, False, False, True, False]
    assert "IAE_a(1) = 7.000" in claims[0].measured
    assert "k = 30" in claims[1].measured and "still falling" in claims[1].measured
    assert "4 of 5" in claims[2].measured and "k = 10" in claims[2].measured
    assert "3 of 5" in claims[4].measured and "10, 23" in claims[4].measured
    assert format_fig11_claims(claims).count("| does not hold |") == 4


def test_fig11_claims_are_judged_with_the_error_bars_over_seeds():
    """Two seeds a point: the claims compare means against twice the standard error of
    their difference, and say where two cases cannot be told apart."""
    ks = [1.0, 23.0]
    rows = []
    for seed, shift in ((1, 0.05), (2, -0.05)):  # a spread of 0.1: sem 0.05
        for label, series in zip("abcd", ([9.0, 1.24], [5.0, 1.0], [4.0, 0.9], [1.0, 0.95])):
            for k, v in zip(ks, series):
                rows.append({"index": len(rows), "variant": label, "kxy": k, "seed": seed,
                             "case": "x", "iae": v + shift, "complete": True})
    claims = fig11_claims(rows)
    assert "IAE_a(1) = 9.000 ± 0.05" in claims[0].measured and claims[0].holds is True
    # (d) at k = 23: 0.95 against (c)'s 0.9, a difference of 0.05 within 2 x 0.071
    assert claims[4].holds is None
    assert claims[4].verdict == "cannot be told apart within the error bars"
    assert "cannot be told apart within the error bars at k = 23" in claims[4].measured
    # the same means with a tenth of the spread: (d) is above (c) beyond the bars
    tight = [dict(r, iae=(r["iae"] - (0.05 if r["seed"] == 1 else -0.05)) + (0.005 if r["seed"] == 1 else -0.005))
             for r in rows]
    assert fig11_claims(tight)[4].holds is False


def test_fig11_claims_outside_the_sweep_and_incomplete_runs():
    ks = [2.0, 5.0]
    claims = fig11_claims(synthetic([3, 2], [2, 1], [2, 1], [1, 0.5], ks))
    assert claims[0].holds is None and claims[1].holds is None
    assert "not covered" in format_fig11_claims(claims)
    rows = synthetic([3, 2], [2, 1], [2, 1], [9, 0.5], ks)
    assert fig11_claims(rows)[-1].holds is False  # (d) is not lowest at k = 2
    rows[4]["complete"], rows[4]["iae"] = False, None  # (c) at k = 2 did not complete
    claims = fig11_claims(rows)
    # left out, and counted: k = 2 drops from every comparison that needs (c)
    assert claims[-1].holds is True and "lowest at 1 of 1 k" in claims[-1].measured
    assert "1 incomplete point(s) left out (c at k = 2)" in claims[-1].measured
    assert "1 incomplete point(s) left out (c at k = 2)" in claims[3].measured
    assert "left out" not in claims[2].measured  # (b) against (a) uses every k
    assert "below at 2 of 2 k" in claims[2].measured
    assert "below at 1 of 1 k" in claims[3].measured  # (c) against (a) where (c) completed
    # no gain where all four completed: (d) cannot be judged, the others still are
    rows[7]["complete"], rows[7]["iae"] = False, None  # (d) at k = 5
    claims = fig11_claims(rows)
    assert claims[-1].holds is None and "no gain with complete points of all four" in claims[-1].measured
    assert claims[2].holds is True and claims[3].holds is True
    with pytest.raises(ValidationError, match="no complete rows for case"):
        fig11_claims([r for r in rows if r["variant"] != "c"])


def test_cli_paper_fig11_short(tmp_path, capsys):
    out = tmp_path / "fig11"
    code = main(["sweep", "--paper-fig11", "--T", "1", "--gains", "[1, 23]", "--no-noise",
                 "--no-progress", "--out", str(out)])
    text, err = capsys.readouterr()
    assert code == 0, err
    rows = read_metrics(out / "metrics.csv")
    assert len(rows) == 8 and {r["variant"] for r in rows} == set("abcd")
    assert (out / "fig11.png").exists() and (out / "metrics.png").exists()
    md = (out / "claims.md").read_text()
    assert "noise off" in md and "T = 1 s" in md and "| the paper says |" in md
    assert "(d) lowest for every k" in text
    spec = json.loads((out / "sweep.json").read_text())
    assert spec["sweep"]["base"]["noise"] == "off"


def test_cli_sweep_file_resume_and_no_resume(tmp_path, capsys):
    f = tmp_path / "s.toml"
    f.write_text('[base]\ncase = "uncompensated"\nT = 1\n[grid]\nkxy = [0.5, 1.0, 1.5]\n')
    out = tmp_path / "o"
    assert main(["sweep", str(f), "--out", str(out), "--no-progress", "--chunk-size", "2"]) == 0
    assert "ran 3 points" in capsys.readouterr().out
    assert main(["sweep", str(f), "--out", str(out), "--no-progress"]) == 0
    assert "3 already done" in capsys.readouterr().out
    assert main(["sweep", str(f), "--out", str(out), "--T", "2", "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert "different sweep" in err and "base.T" in err and "--overwrite" in err
    assert main(["sweep", str(f), "--out", str(out), "--no-resume", "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert "3 finished row(s)" in err and "points 0-2" in err and "--overwrite" in err
    assert main(["sweep", str(f), "--out", str(out), "--T", "2", "--no-resume",
                 "--overwrite", "--no-progress"]) == 0
    assert "replaced   the previous sweep" in capsys.readouterr().out
    rows = read_metrics(out)
    assert len(rows) == 3 and all(math.isfinite(r["iae"]) for r in rows)
    with open(out / "metrics.csv", newline="") as fh:
        assert next(csv.reader(fh)) == ["index", "kxy", "case", "iae", "ise", "itae",
                                        "itse", "energy", "error_final", "peak_error",
                                        "numerical_error", "estimate", "sensitive", "complete",
                                        "message"]


@pytest.mark.filterwarnings("ignore::RuntimeWarning")
def test_cli_sweep_marks_an_incomplete_point_and_counts_it(tmp_path, capsys):
    f = tmp_path / "s.toml"
    f.write_text('[base]\ncase = "compensated"\nT = 2\nnoise = "off"\n[grid]\ntrajectory = ['
                 '{type = "circle", radius = 1.0, omega = 0.2}, '
                 '{type = "circle", radius = 1e300, omega = 1e300}]\n')
    code = main(["sweep", str(f), "--out", str(tmp_path / "o"), "--no-progress"])
    out, err = capsys.readouterr()
    assert code == 1 and "1 point(s) did not complete: 1" in err
    assert "incomplete 1 of 2 point(s) did not complete" in out
    rows = read_metrics(tmp_path / "o")
    assert rows[0]["complete"] is True and rows[0]["iae"] > 0
    # the metrics of the part computed, marked incomplete and not estimated
    assert rows[1]["complete"] is False and rows[1]["numerical_error"] is None
    spec = json.loads((tmp_path / "o" / "sweep.json").read_text())
    assert spec["finished"] is True and spec["failed"] == [1]
    assert (tmp_path / "o" / "metrics.png").stat().st_size > 1000


def test_sweep_names_are_there():
    """Every name unidyn.sweeps.sweep lists is defined there."""
    assert [n for n in sw.__all__ if not hasattr(sw, n)] == []


def test_a_point_at_a_high_adaptation_gain_is_tightened_and_its_estimate_holds(tmp_path):
    """Adaptation at gamma 1000 with the paper's limits, beside gamma 1: each row has
    its estimated numerical error within the promise, and the high-gain one is within
    twice its estimate of the engine at rtol 1e-12 (converged there to 1e-9)."""
    s = Sweep(base={"case": "adaptive", "adapt_from": 0.0, "T": 6.0, "noise": "off"},
              grid={"gamma": [[1.0] * 6, [1000.0] * 6]}, name="gains")
    run_sweep(s, tmp_path, progress=False)
    rows = read_metrics(tmp_path / "metrics.csv")
    assert [r["complete"] for r in rows] == [True, True]
    assert [r["sensitive"] for r in rows] == [False, False]
    assert all(0 < r["numerical_error"] <= 1e-4 for r in rows)
    ref, = simulate_batch([s.points()[1].scenario], rtol=1e-12, atol=1e-14)
    assert abs(rows[1]["iae"] - ref.metrics["iae"]) <= 2 * rows[1]["numerical_error"] * ref.metrics["iae"]


def test_seed_statistics_are_numpy_s_over_the_seeds_of_each_point():
    """Seeded random rows, numpy's mean, sample standard deviation and standard error;
    a run that stopped is counted apart, never averaged in."""
    from unidyn.sweeps.statistics import seed_statistics
    rng = np.random.default_rng(3)
    rows = [{"index": i, "variant": v, "kxy": k, "seed": s, "case": "x",
             **{m: float(rng.lognormal()) for m in files.METRICS},
             "numerical_error": float(rng.uniform(0, 1e-4)), "sensitive": bool(s == 2),
             "complete": not (v == "b" and k == 2.0 and s == 4), "message": ""}
            for i, (v, k, s) in enumerate((v, k, s) for v in "ab" for k in (1.0, 2.0)
                                          for s in range(1, 6))]
    stats = seed_statistics(rows, ["variant", "kxy", "seed"])
    assert [(r["variant"], r["kxy"], r["n"], r["incomplete"]) for r in stats] == [
        ("a", 1.0, 5, 0), ("a", 2.0, 5, 0), ("b", 1.0, 5, 0), ("b", 2.0, 4, 1)]
    for st in stats:
        mine = [r for r in rows if (r["variant"], r["kxy"]) == (st["variant"], st["kxy"])]
        done = [r for r in mine if r["complete"]]
        for m in files.METRICS:
            x = np.array([r[m] for r in done])
            assert st[f"{m}_mean"] == pytest.approx(np.mean(x), rel=1e-14)
            assert st[f"{m}_std"] == pytest.approx(np.std(x, ddof=1), rel=1e-12)
            assert st[f"{m}_sem"] == pytest.approx(np.std(x, ddof=1) / np.sqrt(len(x)), rel=1e-12)
        assert st["numerical_error"] == max(r["numerical_error"] for r in mine)
        assert st["sensitive"] == 1


def test_a_sweep_over_seeds_writes_one_statistics_row_per_point(tmp_path):
    s = Sweep(base={"case": "compensated", "T": 2.0}, grid={"kxy": [0.5, 1.0], "seed": [1, 2, 3]})
    run_sweep(s, tmp_path, progress=False)
    with open(tmp_path / "statistics.csv", newline="") as fh:
        stats = list(csv.DictReader(fh))
    assert [(float(r["kxy"]), int(r["n"])) for r in stats] == [(0.5, 3), (1.0, 3)]
    rows = read_metrics(tmp_path)
    iae = [r["iae"] for r in rows if r["kxy"] == 0.5]
    assert float(stats[0]["iae_mean"]) == pytest.approx(np.mean(iae), rel=1e-12)
    assert float(stats[0]["iae_sem"]) == pytest.approx(np.std(iae, ddof=1) / np.sqrt(3), rel=1e-12)
    assert float(stats[0]["numerical_error"]) <= 1e-4
    # a sweep without a seed axis has none
    run_sweep(Sweep(base={"case": "compensated", "T": 1.0}, grid={"kxy": [0.5]}),
              tmp_path / "plain", progress=False)
    assert not (tmp_path / "plain" / "statistics.csv").exists()


def test_a_seed_sweep_s_figure_draws_each_variant_s_mean_with_its_standard_error_band():
    """Fig. 11's sweep over three seeds, with seeded random IAEs: one line per variant
    (not per seed) through numpy's mean over the seeds, a band of ± its standard error,
    labels in a reader's words (no field name) and no colour twice."""
    import matplotlib
    from matplotlib.collections import PolyCollection

    from unidyn.paper import paper_fig11
    from unidyn.sweeps.plots import plot_metrics
    sweep = paper_fig11(T=10.0, gains=[1.0, 2.0, 4.0], seeds=3)
    rng = np.random.default_rng(11)
    rows = [{"index": p.index, **p.params, "case": p.scenario.case, "complete": True,
             **{m: float(rng.lognormal()) for m in files.METRICS}} for p in sweep.points()]
    fig = plot_metrics(sweep, rows, None)
    try:
        ax = fig.axes[0]
        lines = ax.get_lines()
        assert [ln.get_label().split(":")[0] for ln in lines] == ["a", "b", "c", "d"]
        assert not any(w in ln.get_label() for ln in lines
                       for w in ("theta_hat_scale", "seed", "adapt_from"))
        assert "θ̂(0)/θ = 0.9" in lines[1].get_label()
        colours = [matplotlib.colors.to_hex(ln.get_color()) for ln in lines]
        assert len(set(colours)) == 4
        for ln in lines:
            variant = ln.get_label().split(":")[0]
            for x, y in zip(*ln.get_data()):
                iae = [r["iae"] for r in rows if r["variant"] == variant and r["kxy"] == x]
                assert len(iae) == 3 and y == pytest.approx(np.mean(iae), rel=1e-12)
        bands = [c for c in ax.collections if isinstance(c, PolyCollection)]
        assert len(bands) == 4
        # the first variant's band at its first gain spans mean ± std / sqrt(3)
        iae = [r["iae"] for r in rows if r["variant"] == "a" and r["kxy"] == 1.0]
        xy = bands[0].get_paths()[0].vertices
        ys = xy[xy[:, 0] == 1.0, 1]
        sem = np.std(iae, ddof=1) / np.sqrt(3)
        assert (min(ys), max(ys)) == pytest.approx((np.mean(iae) - sem, np.mean(iae) + sem),
                                                   rel=1e-12)
        assert "over 3 noise seeds" in ax.get_title()
    finally:
        matplotlib.pyplot.close(fig)


def test_a_sweep_figure_gives_each_of_twelve_lines_its_own_colour():
    import matplotlib

    from unidyn.sweeps.plots import plot_metrics
    sweep = Sweep(base={"case": "compensated", "T": 1.0},
                  grid={"kxy": [0.5, 1.0], "a": [0.1 * k for k in range(1, 13)]})
    rows = [{"index": p.index, **p.params, "case": "compensated", "complete": True,
             **{m: 1.0 + p.index for m in files.METRICS}} for p in sweep.points()]
    fig = plot_metrics(sweep, rows, None)
    try:
        colours = [matplotlib.colors.to_hex(ln.get_color()) for ln in fig.axes[0].get_lines()]
        assert len(colours) == 12 and len(set(colours)) == 12
    finally:
        matplotlib.pyplot.close(fig)


def test_the_mean_error_over_seeds_is_drawn_with_its_standard_error_band():
    """Three runs whose distance error is 1, 2 and 4 m throughout (a reference that far
    from a robot at rest): the mean line at 7/3 m, the band ± std / sqrt(3)."""
    import matplotlib
    from matplotlib.collections import PolyCollection

    from unidyn.results.result import Result
    from unidyn.sweeps.seeds import SeedRuns
    sc = unidyn.Scenario.paper(3, T=2.0)
    t = np.linspace(0.0, 2.0, 21)

    def run(d):
        return Result(scenario=sc, t=t, pose=np.zeros((21, 3)), velocity=np.zeros((21, 2)),
                      reference=np.tile([d, 0.0], (21, 1)), v_d=None, v_ref=None,
                      theta_hat=None, engine="batch", backend="compiled")
    runs = SeedRuns(sc, (0, 1, 2), [run(1.0), run(2.0), run(4.0)])
    assert runs.statistics["iae_mean"] == pytest.approx(2.0 * 7 / 3, rel=1e-12)
    ax = runs.plot_error()
    try:
        mean = [ln for ln in ax.get_lines() if ln.get_label().startswith("mean")]
        np.testing.assert_allclose(mean[0].get_ydata(), 7 / 3, rtol=1e-12)
        [band] = [c for c in ax.collections if isinstance(c, PolyCollection)]
        sem = np.std([1.0, 2.0, 4.0], ddof=1) / np.sqrt(3)
        ys = band.get_paths()[0].vertices[:, 1]
        assert (ys.min(), ys.max()) == pytest.approx((7 / 3 - sem, 7 / 3 + sem), rel=1e-12)
        assert "noise seeds 0-2" in ax.get_title()
    finally:
        matplotlib.pyplot.close(ax.figure)


def _disk_fills(monkeypatch, after: int, name: str | None = None):
    """From the ``after``-th file written through the project's one write helper on
    (of ``name``, if given), each write fails as on a full disk, part of it written."""
    import errno

    from unidyn.results import ownership
    real, count = ownership.write_file, [0]

    def write_file(path, write, *args, **kw):
        if name is None or os.path.basename(path) == name:
            count[0] += 1
            if count[0] > after:
                def full(tmp, write=write):
                    with open(tmp, "wb") as fh:
                        fh.write(b"p" * 1000)
                    raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
                return real(path, full, *args, **kw)
        return real(path, write, *args, **kw)
    monkeypatch.setattr(ownership, "write_file", write_file)


def test_a_full_disk_at_the_figure_names_it_and_says_every_row_is_kept(tmp_path,
                                                                         monkeypatch):
    out = tmp_path / "out"
    s = Sweep(base=SHORT, grid={"kx": [0.5, 1.0, 2.0]})

    def plot_metrics(sweep, rows, path):  # the figure fills the disk
        with open(path, "wb") as fh:
            fh.write(b"png" * 400)
        raise OSError(28, os.strerror(28))
    monkeypatch.setattr(sw, "plot_metrics", plot_metrics)
    with pytest.raises(OSError) as err:
        run_sweep(s, out, progress=False)
    text = str(err.value)
    assert f"writing {out / 'metrics.png'} (1.2 kB of it written, " in text, text
    assert f"free); all 3 of 3 points are in {out / 'metrics.csv'}, intact" in text
    assert len(read_metrics(out / "metrics.csv")) == 3 and not (out / "metrics.png").exists()
    assert not [n for n in os.listdir(out) if n.startswith(".unidyn-tmp")]


def test_a_full_disk_on_resuming_names_the_file_and_the_rows_kept(tmp_path, monkeypatch):
    out = tmp_path / "out"
    s = Sweep(base=SHORT, grid={"kx": [0.5, 1.0, 2.0]})
    run_sweep(s, out, progress=False, chunk_size=1)
    rows = (out / "metrics.csv").read_bytes()
    _disk_fills(monkeypatch, after=0, name=".unidyn-sweep.json")
    with pytest.raises(OSError) as err:
        run_sweep(s, out, progress=False)
    text = str(err.value)
    assert re.search(rf"writing {re.escape(str(out))}/\S+ \(.*free\); 3 finished row\(s\) in "
                     rf"metrics.csv \(points 0-2\), intact", text), text
    assert (out / "metrics.csv").read_bytes() == rows


@pytest.mark.parametrize("text, meant", [
    ('nmae = "x"\n[base]\nT = 1\n[grid]\nkx = [1]\n', "name"),
    ('[base]\nT = 1\ntrajectory = {type = "circle", raduis = 2}\n[grid]\nkx = [1]\n', "radius"),
    ('[base]\nT = 1\n[grid]\nkxy = {start = 1, stopp = 2, step = 1}\n', "stop"),
    ('[base]\nT = 1\n[grid]\ntheta_hat_scal = [1, 2]\n', "theta_hat_scale"),
])
def test_a_misspelled_key_of_a_sweep_file_is_named_with_the_one_meant(tmp_path, text, meant):
    f = tmp_path / "s.toml"
    f.write_text(text)
    with pytest.raises(ValidationError) as err:
        sw.Sweep.from_toml(f)
    assert f"(did you mean {meant!r}?)" in str(err.value) and "\n" not in str(err.value)
