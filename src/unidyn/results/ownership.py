"""What unidyn makes and proves its own in a folder it writes: the folder's lock
(:class:`FolderLock`, which records the private folders and temporary files its
holder makes, so that those a killed process left are removed by the next one), and
the one way a file is written (:func:`write_file`: an exclusive temporary file beside
it, then a rename; a full disk a :class:`DiskFull` naming the file, the space left
and what was kept). See :mod:`unidyn.results.folders` for the rules."""

from __future__ import annotations

import contextlib
import errno
import os
import re
import secrets
import shutil
import stat
from pathlib import Path

from .._validate import ValidationError

__all__ = ["FolderLock", "FolderInUse", "DiskFull", "LOCK_NAME", "disk_full", "write_file",
           "write_atomic", "list_files", "FILES_SHOWN"]

#: How many file names a message shows of a longer list (:func:`list_files`).
FILES_SHOWN = 3


def list_files(names, shown: int = FILES_SHOWN) -> str:
    """File names for a one-line message: all of them when there are at most ``shown``
    + 1 (``"theta.json, validation.json"``), else their number and ``shown`` examples,
    of different kinds where there are (``"31 files, e.g. runs.csv, summary.json,
    metrics.png"``); "" for none."""
    names = [str(n) for n in names]
    if len(names) <= shown + 1:
        return ", ".join(names)
    examples, kinds = [], set()
    for n in names:  # one of each suffix first, then the rest in order
        if Path(n).suffix not in kinds and len(examples) < shown:
            kinds.add(Path(n).suffix)
            examples.append(n)
    examples += [n for n in names if n not in examples][:shown - len(examples)]
    return f"{len(names)} files, e.g. {', '.join(sorted(examples, key=names.index))}"


#: The lock file that marks a folder as being written by a unidyn process.
LOCK_NAME = ".unidyn.lock"
_PREFIX = ".unidyn"  # the lock, manifests, private folders, temporaries: never a result
_SHA256 = re.compile(r"sha256:[0-9a-f]{64}\Z")
_STAGE_NAME = re.compile(r"\.unidyn-[a-z0-9_]+-new-[0-9a-f]{12}\Z")
_TMP_NAME = r"\.unidyn-tmp-[0-9a-f]{12}(?:\.[A-Za-z0-9]{1,8})?"
#: What unidyn writes in its lock: its token and PID, then a line per private folder
#: or temporary file it is about to make (the record by which the next command
#: removes one a killed process left, and nothing else)
_LOCK_TEXT = re.compile(r"unidyn lock [0-9a-f]{32}\npid [0-9]+\n(?:(?:stage \.unidyn-[a-z0-9_]+"
                        rf"-new-[0-9a-f]{{12}}|temp {_TMP_NAME}) [0-9a-f]{{32}}\n)*\Z")
_RECORD_LINE = re.compile(r"^(?:stage|temp) (\S+) ([0-9a-f]{32})$", re.M)
_MAX_LOCK_BYTES = 1 << 14
_NOFOLLOW = getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_NONBLOCK", 0)  # (not on Windows)
_FULL = (errno.ENOSPC, errno.EDQUOT)


_STAGE_MARK = ".unidyn-stage"  # inside a private folder: the token it was made with


class FolderInUse(ValidationError):
    """Another process is writing the output folder (it holds the folder's lock)."""


class DiskFull(OSError):
    """A write that failed for lack of space; its message names the file, the space
    left and what was kept (``path`` and ``kept`` hold the last two)."""

    def __init__(self, err_no: int, path, kept: str, written: int | None = None):
        self.path, self.kept, self.written = Path(path), kept, written
        said = ["quota exceeded"] if err_no == errno.EDQUOT else []
        if written:
            said.append(f"{_amount(written)} of it written")
        for folder in (self.path.parent, *self.path.parents):
            with contextlib.suppress(OSError):
                said.append(f"{_amount(shutil.disk_usage(folder).free)} free")
                break
        where = f" ({', '.join(said)})" if said else ""
        super().__init__(err_no, f"{os.strerror(err_no)} writing {self.path}{where}; {kept}")


def disk_full(err: OSError, kept: str, path=None, written: int | None = None) -> OSError:
    """``err`` as a :class:`DiskFull` naming ``path`` (or the file ``err`` names) and
    saying ``kept``; any other error as it is."""
    if err.errno not in _FULL:
        return err
    where = path or getattr(err, "path", None) or err.filename
    written = getattr(err, "written", None) if written is None else written
    return DiskFull(err.errno, where, kept, written) if where else err


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
    line naming it. The lock records the private folders and temporary files its
    holder makes in the folder, so that those a killed process left are removed by
    the next one to take the lock, and only those.

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
        self.made: dict = {}  # private folder or temporary's name -> (kind, token)
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
        for name, (_, token) in list(self.made.items()):  # recorded by a killed holder
            _remove_made(self.folder / name, token)
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
        died holding it), take over its record, write ours."""
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
            self.made = {m.group(1): (m.group(0).split()[0], m.group(2))
                         for m in _RECORD_LINE.finditer(text)}
        self._fd, self._id = fd, (st.st_dev, st.st_ino)
        self._write()

    def _write(self) -> None:
        text = f"unidyn lock {self.token}\npid {os.getpid()}\n" + "".join(
            f"{k} {n} {t}\n" for n, (k, t) in self.made.items())
        os.ftruncate(self._fd, 0)
        os.lseek(self._fd, 0, os.SEEK_SET)
        os.write(self._fd, text.encode("ascii"))

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
        """Record a private folder or temporary file about to be made (before it exists)."""
        if self._fd is None:
            raise RuntimeError(f"the lock on {self.folder} is not held")
        self.made[name] = ("stage" if _STAGE_NAME.match(name) else "temp", token)
        self._write()

    def forget(self, name: str) -> None:
        """Drop a name from the record (removed, moved into place, or never made)."""
        if self.made.pop(name, None) is not None and self._fd is not None:
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

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.release()


def _remove_made(path: Path, token: str, identity=None) -> None:
    """Remove what unidyn made as ``path`` with ``token``, where it proves to be that:
    a private folder (not a link; the same one, ``identity``, when known) holding the
    token, removed without following a link inside (``shutil.rmtree`` on file
    descriptors); a temporary file, regular with one link, whose name carries the
    token. Anything else by that name is left as it is."""
    try:
        st = os.lstat(path)
        if identity and (st.st_dev, st.st_ino) != identity:
            return
        if re.fullmatch(_TMP_NAME, path.name):
            if (stat.S_ISREG(st.st_mode) and st.st_nlink == 1
                    and path.name[len(_PREFIX) + 5:].startswith(token[:12])):
                os.unlink(path)
            return
        if not stat.S_ISDIR(st.st_mode):
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


@contextlib.contextmanager
def _temporary(folder: Path, suffix: str = "", lock: FolderLock | None = None):
    """A new temporary file in ``folder`` for the caller to fill and move into place:
    created exclusively (never an existing file or link), named with a random token
    (``.unidyn-tmp-<token>``, and ``suffix``, from which a figure's format is read),
    recorded in ``lock`` when the caller holds one, with the mode of any new file
    (the umask applies); removed if it is still there when the block ends."""
    if not re.fullmatch(r"(?:\.[A-Za-z0-9]{1,8})?", suffix):
        suffix = ""
    for _ in range(100):
        token = secrets.token_hex(16)
        path = folder / f"{_PREFIX}-tmp-{token[:12]}{suffix}"
        if lock is not None:
            lock.record(path.name, token)
        try:
            os.close(os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL | _NOFOLLOW, 0o666))
            break
        except FileExistsError:  # someone else's, by chance: never touched
            if lock is not None:
                lock.forget(path.name)
    else:  # pragma: no cover
        raise FileExistsError(f"cannot make a temporary file in {folder}")
    try:
        yield path
    finally:
        with contextlib.suppress(OSError):
            os.unlink(path)  # gone already once moved into place
        if lock is not None:
            lock.forget(path.name)


def write_file(path, write, lock: FolderLock | None = None, kept=None, place=None) -> Path:
    """Write one file: ``write(tmp)`` fills a temporary file beside ``path`` (see
    :func:`_temporary`), which ``place(tmp)`` then moves into place (by default a rename
    to ``path``), so an interrupted write never leaves a half-written file that looks
    complete. An error names ``path``; a full disk is a :class:`DiskFull` saying
    ``kept()`` (by default, whether ``path`` is as it was or was not written).
    Returns ``path``."""
    path, size = Path(path), None
    try:
        with _temporary(path.parent, path.suffix, lock) as tmp:
            try:
                write(tmp)
            except OSError:
                with contextlib.suppress(OSError):
                    size = os.lstat(tmp).st_size
                raise
            if place is None:
                os.replace(tmp, path)
            else:
                place(tmp)
    except OSError as err:
        if err.errno in _FULL:
            said = kept() if kept else (f"{path} is as it was" if os.path.lexists(path)
                                        else f"{path} was not written")
            raise disk_full(err, said, path, size) from None
        if err.filename is None:  # a write: name the file
            raise OSError(err.errno, err.strerror, str(path)) from err
        raise
    return path


def write_atomic(path, text: str, more=(), lock: FolderLock | None = None) -> None:
    """Write ``text`` (then each string of the iterable ``more``) to ``path`` with
    :func:`write_file`."""
    def put(tmp):
        with open(tmp, "w", newline="", encoding="utf-8") as fh:
            fh.write(text)
            for chunk in more:
                fh.write(chunk)
    write_file(path, put, lock)



def _amount(n: int) -> str:
    """A number of bytes as a user reads it (``"812 kB"``)."""
    for unit, size in (("GB", 1e9), ("MB", 1e6), ("kB", 1e3)):
        if n >= size:
            return f"{n / size:.3g} {unit}"
    return f"{n} bytes"

