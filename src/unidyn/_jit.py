"""numba, where installed: :func:`jit` of a function that calls the paper's
equations (:mod:`unidyn.equations`), and the same function as plain Python where
numba is absent (``pip install unidyn[fast]`` for the compiled one).

Every public function of :mod:`unidyn.equations` is registered with numba's
``register_jitable`` (inlined into its callers): it stays the plain function for
Python callers and becomes compilable inside compiled code, so the engines compile
the equations the rest of the library runs, not a copy of them.
"""

from __future__ import annotations

import contextlib
import hashlib
import os
import re
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
#: Versions of the compiled code whose cache files are kept (switching between a few
#: versions, as between git branches, compiles none of them again).
KEEP_VERSIONS = 3
_ROOT = Path(__file__).resolve().parent


def sources_stamp() -> str:
    """A short hash of :data:`COMPILED_SOURCES`: the version of the code compiled
    (read through the package's loader, so a zipped install has one too)."""
    from importlib.resources import files
    h = hashlib.sha256()
    for name in COMPILED_SOURCES:
        h.update(files(__package__).joinpath(name).read_bytes())
    return h.hexdigest()[:12]


STAMP = sources_stamp()


def _inside_package(path) -> bool:
    try:
        return Path(path).resolve().is_relative_to(_ROOT)
    except (OSError, ValueError, RuntimeError):  # RuntimeError: a symlink loop
        return False


def _remove_other_versions(folder, keep: int = KEEP_VERSIONS):
    """Remove this package's numba cache files in ``folder`` (one cache folder of its
    source folders) but those of the current version and of the keep - 1 versions
    used most recently, once per version and folder. A process still running a
    version whose files are gone compiles it again if it needs it."""
    folder = Path(folder)
    marker = folder / "unidyn.numba-stamp"
    try:
        if marker.read_text() == STAMP:
            return
    except OSError:
        pass
    versions = {}  # stamp -> (newest modification time, files)
    for cached in list(folder.glob("*.nb[ic]")):
        found = re.search(r"-([0-9a-f]{12})\.py\d", cached.name)
        stamp = found.group(1) if found else None  # None: a file without a stamp
        try:
            mtime = cached.stat().st_mtime
        except OSError:
            continue
        newest, group = versions.get(stamp, (0.0, []))
        versions[stamp] = (max(newest, mtime), group + [cached])
    kept = {STAMP} | set(sorted((v for v in versions if v not in (STAMP, None)),
                                key=lambda v: versions[v][0], reverse=True)[:keep - 1])
    for stamp, (_, group) in versions.items():
        if stamp not in kept:
            for cached in group:
                try:
                    cached.unlink(missing_ok=True)
                except OSError:  # in use (Windows), or read-only
                    pass
    try:
        (folder / "equations.numba-stamp").unlink(missing_ok=True)  # the earlier marker
        marker.write_text(STAMP)
    except OSError:
        pass


if AVAILABLE:
    from numba.core import caching as _caching

    class _StampedLocator:
        """Where numba caches this package's compiled functions: where it would anyway
        (numba's own locators: beside the source, or under ``NUMBA_CACHE_DIR`` or the
        user's cache folder where the source is read-only), with :data:`STAMP` in the
        file names.

        numba keys its on-disk cache (``cache=True``) on the source file of each
        compiled function only, not on the functions it inlines: a kernel in
        ``_kernels.py`` would keep running :mod:`unidyn.equations` as it was when it
        was cached. With the stamp of every file compiled in its name, each version of
        the code has cache files of its own: an edited equation is compiled anew, and
        a process still running the previous version (a notebook started before the
        edit) can write its cache without another process ever loading it. The files
        of older versions are removed (:func:`_remove_other_versions`).

        (``NUMBA_CACHE_LOCATOR_CLASSES``, where a numba has it, replaces numba's list
        of locators, this one included.)"""

        _cleaned: set = set()

        def __init__(self, inner):
            self._inner = inner
            path = inner.get_cache_path()
            if path not in self._cleaned:
                self._cleaned.add(path)
                _remove_other_versions(path)

        def __getattr__(self, name):  # what numba reads of its own locators (_py_file)
            if name == "_inner":
                raise AttributeError(name)
            return getattr(self._inner, name)

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
    # _CacheImpl in older numba)
    _IMPL = getattr(_caching, "CacheImpl", getattr(_caching, "_CacheImpl", None))
    _LOCATORS = getattr(_IMPL, "_locator_classes", None)
    if isinstance(_LOCATORS, list):
        if _StampedLocator not in _LOCATORS:
            _LOCATORS.insert(0, _StampedLocator)
    else:  # no stamp in the names: the package's cache files go when the code changes
        for _folder in (_ROOT / "__pycache__", _ROOT / "identification" / "__pycache__"):
            _remove_other_versions(_folder, keep=1)


_HELD = {}  # lock file -> [open file or None, depth]: the locks this process holds


def _lock(path):
    """An open file of ``path`` locked exclusively (waiting for another process that
    holds it), or ``None`` where files cannot be locked here."""
    try:
        f = open(path, "a+b")
    except OSError:  # a read-only cache folder: numba cannot write there either
        return None
    try:
        import fcntl
        fcntl.flock(f.fileno(), fcntl.LOCK_EX)
        return f
    except ImportError:  # pragma: no cover - Windows
        pass
    try:  # pragma: no cover - Windows
        import msvcrt
        while True:
            try:
                msvcrt.locking(f.fileno(), msvcrt.LK_LOCK, 1)  # retries for 10 s
                return f
            except OSError:
                continue
    except ImportError:  # pragma: no cover
        f.close()
        return None


def _unlock(f):
    if f is None:
        return
    try:
        import fcntl
        fcntl.flock(f.fileno(), fcntl.LOCK_UN)
    except ImportError:  # pragma: no cover - Windows
        import msvcrt
        f.seek(0)
        msvcrt.locking(f.fileno(), msvcrt.LK_UNLCK, 1)
    f.close()


@contextlib.contextmanager
def compiling(folder):
    """Hold numba's compiler lock and, against other processes, a lock on
    ``unidyn.compile.lock`` in the cache folder ``folder`` (re-entrant: a kernel's
    compilation compiles the functions it calls).

    numba writes its cache without a lock between processes: two processes that
    compile the same functions at once (pytest-xdist workers, a Dask cluster, two
    notebooks after an install) each write some of the files, and a process that
    then loads files of both can crash (numba issues #4807 and #10128). Under this
    lock one process loads or compiles and caches at a time; the others wait and load
    what it wrote."""
    from numba.core.compiler_lock import global_compiler_lock
    path = os.path.join(folder, "unidyn.compile.lock")
    with global_compiler_lock:  # first: a thread waiting for it holds no file lock
        held = _HELD.setdefault(path, [None, 0])
        if held[1] == 0:
            held[0] = _lock(path)
        held[1] += 1
        try:
            yield
        finally:
            held[1] -= 1
            if held[1] == 0:
                _unlock(held[0])
                del _HELD[path]


def _compile_locked(dispatcher):
    """The dispatcher, its loading or compiling of a new signature under
    :func:`compiling`."""
    folder = getattr(getattr(dispatcher, "_cache", None), "_cache_path", None)
    if folder is None:  # not cached
        return dispatcher
    compile_ = dispatcher.compile

    def compile(sig):
        with compiling(folder):
            return compile_(sig)

    compile.__doc__ = compile_.__doc__
    dispatcher.compile = compile
    return dispatcher


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
        return _compile_locked(numba.njit(cache=True, nogil=True, parallel=parallel,
                                          error_model="numpy",
                                          inline="always" if inline else "never")(g))
    return wrap if f is None else wrap(f)


#: numba.prange where numba is installed, else range.
prange = numba.prange if AVAILABLE else range
