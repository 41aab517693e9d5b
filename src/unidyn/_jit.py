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


#: The package's files whose code the compiled functions run: the equations and
#: elementary functions they inline, the overloads here, and the compiled functions.
COMPILED_SOURCES = ("equations.py", "_vecmath.py", "_jit.py", "_kernels.py",
                    "identification/_simulate.py")
_ROOT = Path(__file__).resolve().parent


def sources_stamp() -> str:
    """A short hash of :data:`COMPILED_SOURCES`: the version of the code compiled."""
    h = hashlib.sha256()
    for name in COMPILED_SOURCES:
        try:
            h.update((_ROOT / name).read_bytes())
        except OSError:  # pragma: no cover - a packaging without the file
            h.update(name.encode())
    return h.hexdigest()[:12]


STAMP = sources_stamp()


def _inside_package(path) -> bool:
    try:
        return Path(path).resolve().is_relative_to(_ROOT)
    except (OSError, ValueError):
        return False


if AVAILABLE:
    from numba.core import caching as _caching

    class _StampedLocator:
        """Where numba caches this package's compiled functions: where it would anyway
        (numba's own locators), with :data:`STAMP` in the file names.

        numba keys its on-disk cache (``cache=True``) on the source file of each
        compiled function only, not on the functions it inlines: a kernel in
        ``_kernels.py`` would keep running :mod:`unidyn.equations` as it was when it
        was cached. With the stamp of every file compiled in its name, each version of
        the code has cache files of its own: an edited equation is compiled anew, and
        a process still running the previous version (a notebook started before the
        edit) can write its cache without another process ever loading it."""

        def __init__(self, inner):
            self._inner = inner

        def ensure_cache_path(self):
            self._inner.ensure_cache_path()

        def get_cache_path(self):
            return self._inner.get_cache_path()

        def get_source_stamp(self):
            return self._inner.get_source_stamp()

        def get_disambiguator(self):
            return f"{self._inner.get_disambiguator()}-{STAMP}"

        @classmethod
        def from_function(cls, py_func, py_file):
            if not _inside_package(py_file):
                return None
            for other in _LOCATORS:
                if other is not cls:
                    inner = other.from_function(py_func, py_file)
                    if inner is not None:
                        return cls(inner)
            return None

    # numba's locators, tried in order for each function cached (on CacheImpl;
    # _CacheImpl in older numba); where neither exists, the cache files carry no
    # stamp, and _remove_other_versions removes them all when the code changes
    _IMPL = getattr(_caching, "CacheImpl", getattr(_caching, "_CacheImpl", None))
    _LOCATORS = getattr(_IMPL, "_locator_classes", None)
    if isinstance(_LOCATORS, list) and _StampedLocator not in _LOCATORS:
        _LOCATORS.insert(0, _StampedLocator)


def _remove_other_versions():
    """Remove the in-tree cache files of other versions of the compiled code (each
    edit of :data:`COMPILED_SOURCES` leaves a set), once per version. A process still
    running one of them compiles it again if it needs it."""
    marker = _ROOT / "__pycache__" / "compiled.numba-stamp"
    try:
        if marker.read_text() == STAMP:
            return
    except OSError:
        pass
    try:
        for cached in _ROOT.rglob("__pycache__/*.nb[ic]"):
            if f"-{STAMP}." not in cached.name:
                cached.unlink(missing_ok=True)
        (marker.parent / "equations.numba-stamp").unlink(missing_ok=True)  # the earlier marker
        marker.parent.mkdir(exist_ok=True)
        marker.write_text(STAMP)
    except OSError:  # a read-only install: numba caches elsewhere
        pass


if AVAILABLE:
    _remove_other_versions()


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
