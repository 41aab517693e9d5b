"""The paper's Section 5: the four simulations and what the paper says of them, read
from what the README's first command writes (``examples/paper_section5.py``, run once
a session by the ``section5`` fixture of tests/conftest.py): the claims it prints and
writes, checked beside numbers computed here from its time series."""

import numpy as np
import pytest

import unidyn

pytestmark = pytest.mark.slow  # the whole-system tier (tests/README.md)


def test_every_section5_claim_holds_as_printed_and_written(section5):
    table = (section5 / "claims.md").read_text().strip()
    rows = table.splitlines()[2:]
    assert len(rows) == 5 and all(r.endswith("| yes |") for r in rows), table
    # what the reader of the README sees is the table written
    assert table in (section5.parent / "stdout.txt").read_text()


def _iae(cols, t0=0.0, t1=np.inf):
    """The integral of the distance error over [t0, t1] (the trapezoidal rule)."""
    m = (cols["t"] >= t0) & (cols["t"] <= t1)
    return float(np.trapezoid(cols["error"][m], cols["t"][m]) if hasattr(np, "trapezoid")
                 else np.trapz(cols["error"][m], cols["t"][m]))


def test_the_summaries_hold_the_metrics_of_their_time_series(section5_runs):
    for n, (cols, summary) in section5_runs.items():
        assert summary["complete"] is True
        assert abs(summary["metrics"]["iae"] - _iae(cols)) < 1e-6 * _iae(cols), n
        h_d = np.c_[cols["x_d"], cols["y_d"]]
        err = np.hypot(*(h_d - np.c_[cols["x"], cols["y"]]).T)
        np.testing.assert_allclose(cols["error"], err, atol=1e-9)


def test_ordering_of_the_four_cases(section5_runs):
    iae = [_iae(section5_runs[n][0]) for n in (1, 2, 3, 4)]
    # the dynamic robot without compensation is far worse than with it
    assert iae[1] > 5 * iae[2]
    # exact compensation is close to the kinematic case
    assert iae[2] < 2 * iae[0]
    # adaptation cuts the error: the second half beats the first
    r4 = section5_runs[4][0]
    assert _iae(r4, 150, 200) < 0.5 * _iae(r4, 50, 100)


def test_limits_hold_in_the_dynamic_runs(section5_runs):
    lim = unidyn.PAPER_LIMITS
    for n in (2, 3, 4):
        cols = section5_runs[n][0]
        assert np.max(np.abs(cols["u"])) <= lim.speed_max + 1e-6
        assert np.max(np.abs(cols["w"])) <= lim.steer_max + 1e-6
        du = np.diff(cols["u"]) / np.diff(cols["t"])
        assert np.max(np.abs(du)) <= lim.accel_max + 1e-6
