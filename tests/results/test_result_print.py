"""A result printed: a dozen lines that say what ran and how it went, not its arrays."""

import math

import numpy as np

import unidyn
from unidyn.results.result import Result


def _result(complete=True, message=""):
    t = np.linspace(0.0, 20.0, 201)
    pose = np.zeros((len(t), 3))
    reference = np.tile([3.0, 4.0], (len(t), 1))  # 5 m from the robot throughout
    velocity = np.zeros((len(t), 2))
    theta = np.tile([0.2, 0.1, 0.0, 1.0, 0.0, 1.0], (len(t), 1))
    return Result(scenario=unidyn.Scenario.paper(4, T=20), t=t, pose=pose, velocity=velocity,
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


def test_a_result_prints_its_numerical_error_beside_each_metric():
    r = _result()
    r.numerical_error = {"iae": 2e-5, "ise": 2e-5, "itae": 2e-5, "itse": 2e-5, "energy": 2e-5,
                         "error_final": 1e-6, "theta_hat": 3e-6}
    text = repr(r)
    assert "iae          100 m·s  (numerical error 2.0e-05 relative)" in text
    assert "(numerical error 3.0e-06 relative)" in text.splitlines()[-2]
    assert "numerical error: not estimated" in repr(_result())
