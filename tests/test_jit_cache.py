"""numba's on-disk cache never runs equations older than the source.

numba keys its cache on the file of each compiled function, not on the functions
it calls; the compiled engine inlines :mod:`unidyn.equations`, so without the
stamp of the compiled sources in the cache's file names
(:class:`unidyn._jit._StampedLocator`) an edited equation would keep running as it
was cached. The tests edit Eq. (2) in a copy of the package, between real
processes, and check that the compiled engine follows the edit (and agrees with the
numpy engine on the edited equations), also when a process of the previous version
writes its cache after the edit.
"""

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from unidyn import _jit

pytestmark = pytest.mark.skipif(not _jit.AVAILABLE, reason="needs numba (the cache is numba's)")

SRC = Path(__file__).resolve().parent.parent / "src" / "unidyn"
PROBE = """
import sys
from unidyn import Scenario
from unidyn.batch import simulate_batch
sc = Scenario.paper(4, T=3.0, noise=None)
print(simulate_batch([sc], backend=sys.argv[1], progress=False)[0].metrics["iae"])
"""


def _iae(root, backend):
    env = dict(os.environ, PYTHONPATH=str(root), MPLBACKEND="Agg")
    out = subprocess.run([sys.executable, "-c", PROBE, backend], env=env, cwd=root,
                         capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr
    return float(out.stdout.split()[-1])


def _edit_eq2(pkg):
    eqs = pkg / "equations.py"
    text = eqs.read_text()
    edited = text.replace("(th3 * w * w - th4 * u + u_ref) / th1",
                          "(th3 * w * w - th4 * u + 0.5 * u_ref) / th1")
    assert edited != text
    eqs.write_text(edited)


def _cache_files(pkg):
    return {p: p.read_bytes() for p in pkg.rglob("__pycache__/*.nb[ic]")}


@pytest.mark.slow
def test_an_edited_equation_is_compiled_anew(tmp_path):
    pkg = tmp_path / "unidyn"
    shutil.copytree(SRC, pkg, ignore=shutil.ignore_patterns("__pycache__"))
    before = _iae(tmp_path, "numba")
    assert _iae(tmp_path, "numba") == before  # from the cache, the same bits
    old = _cache_files(pkg)
    assert [p for p in old if p.suffix == ".nbi"], "numba wrote no cache; the test proves nothing"
    _edit_eq2(pkg)
    after = _iae(tmp_path, "numba")
    assert after != before
    assert after == pytest.approx(_iae(tmp_path, "numpy"), rel=1e-9)
    new = set(_cache_files(pkg)) - set(old)
    assert new and {p.suffix for p in new} == {".nbi", ".nbc"}  # files of its own
    # a process still running the old version writes its cache now (as a notebook
    # started before the edit would): the new version does not load it
    for path, data in old.items():
        path.write_bytes(data)
    assert _iae(tmp_path, "numba") == after
    # and the old version, back (a git checkout), runs from its own files again
    (pkg / "equations.py").write_text((SRC / "equations.py").read_text())
    assert _iae(tmp_path, "numba") == before


def _fake_cache(folder, stamp, age, now):
    files = [folder / f"_kernels.run_groups-539-{stamp}.py311.nbi",
             folder / f"_kernels.run_groups-539-{stamp}.py311.1.nbc"]
    for f in files:
        f.write_bytes(b"x")
        os.utime(f, (now - age, now - age))
    return files


def test_the_cache_keeps_the_current_version_and_the_two_used_last(tmp_path):
    import time
    now = time.time()
    versions = {f"{k:012x}": 100.0 * k for k in range(1, 6)}  # ages: 100 s ... 500 s
    files = {v: _fake_cache(tmp_path, v, age, now) for v, age in versions.items()}
    current = _fake_cache(tmp_path, _jit.STAMP, 1000.0, now)   # the oldest files, but current
    unstamped = tmp_path / "_kernels.run_groups-539.py311.1.nbc"  # written by numba's own locator
    unstamped.write_bytes(b"x")
    other = tmp_path / "something.else"
    other.write_bytes(b"x")
    _jit._remove_other_versions(tmp_path, keep=3)
    left = {p.name for p in tmp_path.iterdir()}
    expect = {p.name for p in current + files[f"{1:012x}"] + files[f"{2:012x}"]}
    assert left == expect | {"something.else", "unidyn.numba-stamp"}
    # once per version: files of a version written later are not looked at again
    late = _fake_cache(tmp_path, f"{9:012x}", 5000.0, now)
    _jit._remove_other_versions(tmp_path, keep=3)
    assert all(p.exists() for p in late)


def test_a_package_function_numba_cannot_cache_is_warned_about_not_fatal(tmp_path, monkeypatch):
    """numba reads its locator's _py_file to say why a function cannot be cached (here:
    it calls a C function through ctypes, an address fixed in this process only)."""
    import importlib.util
    import warnings

    from numba.core.errors import NumbaWarning
    src = tmp_path / "uncachable.py"
    src.write_text(
        "import ctypes, ctypes.util, numba\n"
        "libm = ctypes.CDLL(ctypes.util.find_library('m'))\n"
        "cos = libm.cos\n"
        "cos.restype = ctypes.c_double\n"
        "cos.argtypes = (ctypes.c_double,)\n"
        "@numba.njit(cache=True)\n"
        "def f(x):\n"
        "    return cos(x)\n")
    monkeypatch.setattr(_jit, "_ROOT", tmp_path)  # as if the file were in the package
    spec = importlib.util.spec_from_file_location("uncachable", src)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    assert isinstance(module.f._cache._impl.locator, _jit._StampedLocator)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        assert module.f(0.0) == 1.0
    assert any(issubclass(w.category, NumbaWarning) and "cannot cache" in str(w.message).lower()
               for w in caught)


def test_a_process_waits_while_another_compiles_into_the_same_cache(tmp_path):
    """numba writes its cache without a lock between processes; unidyn's compiled
    functions load, compile and cache under one (unidyn._jit.compiling), so processes
    that start together (xdist workers, a Dask cluster) never load a mix of files each
    wrote. Here the test holds the lock of a fresh copy's cache folder: a process that
    needs a compiled function of that copy waits until it is released."""
    import time
    pkg = tmp_path / "unidyn"
    shutil.copytree(SRC, pkg, ignore=shutil.ignore_patterns("__pycache__"))
    (pkg / "__pycache__").mkdir()
    env = dict(os.environ, PYTHONPATH=str(tmp_path), MPLBACKEND="Agg")
    code = "from unidyn import _kernels; print(_kernels.log_index(10, 100, 3, True))"
    with _jit.compiling(str(pkg / "__pycache__")):
        proc = subprocess.Popen([sys.executable, "-c", code], env=env, cwd=tmp_path,
                                stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        try:
            time.sleep(8.0)  # an import and a compile of log_index take about 3 s
            assert proc.poll() is None, proc.communicate()
        except BaseException:
            proc.kill()
            raise
    out, err = proc.communicate(timeout=300)
    assert proc.returncode == 0, err
    assert out.split() == ["4"]   # sample 10, every 3rd logged, stopped there: row 10 // 3 + 1
