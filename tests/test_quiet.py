"""What unidyn starts prints nothing of bdsim's: no toolbox notices, no notes on
unconnected outputs, no solver statistics."""

import os
import subprocess
import sys
import textwrap

import pytest

# each test starts a process of its own (tests/README.md)
pytestmark = pytest.mark.slow


def _run(code):
    env = {**os.environ, "MPLBACKEND": "Agg"}
    p = subprocess.run([sys.executable, "-c", textwrap.dedent(code)], capture_output=True,
                       text=True, env=env, timeout=300)
    assert p.returncode == 0, p.stderr
    return p.stdout, p.stderr


def test_simulate_prints_nothing():
    out, err = _run("""
        import unidyn
        for n in (1, 4):
            unidyn.simulate(unidyn.Scenario.paper(n, T=0.3))
        unidyn.simulate(unidyn.Scenario.paper(4, T=0.3, control="sampled"))
    """)
    assert out == "" and err == "", (out, err)


def test_a_fig2_diagram_in_a_quiet_user_simulator_compiles_and_runs_silently():
    out, err = _run("""
        import unidyn, bdsim
        from unidyn.diagrams import build_fig2
        # as the README's diagram: toolboxes=False (no notice on uninstalled toolboxes)
        sim = bdsim.BDSim(graphics=False, progress=False, banner=False, sysargs=False,
                          quiet=True, toolboxes=False)
        print("ready", flush=True)
        for sc in (unidyn.Scenario.paper(3, T=0.3), unidyn.Scenario.paper(1, T=0.3, vd_dot="filter")):
            fig = build_fig2(sim, sc)
            fig.bd.compile()
            sim.run(fig.bd, T=0.3, dt=0.1)
    """)
    assert out == "ready\n" and err == "", (out, err)
