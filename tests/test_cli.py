"""The ``unidyn`` command line, run in-process through ``main([...])`` and once as a
subprocess (``python -m unidyn`` and the console script).

The fast tier checks the arguments and the one-line errors; the tests that write a
run's files and figures into a folder are whole-system checks, in the slow tier."""

import csv
import json
import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from unidyn.cli import main
from unidyn.model import robots

TIMESERIES_COLUMNS = ["t", "x", "y", "psi", "u", "w", "x_d", "y_d", "u_d", "w_d", "u_ref",
                      "w_ref", "error"] + [f"theta_hat{i}" for i in range(1, 7)]
VENV_BIN = Path(sys.executable).parent


def run_cli(capsys, *argv):
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


def read_csv(path):
    with open(path, newline="") as fh:
        rows = list(csv.reader(fh))
    return rows[0], np.array(rows[1:], dtype=float)


def assert_one_line_error(err, *words):
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert lines[0].startswith("unidyn: error: "), err
    assert "Traceback" not in err
    for w in words:
        assert w in lines[0], (w, err)


@pytest.fixture(scope="module")
def paper1(tmp_path_factory):
    """One bdsim run of the paper's simulation 1 over 5 s, shared by several tests."""
    out = tmp_path_factory.mktemp("paper1") / "run"
    code = main(["run", "--paper", "1", "--T", "5", "--out", str(out)])
    assert code == 0
    return out


@pytest.mark.slow
def test_run_writes_timeseries_summary_and_figures(paper1):
    header, data = read_csv(paper1 / "timeseries.csv")
    assert header == TIMESERIES_COLUMNS
    assert data.shape == (51, len(TIMESERIES_COLUMNS))
    np.testing.assert_allclose(data[:, 0], np.arange(51) * 0.1, atol=1e-12)
    for name in ("path.png", "error.png", "positions.png", "velocities.png"):
        assert (paper1 / name).stat().st_size > 1000
    summary = json.loads((paper1 / "summary.json").read_text())
    assert summary["scenario"]["case"] == "kinematic"
    assert summary["scenario"]["T"] == 5.0
    # the default engine is the batch engine for continuous control
    assert summary["engine"] == "batch" and summary["complete"] is True


@pytest.mark.slow
def test_summary_metrics_match_the_timeseries(paper1):
    header, data = read_csv(paper1 / "timeseries.csv")
    col = {h: data[:, i] for i, h in enumerate(header)}
    # the error column is the distance between reference and position
    err = np.hypot(col["x_d"] - col["x"], col["y_d"] - col["y"])
    np.testing.assert_allclose(col["error"], err, rtol=1e-8, atol=1e-10)
    t, e = col["t"], col["error"]
    trap = lambda y: float(np.sum(0.5 * (y[1:] + y[:-1]) * np.diff(t)))  # noqa: E731
    m = json.loads((paper1 / "summary.json").read_text())["metrics"]
    assert m["iae"] == pytest.approx(trap(e), rel=1e-8)
    assert m["ise"] == pytest.approx(trap(e ** 2), rel=1e-8)
    assert m["itae"] == pytest.approx(trap(t * e), rel=1e-8)
    assert m["itse"] == pytest.approx(trap(t * e ** 2), rel=1e-8)
    assert m["energy"] == pytest.approx(trap(col["u"] ** 2 + col["w"] ** 2), rel=1e-8)
    assert m["error_final"] == pytest.approx(e[-1], rel=1e-8)
    # the kinematic case starts 0.2 m off the reference and closes in on it
    assert e[0] == pytest.approx(0.2, abs=1e-9) and e[-1] < e[0]


@pytest.mark.slow
def test_from_summary_reproduces_the_run_bit_for_bit(paper1, tmp_path, capsys):
    code, out, _ = run_cli(capsys, "run", "--from", paper1 / "summary.json", "--out", tmp_path)
    assert code == 0 and "IAE" in out
    a = json.loads((paper1 / "summary.json").read_text())
    b = json.loads((tmp_path / "summary.json").read_text())
    assert a["metrics"] == b["metrics"]
    assert a["scenario"] == b["scenario"]
    assert (paper1 / "timeseries.csv").read_bytes() == (tmp_path / "timeseries.csv").read_bytes()


@pytest.mark.slow
def test_out_folder_with_results_is_refused_without_overwrite(paper1, capsys):
    before = (paper1 / "summary.json").read_bytes()
    code, out, err = run_cli(capsys, "run", "--paper", "2", "--T", "1", "--out", paper1)
    assert code == 2
    assert_one_line_error(err, "already holds run results", "timeseries.csv, summary.json",
                          "--overwrite")
    assert (paper1 / "summary.json").read_bytes() == before


def _files(folder):
    return {p.name: p.read_bytes() for p in sorted(folder.iterdir())}


@pytest.mark.slow
def test_a_failed_overwrite_keeps_the_old_results(tmp_path, capsys):
    out = tmp_path / "X"
    assert run_cli(capsys, "run", "--set", "T=2", "--out", out)[0] == 0
    before = _files(out)
    code, text, err = run_cli(capsys, "run", "--rtol", "1", "--overwrite", "--out", out)
    assert code == 2 and "unidyn: error:" in err and "rtol" in err
    # what would have been replaced is said up front, and nothing was
    assert "replacing" in err and "timeseries.csv, summary.json, path.png" in err
    assert _files(out) == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["X"]  # no staging folder left


@pytest.mark.slow
def test_an_overwrite_says_what_it_replaced(tmp_path, capsys):
    out = tmp_path / "X"
    assert run_cli(capsys, "run", "--set", "T=1", "--out", out)[0] == 0
    (out / "notes.txt").write_text("mine")
    code, text, _ = run_cli(capsys, "run", "--set", "T=2", "--case", "compensated",
                            "--overwrite", "--out", out)
    assert code == 0
    # the adaptive run's seven files (theta_hat.png, gone now, among them) in one line
    assert "replaced   the previous 7 files, e.g. timeseries.csv, summary.json, path.png\n" in text
    assert sorted(p.name for p in out.iterdir()) == sorted(
        ["notes.txt", "timeseries.csv", "summary.json", "path.png", "error.png",
         "positions.png", "velocities.png", ".unidyn-run.json"])  # the manifest
    assert json.loads((out / "summary.json").read_text())["scenario"]["T"] == 2.0


DIVERGING = ["--set", 'trajectory={type = "circle", radius = 1e300, omega = 1e300}',
             "--set", "noise=off", "--T", "2"]


@pytest.mark.slow
@pytest.mark.filterwarnings("ignore::RuntimeWarning")
def test_an_incomplete_run_says_so_and_never_replaces_a_complete_one(tmp_path, capsys):
    # into an empty folder: written there, marked incomplete, the IAE of the part computed
    code, text, err = run_cli(capsys, "run", *DIVERGING, "--out", tmp_path / "new")
    assert code == 1 and "unidyn: warning: the run stopped early" in err
    assert "INCOMPLETE: stopped at t = " in text and "non-finite" in text
    t_stop = re.search(r"stopped at t = (\S+) s", text).group(1)
    assert re.search(rf"IAE +\S+ m·s \(to t = {re.escape(t_stop)} s\)", text), text
    summary = json.loads((tmp_path / "new" / "summary.json").read_text())
    assert summary["complete"] is False and summary["numerical_error"] is None
    assert summary["metrics"]["iae"] is not None
    # beside complete results: those stay, the partial run goes to <out>.incomplete
    out = tmp_path / "X"
    assert run_cli(capsys, "run", "--set", "T=1", "--out", out)[0] == 0
    before = _files(out)
    code, text, err = run_cli(capsys, "run", *DIVERGING, "--overwrite", "--out", out)
    assert code == 1 and _files(out) == before
    assert f"written    {out}.incomplete/" in text and "kept" in text
    partial = json.loads((tmp_path / "X.incomplete" / "summary.json").read_text())
    assert partial["complete"] is False and partial["message"]


@pytest.mark.slow
def test_run_summary_names_engine_and_backend(paper1, tmp_path, capsys):
    code, text, _ = run_cli(capsys, "run", "--from", paper1, "--out", tmp_path / "r")
    summary = json.loads((tmp_path / "r" / "summary.json").read_text())
    line = next(ln for ln in text.splitlines() if ln.startswith("engine"))
    assert code == 0 and f"{summary['engine']} ({summary['backend']})" in line


@pytest.mark.parametrize("how", ["set", "file"])
def test_a_huge_name_is_refused_before_anything_is_written(tmp_path, capsys, how):
    name = "n" * 3_000_000
    if how == "set":
        argv = ["run", "--T", "1", "--set", f"name={name}", "--out", tmp_path / "o"]
    else:
        (tmp_path / "s.toml").write_text(f'name = "{name}"\nT = 1\n')
        argv = ["run", tmp_path / "s.toml", "--out", tmp_path / "o"]
    code, text, err = run_cli(capsys, *argv)
    assert code == 2 and text == ""
    assert_one_line_error(err, "name is 3000000 characters long", "at most 200")
    assert not (tmp_path / "o").exists()


@pytest.mark.slow
def test_overwrite_replaces_results_and_stale_files(tmp_path, capsys):
    out = tmp_path / "run"
    assert run_cli(capsys, "run", "--paper", "4", "--T", "1", "--engine", "batch",
                   "--out", out)[0] == 0
    assert (out / "theta_hat.png").exists()  # adaptive case
    code, _, _ = run_cli(capsys, "run", "--paper", "2", "--T", "1", "--engine", "batch",
                         "--overwrite", "--out", out)
    assert code == 0
    assert json.loads((out / "summary.json").read_text())["scenario"]["case"] == "uncompensated"
    assert not (out / "theta_hat.png").exists()  # no figure of the previous run survives


@pytest.mark.slow
def test_set_overrides_fields(tmp_path, capsys):
    code, out, _ = run_cli(capsys, "run", "--paper", "2", "--T", "2", "--engine", "batch",
                           "--set", "kx=0.5", "--set", "noise=off", "--set", "x0=[0, 0.1, 0]",
                           "--set", "robot=p3dx", "--out", tmp_path / "a")
    assert code == 0
    sc = json.loads((tmp_path / "a" / "summary.json").read_text())["scenario"]
    assert sc["kx"] == 0.5 and sc["ky"] == 0.1
    assert sc["noise"] is None
    assert sc["x0"] == [0.0, 0.1, 0.0]
    assert sc["robot"] == "p3dx"
    assert sc["case"] == "uncompensated"
    # a dotted key sets one entry of a table; flags apply before --set
    code, _, _ = run_cli(capsys, "run", "--case", "compensated", "--T", "1", "--engine", "batch",
                         "--set", "noise.seed=3", "--set", "T=1.5", "--out", tmp_path / "b")
    assert code == 0
    sc = json.loads((tmp_path / "b" / "summary.json").read_text())["scenario"]
    assert sc["noise"]["seed"] == 3 and sc["noise"]["position_std"] == 0.01
    assert sc["T"] == 1.5 and sc["case"] == "compensated"


@pytest.mark.parametrize("item, words", [
    ("kz=0.5", ["kz", "unknown scenario field"]),
    ("kx=-1", ["kx", "> 0"]),
    ("kx=fast", ["kx", "real number"]),
    ("noise.sead=1", ["sead"]),
    ("kx", ["KEY=VALUE"]),
])
def test_bad_set_exits_2_naming_the_key(tmp_path, capsys, item, words):
    code, out, err = run_cli(capsys, "run", "--T", "1", "--set", item, "--out", tmp_path)
    assert code == 2
    assert_one_line_error(err, *words)
    assert not (tmp_path / "summary.json").exists()


@pytest.mark.parametrize("text, words", [
    ("case = 'compensated'\nkx = \n", ["malformed TOML", "line 2"]),
    ("robot = p3dx_laser  # no quotes\n", ["malformed TOML", "line 1",
                                          'text needs quotes: robot = "p3dx_laser"']),
    ("case = 'compensated'\nkz = 0.5\n", ["unknown scenario field 'kz'"]),
    ("label = 'a sweep variant'\nT = 1\n", ["unknown scenario field 'label'"]),
    ("kx = 'fast'\n", ["kx must be a real number"]),
    ("kx = -0.5\n", ["kx must be > 0"]),
    ("x0 = [0, 0]\n", ["x0", "length 3"]),
    ("[scenario]\ncase = 'sideways'\n", ["case must be one of"]),
])
def test_bad_scenario_file_exits_2_with_one_line(tmp_path, capsys, text, words):
    f = tmp_path / "scenario.toml"
    f.write_text(text)
    code, out, err = run_cli(capsys, "run", f, "--out", tmp_path / "out")
    assert code == 2
    assert_one_line_error(err, str(f), *words)
    assert out == ""


@pytest.mark.slow
def test_scenario_file_then_flags(tmp_path, capsys):
    f = tmp_path / "s.toml"
    f.write_text("case = 'compensated'\nT = 3\nkx = 0.3\nnoise = 'off'\n")
    code, out, _ = run_cli(capsys, "run", f, "--T", "1", "--set", "ky=0.4", "--engine", "batch",
                           "--out", tmp_path / "o")
    assert code == 0 and "compensated" in out
    sc = json.loads((tmp_path / "o" / "summary.json").read_text())["scenario"]
    assert (sc["T"], sc["kx"], sc["ky"], sc["noise"]) == (1.0, 0.3, 0.4, None)


def test_missing_files_and_usage_errors(tmp_path, capsys):
    code, _, err = run_cli(capsys, "run", tmp_path / "nope.toml", "--out", tmp_path / "o")
    assert code == 2
    assert_one_line_error(err, "nope.toml", "does not exist")
    code, _, err = run_cli(capsys, "run", "--from", tmp_path / "nope.json", "--out", tmp_path)
    assert code == 2
    assert_one_line_error(err, "nope.json")
    code, _, err = run_cli(capsys, "run", "--paper", "1")  # no --out
    assert code == 2
    assert_one_line_error(err, "--out")
    code, _, err = run_cli(capsys, "run", "--paper", "1", "--from", tmp_path, "--out", tmp_path)
    assert code == 2
    assert_one_line_error(err, "--from")
    code, _, err = run_cli(capsys, "properties", "r2d2")
    assert code == 2
    assert_one_line_error(err, "unknown robot 'r2d2'")


def test_batch_engine_refuses_sampled_control(tmp_path, capsys):
    code, _, err = run_cli(capsys, "run", "--T", "1", "--set", "control=sampled",
                           "--engine", "batch", "--out", tmp_path)
    assert code == 2
    assert_one_line_error(err, "sampled")


def test_keyboard_interrupt_exits_130(tmp_path, capsys, monkeypatch):
    import unidyn.diagrams.simulate

    def interrupted(*a, **k):
        raise KeyboardInterrupt

    monkeypatch.setattr(unidyn.diagrams.simulate, "simulate", interrupted)
    code, _, err = run_cli(capsys, "run", "--T", "1", "--engine", "bdsim", "--out", tmp_path)
    assert code == 130
    assert "Traceback" not in err and "interrupted" in err


def test_animate_reports_a_missing_module(tmp_path, capsys, monkeypatch):
    import unidyn
    monkeypatch.delattr(unidyn, "animation", raising=False)
    monkeypatch.setitem(sys.modules, "unidyn.teaching.animation", None)
    code, _, err = run_cli(capsys, "run", "--T", "1", "--animate", "--out", tmp_path)
    assert code == 2
    assert_one_line_error(err, "--animate", "unidyn.teaching.animation")
    assert not (tmp_path / "summary.json").exists()  # checked before simulating


@pytest.mark.slow
def test_animate_writes_a_gif(tmp_path, capsys):
    pytest.importorskip("unidyn.teaching.animation")
    code, _, _ = run_cli(capsys, "run", "--paper", "3", "--T", "1", "--engine", "batch",
                         "--animate", "--out", tmp_path)
    assert code == 0
    assert (tmp_path / "animation.gif").read_bytes()[:3] == b"GIF"


def test_robots_and_properties(capsys):
    code, out, _ = run_cli(capsys, "robots")
    assert code == 0
    lines = out.strip().splitlines()
    assert len(lines) == 1 + len(robots.names())
    row = next(ln for ln in lines if ln.startswith("p3dx_laser "))
    assert "0.2604" in row and "-0.000499" in row and "Table 1" in row
    code, out, _ = run_cli(capsys, "properties", "khepera3", "--u-max", "0.5")
    assert code == 0
    assert "khepera3" in out and "skew" in out


@pytest.mark.slow
def test_identify_from_a_csv_log_and_run_with_the_result(tmp_path, capsys):
    from unidyn import identification as ident
    exc = ident.excitation(40.0, 0.05, robot="p3dx")
    log = ident.simulate_log("p3dx", exc, noise_std=0.005, seed=1, commands="held")
    path = tmp_path / "log.csv"
    with open(path, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["time", "u_cmd", "w_cmd", "v_meas", "omega_meas"])
        for row in zip(*(log[k] for k in ("t", "u_ref", "w_ref", "u", "w"))):
            w.writerow([repr(float(x)) for x in row])
    out = tmp_path / "ident"
    code, text, err = run_cli(capsys, "identify", path, "--columns",
                              "t=time,u_ref=u_cmd,w_ref=w_cmd,u=v_meas,w=omega_meas",
                              "--out", out)
    assert code == 0, err
    theta = json.loads((out / "theta.json").read_text())
    true = robots.get("p3dx").theta
    for i in (1, 2, 4, 6):
        assert theta[f"theta{i}"] == pytest.approx(true[i - 1], rel=0.03)
    assert "theta1" in text
    if hasattr(ident, "plot_validation"):
        assert (out / "validation.png").exists()
    # a missing column is named; theta.json is not overwritten without --overwrite
    code, _, err = run_cli(capsys, "identify", path, "--out", tmp_path / "x")
    assert code == 2
    assert_one_line_error(err, "missing column")
    code, _, err = run_cli(capsys, "identify", path, "--out", out)
    assert code == 2
    assert_one_line_error(err, "--overwrite")
    # the identified parameters drive a simulation
    code, text, _ = run_cli(capsys, "run", "--robot", out / "theta.json", "--case", "compensated",
                            "--T", "1", "--engine", "batch", "--out", tmp_path / "sim")
    assert code == 0
    sc = json.loads((tmp_path / "sim" / "summary.json").read_text())["scenario"]
    assert sc["robot"]["theta1"] == theta["theta1"]


def _env():
    env = dict(os.environ, MPLBACKEND="Agg")
    return env


@pytest.mark.slow
def test_python_m_unidyn_and_console_script(tmp_path):
    out = tmp_path / "run"
    p = subprocess.run([sys.executable, "-m", "unidyn", "run", "--paper", "3", "--T", "1",
                        "--engine", "batch", "--out", str(out)],
                       capture_output=True, text=True, env=_env(), timeout=120)
    assert p.returncode == 0, p.stderr
    assert "compensated" in p.stdout and "IAE" in p.stdout
    assert (out / "summary.json").exists() and (out / "timeseries.csv").exists()
    script = VENV_BIN / "unidyn"
    if not script.exists():
        pytest.skip("the unidyn console script is not installed next to this Python")
    bad = tmp_path / "bad.toml"
    bad.write_text("kx = [\n")
    p = subprocess.run([str(script), "run", str(bad), "--out", str(tmp_path / "o")],
                       capture_output=True, text=True, env=_env(), timeout=120)
    assert p.returncode == 2
    assert_one_line_error(p.stderr, "malformed TOML")


@pytest.mark.slow
def test_a_run_into_a_folder_being_written_is_refused(tmp_path, capsys):
    from unidyn.results.folders import FolderLock
    out = tmp_path / "busy"
    out.mkdir()
    with FolderLock(out):  # as a sweep or another run holds it
        code, text, err = run_cli(capsys, "run", "--T", "1", "--out", out)
    assert code == 2 and text == ""
    assert_one_line_error(err, f"PID {os.getpid()}", "another unidyn process")
    assert list(out.iterdir()) == []
    assert run_cli(capsys, "run", "--T", "1", "--out", out)[0] == 0  # released
    assert not (out / ".unidyn.lock").exists()


def test_ctrl_c_reported_as_a_librarys_own_error_is_an_interrupt(capsys, monkeypatch):
    """Ctrl-C inside an import or a library's C code comes out as that library's error
    (Python: "Error calling __set_name__", with the interrupt as its cause): exit 130,
    one line, no traceback."""
    import unidyn.cli as c
    import unidyn.cli.robots

    def interrupted_import(args):
        try:
            raise KeyboardInterrupt
        except KeyboardInterrupt as err:
            raise RuntimeError("Error calling __set_name__") from err
    monkeypatch.setattr(unidyn.cli.robots, "unidyn_robots", interrupted_import)
    assert c.main(["robots"]) == 130
    assert capsys.readouterr().err.strip() == "unidyn: interrupted"

    def plain_bug(args):
        raise RuntimeError("a bug")
    monkeypatch.setattr(unidyn.cli.robots, "unidyn_robots", plain_bug)
    with pytest.raises(RuntimeError, match="a bug"):  # anything else: a traceback as ever
        c.main(["robots"])


def test_an_interrupt_lost_in_a_finaliser_is_sent_again():
    """Python cannot raise a KeyboardInterrupt that lands in a finaliser; it passes it to
    sys.unraisablehook. The command's hook sends the signal again, from another thread,
    so that it stops the command where it can."""
    import signal
    import time
    from types import SimpleNamespace

    from unidyn import process
    got = []
    previous = signal.signal(signal.SIGINT, lambda *a: got.append("int"))
    try:
        process._unraisable(SimpleNamespace(exc_value=KeyboardInterrupt()))
        t_end = time.monotonic() + 5
        while not got and time.monotonic() < t_end:
            time.sleep(0.01)
        assert got == ["int"]
    finally:
        signal.signal(signal.SIGINT, previous)


def test_a_run_without_a_scenario_says_what_it_runs_before_it_runs(tmp_path, capsys):
    code, out, err = run_cli(capsys, "run", "--T", "1", "--engine", "batch", "--out", tmp_path)
    assert code == 0
    assert out.splitlines()[0] == ("running    the defaults (no scenario file, --paper or "
                                   "--from given): case adaptive, robot p3dx_laser, T = 1 s, "
                                   "engine batch"), out
    code, out, _ = run_cli(capsys, "run", "--paper", "1", "--T", "1", "--engine", "batch",
                           "--out", tmp_path / "p")
    assert code == 0 and "the defaults" not in out


@pytest.mark.slow
def test_a_sweep_is_not_written_into_a_runs_folder_nor_a_run_into_a_sweeps(tmp_path, capsys):
    run_dir, sweep_dir = tmp_path / "run", tmp_path / "sweep"
    assert run_cli(capsys, "run", "--paper", "3", "--T", "1", "--engine", "batch",
                   "--out", run_dir)[0] == 0
    sweep = tmp_path / "s.toml"
    sweep.write_text('[base]\nT = 1\nnoise = "off"\n[grid]\nkxy = [1, 2]\n')
    assert run_cli(capsys, "sweep", sweep, "--out", sweep_dir)[0] == 0
    before = {p.name: p.read_bytes() for d in (run_dir, sweep_dir) for p in d.iterdir()
              if p.is_file()}
    code, out, err = run_cli(capsys, "sweep", sweep, "--out", run_dir, "--overwrite")
    assert code == 2 and out == ""
    assert_one_line_error(err, f"{run_dir} holds a run (6 files, e.g. timeseries.csv, "
                               "summary.json, path.png)",
                          "; choose another --out for a sweep")
    code, _, err = run_cli(capsys, "run", "--paper", "3", "--T", "1", "--out", sweep_dir)
    assert code == 2
    assert_one_line_error(err, f"{sweep_dir} holds a sweep (metrics.csv",
                          "; choose another --out for a run")
    code, _, err = run_cli(capsys, "run", "--paper", "3", "--T", "1", "--seeds", "2",
                           "--out", run_dir)
    assert code == 2
    assert_one_line_error(err, f"{run_dir} holds a run", "; choose another --out for seed runs")
    after = {p.name: p.read_bytes() for d in (run_dir, sweep_dir) for p in d.iterdir()
             if p.is_file()}
    assert after == before
