"""log_every thins what is logged, never what is integrated."""

import numpy as np
import pytest

import unidyn
from unidyn import Scenario
from unidyn.batch import simulate_batch

pytestmark = pytest.mark.reliability

FIELDS = ("pose", "velocity", "reference", "v_d", "v_ref", "theta_hat")


@pytest.mark.parametrize("backend", ["numba", "numpy"])
def test_a_thinned_batch_log_is_every_Lth_sample_of_the_full_one(backend):
    sc = Scenario.paper(4, T=6.0, adapt_from=2.0)
    full, = simulate_batch([sc], backend=backend)
    thin, = simulate_batch([sc.replace(log_every=4)], backend=backend)
    assert thin.complete and len(thin.t) == 16
    np.testing.assert_allclose(thin.t, full.t[::4], rtol=0, atol=1e-12)
    for f in FIELDS:
        assert np.array_equal(getattr(thin, f), getattr(full, f)[::4]), f


def test_a_thinned_diagram_log_is_every_Lth_sample_of_the_full_one():
    sc = Scenario.paper(3, T=2.0)
    full = unidyn.simulate(sc)
    thin = unidyn.simulate(sc.replace(log_every=5))
    assert len(thin.t) == 5
    for f in FIELDS:
        assert np.array_equal(getattr(thin, f), getattr(full, f)[::5]), f
