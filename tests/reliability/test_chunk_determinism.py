"""A run's numbers do not depend on which other runs share its call (the chunk of
a sweep), in either batch backend: a resumed sweep equals an uninterrupted one."""

import numpy as np
import pytest

from unidyn import NoiseSpec, Scenario
from unidyn.engine.batch import simulate_batch

pytestmark = pytest.mark.reliability

FIELDS = ("t", "pose", "velocity", "reference", "v_d", "v_ref", "theta_hat")


def _points():
    base = Scenario.paper(4, T=1.5, adapt_from=0.5)
    return [base,
            base.replace(noise=NoiseSpec(seed=3)),
            base.replace(robot="khepera3"),          # a fast robot: shorter steps
            base.replace(gamma=[100.0] * 6),         # a high gain: shorter still
            base.replace(kx=0.5, ky=0.5),
            Scenario.paper(2, T=1.5)]


@pytest.mark.parametrize("backend", ["plain", "compiled"])
def test_results_are_bit_identical_whatever_the_chunking(backend):
    pts = _points()
    whole = simulate_batch(pts, backend=backend)
    assert len({r.steps for r in whole}) >= 2  # the runs really take different steps
    for size in (1, 2, 4):
        chunked = []
        for i in range(0, len(pts), size):
            chunked += simulate_batch(pts[i:i + size], backend=backend)
        for a, b in zip(whole, chunked):
            for f in FIELDS:
                assert np.array_equal(getattr(a, f), getattr(b, f)), (size, f)
            assert a.metrics == b.metrics


def test_order_within_a_call_does_not_matter():
    pts = _points()
    fwd = simulate_batch(pts, backend="plain")
    rev = simulate_batch(pts[::-1], backend="plain")[::-1]
    for a, b in zip(fwd, rev):
        assert a.metrics == b.metrics


def test_runs_shared_among_threads_are_each_run_alone():
    """The compiled engine shares a call's runs among a thread per core: each of 11 runs
    has the numbers of the run alone, bit for bit."""
    from unidyn.engine import kernels as _kernels
    if not _kernels.AVAILABLE:
        pytest.skip("numba not installed")
    base = Scenario.paper(3, T=3.0)
    pts = [base.replace(kx=k, ky=k, noise=NoiseSpec(seed=i))
           for i, k in enumerate(np.linspace(0.5, 3.0, 11))]
    together = simulate_batch(pts, backend="compiled")
    for p, a in zip(pts, together):
        b, = simulate_batch([p], backend="compiled")
        for f in FIELDS:
            assert np.array_equal(getattr(a, f), getattr(b, f)), f
        assert a.metrics == b.metrics
