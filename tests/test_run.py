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
