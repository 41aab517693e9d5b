"""log_every thins what is logged, never what is integrated."""

import numpy as np
import pytest

import unidyn
from unidyn import Scenario
from unidyn.engine.batch import DECISIVE, simulate_batch
from unidyn.model.metrics import METRICS, PEAK
from unidyn.results.result import metrics

pytestmark = pytest.mark.reliability

FIELDS = ("pose", "velocity", "reference", "v_d", "v_ref", "theta_hat")


@pytest.mark.parametrize("backend", ["compiled", "plain"])
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


@pytest.mark.parametrize("backend", ["compiled", "plain"])
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
    for k in ("iae", "ise", "itae", "itse", "energy"):
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


@pytest.mark.parametrize("backend", ["compiled", "plain"])
def test_the_held_noise_drawn_in_windows_is_the_noise_drawn_whole(backend, monkeypatch):
    """The engine draws the held noise a window at a time (a long run keeps only the
    window in memory); with windows of 3 samples the runs are bit for bit those with
    the whole noise in one window, and the noise is that of held_sequence."""
    import unidyn.model.closed_loop as cl
    from unidyn.model.noise import held_sequence, noise_seeds
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


# ------------------------------------------------------------------ log_series
def _owners(r):
    """The arrays a result holds (its series are views of one log), by identity."""
    out = {}
    for a in (r.t, r.pose, r.velocity, r.reference, r.v_d, r.v_ref, r.theta_hat, r.error):
        if a is None:
            continue
        while a.base is not None:
            a = a.base
        out[id(a)] = a
    return out


@pytest.mark.parametrize("backend", ["compiled", "plain"])
def test_log_series_keeps_only_the_series_asked_for_and_changes_nothing_else(backend):
    """Leaving series out of the log changes what is stored only: the series kept
    and the metrics are bit for bit those of the full log, in every case (the
    kinematic robot's velocity, its clipped command, included)."""
    scs = [Scenario.paper(n, T=8.0, adapt_from=2.0) for n in (1, 2, 3, 4)]
    full = simulate_batch(scs, backend=backend)
    for series in ((), ("theta_hat",), ("v_d", "v_ref")):
        part = simulate_batch([s.replace(log_series=series) for s in scs], backend=backend)
        for a, b in zip(full, part):
            assert b.complete
            for f in FIELDS:
                if f in ("pose", "velocity", "reference") or f in series:
                    assert np.array_equal(getattr(a, f), getattr(b, f)), (f, series)
                else:
                    assert getattr(b, f) is None, (f, series)
            assert np.array_equal(a.error, b.error) and a.metrics == b.metrics


def test_log_series_in_the_diagram_engine():
    sc = Scenario.paper(4, T=2.0, adapt_from=1.0)
    full = unidyn.simulate(sc)
    part = unidyn.simulate(sc.replace(log_series=["v_ref"]))
    assert part.theta_hat is None and part.v_d is None
    for f in ("pose", "velocity", "reference", "v_ref", "error"):
        assert np.array_equal(getattr(full, f), getattr(part, f)), f
    assert full.metrics == part.metrics


@pytest.mark.parametrize("dtype", ["float64", "float32"])
def test_a_log_of_the_essential_series_takes_under_100_bytes_a_sample(dtype):
    """What the result holds per logged sample (t, pose, velocity, reference and the
    error) is what Scenario.logged_bytes says: 72 bytes in float64, 40 in float32;
    all series: 152 and 80."""
    sc = Scenario.paper(4, T=50.0, log_dtype=dtype)
    for series, want in (((), {"float64": 72, "float32": 40}),
                         (sc.log_series, {"float64": 152, "float32": 80})):
        r, = simulate_batch([sc.replace(log_series=series)])
        per_sample = sum(a.nbytes for a in _owners(r).values()) / len(r.t)
        # (the log has one row more than a complete run's samples: the row for the
        # sample a run stops at)
        assert per_sample == pytest.approx(want[dtype], rel=0.01)
        assert r.scenario.logged_bytes() == want[dtype]
    # a kinematic robot's velocity is its clipped command, held once
    kin = Scenario.paper(1, T=50.0, log_dtype=dtype)
    for series in ((), ("v_ref",), ("theta_hat",), kin.log_series):
        r, = simulate_batch([kin.replace(log_series=series)])
        per_sample = sum(a.nbytes for a in _owners(r).values()) / len(r.t)
        assert per_sample == pytest.approx(r.scenario.logged_bytes(), rel=0.01), series
    assert kin.replace(log_series=()).logged_bytes() == {"float64": 72, "float32": 40}[dtype]
    # 10^7 samples logged whole in float64 fit the log's budget without the others
    assert Scenario(T=1e6, Ts=0.1, log_series=()).steps == 10_000_000
    with pytest.raises(unidyn.ValidationError, match="log_series"):
        Scenario(T=1e6, Ts=0.1)


def test_files_and_figures_of_a_run_without_some_series(tmp_path):
    import json

    from unidyn.results.plots import save_figures
    r, = simulate_batch([Scenario.paper(4, T=5.0, adapt_from=1.0, log_series=["v_ref"])])
    r.save(tmp_path)
    header = (tmp_path / "timeseries.csv").read_text().splitlines()[0].split(",")
    assert header == ["t", "x", "y", "psi", "u", "w", "x_d", "y_d", "u_ref", "w_ref", "error"]
    data = np.genfromtxt(tmp_path / "timeseries.csv", delimiter=",", names=True)
    np.testing.assert_allclose(data["w_ref"], r.v_ref[:, 1], rtol=1e-9)  # 10 digits
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["theta_hat_final"] is None
    assert summary["scenario"]["log_series"] == ["v_ref"]
    assert summary["metrics"]["iae"] == pytest.approx(r.metrics["iae"], rel=1e-12)
    written = {p.name for p in save_figures(r, tmp_path / "fig")}
    assert written == {"path.png", "error.png", "positions.png", "velocities.png"}
    with pytest.raises(ValueError, match="log_series"):
        r.plot_theta_hat()


def test_log_series_is_validated_and_read_back():
    assert Scenario(log_series="theta_hat").log_series == ("theta_hat",)
    assert Scenario(log_series="theta_hat, v_d").log_series == ("v_d", "theta_hat")
    assert Scenario(log_series="").log_series == ()
    # in the order of the result's series, the ones always logged dropped
    sc = Scenario(log_series=["theta_hat", "pose", "v_d"])
    assert sc.log_series == ("v_d", "theta_hat")
    assert Scenario.from_dict(sc.to_dict()) == sc
    with pytest.raises(unidyn.ValidationError, match="v_d, v_ref, theta_hat"):
        Scenario(log_series=["error"])
    with pytest.raises(unidyn.ValidationError, match="log_series"):
        Scenario(log_series={"theta_hat": True})


def test_the_error_of_integer_arrays_is_a_float():
    from unidyn.results.result import distance
    assert distance(np.array([[0, 0], [1, 1]]), np.array([[3, 4], [1, 1]])).tolist() == [5.0, 0.0]


@pytest.mark.parametrize("backend", ["compiled", "plain"])
def test_the_metrics_and_their_windows_do_not_depend_on_log_every(backend):
    """The metrics are accumulated at every sample, whatever is logged: the same bits at
    log_every 1, 10 and 20, and at 1 they are the trapezoidal rule over the series."""
    sc = Scenario.paper(4, T=10.0, adapt_from=2.0)
    runs = [simulate_batch([sc.replace(log_every=L)], backend=backend)[0] for L in (1, 10, 20)]
    assert [len(r.t) for r in runs] == [101, 11, 6]
    for r in runs[1:]:
        # the metrics' estimates and the final state's decide the tolerance: the same;
        # the series' estimates are over the samples logged
        assert r.metrics == runs[0].metrics and r.rtol == runs[0].rtol
        assert all(r.numerical_error[k] == runs[0].numerical_error[k] for k in DECISIVE)
        assert r.sensitive == runs[0].sensitive and r.estimate == runs[0].estimate
        assert r.window(2.0, 8.0) == runs[0].window(2.0, 8.0)
    full = runs[0]
    by_rule = metrics(full.t, full.error, full.velocity)
    inside = (full.t >= 2.0) & (full.t <= 8.0)
    window = metrics(full.t[inside], full.error[inside], full.velocity[inside])
    for k in by_rule:
        assert full.metrics[k] == pytest.approx(by_rule[k], rel=1e-12), k
    # a window gives its integrals and final values; a peak needs every sample in it
    windowed = full.window(2.0, 8.0)
    assert set(windowed) == {m.name for m in METRICS if m.rule != PEAK}
    for k in windowed:
        assert windowed[k] == pytest.approx(window[k], rel=1e-12), k


def test_the_diagram_s_metrics_do_not_depend_on_log_every():
    sc = Scenario.paper(3, T=2.0)
    full = unidyn.simulate(sc)
    thin = unidyn.simulate(sc.replace(log_every=10))
    assert len(thin.t) == 3 and thin.metrics == full.metrics
    assert thin.window(0.0, 1.0) == full.window(0.0, 1.0)
