"""Non-finite values stop a run with a clear error and keep what was computed;
runs are deterministic; results record what is needed to reproduce them."""

import json

import numpy as np
import pytest

import unidyn
from unidyn.cli import main
from unidyn.engine.batch import simulate_batch
from unidyn.model.scenario import Scenario

pytestmark = pytest.mark.reliability

from ._faults import F8
from ._faults import nan_after as _nan_after


def test_a_nan_in_the_diagram_stops_the_run_and_keeps_the_part_computed():
    sc = Scenario.paper(4, T=10.0, trajectory=_nan_after(3.0), name="nan-after-3s")
    part = unidyn.simulate(sc)  # returned incomplete, as the batch engine returns it
    msg = part.message
    # says when, in which block and signal, and with which scenario
    assert "nan-after-3s" in msg and "'controller'" in msg and "'h_d'" in msg
    assert "t = 3.0" in msg
    assert part.complete is False
    assert part.t[-1] == pytest.approx(3.0) and np.all(np.isfinite(part.pose))
    # the part computed is the run up to the failure: same as a clean run's start
    clean = unidyn.simulate(sc.replace(trajectory=F8, T=3.0))
    np.testing.assert_allclose(part.pose, clean.pose, atol=1e-9)


@pytest.mark.parametrize("error", [RuntimeError("a block's start failed"), KeyboardInterrupt()])
def test_a_failure_while_bdsim_starts_the_blocks_is_passed_on(error, monkeypatch):
    """Before the run has a log (bdsim has not set its time and log yet) the error
    itself reaches the user: Ctrl-C as SimulationInterrupted, anything else as is."""
    import bdsim.blockdiagram as bdm

    def start(self, simstate):
        raise error
    monkeypatch.setattr(bdm.BlockDiagram, "start", start)
    from unidyn.diagrams.simulate import SimulationInterrupted
    expected = SimulationInterrupted if isinstance(error, KeyboardInterrupt) else RuntimeError
    with pytest.raises(expected) as info:
        unidyn.simulate(Scenario.paper(2, T=1.0), progress=False)
    if expected is RuntimeError:
        assert "a block's start failed" in str(info.value)
    else:
        assert "interrupted" in str(info.value)


def test_a_nan_in_the_batch_engine_marks_only_that_run_incomplete():
    bad = Scenario.paper(3, T=6.0, trajectory=_nan_after(2.0), name="bad")
    good = Scenario.paper(3, T=6.0, name="good")
    rb, rg = simulate_batch([bad, good], backend="plain")
    assert rg.complete and len(rg.t) == 61
    assert not rb.complete and "bad" in rb.message and "t = 2.1" in rb.message
    assert 0 < len(rb.t) < 61 and np.all(np.isfinite(rb.pose))


@pytest.mark.slow
def test_the_cli_writes_a_failed_run_marked_incomplete(tmp_path, capsys, monkeypatch):
    # a scenario file cannot hold Python, so inject the failing trajectory in-process
    import unidyn.cli.run as cli_run
    real = cli_run._build_scenario

    def build(args):
        sc, engine = real(args)
        return sc.replace(trajectory=_nan_after(1.0), name="nan-run"), engine
    monkeypatch.setattr(cli_run, "_build_scenario", build)
    out = tmp_path / "run"
    code = main(["run", "--paper", "4", "--T", "5", "--engine", "bdsim", "--out", str(out)])
    assert code == 1
    summary = json.loads((out / "summary.json").read_text())
    assert summary["complete"] is False and "nan-run" in summary["message"]
    data = np.loadtxt(out / "timeseries.csv", delimiter=",", skiprows=1)
    assert data[-1, 0] == pytest.approx(1.0)
    assert "stopped early" in capsys.readouterr().err


@pytest.mark.parametrize("engine", ["bdsim", "batch"])
def test_same_scenario_and_seed_give_bit_identical_results(engine):
    sc = Scenario.paper(4, T=8.0, adapt_from=2.0)
    run = unidyn.simulate if engine == "bdsim" else (lambda s: simulate_batch([s])[0])
    a, b = run(sc), run(sc)
    for name in ("pose", "velocity", "theta_hat", "v_ref", "v_d", "reference"):
        assert np.array_equal(getattr(a, name), getattr(b, name)), name
    assert a.metrics == b.metrics


def test_results_record_version_scenario_and_seed(tmp_path):
    sc = Scenario.paper(4, T=2.0, noise=unidyn.NoiseSpec(seed=42))
    r = unidyn.simulate(sc)
    r.save(tmp_path)
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["unidyn_version"] == unidyn.__version__
    assert summary["seed"] == 42
    assert Scenario.from_dict(summary["scenario"]) == sc
    # and the saved scenario alone reproduces the run
    again = unidyn.simulate(Scenario.from_dict(summary["scenario"]))
    assert np.array_equal(again.pose, r.pose)


def test_an_interrupted_write_leaves_no_file_that_looks_complete(tmp_path, monkeypatch):
    from unidyn.results import folders as result_mod  # where results are written atomically
    r = simulate_batch([Scenario.paper(1, T=1.0)])[0]

    def broken_replace(src, dst):
        raise KeyboardInterrupt  # the process dies between writing and renaming
    monkeypatch.setattr(result_mod.os, "replace", broken_replace)
    with pytest.raises(KeyboardInterrupt):
        r.save(tmp_path)
    assert not (tmp_path / "timeseries.csv").exists()
    assert list(tmp_path.iterdir()) == []  # the temporary file is removed too
