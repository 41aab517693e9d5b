"""Nothing is lost: the command line under real signals, in real processes.

Every test starts ``python -m unidyn`` in a subprocess (in a temporary folder, so
the checkout's own folder name plays no part), sends SIGINT (Ctrl-C) or SIGKILL
at a seeded-random moment, and then looks at the output folder: it holds either
the results it held before, byte for byte, or complete new ones; never neither,
never a mix. Sweeps interrupted at random rows and resumed give a metrics.csv
byte-identical to an uninterrupted sweep; two sweeps started into one folder do
not both write it.
"""

from __future__ import annotations

import csv
import json
import os
import random
import shlex
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from processes import cpu_seconds

pytestmark = pytest.mark.reliability

RUN_FILES = {"timeseries.csv", "summary.json", "path.png", "error.png", "positions.png",
             "velocities.png"}
SWEEP_TOML = """name = "nothing lost"
[base]
case = "adaptive"
T = {T}
noise = {{position_std = 0.01, velocity_std = 0.0141, seed = 0}}
[grid]
kxy = {gains}
seed = [0, 1]
"""


#: How a command stopped by Ctrl-C ends: by SIGINT, once it has cleaned up and said
#: what it kept (a shell shows status 130 and stops the script that ran it)
INTERRUPTED = -signal.SIGINT


def _no_sigint_ignore():  # a shell's background job may inherit SIGINT ignored
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def start(cwd: Path, *args, env=None) -> subprocess.Popen:
    env = dict(os.environ, MPLBACKEND="Agg", PYTHONUNBUFFERED="1", **(env or {}))
    return subprocess.Popen([sys.executable, "-m", "unidyn", *map(str, args)], cwd=cwd,
                            env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True, preexec_fn=_no_sigint_ignore)


def finish(p: subprocess.Popen, timeout=180):
    out, err = p.communicate(timeout=timeout)
    return p.returncode, out, err


def cli(cwd: Path, *args, timeout=180, env=None):
    return finish(start(cwd, *args, env=env), timeout)


def without_numba(folder: Path) -> dict:
    """Environment for a child process in which ``import numba`` fails (the batch
    engine then runs its kernels as plain Python)."""
    pkg = folder / "no-numba" / "numba"
    pkg.mkdir(parents=True, exist_ok=True)
    (pkg / "__init__.py").write_text("raise ImportError('numba hidden for this test')\n")
    return {"PYTHONPATH": os.pathsep.join(filter(None, [str(pkg.parent),
                                                        os.environ.get("PYTHONPATH")]))}


def files(folder: Path) -> dict:
    """The files of ``folder`` and their bytes, but for the lock file (a SIGKILL leaves
    it behind; the next writer takes it over, as a test below checks)."""
    if not folder.is_dir():
        return {}
    return {p.name: p.read_bytes() for p in sorted(folder.iterdir())
            if p.is_file() and p.name != ".unidyn.lock"}


def leftovers(parent: Path, name: str) -> list:
    """What a command left of its work on ``parent/name``: its private folders inside,
    and anything beside it (nothing is ever written there)."""
    inside = (parent / name).glob(".unidyn-*-new-*") if (parent / name).is_dir() else []
    return [p.name for p in parent.iterdir() if p.name.startswith(f".{name}.")] + [
        f"{name}/{p.name}" for p in inside]


def complete_run(folder: Path, T: float) -> bool:
    """A complete run of duration T: both result files, every figure, consistent."""
    got = files(folder)
    if not RUN_FILES <= set(got):
        return False
    summary = json.loads(got["summary.json"])
    rows = got["timeseries.csv"].decode().strip().splitlines()
    return (summary["complete"] is True and summary["scenario"]["T"] == T
            and len(rows) == 1 + summary["samples"] and float(rows[-1].split(",")[0]) == T)


def kill_at_random(p: subprocess.Popen, rng: random.Random, low: float, high: float, sig,
                   after_line: bool = False):
    """Send ``sig`` at a random moment in [low, high] s from now (or, with
    ``after_line``, from the first line on stderr: the run has started writing)."""
    first = p.stderr.readline() if after_line else ""
    time.sleep(rng.uniform(low, high))
    if p.poll() is None:
        p.send_signal(sig)
    code, out, err = finish(p)
    return code, out, first + err


def loading(code: int, err: str) -> bool:
    """Ctrl-C while Python was still importing the package, before any unidyn code
    ran: Python's own traceback, nothing started, nothing written."""
    return (code == -signal.SIGINT and err.strip().endswith("KeyboardInterrupt")
            and "_run_module_as_main" in err and "unidyn/cli/" not in err)


# --------------------------------------------------------------------------- run

@pytest.mark.slow
def test_an_interrupted_overwrite_keeps_the_old_run_or_writes_the_new(tmp_path):
    rng = random.Random(20261123)
    assert cli(tmp_path, "run", "--set", "T=2", "--out", "X")[0] == 0
    old = files(tmp_path / "X")
    t0 = time.monotonic()
    assert cli(tmp_path, "run", "--set", "T=3", "--out", "Y")[0] == 0
    took = time.monotonic() - t0  # how long a run takes here: kill within it
    outcomes = []
    for sig in (signal.SIGINT, signal.SIGKILL):
        p = start(tmp_path, "run", "--set", "T=3", "--overwrite", "--out", "X")
        code, _, err = kill_at_random(p, rng, 0.0, 0.8 * took, sig, after_line=True)
        assert err.startswith("unidyn: replacing X/ (7 files, e.g. timeseries.csv, summary.json, "
                              "path.png)")
        now = files(tmp_path / "X")
        if now == old:
            outcomes.append("old")
            if sig == signal.SIGINT and code == INTERRUPTED:
                assert "X is as it was before this run" in err
        else:
            assert complete_run(tmp_path / "X", 3.0), (code, err, sorted(now))
            outcomes.append("new")
            old = now
            assert cli(tmp_path, "run", "--set", "T=2", "--overwrite", "--out", "X")[0] == 0
            old = files(tmp_path / "X")
        assert code in (0, INTERRUPTED, -signal.SIGKILL), (code, err)
        assert "Traceback" not in err
    # whatever a kill left beside X is cleaned up by the next command writing there
    assert cli(tmp_path, "run", "--set", "T=1", "--overwrite", "--out", "X")[0] == 0
    assert leftovers(tmp_path, "X") == [] and complete_run(tmp_path / "X", 1.0)
    print(outcomes)


@pytest.mark.slow
def test_ctrl_c_after_the_command_finished_keeps_its_status_and_prints_no_traceback(tmp_path):
    """Ctrl-C in the second that Python takes to shut down after a finished command
    (numba's, matplotlib's and bdsim's finalisers run then): the results are whole,
    the exit status is the command's own, and no finaliser prints a traceback. The
    signal is sent by the process itself from an exit handler, so it lands during the
    shut-down, not by chance; the modules loaded are those of a real run."""
    child = ("import atexit, os, signal\n"
             "from unidyn.cli import script\n"
             "atexit.register(os.kill, os.getpid(), signal.SIGINT)\n"
             "script(['run', '--set', 'T=1', '--out', 'R'])\n")
    env = dict(os.environ, MPLBACKEND="Agg")
    p = subprocess.run([sys.executable, "-c", child], cwd=tmp_path, env=env, text=True,
                       capture_output=True, timeout=180, preexec_fn=_no_sigint_ignore)
    assert p.returncode == 0, (p.returncode, p.stderr)
    assert "Traceback" not in p.stderr and "KeyboardInterrupt" not in p.stderr, p.stderr
    assert complete_run(tmp_path / "R", 1.0)


def test_an_interrupted_command_run_in_process_returns_130_and_leaves_the_caller_alone(
        tmp_path):
    """``entry`` called by a script (or a notebook): a Ctrl-C'd command returns 130; the
    caller's signal handling is as it was, its exit handlers run, and it exits with the
    status it chooses. Only the ``unidyn`` command ends its process by the signal."""
    child = ("import atexit, os, signal, subprocess, sys, threading\n"
             "import unidyn.cli as c, unidyn.cli.robots\n"
             "atexit.register(print, 'handler ran', flush=True)\n"
             "def cmd(args):\n"
             "    os.kill(os.getpid(), signal.SIGINT)\n"
             "    threading.Event().wait(10)\n"
             "unidyn.cli.robots.unidyn_robots = cmd\n"
             "before = signal.getsignal(signal.SIGINT), signal.getsignal(signal.SIGTERM)\n"
             "print('status', c.entry(['robots']), flush=True)\n"
             "after = signal.getsignal(signal.SIGINT), signal.getsignal(signal.SIGTERM)\n"
             "print('handlers', 'restored' if after == before else after, flush=True)\n"
             "sys.exit(0)\n")
    p = subprocess.run([sys.executable, "-c", child], cwd=tmp_path, text=True,
                       capture_output=True, timeout=60, preexec_fn=_no_sigint_ignore)
    assert p.returncode == 0, (p.returncode, p.stdout, p.stderr)
    assert p.stdout.split("\n")[:3] == ["status 130", "handlers restored", "handler ran"], \
        p.stdout
    assert p.stderr.strip() == "unidyn: interrupted", p.stderr


@pytest.mark.slow
def test_an_interrupted_first_run_leaves_nothing_or_everything(tmp_path):
    rng = random.Random(7)
    for i, sig in enumerate((signal.SIGINT, signal.SIGKILL)):
        p = start(tmp_path, "run", "--set", "T=2", "--out", f"R{i}")
        code, _, err = kill_at_random(p, rng, 0.3, 4.0, sig)
        got = files(tmp_path / f"R{i}")
        assert got == {} or complete_run(tmp_path / f"R{i}", 2.0), (code, err, sorted(got))
        assert "Traceback" not in err or loading(code, err), err


@pytest.mark.slow
def test_ctrl_c_during_a_long_bdsim_run_stops_it_and_keeps_the_old_results(tmp_path):
    rng = random.Random(4)
    assert cli(tmp_path, "run", "--paper", "4", "--T", "1", "--engine", "batch",
               "--out", "Y")[0] == 0
    old = files(tmp_path / "Y")
    p = start(tmp_path, "run", "--paper", "4", "--engine", "bdsim", "--overwrite", "--out", "Y")
    # start-up (imports, building the diagram) takes about 2 s of CPU; past the wait
    # the 200 s run is integrating, however busy the machine is
    wait, deadline = rng.uniform(4.0, 6.0), time.monotonic() + 120
    while cpu_seconds(p.pid) < wait and time.monotonic() < deadline:
        time.sleep(0.2)
    assert p.poll() is None
    p.send_signal(signal.SIGINT)
    code, out, err = finish(p)  # stopped by Ctrl-C, not by reaching its end (200 s)
    assert code == INTERRUPTED, err
    assert "Traceback" not in err and "IAE" not in out
    assert files(tmp_path / "Y") == old and leftovers(tmp_path, "Y") == []
    # what the diagram had computed is kept beside the old results, marked incomplete
    assert "interrupted at t = " in err and "Y keeps its previous results" in err, err
    partial = json.loads((tmp_path / "Y.incomplete" / "summary.json").read_text())
    assert partial["complete"] is False and partial["numerical_error"] is None
    assert 0 < partial["t_end"] < 200 and partial["metrics"]["iae"] > 0  # of the part computed


@pytest.mark.slow
def test_ctrl_c_during_a_long_batch_run_writes_the_part_computed(tmp_path):
    """The compiled engine returns to Python between time slices, so Ctrl-C stops it
    and the CLI writes the computed part, marked incomplete."""
    # a short run first compiles the kernels, if this cache has not yet got them, so
    # that the long run below is integrating (not compiling) when Ctrl-C comes
    code, out, err = cli(tmp_path, "run", "--case", "compensated", "--T", "1", "--set",
                         "noise=off", "--out", "warm")
    assert code == 0, err
    p = start(tmp_path, "run", "--case", "compensated", "--T", "400000", "--set",
              "log_every=100", "--set", "noise=off", "--out", "L")
    # start-up and loading the cached kernels take about 2 s of CPU; past 5 s it is
    # integrating, however busy the machine is
    deadline = time.monotonic() + 120
    while cpu_seconds(p.pid) < 5.0 and time.monotonic() < deadline:
        time.sleep(0.2)
    assert p.poll() is None, finish(p)
    p.send_signal(signal.SIGINT)
    code, out, err = finish(p)
    assert code == INTERRUPTED and "interrupted at t = " in err and "Traceback" not in err, err
    summary = json.loads((tmp_path / "L" / "summary.json").read_text())
    assert summary["complete"] is False and summary["numerical_error"] is None
    assert 0 < summary["t_end"] < 400000
    rows = (tmp_path / "L" / "timeseries.csv").read_text().strip().splitlines()
    t = [float(r.split(",")[0]) for r in rows[1:]]
    assert t[0] == 0 and t[-1] == summary["t_end"] and len(t) == summary["samples"]
    assert all(abs((b - a) - 10.0) < 1e-6 for a, b in zip(t, t[1:]))  # every 100th sample


# ------------------------------------------------------------------------- sweeps

def sweep_file(folder: Path, T=30, gains="[0.5, 1.0, 2.0, 4.0, 8.0, 16.0]") -> Path:
    f = folder / "sweep.toml"
    f.write_text(SWEEP_TOML.format(T=T, gains=gains))
    return f


def rows_in(path: Path) -> int:
    try:
        return max(0, len(path.read_text().splitlines()) - 1)
    except FileNotFoundError:
        return 0


def kill_after_rows(p, path: Path, rows: int, sig, timeout=120) -> tuple:
    """Send ``sig`` once metrics.csv holds at least ``rows`` rows (or the sweep ended),
    but not before the command has said it started: a folder that holds them already
    (a kill that came too late) would otherwise have the signal land while Python
    starts, which is another test's subject."""
    first = p.stdout.readline()  # "sweep: ...", or "" if it ended without a word
    t_end = time.monotonic() + timeout
    while p.poll() is None and rows_in(path) < rows and time.monotonic() < t_end:
        time.sleep(0.005)
    if p.poll() is None:
        p.send_signal(sig)
    code, out, err = finish(p)
    return code, first + out, err


@pytest.mark.parametrize("engine, T, gains, chunk", [
    pytest.param("batch", 30, "[0.5, 1.0, 2.0, 4.0, 8.0, 16.0]", 2, marks=pytest.mark.slow),
    pytest.param("batch-plain", 10, "[0.5, 2.0, 8.0]", 2, marks=pytest.mark.slow),
    pytest.param("bdsim", 1, "[1.0, 4.0]", 1, marks=pytest.mark.slow),
], ids=["batch", "batch-plain", "bdsim"])
def test_sweeps_killed_at_random_rows_resume_byte_identical(tmp_path, engine, T, gains, chunk):
    """The uninterrupted sweep runs in one chunk (the default size); the killed ones
    in chunks of ``chunk`` points and the last resume in chunks of ``chunk + 1``, so
    no chunk holds the same points as another run's."""
    rng = random.Random(11)
    f = sweep_file(tmp_path, T, gains)
    env = without_numba(tmp_path) if engine == "batch-plain" else None
    engine = engine.split("-")[0]
    common = ["--engine", engine, "--chunk-size", chunk, "--no-progress"]
    code, out, err = cli(tmp_path, "sweep", f, "--out", "whole", "--engine", engine,
                         "--chunk-size", 40, "--no-progress", env=env)
    assert code == 0, err
    if env:
        assert cli(tmp_path, "run", "--T", "1", "--out", "probe", env=env)[0] == 0
        assert json.loads((tmp_path / "probe" / "summary.json").read_text())["backend"] == "plain"
    whole = (tmp_path / "whole" / "metrics.csv").read_bytes()
    n = rows_in(tmp_path / "whole" / "metrics.csv")
    cuts = 0
    for sig in (signal.SIGKILL, signal.SIGINT):
        at = rng.randint(1, n - 1)
        p = start(tmp_path, "sweep", f, "--out", "cut", *common, env=env)
        code, _, err = kill_after_rows(p, tmp_path / "cut" / "metrics.csv", at, sig)
        assert "Traceback" not in err, err
        kept = rows_in(tmp_path / "cut" / "metrics.csv")
        cuts += kept < n
        if sig == signal.SIGINT:
            assert code in (0, INTERRUPTED), err
            # what is left is said (unless Ctrl-C came as the sweep was wrapping up)
            assert code == 0 or "again to resume" in err or err.strip() == \
                "unidyn: interrupted", err
            if "again to resume" in err:
                assert f"{kept} of {n} points are in" in err
    code, out, err = cli(tmp_path, "sweep", f, "--out", "cut", "--engine", engine,
                         "--chunk-size", chunk + 1, "--no-progress", env=env)
    assert code == 0, err
    assert (tmp_path / "cut" / "metrics.csv").read_bytes() == whole
    assert cuts >= 1  # at least one kill landed mid-sweep
    assert not (tmp_path / "cut" / ".unidyn.lock").exists()


#: the ``unidyn`` console script of the environment running the tests
CONSOLE_SCRIPT = Path(sys.executable).with_name("unidyn")


@pytest.mark.slow
@pytest.mark.parametrize("launch", [
    [sys.executable, "-m", "unidyn"],
    pytest.param([str(CONSOLE_SCRIPT)], marks=pytest.mark.skipif(
        not CONSOLE_SCRIPT.exists(), reason="no unidyn console script beside Python"))],
    ids=["python -m unidyn", "console script"])
def test_ctrl_c_stops_the_shell_script_that_ran_the_command(tmp_path, launch):
    """Ctrl-C in a terminal signals the shell and the command alike. bash waits for
    the command and goes on with its script if the command merely exited (status
    130: "it handled Ctrl-C"), and stops only if the command ended by SIGINT. A loop of
    sweeps must stop at Ctrl-C, and the rows kept are said."""
    f = sweep_file(tmp_path, T=100000, gains="[0.5, 1.0]")
    env = dict(os.environ, MPLBACKEND="Agg", PYTHONUNBUFFERED="1",
               **without_numba(tmp_path))  # plain Python: nothing to compile first
    cmd = " ".join(map(shlex.quote, [*launch, "sweep", str(f), "--out", "S",
                                     "--engine", "batch", "--no-progress", "--yes"]))
    p = subprocess.Popen(["bash", "-c", f"{cmd}; echo went on: $?"], cwd=tmp_path, env=env,
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                         preexec_fn=_no_sigint_ignore, start_new_session=True)
    first = p.stdout.readline()
    assert first.startswith("sweep: "), first + p.communicate()[1]
    time.sleep(random.Random(2).uniform(0.5, 1.5))
    os.killpg(p.pid, signal.SIGINT)  # as a terminal does: the whole foreground group
    code, out, err = finish(p)
    assert "went on" not in out, (out, err)
    assert code == INTERRUPTED, (code, err)
    assert "Traceback" not in err and "unidyn: interrupted" in err, err
    assert "no point had finished; nothing was written" in err, err


#: sweep options of the tests that replace one sweep by another
COMMON = ["--chunk-size", "2", "--no-progress"]


def a_sweep_and_another(tmp_path) -> tuple:
    """A finished sweep in S and the file of a different one: (its file, the other's,
    S's files)."""
    f = sweep_file(tmp_path)
    assert cli(tmp_path, "sweep", f, "--out", "S", *COMMON)[0] == 0
    g = tmp_path / "other.toml"
    g.write_text(SWEEP_TOML.format(T=20, gains="[0.5, 1.0, 2.0, 4.0, 8.0, 16.0]"))
    return f, g, files(tmp_path / "S")


@pytest.mark.slow
def test_a_killed_restart_keeps_the_old_rows_or_writes_all_new_ones(tmp_path):
    rng = random.Random(3)
    common = COMMON
    f, g, old = a_sweep_and_another(tmp_path)
    assert cli(tmp_path, "sweep", g, "--out", "S2", *common)[0] == 0
    new = (tmp_path / "S2" / "metrics.csv").read_bytes()
    # deleting finished rows needs --overwrite, and the refusal names them
    for args in ((g,), (f, "--no-resume")):
        code, _, err = cli(tmp_path, "sweep", *args, "--out", "S", *common)
        assert code == 2 and "12 finished row(s)" in err and "--overwrite" in err, err
        assert files(tmp_path / "S") == old
    seen = set()
    for sig in (signal.SIGKILL, signal.SIGINT):
        p = start(tmp_path, "sweep", g, "--out", "S", "--overwrite", *common)
        # the new rows go to a private folder: kill at a random moment of the run
        code, _, err = kill_at_random(p, rng, 0.5, 6.0, sig)
        assert "Traceback" not in err or loading(code, err), err
        got = files(tmp_path / "S")
        if sig == signal.SIGINT and code == INTERRUPTED:  # the rows kept are said
            assert "S is as it was (12 finished row(s)" in err or err.strip() == \
                "unidyn: interrupted", err
        if got == old:
            seen.add("old")
        else:
            assert got["metrics.csv"] == new, (code, err)
            seen.add("new")
            break
    print(seen)
    assert cli(tmp_path, "sweep", g, "--out", "S", "--overwrite", *common)[0] == 0
    assert (tmp_path / "S" / "metrics.csv").read_bytes() == new
    assert leftovers(tmp_path, "S") == [] and not (tmp_path / "S" / ".unidyn.lock").exists()


@pytest.mark.slow
def test_sigterm_stops_a_sweep_like_ctrl_c_and_leaves_no_staging_folder(tmp_path):
    """kill (SIGTERM) during a sweep that replaces another: the old rows stay, the
    private folder and temporary files go, then the process ends by SIGTERM (the
    shell's status 143)."""
    _, g, old = a_sweep_and_another(tmp_path)
    p = start(tmp_path, "sweep", g, "--out", "S", "--overwrite", *COMMON)
    t_end = time.monotonic() + 120
    while p.poll() is None and time.monotonic() < t_end and not any(
            rows_in(tmp_path / name / "metrics.csv") >= 2 for name in leftovers(tmp_path, "S")):
        # the new sweep's rows go into its private folder inside S
        time.sleep(0.005)
    assert p.poll() is None, "the sweep ended before it could be killed"
    p.send_signal(signal.SIGTERM)
    code, _, err = finish(p)
    assert code == -signal.SIGTERM and "unidyn: terminated: S is as it was (12 finished row(s)" in err, err
    assert "Traceback" not in err, err
    assert files(tmp_path / "S") == old
    assert leftovers(tmp_path, "S") == [] and not (tmp_path / "S" / ".unidyn.lock").exists()
    assert not [q for q in (tmp_path / "S").iterdir() if q.name.endswith(".tmp")]


@pytest.mark.slow
def test_two_sweeps_into_one_folder_never_both_write_it(tmp_path):
    f = sweep_file(tmp_path, T=1, gains="[1.0, 2.0, 4.0]")
    common = ["--engine", "bdsim", "--no-progress"]
    a = start(tmp_path, "sweep", f, "--out", "S", *common)
    lock = tmp_path / "S" / ".unidyn.lock"
    t_end = time.monotonic() + 60
    while not lock.exists() and a.poll() is None and time.monotonic() < t_end:
        time.sleep(0.01)
    assert a.poll() is None, finish(a)
    code_b, _, err_b = cli(tmp_path, "sweep", f, "--out", "S", *common)
    code_a, _, err_a = finish(a)
    assert code_a == 0, err_a
    assert code_b == 2 and f"PID {a.pid}" in err_b and "another unidyn process" in err_b
    assert len(err_b.strip().splitlines()) == 1
    code, out, _ = cli(tmp_path, "sweep", f, "--out", "whole", *common)
    assert code == 0
    # one writer: every row once, as an uninterrupted sweep writes them
    assert (tmp_path / "S" / "metrics.csv").read_bytes() == \
        (tmp_path / "whole" / "metrics.csv").read_bytes()
    with open(tmp_path / "S" / "metrics.csv", newline="") as fh:
        idx = [r["index"] for r in csv.DictReader(fh)]
    assert idx == [str(i) for i in range(6)]


@pytest.mark.slow
def test_a_failed_sweep_start_leaves_no_folder(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text("[grid]\nkxy = [1, -2]\n")
    code, _, err = cli(tmp_path, "sweep", bad, "--out", "A", "--no-progress")
    assert code == 2 and "kxy" in err and not (tmp_path / "A").exists()
    f = sweep_file(tmp_path, T=1, gains="[1.0]")
    code, _, err = cli(tmp_path, "sweep", f, "--out", "B", "--dask", "tcp://127.0.0.1:9",
                       "--no-progress")
    assert code == 2 and "--dask" in err and "Traceback" not in err
    assert len(err.strip().splitlines()) == 1 and not (tmp_path / "B").exists()


# ---------------------------------------------------------------------- identify

def write_log(path: Path, seed: int, T=40.0):
    from unidyn import identification as ident
    exc = ident.excitation(T, 0.05, robot="p3dx")
    log = ident.simulate_log("p3dx", exc, noise_std=0.005, seed=seed, commands="held")
    with open(path, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["t", "u_ref", "w_ref", "u", "w"])
        for row in zip(*(log[k] for k in ("t", "u_ref", "w_ref", "u", "w"))):
            w.writerow([repr(float(x)) for x in row])


@pytest.mark.slow
def test_an_interrupted_identify_keeps_the_old_theta(tmp_path):
    rng = random.Random(5)
    write_log(tmp_path / "a.csv", 1)
    write_log(tmp_path / "b.csv", 2)
    code, _, err = cli(tmp_path, "identify", "a.csv", "--out", "I")
    assert code == 0, err
    old = files(tmp_path / "I")
    t0 = time.monotonic()
    assert cli(tmp_path, "identify", "b.csv", "--out", "J")[0] == 0
    took = time.monotonic() - t0
    new_theta = json.loads((tmp_path / "J" / "theta.json").read_text())
    for sig in (signal.SIGINT, signal.SIGKILL):
        p = start(tmp_path, "identify", "b.csv", "--overwrite", "--out", "I")
        code, _, err = kill_at_random(p, rng, 0.2, 1.2 * took, sig)
        got = files(tmp_path / "I")
        assert got == old or json.loads(got["theta.json"]) == new_theta, (code, err)
        assert "Traceback" not in err or loading(code, err), err
        if got != old:
            break
    # a log that cannot be identified leaves theta.json as it was
    (tmp_path / "bad.csv").write_text("t,u_ref\n0,1\n")
    before = files(tmp_path / "I")
    code, _, err = cli(tmp_path, "identify", "bad.csv", "--overwrite", "--out", "I")
    assert code == 2 and files(tmp_path / "I") == before


@pytest.mark.slow
def test_ctrl_c_during_the_default_job_stops_its_workers_and_keeps_the_old_results(tmp_path):
    """examples/paper_section5.py runs the four simulations in worker processes;
    Ctrl-C to it (the main process only, as a terminal sends it to the whole group
    but the workers ignore it) stops it and its workers promptly and leaves --out
    as it was."""
    script = Path(__file__).resolve().parents[2] / "examples" / "paper_section5.py"
    out = tmp_path / "S"
    sys.path.insert(0, str(script.parent))
    try:
        from paper_section5 import OWNED
    finally:
        sys.path.remove(str(script.parent))
    from unidyn.results.folders import staged_output
    with staged_output(out, kind="section5", names=OWNED, overwrite=False) as stage:
        (stage.path / "claims.md").write_text("earlier results\n")  # written as the script does
    old = files(out)
    env = dict(os.environ, MPLBACKEND="Agg", PYTHONUNBUFFERED="1")
    p = subprocess.Popen([sys.executable, str(script), "--out", str(out), "--overwrite",
                          "--processes", "2"], cwd=tmp_path, env=env, stdout=subprocess.PIPE,
                         stderr=subprocess.PIPE, text=True, preexec_fn=_no_sigint_ignore)
    deadline = time.monotonic() + 60
    workers = []
    while len(workers) < 2 and time.monotonic() < deadline and p.poll() is None:
        time.sleep(0.5)
        workers = subprocess.run(["pgrep", "-P", str(p.pid)], capture_output=True,
                                 text=True).stdout.split()
    assert len(workers) >= 2, "the workers did not start"
    time.sleep(random.Random(5).uniform(1.0, 3.0))
    assert p.poll() is None
    p.send_signal(signal.SIGINT)
    code, out_text, err = finish(p, timeout=60)  # a guard against a hang, not a bound
    assert code == INTERRUPTED and "Traceback" not in err, err
    assert "interrupted" in err
    assert files(out) == old and leftovers(tmp_path, "S") == []
    time.sleep(0.5)
    assert [w for w in workers if _running(w)] == [], "workers left running"


def _running(pid: str) -> bool:
    try:
        return "zombie" not in Path(f"/proc/{pid}/status").read_text().lower()
    except (FileNotFoundError, ProcessLookupError):
        return False
