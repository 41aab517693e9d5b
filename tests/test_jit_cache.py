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

pytestmark = [pytest.mark.slow,
              pytest.mark.skipif(not _jit.AVAILABLE, reason="needs numba (the cache is numba's)")]

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
    new = _cache_files(pkg)
    # a process still running the old version writes its cache now (as a notebook
    # started before the edit would): the new version does not load it
    for path, data in old.items():
        path.write_bytes(data)
    assert _iae(tmp_path, "numba") == after
    assert not set(old) & set(new)   # each version has files of its own
