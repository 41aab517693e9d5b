"""Writing files the user asked for, touching nothing else: the one way unidyn writes.

A command (``unidyn run``, ``unidyn identify``, a sweep started over, a script) writes
its files into a private folder inside ``out`` and moves them into place only when it
has finished::

    with staged_output(out, kind="run", names=RUN_FILES, overwrite=args.overwrite,
                       what="run results") as stage:
        result.save(stage)                 # every file written into stage.path
        if not result.complete:
            stage.incomplete(result.message)
    print(f"written {stage.final}/")

A file outside a results folder (``unidyn run --bag run.mcap``) is an
:class:`OwnedFile`; a single file anywhere is written by :func:`write_file`. Their
parts: the folder's lock and the one way a file is written (an exclusive temporary
file, then a rename) are in :mod:`unidyn.results.ownership`, the manifests in
:mod:`unidyn.results.ledger`; this module puts them together.

What a user can rely on:

- **A file is unidyn's only when its content proves it.** Each folder unidyn writes
  in has a manifest, ``.unidyn-<kind>.json``, written *before* a file is created or
  changed: the file's name (one of the names that kind of command writes) and the
  SHA-256 of the content it is about to have. A file counts as unidyn's
  (:class:`Ledger`) only if such a manifest lists it and the file, a regular file with
  a single link, still has that content. Anything else with a result's name -- a
  user's ``path.png`` or recording, an edited ``summary.json``, a link -- is never
  replaced or removed, with or without ``overwrite``: the command refuses up front.
- **A manifest is untrusted input.** Every entry must be one of the kind's file names
  with a SHA-256; anything else is refused in one line naming the manifest and the
  entry, and nothing is changed. Nothing read from disk is removed as a tree.
- **unidyn's own scaffolding is proven too, never judged by name.** Its private
  folders (``.unidyn-<kind>-new-<random>``) and temporary files
  (``.unidyn-tmp-<random>``) are created exclusively, and recorded with a random
  token in the folder's lock (``.unidyn.lock``, a file unidyn creates and whose
  content it wrote) before they exist; a private folder also holds its token. What
  a killed process left is removed by the next command that takes the lock, and
  only what that record proves. A user's file, folder or link with any of these
  names -- or named ``<out>.incomplete`` -- is never changed or removed; where it is
  in the way, the command refuses in one line naming it. Links are never followed.
- **An interruption or an error changes nothing.** Ctrl-C, an exception, ``kill``
  or ``kill -9`` while the block runs leave ``out``'s files as they were.
- **Each file is replaced atomically, and the set is recorded.** The finished files
  are renamed into place one by one (``os.replace``), Ctrl-C and SIGTERM held back
  meanwhile; until the last one is in place the manifest says so, and a reader
  (:func:`check_manifest`) never takes files of two runs for one result.
- **Results are replaced only when asked** (``overwrite``, a bool).
- **One writer at a time.** The block holds ``out``'s :class:`FolderLock`.
- **A partial result never replaces a complete one.** After :meth:`Stage.incomplete`
  the files go to ``<out>.incomplete`` if ``out`` holds results, a folder checked
  before the work starts; an :class:`OwnedFile` is then not replaced at all.
- **Problems are found before the work**: ``out`` is made, locked and written into
  (its private folder) on entering the block; a link that loops, a file, a folder
  that cannot be made are refused in one line saying why.
- **A full disk** (:class:`DiskFull`) is reported naming the file being written, the
  space left, and what was kept, for every file written here.
"""

from __future__ import annotations

import contextlib
import errno
import math
import os
import re
import secrets
import stat
from dataclasses import dataclass, field
from pathlib import Path

from .._validate import ValidationError
from .._validate import flag as _flag
from ..process import finishes_on_sigterm
from .ledger import MAX_MANIFEST_BYTES, Ledger, _manifest_path, check_manifest, foreign_files
from .ownership import (
    _FULL,
    _NOFOLLOW,
    _PREFIX,
    _STAGE_MARK,
    _STAGE_NAME,
    LOCK_NAME,
    DiskFull,
    FolderInUse,
    FolderLock,
    _kind_of,
    _remove_made,
    disk_full,
    list_files,
    write_atomic,
    write_file,
)

__all__ = ["Stage", "staged_output", "Claim", "claimed_folder", "OwnedFile", "Ledger", "FolderLock", "FolderInUse",
           "DiskFull", "LOCK_NAME", "MAX_MANIFEST_BYTES", "check_manifest", "foreign_files",
           "output_folder", "make_output_folder", "write_file", "write_atomic", "disk_full", "json_ready",
           "list_files"]


def output_folder(out, option: str = "--out") -> Path:
    """``out`` as an absolute path with symbolic links followed; one line of refusal
    for an empty name, a file, or a link that loops."""
    if str(out) == "":
        raise ValidationError(f"{option} is empty; give a folder ({option} . for the "
                              f"current one)")
    try:
        path = Path(os.path.realpath(os.fspath(out), strict=os.path.lexists(out)))
    except OSError as err:
        why = ("is a symbolic link that leads back to itself" if err.errno == errno.ELOOP
               else f"cannot be followed ({err.strerror})")
        raise ValidationError(f"{option} {out} {why}; give a folder") from None
    if path.exists() and not path.is_dir():
        raise ValidationError(f"{option} {out} is a file, not a folder")
    return path


def make_output_folder(out, option: str = "--out") -> bool:
    """Make the folder ``out`` (links followed, :func:`output_folder`) and its parents;
    True if it was made. One line saying why where it cannot be."""
    path = output_folder(out, option)
    if path.is_dir():
        return False
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError as err:
        raise ValidationError(f"{option} {out}: cannot make the folder {err.filename or path}"
                              f" ({err.strerror or err})") from None
    return True


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


def _make_stage(lock: FolderLock, kind: str) -> tuple:
    """Make a private folder in ``lock``'s folder and prove it unidyn's: its random name
    and token are recorded in the lock before it exists, it is created exclusively
    (never an existing folder) and holds the token. Returns ``(path, token, identity)``."""
    if not re.fullmatch(r"[a-z0-9_]+", kind):
        raise ValueError(f"kind must be lowercase letters, digits or _, got {kind!r}")
    for _ in range(100):
        token = secrets.token_hex(16)
        path = lock.folder / f"{_PREFIX}-{kind}-new-{token[:12]}"
        lock.record(path.name, token)
        try:
            os.mkdir(path, 0o700)
        except FileExistsError:  # someone else's, by chance: never touched
            lock.forget(path.name)
            continue
        except OSError as err:
            lock.forget(path.name)
            raise ValidationError(f"{lock.option} {lock.folder} cannot be written "
                                  f"({err.strerror}): unidyn writes its files there") from None
        st = os.lstat(path)
        fd = os.open(path / _STAGE_MARK, os.O_WRONLY | os.O_CREAT | os.O_EXCL | _NOFOLLOW, 0o600)
        try:
            os.write(fd, f"unidyn stage {token}\n".encode())
        finally:
            os.close(fd)
        return path, token, (st.st_dev, st.st_ino)
    raise FileExistsError(f"cannot make a private folder in {lock.folder}")  # pragma: no cover


def _drop_stage(lock: FolderLock, path: Path, token: str, identity) -> None:
    _remove_made(path, token, identity)
    lock.forget(path.name)


@dataclass
class Stage:
    """The private folder of one :func:`staged_output` block.

    :ivar path: the folder to write into (inside ``out``)
    :ivar lock: ``out``'s :class:`FolderLock`, held for the block
    :ivar held: the result files ``out`` held before (to be replaced)
    :ivar final: after the block, where the files are (``out``, or
        ``<out>.incomplete`` for a partial result beside complete ones)
    :ivar partial: why the results are partial ("" when complete)
    :ivar moving: files are being (or were) moved into place
    """

    path: Path
    lock: FolderLock | None = field(default=None, repr=False)
    held: tuple = ()
    final: Path | None = None
    partial: str = ""
    moving: bool = False

    def incomplete(self, reason: str) -> None:
        """Mark what was written as partial (a run that stopped early)."""
        self.partial = str(reason) or "incomplete"


@contextlib.contextmanager
def staged_output(out, *, kind: str, names, overwrite: bool, what: str = "results",
                  option: str = "--out", flag: str = "--overwrite", lock=None):
    """Write a command's results into ``out`` (see the module docstring).

    :param out: the output folder (created if needed, with its parents)
    :param kind: names the manifest (``.unidyn-<kind>.json``): one per kind of result
    :param names: every file name this kind of result may have (plain names)
    :param overwrite: replace results that ``out`` already holds (a bool)
    :param what: what the results are, for messages ("run results")
    :param option: how the caller named ``out``, and ``flag`` how it asks to
        overwrite, for messages (``"--out"``, ``"--overwrite"`` on the command line)
    :param lock: ``out``'s :class:`FolderLock` where the caller holds it (else the
        block takes it)
    :raises ValidationError: ``out`` cannot be made or written, or is a file; it holds
        results and ``overwrite`` is false; it holds files with a result's name that
        unidyn did not write; its manifest is not one unidyn wrote; ``<out>.incomplete``
        is not unidyn's. :class:`FolderInUse` if another process holds ``out``'s lock
    """
    final = output_folder(out, option)
    overwrite = _flag("overwrite" if flag.startswith("overwrite") else flag, overwrite)
    if _STAGE_NAME.match(final.name) and os.path.lexists(final / _STAGE_MARK):
        raise ValueError(f"{final} is the private folder of a staged_output block: write "
                         f"into it directly (pass the Stage), not through another block")
    created = make_output_folder(out, option)
    try:
        with (FolderLock(final, option) if lock is None else contextlib.nullcontext(lock)) \
                as held_lock:
            if held_lock.folder != final:
                raise ValueError(f"the lock given is on {held_lock.folder}, not {final}")
            held, foreign = Ledger(final, kind, names).sort()
            if foreign:
                raise ValidationError(foreign_files(out, foreign, what, option))
            if held and not overwrite:
                raise ValidationError(f"{out} already holds {what} ({list_files(held)}); pass "
                                      f"{flag} to replace them (they are kept until the new "
                                      f"{what} are complete) or choose another {option}")
            if held:  # where a partial result would go: checked before the work
                _incomplete_place(final, kind, names, what, make=False)
            path, token, identity = _make_stage(held_lock, kind)
            stage = Stage(path, held_lock, held=tuple(held))
            try:
                yield stage
                with _interrupts_deferred():
                    stage.final = _commit(stage, final, kind, names, what, option)
            except OSError as err:
                if err.errno not in _FULL:
                    raise
                where, kept, size = _disk_full(err, stage, out)  # while the stage is there
                _drop_stage(held_lock, path, token, identity)  # then the space it freed
                raise DiskFull(err.errno, where, kept, size) from None
            finally:
                _drop_stage(held_lock, path, token, identity)
    except BaseException:
        if created:  # nothing was written: leave no empty folder behind
            with contextlib.suppress(OSError):
                final.rmdir()
        raise


@dataclass
class Claim:
    """An output folder held for a command's results (:func:`claimed_folder`).

    :ivar path: where the files are written: the folder itself, or the private folder
        of a replacement (moved into place when the block ends)
    :ivar lock: the folder's :class:`FolderLock`
    :ivar staged: whether ``path`` is the private folder of a replacement
    """

    path: Path
    lock: FolderLock
    staged: bool


@contextlib.contextmanager
def claimed_folder(out, *, kind: str, names, replace, what: str = "results",
                   option: str = "--out"):
    """Hold ``out`` for results of ``kind`` (file ``names``) that are either written
    into it as they come (a run that resumes, or a folder with nothing to lose) or
    replace what it holds once they are complete; yields a :class:`Claim`.

    ``out`` is made if needed and locked for the block; files with a result's name that
    unidyn cannot prove it wrote are refused up front (:func:`foreign_files`); then
    ``replace(folder)``, called under the lock, says which: False writes in place,
    True stages the results as :func:`staged_output` does, moving them into place only
    when the block has finished (an error or an interrupt leaves ``out`` as it was). It
    may raise to refuse. A folder made here is removed again if the block fails and it
    is empty."""
    final = output_folder(out, option)
    created = make_output_folder(out, option)  # one line where it cannot be made
    with FolderLock(final, option) as lock:
        try:
            held, foreign = Ledger(final, kind, names).sort()
            if foreign:
                raise ValidationError(foreign_files(out, foreign, what, option))
            if not replace(final):
                yield Claim(final, lock, staged=False)
                return
            with staged_output(final, kind=kind, names=names, overwrite=True, what=what,
                               option=option, lock=lock) as stage:
                yield Claim(stage.path, lock, staged=True)
        except BaseException:
            if created:
                lock.release()
                with contextlib.suppress(OSError):
                    final.rmdir()
            raise


def _commit(stage: Stage, out: Path, kind, names, what, option) -> Path:
    """Move the staged files into ``out`` (or ``<out>.incomplete``), remove the
    earlier result's files that the new one lacks, record them in the manifest."""
    target, made = out, False
    if stage.partial and stage.held:
        target, made = _incomplete_place(out, kind, names, what, make=True)
    try:
        ledger = Ledger(target, kind, names, stage.lock if target == out else None)
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


def _incomplete_place(out: Path, kind, names, what, make: bool) -> tuple:
    """``(<out>.incomplete, made)``: the folder a partial result goes to beside complete
    ones, made now (``make``) or proven unidyn's: a folder, not a link, holding
    unidyn's manifest of ``kind``. Anything else by that name is refused, never written
    into or through; so is a folder whose parent cannot hold it."""
    def refuse(why):
        return ValidationError(f"{target} is {why}; unidyn keeps there the partial {what} "
                               f"of a run that stops early, and {out} is kept as it was: "
                               f"move it elsewhere or choose another folder (nothing was "
                               f"run)" if not make else
                               f"{target} is {why}: the partial {what} were not written, "
                               f"and {out} is as it was")
    if out.parent == out:
        target = out
        raise refuse("the root of the file system, with no folder beside it")
    target = out.with_name(out.name + ".incomplete")
    try:
        st = os.lstat(target)
    except FileNotFoundError:
        if not make:
            if not os.access(out.parent, os.W_OK | os.X_OK):
                raise refuse(f"not there and {out.parent} cannot be written") from None
            return target, False
        os.mkdir(target)
        return target, True
    if not stat.S_ISDIR(st.st_mode):
        raise refuse(f"{_kind_of(st)}, not the folder unidyn makes")
    try:
        ledger = Ledger(target, kind, names)
    except ValidationError as err:
        raise refuse(f"a folder whose manifest unidyn did not write ({err})") from None
    if not ledger.exists:
        raise refuse(f"a folder without unidyn's {_manifest_path(target, kind).name}, not "
                     f"one unidyn made")
    return target, False



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


def _disk_full(err: OSError, stage: Stage, out) -> tuple:
    """For the full-disk error: ``(file, kept, size)``, the file being written (as it
    will be named in ``out``), what became of the results, and how much of the file was
    written."""
    where = getattr(err, "path", None) or (Path(err.filename) if err.filename else None)
    if where is None or where.name.startswith(f"{_PREFIX}-tmp-"):
        where = _newest(stage.path) or where
    size = None
    if where is not None and stage.path in where.parents:
        with contextlib.suppress(OSError):
            size = os.lstat(where).st_size
        where = Path(out) / where.relative_to(stage.path)
    if stage.moving:
        kept = (f"the replacement was cut short, so {out} may hold files of both "
                f"results (its manifest says so); run the command again to write a "
                f"complete set")
    elif stage.held:
        kept = f"the earlier results in {out} are intact (nothing was replaced)"
    else:
        kept = f"nothing was written to {out}"
    return where or Path(out), kept, getattr(err, "written", None) or size


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



class OwnedFile:
    """One file unidyn writes outside a results folder, where the user named it (the
    recording of ``unidyn run --bag run.mcap``), under the same rules as a results
    folder's files. Checked when made, before the work: a name that is a link, a
    folder, or a file unidyn cannot prove it wrote (a recording of the user's) is
    refused in one line, with or without ``overwrite``; one unidyn wrote -- its
    SHA-256 recorded in the folder's manifest ``.unidyn-<kind>.json`` -- is replaced
    only with ``overwrite``, and never by an incomplete result (:meth:`write`).

    :param path: the file (its folder's links followed, never the file's own)
    :param kind: names the manifest, ``"bag"``
    :param pattern: a compiled pattern every such file name matches
    :param overwrite: replace the file if unidyn wrote it
    :param option: how the caller named the file, and ``flag`` how it asks to
        overwrite, for messages
    """

    def __init__(self, path, *, kind: str, pattern, overwrite: bool, option: str,
                 flag: str = "--overwrite"):
        self.given, self.kind, self.pattern = Path(path), kind, pattern
        self.option, self.flag = option, flag
        if not pattern.fullmatch(self.given.name):
            raise ValidationError(f"{option} {str(path)[:80]!r} is not a file name unidyn "
                                  f"writes (one matching {pattern.pattern})")
        parent = self.given.parent
        if not parent.is_dir():
            raise ValidationError(f"{option} {path}: folder {parent} does not exist")
        self.folder = Path(os.path.realpath(parent))
        self.path = self.folder / self.given.name
        self.held = self._check(overwrite)
        self.overwrite = overwrite

    def _check(self, overwrite: bool) -> bool:
        """Whether the file is there and unidyn's (refusing anything else)."""
        try:
            st = os.lstat(self.path)
        except FileNotFoundError:
            return False
        ledger = Ledger(self.folder, self.kind, self.pattern)
        if not stat.S_ISREG(st.st_mode) or not ledger.owns(self.path.name):
            what = (_kind_of(st) if not stat.S_ISREG(st.st_mode) or st.st_nlink != 1
                    else "a file unidyn did not write as it is now")
            raise ValidationError(f"{self.option} {self.given} is {what} (see "
                                  f"{ledger.path.name} in {self.folder}); unidyn never "
                                  f"replaces it, with or without {self.flag}: choose "
                                  f"another {self.option} name")
        if not overwrite:
            raise ValidationError(f"{self.option} {self.given} already exists (unidyn wrote "
                                  f"it); pass {self.flag} to replace it, or choose another "
                                  f"{self.option} name")
        return True

    def write(self, write, complete: bool = True) -> bool:
        """Have ``write(folder)`` write the file into a private folder and return its
        path there; move it into place. An incomplete result (``complete`` false)
        does not replace a file unidyn wrote: nothing is written then (False)."""
        with FolderLock(self.folder, self.option) as lock:
            self.held = self._check(self.overwrite)  # again: time has passed
            if self.held and not complete:
                return False
            path, token, identity = _make_stage(lock, self.kind)
            try:
                ledger = Ledger(self.folder, self.kind, self.pattern, lock)
                written = Path(write(path))
                with _interrupts_deferred():
                    ledger.replace({self.path.name: written})
            except OSError as err:
                kept = (f"the earlier {self.given} is as it was" if self.held
                        else f"no {self.given} was written")
                _drop_stage(lock, path, token, identity)  # the space it held is free again
                raise disk_full(err, kept, self.given) from None
            finally:
                _drop_stage(lock, path, token, identity)
        return True


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
