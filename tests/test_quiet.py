"""What unidyn starts prints nothing of bdsim's: no toolbox notices, no notes on
unconnected outputs, no solver statistics."""

import json
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


def test_the_editor_starts_bdsim_without_notices_on_missing_toolboxes_and_keeps_installed_ones():
    """bdedit creates ``bdsim.BDSim(sysargs=False)`` (toolboxes on) when it fills its
    palette; ``unidyn edit`` sets bdsim's BDSIM_NO_TOOLBOXES first and names the
    installed toolboxes in BDSIMPATH (unidyn.editor.quiet_toolboxes). If bdsim stops
    reading that switch, its notices come back and this fails."""
    import importlib.util

    from unidyn.editor import TOOLBOXES
    installed = [p for p in TOOLBOXES if importlib.util.find_spec(p) is not None]
    missing = [p for p in TOOLBOXES if p not in installed]
    code = """
        import unidyn, bdsim
        from unidyn.editor import quiet_toolboxes
        quiet_toolboxes()
        for _ in range(2):  # bdedit starts two
            sim = bdsim.BDSim(sysargs=False)
        import json, sys
        print(json.dumps(sorted({b.get("package") for b in sim.block_library.values()})),
              file=sys.stderr)
    """
    env = {k: v for k, v in os.environ.items() if k != "BDSIM_NO_TOOLBOXES"}
    env["MPLBACKEND"] = "Agg"
    p = subprocess.run([sys.executable, "-c", textwrap.dedent(code)], capture_output=True,
                       text=True, env=env, timeout=300)
    assert p.returncode == 0, p.stderr
    assert p.stdout == "", p.stdout
    packages = json.loads(p.stderr.strip().splitlines()[-1])
    assert "unidyn" in packages and "bdsim" in packages
    assert all(t in packages for t in installed), (installed, packages)
    if missing:  # bdsim's notice, as it is without the switch: what the switch removes
        p = subprocess.run([sys.executable, "-c", "import unidyn, bdsim; "
                            "bdsim.BDSim(sysargs=False)"], capture_output=True, text=True,
                           env=env, timeout=300)
        assert f"package {missing[0]} not loaded" in p.stdout, p.stdout
