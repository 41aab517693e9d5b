"""numba, where installed: :func:`jit` of a function that calls the paper's
equations (:mod:`unidyn.equations`), and the same function as plain Python where
numba is absent (``pip install unidyn[fast]`` for the compiled one).

Every public function of :mod:`unidyn.equations` is registered with numba's
``register_jitable``: it stays the plain function for Python callers and becomes
compilable inside compiled code, so the engines compile the equations the rest of
the library runs, not a copy of them.
"""

from __future__ import annotations

from . import equations

try:  # numba is optional
    import numba
    from numba.extending import register_jitable
    AVAILABLE = True
except ImportError:  # pragma: no cover - exercised where numba is absent
    numba = None
    AVAILABLE = False

if AVAILABLE:
    for _name in equations.__all__:
        _f = getattr(equations, _name)
        if callable(_f) and getattr(_f, "__module__", None) == equations.__name__:
            register_jitable(_f)


def jit(f=None, *, parallel: bool = False):
    """``numba.njit(cache=True, nogil=True)`` of f (``parallel=True``: numba's
    threads over ``numba.prange``); f itself without numba."""
    def wrap(g):
        if not AVAILABLE:
            return g
        return numba.njit(cache=True, nogil=True, parallel=parallel)(g)
    return wrap if f is None else wrap(f)


#: numba.prange where numba is installed, else range.
prange = numba.prange if AVAILABLE else range
