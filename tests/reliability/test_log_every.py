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


@pytest.mark.parametrize("backend", ["numba", "numpy"])
def test_a_float32_log_is_the_float64_log_rounded(backend):
    """log_dtype changes the stored type only: the integration is the same, so every
    float32 value is the float64 value rounded to nearest, and the metrics (accumulated
    in float64 from the float32 series) differ by the rounding alone."""
    sc = Scenario.paper(4, T=20.0, adapt_from=5.0)
    wide, = simulate_batch([sc], backend=backend)
    narrow, = simulate_batch([sc.replace(log_dtype="float32")], backend=backend)
    assert narrow.complete
    for f in FIELDS:
        a, b = getattr(wide, f), getattr(narrow, f)
        assert b.dtype == np.float32, f
        assert np.array_equal(a.astype(np.float32), b), f
    assert narrow.error.dtype == np.float32
    # |h_d - h| from 7-digit values: about 1e-7 m per sample, over 20 s
    for k in ("iae", "ise", "itae", "energy"):
        assert narrow.metrics[k] == pytest.approx(wide.metrics[k], rel=1e-5, abs=2e-6), k


def test_a_float32_diagram_log_is_the_float64_log_rounded():
    sc = Scenario.paper(2, T=2.0)
    wide = unidyn.simulate(sc)
    narrow = unidyn.simulate(sc.replace(log_dtype="float32"))
    for f in FIELDS:
        assert np.array_equal(getattr(wide, f).astype(np.float32), getattr(narrow, f)), f


def test_a_float32_log_takes_under_100_bytes_a_sample_and_its_csv_reads_back(tmp_path):
    """What the result holds per logged sample (its arrays share one log), and the
    CSV's 9 significant digits give every float32 value back exactly."""
    sc = Scenario.paper(4, T=50.0, log_dtype="float32")
    r, = simulate_batch([sc])
    arrays = {id(a.base if a.base is not None else a): (a.base if a.base is not None else a)
              for a in (r.pose, r.velocity, r.reference, r.v_d, r.v_ref, r.theta_hat, r.error)}
    per_sample = sum(a.nbytes for a in arrays.values()) / len(r.t)
    assert per_sample < 100, per_sample
    r.save(tmp_path)
    data = np.genfromtxt(tmp_path / "timeseries.csv", delimiter=",", names=True)
    assert np.array_equal(data["x"].astype(np.float32), r.pose[:, 0])
    assert np.array_equal(data["theta_hat3"].astype(np.float32), r.theta_hat[:, 2])


@pytest.mark.parametrize("backend", ["numba", "numpy"])
def test_the_held_noise_drawn_in_windows_is_the_noise_drawn_whole(backend, monkeypatch):
    """The engine draws the held noise a window at a time (a long run keeps only the
    window in memory); with windows of 3 samples the runs are bit for bit those with
    the whole noise in one window, and the noise is that of held_sequence."""
    import unidyn.closedloop as cl
    from unidyn.noise import held_sequence, noise_seeds
    scs = [Scenario.paper(4, T=3.0, adapt_from=1.0), Scenario.paper(2, T=3.0,
           noise={"seed": 5})]
    whole = simulate_batch(scs, backend=backend)
    monkeypatch.setattr(cl, "NOISE_WINDOW_VALUES", 2 * 3)  # 3 rows of 2 runs
    windows = simulate_batch(scs, backend=backend)
    for a, b in zip(whole, windows):
        assert b.complete
        for f in FIELDS:
            assert np.array_equal(getattr(a, f), getattr(b, f)), f
    loop = cl.ClosedLoop(scs)  # windows of 3 rows, read back to back
    got = []
    for k in range(0, 31, 3):
        if k:
            loop.noise_window(k, 3)
        got.append(loop.pos_noise[1].copy())
    want = held_sequence(noise_seeds(5)[0], 0.01, 31)
    assert np.array_equal(np.concatenate(got)[:31], want)
    with pytest.raises(ValueError, match="follow each other"):
        loop.noise_window(0, 3)
