"""The circle whose radius steps (the circle of the authors' MATLAB package): the
reference against the circle's formulas typed in again, the radius of the current
interval in position, velocity and acceleration alike; the closed loop in both engines
and with the CIRCLE block. In the kinematic case with no limits, Eq. (10) makes each
component of the error obey h~' = -l tanh(k h~ / l) between steps, solved by
h~(t) = (l/k) asinh(sinh(k h~0 / l) e^{-k (t - t0)}), and a step adds the jump of h_d
to h~ (h itself does not jump). The scenario file's form and the schedules refused."""

import json
import math

import numpy as np
import pytest

import unidyn
from unidyn import NO_LIMITS, Scenario, ValidationError
from unidyn.engine import kernels
from unidyn.model import equations as eq
from unidyn.model.closed_loop import ClosedLoop
from unidyn.model.trajectories import Circle, from_spec
from unidyn.sweeps.sweep_files import read_scenario_table

# the MATLAB package's circle: 1 m, a step of -0.1 m every 60 s, its sign alternating
FX44850 = Circle(radius=[(0, 1.0), (60, 0.9), (120, 1.0), (180, 0.9), (240, 1.0)],
                 omega=0.1)
# t, the radius then (typed in from the schedule above)
RADII = [(0.0, 1.0), (59.999, 1.0), (60.0, 0.9), (61.0, 0.9), (119.9, 0.9), (120.0, 1.0),
         (179.0, 1.0), (180.0, 0.9), (239.99, 0.9), (240.0, 1.0), (400.0, 1.0)]


def circle_formulas(t, R, w, c=(0.0, 0.0), phi=0.0):
    a = w * t + phi
    return (np.array([c[0] + R * math.cos(a), c[1] + R * math.sin(a)]),
            np.array([-R * w * math.sin(a), R * w * math.cos(a)]),
            np.array([-R * w * w * math.cos(a), -R * w * w * math.sin(a)]))


def test_the_reference_is_the_circle_of_the_radius_in_force():
    for t, R in RADII:
        want = circle_formulas(t, R, 0.1)
        for got, w in zip(FX44850.evaluate(t), want):
            np.testing.assert_allclose(got, w, rtol=0, atol=1e-15)
    # arrays of times give the same
    t = np.array([t for t, _ in RADII])
    for got, i in zip(FX44850.evaluate(t), range(3)):
        np.testing.assert_allclose(got, [circle_formulas(s, R, 0.1)[i] for s, R in RADII],
                                   rtol=0, atol=1e-15)


# the batch engine's reference from its parameter table: plain Python, and compiled
REFERENCE = [pytest.param(kernels.reference.py_func if kernels.AVAILABLE else kernels.reference,
                          id="python")] + (
    [pytest.param(kernels.reference, id="compiled")] if kernels.AVAILABLE else [])


@pytest.mark.parametrize("reference", REFERENCE)
def test_the_engine_s_table_holds_the_schedule(reference):
    stepped = Circle(radius=[(0, 0.7)] + [(3.0 * k, 0.7 + 0.1 * k) for k in
                                          range(1, eq.RADIUS_STEPS + 1)],
                     omega=-0.4, center=(0.5, -1.0), phase=0.3)
    plain = Circle(radius=0.7, omega=-0.4, center=(0.5, -1.0), phase=0.3)
    table = ClosedLoop([Scenario(trajectory=tr, T=1.0) for tr in (stepped, plain)]).P
    for t in np.linspace(0.0, 30.0, 301):
        np.testing.assert_allclose(reference(t, t, table[0], ()), np.concatenate(stepped.evaluate(t)),
                                   rtol=0, atol=1e-15)
        # a circle whose radius does not step: the circle's function, bit for bit
        assert reference(t, t, table[1], ()) == eq.circle(t, 0.7, -0.4, 0.5, -1.0, 0.3)


STEPS = [(0, 1.0), (5, 0.8), (10, 1.0), (15, 0.8)]   # t, R: from t on, R
W, X0, K, L = 0.5, (0.7, 0.2, 0.3), 1.0, 0.3


def kinematic_error(times):
    """|h~| at the given times from the solution above, interval by interval."""
    e = circle_formulas(0.0, STEPS[0][1], W)[0] - X0[:2]
    decay = lambda e, dt: (L / K) * np.arcsinh(np.sinh(K * e / L) * math.exp(-K * dt))
    t0, k, out = 0.0, 1, []
    for t in times:
        while k < len(STEPS) and t >= STEPS[k][0]:  # decay to the step, add its jump
            ts = STEPS[k][0]
            e = decay(e, ts - t0) + (circle_formulas(ts, STEPS[k][1], W)[0]
                                     - circle_formulas(ts, STEPS[k - 1][1], W)[0])
            t0, k = ts, k + 1
        out.append(np.hypot(*decay(e, t - t0)))
    return np.array(out)


def scenario(**kw):
    return Scenario(**{**dict(case="kinematic", trajectory={"type": "circle", "radius": STEPS,
                                                            "omega": W},
                              x0=X0, kx=K, ky=K, lx=L, ly=L, limits=NO_LIMITS, noise=None,
                              T=20.0), **kw})


def before_each_step(r):
    """The samples just before each step and at the end."""
    return [np.searchsorted(r.t, t) - 1 for t, _ in STEPS[1:]] + [len(r.t) - 1]


@pytest.mark.parametrize("engine", ["batch", "bdsim"])
def test_kinematic_loop_follows_each_step_as_the_closed_form_says(engine):
    r = unidyn.run(scenario(), engine=engine, rtol=1e-8, atol=1e-10)  # series to 1e-7
    assert r.complete, r.message
    np.testing.assert_allclose(r.error, kinematic_error(r.t), atol=1e-6)
    # each step throws h 0.2 m off (the start 0.36 m); it is back within 5 mm by the next
    assert np.all(r.error[before_each_step(r)] < 5e-3)
    assert np.all(r.error[[np.searchsorted(r.t, t) for t, _ in STEPS[1:]]] > 0.19)


def test_dynamic_loop_the_circle_block_and_the_batch_engine_agree():
    """The robot with its dynamics (Eq. 2) and exact compensation (Eq. 12), the paper's
    limits: the CIRCLE block in the diagram and the batch engine's table agree, and h
    follows each new radius."""
    sc = scenario(case="compensated", limits=unidyn.PAPER_LIMITS, lx=0.5, ly=0.5)
    batch = unidyn.run(sc, engine="batch", rtol=1e-8, atol=1e-10)  # series, as the diagram
    block = unidyn.simulate(sc, trajectory=lambda bd, sc: bd.CIRCLE(radius=STEPS, omega=W))
    assert batch.complete and block.complete, (batch.message, block.message)
    np.testing.assert_allclose(block.pose, batch.pose, atol=1e-6)
    np.testing.assert_allclose(block.reference, batch.reference, atol=1e-12)
    assert np.all(batch.error[before_each_step(batch)] < 0.01)


def test_the_schedule_reads_and_writes_as_a_scenario_file_does(tmp_path):
    f = tmp_path / "circle.toml"
    f.write_text('case = "kinematic"\n[trajectory]\ntype = "circle"\nomega = 0.1\n'
                 'radius = [[0, 1.0], [60, 0.9], [120, 1.0], [180, 0.9], [240, 1.0]]\n')
    sc = Scenario.from_dict(read_scenario_table(f))
    assert sc.trajectory == FX44850
    spec = sc.to_dict()["trajectory"]
    assert spec["radius"] == [[0.0, 1.0], [60.0, 0.9], [120.0, 1.0], [180.0, 0.9],
                              [240.0, 1.0]]
    # written back as TOML (a list of numbers is the same in TOML and JSON) and as the
    # JSON of a result's summary: the same circle
    f.write_text("[trajectory]\n" + "".join(f"{k} = {json.dumps(v)}\n" for k, v in spec.items()))
    assert Scenario.from_dict(read_scenario_table(f)).trajectory == FX44850
    assert Scenario.from_dict(json.loads(json.dumps(sc.to_dict()))) == sc
    # one row is a radius that does not step
    assert from_spec({"type": "circle", "radius": [[0, 2.0]]}) == Circle(radius=2.0)
    assert Circle(radius=2.0).to_spec()["radius"] == 2.0


@pytest.mark.parametrize("radius, message", [
    ([], r"radius must be a number > 0 \(m\) or a schedule of \[t, R\] rows"),
    ([[0, 1.0], [60]], r"radius must be a number > 0 \(m\) or a schedule"),
    ([1.0, 0.9], r"radius must be a number > 0 \(m\) or a schedule"),
    ("1 m", r"radius must be a number > 0 \(m\) or a schedule"),
    ([[5, 1.0], [60, 0.9]], r"starts with the radius at t = 0, \[0, R\]; its first row has t = 5"),
    ([[0, 1.0], [60, 0.9], [60, 1.0]], r"times increase; row 2 has t = 60 after t = 60"),
    ([[0, 1.0], [60, 0.9], [30, 1.0]], r"times increase; row 2 has t = 30 after t = 60"),
    ([[0, 1.0], [60, -0.1]], r"radius\[1\] R must be > 0, got -0.1"),
    ([[0, 1.0], [60, 0.0]], r"radius\[1\] R must be > 0"),
    ([[0, 1.0], [math.nan, 0.9]], r"radius\[1\] t must be finite"),
    ([[0, 1.0], [math.inf, 0.9]], r"radius\[1\] t must be finite"),
    ([[0, 1.0], [60, True]], r"radius\[1\] R must be a real number"),
    ([[0, 1.0]] + [[k, 1.0] for k in range(1, eq.RADIUS_STEPS + 2)],
     rf"at most {eq.RADIUS_STEPS} steps after its row at t = 0, got {eq.RADIUS_STEPS + 1}"),
])
def test_bad_schedules_are_refused_in_one_line(radius, message):
    with pytest.raises(ValidationError, match=message) as err:
        from_spec({"type": "circle", "radius": radius})
    assert str(err.value).startswith("trajectory: radius") and "\n" not in str(err.value)
    with pytest.raises(ValidationError, match=message):
        Circle(radius=radius)
