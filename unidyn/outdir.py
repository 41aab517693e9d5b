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
from dataclasses import dataclass, field
from pathlib import Path

from ._validate import ValidationError

__all__ = ["Stage", "staged_output"]

_NEW, _OLD = "new", "old"


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


def _pid_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def _leftovers(out: Path, kind: str):
    """Staging (``new``) or backup (``old``) folders of ``out`` left by dead processes."""
    prefix = f".{out.name}.{kind}-"
    try:
        entries = list(out.parent.iterdir())
    except OSError:
        return []
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
def staged_output(out, *, overwrite: bool, results, what: str = "results", owned=None,
                  option: str = "--out"):
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
    :raises ValidationError: ``out`` is a file, or holds results and ``overwrite``
        is false
    :return: a context manager yielding a :class:`Stage`
    """
    out = Path(out).absolute()
    results = tuple(results)
    owned = tuple(results if owned is None else owned) + results
    if out.exists() and not out.is_dir():
        raise ValidationError(f"{option} {out} is a file, not a folder")
    out.parent.mkdir(parents=True, exist_ok=True)
    _recover(out)
    held = tuple(n for n in results if (out / n).exists())
    if held and not overwrite:
        raise ValidationError(f"{out} already holds {what} ({', '.join(held)}); pass "
                              f"--overwrite to replace them (they are kept until the new "
                              f"{what} are complete) or choose another {option}")
    stage = Stage(_mkdir_like_others(out.parent, f".{out.name}.{_NEW}-{os.getpid()}-"),
                  held=held, _out=out)
    try:
        yield stage
        if stage.partial and any((out / n).exists() for n in results):
            target = out.with_name(out.name + ".incomplete")
            _swap_in(stage.path, target, owned=tuple(os.listdir(target)) if target.is_dir()
                     else ())
        else:
            target = out
            _swap_in(stage.path, out, owned)
        stage.final = target
    except BaseException:
        shutil.rmtree(stage.path, ignore_errors=True)
        raise
