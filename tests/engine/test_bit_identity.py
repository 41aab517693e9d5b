"""The batch engine gives the same bits as before its tables were named: a fixed set of
short scenarios (kinematic, compensated, adaptive, with noise, with a payload, a circle,
a figure eight and a line), each run through both backends, hashed: the metrics that
existed then, their numerical error estimates, the logged series, the integrals at each
logged sample, the steps and the tolerance each run was returned at.

The expected digests were recorded from commit 290529c by running :func:`digest` there
(its ``Result.integrals``, the five integral metrics at each logged sample, is read here
as those columns of ``Result.running``).
A change of these bits is a change of every result users have: if it is meant, record
them again and say why in the commit.

The bdsim diagram is checked the same way on two runs, but for the running ITSE: both
engines now take t |h̃|² as (t |h̃|) |h̃|, the batch engine's order, where the diagram
took t (|h̃| |h̃|), which moves its last bit (3.5e-18 m²·s² on the kinematic run; its
metrics were the same bits there)."""

import hashlib

import numpy as np
import pytest

import unidyn
from unidyn.engine import kernels as _kernels
from unidyn.engine.batch import simulate_batch
from unidyn.model.noise import NoiseSpec
from unidyn.model.scenario import Scenario
from unidyn.model.trajectories import Circle, FigureEight, Line

#: The metrics of commit 290529c, in its order.
METRICS_290529C = ("iae", "ise", "itae", "itse", "energy", "error_final")
#: The estimates of commit 290529c (its metrics', the final state's and the series').
ESTIMATES_290529C = METRICS_290529C + ("final_state", "position", "heading",
                                       "distance_error", "theta_hat")

SCENARIOS = [
    Scenario(case="kinematic", T=3.0, noise=None, trajectory=Circle(radius=0.5, omega=0.5)),
    Scenario(case="compensated", T=3.0, noise=None),
    Scenario(case="adaptive", T=3.0, noise=None, adapt_from=0.0,
             trajectory=Line((0.5, 0.5), (0.1, -0.2))),
    Scenario(case="adaptive", T=3.0, noise=NoiseSpec(seed=7), adapt_from=1.0,
             trajectory=FigureEight(), log_every=3),
    Scenario(case="compensated", T=3.0, noise=NoiseSpec(seed=3), payload=[[1.0, 2.0]],
             trajectory=Circle(radius=0.5, omega=1.0), log_dtype="float32"),
]


def integral_columns(r):
    """The five integral metrics at each logged sample, (N, 5)."""
    from unidyn.model.metrics import METRIC_NAMES
    return r.running[:, [METRIC_NAMES.index(k) for k in METRICS_290529C[:5]]]


def digest(results, integrals=integral_columns) -> str:
    """A sha256 of what the runs give: per run, its metrics and estimates (those of
    commit 290529c), series, integrals, steps, rtol and message."""
    h = hashlib.sha256()
    for r in results:
        for k in METRICS_290529C:
            h.update(np.float64(r.metrics[k]).tobytes())
        for k in ESTIMATES_290529C:
            h.update(np.float64(r.numerical_error[k]).tobytes())
        for a in (r.t, r.pose, r.velocity, r.reference, r.v_d, r.v_ref, r.theta_hat,
                  integrals(r)):
            h.update(np.ascontiguousarray(a).tobytes())
        h.update(repr((r.complete, r.sensitive, r.steps, r.rejected, r.rtol, r.estimate,
                       r.message)).encode())
    return h.hexdigest()


#: Recorded from commit 290529c, per backend.
EXPECTED = {
    "plain": "e4c9c8387e1cb10787b301a6e0be219ee44c1be6ecc710b82e33893f96525678",
    "compiled": "64923d4252247024b3b1febf0a1020b3bdc7fe74cd3a40427a3c7c600cd019ef",
}


@pytest.mark.parametrize("backend", ["plain", "compiled"])
def test_the_runs_are_bit_identical_to_commit_290529c(backend):
    if backend == "compiled" and not _kernels.AVAILABLE:
        pytest.skip("numba is not installed")
    assert digest(simulate_batch(SCENARIOS, backend=backend)) == EXPECTED[backend]


DIAGRAM_SCENARIOS = [
    Scenario(case="kinematic", T=2.0, noise=None, trajectory=Circle(radius=0.5, omega=0.5)),
    Scenario.paper(4, T=3.0, adapt_from=1.0, log_every=3),
]
#: Recorded from commit 290529c: the metrics, the series and the running integrals but
#: ITSE of DIAGRAM_SCENARIOS through unidyn.simulate.
DIAGRAM_EXPECTED = "df5cbf5a52f3a5d7cac45b1a60311acee7f6e77c721724a0493b88d9e9e563f8"


def test_the_diagram_s_runs_are_bit_identical_to_commit_290529c():
    h = hashlib.sha256()
    for sc in DIAGRAM_SCENARIOS:
        r = unidyn.simulate(sc)
        for k in METRICS_290529C:
            h.update(np.float64(r.metrics[k]).tobytes())
        integrals = np.delete(integral_columns(r), METRICS_290529C.index("itse"), axis=1)
        for a in (r.t, r.pose, r.velocity, r.reference, r.v_d, r.v_ref, r.theta_hat,
                  integrals):
            h.update(np.ascontiguousarray(a).tobytes())
    assert h.hexdigest() == DIAGRAM_EXPECTED
