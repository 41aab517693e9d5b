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


# ------------------------------------------------------------ the plain-Python route

def _function_reference(T):
    """The paper's figure eight as a Python function: the batch engine runs it as
    plain Python (compiled code cannot call it)."""
    ref = unidyn.model.trajectories.FigureEight()

    def f(t):
        return ref.position(t), ref.velocity(t)
    return Scenario.paper(3, T=T, trajectory=unidyn.model.trajectories.FunctionTrajectory(f))


def test_a_long_plain_python_job_warns_once_at_its_start_with_its_time_and_fix():
    """250 s at Ts = 0.1 s is 2500 sample intervals; at 3 ms each, 7.5 s per run: four
    runs take 30 s and warn, one run of 2 s does not."""
    import warnings

    from unidyn.engines import PlainPythonWarning, plain_cost, warn_if_plain
    long = [_function_reference(250.0)] * 4
    seconds, fix = plain_cost(long)
    assert seconds == pytest.approx(4 * 2500 * 3e-3)
    assert "FunctionTrajectory" in fix and "figure_eight" in fix
    with pytest.warns(PlainPythonWarning, match=r"about 30 s of CPU for these runs; a reference"):
        warn_if_plain(long)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        warn_if_plain([_function_reference(2.0)])          # short: no warning
        warn_if_plain([Scenario.paper(3, T=250.0)] * 100)  # compiled: none
    assert plain_cost([Scenario.paper(3, T=250.0)]) is None
    assert "backend='plain' was asked for" in plain_cost([Scenario.paper(3)], "plain")[1]


@pytest.mark.slow
def test_without_numba_a_long_job_names_numba_and_its_time(tmp_path):
    """In a process where numba cannot be imported (a platform without it), the paper's
    run over 250 s, eight seeds, is a minute of plain Python: the warning says so and
    how to install numba."""
    import os
    import subprocess
    import sys
    pkg = tmp_path / "no-numba" / "numba"
    pkg.mkdir(parents=True)
    (pkg / "__init__.py").write_text("raise ImportError('numba hidden for this test')\n")
    code = ("import warnings, unidyn\nfrom unidyn.engines import warn_if_plain\n"
            "with warnings.catch_warnings(record=True) as w:\n"
            "    warnings.simplefilter('always')\n"
            "    warn_if_plain([unidyn.Scenario.paper(3, T=250)] * 8)\n"
            "print(*[str(x.message) for x in w], sep='\\n')\n")
    env = {**os.environ, "PYTHONPATH": str(pkg.parent), "MPLBACKEND": "Agg"}
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env,
                       cwd=tmp_path, timeout=300)
    assert p.returncode == 0, p.stderr
    # 8 runs x 2500 intervals x 3 ms = 60 s
    assert "about 60 s of CPU for these runs; numba is not installed (pip install numba" in p.stdout



@pytest.mark.slow
def test_a_sweep_without_numba_warns_at_its_start_with_its_time(tmp_path):
    """unidyn sweep where numba cannot be imported: before the first point, one line
    names the time of its 4 runs of 250 s as plain Python (4 x 2500 x 3 ms = 30 s) and
    how to install numba; the sweep is then stopped by Ctrl-C."""
    import os
    import signal
    import subprocess
    import sys
    import time
    pkg = tmp_path / "no-numba" / "numba"
    pkg.mkdir(parents=True)
    (pkg / "__init__.py").write_text("raise ImportError('numba hidden for this test')\n")
    env = {**os.environ, "PYTHONPATH": str(pkg.parent), "MPLBACKEND": "Agg"}
    p = subprocess.Popen([sys.executable, "-m", "unidyn", "sweep", "--paper-fig11", "--gains",
                          "1", "--out", str(tmp_path / "out")], env=env, cwd=tmp_path,
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        line = p.stderr.readline()
    finally:
        time.sleep(0.5)
        p.send_signal(signal.SIGINT)
        p.communicate(timeout=120)
    assert line.startswith("unidyn: warning: the batch engine runs as plain Python here"), line
    assert "about 30 s of CPU for these runs; numba is not installed (pip install numba" in line

# ------------------------------------------------------------------- over seeds

def test_seeds_run_the_scenario_once_per_noise_seed_each_as_run_alone():
    """seeds=3 runs the seeds 5, 6, 7 of a scenario whose seed is 5, in one call, each
    bit for bit the run of that seed alone; the statistics are numpy's mean, sample
    standard deviation and standard error of those runs' metrics."""
    sc = Scenario.paper(3, T=4.0).replace(noise={"seed": 5})
    runs = unidyn.run(sc, seeds=3)
    assert runs.seeds == (5, 6, 7) and len(runs) == 3
    alone = [unidyn.simulate_batch([sc.replace(noise={"seed": s})])[0] for s in (5, 6, 7)]
    for r, a in zip(runs, alone):
        np.testing.assert_array_equal(r.pose, a.pose)
        assert r.metrics == a.metrics
    st = runs.statistics
    assert st["n"] == 3 and st["incomplete"] == 0 and st["sensitive"] == 0
    for m in ("iae", "itae", "error_final"):
        x = np.array([a.metrics[m] for a in alone])
        assert st[f"{m}_mean"] == pytest.approx(x.mean(), rel=1e-14)
        assert st[f"{m}_std"] == pytest.approx(x.std(ddof=1), rel=1e-12)
        assert st[f"{m}_sem"] == pytest.approx(x.std(ddof=1) / np.sqrt(3), rel=1e-12)
    # another seed moves the IAE by far more than its numerical error
    spread = st["iae_std"] / st["iae_mean"]
    assert spread > 10 * max(r.numerical_error["iae"] for r in runs)


def test_seeds_print_each_metric_as_mean_plus_minus_standard_error_with_n():
    runs = unidyn.run(Scenario.paper(3, T=4.0), seeds=[0, 2, 4, 6])
    text = repr(runs)
    st = runs.statistics
    from unidyn.sweeps.seeds import plus_minus
    assert f"iae          {plus_minus(st['iae_mean'], st['iae_sem'], 'm·s')} (n = 4)" in text
    assert "over 4 noise seeds (0, 2, 4, 6)" in text
    assert "sensitive    0 of 4 runs" in text
    for line in text.splitlines():  # beside a metric only where it is not small
        if "numerical error" in line and "±" in line:
            m = line.split()[0]
            assert runs.numerical_error_small(m) is False


def test_a_metric_exact_and_alike_over_seeds_has_a_small_numerical_error():
    # the peak distance error of these runs is the start's offset, 0.2 m whatever the
    # seed: no spread, and no numerical error (the initial state is exact)
    from unidyn.sweeps.statistics import numerical_error_small
    assert numerical_error_small(0.0, 0.2, 0.0) is True
    assert numerical_error_small(1e-9, 0.2, 0.0) is False
    assert numerical_error_small(1e-6, 1.0, 1e-4) is True
    assert numerical_error_small(1e-4, 1.0, 1e-4) is False


@pytest.mark.parametrize("mean, sem, text", [
    (2.74382, 0.0213, "2.744 ± 0.021"), (2.74382, 0.00002, "2.743820 ± 0.000020"),
    (1234.56, 12.3, "1235 ± 12"), (0.5, None, "0.5"), (3e12, 4e10, "3.000e+12 ± 4.0e+10")])
def test_plus_minus_rounds_the_mean_to_the_standard_error_s_second_digit(mean, sem, text):
    from unidyn.sweeps.seeds import plus_minus
    assert plus_minus(mean, sem) == text


def test_seeds_need_noise_and_distinct_seeds():
    with pytest.raises(ValidationError, match="no measurement noise"):
        unidyn.run(Scenario.paper(3, T=1.0, noise=None), seeds=3)
    for bad, match in ((0, "seeds must be"), ([1, 1], "twice"), ([], "empty"),
                       ([-1], "seeds"), (True, "seeds")):
        with pytest.raises(ValidationError, match=match):
            unidyn.run(Scenario.paper(3, T=1.0), seeds=bad)


def test_seed_runs_write_their_runs_statistics_series_and_figure(tmp_path):
    import csv
    runs = unidyn.run(Scenario.paper(4, T=3.0), seeds=3)
    runs.save(tmp_path / "s")
    folder = tmp_path / "s"
    assert {p.name for p in folder.iterdir() if not p.name.startswith(".")} == {
        "runs.csv", "statistics.csv", "timeseries.csv", "summary.json", "error.png"}
    with open(folder / "statistics.csv", newline="") as fh:
        [st] = list(csv.DictReader(fh))
    assert float(st["iae_mean"]) == pytest.approx(np.mean([r.metrics["iae"] for r in runs]),
                                                  rel=1e-12)
    assert st["numerical_error_small"] in ("True", "False", "true", "false") and st["n"] == "3"
    with open(folder / "timeseries.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    assert len(rows) == sum(len(r.t) for r in runs)
    first = [r for r in rows if r["seed"] == "1"]
    np.testing.assert_allclose([float(r["x"]) for r in first], runs[1].pose[:, 0], rtol=1e-9)
    summary = json.loads((folder / "summary.json").read_text())
    assert summary["seeds"] == [0, 1, 2] and "standard error" in summary["uncertainty"]
    with pytest.raises(ValidationError, match="overwrite"):
        runs.save(folder)


# ------------------------------------------------------------ the command line

def test_unidyn_run_seeds_prints_mean_plus_minus_standard_error_and_writes_statistics(
        tmp_path, capsys):
    import csv

    from unidyn.sweeps.seeds import plus_minus
    assert main(["run", "--paper", "4", "--T", "3", "--seeds", "3",
                 "--out", str(tmp_path / "s")]) == 0
    out = capsys.readouterr().out
    with open(tmp_path / "s" / "statistics.csv", newline="") as fh:
        [st] = list(csv.DictReader(fh))
    with open(tmp_path / "s" / "runs.csv", newline="") as fh:
        runs = list(csv.DictReader(fh))
    assert [r["seed"] for r in runs] == ["0", "1", "2"]
    iae = np.array([float(r["iae"]) for r in runs])
    assert float(st["iae_mean"]) == pytest.approx(iae.mean(), rel=1e-12)
    assert float(st["iae_sem"]) == pytest.approx(iae.std(ddof=1) / np.sqrt(3), rel=1e-12)
    assert f"IAE        {plus_minus(iae.mean(), iae.std(ddof=1) / np.sqrt(3), 'm·s')} (n = 3)" in out
    assert "noise seeds 0-2 (3 runs)" in out and "sensitive  0 of 3 runs" in out
    assert (tmp_path / "s" / "error.png").stat().st_size > 0
    # the seeds continue from the scenario's own
    assert main(["run", "--paper", "4", "--T", "1", "--seeds", "2", "--set", "noise.seed=7",
                 "--out", str(tmp_path / "t")]) == 0
    assert "noise seeds 7-8 (2 runs)" in capsys.readouterr().out


def test_unidyn_run_seeds_refuses_what_it_cannot_do_in_one_line(tmp_path, capsys):
    for args, words in ((["--set", "noise=off"], "no noise"), (["--animate"], "--animate"),
                        (["--seeds", "0"], "at least 1")):
        seeds = [] if "--seeds" in args else ["--seeds", "2"]
        assert main(["run", "--paper", "3", "--T", "1", *seeds, *args,
                     "--out", str(tmp_path / "x")]) == 2
        err = capsys.readouterr().err
        assert words in err and len(err.strip().splitlines()) == 1, err
    assert not (tmp_path / "x").exists()


def test_unidyn_run_says_which_uncertainty_to_quote(tmp_path, capsys):
    assert main(["run", "--paper", "3", "--T", "2", "--out", str(tmp_path / "a")]) == 0
    noisy = capsys.readouterr().out
    assert "quote      these are one sample of the noise (seed 0)" in noisy
    assert "--seeds N gives mean ± standard error" in noisy
    assert "sensitive  False" in noisy
    iae_line = next(x for x in noisy.splitlines() if x.startswith("IAE"))
    assert "numerical error" not in iae_line
    assert main(["run", "--paper", "3", "--T", "2", "--set", "noise=off",
                 "--out", str(tmp_path / "b")]) == 0
    clean = capsys.readouterr().out
    assert "quote      no noise: deterministic" in clean and "sensitive  False" in clean
    assert "numerical error" in next(x for x in clean.splitlines() if x.startswith("IAE"))
    summary = json.loads((tmp_path / "a" / "summary.json").read_text())
    assert summary["uncertainty"].startswith("one sample of the measurement noise")
