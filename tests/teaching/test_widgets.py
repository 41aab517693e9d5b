"""The live sliders (unidyn.teaching.widgets): the callback runs the loop the settings describe
and draws what that run computed; the payload is the mass scaling of Section 2."""

from __future__ import annotations

import numpy as np
import pytest

import unidyn
from unidyn import RobotParameters, ValidationError
from unidyn.model import robots
from unidyn.teaching.widgets import LoopExplorer, with_payload


@pytest.fixture
def explorer():
    """A new explorer for each test: tests may run in any order and in any worker."""
    return LoopExplorer(k=0.1, payload=1.0, noise=True, case=4)


def _direct(case, k, payload, noise, theta_hat0=None, backend="auto"):
    """The same run built here from the paper's scenario, without the widget (on the
    backend that ran the widget's: a process's first steps run as plain Python, whose sin
    and cos may differ from the compiled ones in the last bit)."""
    th = robots.get("p3dx_laser").theta * np.array([payload, payload, payload, 1, payload, 1])
    sc = unidyn.Scenario.paper(case, robot=RobotParameters.from_vector(th), kx=k, ky=k,
                               theta_hat0=theta_hat0, noise=unidyn.NoiseSpec() if noise else None)
    (r,) = unidyn.simulate_batch([sc], progress=False, backend=backend)
    return r


def test_initial_drawing_is_the_papers_simulation_4(explorer):
    (r,) = unidyn.simulate_batch([unidyn.Scenario.paper(4)], progress=False,
                                 backend=explorer.result.backend)
    d = explorer.drawn
    np.testing.assert_array_equal(d["path"], r.pose[:, :2])
    np.testing.assert_array_equal(d["reference"], r.reference)
    np.testing.assert_array_equal(d["error"], np.c_[r.t, r.error])
    assert explorer.result.metrics["iae"] == r.metrics["iae"]


_MOVES = [dict(case=2, k=1.5, noise=False), dict(payload=2.0), dict(case=3, noise=True)]


@pytest.mark.parametrize("n_moves, expect", [
    (1, dict(case=2, k=1.5, payload=1.0, noise=False)),
    (2, dict(case=2, k=1.5, payload=2.0, noise=False)),  # the rest kept
    (3, dict(case=3, k=1.5, payload=2.0, noise=True, theta_hat0="p3dx_laser")),
])
def test_callback_redraws_the_run_it_describes(explorer, n_moves, expect):
    """The slider moves of _MOVES[:n_moves], one after the other, from the initial drawing."""
    for moves in _MOVES[:n_moves - 1]:
        explorer.update(**moves)
    before = explorer.drawn["error"].copy()
    explorer.update(**_MOVES[n_moves - 1])
    expect = dict(expect)
    r = _direct(expect.pop("case"), expect.pop("k"), expect.pop("payload"), expect.pop("noise"),
                backend=explorer.result.backend, **expect)
    d = explorer.drawn
    np.testing.assert_array_equal(d["path"], r.pose[:, :2])
    np.testing.assert_array_equal(d["error"], np.c_[r.t, r.error])
    assert not np.array_equal(before, d["error"])
    assert explorer.seconds["simulate"] > 0 and explorer.seconds["draw"] > 0


def test_payload_is_the_mass_scaling_of_section_2():
    """theta from physical parameters (Section 2) with the mass and I_z doubled, no rotor
    inertia and no servo derivative gains, equals with_payload(theta, 2)."""
    phys = dict(m=20.0, Iz=0.6, Ra=0.7, ka=0.03, kb=0.03, Be=0.002, Ie=0.0, r=0.1, b=0.05,
                d=0.33, kPT=2.0, kPR=2.5)
    empty = RobotParameters.from_physical(**phys)
    heavy = RobotParameters.from_physical(**{**phys, "m": 40.0, "Iz": 1.2})
    np.testing.assert_allclose(with_payload(empty, 2.0).theta, heavy.theta, rtol=1e-12)
    th = robots.get("p3dx").theta
    got = with_payload("p3dx", 1.5).theta
    np.testing.assert_allclose(got[[0, 1, 2, 4]], 1.5 * th[[0, 1, 2, 4]])
    np.testing.assert_array_equal(got[[3, 5]], th[[3, 5]])
    with pytest.raises(ValidationError, match="payload"):
        with_payload("p3dx", 0.0)


def test_unknown_payload_hurts_exact_compensation():
    """Case 3 compensates with the empty robot's theta: without noise it tracks the
    figure eight almost exactly; with twice the mass the error grows many-fold."""
    ex = LoopExplorer(case=3, noise=False, payload=1.0, figure=False)
    late = ex.result.t >= 100
    e1 = ex.result.error[late].mean()
    ex.update(payload=2.0)
    e2 = ex.result.error[late].mean()
    assert e1 < 1e-3 and e2 > 10 * e1
    with pytest.raises(ValidationError, match="draws nothing"):
        ex.drawn  # noqa: B018


def test_bad_settings_are_refused_and_keep_the_drawing(explorer):
    before = explorer.drawn["error"].copy()
    for bad in (dict(case=5), dict(case=True), dict(k=-1.0), dict(noise="yes"),
                dict(payload=0.0), dict(load_time=-1.0), dict(load_time=1e4)):
        with pytest.raises(ValidationError):
            explorer.update(**bad)
    np.testing.assert_array_equal(explorer.drawn["error"], before)


def test_widget_controls_drive_the_callback():
    w = pytest.importorskip("ipywidgets")
    ex = LoopExplorer(case=1, noise=False, k=0.5)
    box = ex.widget()
    sliders = {c.description: c for row in box.children for c in
               (row.children if isinstance(row, w.HBox) else [row]) if hasattr(c, "description")}
    sliders["k = kx = ky"].value = 2.0
    assert ex.settings["k"] == pytest.approx(2.0)
    r = _direct(1, ex.settings["k"], 1.0, False)
    np.testing.assert_array_equal(ex.drawn["path"], r.pose[:, :2])
    sliders["case"].value = 2
    assert ex.settings["case"] == 2 and ex.result.scenario.case == "uncompensated"
    sliders["payload x"].value = 2.0
    sliders["load at t ="].value = 50.0
    assert ex.result.scenario.payload == ((50.0, 2.0),)


def test_load_picked_up_mid_run_is_the_scenarios_payload_schedule():
    """The load slider's time: the run is the paper's with the empty robot carrying
    twice its mass from 100 s on; before 100 s it is the empty robot's run."""
    ex = LoopExplorer(case=3, noise=False, payload=2.0, load_time=100.0, figure=False)
    sc = unidyn.Scenario.paper(3, noise=None, payload=[[100.0, 2.0]])
    (r,) = unidyn.simulate_batch([sc], progress=False, backend=ex.result.backend)
    np.testing.assert_array_equal(ex.result.error, r.error)
    empty = LoopExplorer(case=3, noise=False, payload=1.0, figure=False).result
    before, after = ex.result.t < 100.0, ex.result.t >= 150.0
    np.testing.assert_array_equal(ex.result.error[before], empty.error[before])
    assert ex.result.error[after].mean() > 10 * empty.error[after].mean()
