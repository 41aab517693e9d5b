"""The paper's Fig. 2 as .bd files: bdrun/bdload runs them to the numbers of
unidyn.simulate; the .bd writer round-trips diagrams; the fixed-port blocks that
bdedit draws declare the ports they have; every block has an icon and typed
parameters."""

from __future__ import annotations

import contextlib
import functools
import inspect
import io
import json
import os
import pickle
import struct
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

import unidyn
from unidyn import Scenario
from unidyn.diagrams import bdfile, build_fig2, new_simulator
from unidyn.diagrams.bdfile import PAPER_FILES, BdFileError

ROOT = Path(__file__).resolve().parents[2]
BD_DIR = ROOT / "examples" / "bd"
ICONS = ROOT / "src" / "unidyn" / "blocks" / "Icons"
from unidyn.diagrams.simulate import DEFAULT_ATOL, DEFAULT_RTOL  # noqa: E402

SOLVER = dict(rtol=DEFAULT_RTOL, atol=DEFAULT_ATOL)


def _quiet(f, *args, **kwargs):
    with warnings.catch_warnings(), contextlib.redirect_stdout(io.StringIO()):
        warnings.simplefilter("ignore")  # bdload's notice that it evaluates expressions
        return f(*args, **kwargs)


def _run(sim, bd, T, Ts=0.1):
    """Run as unidyn.simulate does: same solver, tolerances, step bound and output grid;
    the continuous states (robot x, y, psi[, u, w], compensator theta_hat) at t = k Ts."""
    _quiet(bd.compile)
    out = _quiet(sim.run, bd, T=T, dt=Ts, solver="RK45",
                 solver_args=dict(**SOLVER, max_step=Ts))
    return np.asarray(out.t), np.asarray(out.x), list(out.xnames)


def _load(path):
    from bdsim.blockdiagram import bdload
    sim = new_simulator()
    bd = sim.blockdiagram()
    _quiet(bdload, bd, str(path))
    return sim, bd


@functools.cache
def _simulated_states(n, T):
    """The same states from unidyn.simulate(Scenario.paper(n, T=T)), the library's own
    route (once per process: the shipped file and bdrun are both checked against it)."""
    return _states(unidyn.simulate(Scenario.paper(n, T=T), progress=False), n)


def _states(res, n):
    """A Result's continuous states in the order of a Fig. 2 diagram's."""
    cols = [res.pose]
    if n != 1:
        cols.append(res.velocity)
    if n in (3, 4):
        cols.append(res.theta_hat)
    return res.t, np.hstack(cols)


# --------------------------------------------------------------------------- #
# the shipped files


def test_shipped_files_are_what_the_script_writes(tmp_path):
    written = bdfile.write_paper_fig2(tmp_path)
    assert sorted(p.name for p in written) == sorted(PAPER_FILES.values())
    for p in written:
        assert p.read_bytes() == (BD_DIR / p.name).read_bytes(), (
            f"examples/bd/{p.name} is stale: run python tools/make_bd_files.py")


@pytest.mark.slow
@pytest.mark.parametrize("n", [1, 2, 3, 4])
def test_shipped_file_runs_to_simulate_numbers(n):
    """bdload + run of the shipped file (10 s) = unidyn.simulate(Scenario.paper(n, T=10)),
    with the paper's noise (same seeds, drawn by SENSORNOISE from the file's seed/stream)."""
    T = 10.0
    sim, bd = _load(BD_DIR / PAPER_FILES[n])
    t, x, names = _run(sim, bd, T)
    t_ref, x_ref = _simulated_states(n, T)
    assert x.shape == x_ref.shape == (101, {1: 3, 2: 5, 3: 11, 4: 11}[n]), names
    np.testing.assert_allclose(t, t_ref, rtol=0, atol=1e-12)
    err = np.abs(x - x_ref).max()
    assert err <= 1e-9, f"case {n}: max |bd file - simulate| = {err:.3g}"
    # and it is a real trajectory: the robot moved along the figure eight
    assert np.ptp(x[:, 0]) > 0.5


def _bdrun(path, T, out, timeout, rtol=SOLVER["rtol"], atol=SOLVER["atol"]):
    env = dict(os.environ, BDSIMPATH="unidyn", MPLBACKEND="Agg")
    bdrun = Path(sys.executable).with_name("bdrun")
    cmd = [str(bdrun), str(path), "--simtime", f"{T},0.1", "--rtol", str(rtol),
           "--atol", str(atol), "--max-step", "0.1", "--no-graphics", "-q", "-p", str(out)]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, env=env)
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-2000:]
    with open(out, "rb") as f:
        return pickle.load(f)


@pytest.mark.slow
@pytest.mark.parametrize("n", [1, 2, 3, 4])
def test_bdrun_runs_each_shipped_file_headless(n, tmp_path):
    """The command line route: bdrun FILE.bd (a separate process, no display) with
    simulate's solver settings gives simulate's numbers (10 s)."""
    T = 10.0
    o = _bdrun(BD_DIR / PAPER_FILES[n], T, tmp_path / "out.pkl", timeout=180)
    t_ref, x_ref = _simulated_states(n, T)
    assert list(o.xnames) == ([f"robot:{s}" for s in ("x", "y", "psi", "u", "w")[:3 if n == 1 else 5]]
                              + [f"theta_hat{i}" for i in range(1, 7) if n in (3, 4)])
    np.testing.assert_allclose(np.asarray(o.t), t_ref, rtol=0, atol=1e-12)
    assert np.abs(np.asarray(o.x) - x_ref).max() <= 1e-9


@pytest.mark.slow
def test_bdrun_full_paper_run_4(tmp_path, section5_runs):
    """The paper's full simulation 4 (200 s, the update switched on at 100 s: past the
    10 s runs above), through bdrun with the solver settings of the README's Section 5
    script, against that script's run of it (the timeseries.csv it wrote, 10
    significant digits: within 5e-10 of the values it computed)."""
    sys.path.insert(0, str(ROOT / "examples"))
    try:
        import paper_section5
    finally:
        sys.path.remove(str(ROOT / "examples"))
    o = _bdrun(BD_DIR / PAPER_FILES[4], 200.0, tmp_path / "out.pkl", timeout=600,
               rtol=paper_section5.RTOL, atol=paper_section5.ATOL)
    cols, _ = section5_runs[4]
    x_ref = np.column_stack([cols[k] for k in ("x", "y", "psi", "u", "w")]
                            + [cols[f"theta_hat{i}"] for i in range(1, 7)])
    np.testing.assert_allclose(np.asarray(o.t), cols["t"], rtol=0, atol=1e-9)
    x = np.asarray(o.x)
    assert x.shape == x_ref.shape
    err = np.abs(x - x_ref).max()
    assert err <= 1e-9, f"max |bdrun - paper_section5.py| over 200 s = {err:.3g}"


# --------------------------------------------------------------------------- #
# the writer


#: 5 s each: past the adaptation switched on at 2 s and the radius step at 4 s
ROUND_TRIP = {
    "paper 1": Scenario.paper(1, T=5.0),
    "paper 2": Scenario.paper(2, T=5.0),
    "paper 3": Scenario.paper(3, T=5.0),
    "paper 4, adapting from 2 s": Scenario.paper(4, T=5.0, adapt_from=2.0),
    # a robot that is not a preset, a circle whose radius steps, no noise, the derivative
    # filter (the string "filter", a Python builtin, must reach the block as a string)
    "circle, filter, custom robot": Scenario(
        case="adaptive", T=5.0, noise=None, vd_dot="filter", adapt_from=0.0,
        robot=[0.3, 0.25, 0.001, 0.95, 0.002, 1.05],
        trajectory={"type": "circle", "radius": [[0, 1.2], [4, 1.0]], "omega": -0.3,
                    "phase": 0.5}),
    # a load picked up during the run (DYNAMICUNICYCLE's payload schedule)
    "paper 4, load picked up at 2.5 s": Scenario.paper(4, T=5.0, adapt_from=1.0,
                                                       payload=[[2.5, 2.0]]),
    "line, fx44850 leakage, no limits": Scenario(
        case="adaptive", T=5.0, leakage="fx44850", limits=unidyn.NO_LIMITS,
        trajectory={"type": "line", "start": [0.0, 0.5], "velocity": [0.2, 0.05]}),
    # the compensator with its own derivative filter, noise of another seed, a goal point
    "point, compensated, filter, noise seed 5": Scenario(
        case="compensated", T=5.0, vd_dot="filter", noise={"seed": 5},
        trajectory={"type": "point", "x": 0.8, "y": -0.4}),
}


@pytest.mark.slow
@pytest.mark.parametrize("label", list(ROUND_TRIP))
def test_writer_round_trip(label, tmp_path):
    """write build_fig2's diagram, bdload it, run both: the same numbers."""
    sc = ROUND_TRIP[label]
    sim = new_simulator()
    fig = build_fig2(sim, sc)
    path = bdfile.save_bd(fig, tmp_path / "fig2.bd")
    sim2, bd2 = _load(path)
    assert sorted(b.name for b in bd2.blocklist) == sorted(b.name for b in fig.bd.blocklist)
    wires = lambda bd: sorted((w.start.block.name, w.start.port, w.end.block.name, w.end.port)
                              for w in bd.wirelist)
    assert wires(bd2) == wires(fig.bd)
    t1, x1, n1 = _run(sim, fig.bd, sc.T)
    t2, x2, n2 = _run(sim2, bd2, sc.T)
    assert n1 == n2 and x1.shape == x2.shape
    assert np.abs(x1 - x2).max() <= 1e-12
    # the loaded blocks hold the same settings as the built ones
    for b in fig.bd.blocklist:
        b2 = next(c for c in bd2.blocklist if c.name == b.name)
        assert bdfile.block_parameters(b2) == bdfile.block_parameters(b)
    # written twice: the same bytes
    assert bdfile.save_bd(build_fig2(new_simulator(), sc), tmp_path / "again.bd").read_bytes() \
        == path.read_bytes()


#: For every unidyn block a .bd file can hold: a value for each parameter other than
#: its default, and the values on its inputs. A new parameter fails the test below
#: until it has a value here.
NON_DEFAULT = {
    "DynamicUnicycle": (dict(robot=[0.3, 0.25, 0.001, 0.95, 0.002, 1.05], a=0.15,
                             x0=[0.1, -0.2, 0.3, 0.05, -0.02], speed_max=0.9, accel_max=0.6,
                             steer_max=1.7, angular_accel_max=2.2,
                             limits=unidyn.Limits(speed_max=0.8, steer_max=1.5, accel_max=0.5,
                                                  angular_accel_max=2.0),
                             disturbance=True, velocity_output=True, w=0.4,
                             payload=[[0.5, 2.0], [3.0, 0.8]]),
                        [0.3, -0.2, [0.01, 0.02, -0.03, 0.04]]),
    "DynamicUnicycleWithVelocity": (dict(robot="khepera3", a=0.1, x0=[1.0, 2.0, 0.5],
                                         speed_max=0.7, accel_max=0.4, steer_max=1.2,
                                         angular_accel_max=1.9, payload=[[0.2, 1.5]]),
                                    [0.3, -0.2]),
    "KinematicUnicycle": (dict(a=0.25, x0=[0.5, -0.5, 1.0], speed_max=0.6, steer_max=1.1,
                               limits=unidyn.Limits(speed_max=0.5, steer_max=0.9)), [0.3, -0.2]),
    "KinematicController": (dict(a=0.3, kx=0.2, ky=0.3, lx=0.4, ly=0.5, rate=True),
                            [[1.0, 0.5], [0.1, 0.2], [0.9, 0.4, 0.3], [0.01, -0.02], [0.2, 0.1]]),
    "KinematicControllerWithRate": (dict(a=0.3, kx=0.2, ky=0.3, lx=0.4, ly=0.5),
                                    [[1.0, 0.5], [0.1, 0.2], [0.9, 0.4, 0.3], [0.01, -0.02],
                                     [0.2, 0.1]]),
    "DynamicCompensator": (dict(theta_hat0=[0.3, 0.25, 0.001, 0.95, 0.002, 1.05], ku=3.0,
                                kw=5.0, lu=0.7, lw=1.3, adaptive=True,
                                gamma=[1.0, 2.0, 3.0, 4.0, 5.0, 6.0],
                                sigma=[0.1, 0.2, 0.3, 0.4, 0.5, 0.6], adapt_from=0.5,
                                leakage="fx44850", vd_dot="input", tau=0.2),
                           [[0.3, 0.1], [0.25, 0.05], [0.01, -0.02]]),
    "DynamicCompensatorWithRateInput": (dict(theta_hat0="khepera3", ku=3.0, kw=5.0, lu=0.7,
                                             lw=1.3, adaptive=True,
                                             gamma=[1.0, 2.0, 3.0, 4.0, 5.0, 6.0],
                                             sigma=[0.1, 0.2, 0.3, 0.4, 0.5, 0.6],
                                             adapt_from=0.5, leakage="none"),
                                        [[0.3, 0.1], [0.25, 0.05], [0.01, -0.02]]),
    "TrajectorySource": (dict(trajectory={"type": "circle", "radius": 2.0, "omega": -0.3,
                                          "center": [1.0, 1.0], "phase": 0.2}), []),
    "FigureEight": (dict(ax=2.0, ay=0.5, wx=0.3, wy=0.15, center=[1.0, -1.0]), []),
    "Circle": (dict(radius=[[0.0, 2.0], [3.0, 1.5]], omega=-0.3, center=[1.0, 1.0],
                    phase=0.2), []),
    "Line": (dict(start=[1.0, 2.0], velocity=[-0.1, 0.3]), []),
    "Point": (dict(x=-1.0, y=2.5), []),
    "Segment": (dict(start=[1.0, 2.0], end=[-0.5, 3.0], speed=0.4), []),
    "SensorNoise": (dict(Ts=0.2, clock_name="meas", std=0.05, seed=9, stream=2,
                         indices=[1, 2]), [[1.0, 2.0, 3.0]]),
}

#: Parameters no .bd file can hold a non-default value of: code, a bdsim clock.
NOT_IN_FILES = {("TrajectorySource", "acceleration")}


def _evaluate(block, inputs):
    """The block's outputs, and its state derivative where it has one, at t = 0.7 s
    from its initial state."""
    x = np.asarray(block._x0, dtype=float) if (block.nstates or block.ndstates) else None
    values = [np.asarray(v, dtype=float) for v in block.output(0.7, inputs, x)]
    if block.nstates:
        values.append(np.asarray(block.deriv(0.7, inputs, x), dtype=float))
    return values


@pytest.mark.parametrize("name", sorted(NON_DEFAULT))
def test_block_with_every_parameter_changed_round_trips(name, tmp_path):
    """A block built with a non-default value of every parameter, written to a .bd file
    and loaded by bdload, is rebuilt with the same arguments and computes the same."""
    import unidyn.blocks as blocks
    cls = getattr(blocks, name)
    kwargs, inputs = NON_DEFAULT[name]
    sig = inspect.signature(cls.__init__)
    for p in sig.parameters.values():
        if p.name == "self" or p.kind in (p.VAR_KEYWORD, p.VAR_POSITIONAL):
            continue
        if (name, p.name) in NOT_IN_FILES:
            continue
        assert p.name in kwargs, f"give {name}'s new parameter {p.name!r} a non-default value in NON_DEFAULT"
        if p.default is not inspect.Parameter.empty:
            assert not np.array_equal(np.asarray(kwargs[p.name], dtype=object),
                                      np.asarray(p.default, dtype=object)), (name, p.name)
    sim = new_simulator()
    bd = sim.blockdiagram()
    block = cls(**kwargs, bd=bd, name="block")
    for i, value in enumerate(inputs):
        bd.connect(bd.CONSTANT(value, name=f"in{i}"), block[i])
    for i in range(block.nout):
        bd.connect(block[i], bd.NULL(1, name=f"out{i}"))
    _, bd2 = _load(bdfile.save_bd(bd, tmp_path / "block.bd", layout=None))
    loaded = next(b for b in bd2.blocklist if b.name == "block")
    assert type(loaded).__name__ == name
    assert bdfile.block_parameters(loaded) == bdfile.block_parameters(block)
    inputs = [np.asarray(v, dtype=float) if np.ndim(v) else v for v in inputs]
    for a, b in zip(_evaluate(loaded, inputs), _evaluate(block, inputs), strict=True):
        np.testing.assert_array_equal(a, b)


def test_every_writable_block_is_in_the_round_trip():
    """Every unidyn block class is either in NON_DEFAULT or needs a bdsim clock."""
    import unidyn.blocks as blocks
    for name in blocks.__all__:
        cls = getattr(blocks, name)
        if not inspect.isclass(cls):
            continue
        if "clock" in inspect.signature(cls.__init__).parameters:
            continue
        assert name in NON_DEFAULT, name


def test_writer_values_in_bdload_form():
    from unidyn.diagrams.bdfile import _write_value as w
    assert w("p3dx_laser", "p") == "p3dx_laser"        # bdload's eval fails: kept as a string
    assert w("input", "p") == "='input'"               # a builtin: written as an expression
    assert w("filter", "p") == "='filter'"
    assert w("np", "p") == "='np'"
    assert w("=x", "p") == "='=x'"
    assert w(np.inf, "p") == "=math.inf"
    assert w([1.0, -np.inf], "p") == "=[1.0, -math.inf]"
    assert w(np.array([1, 2]), "p") == [1, 2]
    assert w(None, "p") is None
    with pytest.raises(BdFileError, match="p is NaN"):
        w(float("nan"), "p")


def test_writer_errors_name_block_and_parameter(tmp_path):
    sim = new_simulator()
    fig = build_fig2(sim, Scenario.paper(3, T=1.0, control="sampled"))
    with pytest.raises(BdFileError, match=r"block 'controller' \(SampledKinematicController\): "
                                          r"parameter 'clock'"):
        bdfile.save_bd(fig, tmp_path / "x.bd")
    assert not (tmp_path / "x.bd").exists()

    from unidyn.blocks import TrajectorySource
    bd = new_simulator().blockdiagram()
    src = TrajectorySource(lambda t: ((0.0, 0.0), (0.0, 0.0)), bd=bd, name="ref")
    bd.connect(src[0], bd.NULL(1, name="n0"))
    with pytest.raises(BdFileError, match=r"block 'ref' \(TrajectorySource\): parameter 'trajectory'"):
        bdfile.to_bd_dict(bd)

    bd = new_simulator().blockdiagram()
    c = bd.CONSTANT(1.0, name="one")
    i = bd.INTEGRATOR(name="integ")
    bd.connect(c, i)
    with pytest.raises(BdFileError, match=r"block 'integ' \(Integrator\)"):
        bdfile.to_bd_dict(bd)


def test_fig2_layout_reads_left_to_right():
    data = json.loads((BD_DIR / PAPER_FILES[4]).read_text())
    pos = {b["title"]: (b["pos_x"], b["pos_y"]) for b in data["blocks"]}
    order = ["trajectory", "controller", "compensator", "demux", "robot"]
    xs = [pos[k][0] for k in order]
    assert xs == sorted(xs) and len(set(xs)) == len(xs)
    assert all(pos[k][1] == 0.0 for k in order)
    for k in ("position_noise", "velocity_noise"):   # the measurements, below, fed back
        assert pos[k][1] > 100.0
    flipped = {b["title"] for b in data["blocks"] if b["flipped"]}
    assert flipped == {"position_noise", "velocity_noise"}



@pytest.mark.parametrize("n", sorted(PAPER_FILES))
def test_unused_outputs_end_in_sinks_named_for_their_signal(n):
    """An output nothing reads ends in a NULL named for the signal (theta_hat_unused),
    not a number the editor's user has to trace back."""
    data = json.loads((BD_DIR / PAPER_FILES[n]).read_text())
    port = {o["id"]: (b, o["index"]) for b in data["blocks"] for o in b["outputs"]}
    feeds = {i["id"]: b for b in data["blocks"] for i in b["inputs"]}
    sinks = 0
    for w in data["wires"]:
        sink = feeds[w["end_socket"]]
        if sink["block_type"] != "NULL":
            continue
        src, index = port[w["start_socket"]]
        names = {"FIGUREEIGHT": ["h_d", "h_d_dot", "h_d_ddot"],
                 "DYNAMICCOMPENSATORWITHRATEINPUT": ["v_r", "theta_hat"]}[src["block_type"]]
        assert sink["title"] == f"{names[index]}_unused"
        sinks += 1
    assert sinks == 1


def test_fig2_layout_keeps_the_editors_wire_lanes_apart():
    """bdedit turns a wire fed back into input i of a block 20 px x (i + 1) left of it,
    and a wire between two side-by-side blocks halfway between them: the gaps before K
    and D keep every such turn twice that from the others, blocks sit on the
    editor's 20 px grid."""
    data = json.loads((BD_DIR / PAPER_FILES[4]).read_text())
    blocks = {b["title"]: b for b in data["blocks"]}
    for b in blocks.values():
        assert b["pos_x"] % 20 == 0 and b["pos_y"] % 20 == 0, b["title"]
    for left, right, fed_back in (("trajectory", "controller", (2, 4)),
                                  ("controller", "compensator", (1,))):
        gap = blocks[right]["pos_x"] - blocks[left]["pos_x"] - blocks[left]["width"]
        turns = sorted([gap / 2] + [20 * (i + 1) for i in fed_back])
        assert min(np.diff(turns)) >= 40, (left, right, turns)

# --------------------------------------------------------------------------- #
# blocks: fixed ports, icons, typed parameters


def _unidyn_library():
    sim = new_simulator()
    return sim, {k: v for k, v in sim.block_library.items() if v["module"].startswith("unidyn.")}


def _construct(sim, key):
    """A block of each unidyn type with its defaults (a named clock where one is needed)."""
    bd = sim.blockdiagram()
    f = getattr(bd, key)
    if "clock" in _unidyn_library()[1][key]["params"]:
        return f(bd.clock(0.1, name="c"))
    if key == "TRAJECTORYSOURCE":
        return f({"type": "circle"})
    return f()


FIXED = {"DYNAMICUNICYCLEWITHVELOCITY": (2, 2), "KINEMATICCONTROLLERWITHRATE": (5, 2),
         "DYNAMICCOMPENSATORWITHRATEINPUT": (3, 2), "SENSORNOISE": (1, 1)}


def test_fixed_port_classes_have_the_ports_they_declare():
    sim, lib = _unidyn_library()
    assert set(FIXED) <= set(lib)
    for key, info in lib.items():
        block = _construct(sim, key)
        cls = type(block)
        # what bdedit reads (bdsim's library, from the class attributes) = the block at run time
        assert (info["nin"], info["nout"]) == (cls.nin, cls.nout) == (block.nin, block.nout), key
        assert len(cls.outlabels) == cls.nout, key
        if cls.nin:
            assert len(cls.inlabels) == cls.nin, key
    for key, ports in FIXED.items():
        assert (lib[key]["nin"], lib[key]["nout"]) == ports


def test_fixed_port_classes_refuse_port_changing_options():
    from unidyn.blocks import (
        DynamicCompensatorWithRateInput,
        DynamicUnicycleWithVelocity,
        KinematicControllerWithRate,
    )
    bd = new_simulator().blockdiagram()
    for cls, kw in ((DynamicUnicycleWithVelocity, {"velocity_output": False}),
                    (DynamicUnicycleWithVelocity, {"disturbance": True}),
                    (DynamicUnicycleWithVelocity, {"nout": 1}),
                    (KinematicControllerWithRate, {"rate": False}),
                    (DynamicCompensatorWithRateInput, {"vd_dot": "filter"})):
        with pytest.raises(unidyn.ValidationError, match=f"{cls.__name__}: unknown keyword "
                                                         f"'{next(iter(kw))}'"):
            cls(bd=bd, **kw)


def test_fixed_port_classes_compute_what_their_parents_compute():
    """Each fixed-port block gives its parent's outputs and derivatives on random inputs."""
    from unidyn.blocks import (
        DynamicCompensator,
        DynamicCompensatorWithRateInput,
        DynamicUnicycle,
        DynamicUnicycleWithVelocity,
        KinematicController,
        KinematicControllerWithRate,
    )
    bd = new_simulator().blockdiagram()
    rng = np.random.default_rng(1)
    pairs = [(DynamicUnicycleWithVelocity(robot="p3dx_laser", a=0.2, speed_max=0.75, accel_max=0.3,
                                          bd=bd),
              DynamicUnicycle(robot="p3dx_laser", a=0.2, speed_max=0.75, accel_max=0.3,
                              velocity_output=True, bd=bd), [1, 1], 5),
             (KinematicControllerWithRate(kx=0.4, bd=bd), KinematicController(kx=0.4, rate=True, bd=bd),
              [2, 2, 3, 2, 2], 0),
             (DynamicCompensatorWithRateInput(adaptive=True, bd=bd),
              DynamicCompensator(adaptive=True, vd_dot="input", bd=bd), [2, 2, 2], 6)]
    for new, old, sizes, nx in pairs:
        for _ in range(20):
            u = [rng.normal(size=n) if n > 1 else rng.normal() for n in sizes]
            x = rng.normal(size=nx) * 0.3
            for a, b in zip(new.output(1.0, u, x), old.output(1.0, u, x)):
                np.testing.assert_array_equal(a, b)
            if nx:
                np.testing.assert_array_equal(new.deriv(1.0, u, x), old.deriv(1.0, u, x))


def test_sensor_noise_streams_are_the_runs_noise():
    """SENSORNOISE(seed, stream=k) draws the k-th stream of unidyn.model.noise.noise_seeds(seed),
    and blocks naming one clock share it."""
    from unidyn.blocks import MeasurementNoise, SensorNoise
    from unidyn.model.noise import noise_seeds
    bd = new_simulator().blockdiagram()
    a = SensorNoise(Ts=0.1, seed=7, stream=1, std=0.5, bd=bd)
    b = SensorNoise(Ts=0.1, seed=7, stream=0, bd=bd)
    ref = MeasurementNoise(bd.clock(0.1, name="other"), seed=noise_seeds(7)[1], std=0.5, bd=bd)
    assert a._clock is b._clock and a._clock.name == "sensor"
    a.start(None), ref.start(None)
    np.testing.assert_array_equal(a._x0, ref._x0)
    for _ in range(5):
        np.testing.assert_array_equal(a.next(0.0, [np.zeros(2)], None), ref.next(0.0, [np.zeros(2)], None))
    with pytest.raises(unidyn.ValidationError, match="clock 'sensor' has period 0.1 s"):
        SensorNoise(Ts=0.2, bd=bd)


def _png_size(path: Path):
    head = path.read_bytes()[:24]
    assert head[:8] == b"\x89PNG\r\n\x1a\n", path
    return struct.unpack(">II", head[16:24])


def test_every_block_has_an_icon_and_typed_parameters():
    sim, lib = _unidyn_library()
    assert lib
    for key, info in lib.items():
        # bdedit's rule (bdedit.block_importer): <blocks folder>/Icons/<block type lower>.png
        icon = Path(info["path"][0]) / "Icons" / f"{key.lower()}.png"
        assert icon.is_file(), f"{key}: no icon {icon}"
        assert icon.resolve().parent == ICONS.resolve()
        assert _png_size(icon) == (250, 250)
        cls = type(_construct(sim, key))
        sig = inspect.signature(cls.__init__)
        params = [p for p in sig.parameters.values()
                  if p.name != "self" and p.kind not in (p.VAR_KEYWORD, p.VAR_POSITIONAL)]
        assert params, key
        for p in params:
            assert p.annotation is not inspect.Parameter.empty, f"{key}: {p.name} has no annotation"
            typ, text = info["params"].get(p.name, (None, None))
            assert text, f"{key}: no :param {p.name}:"
            assert typ and typ.strip(), f"{key}: no :type {p.name}:"
        # nothing documented that the constructor does not take (bdedit would offer it)
        documented = set(info["params"]) - {"blockargs"}
        assert documented <= {p.name for p in params}, key


def test_annotations_resolve():
    """bdweb-style forms evaluate the annotations: every one names something real."""
    import typing
    sim, lib = _unidyn_library()
    for key in lib:
        cls = type(_construct(sim, key))
        hints = typing.get_type_hints(cls.__init__)
        assert hints, key


def test_the_former_import_path_still_gives_the_writer():
    with pytest.warns(DeprecationWarning, match="unidyn.diagrams.bdfile"):
        from unidyn.teaching import bdfile as former
    assert former is bdfile
