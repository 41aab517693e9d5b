"""Writing a command's results into a folder the user chose, touching nothing else.

A command (``unidyn run``, ``unidyn identify``, a sweep started over, a script) writes
its files into a private folder inside ``out`` and moves them into place only when it
has finished::

    with staged_output(out, kind="run", overwrite=args.overwrite,
                       results=("summary.json",), what="run results") as stage:
        result.save(stage.path)            # write every file into stage.path
        if not result.complete:
            stage.incomplete(result.message)
    print(f"written {stage.final}/")

What a user can rely on:

- **Only the command's own files change.** ``out`` itself is never renamed, copied
  or deleted, nor is anything in it that the command did not write: a user's notes,
  a sub-folder, a file system mounted inside, files another process is writing. A
  symbolic link ``out`` is followed: the results land in its target.
- **An interruption or an error changes nothing.** Ctrl-C, an exception, ``kill``
  or ``kill -9`` while the block runs leave ``out``'s files as they were; the
  private folder (``.unidyn-<kind>-new-*``) is removed, after ``kill -9`` by the next
  command that writes ``out``.
- **Each file is replaced atomically, and the set is recorded.** The finished files
  are renamed into place one by one (``os.replace``); Ctrl-C and SIGTERM are held
  back meanwhile. A manifest ``.unidyn-<kind>.json`` then lists every file with its
  SHA-256; until it is written it says the replacement is under way, so a reader
  (:func:`check_manifest`) never takes files of two runs for one result, even after
  ``kill -9`` in those milliseconds.
- **Results are replaced only when asked** (``overwrite``); the earlier result's
  files that the new one does not have (listed in the old manifest) are removed.
- **One writer at a time.** The block holds ``out``'s :class:`FolderLock`.
- **A partial result never replaces a complete one.** After :meth:`Stage.incomplete`
  the files go to the sibling folder ``<out>.incomplete`` if ``out`` holds results.
- **A full disk** is reported naming the file, and whether earlier results are intact.
"""

from __future__ import annotations

import contextlib
import errno
import hashlib
import json
import math
import os
import shutil
import tempfile
import uuid
from dataclasses import dataclass
from pathlib import Path

from .._validate import ValidationError
from ..process import finishes_on_sigterm

__all__ = ["Stage", "staged_output", "FolderLock", "FolderInUse", "LOCK_NAME",
           "check_manifest", "record_files", "output_folder", "write_atomic", "json_ready"]

#: The lock file that marks a folder as being written by a unidyn process.
LOCK_NAME = ".unidyn.lock"
_PREFIX = ".unidyn"  # the lock, manifests and private folders: never a result file
_STAGES: set = set()  # the private folders being written by this process


class FolderInUse(ValidationError):
    """Another process is writing the output folder (it holds the folder's lock)."""


class FolderLock:
    """An exclusive lock on a folder held by this process: ``filelock`` on the file
    ``.unidyn.lock``, which holds the PID (the system releases it when the process
    dies, so the lock of a killed process is simply taken over)."""

    def __init__(self, folder):
        import filelock
        self.path = Path(folder) / LOCK_NAME

        def write_pid(fd):
            os.ftruncate(fd, 0)
            os.lseek(fd, 0, os.SEEK_SET)
            os.write(fd, f"{os.getpid()}\n".encode())
        self._lock = filelock.FileLock(self.path, timeout=0, on_acquired=write_pid)
        for _ in range(20):  # a holder that released meanwhile removed the file: again
            try:
                self._lock.acquire()
                return
            except filelock.Timeout:
                try:
                    pid = self.path.read_text(errors="replace").strip() or "unknown"
                except FileNotFoundError:
                    continue
                except OSError:  # locked for reading too (Windows)
                    pid = "unknown"
                raise FolderInUse(f"{folder} is being written by another unidyn process "
                                  f"(PID {pid}, lock {self.path}); wait for it to finish or "
                                  f"choose another output folder") from None
        raise FolderInUse(f"{folder}: cannot take the lock {self.path}")  # pragma: no cover

    def release(self) -> None:
        if self._lock.is_locked:  # removed while held: a waiter on it then tries afresh
            with contextlib.suppress(OSError):  # (Windows: filelock removes it)
                self.path.unlink()
            self._lock.release()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.release()


def output_folder(out, option: str = "--out") -> Path:
    """``out`` as an absolute path with symbolic links followed; one line of refusal
    for an empty name or a file."""
    if str(out) == "":
        raise ValidationError(f"{option} is empty; give a folder ({option} . for the "
                              f"current one)")
    path = Path(os.path.realpath(os.fspath(out)))
    if path.exists() and not path.is_dir():
        raise ValidationError(f"{option} {out} is a file, not a folder")
    return path


def _manifest_path(folder: Path, kind: str) -> Path:
    return folder / f"{_PREFIX}-{kind}.json"


def _read_manifest(folder: Path, kind: str):
    try:
        m = json.loads(_manifest_path(folder, kind).read_text())
        return m if isinstance(m, dict) and isinstance(m.get("files"), dict) else {"files": {}}
    except FileNotFoundError:
        return None
    except (OSError, ValueError):
        return {"files": {}}  # unreadable: as a replacement cut short


def _sha256(path: Path):
    if not path.is_file():
        return None
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            h.update(block)
    return "sha256:" + h.hexdigest()


def json_ready(value):
    """Plain data with every non-finite float replaced by None, for strict JSON (a
    scenario's infinite limit, "no limit", is written ``null``, which
    :class:`unidyn.model.unicycle.Limits` reads back as no limit)."""
    if isinstance(value, dict):
        return {k: json_ready(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [json_ready(v) for v in value]
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def write_atomic(path, text: str, more=()) -> None:
    """Write ``text`` (then each string of the iterable ``more``) to ``path``
    through a temporary file in the same folder and a rename, so an interrupted write
    never leaves a half-written file that looks complete. An error names ``path``."""
    path = Path(path)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "w", newline="") as fh:
            fh.write(text)
            for chunk in more:
                fh.write(chunk)
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)  # mkstemp creates 0600; give the usual mode
        os.replace(tmp, path)
    except BaseException as err:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        if isinstance(err, OSError) and err.filename is None:  # a write: name the file
            raise OSError(err.errno, err.strerror, str(path)) from err
        raise


def _write_manifest(folder: Path, kind: str, files: dict, complete: bool, run_id: str):
    text = json.dumps({"kind": kind, "id": run_id, "complete": complete, "files": files},
                      indent=2)
    write_atomic(_manifest_path(folder, kind), text + "\n")


def check_manifest(folder, kind: str, names=()) -> str:
    """What is wrong with ``folder``'s results of ``kind`` ("" if nothing): a
    replacement cut short, or any of ``names`` not the file its manifest lists. A
    folder without a manifest (written before manifests) passes."""
    folder = Path(folder)
    m = _read_manifest(folder, kind)
    if m is None:
        return ""
    if m.get("complete") is not True:
        return (f"{folder} holds {kind} results whose replacement was cut short (its files "
                f"may come from two runs)")
    for n in names:
        want = m["files"].get(n)
        if want is not None and _sha256(folder / n) != want:
            return (f"{folder / n} is not the file its run wrote (it differs from "
                    f"{_manifest_path(folder, kind).name}: another run's file, or edited)")
    return ""


def record_files(folder, kind: str, names, hashes: bool = True) -> None:
    """Add files that a command wrote into ``folder`` itself (outside
    :func:`staged_output`) to the manifest of its results."""
    folder = Path(folder)
    m = _read_manifest(folder, kind) or {"files": {}, "id": uuid.uuid4().hex}
    m["files"].update({n: _sha256(folder / n) if hashes else None for n in names})
    _write_manifest(folder, kind, m["files"], True, m.get("id", ""))


@dataclass
class Stage:
    """The private folder of one :func:`staged_output` block.

    :ivar path: the folder to write into (inside ``out``)
    :ivar held: the result files ``out`` held before (to be replaced)
    :ivar final: after the block, where the files are (``out``, or
        ``<out>.incomplete`` for a partial result beside complete ones)
    :ivar partial: why the results are partial ("" when complete)
    :ivar moving: files are being (or were) moved into place
    """

    path: Path
    held: tuple = ()
    final: Path | None = None
    partial: str = ""
    moving: bool = False

    def incomplete(self, reason: str) -> None:
        """Mark what was written as partial (a run that stopped early)."""
        self.partial = str(reason) or "incomplete"


@contextlib.contextmanager
def staged_output(out, *, overwrite: bool, results, what: str = "results", owned=None,
                  kind: str = "results", option: str = "--out", flag: str = "--overwrite",
                  lock: bool = True, hashes: bool = True):
    """Write a command's results into ``out`` (see the module docstring).

    :param out: the output folder (created if needed, with its parents)
    :param overwrite: replace results that ``out`` already holds
    :param results: file names whose presence in ``out`` means it holds results
    :param what: what the results are, for messages ("run results")
    :param owned: names the command writes, removed on replacement from a folder
        written before manifests (default: ``results``)
    :param kind: names the manifest (``.unidyn-<kind>.json``): one per kind of result
    :param option: how the caller named ``out``, and ``flag`` how it asks to
        overwrite, for messages (``"--out"``, ``"--overwrite"`` on the command line)
    :param lock: hold ``out``'s :class:`FolderLock` (False: the caller holds it)
    :param hashes: record each file's SHA-256 (False for files appended to later)
    :raises ValidationError: ``out`` is a file, or holds results and ``overwrite`` is
        false; :class:`FolderInUse` if another process holds ``out``'s lock
    """
    final = output_folder(out, option)
    if final in _STAGES:  # called by code writing into a stage (save() by a command)
        yield Stage(final)
        return
    created = not final.exists()
    final.mkdir(parents=True, exist_ok=True)
    try:
        with (FolderLock(final) if lock else contextlib.nullcontext()):
            for p in final.glob(f"{_PREFIX}-*-new-*"):  # left by a killed process
                shutil.rmtree(p, ignore_errors=True)
            old = _read_manifest(final, kind)
            held = tuple(dict.fromkeys([n for n in results if (final / n).exists()]
                                       + [n for n in (old or {"files": {}})["files"]
                                          if (final / n).exists()]))
            if held and not overwrite:
                raise ValidationError(f"{out} already holds {what} ({', '.join(held)}); pass "
                                      f"{flag} to replace them (they are kept until the new "
                                      f"{what} are complete) or choose another {option}")
            stage = Stage(Path(tempfile.mkdtemp(prefix=f"{_PREFIX}-{kind}-new-", dir=final)),
                          held=held)
            _STAGES.add(stage.path)
            try:
                yield stage
                with _interrupts_deferred():
                    stage.final = _commit(stage, final, kind, tuple(owned or results),
                                          what, hashes)
            except OSError as err:
                if err.errno in (errno.ENOSPC, errno.EDQUOT):
                    raise _disk_full(err, stage, out, final) from None
                raise
            finally:
                _STAGES.discard(stage.path)
                shutil.rmtree(stage.path, ignore_errors=True)
    except BaseException:
        if created:  # nothing was written: leave no empty folder behind
            with contextlib.suppress(OSError):
                final.rmdir()
        raise


def _commit(stage: Stage, out: Path, kind, owned, what, hashes) -> Path:
    """Move the staged files into ``out`` (or ``<out>.incomplete``), remove the
    earlier result's files that the new one lacks, write the manifest."""
    target = out
    if stage.partial and stage.held:
        if out.parent == out:
            raise ValidationError(f"cannot keep the partial {what} beside {out}; {out} is "
                                  f"as it was")
        target = out.with_name(out.name + ".incomplete")
        target.mkdir(exist_ok=True)
    old = _read_manifest(target, kind)
    earlier = set(owned if old is None else old["files"])  # the earlier result's names
    new = sorted(n for n in os.listdir(stage.path) if not n.startswith(_PREFIX))
    for n in new:
        p = target / n
        if p.is_dir() and not p.is_symlink() and n not in earlier:
            raise ValidationError(f"{p} is a folder that these {what} did not write; "
                                  f"{target} is as it was")
    run_id = uuid.uuid4().hex
    files = {n: _sha256(stage.path / n) if hashes else None for n in new}
    _write_manifest(target, kind, files, False, run_id)  # under way, until the last line
    stage.moving = True
    for n in new:
        p = target / n
        if p.is_dir() and not p.is_symlink():  # a folder of the earlier result: aside
            os.rename(p, stage.path / f"{_PREFIX}-old-{n}")
        _move(stage.path / n, p)
    for n in sorted(earlier - set(new)):
        p = target / n
        if p.is_dir() and not p.is_symlink():
            shutil.rmtree(p, ignore_errors=True)
        elif p.is_file() or p.is_symlink():
            p.unlink()
    _write_manifest(target, kind, files, True, run_id)
    return target


def _move(src: Path, dst: Path) -> None:
    try:
        os.replace(src, dst)
    except OSError as err:  # another file system (<out>.incomplete beside a mount point)
        if err.errno != errno.EXDEV:
            raise
        tmp = dst.with_name(f"{_PREFIX}-new-{dst.name}")
        (shutil.copytree if src.is_dir() else shutil.copy2)(src, tmp)
        os.replace(tmp, dst)


def _disk_full(err: OSError, stage: Stage, out, final: Path) -> OSError:
    """The full-disk error, naming the file and saying what became of the results."""
    where = Path(err.filename) if err.filename else None
    if where is not None and stage.path in where.parents:
        where = Path(out) / where.relative_to(stage.path)
    what = f"writing {where}" if where else f"writing into {out}"
    if stage.moving:
        kept = (f"the new files are in place but not recorded; run the command again "
                f"to write a complete set")
    elif stage.held:
        kept = f"the earlier results in {out} are intact (nothing was replaced)"
    else:
        kept = f"nothing was written to {out}"
    return OSError(err.errno, f"{os.strerror(err.errno)} {what}; {kept}")


@contextlib.contextmanager
def _interrupts_deferred():
    """Hold back Ctrl-C (SIGINT) and SIGTERM while the files are renamed into place,
    so that a replacement is never cut in half. A Ctrl-C that came meanwhile is dropped
    once the new results are in place (the command has finished), and raised if they
    are not. A SIGTERM is delivered after to whatever handler was there before, except,
    once the results are in place, to the ``unidyn`` command's
    (:func:`unidyn.process.finishes_on_sigterm`: its work is done, and it reports it
    as done)."""
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
        if term and not (done and finishes_on_sigterm(previous_term)):
            signal.raise_signal(signal.SIGTERM)
        if caught and not done:
            raise KeyboardInterrupt
