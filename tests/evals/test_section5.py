"""The paper's Section 5: the four simulations and what the paper says of them."""

import numpy as np
import pytest

import unidyn
from unidyn.paper import section5_claims

pytestmark = pytest.mark.slow  # the whole-system tier (tests/README.md)


@pytest.fixture(scope="module")
def runs(paper_run):
    return [paper_run(n) for n in (1, 2, 3, 4)]


def test_every_section5_claim_holds(runs):
    claims = section5_claims(*runs)
    failed = [c for c in claims if not c.holds]
    assert not failed, "\n".join(f"{c.case}: {c.paper}: {c.measured}" for c in failed)


def test_ordering_of_the_four_cases(runs):
    iae = [r.metrics["iae"] for r in runs]
    # the dynamic robot without compensation is far worse than with it
    assert iae[1] > 5 * iae[2]
    # exact compensation is close to the kinematic case
    assert iae[2] < 2 * iae[0]
    # adaptation cuts the error: the second half beats the first
    r4 = runs[3]
    assert r4.window(150, 200)["iae"] < 0.5 * r4.window(50, 100)["iae"]


def test_limits_hold_in_the_dynamic_runs(runs):
    lim = unidyn.PAPER_LIMITS
    for r in runs[1:]:
        assert np.max(np.abs(r.velocity[:, 0])) <= lim.speed_max + 1e-6
        assert np.max(np.abs(r.velocity[:, 1])) <= lim.steer_max + 1e-6
        du = np.diff(r.velocity[:, 0]) / np.diff(r.t)
        assert np.max(np.abs(du)) <= lim.accel_max + 1e-6
