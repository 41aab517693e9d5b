"""The segment: from p0 to p1 at constant speed v, then p1 held (its desired velocity jumps
to zero at the arrival t_a = |p1 - p0| / v). The reference against the formulas typed in
again; in the kinematic case with no limits, Eq. (10) makes each component of the error
obey h~' = -l tanh(k h~ / l) whatever the reference does, solved by
h~(t) = (l/k) asinh(sinh(k h~0 / l) e^{-kt}), so h = h_d - h~ in both engines; with the
robot's dynamics (Eq. 2), exact compensation (Eq. 12) and the paper's limits, the batch
engine against scipy's solve_ivp; the SEGMENT block in the diagram; the scenario file,
a sweep over segments and the .bd file."""

import json
import math

import numpy as np
import pytest

import unidyn
from unidyn import NO_LIMITS, Scenario, ValidationError
from unidyn.diagrams import bdfile, build_fig2, new_simulator
from unidyn.engine.batch import simulate_batch
from unidyn.model.closed_loop import ClosedLoop
from unidyn.model.trajectories import Segment, from_spec
from unidyn.results.result import metrics
from unidyn.sweeps.sweep import Sweep, run_sweep
from unidyn.sweeps.sweep_files import read_metrics, read_scenario_table

# 1 m at 0.64 m/s: the arrival t_a = 1.5625 s (exact in binary) falls between two samples
P0, P1, V, TA = np.array([0.3, -0.2]), np.array([0.9, 0.6]), 0.64, 1.5625
SEGMENT = Segment(start=tuple(P0), end=tuple(P1), speed=V)


def path(t):
    """(h_d, h_d', h_d'') at times t, typed in from the definition."""
    t = np.asarray(t, dtype=float)[..., None]
    moving = t < TA
    return (np.where(moving, P0 + (P1 - P0) * t / TA, P1),
            np.where(moving, (P1 - P0) / TA + 0 * t, 0.0), 0.0 * t + np.zeros(2))


def test_the_reference_is_the_segment_typed_in_again():
    assert SEGMENT.duration == TA
    t = np.array([0.0, 0.7, 1.5625 - 1e-6, 1.5625, 1.6, 30.0])
    for got, want in zip(SEGMENT.evaluate(t), path(t)):
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-15)
    for s in t:  # one time at once, as the blocks ask
        for got, want in zip(SEGMENT.evaluate(float(s)), path(s)):
            np.testing.assert_allclose(got, want, rtol=0, atol=1e-15)
    # at constant speed v, and at p1 from the arrival on
    assert np.linalg.norm(SEGMENT.velocity(1.0)) == pytest.approx(V, rel=1e-15)
    np.testing.assert_array_equal(SEGMENT.position(TA), P1)


X0, K, L = (0.0, 0.1, 0.4), 1.0, 0.3


def kinematic(**kw):
    return Scenario(**{**dict(case="kinematic", trajectory=SEGMENT, x0=X0, kx=K, ky=K, lx=L,
                              ly=L, limits=NO_LIMITS, noise=None, T=4.0), **kw})


def error(t):
    """h~ at times t from the solution above, per component."""
    e0 = P0 - np.array(X0[:2])
    return np.stack([(L / K) * np.arcsinh(np.sinh(K * c / L) * np.exp(-K * t)) for c in e0], -1)


@pytest.mark.parametrize("engine, atol", [
    ("batch", 1e-9),
    # bdsim's solver steps across the jump of the desired velocity (the batch engine ends
    # a step there): about 2e-6 m at its default tolerances, 7e-11 m on a line
    ("bdsim", 1e-5)])
def test_kinematic_loop_tracks_as_the_closed_form_says(engine, atol):
    r = unidyn.run(kinematic(), engine=engine, rtol=1e-8, atol=1e-10)
    assert r.complete, r.message
    np.testing.assert_allclose(r.reference, path(r.t)[0], rtol=0, atol=1e-15)
    np.testing.assert_allclose(r.pose[:, :2], path(r.t)[0] - error(r.t), rtol=0, atol=atol)


def dynamic(**kw):
    return Scenario(**{**dict(case="compensated", trajectory=SEGMENT, x0=(0.4, -0.3, 0.3),
                              T=3.0, noise=None, kx=2.0, ky=2.0, lx=0.5, ly=0.5), **kw})


def test_dynamic_loop_in_the_batch_engine_is_within_twice_its_estimate_of_solve_ivp():
    """The robot with Eq. (2), the paper's limits (its accelerations clip, braking at the
    arrival); the converged reference takes 10 ms steps at most (agreeing with 1 ms ones
    to 1e-11 here), scipy's DOP853 stepping across the arrival under its error control."""
    sc = dynamic()
    r = simulate_batch([sc])[0]
    assert r.complete and not r.sensitive, r.message
    assert np.abs(np.diff(r.velocity[:, 0])).max() / sc.Ts == pytest.approx(0.3)  # clipped
    loop = ClosedLoop(sc)
    X = loop.converged(rtol=1e-11, atol=1e-13, max_step=1e-2)[0]
    t = np.arange(sc.steps + 1) * sc.Ts
    np.testing.assert_allclose(np.array([loop.reference(s)[:2] for s in t])[:, :, 0],
                               path(t)[0], rtol=0, atol=1e-15)
    want = metrics(t, np.hypot(*(X[:, :2] - path(t)[0]).T), X[:, 3:5])
    for k, v in want.items():
        assert abs(r.metrics[k] - v) <= 2 * r.numerical_error[k] * abs(v), k
    np.testing.assert_allclose(r.pose, X[:, :3], rtol=0, atol=1e-7)


def test_the_segment_block_in_the_diagram_agrees_with_the_batch_engine():
    sc = dynamic()
    fig = build_fig2(new_simulator(), sc)
    assert type(fig.blocks["trajectory"]).__name__ == "Segment"
    block = unidyn.simulate(sc, rtol=1e-10, atol=1e-12)
    batch = unidyn.run(sc, engine="batch", rtol=1e-10, atol=1e-12)
    assert block.complete and batch.complete, (block.message, batch.message)
    np.testing.assert_allclose(block.reference, batch.reference, rtol=0, atol=1e-15)
    np.testing.assert_allclose(block.pose, batch.pose, rtol=0, atol=1e-6)
    # a .bd file holds the block with its numbers, as bdedit shows them
    d = bdfile.to_bd_dict(fig)
    seg = [b for b in d["blocks"] if b["block_type"] == "SEGMENT"]
    assert len(seg) == 1
    assert dict(seg[0]["parameters"]) == {"start": list(P0), "end": list(P1), "speed": V}


def test_a_segment_reads_and_writes_as_a_scenario_file_does(tmp_path):
    f = tmp_path / "segment.toml"
    f.write_text('case = "kinematic"\n'
                 'trajectory = {type = "segment", start = [0.3, -0.2], end = [0.9, 0.6], '
                 'speed = 0.64}\n')
    sc = Scenario.from_dict(read_scenario_table(f))
    assert sc.trajectory == SEGMENT
    assert Scenario.from_dict(json.loads(json.dumps(sc.to_dict()))) == sc


@pytest.mark.parametrize("spec, message", [
    ({"end": [0.3, -0.2]}, r"end must differ from start, both \[0.3, -0.2\]; .* type 'point'"),
    ({"speed": 0}, r"speed must be > 0"),
    ({"speed": -1}, r"speed must be > 0"),
    ({"end": [1.0, math.nan]}, r"end"),
    ({"velocity": [1, 0]}, r"unknown trajectory.velocity for type 'segment'"),
])
def test_bad_segments_are_refused_in_one_line(spec, message):
    with pytest.raises(ValidationError, match=message) as err:
        from_spec({"type": "segment", "start": [0.3, -0.2], **spec})
    assert "\n" not in str(err.value)


def test_a_sweep_over_segments_runs_each(tmp_path):
    """Starting on the path, heading along it, the kinematic robot is on the reference
    throughout: u = v until the arrival, then 0, w = 0; no error, and an energy of v^2
    (trapezoids of the samples) up to the arrival."""
    f = tmp_path / "sweep.toml"
    heading = math.atan2(*(P1 - P0)[::-1])
    f.write_text(f'[base]\ncase = "kinematic"\nT = 4\nnoise = "off"\n'
                 f'x0 = [0.3, -0.2, {heading!r}]\n'
                 '[grid]\ntrajectory = ['
                 '{type = "segment", start = [0.3, -0.2], end = [0.9, 0.6], speed = 0.32}, '
                 '{type = "segment", start = [0.3, -0.2], end = [0.9, 0.6], speed = 0.64}]\n')
    sweep = Sweep.from_toml(f)
    assert [p.scenario.trajectory.speed for p in sweep.points()] == [0.32, 0.64]
    run_sweep(sweep, tmp_path / "out", progress=False)
    rows = read_metrics(tmp_path / "out")
    t = np.arange(41) * 0.1
    for row, v in zip(rows, (0.32, 0.64)):
        u = np.where(t < 1.0 / v, v, 0.0)
        assert row["complete"] and row["iae"] < 1e-12 and row["error_final"] < 1e-12
        assert row["energy"] == pytest.approx(np.trapezoid(u * u, t), rel=1e-12)
