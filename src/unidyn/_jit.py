"""numba, where installed: :func:`jit` of a function that calls the paper's
equations (:mod:`unidyn.equations`), and the same function as plain Python where
numba is absent (``pip install unidyn[fast]`` for the compiled one).

Every public function of :mod:`unidyn.equations` is registered with numba's
``register_jitable`` (inlined into its callers): it stays the plain function for
Python callers and becomes compilable inside compiled code, so the engines compile
the equations the rest of the library runs, not a copy of them.
"""

from __future__ import annotations

import hashlib
from pathlib import Path

from . import equations

try:  # numba is optional
    import numba
    from numba.extending import register_jitable
    AVAILABLE = True
except ImportError:  # pragma: no cover - exercised where numba is absent
    numba = None
    AVAILABLE = False

if AVAILABLE:
    import numpy as np
    from numba.core import types
    from numba.extending import overload

    from . import _vecmath

    _OVERLOADED = (equations.select, equations.sin, equations.cos, equations.tanh)
    # called, not inlined: a whole loop evaluation that a caller makes several times
    # (inlined, each copy costs numba's compiler seconds)
    _CALLED = (equations.loop_acceleration, equations.loop_step_rate)
    for _name in equations.__all__:
        _f = getattr(equations, _name)
        if (callable(_f) and getattr(_f, "__module__", None) == equations.__name__
                and _f not in _OVERLOADED):
            register_jitable(inline="never" if _f in _CALLED else "always")(_f)

    def _elementary(function, vectorisable, ufunc):
        """Compile function (equations.sin, ...) of a float64 as the vectorisable
        intrinsic, of anything else (an array, a float32) as numpy's ufunc."""
        @overload(function, inline="always")
        def _compiled(x):
            if x == types.float64:
                return lambda x: vectorisable(x)
            return lambda x: ufunc(x)

    _elementary(equations.sin, _vecmath.sin, np.sin)
    _elementary(equations.cos, _vecmath.cos, np.cos)
    _elementary(equations.tanh, _vecmath.tanh, np.tanh)

    @overload(equations.select)
    def _select(condition, a, b):
        """equations.select compiled: a branch on scalars (np.where would allocate a 0-d
        array per call), np.where on arrays."""
        if (isinstance(condition, types.Boolean) and isinstance(a, types.Number)
                and isinstance(b, types.Number)):
            return lambda condition, a, b: a if condition else b
        return lambda condition, a, b: np.where(condition, a, b)


def _invalidate_stale_cache():
    """Drop numba's cached machine code of this package when the equations changed.

    numba's on-disk cache (``cache=True``) is keyed on the source file of each
    compiled function only, not on the functions it calls: a kernel in
    ``_kernels.py`` would keep running the equations as they were when it was
    cached after :mod:`unidyn.equations` was edited. A stamp of the equations'
    source beside the cache files tells; when it differs, the package's cache files
    are removed and compiled anew. (An installed release changes every file, and
    with them numba's own stamps.)"""
    root = Path(__file__).resolve().parent
    stamp = hashlib.sha256(b"".join(Path(f).read_bytes() for f in (
        equations.__file__, __file__, Path(__file__).with_name("_vecmath.py")))).hexdigest()
    marker = root / "__pycache__" / "equations.numba-stamp"
    try:
        if marker.read_text() == stamp:
            return
    except OSError:
        pass
    try:
        for cached in root.rglob("__pycache__/*.nb[ic]"):
            cached.unlink(missing_ok=True)
        marker.parent.mkdir(exist_ok=True)
        marker.write_text(stamp)
    except OSError:  # a read-only install: numba caches elsewhere, keyed on its files
        pass


if AVAILABLE:
    _invalidate_stale_cache()


def jit(f=None, *, parallel: bool = False, inline: bool = False):
    """``numba.njit(cache=True, nogil=True)`` of f; f itself without numba.

    ``parallel=True``: numba's threads over ``numba.prange``; ``inline=True``: f is
    inlined into its compiled callers (as the equations are), which saves a call
    with reference counting of its array arguments at every right-hand side.
    Division by zero gives inf or NaN as in numpy (``error_model="numpy"``), which the
    engines' checks for non-finite states then report."""
    def wrap(g):
        if not AVAILABLE:
            return g
        return numba.njit(cache=True, nogil=True, parallel=parallel, error_model="numpy",
                          inline="always" if inline else "never")(g)
    return wrap if f is None else wrap(f)


#: numba.prange where numba is installed, else range.
prange = numba.prange if AVAILABLE else range
