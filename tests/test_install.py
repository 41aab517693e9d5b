"""The installed package: dependency versions, bdsim block discovery, the .pth hook.

Every helper process starts in a fresh empty folder: started from the checkout's
parent folder, ``python -c`` would put that folder first on ``sys.path``, and a
checkout named ``unidyn`` (``git clone``'s default) would then be imported as a
namespace package instead of the installed one.
"""

import os
import subprocess
import sys
import tempfile
import textwrap
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
BLOCKS = ["DYNAMICUNICYCLE", "KINEMATICUNICYCLE", "KINEMATICCONTROLLER",
          "SAMPLEDKINEMATICCONTROLLER", "DYNAMICCOMPENSATOR", "SAMPLEDDYNAMICCOMPENSATOR",
          "FIGUREEIGHT", "CIRCLE", "LINE", "TRAJECTORYSOURCE", "MEASUREMENTNOISE"]


def _run(code, env=None):
    full = {**os.environ, "MPLBACKEND": "Agg", **(env or {})}
    with tempfile.TemporaryDirectory(prefix="unidyn-cwd-") as cwd:
        return subprocess.run([sys.executable, "-c", textwrap.dedent(code)],
                              capture_output=True, text=True, env=full, cwd=cwd, timeout=300)


def test_bdsim_with_toolboxes_has_unicycle_vehicleplot_and_our_blocks():
    # Guards the pin of roboticstoolbox-python < 1.5: with rtb 1.5.0, bdsim 1.4.0's
    # block loader raises KeyError: 'type' inside bdsim.BDSim().
    r = _run(f"""
        import unidyn, bdsim
        sim = bdsim.BDSim(graphics=False, progress=False, banner=False, sysargs=False, toolboxes=True)
        lib = sim.blocklibrary() if callable(getattr(sim, 'blocklibrary', None)) else sim._blocklibrary
        missing = [b for b in {BLOCKS + ['UNICYCLE', 'VEHICLEPLOT']!r} if b not in lib]
        assert not missing, missing
        bd = sim.blockdiagram()
        veh = bd.DYNAMICUNICYCLE(robot='p3dx', x0=[0, 0, 0])
        uni = bd.UNICYCLE(x0=[0, 0, 0])
        print('ok')
    """)
    assert r.returncode == 0 and "ok" in r.stdout, r.stdout + r.stderr


def test_the_documented_line_for_editable_installs():
    # 'import unidyn' before bdsim.BDSim() makes the blocks available whatever the install
    r = _run("""
        import os
        os.environ.pop('BDSIMPATH', None)
        import unidyn, bdsim
        sim = bdsim.BDSim(graphics=False, progress=False, banner=False, sysargs=False)
        bd = sim.blockdiagram()
        print(type(bd.FIGUREEIGHT()).__name__)
    """, env={"BDSIMPATH": ""})
    assert r.returncode == 0 and "FigureEight" in r.stdout, r.stdout + r.stderr


def test_import_after_bdsim_still_registers():
    r = _run("""
        import bdsim
        sim = bdsim.BDSim(graphics=False, progress=False, banner=False, sysargs=False)
        import unidyn
        sim = bdsim.BDSim(graphics=False, progress=False, banner=False, sysargs=False)
        print(type(sim.blockdiagram().DYNAMICUNICYCLE()).__name__)
    """, env={"BDSIMPATH": ""})
    assert r.returncode == 0 and "DynamicUnicycle" in r.stdout, r.stdout + r.stderr


def test_import_changes_only_bdsimpath_in_this_process(tmp_path):
    """import unidyn leaves sys.path and the temp folder as they were; it adds
    unidyn to BDSIMPATH (documented) and nothing else to the environment. The temp
    folder is the process' own (TMPDIR): the system's gets other processes' files
    meanwhile, such as this module's other tests' working folders."""
    r = _run("""
        import os, sys, tempfile
        before_path, before_env = list(sys.path), dict(os.environ)
        before_tmp = set(os.listdir(tempfile.gettempdir()))
        import unidyn, unidyn.blocks, unidyn.diagrams
        new_tmp = set(os.listdir(tempfile.gettempdir())) - before_tmp
        changed = {k for k in set(os.environ) | set(before_env)
                   if os.environ.get(k) != before_env.get(k)}
        assert tempfile.gettempdir() == os.environ['TMPDIR']
        assert sys.path == before_path, (before_path, sys.path)
        assert not [n for n in new_tmp if 'unidyn' in n], new_tmp
        assert changed == {'BDSIMPATH'}, changed
        assert os.environ['BDSIMPATH'].split(':')[-1] == 'unidyn'
        print('ok')
    """, env={"BDSIMPATH": "", "TMPDIR": str(tmp_path)})
    assert r.returncode == 0 and "ok" in r.stdout, r.stdout + r.stderr


def test_python_started_in_the_checkout_imports_the_package_not_a_folder():
    """From the checkout's own folder (sys.path[0] = ''), import unidyn and its
    diagrams resolve to the package, never to a top-level folder of the checkout."""
    full = {**os.environ, "MPLBACKEND": "Agg"}
    r = subprocess.run([sys.executable, "-c", "import unidyn, unidyn.diagrams, unidyn.blocks; "
                        "print(unidyn.__file__); print(unidyn.diagrams.__file__)"],
                       capture_output=True, text=True, env=full, cwd=ROOT, timeout=300)
    assert r.returncode == 0, r.stderr
    init, diagrams = (Path(x) for x in r.stdout.split())
    assert init.name == "__init__.py" and init.parent.name == "unidyn"
    assert init.parent != ROOT / "unidyn" and diagrams.parent.parent == init.parent


def test_core_does_not_import_bdsim():
    r = _run("""
        import sys, unidyn, unidyn.model, unidyn.control, unidyn.trajectories, unidyn.robots
        import unidyn.scenario, unidyn.result
        print('bdsim' in sys.modules)
    """)
    assert r.returncode == 0 and r.stdout.strip() == "False", r.stdout + r.stderr


def test_import_is_light_and_the_core_is_reached_from_it():
    """``import unidyn`` loads no numpy (so the command's Ctrl-C handling is in place
    at once); what it used to load eagerly is still reached as an attribute."""
    r = _run("""
        import sys, unidyn
        print('numpy' in sys.modules)
        for name in ("model", "control", "trajectories", "robots", "parameters", "noise",
                     "equations", "RobotParameters", "Limits", "NoiseSpec", "NO_LIMITS",
                     "PAPER_LIMITS", "ValidationError", *unidyn.__all__):
            getattr(unidyn, name)
        from unidyn import *
        print(unidyn.parameters.RobotParameters is RobotParameters, issubclass(
              ValidationError, ValueError), sorted(set(unidyn.__all__) - set(dir(unidyn))))
    """)
    assert r.returncode == 0, r.stdout + r.stderr
    assert r.stdout.split("\n")[:2] == ["False", "True True []"], r.stdout


@pytest.mark.slow
def test_regular_install_finds_blocks_with_no_extra_step(tmp_path):
    """Build the wheel, install it (no deps) into a site dir and check that a
    fresh interpreter that never imports unidyn still gets bd.DYNAMICUNICYCLE."""
    wheel_dir = tmp_path / "wheel"
    r = subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation",
                        "-q", "-w", str(wheel_dir), str(ROOT)], capture_output=True, text=True,
                       timeout=600)
    if r.returncode != 0 and "No module named" in r.stderr:
        pytest.skip(f"cannot build a wheel here: {r.stderr[-300:]}")
    assert r.returncode == 0, r.stderr
    wheel = next(wheel_dir.glob("unidyn-*.whl"))
    site = tmp_path / "site"
    r = subprocess.run([sys.executable, "-m", "pip", "install", "--no-deps", "-q", "--target",
                        str(site), str(wheel)], capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr
    assert (site / "unidyn-bdsim.pth").is_file()
    assert (site / "unidyn" / "blocks" / "robots.py").is_file()
    # bdedit's palette icons are package data
    icons = {p.name for p in (ROOT / "src" / "unidyn" / "blocks" / "Icons").glob("*.png")}
    assert icons and icons == {p.name for p in (site / "unidyn" / "blocks" / "Icons").glob("*.png")}
    # a site dir processes .pth files as site-packages does at start-up; the
    # editable install's finder is removed so only the wheel's copy is visible
    code = f"""
        import sys, site
        sys.meta_path[:] = [f for f in sys.meta_path if 'editable' not in type(f).__module__
                            and 'editable' not in getattr(f, '__name__', '')]
        sys.path_importer_cache.clear()
        site.addsitedir({str(site)!r})
        sys.path.insert(0, {str(site)!r})
        import os
        assert 'unidyn' in os.environ['BDSIMPATH'].split(':'), os.environ.get('BDSIMPATH')
        import bdsim
        sim = bdsim.BDSim(graphics=False, progress=False, banner=False, sysargs=False)
        veh = sim.blockdiagram().DYNAMICUNICYCLE()
        import unidyn.blocks.robots as m
        print(m.__file__)
    """
    r = _run(code, env={"BDSIMPATH": ""})
    assert r.returncode == 0, r.stdout + r.stderr
    assert r.stdout.strip().splitlines()[-1].startswith(str(site)), r.stdout
