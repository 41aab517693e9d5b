"""Writing a command's results into a folder the user chose, touching nothing else.

A command (``unidyn run``, ``unidyn identify``, a sweep started over, a script) writes
its files into a private folder inside ``out`` and moves them into place only when it
has finished::

    with staged_output(out, kind="run", names=RUN_FILES, overwrite=args.overwrite,
                       what="run results") as stage:
        result.save(stage.path)            # write every file into stage.path
        if not result.complete:
            stage.incomplete(result.message)
    print(f"written {stage.final}/")

What a user can rely on:

- **A file is unidyn's only when its content proves it.** Each folder of results
  has a manifest, ``.unidyn-<kind>.json``, that unidyn writes *before* it creates or
  changes a file: the file's name (one of the few names that kind of command writes)
  and the SHA-256 of the content it is about to have. A file counts as unidyn's
  (:class:`Ledger`) only if such a manifest lists it and the file, a regular file with
  a single link, still has that content. Anything else with a result's name -- a
  user's ``path.png``, an edited ``summary.json``, a link -- is never replaced or
  removed, with or without ``overwrite``: the command refuses up front and names it.
- **A manifest is untrusted input.** Every entry must be one of the kind's file names
  with a SHA-256; anything else (a path, ``..``, a folder, a huge or unreadable file)
  is refused in one line naming the manifest and the entry, and nothing is changed.
  Nothing read from disk is ever removed as a tree.
- **unidyn's own scaffolding is proven too, never judged by name.** Its private
  folder (``.unidyn-<kind>-new-<random>``) is created exclusively, holds a random
  token, and is recorded with it in the lock before it exists; its lock
  (``.unidyn.lock``) is a file it creates and whose content it wrote; its temporary
  files are made exclusively (``mkstemp``) and removed by the path it recorded. A
  file, folder or link of the user's with any of these names -- ``.unidyn-*-new-*``,
  ``.unidyn.lock``, ``<out>.incomplete`` -- is never changed or removed; where it is
  in the way, the command refuses in one line naming it. Links are never followed.
- **An interruption or an error changes nothing.** Ctrl-C, an exception, ``kill``
  or ``kill -9`` while the block runs leave ``out``'s files as they were; the
  private folder is removed, after ``kill -9`` by the next command that takes
  ``out``'s lock (the killed process's lock names it, with its token).
- **Each file is replaced atomically, and the set is recorded.** The finished files
  are renamed into place one by one (``os.replace``); Ctrl-C and SIGTERM are held
  back meanwhile. Until the last one is in place the manifest says the replacement is
  under way, so a reader (:func:`check_manifest`) never takes files of two runs for
  one result, even after ``kill -9`` in those milliseconds.
- **Results are replaced only when asked** (``overwrite``, a bool); the earlier
  result's files that the new one does not have are removed if they are proven
  unidyn's.
- **One writer at a time.** The block holds ``out``'s :class:`FolderLock`; a lock
  that cannot be taken is refused in one line saying why (another process, with its
  PID; a ``.unidyn.lock`` unidyn did not make; a folder it cannot write).
- **A partial result never replaces a complete one.** After :meth:`Stage.incomplete`
  the files go to the sibling folder ``<out>.incomplete`` if ``out`` holds results:
  one unidyn makes, or one holding its manifest (never a link or a user's folder).
- **A full disk** is reported naming the file being written, how much of it was
  written and the space left, and whether earlier results are intact.
"""

from __future__ import annotations

import contextlib
import errno
import hashlib
import json
import math
import os
import re
import secrets
import shutil
import stat
import tempfile
import uuid
from dataclasses import dataclass
from pathlib import Path

from .._validate import ValidationError, flag as _flag
from ..process import finishes_on_sigterm

__all__ = ["Stage", "staged_output", "Ledger", "FolderLock", "FolderInUse", "LOCK_NAME",
           "check_manifest", "output_folder", "write_atomic", "json_ready"]

#: The lock file that marks a folder as being written by a unidyn process.
LOCK_NAME = ".unidyn.lock"
_PREFIX = ".unidyn"  # the lock, manifests and private folders: never a result file
_STAGES: set = set()  # the private folders being written by this process
_SHA256 = re.compile(r"sha256:[0-9a-f]{64}\Z")
#: The largest manifest read: one lists a handful of names and hashes.
MAX_MANIFEST_BYTES = 1 << 16


class FolderInUse(ValidationError):
    """Another process is writing the output folder (it holds the folder's lock)."""


#: What unidyn writes in its lock: its token and PID, then a line per private folder
#: it is about to make (the record by which the next command removes one a killed
#: process left, and nothing else)
_LOCK_TEXT = re.compile(r"unidyn lock [0-9a-f]{32}\npid [0-9]+\n"
                        r"(?:stage \.unidyn-[a-z0-9_]+-new-[0-9a-f]{12} [0-9a-f]{32}\n)*\Z")
_STAGE_LINE = re.compile(r"stage (\S+) ([0-9a-f]{32})$", re.M)
_MAX_LOCK_BYTES = 1 << 14
_HELD: dict = {}  # folder -> the FolderLock this process holds on it
_NOFOLLOW = getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_NONBLOCK", 0)  # (not on Windows)


class _Replaced(Exception):
    """The lock file was removed or replaced between its opening and its locking."""


def _kind_of(st) -> str:
    """What a non-regular directory entry is, in a user's words."""
    if stat.S_ISLNK(st.st_mode):
        return "a symbolic link"
    if stat.S_ISDIR(st.st_mode):
        return "a folder"
    if not stat.S_ISREG(st.st_mode):
        return "not a regular file"
    return f"a file with {st.st_nlink} hard links"


class FolderLock:
    """An exclusive lock on a folder held by this process: ``filelock`` on the file
    ``.unidyn.lock``, which unidyn creates itself and proves by content (its token and
    PID; the system releases the lock when the process dies, so the lock of a killed
    process is taken over). A ``.unidyn.lock`` unidyn did not write -- a file of the
    user's, a link, a folder -- is never changed or removed: the lock is refused in one
    line naming it. The lock also records the private folders the holder makes in the
    folder (:func:`staged_output`), so that one left by a killed process is removed
    by the next command, and only one so recorded.

    :param folder: the folder (links followed: it is what the caller asked for)
    :param option: how the caller named the folder, for messages
    :raises FolderInUse: another process holds the lock
    :raises ValidationError: ``.unidyn.lock`` is not unidyn's, or cannot be created
    """

    def __init__(self, folder, option: str = "--out"):
        import filelock
        self.folder = Path(os.path.realpath(os.fspath(folder)))
        self.path = self.folder / LOCK_NAME
        self.option = option
        self.token = secrets.token_hex(16)
        self.stages: dict = {}  # private folder name -> its token, as recorded
        self._fd = self._id = None
        self._lock = filelock.FileLock(self.path, timeout=0, preserve_lock_file=True,
                                       on_acquired=self._claim)
        for _ in range(20):  # a holder that released meanwhile removed the file: again
            self._existed = self._check_entry()
            try:
                self._lock.acquire()
                break
            except _Replaced:
                continue
            except filelock.Timeout:
                raise FolderInUse(f"{self.folder} is being written by another unidyn process "
                                  f"(PID {self._holder()}, lock {self.path}); wait for it to "
                                  f"finish or choose another {option}") from None
            except OSError as err:
                raise ValidationError(f"cannot take the lock {self.path}: "
                                      f"{err.strerror or err} (unidyn creates it to keep other "
                                      f"unidyn processes out of {self.folder} while it writes)"
                                      ) from None
        else:  # pragma: no cover - replaced twenty times in a row
            raise FolderInUse(f"cannot take the lock {self.path}: it was replaced twenty "
                              f"times while unidyn took it")
        _HELD[self.folder] = self
        for name, token in list(self.stages.items()):  # recorded by a killed holder
            _remove_stage(self.folder / name, token)
            self.forget(name)

    def _foreign(self, why: str) -> ValidationError:
        return ValidationError(f"{self.path} is {why}, not a lock unidyn made; unidyn never "
                               f"changes or removes it: move it elsewhere or choose another "
                               f"{self.option}")

    def _check_entry(self) -> bool:
        """Whether the lock file is there, refusing anything but a regular file."""
        try:
            st = os.lstat(self.path)
        except FileNotFoundError:
            return False
        if not stat.S_ISREG(st.st_mode) or st.st_nlink != 1:
            raise self._foreign(_kind_of(st))
        return True

    def _claim(self, fd: int) -> None:
        """Just locked: prove the file is unidyn's lock (made now, or by a process that
        died holding it), take over its record of private folders, write ours."""
        st = os.fstat(fd)
        try:
            now = os.lstat(self.path)
        except FileNotFoundError:
            raise _Replaced from None
        if st.st_nlink == 0 or (now.st_dev, now.st_ino) != (st.st_dev, st.st_ino):
            raise _Replaced
        if not stat.S_ISREG(st.st_mode) or st.st_nlink != 1:
            raise self._foreign(_kind_of(st))
        os.lseek(fd, 0, os.SEEK_SET)
        data = os.read(fd, _MAX_LOCK_BYTES + 1)
        try:
            text = data.decode("ascii")
        except UnicodeDecodeError:
            text = None
        if data or self._existed:  # empty only when made now, by this process
            if text is None or not _LOCK_TEXT.match(text):
                raise self._foreign("a file whose content unidyn did not write" if data
                                    else "an empty file that was there before")
            self.stages = dict(_STAGE_LINE.findall(text))
        self._fd, self._id = fd, (st.st_dev, st.st_ino)
        self._write()

    def _write(self) -> None:
        text = f"unidyn lock {self.token}\npid {os.getpid()}\n" + "".join(
            f"stage {n} {t}\n" for n, t in self.stages.items())
        data = text.encode("ascii")
        os.ftruncate(self._fd, 0)
        os.lseek(self._fd, 0, os.SEEK_SET)
        os.write(self._fd, data)

    def _holder(self) -> str:
        """The PID the lock names (read without following a link), or "unknown"."""
        try:
            fd = os.open(self.path, os.O_RDONLY | _NOFOLLOW)
            try:
                head = os.read(fd, 256).decode("ascii", "replace")
            finally:
                os.close(fd)
        except OSError:
            return "unknown"
        found = re.search(r"^pid ([0-9]+)$", head, re.M)
        return found.group(1) if found else "unknown"

    def record(self, name: str, token: str) -> None:
        """Record a private folder about to be made (before it exists)."""
        self.stages[name] = token
        self._write()

    def forget(self, name: str) -> None:
        """Drop a private folder from the record (removed, or never made)."""
        if self.stages.pop(name, None) is not None and self._fd is not None:
            self._write()

    def release(self) -> None:
        """Remove the lock file (the one this process locked, proven by its identity)
        and release the lock."""
        if self._lock.is_locked:  # removed while held: a waiter on it then tries afresh
            with contextlib.suppress(OSError):
                now = os.lstat(self.path)
                if (now.st_dev, now.st_ino) == self._id:
                    os.unlink(self.path)
            self._fd = None
            self._lock.release()
        if _HELD.get(self.folder) is self:
            del _HELD[self.folder]

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



def _manifest_path(folder: Path, kind: str) -> Path:
    return folder / f"{_PREFIX}-{kind}.json"


def _digest(path: Path):
    """The running SHA-256 of a file's bytes (a ``hashlib`` object, which can go on)."""
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            h.update(block)
    return h


def _hex(digest) -> str:
    return "sha256:" + digest.hexdigest()


class Ledger:
    """The files of one kind of result that unidyn wrote in ``folder``, proven by content.

    Its record is the manifest ``.unidyn-<kind>.json``::

        {"kind": "run", "id": "...", "complete": true,
         "files": {"summary.json": ["sha256:..."], ...}}

    A name maps to the SHA-256 of the content unidyn gave the file, or to two of them
    while unidyn replaces it (before and after: the manifest is written before the
    file changes). :meth:`owns` is true only for a listed name whose file is a regular
    file with one link and one of the listed hashes.

    :param folder: the folder (a real path: links already followed by the caller)
    :param kind: ``"run"``, ``"identify"``, ``"sweep"``, ...: one manifest per kind
    :param names: every file name this kind of command writes (``"summary.json"``; a
        file in a result's own folder as ``"case1/summary.json"``); a manifest listing
        anything else is refused
    :raises ValidationError: the manifest is not one unidyn could have written
    """

    def __init__(self, folder, kind: str, names):
        self.folder, self.kind, self.names = Path(folder), kind, tuple(names)
        self.path = _manifest_path(self.folder, kind)
        self.files: dict = {}
        self.complete = True
        self.id = uuid.uuid4().hex
        self.exists = os.path.lexists(self.path)
        self._proven: dict = {}  # name -> running digest of the content it was proven by
        if self.exists:
            self._load()

    def _refuse(self, why: str) -> ValidationError:
        return ValidationError(f"{self.path} {why}; nothing was changed (move the folder's "
                               f"results and this file elsewhere, or choose another folder)")

    def _load(self) -> None:
        st = os.lstat(self.path)
        if not stat.S_ISREG(st.st_mode):
            raise self._refuse("is not a regular file, so not a manifest unidyn wrote")
        if st.st_size > MAX_MANIFEST_BYTES:
            raise self._refuse(f"has {st.st_size} bytes, more than a manifest unidyn writes")
        try:
            data = json.loads(self.path.read_bytes())
        except (OSError, ValueError) as err:  # UnicodeDecodeError is a ValueError
            raise self._refuse(f"is not a manifest unidyn wrote ({err})") from None
        if not isinstance(data, dict) or not isinstance(data.get("files"), dict):
            raise self._refuse("is not a manifest unidyn wrote (it has no table of files)")
        for name, hashes in data["files"].items():
            if name not in self.names:
                raise self._refuse(f"lists {name!r}, which is not a file unidyn {self.kind} "
                                   f"writes (those are {', '.join(self.names)})")
            if isinstance(hashes, str):
                hashes = [hashes]
            if not (isinstance(hashes, list) and 1 <= len(hashes) <= 2
                    and all(isinstance(h, str) and _SHA256.match(h) for h in hashes)):
                raise self._refuse(f"lists {name!r} without the SHA-256 of its content")
            self.files[name] = list(hashes)
        self.complete = data.get("complete") is True
        if isinstance(data.get("id"), str):
            self.id = data["id"]

    def _lstat(self, name: str):
        """``os.lstat`` of ``folder/name``; None when it is not there, False when a
        folder on its way is a link or not a folder (a link is never followed)."""
        path = self.folder
        *parents, last = name.split("/")
        for part in parents:
            path = path / part
            try:
                if not stat.S_ISDIR(os.lstat(path).st_mode):
                    return False
            except FileNotFoundError:
                return None
        try:
            return os.lstat(path / last)
        except FileNotFoundError:
            return None

    def owns(self, name: str) -> bool:
        """Whether ``folder/name`` is a file unidyn wrote, as it wrote it."""
        hashes = self.files.get(name)
        st = self._lstat(name) if hashes else None
        if not st or not stat.S_ISREG(st.st_mode) or st.st_nlink != 1:
            return False
        digest = _digest(self.folder / name)
        if _hex(digest) not in hashes:
            return False
        self._proven[name] = digest
        return True

    def present(self) -> list:
        """The kind's names that are in the folder (files, folders or links), or that a
        link or a file stands in the way of."""
        return [n for n in self.names if self._lstat(n) is not None]

    def sort(self) -> tuple:
        """``(held, foreign)``: the names in the folder that are unidyn's, and those
        that are not (a user's files, edited results, links, folders)."""
        held, foreign = [], []
        for n in self.present():
            (held if self.owns(n) else foreign).append(n)
        return held, foreign

    def _save(self) -> None:
        text = json.dumps({"kind": self.kind, "id": self.id, "complete": self.complete,
                           "files": self.files}, indent=2)
        write_atomic(self.path, text + "\n")
        self.exists = True

    def _claim(self, name: str, digest) -> None:
        """Record ``digest`` as what ``name`` is about to hold, beside what it holds now
        (which must be unidyn's: a file of the user's is never replaced)."""
        if name not in self.names:
            raise ValueError(f"{name!r} is not a file of unidyn's {self.kind} results")
        now = self._current(name)
        self.files[name] = ([] if now is None else [_hex(now)]) + [_hex(digest)]

    def _current(self, name: str):
        """The running digest of what ``name`` holds now (None where there is nothing);
        a file there that unidyn cannot prove it wrote is refused, never changed."""
        if (name not in self._proven and os.path.lexists(self.folder / name)
                and not self.owns(name)):
            raise ValidationError(foreign_files(self.folder, [name], "results"))
        return self._proven.get(name)

    def _settle(self, name: str, digest) -> None:
        self.files[name] = [_hex(digest)]
        self._proven[name] = digest

    def replace(self, sources: dict, remove=(), as_set: bool = False) -> None:
        """Move finished files into place: ``sources`` maps a name to a file in this
        folder or a private folder inside it; ``remove`` names files of unidyn's to
        delete. With ``as_set``, the manifest says the results are incomplete until
        every file is in place (a set of files that belong together)."""
        digests = {n: _digest(src) for n, src in sources.items()}
        for n, d in digests.items():
            self._claim(n, d)
        if as_set:
            self.complete = False
        self._save()
        for n, src in sources.items():
            (self.folder / n).parent.mkdir(exist_ok=True)  # a result's own folder
            _move(Path(src), self.folder / n)
        for n in remove:
            self._unlink(n)
        for n, d in digests.items():
            self._settle(n, d)
        if as_set:
            self.complete = True
        self._save()

    def write_with(self, name: str, write) -> Path:
        """Have ``write(path)`` write the file at a temporary path beside it (with
        ``name``'s suffix, which a figure's format is read from), then move it into
        place as ``name``."""
        fd, tmp = tempfile.mkstemp(dir=self.folder, prefix=f"{_PREFIX}-tmp-",
                                   suffix=Path(name).suffix)
        os.close(fd)
        try:
            write(Path(tmp))
            umask = os.umask(0)
            os.umask(umask)
            os.chmod(tmp, 0o666 & ~umask)  # mkstemp creates 0600; give the usual mode
            self.replace({name: tmp})
        except BaseException:
            with contextlib.suppress(OSError):
                os.unlink(tmp)
            raise
        return self.folder / name

    def write(self, name: str, text: str) -> Path:
        """Write ``text`` as ``name``, atomically (a temporary file, then a rename)."""
        def put(path):
            with open(path, "w", newline="") as fh:
                fh.write(text)
        return self.write_with(name, put)

    def append(self, name: str, text: str) -> None:
        """Add ``text`` at the end of ``name`` (unidyn's, proven by :meth:`owns`), in one
        write, recording the content it will have before writing it."""
        before = self._current(name)
        if before is None:
            raise FileNotFoundError(f"{self.folder / name} does not exist: nothing to append to")
        data = text.encode()
        after = before.copy()
        after.update(data)
        self._claim(name, after)
        self._save()
        path = self.folder / name
        fd = os.open(path, os.O_WRONLY | os.O_APPEND)
        size = os.fstat(fd).st_size
        try:
            view = memoryview(data)
            while view:
                view = view[os.write(fd, view):]
            os.fsync(fd)
        except OSError as err:  # a full disk: back to what it held, which stays proven
            with contextlib.suppress(OSError):
                os.ftruncate(fd, size)
            raise OSError(err.errno, err.strerror, str(path)) from None
        finally:
            os.close(fd)
        self._settle(name, after)
        self._save()

    def _unlink(self, name: str) -> None:
        """Delete ``name`` if it is unidyn's, and its folder if that is left empty."""
        if self.owns(name):
            os.unlink(self.folder / name)
            if "/" in name:
                with contextlib.suppress(OSError):  # not empty: something of the user's
                    (self.folder / name).parent.rmdir()
        self.files.pop(name, None)
        self._proven.pop(name, None)

    def discard(self, name: str) -> None:
        """Delete ``name`` if it is unidyn's (anything else is left as it is)."""
        self._unlink(name)
        if self.files:
            self._save()
        elif self.exists:
            with contextlib.suppress(FileNotFoundError):
                os.unlink(self.path)
            self.exists = False


def foreign_files(folder, names, what: str, option: str = "--out") -> str:
    """The refusal for files with a result's name that unidyn cannot prove it wrote."""
    return (f"{folder} holds {', '.join(names)}, named like unidyn's {what} but not "
            f"written by unidyn as they are now (a file of yours, a link, a folder, or a "
            f"result edited since); unidyn never replaces or removes such files, with or "
            f"without overwriting: move them elsewhere or choose another {option}")


def check_manifest(folder, kind: str, names, files=()) -> str:
    """What is wrong with ``folder``'s results of ``kind`` ("" if nothing): a manifest
    unidyn did not write, a replacement cut short, or any of ``files`` not the file
    unidyn wrote. A folder without a manifest passes (nothing to compare)."""
    folder = Path(folder)
    try:
        ledger = Ledger(folder, kind, names)
    except ValidationError as err:
        return str(err)
    if not ledger.exists:
        return ""
    if not ledger.complete:
        return (f"{folder} holds {kind} results whose replacement was cut short (its files "
                f"may come from two runs)")
    for n in files:
        if os.path.lexists(folder / n) and not ledger.owns(n):
            return (f"{folder / n} is not the file its run wrote (it differs from "
                    f"{ledger.path.name}: another run's file, or edited)")
    return ""


_STAGE_MARK = ".unidyn-stage"  # inside a private folder: the token it was made with


def _make_stage(folder: Path, kind: str) -> tuple:
    """Make a private folder in ``folder`` (locked by this process) and prove it
    unidyn's: its random name and token are recorded in the lock before it exists, it
    is created exclusively (never an existing folder) and holds the token. Returns
    ``(path, token, identity)``."""
    if not re.fullmatch(r"[a-z0-9_]+", kind):
        raise ValueError(f"kind must be lowercase letters, digits or _, got {kind!r}")
    lock = _HELD.get(folder)
    for _ in range(100):
        token = secrets.token_hex(16)
        name = f"{_PREFIX}-{kind}-new-{token[:12]}"
        if lock is not None:
            lock.record(name, token)
        try:
            os.mkdir(folder / name, 0o700)
        except FileExistsError:  # someone else's, by chance: never touched
            if lock is not None:
                lock.forget(name)
            continue
        st = os.lstat(folder / name)
        fd = os.open(folder / name / _STAGE_MARK,
                     os.O_WRONLY | os.O_CREAT | os.O_EXCL | _NOFOLLOW, 0o600)
        try:
            os.write(fd, f"unidyn stage {token}\n".encode())
        finally:
            os.close(fd)
        return folder / name, token, (st.st_dev, st.st_ino)
    raise FileExistsError(f"cannot make a private folder in {folder}")  # pragma: no cover


def _remove_stage(path: Path, token: str, identity=None) -> None:
    """Remove a private folder only where it proves to be the one unidyn made with
    ``token``: a folder (not a link), the same one (``identity``, when known), holding
    the token. Its tree is removed without following a link inside (``shutil.rmtree``
    on file descriptors); anything else by that name is left as it is."""
    try:
        st = os.lstat(path)
        if not stat.S_ISDIR(st.st_mode) or (identity and (st.st_dev, st.st_ino) != identity):
            return
        fd = os.open(path / _STAGE_MARK, os.O_RDONLY | _NOFOLLOW)
        try:
            mark = os.read(fd, 100)
        finally:
            os.close(fd)
    except OSError:
        return
    if mark == f"unidyn stage {token}\n".encode():
        shutil.rmtree(path, ignore_errors=True)


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
def staged_output(out, *, kind: str, names, overwrite: bool, what: str = "results",
                  option: str = "--out", flag: str = "--overwrite", lock: bool = True):
    """Write a command's results into ``out`` (see the module docstring).

    :param out: the output folder (created if needed, with its parents)
    :param kind: names the manifest (``.unidyn-<kind>.json``): one per kind of result
    :param names: every file name this kind of result may have (plain names)
    :param overwrite: replace results that ``out`` already holds (a bool)
    :param what: what the results are, for messages ("run results")
    :param option: how the caller named ``out``, and ``flag`` how it asks to
        overwrite, for messages (``"--out"``, ``"--overwrite"`` on the command line)
    :param lock: hold ``out``'s :class:`FolderLock` (False: the caller holds it)
    :raises ValidationError: ``out`` is a file; it holds results and ``overwrite`` is
        false; it holds files with a result's name that unidyn did not write; its
        manifest is not one unidyn wrote. :class:`FolderInUse` if another process holds
        ``out``'s lock
    """
    final = output_folder(out, option)
    overwrite = _flag("overwrite" if flag.startswith("overwrite") else flag, overwrite)
    if final in _STAGES:  # called by code writing into a stage (save() by a command)
        yield Stage(final)
        return
    created = not final.exists()
    final.mkdir(parents=True, exist_ok=True)
    try:
        with (FolderLock(final, option) if lock else contextlib.nullcontext()):
            held, foreign = Ledger(final, kind, names).sort()
            if foreign:
                raise ValidationError(foreign_files(out, foreign, what, option))
            if held and not overwrite:
                raise ValidationError(f"{out} already holds {what} ({', '.join(held)}); pass "
                                      f"{flag} to replace them (they are kept until the new "
                                      f"{what} are complete) or choose another {option}")
            path, token, identity = _make_stage(final, kind)
            stage = Stage(path, held=tuple(held))
            _STAGES.add(stage.path)
            try:
                yield stage
                with _interrupts_deferred():
                    stage.final = _commit(stage, final, kind, names, what, option)
            except OSError as err:
                if err.errno in (errno.ENOSPC, errno.EDQUOT):
                    raise _disk_full(err, stage, out, final) from None
                raise
            finally:
                _STAGES.discard(stage.path)
                _remove_stage(stage.path, token, identity)
                if final in _HELD:
                    _HELD[final].forget(stage.path.name)
    except BaseException:
        if created:  # nothing was written: leave no empty folder behind
            with contextlib.suppress(OSError):
                final.rmdir()
        raise


def _commit(stage: Stage, out: Path, kind, names, what, option) -> Path:
    """Move the staged files into ``out`` (or ``<out>.incomplete``), remove the
    earlier result's files that the new one lacks, record them in the manifest."""
    target = out
    if stage.partial and stage.held:
        if out.parent == out:
            raise ValidationError(f"cannot keep the partial {what} beside {out}; {out} is "
                                  f"as it was")
        target = out.with_name(out.name + ".incomplete")
        made = _incomplete_place(target, kind, names, what, out)
    else:
        made = False
    try:
        ledger = Ledger(target, kind, names)
        held, foreign = ledger.sort()  # again: a file may have appeared while the run ran
        if foreign:
            raise ValidationError(foreign_files(target, foreign, what, option))
        new = _files_in(stage.path)
        stage.moving = True
        ledger.replace({n: stage.path / n for n in new},
                       remove=[n for n in held if n not in new], as_set=True)
    except BaseException:
        if made and not stage.moving:
            with contextlib.suppress(OSError):
                target.rmdir()
        raise
    return target


def _incomplete_place(target: Path, kind, names, what, out) -> bool:
    """Make ``<out>.incomplete`` (True), or prove the one there unidyn's (False): a
    folder, not a link, holding unidyn's manifest of ``kind``. Anything else by that
    name is refused, never written into or through."""
    try:
        os.mkdir(target)
        return True
    except FileExistsError:
        pass
    st = os.lstat(target)
    why = ("" if stat.S_ISDIR(st.st_mode) and Ledger(target, kind, names).exists
           else _kind_of(st) if not stat.S_ISDIR(st.st_mode)
           else f"a folder without unidyn's {_manifest_path(target, kind).name}")
    if why:
        raise ValidationError(f"{target} is {why}, not the folder unidyn keeps partial "
                              f"{what} in; it was left as it is, and so is {out} (the "
                              f"partial {what} were not written): move it elsewhere")
    return False


def _files_in(stage: Path) -> list:
    """The files written into a private folder, as names relative to it (``a.csv``,
    ``case1/summary.json``), leaving out this module's own (``.unidyn*``) at its top."""
    out = []
    for root, dirs, files in os.walk(stage):
        rel = Path(root).relative_to(stage)
        if rel == Path("."):
            dirs[:] = [d for d in dirs if not d.startswith(_PREFIX)]
            files = [f for f in files if not f.startswith(_PREFIX)]
        out += [(rel / f).as_posix() for f in files]
    return sorted(out)


def _move(src: Path, dst: Path) -> None:
    try:
        os.replace(src, dst)
    except OSError as err:  # another file system (<out>.incomplete beside a mount point)
        if err.errno != errno.EXDEV:
            raise
        fd, tmp = tempfile.mkstemp(dir=dst.parent, prefix=f"{_PREFIX}-tmp-")
        try:
            with os.fdopen(fd, "wb") as fh, open(src, "rb") as fs:
                shutil.copyfileobj(fs, fh)
            os.replace(tmp, dst)
        except BaseException as failed:
            with contextlib.suppress(OSError):
                os.unlink(tmp)
            if isinstance(failed, OSError) and failed.filename is None:
                raise OSError(failed.errno, failed.strerror, str(dst)) from failed
            raise


def _disk_full(err: OSError, stage: Stage, out, final: Path) -> OSError:
    """The full-disk error naming the file being written, how much of it was written
    and the space left, and what became of the results."""
    where = Path(err.filename) if err.filename else _newest(stage.path)
    size = None
    if where is not None:
        with contextlib.suppress(OSError):
            size = os.lstat(where).st_size
        if stage.path in where.parents:
            where = Path(out) / where.relative_to(stage.path)
    what = f"writing {where}" if where else f"writing into {out}"
    space = []
    if size:
        space.append(f"{_amount(size)} of it written")
    with contextlib.suppress(OSError):
        space.append(f"{_amount(shutil.disk_usage(final).free)} free")
    if space:
        what += f" ({', '.join(space)})"
    if stage.moving:
        kept = (f"the replacement was cut short, so {out} may hold files of both "
                f"results (its manifest says so); run the command again to write a "
                f"complete set")
    elif stage.held:
        kept = f"the earlier results in {out} are intact (nothing was replaced)"
    else:
        kept = f"nothing was written to {out}"
    return OSError(err.errno, f"{os.strerror(err.errno)} {what}; {kept}")


def _newest(folder: Path):
    """The file last written under ``folder`` (the one a write without a file name was
    filling), or None."""
    newest, when = None, -1
    for root, _, files in os.walk(folder):
        for f in files:
            p = Path(root) / f
            with contextlib.suppress(OSError):
                st = os.lstat(p)
                if stat.S_ISREG(st.st_mode) and f != _STAGE_MARK and st.st_mtime_ns > when:
                    newest, when = p, st.st_mtime_ns
    return newest


def _amount(n: int) -> str:
    """A number of bytes as a user reads it (``"812 kB"``)."""
    for unit, size in (("GB", 1e9), ("MB", 1e6), ("kB", 1e3)):
        if n >= size:
            return f"{n / size:.3g} {unit}"
    return f"{n} bytes"


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
