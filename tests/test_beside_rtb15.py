"""unidyn's bdsim routes beside roboticstoolbox-python 1.5.0, in a venv of its own.

rtb 1.5.0's block docstrings have ``:param`` lines without ``:type``, and bdsim 1.4's
block loader then raises ``KeyError: 'type'`` inside every ``bdsim.BDSim()`` that loads
the toolboxes' blocks. The venv holds rtb 1.5.0 and no other release of it, beside
unidyn's own dependencies (read from pyproject.toml) and the checkout's ``src/``.

rtb is installed without its dependencies (robot models and meshes: about 500 MB and
90 s): bdsim's loader reads the source of ``roboticstoolbox/blocks/*.py`` without
importing it, and unidyn's diagrams import nothing of rtb, so a route that did
would fail here for the missing ones rather than pass. The wheels are downloaded
once into the user's cache folder; from there the venv takes about 10 s.
"""

import ast
import hashlib
import os
import subprocess
import sys
import tempfile
import textwrap
from pathlib import Path

import pytest

try:
    import tomllib
except ImportError:  # Python 3.10
    import tomli as tomllib

ROOT = Path(__file__).resolve().parents[1]
RTB = "roboticstoolbox-python==1.5.0"


def _pip(*args, python=None):
    target = [] if python is None else ["--python", str(python)]
    r = subprocess.run([sys.executable, "-m", "pip", *target, *map(str, args)],
                       capture_output=True, text=True, timeout=900, cwd=tempfile.gettempdir())
    assert r.returncode == 0, r.stdout + r.stderr


def _wheelhouse(deps):
    """rtb 1.5.0 and unidyn's dependencies as wheels for this Python, downloaded once."""
    key = hashlib.sha256(repr((RTB, deps, sys.version_info[:2])).encode()).hexdigest()[:12]
    cache = Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache")
    folder = cache / "unidyn-tests" / f"beside-rtb15-{key}"
    if not folder.is_dir():
        part = folder.with_name(f"{folder.name}.{os.getpid()}.part")
        _pip("download", "-q", "-d", part, *deps)
        _pip("download", "-q", "--no-deps", "-d", part, RTB)
        try:
            part.rename(folder)   # whole or not at all
        except OSError:           # another process got there first
            pass
    return folder


def _in_venv(python, code, cwd):
    env = {k: v for k, v in os.environ.items() if k not in ("BDSIMPATH", "PYTHONPATH")}
    env.update(MPLBACKEND="Agg", PYTHONPATH=str(ROOT / "src"))
    return subprocess.run([str(python), "-c", textwrap.dedent(code)], capture_output=True,
                          text=True, env=env, cwd=cwd, timeout=600)


@pytest.mark.slow
def test_unidyn_bdsim_routes_work_beside_roboticstoolbox_1_5(tmp_path):
    deps = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["dependencies"]
    wheels = _wheelhouse(deps)
    subprocess.run([sys.executable, "-m", "venv", "--without-pip", str(tmp_path / "venv")],
                   check=True, timeout=120)
    python = tmp_path / "venv" / "bin" / "python"
    install = ["install", "-q", "--no-compile", "--no-index", "--find-links", wheels]
    _pip(*install, "--no-deps", RTB, python=python)
    _pip(*install, *deps, python=python)
    r = _in_venv(python, """
        import importlib.metadata, subprocess, sys, warnings
        import bdsim
        print(importlib.metadata.version("roboticstoolbox-python"))
        try:                       # a user's own simulator: the crash as it comes
            bdsim.BDSim(graphics=False, progress=False, banner=False, sysargs=False)
        except KeyError as err:
            print("BDSim():", repr(err))
        import unidyn
        from unidyn.diagrams import ToolboxWarning, new_simulator
        try:
            new_simulator(toolboxes=True)
        except RuntimeError as err:
            print("new_simulator(toolboxes=True):", err)
        with warnings.catch_warnings(record=True) as seen:
            warnings.simplefilter("always")
            res = unidyn.run(unidyn.Scenario.paper(2).replace(T=0.5), engine="bdsim")
        print("run:", res.engine, res.complete, len(res.t),
              [str(w.message) for w in seen if w.category is ToolboxWarning])
        print("imported:", "roboticstoolbox" in sys.modules)
        cli = subprocess.run([sys.executable, "-m", "unidyn", "run", "--paper", "2", "--T", "0.5",
                              "--engine", "bdsim", "--out", "out"], capture_output=True, text=True)
        print("cli:", cli.returncode, cli.stderr.strip().splitlines())
    """, cwd=tmp_path)
    assert r.returncode == 0, r.stdout + r.stderr
    from unidyn.diagrams import TOOLBOX_CRASH
    lines = r.stdout.splitlines()
    assert lines[0] == "1.5.0"
    assert lines[1] == "BDSim(): KeyError('type')", r.stdout
    assert lines[2] == f"new_simulator(toolboxes=True): {TOOLBOX_CRASH}"
    assert lines[3].startswith("run: bdsim True 6 [") and TOOLBOX_CRASH in lines[3], lines[3]
    assert lines[4] == "imported: False"
    assert lines[5].startswith("cli: 0 ") and TOOLBOX_CRASH in lines[5], lines[5] + r.stderr
    stderr_lines = ast.literal_eval(lines[5][len("cli: 0 "):])
    assert stderr_lines == [f"unidyn: warning: {TOOLBOX_CRASH}; this process's bdsim "
                            f"simulators now have bdsim's and unidyn's blocks only"]
    assert (tmp_path / "out" / "summary.json").is_file()
