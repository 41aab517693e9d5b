"""A run that did not complete keeps the metrics of the part computed, marked
incomplete, and summary.json is strict JSON (no Infinity, no NaN)."""

import json

import numpy as np
import pytest

import unidyn
from unidyn.engine.batch import simulate_batch
from unidyn.model.scenario import Scenario
from unidyn.results.result import Result, metrics

pytestmark = pytest.mark.reliability

from ._faults import nan_after as _nan_after


def _strict(text):
    def bad(c):
        raise AssertionError(f"non-standard JSON constant {c}")
    return json.loads(text, parse_constant=bad)


def test_an_incomplete_batch_run_keeps_the_metrics_of_the_part_computed(tmp_path):
    bad = Scenario.paper(3, T=6.0, trajectory=_nan_after(2.0), name="bad")
    rb, = simulate_batch([bad], backend="plain")
    assert rb.complete is False and rb.message and rb.numerical_error is None
    assert set(rb.metrics) == {"iae", "ise", "itae", "itse", "energy", "error_final",
                               "peak_error"}
    # the metrics are those of the part computed: the trapezoidal rule over its logged
    # samples (every sample, log_every = 1), computed apart from the engine's own sums
    assert np.all(np.isfinite(rb.pose)) and rb.t[-1] >= 2.0
    part = metrics(rb.t, rb.error, rb.velocity)
    for k, v in part.items():
        assert rb.metrics[k] == pytest.approx(v, rel=1e-12, abs=1e-15), k
    rb.save(tmp_path)
    s = _strict((tmp_path / "summary.json").read_text())
    assert s["complete"] is False and s["message"] == rb.message
    assert s["metrics"]["iae"] == pytest.approx(part["iae"], rel=1e-12)
    assert s["numerical_error"] is None and s["sensitive"] is False
    assert s["engine"] == "batch" and s["backend"] == "plain"


def test_a_complete_run_says_which_backend_ran_it():
    sc = Scenario.paper(1, T=1.0)
    r_np, = simulate_batch([sc], backend="plain")
    r_bd = unidyn.simulate(sc)
    assert (r_np.engine, r_np.backend) == ("batch", "plain")
    assert (r_bd.engine, r_bd.backend) == ("bdsim", "solve_ivp RK45")
    assert r_np.complete and all(np.isfinite(v) for v in r_np.metrics.values())


def test_non_finite_numbers_are_written_as_null_with_a_note(tmp_path):
    sc = Scenario.paper(1, T=0.2)
    n = 3
    pose = np.zeros((n, 3))
    pose[-1, 0] = np.inf  # a diverged sample
    r = Result(scenario=sc, t=np.arange(n) * 0.1, pose=pose, velocity=np.zeros((n, 2)),
               reference=np.zeros((n, 2)), v_d=np.zeros((n, 2)), v_ref=np.zeros((n, 2)),
               theta_hat=np.full((n, 6), np.nan), engine="batch", complete=False, message="diverged")
    r.save(tmp_path)
    text = (tmp_path / "summary.json").read_text()
    assert "Infinity" not in text and "NaN" not in text
    s = _strict(text)
    assert s["metrics"]["iae"] is None and s["metrics"]["error_final"] is None
    assert s["theta_hat_final"] == [None] * 6
    assert any("iae" in note and "inf" in note for note in s["notes"])


@pytest.mark.parametrize("limits", [unidyn.Limits(),
                                    unidyn.Limits(speed_max=np.inf, steer_max=1.745,
                                                  accel_max=0.3, angular_accel_max=np.inf)],
                         ids=["none", "some"])
def test_a_run_without_limits_is_saved_and_read_back(tmp_path, limits):
    """"No limit" (inf) is written as null, and a null limit reads back as none."""
    sc = Scenario.paper(3, T=0.5, limits=limits)
    r, = simulate_batch([sc], backend="plain")
    r.save(tmp_path)
    s = _strict((tmp_path / "summary.json").read_text())
    nulls = [k for k, v in s["scenario"]["limits"].items() if v is None]
    assert nulls == [k for k, v in limits.as_dict().items() if v == np.inf]
    assert Scenario.from_dict(s["scenario"]) == sc


def test_a_sweep_without_limits_writes_strict_json_and_resumes(tmp_path):
    from unidyn.sweeps.sweep import Sweep, run_sweep
    sw = Sweep(base={"T": 0.5, "noise": "off", "case": "kinematic",
                     "limits": {"speed_max": float("inf"), "steer_max": 1.745}},
               grid={"kx": [1.0, 2.0]})
    first = run_sweep(sw, tmp_path / "s", progress=False)
    s = _strict((tmp_path / "s" / "sweep.json").read_text())
    assert s["sweep"]["base"]["limits"]["speed_max"] is None
    again = run_sweep(sw, tmp_path / "s", progress=False)  # the same sweep: resumed
    assert (first.ran, again.ran, again.skipped) == (2, 0, 2)


def test_a_changed_sweep_without_limits_names_only_what_changed(tmp_path):
    from unidyn import ValidationError
    from unidyn.sweeps.sweep import Sweep, run_sweep
    base = {"T": 0.5, "noise": "off", "case": "kinematic", "limits": {"speed_max": float("inf")}}
    run_sweep(Sweep(base=base, grid={"kx": [1.0]}), tmp_path / "s", progress=False)
    with pytest.raises(ValidationError, match="differs in base.T") as err:
        run_sweep(Sweep(base={**base, "T": 0.4}, grid={"kx": [1.0]}), tmp_path / "s",
                  progress=False)
    assert "limits" not in str(err.value)
