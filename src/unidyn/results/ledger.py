"""The manifests by which unidyn proves, by content, which files of a folder it wrote
(:class:`Ledger`); see :mod:`unidyn.results.folders` for the rules."""

from __future__ import annotations

import contextlib
import errno
import hashlib
import json
import os
import re
import shutil
import stat
import uuid
from pathlib import Path

from .._validate import ValidationError
from .ownership import (
    _FULL,
    _PREFIX,
    _SHA256,
    FolderLock,
    disk_full,
    list_files,
    write_atomic,
    write_file,
)

__all__ = ["Ledger", "check_manifest", "foreign_files", "MAX_MANIFEST_BYTES"]

#: The largest manifest read: one lists a handful of names and hashes.
MAX_MANIFEST_BYTES = 1 << 16


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
    :param kind: ``"run"``, ``"identify"``, ``"sweep"``, ``"bag"``: one manifest per kind
    :param names: every file name this kind of command writes (``"summary.json"``; a
        file in a result's own folder as ``"case1/summary.json"``), or a compiled
        pattern plain names must match (a bag's ``*.mcap``); a manifest listing
        anything else is refused
    :param lock: the folder's :class:`FolderLock`, held by the caller: temporary files
        are recorded in it
    :raises ValidationError: the manifest is not one unidyn could have written
    """

    def __init__(self, folder, kind: str, names, lock: FolderLock | None = None):
        self.folder, self.kind, self.lock = Path(folder), kind, lock
        self.names = names if isinstance(names, re.Pattern) else tuple(names)
        self.path = _manifest_path(self.folder, kind)
        self.files: dict = {}
        self.complete = True
        self.id = uuid.uuid4().hex
        self.exists = os.path.lexists(self.path)
        self._proven: dict = {}  # name -> running digest of the content it was proven by
        if self.exists:
            self._load()

    def _allowed(self, name) -> bool:
        if isinstance(self.names, tuple):
            return name in self.names
        return isinstance(name, str) and "/" not in name and bool(self.names.fullmatch(name))

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
            if not self._allowed(name):
                allowed = (list_files(self.names) if isinstance(self.names, tuple)
                           else f"names matching {self.names.pattern}")
                raise self._refuse(f"lists {name!r}, which is not a file unidyn {self.kind} "
                                   f"writes (those are {allowed})")
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
        names = self.names if isinstance(self.names, tuple) else list(self.files)
        return [n for n in names if self._lstat(n) is not None]

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
        write_atomic(self.path, text + "\n", lock=self.lock)
        self.exists = True

    def _claim(self, name: str, digest) -> None:
        """Record ``digest`` as what ``name`` is about to hold, beside what it holds now
        (which must be unidyn's: a file of the user's is never replaced)."""
        if not self._allowed(name):
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
            _move(Path(src), self.folder / n, self.lock)
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
        place as ``name``. A full disk is a :class:`DiskFull` naming the file."""
        target = self.folder / name
        return write_file(target, write, self.lock, place=lambda tmp: self.replace({name: tmp}),
                          kept=lambda: (f"{target} is as it was" if self.owns(name)
                                        else f"{target} was not written"))

    def write(self, name: str, text: str) -> Path:
        """Write ``text`` as ``name``, atomically (a temporary file, then a rename)."""
        def put(path):
            with open(path, "w", newline="") as fh:
                fh.write(text)
        return self.write_with(name, put)

    def append(self, name: str, text: str) -> None:
        """Add ``text`` at the end of ``name`` (unidyn's, proven by :meth:`owns`), in one
        write, recording the content it will have before writing it. A full disk leaves
        the file as it was (a :class:`DiskFull`)."""
        before = self._current(name)
        if before is None:
            raise FileNotFoundError(f"{self.folder / name} does not exist: nothing to append to")
        data = text.encode()
        after = before.copy()
        after.update(data)
        self._claim(name, after)
        path = self.folder / name
        try:
            self._save()
        except OSError as err:
            raise disk_full(err, f"{path} is as it was", self.path) from None
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
            if err.errno not in _FULL:
                raise OSError(err.errno, err.strerror, str(path)) from None
            raise disk_full(err, f"{path} is as it was", path) from None
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
    return (f"{folder} holds {list_files(names)}, named like unidyn's {what} but not "
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



def _move(src: Path, dst: Path, lock: FolderLock | None = None) -> None:
    try:
        os.replace(src, dst)
    except OSError as err:  # another file system (<out>.incomplete beside a mount point)
        if err.errno != errno.EXDEV:
            raise

        def copy(tmp):
            with open(tmp, "wb") as fh, open(src, "rb") as fs:
                shutil.copyfileobj(fs, fh)
        write_file(dst, copy, lock)

