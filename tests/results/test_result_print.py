"""A result printed: a dozen lines that say what ran and how it went, not its arrays."""

import math

import numpy as np

import unidyn
from unidyn.model.noise import PAPER_NOISE, NoiseSpec
from unidyn.results.result import Result


def _result(complete=True, message="", noise=PAPER_NOISE):
    t = np.linspace(0.0, 20.0, 201)
    pose = np.zeros((len(t), 3))
    reference = np.tile([3.0, 4.0], (len(t), 1))  # 5 m from the robot throughout
    velocity = np.zeros((len(t), 2))
    theta = np.tile([0.2, 0.1, 0.0, 1.0, 0.0, 1.0], (len(t), 1))
    return Result(scenario=unidyn.Scenario.paper(4, T=20, noise=noise), t=t, pose=pose, velocity=velocity,
                  reference=reference, v_d=None, v_ref=None, theta_hat=theta,
                  engine="batch", backend="compiled", complete=complete, message=message)


def test_a_result_prints_in_a_dozen_lines_with_its_metrics():
    text = repr(_result())
    lines = text.splitlines()
    assert len(lines) <= 20 and all(len(x) <= 110 for x in lines), text
    assert lines[0] == "unidyn.Result: adaptive loop 'paper simulation 4 (adaptive)'"
    assert "engine batch (compiled), complete" in text
    # a constant 5 m error over 20 s: IAE 100 m·s, ISE 500 m²·s, ITAE 5 * 20²/2 = 1000 m·s²
    assert "iae          100 m·s" in text and "ise          500 m²·s" in text
    assert "itae         1000 m·s²" in text and "error_final  5 m" in text
    assert "theta_hat(T) 0.2 0.1 0 1 0 1" in text
    assert str(_result()) == text and not np.array2string(np.zeros(3)) in text


def test_an_incomplete_result_says_so_and_shows_the_metrics_of_the_part_computed():
    text = repr(_result(complete=False, message="diverged at t = 3 s"))
    assert "INCOMPLETE: diverged at t = 3 s" in text
    assert "metrics of the part computed, to t = 20 s" in text
    assert math.isclose(_result(complete=False).metrics["iae"], 100.0)


_ERRORS = {"iae": 2e-5, "ise": 2e-5, "itae": 2e-5, "itse": 2e-5, "energy": 2e-5,
           "error_final": 1e-6, "theta_hat": 3e-6}


def test_a_noise_free_result_prints_its_numerical_error_beside_each_metric():
    r = _result(noise=None)
    r.numerical_error = dict(_ERRORS)
    text = repr(r)
    assert "no noise: deterministic, each metric to its numerical error" in text
    assert "iae          100 m·s  (numerical error 2.0e-05 relative)" in text
    assert "(numerical error 3.0e-06 relative)" in text.splitlines()[-2]
    assert "numerical error: not estimated" in repr(_result(noise=None))
    assert "seed" not in text


def test_a_noisy_result_says_its_metrics_are_one_sample_and_how_to_get_their_spread():
    """Beside a noisy run's metrics, no numerical error that reads as their error bar:
    it says they are one sample of the noise, and names the seeds that give their
    spread."""
    r = _result()
    r.numerical_error = dict(_ERRORS)
    text = repr(r)
    lines = text.splitlines()
    assert len(lines) <= 20 and all(len(x) <= 110 for x in lines), text
    assert "noise seed 0: these metrics are one sample of the noise" in text
    assert "unidyn.run(scenario, seeds=N): mean ± standard error (n)" in text
    assert "iae          100 m·s\n" in text  # nothing beside it
    assert "numerical error at most 2.0e-05 relative: the integration's, not an error bar" in text
    assert not any("numerical error" in x for x in lines if x.split()[0] in _ERRORS)


def test_sensitive_is_always_stated_false_included():
    r = _result()
    assert "  sensitive    False" in repr(r).splitlines()
    r.numerical_error, r.sensitive = dict(_ERRORS), True
    assert "  sensitive    True: no tolerance converges it; quote the spread over seeds" in repr(r)
    clean = _result(noise=None)
    clean.numerical_error, clean.sensitive = dict(_ERRORS), True
    assert "  sensitive    True: no tolerance converges it" in repr(clean).splitlines()


def test_summary_json_says_which_uncertainty_to_quote(tmp_path):
    noisy, clean = _result(), _result(noise=None)
    clean.numerical_error = dict(_ERRORS)
    a, b = noisy.summary(), clean.summary()
    assert a["uncertainty"].startswith("one sample of the measurement noise (seed 0)")
    assert "seeds=N" in a["uncertainty"] and "not an error bar" in a["uncertainty"]
    assert b["uncertainty"] == "no noise: deterministic; quote each metric with its numerical error"
    assert a["sensitive"] is False and "sensitive" in b
    # zero noise is no noise
    zero = NoiseSpec(position_std=0.0, velocity_std=0.0)
    assert _result(noise=zero).summary()["uncertainty"].startswith("no noise")


def _case_result(case, noise=None):
    t = np.linspace(0.0, 2.0, 21)
    return Result(scenario=unidyn.Scenario.paper(case, T=2, noise=noise), t=t,
                  pose=np.zeros((len(t), 3)), velocity=np.tile([0.3, 0.4], (len(t), 1)),
                  reference=np.tile([3.0, 4.0], (len(t), 1)), v_d=None, v_ref=None,
                  theta_hat=np.tile([0.2, 0.1, 0.0, 1.0, 0.0, 1.0], (len(t), 1)),
                  engine="batch", backend="compiled", complete=True, message="")


def test_a_result_shows_an_estimate_only_for_a_loop_that_has_one():
    """Simulations 1-2 have no compensator, 3 compensates with fixed parameters, 4 adapts."""
    for case in (1, 2):
        assert "theta_hat    " not in repr(_case_result(case))
        assert "theta_hat(T)" not in repr(_case_result(case))
    fixed = repr(_case_result(3))
    assert "theta_hat    0.2 0.1 0 1 0 1  (fixed: exact compensation)" in fixed
    assert "theta_hat(T)" not in fixed
    assert "theta_hat(T) 0.2 0.1 0 1 0 1" in repr(_case_result(4))


def test_energy_is_printed_in_units_a_reader_can_check():
    """u = 0.3 m/s, w = 0.4 rad/s for 2 s: 2 * (0.09 + 0.16) = 0.5, in m²/s + rad²/s."""
    r = _case_result(4)
    r.numerical_error = dict(_ERRORS)
    (line,) = [ln for ln in repr(r).splitlines() if ln.startswith("  energy")]
    assert line == ("  energy       0.5 m²/s + rad²/s (∫u² dt + ∫ω² dt)  (numerical error 2.0e-05 "
                    "relative)")
