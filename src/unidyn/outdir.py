"""All-or-nothing writing of a command's results into a folder.

A command (``unidyn run``, ``unidyn identify``, a sweep started over, the Section 5
script) writes everything into a fresh staging folder beside its output folder and
swaps it in only when it has finished::

    with staged_output(out, overwrite=args.overwrite, results=("summary.json",),
                       what="run results") as stage:
        result.save(stage.path)            # write every file into stage.path
        if not result.complete:
            stage.incomplete(result.message)
    print(f"written {stage.final}/")

What a user can rely on:

- **An interruption or an error changes nothing.** Ctrl-C, an exception, ``kill``
  or ``kill -9`` while the block runs leave ``out`` exactly as it was; the
  staging folder is removed (or, after ``kill -9``, removed by the next command
  that writes beside it).
- **The swap is atomic.** On Linux the two folders are exchanged with one
  ``renameat2(RENAME_EXCHANGE)`` system call, so ``out`` always holds either the
  old results or the new ones, never a mix and never nothing. Elsewhere (or on a
  file system without the call) the old folder is renamed aside first; if the
  process dies between the two renames, the next command restores it.
- **Results are replaced only with --overwrite.** If ``out`` holds any of
  ``results``, :func:`staged_output` refuses with a :class:`ValidationError` that
  names them, unless ``overwrite`` is true.
- **Other files survive.** Entries of ``out`` that the command does not write
  (a user's notes, a sub-folder) are carried into the new folder (hard links, so
  nothing is copied); entries named in ``owned`` (the command's own artefacts,
  such as last run's ``animation.gif``) are not, so no stale artefact survives.
- **One writer at a time.** The block holds ``out``'s :class:`FolderLock` (the
  file ``.unidyn.lock`` in ``out``, locked with ``flock``), so a second command
  writing the same folder (a run, a sweep, an identification) is refused with a
  message naming the first one's PID; the lock of a killed process is taken over.
- **Ctrl-C during the swap** is held back until the swap is done: the command
  then either has its new results in place or has left the old ones.
- **A read-only parent folder** (``out`` writable, the folder holding it not):
  the staging folder goes inside ``out`` and the files are moved in one by one,
  each replacement atomic but not the set; the rest holds as above.
- **A partial result never replaces a complete one.** After
  :meth:`Stage.incomplete`, the staged files replace ``out`` only if ``out`` held
  no results; otherwise they go to the sibling folder ``<out>.incomplete`` and the
  old results stay where they were.
"""

from __future__ import annotations

import contextlib
import ctypes
import errno
import os
import shutil
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

from ._validate import ValidationError

__all__ = ["Stage", "staged_output", "FolderLock", "FolderInUse", "LOCK_NAME"]

_NEW, _OLD = "new", "old"
#: The lock file that marks a folder as being written by a unidyn process.
LOCK_NAME = ".unidyn.lock"


class FolderInUse(ValidationError):
    """Another process is writing the output folder (it holds the folder's lock)."""


def _pid_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (PermissionError, OverflowError, ValueError):
        return True
    return True


class FolderLock:
    """An exclusive lock on a folder, held by this process: the file ``.unidyn.lock``
    holding its PID, locked with ``fcntl.flock`` (released by the system when the
    process dies, so a lock left by a killed process is simply taken over). Where
    ``fcntl`` is missing the file is created exclusively and a lock whose PID is not
    running is taken over."""

    def __init__(self, folder, option: str = "out_dir"):
        self.path = Path(folder) / LOCK_NAME
        self._fd = None
        try:
            import fcntl
        except ImportError:  # pragma: no cover - not POSIX
            fcntl = None
        for _ in range(100):
            if fcntl is not None and self._try_flock(fcntl):
                break
            if fcntl is None and self._try_exclusive():
                break
        else:  # pragma: no cover - the lock file keeps vanishing under us
            raise FolderInUse(f"{folder}: cannot take the lock {self.path}")
        os.ftruncate(self._fd, 0)
        os.write(self._fd, f"{os.getpid()}\n".encode())
        os.fsync(self._fd)

    def _holder(self, fd=None) -> str:
        for _ in range(20):  # the holder writes its PID just after locking
            try:
                if fd is not None:
                    text = os.pread(fd, 64, 0).decode(errors="replace")
                else:
                    text = self.path.read_text(errors="replace")
            except OSError:
                text = ""
            if text.strip().isdigit():
                return text.strip()
            time.sleep(0.01)
        return "unknown"

    def _busy(self, pid: str):
        folder = self.path.parent
        return FolderInUse(f"{folder} is being written by another unidyn process (PID {pid}, "
                           f"lock {self.path}); wait for it to finish or choose another "
                           f"output folder")

    def _try_flock(self, fcntl) -> bool:
        fd = os.open(self.path, os.O_RDWR | os.O_CREAT, 0o644)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            pid = self._holder(fd)
            os.close(fd)
            raise self._busy(pid) from None
        try:  # a holder that released meanwhile removed the file: lock the new one
            same = os.stat(self.path).st_ino == os.fstat(fd).st_ino
        except FileNotFoundError:
            same = False
        if not same:
            os.close(fd)
            return False
        self._fd = fd
        return True

    def _try_exclusive(self) -> bool:  # pragma: no cover - not POSIX
        try:
            self._fd = os.open(self.path, os.O_RDWR | os.O_CREAT | os.O_EXCL, 0o644)
            return True
        except FileExistsError:
            pid = self._holder()
            if pid.isdigit() and _pid_alive(int(pid)):
                raise self._busy(pid) from None
            try:
                self.path.unlink()  # left by a process that is gone
            except FileNotFoundError:
                pass
            return False

    def release(self) -> None:
        if self._fd is None:
            return
        try:
            try:
                if os.stat(self.path).st_ino == os.fstat(self._fd).st_ino:
                    self.path.unlink()
            except FileNotFoundError:
                pass
        finally:
            os.close(self._fd)
            self._fd = None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.release()



@dataclass
class Stage:
    """The staging folder of one :func:`staged_output` block.

    :ivar path: the folder to write into
    :ivar held: the result files ``out`` held before (to be replaced)
    :ivar final: after the block, where the files are (``out``, or
        ``<out>.incomplete`` for a partial result beside complete ones)
    :ivar partial: why the results are partial ("" when complete)
    """

    path: Path
    held: tuple = ()
    final: Path | None = None
    partial: str = ""
    _out: Path = field(default=None, repr=False)

    def incomplete(self, reason: str) -> None:
        """Mark what was written as partial (a run that stopped early)."""
        self.partial = str(reason) or "incomplete"


def _leftovers(out: Path, kind: str):
    """Staging (``new``) or backup (``old``) folders of ``out`` left by dead processes."""
    prefix = f".{out.name}.{kind}-"
    entries = []
    for folder in (out.parent, out):  # staging goes inside out where the parent is read-only
        with contextlib.suppress(OSError):
            entries += list(folder.iterdir())
    found = []
    for p in entries:
        if not p.name.startswith(prefix) or not p.is_dir():
            continue
        pid = p.name[len(prefix):].split("-", 1)[0]
        if pid.isdigit() and not _pid_alive(int(pid)):
            found.append(p)
    return found


def _recover(out: Path) -> None:
    """Undo what a killed process left: restore a backup that never got its
    replacement, delete staging folders that were never swapped in."""
    for old in _leftovers(out, _OLD):
        if not out.exists():
            os.rename(old, out)  # died between the two renames of the fallback swap
        else:
            shutil.rmtree(old, ignore_errors=True)  # died after the swap, before the clean-up
    for new in _leftovers(out, _NEW):
        shutil.rmtree(new, ignore_errors=True)


def _mkdir_like_others(parent: Path, prefix: str) -> Path:
    path = Path(tempfile.mkdtemp(prefix=prefix, dir=parent))
    umask = os.umask(0)
    os.umask(umask)
    os.chmod(path, 0o777 & ~umask)  # mkdtemp makes 0700; give the usual mode
    return path


def _renameat2_exchange():
    """``renameat2(..., RENAME_EXCHANGE)`` from the C library, or None."""
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        fn = libc.renameat2
    except (OSError, AttributeError):
        return None
    fn.argtypes = [ctypes.c_int, ctypes.c_char_p, ctypes.c_int, ctypes.c_char_p, ctypes.c_uint]
    fn.restype = ctypes.c_int

    def exchange(a: Path, b: Path) -> None:
        at_fdcwd, rename_exchange = -100, 2
        if fn(at_fdcwd, os.fsencode(a), at_fdcwd, os.fsencode(b), rename_exchange) != 0:
            err = ctypes.get_errno()
            raise OSError(err, os.strerror(err), str(a))

    return exchange


_EXCHANGE = _renameat2_exchange() if hasattr(os, "fsencode") else None


def _carry(src: Path, dst: Path, skip) -> None:
    """Link the entries of ``src`` that are not in ``skip`` and not already in
    ``dst`` into ``dst`` (hard links; copies where linking is refused)."""
    for entry in src.iterdir():
        if entry.name in skip or (dst / entry.name).exists():
            continue
        target = dst / entry.name
        if entry.is_dir() and not entry.is_symlink():
            shutil.copytree(entry, target, symlinks=True, copy_function=_link_or_copy)
        else:
            _link_or_copy(entry, target)


def _link_or_copy(src, dst):
    try:
        if os.path.islink(src):
            os.symlink(os.readlink(src), dst)
        else:
            os.link(src, dst)
    except OSError:
        shutil.copy2(src, dst, follow_symlinks=False)
    return dst


def _swap_in(new: Path, out: Path, owned) -> None:
    """Make ``new`` become ``out`` atomically; the old ``out`` is deleted."""
    if not out.exists():
        try:
            os.rename(new, out)
            return
        except OSError as err:  # created meanwhile (by another process)
            if err.errno not in (errno.ENOTEMPTY, errno.EEXIST):
                raise
    _carry(out, new, set(owned))
    if _EXCHANGE is not None:
        try:
            _EXCHANGE(new, out)  # new now holds the old results
            shutil.rmtree(new, ignore_errors=True)
            return
        except OSError as err:
            if err.errno not in (errno.EINVAL, errno.ENOSYS, errno.EOPNOTSUPP):
                raise
    old = _mkdir_like_others(out.parent, f".{out.name}.{_OLD}-{os.getpid()}-")
    os.rmdir(old)
    os.rename(out, old)
    os.rename(new, out)  # a death between these two renames is undone by _recover
    shutil.rmtree(old, ignore_errors=True)


@contextlib.contextmanager
def _interrupts_deferred():
    """Hold back Ctrl-C (SIGINT) and SIGTERM for the few system calls of a swap, so
    that it is never cut in half. A Ctrl-C that came meanwhile is dropped once the new
    results are in place (the command has finished), and raised if they are not. A
    SIGTERM is delivered after the swap to whatever handler was there before, except,
    once the results are in place, to a handler marked ``unidyn_done_is_done`` (the
    ``unidyn`` command's: its work is done, and it reports it as done)."""
    import signal
    import threading
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    caught, term = [], []
    previous = signal.signal(signal.SIGINT, lambda *a: caught.append(True))
    previous_term = signal.signal(signal.SIGTERM, lambda *a: term.append(True))
    done = False
    try:
        yield
        done = True
    finally:
        # None: a handler set outside Python, which cannot be restored; the default then
        signal.signal(signal.SIGINT, signal.SIG_DFL if previous is None else previous)
        signal.signal(signal.SIGTERM, signal.SIG_DFL if previous_term is None else previous_term)
        if term and not (done and getattr(previous_term, "unidyn_done_is_done", False)):
            signal.raise_signal(signal.SIGTERM)
        if caught and not done:
            raise KeyboardInterrupt


def _stage_folder(out: Path) -> tuple[Path, bool]:
    """A fresh staging folder beside ``out`` (True), or inside it where the parent
    folder cannot be written (False: the files are then moved in one by one)."""
    prefix = f".{out.name}.{_NEW}-{os.getpid()}-"
    try:
        return _mkdir_like_others(out.parent, prefix), True
    except PermissionError:
        if not (out.is_dir() and os.access(out, os.W_OK)):
            raise
    return _mkdir_like_others(out, prefix), False


def _move_in(stage: Path, out: Path, owned) -> None:
    """Fallback for a read-only parent folder: move the staged entries into ``out``
    one by one (each replacement atomic, the set not), then drop the command's
    artefacts that the new results do not have."""
    new = set(os.listdir(stage))
    for name in sorted(new):
        target = out / name
        if target.is_dir() and not target.is_symlink():
            shutil.rmtree(target)
        os.replace(stage / name, target)
    for name in owned:
        p = out / name
        if name not in new and (p.is_file() or p.is_symlink()):
            p.unlink()
    os.rmdir(stage)


@contextlib.contextmanager
def staged_output(out, *, overwrite: bool, results, what: str = "results", owned=None,
                  option: str = "--out", lock: bool = True):
    """Write a command's output folder all-or-nothing (see the module docstring).

    :param out: the output folder (created if needed, with its parents)
    :type out: str or os.PathLike
    :param overwrite: replace results that ``out`` already holds
    :type overwrite: bool
    :param results: file names whose presence in ``out`` means it holds results
        (``("summary.json", "timeseries.csv")`` for a run)
    :type results: tuple of str
    :param what: what the results are, for messages ("run results")
    :type what: str
    :param owned: every name the command writes; those entries of the old folder
        are not carried into the new one (default: ``results``)
    :type owned: tuple of str
    :param option: the option that named ``out``, for messages
    :type option: str
    :param lock: hold ``out``'s :class:`FolderLock` for the whole block, so that a
        second process writing the same folder is refused naming this one; pass
        False only when the caller holds it already
    :type lock: bool
    :raises ValidationError: ``out`` is a file, or holds results and ``overwrite``
        is false
    :raises FolderInUse: another process holds ``out``'s lock
    :return: a context manager yielding a :class:`Stage`
    """
    out = Path(out).absolute()
    results = tuple(results)
    owned = tuple(results if owned is None else owned) + results
    if out.exists() and not out.is_dir():
        raise ValidationError(f"{option} {out} is a file, not a folder")
    if out.parent.is_dir():
        _recover(out)  # first: a backup of a killed process may be all that is left of out
    created = not out.exists()
    out.mkdir(parents=True, exist_ok=True)
    try:
        with (FolderLock(out) if lock else contextlib.nullcontext()):
            with _staged(out, overwrite, results, what, owned, option) as stage:
                yield stage
    except BaseException:
        if created:  # nothing was written: leave no empty folder behind
            for p in (out / LOCK_NAME, out):
                with contextlib.suppress(OSError):
                    p.rmdir() if p == out else p.unlink()
        raise


@contextlib.contextmanager
def _staged(out, overwrite, results, what, owned, option):
    held = tuple(n for n in results if (out / n).exists())
    if held and not overwrite:
        raise ValidationError(f"{out} already holds {what} ({', '.join(held)}); pass "
                              f"--overwrite to replace them (they are kept until the new "
                              f"{what} are complete) or choose another {option}")
    path, beside = _stage_folder(out)
    stage = Stage(path, held=held, _out=out)
    try:
        yield stage
        with _interrupts_deferred():
            if stage.partial and any((out / n).exists() for n in results):
                target = out.with_name(out.name + ".incomplete")
                if not beside:
                    raise ValidationError(f"cannot keep the partial {what} beside {out}: "
                                          f"{out.parent} is not writable; {out} is as it was")
                _swap_in(path, target, owned=tuple(os.listdir(target)) if target.is_dir()
                         else ())
            elif beside:
                target = out
                _swap_in(path, out, owned)
            else:
                target = out
                _move_in(path, out, owned)
            stage.final = target
    except BaseException:
        shutil.rmtree(path, ignore_errors=True)
        raise
