"""Section 5's experiment as simulated scenarios: the windowed IAE, the statistics
over seeds, the claims against the paper's numbers, the command line."""

import math
import re
import subprocess
import sys
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from unidyn import Scenario, ValidationError
from unidyn.cli import main
from unidyn.paper import (
    EXPERIMENT_FILES,
    EXPERIMENT_PAPER,
    ExperimentRun,
    experiment,
    experiment_claims,
    experiment_scenarios,
    experiment_stats,
)
from unidyn.results.result import Result


def _fake(error, T=60.0, Ts=0.1, u=0.3, w=0.5):
    t = np.arange(round(T / Ts) + 1) * Ts
    err = error(t) if callable(error) else np.full_like(t, error)
    vel = np.column_stack([np.full_like(t, u), np.full_like(t, w)])
    return SimpleNamespace(t=t, error=err, velocity=vel, complete=True)


def _result(error, T=60.0, Ts=0.1):
    """A Result whose distance error is ``error(t)``: the reference that far ahead in x."""
    t = np.arange(round(T / Ts) + 1) * Ts
    err = error(t) if callable(error) else np.full_like(t, error)
    zeros = np.zeros((len(t), 2))
    return Result(scenario=Scenario.paper(4, T=T), t=t, pose=np.zeros((len(t), 3)),
                  velocity=zeros, reference=np.column_stack([err, np.zeros(len(t))]),
                  v_d=None, v_ref=None, theta_hat=None)


def test_the_windowed_iae_integrates_the_distance_error():
    """A linear error e = 0.01 t (trapezoidal rule exact): over 15-30 s,
    0.01 (30^2 - 15^2)/2 = 3.375 m·s; a constant 0.1 m over 15 s: 1.5 m·s."""
    assert _result(lambda t: 0.01 * t).window(15.0, 30.0)["iae"] == pytest.approx(3.375, rel=1e-12)
    assert _result(0.1).window(45.0, 60.0)["iae"] == pytest.approx(1.5, rel=1e-12)
    with pytest.raises(ValidationError, match="45-70 s is not covered"):
        _result(0.1).window(45.0, 70.0)


def _runs(values):
    """ExperimentRuns of seeds 0, 1, ... whose windowed IAEs are ``values``:
    seed -> (adaptive before, adaptive after, kinematic before, kinematic after)."""
    runs = []
    for seed, (a0, a1, k0, k1) in values.items():
        runs.append(ExperimentRun(seed, "adaptive", "batch", _fake(0.1),
                                  {"before": a0, "after": a1}))
        runs.append(ExperimentRun(seed, "uncompensated", "batch", _fake(0.1),
                                  {"before": k0, "after": k1}))
    return runs


def test_seed_statistics_are_mean_and_standard_error():
    """Two seeds with adaptive IAE 2 and 4 over 15-30 s: mean 3, std 1.414 (n - 1),
    standard error 1; the ratios are taken seed by seed (1/2 and 3/4: mean 0.625)."""
    st = experiment_stats(_runs({0: (2.0, 1.0, 3.0, 3.0), 1: (4.0, 3.0, 3.0, 5.0)}))
    assert st["adaptive before"] == pytest.approx((3.0, 1.0, 2))
    assert st["after/before"][0] == pytest.approx(0.625)
    assert st["after/before"][1] == pytest.approx(0.125)
    assert st["kinematic/before"][0] == pytest.approx((3 / 2 + 5 / 4) / 2)
    assert st["u max"][0] == pytest.approx(0.3) and st["w min"][0] == pytest.approx(0.5)


def test_claims_judge_the_ratios_not_the_magnitudes():
    """IAEs ten times the paper's in the paper's ratios hold every claim; the magnitude
    is not compared; a kinematic IAE above 1.2 x the paper's ratio fails."""
    P = EXPERIMENT_PAPER
    same = {s: (P["before"] * 10 * f, P["after"] * 10 * f, P["before"] * 10 * f,
                P["kinematic"] * 10 * f) for s, f in ((0, 1.0), (1, 1.02), (2, 0.98))}
    claims = experiment_claims(experiment_stats(_runs(same)))
    assert claims[0].holds is None
    assert all(c.holds for c in claims[1:]), claims
    far = {s: (a0, a1, k0, a0 * 0.9) for s, (a0, a1, k0, _) in same.items()}
    claims = experiment_claims(experiment_stats(_runs(far)))
    assert [c.holds for c in claims[1:]] == [True, True, False, True]


def test_scenarios_are_the_papers_settings():
    specs = experiment_scenarios(seeds=2)
    assert [(s, c) for s, c, _ in specs] == [
        (None, "adaptive"), (None, "uncompensated"), (0, "adaptive"), (0, "uncompensated"),
        (1, "adaptive"), (1, "uncompensated")]
    sc = specs[2][2]
    assert sc.T == 60.0 and sc.adapt_from == 30.0 and sc.x0 == (0.2, 0.0, 0.0)
    np.testing.assert_allclose(sc.theta_hat_initial, 0.8 * sc.robot.theta)
    assert sc.noise.seed == 0 and specs[0][2].noise is None
    np.testing.assert_allclose(experiment_scenarios(seeds=0, estimate=1.2)[0][2]
                               .theta_hat_initial, 1.2 * sc.robot.theta)
    with pytest.raises(ValidationError, match="seeds must be an integer"):
        experiment_scenarios(seeds=-1)


def test_updating_ends_below_the_kinematic_controller():
    """One seed and the noise-free run, batch engine: the update of Eq. (20) lowers the
    IAE from the first window to the second, below the kinematic controller's."""
    exp = experiment(seeds=1, engines=("batch",))
    assert len(exp.runs) == 4 and math.isnan(exp.engines)
    for seed in (None, 0):
        a = next(r for r in exp.runs if r.seed == seed and r.case == "adaptive")
        k = next(r for r in exp.runs if r.seed == seed and r.case == "uncompensated")
        assert a.iae["after"] < 0.7 * a.iae["before"]
        assert a.iae["after"] < k.iae["after"]


@pytest.mark.slow
def test_both_engines_give_the_same_experiment():
    exp = experiment(seeds=1, engines=("batch", "bdsim"))
    assert exp.engines < 1e-4
    assert exp.claims[-1].holds


def test_the_experiment_refuses_an_option_it_does_not_take(capsys, tmp_path):
    # (--seeds runs any scenario over seeds: tests/test_run.py)
    code = main(["run", "--paper", "experiment", "--T", "20", "--out", str(tmp_path / "x")])
    err = capsys.readouterr().err
    assert code == 2 and "not --T" in err
    assert not (tmp_path / "x").exists()


@pytest.mark.slow
def test_command_writes_the_papers_numbers_beside_the_measured(tmp_path):
    out = tmp_path / "exp"
    proc = subprocess.run([sys.executable, "-m", "unidyn", "run", "--paper", "experiment",
                           "--seeds", "2", "--engine", "batch", "--out", str(out)],
                          capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr
    for number in ("14.38", "6.55", "9.06"):
        assert number in proc.stdout
    assert sorted(p.name for p in out.iterdir() if not p.name.startswith(".")) == \
        sorted(EXPERIMENT_FILES)
    claims = (out / "claims.md").read_text()
    for text in ("14.38", "6.55", "9.06", "about 50 % smaller", "Why a simulation"):
        assert text in claims
    assert Path(out / "experiment.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.mark.slow
def test_the_experiment_off_a_terminal_says_how_far_it_is_and_what_it_wrote(tmp_path):
    """Its diagram runs take seconds each: lines on stderr (a pipe here) with the time
    left, then the wall time and the files written."""
    out = tmp_path / "exp"
    proc = subprocess.run([sys.executable, "-m", "unidyn", "run", "--paper", "experiment",
                           "--seeds", "1", "--engine", "bdsim", "--out", str(out)],
                          capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr
    said = [ln for ln in proc.stderr.splitlines() if ln.startswith("experiment, bdsim: ")]
    assert len(said) >= 3 and "\r" not in proc.stderr, proc.stderr
    assert any(re.search(r"\d+ of 2,400 samples \(\d+ %\), \d+ s elapsed, about \d+ s left", ln)
               for ln in said), said
    assert re.fullmatch(r"experiment, bdsim: 2,400 samples in \d+ s", said[-1]), said
    assert re.search(r"^wall time +[\d.]+ s$", proc.stdout, re.M)
    assert f"written    {out}/ (claims.md" in proc.stdout
