"""numba's on-disk cache never runs equations older than the source.

numba keys its cache on the file of each compiled function, not on the functions
it calls; the compiled engine inlines :mod:`unidyn.equations`, so without
:func:`unidyn._jit._invalidate_stale_cache` an edited equation would keep running
as it was cached. The test edits Eq. (2) in a copy of the package, between two
real processes, and checks that the compiled engine follows the edit (and agrees
with the numpy engine on the edited equations).
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


def test_an_edited_equation_is_compiled_anew(tmp_path):
    pkg = tmp_path / "unidyn"
    shutil.copytree(SRC, pkg, ignore=shutil.ignore_patterns("__pycache__"))
    before = _iae(tmp_path, "numba")
    assert _iae(tmp_path, "numba") == before  # from the cache, the same bits
    assert list(pkg.rglob("*.nbi")), "numba wrote no cache; the test would prove nothing"
    eqs = pkg / "equations.py"
    text = eqs.read_text()
    edited = text.replace("(th3 * w * w - th4 * u + u_ref) / th1",
                          "(th3 * w * w - th4 * u + 0.5 * u_ref) / th1")
    assert edited != text
    eqs.write_text(edited)
    after = _iae(tmp_path, "numba")
    assert after != before
    assert after == pytest.approx(_iae(tmp_path, "numpy"), rel=1e-9)
