"""numba, where installed: :func:`jit` compiles a function that calls the paper's
equations (:mod:`unidyn.model.equations`), the metrics' rules (:mod:`unidyn.model.metrics`)
or the log's (:mod:`unidyn.model.log`), each registered with numba's
``register_jitable`` and inlined by LLVM: the engines compile what the rest of the
library runs; without numba, or in :func:`plain_copy`, it runs as plain Python.

numba keys its on-disk cache on a function's own file, not on the files it inlines
(a documented limitation), so the package caches in a folder per version of the
compiled sources (:data:`STAMP`), ``<cache>/unidyn-numba/<STAMP>``. Nothing is written
at import: an entry point (:class:`Compiled`) sets the folder up at its first call and
declares its function there, pointing numba at it through ``NUMBA_CACHE_DIR``. numba
writes its cache without a lock between processes (numba issues #4807, #10128), so that
first call holds a ``filelock`` lock of the folder.
"""

from __future__ import annotations

import contextlib
import hashlib
import importlib.util
import os
import shutil
import sys
import threading
from functools import cache
from pathlib import Path

from filelock import FileLock

from .model import equations, log, metrics

#: The model's modules whose functions compiled code calls, each registered with numba.
COMPILED_MODULES = (equations, metrics, log)

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

    # inlined by LLVM (forceinline), not by numba's inline="always", which types each
    # function again at every place it is called
    _OVERLOADED = (equations.select, equations.saturate)
    for _module in COMPILED_MODULES:
        for _name in _module.__all__:
            _f = getattr(_module, _name)
            if (callable(_f) and getattr(_f, "__module__", None) == _module.__name__
                    and _f not in _OVERLOADED and not isinstance(_f, type)):
                register_jitable(forceinline=True)(_f)
    _INLINE = dict(jit_options=dict(forceinline=True))

    @overload(equations.saturate, **_INLINE)
    def _saturate(x, limit):
        """equations.saturate compiled: numpy's NaN-keeping minimum and maximum."""
        return lambda x, limit: np.minimum(np.maximum(x, -limit), limit)

    @overload(equations.select, **_INLINE)
    def _select(condition, a, b):
        """equations.select compiled: a branch on scalars, np.where on arrays."""
        if (isinstance(condition, types.Boolean) and isinstance(a, types.Number)
                and isinstance(b, types.Number)):
            return lambda condition, a, b: a if condition else b
        return lambda condition, a, b: np.where(condition, a, b)


#: The package's files whose code the compiled functions run: the model's modules they
#: inline (:data:`COMPILED_MODULES`), the overloads here, and the compiled functions.
COMPILED_SOURCES = tuple(m.__name__.replace(".", "/")[len("unidyn/"):] + ".py"
                         for m in COMPILED_MODULES) + (
    "compiled.py", "engine/kernels.py", "identification/replay.py")
#: Versions of the compiled code whose cache folders are kept (switching between a few
#: versions, as between git branches, compiles none of them again).
KEEP_VERSIONS = 3


def sources_stamp() -> str:
    """A short hash of :data:`COMPILED_SOURCES`: the version of the code compiled
    (read through the package's loader, so a zipped install has one too)."""
    from importlib.resources import files
    h = hashlib.sha256()
    for name in COMPILED_SOURCES:
        h.update(files("unidyn").joinpath(name).read_bytes())
    return h.hexdigest()[:12]


STAMP = sources_stamp()


def cache_root() -> Path:
    """Where the versions' cache folders lie: ``$NUMBA_CACHE_DIR/unidyn-numba`` if the
    user set numba's cache folder, else ``unidyn-numba`` in the user's cache folder."""
    base = os.environ.get("NUMBA_CACHE_DIR")
    if not base:
        if sys.platform == "win32":
            base = os.environ.get("LOCALAPPDATA") or Path.home() / "AppData" / "Local"
        elif sys.platform == "darwin":
            base = Path.home() / "Library" / "Caches"
        else:
            base = os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache"
    return Path(base) / "unidyn-numba"


def remove_other_versions(root: Path, keep: int = KEEP_VERSIONS):
    """Remove the version folders in ``root`` but :data:`STAMP`'s and those of the
    keep - 1 other versions used most recently (a process still running a removed
    version compiles it again if it needs it)."""
    try:
        folders = [f for f in root.iterdir() if f.is_dir() and f.name != STAMP]
        folders.sort(key=lambda f: f.stat().st_mtime, reverse=True)
    except OSError:
        return
    for f in folders[keep - 1:]:
        shutil.rmtree(f, ignore_errors=True)


@cache
def cache_folder():
    """This version's cache folder, created (and touched: used now) at the first call in
    a process, or None where no folder can be written: then nothing is cached and each
    process compiles."""
    folder = cache_root() / STAMP
    try:
        folder.mkdir(parents=True, exist_ok=True)
        os.utime(folder)
        probe = folder / ".writable"
        probe.write_bytes(b"")
        probe.unlink()
    except OSError:
        return None
    remove_other_versions(folder.parent)
    return folder


@contextlib.contextmanager
def _numba_cache_dir(folder):
    """numba's documented NUMBA_CACHE_DIR set to folder while the package's functions
    are declared (numba reads it when a function with cache=True is declared)."""
    before = os.environ.get("NUMBA_CACHE_DIR")
    os.environ["NUMBA_CACHE_DIR"] = str(folder)
    numba.config.reload_config()
    try:
        yield
    finally:
        if before is None:
            del os.environ["NUMBA_CACHE_DIR"]
        else:
            os.environ["NUMBA_CACHE_DIR"] = before
        numba.config.reload_config()


#: Said once per process on stderr (a terminal) before a compile of the engine.
NOTICE = ("unidyn: compiling {what}, once per install and version "
          "(some seconds; later runs load it from the cache) ...")
_noticed = []


def _kind(a):
    """What numba compiles a call's argument a for (its type, dtype and dimensions;
    those of the items of a tuple)."""
    if isinstance(a, tuple):
        return (type(a).__name__,) + tuple(_kind(x) for x in a)
    return type(a).__name__, str(getattr(a, "dtype", "")), getattr(a, "ndim", 0)


class Compiled:
    """A compiled entry point, declared at its first call in a process, in the cache folder
    (:func:`cache_folder`). Its first call per argument types (where numba loads or
    compiles it) holds a ``filelock`` lock of that folder, and one that compiles (no
    marker of an earlier compile) says so on a terminal (:data:`NOTICE`)."""

    _declaring = threading.Lock()  # NUMBA_CACHE_DIR is the process's, one declaration at a time

    def __init__(self, py_func, options, what):
        self.py_func, self.options, self.what = py_func, options, what
        self.name = py_func.__qualname__
        self.dispatcher = None
        self.ready = set()
        self.__doc__ = py_func.__doc__

    def _declared(self):
        with self._declaring:
            if self.dispatcher is None:
                folder = cache_folder()
                if folder is None:
                    self.dispatcher = numba.njit(**self.options)(self.py_func)
                else:
                    with _numba_cache_dir(folder):
                        self.dispatcher = numba.njit(cache=True, **self.options)(self.py_func)
        return self.dispatcher

    def __call__(self, *args):
        key = _kind(args)
        if key in self.ready:
            return self.dispatcher(*args)
        dispatcher = self._declared()
        folder = cache_folder()
        if folder is None:
            out = dispatcher(*args)
            self.ready.add(key)
            return out
        marker = folder / f"{self.name}-{hashlib.sha256(repr(key).encode()).hexdigest()[:8]}.ready"
        with FileLock(str(folder / "compile.lock")):
            if not marker.exists() and not _noticed and sys.stderr is not None and sys.stderr.isatty():
                _noticed.append(True)
                print(NOTICE.format(what=self.what), file=sys.stderr, flush=True)
            out = dispatcher(*args)
            marker.touch()
        self.ready.add(key)
        return out


def jit(f=None, *, inline: bool = False, entry: str = ""):
    """``numba.njit(nogil=True, error_model="numpy")`` of f (division by zero gives inf
    or NaN); f itself without numba. ``inline``: inlined into its compiled callers
    (``forceinline``); ``entry``: called from Python, what it is for the compile notice
    (:class:`Compiled`: declared at its first call, cached on disk with the functions it
    calls; the others are compiled into their callers, never cached apart)."""
    def wrap(g):
        if not AVAILABLE or _loading_plain:
            return g
        options = dict(nogil=True, error_model="numpy", forceinline=inline)
        return Compiled(g, options, entry) if entry else numba.njit(**options)(g)
    return wrap if f is None else wrap(f)


#: Set while :func:`plain_copy` loads a module: its functions stay plain Python.
_loading_plain = []


def plain_copy(module):
    """``module`` loaded once more as ``<name>_plain``, its functions the same source run
    by Python, not compiled: it runs what compiled code cannot call (a reference that is
    a Python function), and needs no compiling."""
    name = module.__name__ + "_plain"
    if name in sys.modules:
        return sys.modules[name]
    spec = importlib.util.spec_from_file_location(name, module.__file__)
    plain = importlib.util.module_from_spec(spec)
    _loading_plain.append(True)
    try:
        spec.loader.exec_module(plain)
    finally:
        _loading_plain.pop()
    sys.modules[name] = plain
    return plain
