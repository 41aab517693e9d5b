"""numba's on-disk cache never runs equations older than the source, and processes
sharing it never load a half-written one.

numba keys its cache on the file of each compiled function, not on the functions
it inlines; the compiled engine inlines :mod:`unidyn.model.equations`, so the package
caches its compiled functions in a folder per version of the compiled sources
(:data:`unidyn.compiled.STAMP`), which numba is pointed at through its documented
``NUMBA_CACHE_DIR``. The tests edit Eq. (2) in a copy of the package, between real
processes, and check that a compiled function follows the edit (and agrees with the
same code run by Python on the edited equations); they fail loudly if numba stops
writing the package's cache where it is told to. The function is the log simulator of
identification, which inlines Eq. (2) as the engine's kernels do and is declared
through the same :func:`unidyn.compiled.jit`: it compiles in seconds, the kernels in
tens of seconds.
"""

import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

import pytest

from unidyn import compiled as _jit

pytestmark = pytest.mark.skipif(not _jit.AVAILABLE, reason="needs numba (the cache is numba's)")

SRC = Path(__file__).resolve().parents[2] / "src" / "unidyn"
HELD = """
import sys
import numpy as np
from unidyn.compiled import plain_copy
from unidyn.identification import replay
# argv[1] "plain": the same code run by Python (nothing compiled)
simulate_held = (plain_copy(replay) if sys.argv[1:] == ["plain"] else replay).simulate_held
t = np.arange(0.0, 2.0, 0.1)
v = simulate_held([0.24, 0.23, 0.0003, 0.97, 0.003, 1.07], t, np.full(t.size, 0.3),
                  np.zeros(t.size), [(0, t.size)], [[0.0, 0.0]])
print(v[-1, 0])
"""


def _env(root, cache):
    return dict(os.environ, PYTHONPATH=str(root), MPLBACKEND="Agg", NUMBA_CACHE_DIR=str(cache))


def _run(root, cache, code, *args):
    out = subprocess.run([sys.executable, "-c", code, *args], env=_env(root, cache), cwd=root,
                         capture_output=True, text=True, timeout=600)
    assert out.returncode == 0, out.stderr
    return float(out.stdout.split()[-1])


def _versions(cache):
    root = Path(cache) / "unidyn-numba"
    return {f.name: {p.name for p in f.rglob("*.nb[ic]")} for f in root.iterdir() if f.is_dir()}


@pytest.mark.slow
def test_the_cache_is_written_in_the_version_folder_numba_is_told(tmp_path):
    """If numba stops reading NUMBA_CACHE_DIR when a function is declared (how the
    package points it at its version folder, at an entry point's first call), this
    fails."""
    value = _run(SRC.parent, tmp_path, HELD)
    assert 0.0 < value < 0.31
    files = _versions(tmp_path)
    assert set(files) == {_jit.STAMP}
    assert any(name.endswith(".nbi") for name in files[_jit.STAMP]), files
    assert _run(SRC.parent, tmp_path, HELD) == value  # loaded from it: the same bits


IMPORT_ONLY = """
import unidyn, unidyn.identification
from unidyn.engine import batch, kernels
print(0.0)
"""


@pytest.mark.slow
def test_importing_the_package_writes_nothing_to_the_cache(tmp_path):
    """The cache folder is set up at the first compile, not when the package (with the
    kernels and the log simulator, whose functions are declared then) is imported."""
    _run(SRC.parent, tmp_path, IMPORT_ONLY)
    assert list(tmp_path.iterdir()) == []
    _run(SRC.parent, tmp_path, HELD)  # a compile makes it
    assert set(_versions(tmp_path)) == {_jit.STAMP}


def _edit_eq2(pkg):
    eqs = pkg / "model" / "equations.py"
    text = eqs.read_text()
    edited = text.replace("(th3 * w * w - th4 * u + u_ref) / th1",
                          "(th3 * w * w - th4 * u + 0.5 * u_ref) / th1")
    assert edited != text
    eqs.write_text(edited)


@pytest.mark.slow
def test_an_edited_equation_is_compiled_anew(tmp_path):
    pkg = tmp_path / "unidyn"
    cache = tmp_path / "cache"
    shutil.copytree(SRC, pkg, ignore=shutil.ignore_patterns("__pycache__"))
    before = _run(tmp_path, cache, HELD)
    assert _run(tmp_path, cache, HELD) == before  # from the cache, the same bits
    old = _versions(cache)
    assert len(old) == 1 and any(n.endswith(".nbi") for n in next(iter(old.values())))
    _edit_eq2(pkg)
    after = _run(tmp_path, cache, HELD)
    assert after != before
    assert after == pytest.approx(_run(tmp_path, cache, HELD, "plain"), rel=1e-9)
    assert len(_versions(cache)) == 2  # a folder of its own
    # the old version, back (a git checkout), runs from its own files again
    (pkg / "model" / "equations.py").write_text((SRC / "model" / "equations.py").read_text())
    assert _run(tmp_path, cache, HELD) == before


def test_the_cache_keeps_the_current_version_and_the_two_used_last(tmp_path):
    now = time.time()
    for k in range(1, 6):  # ages 100 s ... 500 s
        folder = tmp_path / f"{k:012x}"
        folder.mkdir()
        (folder / "f.nbi").write_bytes(b"x")
        os.utime(folder, (now - 100.0 * k, now - 100.0 * k))
    current = tmp_path / _jit.STAMP
    current.mkdir()
    os.utime(current, (now - 1000.0, now - 1000.0))  # the oldest, but current
    _jit.remove_other_versions(tmp_path, keep=3)
    assert {p.name for p in tmp_path.iterdir()} == {_jit.STAMP, f"{1:012x}", f"{2:012x}"}


@pytest.mark.slow
def test_a_process_waits_while_another_compiles_into_the_same_cache(tmp_path):
    """numba writes its cache without a lock between processes; the package's compiled
    entry points load or compile under one (unidyn.compiled.Compiled), so processes that
    start together (xdist workers, a Dask cluster) never load a mix of files each
    wrote. Here the test holds the lock of a fresh cache folder: a process that needs
    a compiled function waits until it is released."""
    from filelock import FileLock
    folder = tmp_path / "unidyn-numba" / _jit.STAMP
    folder.mkdir(parents=True)
    with FileLock(str(folder / "compile.lock")):
        proc = subprocess.Popen([sys.executable, "-c", HELD], env=_env(SRC.parent, tmp_path),
                                stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        try:
            time.sleep(8.0)  # an import and a compile of the held-command RK4 take seconds
            assert proc.poll() is None, proc.communicate()
            assert not list(folder.rglob("*.nbi"))  # nothing written meanwhile
        except BaseException:
            proc.kill()
            raise
    out, err = proc.communicate(timeout=600)
    assert proc.returncode == 0, err
    assert 0.0 < float(out.split()[-1]) < 0.31


def _stderr_on_a_terminal(cache):
    """HELD run with its stderr on a pseudo-terminal: what it writes there."""
    import pty
    main, child = pty.openpty()
    proc = subprocess.Popen([sys.executable, "-c", HELD], env=_env(SRC.parent, cache),
                            stdout=subprocess.PIPE, stderr=child, text=True)
    os.close(child)
    out, _ = proc.communicate(timeout=600)
    said = b""
    while True:
        try:
            chunk = os.read(main, 4096)
        except OSError:  # the terminal's other side closed
            break
        if not chunk:
            break
        said += chunk
    os.close(main)
    assert proc.returncode == 0
    return said.decode(errors="replace")


@pytest.mark.slow
def test_a_compile_says_so_on_the_terminal_once_per_install(tmp_path):
    first = _stderr_on_a_terminal(tmp_path)
    assert "compiling the log simulator of identification, once per install" in first, first
    assert "compiling" not in _stderr_on_a_terminal(tmp_path)  # loaded from the cache


USER_RHS = """
import sys
import numpy as np
sys.path.insert(0, sys.argv[1])
import user_rhs  # a right-hand side of the user's own, in a module only this process sees
from unidyn.engine.kernels import dp_step, work_arrays
work = work_arrays(1, 0)
work.K[0, 0] = -2.0  # K[0]: f(0, 1) = -2
dp_step(user_rhs.compiled, 0.0, np.ones(1), 0.1, 2.0, work, 1e-6, 1e-8)
print(round(work.K[1, 0], 12))  # f at x = 1 + 0.02 * (-2)
"""


@pytest.mark.slow
def test_the_step_of_a_users_own_right_hand_side_leaves_the_shared_cache_readable(tmp_path):
    """The engine's Dormand-Prince step takes any compiled right-hand side. numba's cache
    index records a signature's types by their module: had dp_step cached the user's
    function in it, every process without that module would fail to read the index, and
    the engine and identification would stop with ModuleNotFoundError."""
    user = tmp_path / "user"
    user.mkdir()
    # compiled apart from its Python function, which numba's cache then records by name
    (user / "user_rhs.py").write_text("import numba\n\n\ndef decay(t, x, a, mode, out, margins):\n"
                                      "    out[0] = -a * x[0]\n\n\ncompiled = numba.njit(decay)\n")
    assert _run(SRC.parent, tmp_path, USER_RHS, str(user)) == -1.92
    assert 0.0 < _run(SRC.parent, tmp_path, HELD) < 0.31
