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


@pytest.mark.slow
def test_bdsim_with_toolboxes_has_unicycle_vehicleplot_and_our_blocks():
    # Guards the pin of roboticstoolbox-python < 1.5: with rtb 1.5.0, bdsim 1.4.0's
    # block loader raises KeyError: 'type' inside bdsim.BDSim().
    r = _run(f"""
        import unidyn, bdsim
        sim = bdsim.BDSim(graphics=False, progress=False, banner=False, sysargs=False, toolboxes=True)
        lib = sim.block_library
        missing = [b for b in {BLOCKS + ['UNICYCLE', 'VEHICLEPLOT']!r} if b not in lib]
        assert not missing, missing
        bd = sim.blockdiagram()
        veh = bd.DYNAMICUNICYCLE(robot='p3dx', x0=[0, 0, 0])
        uni = bd.UNICYCLE(x0=[0, 0, 0])
        print('ok')
    """)
    assert r.returncode == 0 and "ok" in r.stdout, r.stdout + r.stderr


@pytest.mark.slow
def test_import_first_serves_a_checkout_used_without_install():
    # with no hook (BDSIMPATH emptied, as for src/ on PYTHONPATH), 'import unidyn'
    # before bdsim.BDSim() makes the blocks available
    r = _run("""
        import os
        os.environ.pop('BDSIMPATH', None)
        import unidyn, bdsim
        sim = bdsim.BDSim(graphics=False, progress=False, banner=False, sysargs=False)
        bd = sim.blockdiagram()
        print(type(bd.FIGUREEIGHT()).__name__)
    """, env={"BDSIMPATH": ""})
    assert r.returncode == 0 and "FigureEight" in r.stdout, r.stdout + r.stderr


@pytest.mark.slow
def test_import_changes_only_bdsimpath_in_this_process(tmp_path):
    """import unidyn leaves sys.path and the temp folder as they were; it adds
    unidyn to BDSIMPATH (documented; an installed unidyn's start-up hook has done so
    already) and nothing else to the environment. The temp
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
        assert changed <= {'BDSIMPATH'}, changed
        assert os.environ['BDSIMPATH'].split(':')[-1] == 'unidyn'
        print('ok')
    """, env={"BDSIMPATH": "", "TMPDIR": str(tmp_path)})
    assert r.returncode == 0 and "ok" in r.stdout, r.stdout + r.stderr


@pytest.mark.slow
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
        import sys, unidyn, unidyn.model.unicycle, unidyn.model.laws, unidyn.model.trajectories, unidyn.model.robots
        import unidyn.model.scenario, unidyn.results.result
        print('bdsim' in sys.modules)
    """)
    assert r.returncode == 0 and r.stdout.strip() == "False", r.stdout + r.stderr


@pytest.mark.slow
def test_import_is_light_and_the_core_is_reached_from_it():
    """``import unidyn`` loads no numpy (so the command's Ctrl-C handling is in place
    at once); what it used to load eagerly is still reached as an attribute."""
    r = _run("""
        import sys, unidyn
        print('numpy' in sys.modules)
        for name in ("model", "laws", "trajectories", "robots", "engine", "results",
                     "equations", "RobotParameters", "Limits", "NoiseSpec", "NO_LIMITS",
                     "PAPER_LIMITS", "ValidationError", *unidyn.__all__):
            getattr(unidyn, name)
        from unidyn import *
        print(unidyn.model.parameters.RobotParameters is RobotParameters, issubclass(
              ValidationError, ValueError), sorted(set(unidyn.__all__) - set(dir(unidyn))))
    """)
    assert r.returncode == 0, r.stdout + r.stderr
    assert r.stdout.split("\n")[:2] == ["False", "True True []"], r.stdout


@pytest.mark.slow
def test_a_run_on_the_batch_engine_loads_no_bdsim():
    """bdsim (and the toolboxes it loads) is for the diagram: ``unidyn run`` on the batch
    engine, its files and figures included, loads none of it."""
    r = _run("""
        import sys, tempfile
        from unidyn.cli import main
        code = main(["run", "--T", "1", "--engine", "batch", "--out", tempfile.mkdtemp() + "/o"])
        print(code, sorted(m for m in ("bdsim", "roboticstoolbox", "spatialmath")
                           if m in sys.modules))
    """)
    assert r.returncode == 0, r.stdout + r.stderr
    assert r.stdout.splitlines()[-1] == "0 []", r.stdout


def build_distributions(dist: Path) -> tuple:
    """The sdist and the wheel of this checkout, built offline into ``dist`` (the wheel
    from the sdist, as pip builds one downloaded): ``(sdist, wheel)``."""
    pytest.importorskip("build")
    r = subprocess.run([sys.executable, "-m", "build", "--no-isolation", "--sdist", "--wheel",
                        "--outdir", str(dist), str(ROOT)], capture_output=True, text=True,
                       timeout=600, cwd=dist.parent)
    assert r.returncode == 0, r.stdout[-3000:] + r.stderr[-3000:]
    return next(dist.glob("unidyn-*.tar.gz")), next(dist.glob("unidyn-*.whl"))


def _fresh_venv(path: Path) -> Path:
    """A new virtual environment whose own site-packages holds nothing but what is
    installed into it; the dependencies come from this interpreter's site-packages,
    added after it by a path line (so its .pth files, such as a development
    install's, are not run), and nothing is fetched."""
    subprocess.run([sys.executable, "-m", "venv", "--without-pip", str(path)], check=True,
                   timeout=120)
    python = path / "bin" / "python"
    purelib = subprocess.run([str(python), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
                             capture_output=True, text=True, check=True).stdout.strip()
    # every site-packages folder this interpreter sees (in a venv of its own, as in
    # tests/test_fresh_clone.py, the dependencies are in an outer one)
    deps = [p for p in sys.path if Path(p).name in ("site-packages", "dist-packages")]
    (Path(purelib) / "zz-unidyn-test-deps.pth").write_text("".join(p + "\n" for p in deps))
    return python


def _pip(python: Path, *args):
    # --ignore-installed: the development install among the dependencies is not this venv's
    r = subprocess.run([str(python), "-m", "pip", "install", "-q", "--no-deps", "--no-index",
                        "--no-build-isolation", "--ignore-installed", *map(str, args)], capture_output=True, text=True,
                       timeout=600, cwd=tempfile.gettempdir())
    assert r.returncode == 0, r.stdout + r.stderr


def _in_venv(python: Path, code: str, *args, cwd=None):
    """A process as a user starts it: no BDSIMPATH, no PYTHONPATH, a folder of its own."""
    env = {k: v for k, v in os.environ.items() if k not in ("BDSIMPATH", "PYTHONPATH")}
    env.update(MPLBACKEND="Agg", QT_QPA_PLATFORM="offscreen")
    with tempfile.TemporaryDirectory(prefix="unidyn-cwd-") as tmp:
        return subprocess.run([str(python), "-c", textwrap.dedent(code), *map(str, args)],
                              capture_output=True, text=True, env=env, cwd=cwd or tmp, timeout=600)


NO_IMPORT = """
    import sys, bdsim
    sim = bdsim.BDSim(graphics=False, progress=False, banner=False, sysargs=False, toolboxes=False)
    print('unidyn' in sys.modules)
    print(type(sim.blockdiagram().DYNAMICUNICYCLE()).__name__)
"""
# the natural notebook order: bdsim first, unidyn later, the same simulator
IMPORT_AFTER = """
    import bdsim
    sim = bdsim.BDSim(graphics=False, progress=False, banner=False, sysargs=False, toolboxes=False)
    import unidyn, unidyn.diagrams
    print(type(sim.blockdiagram().FIGUREEIGHT()).__name__, unidyn.__file__)
"""
# the bdrun and bdedit commands are these two calls (their console scripts)
BDRUN = """
    import sys
    from bdsim.bin.bdrun import bdrun
    sys.argv = ['bdrun', sys.argv[1], '--no-graphics', '--simtime', '0.5', '--no-progress']
    sys.exit(bdrun())
"""
BDEDIT_PALETTE = """
    from PySide6.QtWidgets import QApplication
    from bdedit.block_importer import import_blocks
    app = QApplication(['bdedit'])
    print(sorted(name for group, blocks in import_blocks(None, None) for name, cls in blocks
                 if name.startswith(('DYNAMICUNI', 'FIGUREEIGHT'))))
"""


def _check_install(python: Path, where: Path):
    r = _in_venv(python, NO_IMPORT)
    assert r.returncode == 0 and r.stdout.split() == ["False", "DynamicUnicycle"], r.stdout + r.stderr
    r = _in_venv(python, IMPORT_AFTER)
    assert r.returncode == 0 and r.stdout.split()[0] == "FigureEight", r.stdout + r.stderr
    assert Path(r.stdout.split()[1]).is_relative_to(where), (r.stdout, where)
    r = _in_venv(python, BDRUN, ROOT / "examples" / "bd" / "fig2_case3_compensated.bd")
    assert r.returncode == 0, r.stdout[-2000:] + r.stderr[-2000:]
    assert "not loaded, check BDSIMPATH" not in r.stdout + r.stderr, r.stdout[-2000:]
    r = _in_venv(python, "import PySide6")
    if r.returncode == 0:
        r = _in_venv(python, BDEDIT_PALETTE)
        assert r.returncode == 0, r.stderr[-2000:]
        assert "'DYNAMICUNICYCLE'" in r.stdout and "'FIGUREEIGHT'" in r.stdout, r.stdout


@pytest.mark.slow
def test_editable_install_finds_blocks_in_any_order_with_no_variable(tmp_path):
    """``pip install -e .`` (the README's install) in a fresh venv: blocks are found
    without importing unidyn, with unidyn imported after bdsim's simulator, by
    ``bdrun`` and by ``bdedit``'s palette, with no BDSIMPATH set anywhere."""
    python = _fresh_venv(tmp_path / "venv")
    _pip(python, "-e", ROOT)
    _check_install(python, ROOT / "src")


@pytest.mark.slow
def test_sdist_and_wheel_pass_twine_and_the_wheel_behaves_as_the_editable_install(tmp_path, distributions):
    """The sdist and the wheel build offline and pass ``twine check``; the wheel
    installed into a fresh venv ships the hook and the icons and finds blocks the
    same way as the editable install."""
    pytest.importorskip("twine")
    sdist, wheel = distributions
    r = subprocess.run([sys.executable, "-m", "twine", "check", "--strict", str(sdist), str(wheel)],
                       capture_output=True, text=True, timeout=300)
    assert r.returncode == 0 and r.stdout.count("PASSED") == 2, r.stdout + r.stderr
    python = _fresh_venv(tmp_path / "venv")
    _pip(python, wheel)
    site = Path(_in_venv(python, "import sysconfig; print(sysconfig.get_paths()['purelib'])").stdout.strip())
    assert (site / "unidyn-bdsim.pth").is_file()
    # bdedit's palette icons are package data
    icons = {p.name for p in (ROOT / "src" / "unidyn" / "blocks" / "Icons").glob("*.png")}
    assert icons and icons == {p.name for p in (site / "unidyn" / "blocks" / "Icons").glob("*.png")}
    # the sample data too, found through unidyn.datasets in the installed package (the
    # notebooks, the guides and the docs build read it so, wherever unidyn is installed)
    r = _in_venv(python, "import unidyn.datasets as d; print(*[d.path(n) for n in d.NAMES])")
    shipped = [Path(p) for p in r.stdout.split()]
    data = sorted(p.name for p in (ROOT / "src" / "unidyn" / "datasets").iterdir()
                  if p.is_file() and p.suffix not in (".py", ".pyc"))
    assert sorted(p.name for p in shipped) == data, (r.stdout, data)
    assert all(p.is_file() and site in p.parents for p in shipped), r.stdout
    assert [p.read_bytes() for p in shipped] == [
        (ROOT / "src" / "unidyn" / "datasets" / p.name).read_bytes() for p in shipped]
    _check_install(python, site)


@pytest.mark.slow
def test_unidyn_and_bdsim_run_without_roboticstoolbox():
    """roboticstoolbox-python is the optional extra "toolbox": with it not importable,
    a simulation, a Fig. 2 diagram run by bdsim and a .bd file loaded by bdsim work."""
    r = _run(f"""
        import sys, importlib.abc
        class NoToolbox(importlib.abc.MetaPathFinder):
            def find_spec(self, name, path=None, target=None):
                if name.split('.')[0] in ('roboticstoolbox', 'rtbdata'):
                    raise ModuleNotFoundError(f'No module named {{name!r}}', name=name)
        sys.meta_path.insert(0, NoToolbox())
        import unidyn
        from unidyn.diagrams import build_fig2, new_simulator
        r = unidyn.simulate(unidyn.Scenario.paper(4, T=1))
        sim = new_simulator()
        fig = build_fig2(sim, unidyn.Scenario.paper(3, T=0.5))
        fig.bd.compile()
        sim.run(fig.bd, T=0.5, dt=0.1)
        from bdsim.blockdiagram import bdload
        import warnings
        bd = sim.blockdiagram()
        with warnings.catch_warnings():
            warnings.simplefilter('ignore')
            bdload(bd, {str(ROOT / 'examples' / 'bd' / 'fig2_case4_adaptive.bd')!r})
        print(len(bd.blocklist) >= 8, 'roboticstoolbox' in sys.modules)
    """)
    assert r.returncode == 0, r.stdout[-2000:] + r.stderr[-3000:]
    assert r.stdout.split()[-2:] == ["True", "False"], r.stdout
