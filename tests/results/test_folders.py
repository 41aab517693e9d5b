"""Output folders (unidyn.results.folders): refusals, interruptions, partial results, foreign
files, manifests, the lock, and processes killed at random moments."""

import json
import os
import random
import re
import signal
import subprocess
import sys
import textwrap
import time

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from unidyn import ValidationError
from unidyn.results import folders as outdir
from unidyn.results.folders import staged_output

RESULTS = ("summary.json", "timeseries.csv")
#: every name the tests' results may have
NAMES = RESULTS + ("extra.csv", "animation.gif", "a.csv", "b.csv")


def staged(out, **kw):
    kw.setdefault("kind", "results")
    kw.setdefault("names", NAMES)
    return staged_output(out, **kw)


def _save(out, generation, names=RESULTS):
    """Results written by unidyn (through a staged block): proven by the manifest."""
    with staged(out, overwrite=True) as st:
        _write(st.path, generation, names)


def _write(folder, generation, names=RESULTS):
    for n in names:
        (folder / n).write_text(json.dumps({"generation": generation, "file": n}))


def _generations(folder):
    return {json.loads((folder / n).read_text())["generation"] for n in RESULTS
            if (folder / n).exists()}


def _siblings(tmp_path, out):
    return sorted(p.name for p in tmp_path.iterdir() if p.name != out.name)


def _private(out):
    """What a writer keeps for itself in ``out`` while it works (its folders, the
    lock): nothing once it is done."""
    return sorted(p.name for p in out.iterdir() if p.name.startswith(".unidyn")
                  and not p.name.endswith("-results.json"))


def test_fresh_folder_is_created_with_the_usual_mode_and_a_manifest(tmp_path):
    out = tmp_path / "a" / "b"
    with staged(out, overwrite=False) as st:
        assert st.path.parent == out and st.path.name.startswith(".unidyn-results-new-")
        _write(st.path, 1)
    assert _generations(out) == {1} and st.final == out.absolute()
    umask = os.umask(0)
    os.umask(umask)
    assert (out.stat().st_mode & 0o777) == (0o777 & ~umask)
    assert _siblings(tmp_path / "a", out) == [] and _private(out) == []
    manifest = json.loads((out / ".unidyn-results.json").read_text())
    assert manifest["complete"] is True and sorted(manifest["files"]) == sorted(RESULTS)
    assert outdir.check_manifest(out, "results", NAMES, RESULTS) == ""


def test_existing_results_need_overwrite_and_the_message_names_them(tmp_path):
    out = tmp_path / "out"
    _save(out, 1)
    with pytest.raises(ValidationError, match=r"summary\.json, timeseries\.csv.*--overwrite"):
        with staged(out, overwrite=False, what="run results"):
            pytest.fail("the block must not run")
    with pytest.raises(ValidationError, match=r"pass overwrite=True .* another folder"):
        with staged(out, overwrite=False, option="folder",
                           flag="overwrite=True"):
            pytest.fail("the block must not run")
    assert _generations(out) == {1} and _siblings(tmp_path, out) == []


def test_a_file_or_an_empty_name_is_not_a_folder(tmp_path):
    out = tmp_path / "out"
    out.write_text("x")
    with pytest.raises(ValidationError, match="--out .* is a file"):
        with staged(out, overwrite=True):
            pass
    with pytest.raises(ValidationError, match=r"--out is empty; .*--out \. for the current"):
        with staged("", overwrite=True):
            pass


@pytest.mark.parametrize("exc", [RuntimeError("boom"), KeyboardInterrupt()])
def test_an_error_or_ctrl_c_inside_leaves_the_old_results(tmp_path, exc):
    out = tmp_path / "out"
    _save(out, 1)
    with pytest.raises(type(exc)):
        with staged(out, overwrite=True) as st:
            _write(st.path, 2)
            raise exc
    assert _generations(out) == {1}
    assert _siblings(tmp_path, out) == [] and _private(out) == []  # private folder removed


def test_overwrite_replaces_the_results_files_and_keeps_foreign_ones(tmp_path):
    out = tmp_path / "out"
    (out / "notes").mkdir(parents=True)
    (out / "README.txt").write_text("mine")
    (out / "notes" / "n.txt").write_text("also mine")
    _save(out, 1, names=RESULTS + ("animation.gif",))
    with staged(out, overwrite=True) as st:
        assert st.held == ("summary.json", "timeseries.csv", "animation.gif")
        _write(st.path, 2)
    assert _generations(out) == {2}
    assert not (out / "animation.gif").exists()  # last run's artefact does not survive
    assert (out / "README.txt").read_text() == "mine"
    assert (out / "notes" / "n.txt").read_text() == "also mine"
    assert _siblings(tmp_path, out) == []
    assert sorted(p.name for p in out.iterdir()) == sorted(
        [".unidyn-results.json", "README.txt", "notes", *RESULTS])


def test_files_named_like_results_that_unidyn_did_not_write_are_never_touched(tmp_path):
    """Ownership is proven by content: a user's file with a result's name, an edited
    result, a link or a folder by that name is refused with or without overwrite."""
    out = tmp_path / "out"
    out.mkdir()
    (out / "animation.gif").write_bytes(b"my own gif")
    for overwrite in (False, True):
        with pytest.raises(ValidationError, match=r"animation\.gif, named like unidyn's "
                           r"results but not written by unidyn.*move them elsewhere"):
            with staged(out, overwrite=overwrite):
                pytest.fail("the block must not run")
    assert (out / "animation.gif").read_bytes() == b"my own gif"
    (out / "animation.gif").unlink()
    _save(out, 1)
    (out / "summary.json").write_text("edited by hand")  # no longer what unidyn wrote
    with pytest.raises(ValidationError, match="summary.json, named like"):
        with staged(out, overwrite=True):
            pytest.fail("the block must not run")
    assert (out / "summary.json").read_text() == "edited by hand"
    _save(tmp_path / "b", 1)
    victim = tmp_path / "victim.csv"
    victim.write_text((tmp_path / "b" / "timeseries.csv").read_text())  # same bytes
    (tmp_path / "b" / "timeseries.csv").unlink()
    (tmp_path / "b" / "timeseries.csv").symlink_to(victim)
    with pytest.raises(ValidationError, match="timeseries.csv, named like"):
        with staged(tmp_path / "b", overwrite=True):
            pytest.fail("the block must not run")
    assert victim.read_text() == json.dumps({"generation": 1, "file": "timeseries.csv"})


@pytest.mark.parametrize("entry", ["../victim.txt", "/abs/victim.txt", "..", "/",
                                   "notes", "summary.json/..", ""])
def test_a_manifest_listing_anything_but_its_names_is_refused_and_nothing_changes(
        tmp_path, entry):
    out = tmp_path / "out"
    _save(out, 1)
    victim = tmp_path / "victim.txt"
    victim.write_text("precious")
    manifest = out / ".unidyn-results.json"
    m = json.loads(manifest.read_text())
    m["files"][entry] = m["files"]["summary.json"]
    manifest.write_text(json.dumps(m))
    before = {p: p.read_bytes() for p in tmp_path.rglob("*") if p.is_file()}
    with pytest.raises(ValidationError, match=rf"\.unidyn-results\.json lists "
                       rf"{re.escape(repr(entry))}, which is not a file unidyn results "
                       rf"writes.*nothing was changed"):
        with staged(out, overwrite=True):
            pytest.fail("the block must not run")
    assert {p: p.read_bytes() for p in tmp_path.rglob("*") if p.is_file()} == before
    assert "nothing was changed" in outdir.check_manifest(out, "results", NAMES)


@pytest.mark.parametrize("text", ['{"files": {"summary.json": "md5:abc"}}',
                                  '{"files": {"summary.json": null}}', "not json",
                                  '{"files": ["summary.json"]}', "\xff\xfe"])
def test_a_manifest_that_unidyn_could_not_have_written_is_refused(tmp_path, text):
    out = tmp_path / "out"
    _save(out, 1)
    (out / ".unidyn-results.json").write_text(text, errors="surrogateescape")
    with pytest.raises(ValidationError, match=r"\.unidyn-results\.json .*nothing was changed"):
        with staged(out, overwrite=True):
            pytest.fail("the block must not run")
    assert _generations(out) == {1}


def test_overwrite_must_be_a_bool(tmp_path):
    for value in ("no", 0, None, "False"):
        with pytest.raises(ValidationError, match=r"overwrite must be True or False"):
            with staged(tmp_path / "out", overwrite=value):
                pytest.fail("the block must not run")
    assert not (tmp_path / "out").exists()


def test_a_folder_of_the_user_is_not_replaced_by_a_result_of_that_name(tmp_path):
    out = tmp_path / "out"
    _save(out, 1)
    (out / "extra.csv").mkdir()
    (out / "extra.csv" / "mine.txt").write_text("mine")
    with pytest.raises(ValidationError, match="extra.csv, named like"):
        with staged(out, overwrite=True) as st:
            _write(st.path, 2, names=RESULTS + ("extra.csv",))
    assert (out / "extra.csv" / "mine.txt").read_text() == "mine" and _generations(out) == {1}
    assert sorted(p.name for p in out.iterdir()) == [".unidyn-results.json", "extra.csv",
                                                     *sorted(RESULTS)]


def test_partial_results_never_replace_complete_ones(tmp_path):
    out = tmp_path / "out"
    _save(out, 1)
    with staged(out, overwrite=True) as st:
        _write(st.path, 2)
        st.incomplete("diverged at t = 3 s")
    assert _generations(out) == {1}
    side = tmp_path / "out.incomplete"
    assert st.final == side and _generations(side) == {2}
    # a second failure replaces the previous partial results, not the complete ones
    with staged(out, overwrite=True) as st:
        _write(st.path, 3, names=RESULTS[:1])
        st.incomplete("again")
    assert _generations(out) == {1} and _generations(side) == {3}
    assert not (side / "timeseries.csv").exists()


def test_partial_results_go_into_an_empty_target(tmp_path):
    out = tmp_path / "out"
    with staged(out, overwrite=False) as st:
        _write(st.path, 1)
        st.incomplete("stopped")
    assert st.final == out.absolute() and _generations(out) == {1}


def _killed_while_writing(out, generation):
    """A writer that dies (as by ``kill -9``: no clean-up runs) with its private
    folder full: a forked process that leaves by ``os._exit``."""
    pid = os.fork()
    if pid == 0:  # pragma: no cover - the child
        try:
            with staged(out, overwrite=True) as st:
                _write(st.path, generation)
                os._exit(0)
        finally:
            os._exit(1)
    assert os.waitpid(pid, 0)[1] == 0


def test_what_a_killed_process_left_is_removed_by_the_next_writer_and_nothing_else(tmp_path):
    out = tmp_path / "out"
    _save(out, 1)
    # a user's folders named as unidyn names its private ones, and its lock's twin
    for name in (".unidyn-results-new-abc", ".unidyn-results-new-0123456789ab"):
        (out / name).mkdir()
        (out / name / "cat.jpg").write_text("cat")
    (out / ".unidyn.lock.bak").write_text("my notes")
    users = {".unidyn-results-new-abc", ".unidyn-results-new-0123456789ab", ".unidyn.lock.bak"}
    _killed_while_writing(out, 2)
    left = set(_private(out)) - users
    assert outdir.LOCK_NAME in left and len(left) == 2, left  # the lock and its folder
    with pytest.raises(ValidationError, match="already holds"):
        with staged(out, overwrite=False):
            pass
    assert _generations(out) == {1} and set(_private(out)) == users
    assert all((out / n / "cat.jpg").read_text() == "cat" for n in users if "new" in n)
    _killed_while_writing(out, 3)
    _save(out, 4)  # the next writer that goes ahead cleans up too
    assert _generations(out) == {4} and set(_private(out)) == users


@pytest.mark.parametrize("make", ["file", "empty file", "link out", "dangling link",
                                  "folder", "hard link"])
@pytest.mark.parametrize("overwrite", [False, True])
def test_a_lock_file_unidyn_did_not_make_is_refused_in_one_line_and_kept(tmp_path, make,
                                                                        overwrite):
    out, outside = tmp_path / "out", tmp_path / "outside.txt"
    _save(out, 1)
    outside.write_text("my thesis\n")
    lock = out / outdir.LOCK_NAME
    if make == "file":
        lock.write_text("my notes\n")
    elif make == "empty file":
        lock.touch()
    elif make == "link out":
        lock.symlink_to(outside)
    elif make == "dangling link":
        lock.symlink_to(tmp_path / "nowhere")
    elif make == "folder":
        lock.mkdir()
        (lock / "inside.txt").write_text("mine")
    else:
        os.link(outside, lock)
    before = {p.name: (p.is_symlink(), os.readlink(p) if p.is_symlink() else
                       p.is_dir() or p.read_bytes()) for p in out.iterdir()}
    with pytest.raises(ValidationError) as err:
        with staged(out, overwrite=overwrite) as st:
            _write(st.path, 2)
    text = str(err.value)
    assert "\n" not in text and str(lock) in text and "not a lock unidyn made" in text, text
    assert not isinstance(err.value, outdir.FolderInUse)
    after = {p.name: (p.is_symlink(), os.readlink(p) if p.is_symlink() else
                      p.is_dir() or p.read_bytes()) for p in out.iterdir()}
    assert after == before and outside.read_text() == "my thesis\n"
    assert not (tmp_path / "nowhere").exists()


@pytest.mark.parametrize("make", ["link to a folder of the user's", "folder of the user's",
                                  "file"])
def test_the_place_for_partial_results_is_unidyns_or_refused(tmp_path, make):
    """A partial result beside complete ones goes to ``<out>.incomplete`` only when
    that is a folder unidyn made: never through a link, into a user's folder or file;
    where it cannot, the block is refused on entry, before any work is done."""
    out, theirs = tmp_path / "out", tmp_path / "theirs"
    _save(out, 1)
    theirs.mkdir()
    (theirs / "thesis.tex").write_text("mine")
    place = tmp_path / "out.incomplete"
    if make.startswith("link"):
        place.symlink_to(theirs)
    elif make.startswith("folder"):
        place.mkdir()
        (place / "notes.txt").write_text("mine")
    else:
        place.write_text("mine")
    ran = []
    with pytest.raises(ValidationError, match="unidyn keeps there the partial") as err:
        with staged(out, overwrite=True) as st:  # refused before the work, not after it
            ran.append(True)
            _write(st.path, 2)
            st.incomplete("stopped early")
    assert ran == [] and "nothing was run" in str(err.value)
    assert "\n" not in str(err.value) and str(place) in str(err.value)
    assert sorted(os.listdir(theirs)) == ["thesis.tex"] and _generations(out) == {1}
    assert _private(out) == []
    if make.startswith("folder"):
        assert os.listdir(place) == ["notes.txt"]
    elif make == "file":
        assert place.read_text() == "mine"


def test_a_replacement_cut_short_is_told_apart_from_results(tmp_path):
    """kill -9 in the milliseconds in which files are renamed into place: the
    manifest still says the replacement is under way, and readers say so."""
    out = tmp_path / "out"
    with staged(out, overwrite=False) as st:
        _write(st.path, 1)
    m = json.loads((out / ".unidyn-results.json").read_text())
    (out / ".unidyn-results.json").write_text(json.dumps({**m, "complete": False}))
    assert "cut short" in outdir.check_manifest(out, "results", NAMES)
    (out / ".unidyn-results.json").write_text(json.dumps(m))
    assert outdir.check_manifest(out, "results", NAMES, RESULTS) == ""
    _write(out, 2, names=RESULTS[:1])  # one file of another run
    assert "summary.json is not the file its run wrote" in outdir.check_manifest(
        out, "results", NAMES, RESULTS)
    assert outdir.check_manifest(tmp_path, "results", NAMES, RESULTS) == ""  # no manifest


def test_the_folder_holding_out_is_never_written(tmp_path):
    parent = tmp_path / "parent"
    (parent / "out").mkdir(parents=True)
    before = os.stat(parent).st_mtime_ns
    time.sleep(0.01)
    for gen in (1, 2):
        with staged(parent / "out", overwrite=True) as st:
            _write(st.path, gen)
    assert os.stat(parent).st_mtime_ns == before and _generations(parent / "out") == {2}


#: what a writer does: finish, fail with an error or Ctrl-C, die (``kill -9``), or
#: stop early with a partial result, after writing some of its files
ACTIONS = ("complete", "error", "ctrl-c", "killed", "partial")
#: a user's entries in and beside ``out``, named as unidyn names its own
USERS = {".unidyn-results-new-abc/cat.jpg": b"a cat", ".unidyn-results-new-0123456789ab/x": b"x",
         "notes.txt": b"my notes", ".unidyn.lock.old": b"old notes"}


def _user_entries(out):
    return {n: (out / n).read_bytes() for n in USERS if (out / n).exists()}


@settings(max_examples=25, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(ops=st.lists(st.tuples(st.sampled_from(ACTIONS), st.booleans(), st.integers(0, 2)),
                    min_size=1, max_size=6))
def test_the_protocol_holds_for_any_sequence_of_writers(tmp_path_factory, ops):
    """The protocol, in process, over random sequences of writers: after each, ``out``
    holds every file of one generation -- the last one that finished (or, for a first
    partial result, that one) -- its manifest proves them, the user's entries (named
    like unidyn's private folders too) are as they were, a partial result beside
    complete ones is in ``out.incomplete``, and what a killed writer left is gone once
    the next writer has taken the lock."""
    top = tmp_path_factory.mktemp("protocol")
    out = top / "out"
    for name, data in USERS.items():
        (out / name).parent.mkdir(parents=True, exist_ok=True)
        (out / name).write_bytes(data)
    current, aside = None, None
    for g, (action, overwrite, k) in enumerate(ops, start=1):
        names = RESULTS[:k] if action in ("error", "ctrl-c", "killed") else RESULTS
        refused = current is not None and not overwrite
        if action == "killed":
            pid = os.fork()
            if pid == 0:  # pragma: no cover - the child
                try:
                    with staged(out, overwrite=overwrite) as st_:
                        _write(st_.path, g, names)
                        os._exit(0)
                finally:
                    os._exit(1)
            os.waitpid(pid, 0)
            continue
        exc = {"error": RuntimeError, "ctrl-c": KeyboardInterrupt}.get(action)
        try:
            with staged(out, overwrite=overwrite) as st_:
                _write(st_.path, g, names)
                if exc:
                    raise exc("stopped")
                if action == "partial":
                    st_.incomplete("stopped early")
        except ValidationError as err:
            assert refused and "already holds" in str(err), (action, str(err))
        except (RuntimeError, KeyboardInterrupt):
            assert exc is not None and not refused
        else:
            assert not refused and exc is None
            if action == "partial" and current is not None:
                aside = g
            else:
                current = g
        # the writer took the lock: what a killed one left is gone (checked below)
        assert _generations(out) == (set() if current is None else {current}), (ops, g)
        assert outdir.check_manifest(out, "results", NAMES, RESULTS) == ""
        assert _user_entries(out) == USERS
        assert set(_private(out)) == {n.split("/")[0] for n in USERS if n.startswith(".")}
        if aside is not None:
            assert _generations(top / "out.incomplete") == {aside}
        assert sorted(p.name for p in top.iterdir()) == sorted(
            ["out"] + (["out.incomplete"] if aside is not None else []))


_WRITER = textwrap.dedent("""
    import json, sys, time
    from unidyn.results.folders import staged_output
    out, gen = sys.argv[1], int(sys.argv[2])
    names = ("summary.json", "timeseries.csv", "a.csv", "b.csv")
    with staged_output(out, kind="results", names=names, overwrite=True) as st:
        for n in names:
            (st.path / n).write_text(json.dumps({"generation": gen, "file": n}) + " " * 200000)
            time.sleep(0.01)
    print("done", flush=True)
""")


@pytest.mark.slow
def test_processes_killed_at_random_moments_leave_old_or_new_never_a_mix(tmp_path):
    """Real processes, ``kill -9`` at random moments (Ctrl-C and SIGTERM during the
    renames are tested in process, below; any other moment by the property test
    above): after each, ``out`` holds every file of one generation (the last complete
    one, or the one just killed if it got as far as moving its files in). Only a kill
    in the milliseconds of the renames can leave a mix, and then the manifest says the
    replacement was cut short. A user's folder named like a private one survives."""
    sig = signal.SIGKILL
    rng = random.Random(20261123 + int(sig))
    out = tmp_path / "out"
    script = tmp_path / "writer.py"
    script.write_text(_WRITER)
    env = {**os.environ, "PYTHONDONTWRITEBYTECODE": "1"}
    subprocess.run([sys.executable, str(script), str(out), "0"], check=True, env=env,
                   cwd=tmp_path, capture_output=True)
    names = ("summary.json", "timeseries.csv", "a.csv", "b.csv")
    (out / ".unidyn-results-new-2024").mkdir()
    (out / ".unidyn-results-new-2024" / "cat.jpg").write_text("a cat")
    done = 0
    for gen in range(1, 7):
        proc = subprocess.Popen([sys.executable, str(script), str(out), str(gen)], env=env,
                                cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
        time.sleep(rng.uniform(0.05, 0.6))
        proc.send_signal(sig)
        stdout, _ = proc.communicate(timeout=30)
        finished = b"done" in stdout
        gens = {json.loads((out / n).read_text().rstrip())["generation"] for n in names}
        problem = outdir.check_manifest(out, "results", names, names)
        if len(gens) > 1:
            assert sig == signal.SIGKILL and "cut short" in problem, (gens, sig, problem)
            gens = {gen}
        elif finished:
            assert gens == {gen} and problem == ""
        else:  # the old one, or the new one if the signal came after its renames but
            # before it could print "done"
            assert gens in ({done}, {gen}), (gens, done, gen)
            assert problem == "" or sig == signal.SIGKILL, problem
        done = gens.pop()
    # what the killed processes left in out is cleaned by the next writer
    subprocess.run([sys.executable, str(script), str(out), "99"], check=True, env=env,
                   cwd=tmp_path, capture_output=True)
    assert _siblings(tmp_path, out) == ["writer.py"]
    assert _private(out) == [".unidyn-results-new-2024"]
    assert (out / ".unidyn-results-new-2024" / "cat.jpg").read_text() == "a cat"
    assert outdir.check_manifest(out, "results", names, names) == ""


def test_the_block_holds_the_folder_lock_and_a_second_writer_is_refused(tmp_path):
    out = tmp_path / "out"
    with staged(out, overwrite=False) as st:
        held = (out / outdir.LOCK_NAME).read_text()
        assert re.search(r"^pid ([0-9]+)$", held, re.M).group(1) == str(os.getpid()), held
        with pytest.raises(outdir.FolderInUse, match=f"PID {os.getpid()}"):
            with staged(out, overwrite=True):
                pytest.fail("the second writer must not run")
        _write(st.path, 1)
    assert _generations(out) == {1} and not (out / outdir.LOCK_NAME).exists()


def test_a_refused_write_into_a_new_folder_leaves_no_folder(tmp_path):
    out = tmp_path / "new" / "out"
    with pytest.raises(RuntimeError):
        with staged(out, overwrite=False):
            raise RuntimeError("failed before writing")
    assert not out.exists()


_RACER = textwrap.dedent("""
    import sys, time
    from unidyn import ValidationError
    from unidyn.results.folders import staged_output
    out, me = sys.argv[1], sys.argv[2]
    try:
        with staged_output(out, kind="results", names=("summary.json",), overwrite=False) as st:
            time.sleep(0.5)
            (st.path / "summary.json").write_text(me)
    except ValidationError as err:
        print("refused:", err)
        sys.exit(2)
""")


@pytest.mark.slow
def test_two_processes_into_one_empty_folder_one_writes_the_other_is_refused(tmp_path):
    script = tmp_path / "racer.py"
    script.write_text(_RACER)
    out = tmp_path / "out"
    procs = [subprocess.Popen([sys.executable, str(script), str(out), name], cwd=tmp_path,
                              stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
             for name in ("first", "second")]
    outs = [p.communicate(timeout=60) for p in procs]
    codes = sorted(p.returncode for p in procs)
    assert codes == [0, 2], outs
    refused = [o for o, p in zip(outs, procs) if p.returncode == 2][0][0]
    assert "PID" in refused or "already holds" in refused
    winner = ["first", "second"][[p.returncode for p in procs].index(0)]
    assert (out / "summary.json").read_text() == winner


def test_ctrl_c_during_the_renames_is_held_back():
    # Python's own Ctrl-C handler, as in a process started in the foreground (one started
    # in the background of a shell script begins with SIGINT ignored)
    before = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        with outdir._interrupts_deferred():
            signal.raise_signal(signal.SIGINT)  # arrives inside: held back, then dropped
        with pytest.raises(KeyboardInterrupt):
            with outdir._interrupts_deferred():
                signal.raise_signal(signal.SIGINT)
                raise OSError("a rename failed")  # not done: the Ctrl-C is raised after all
        assert signal.getsignal(signal.SIGINT) is signal.default_int_handler
    finally:
        signal.signal(signal.SIGINT, before)


def test_sigterm_during_the_renames_is_held_back_then_delivered():
    """A SIGTERM while files are renamed into place reaches the handler that was
    there, after; the unidyn command's handler drops it once the results are in place
    (the command has finished, and says what it wrote), and gets it when they are not."""
    from unidyn import process
    got = []
    previous = signal.signal(signal.SIGTERM, lambda *a: got.append("term"))
    try:
        with outdir._interrupts_deferred():
            signal.raise_signal(signal.SIGTERM)
            assert got == []  # held back during the renames
        assert got == ["term"]  # then delivered to the handler that was there
        with process.command_signals():  # the unidyn command's handlers
            with outdir._interrupts_deferred():
                signal.raise_signal(signal.SIGTERM)  # results in place: the command finishes
            with pytest.raises(KeyboardInterrupt):
                with outdir._interrupts_deferred():
                    signal.raise_signal(signal.SIGTERM)
                    raise OSError("a rename failed")  # not in place: the command stops
            assert process.finishes_on_sigterm(signal.getsignal(signal.SIGTERM))
        assert got == ["term"]  # and none reached the handler outside the command
    finally:
        signal.signal(signal.SIGTERM, previous)
        process._received.clear()  # the command's record of a signal, for the next tests


def test_a_results_own_folder_is_replaced_file_by_file(tmp_path):
    """A script's results may have folders of their own (one per case): names such as
    ``case1/a.csv``. The earlier files go one by one, proven by content; a file of the
    user's put inside stays, and so does its folder; a folder of the user's beside
    them stays."""
    out = tmp_path / "out"
    names = ("case1/a.csv", "case1/b.csv", "top.csv")
    (out / "mine").mkdir(parents=True)
    (out / "mine" / "m.txt").write_text("mine")
    for gen, files in ((1, ("a.csv", "b.csv")), (2, ("a.csv",))):
        with staged(out, names=names, overwrite=True) as st:
            (st.path / "case1").mkdir()
            for n in files:
                (st.path / "case1" / n).write_text(str(gen))
    assert sorted(os.listdir(out / "case1")) == ["a.csv"]
    assert (out / "case1" / "a.csv").read_text() == "2"
    assert (out / "mine" / "m.txt").read_text() == "mine" and _private(out) == []
    (out / "case1" / "notes.txt").write_text("the user's")
    with staged(out, names=names, overwrite=True) as st:
        (st.path / "top.csv").write_text("3")
    assert sorted(os.listdir(out / "case1")) == ["notes.txt"]  # a.csv gone, notes kept
    # a link standing for a result's folder is never followed
    (out / "case1" / "notes.txt").unlink()
    (out / "case1").rmdir()
    (out / "case1").symlink_to(out / "mine")
    with pytest.raises(ValidationError, match="case1/a.csv, case1/b.csv, named like"):
        with staged(out, names=names, overwrite=True) as st:
            pytest.fail("the block must not run")
    assert os.listdir(out / "mine") == ["m.txt"]


def test_a_full_disk_without_a_file_name_names_the_file_being_written(tmp_path):
    """A writer (a figure library) whose error does not say which file filled the disk:
    the message names the file it was writing, its size so far and the space left."""
    import errno
    out = tmp_path / "out"
    _save(out, 1)
    with pytest.raises(OSError) as err:
        with staged(out, overwrite=True) as st:
            _write(st.path, 2, names=("summary.json",))
            (st.path / "animation.gif").write_bytes(b"G" * 3000)
            raise OSError(errno.ENOSPC, "No space left on device")
    text = str(err.value)
    assert f"writing {out / 'animation.gif'} (3 kB of it written, " in text, text
    assert re.search(r"written, [0-9.]+ (bytes|kB|MB|GB) free\); the earlier results in .* "
                     r"are intact", text), text
    assert _generations(out) == {1} and _private(out) == []


def test_a_link_that_loops_or_a_folder_that_cannot_be_made_is_one_line(tmp_path):
    loop = tmp_path / "loop"
    loop.symlink_to(loop)
    with pytest.raises(ValidationError, match="leads back to itself") as err:
        with staged(loop, overwrite=False):
            pass
    assert "\n" not in str(err.value) and loop.is_symlink()
    (tmp_path / "a-file").write_text("mine")
    with pytest.raises(ValidationError, match="cannot make the folder") as err:
        with staged(tmp_path / "a-file" / "out", overwrite=False):
            pass
    assert "Not a directory" in str(err.value) and (tmp_path / "a-file").read_text() == "mine"


def test_a_block_inside_a_block_is_refused_not_silently_passed_through(tmp_path):
    with staged(tmp_path / "out", overwrite=False) as st:
        with pytest.raises(ValueError, match="pass the Stage"):
            with staged(st.path, overwrite=False):
                pass
        _write(st.path, 1)
    assert _generations(tmp_path / "out") == {1}


def test_temporary_files_are_recorded_in_the_lock_and_removed_after_a_kill(tmp_path):
    """A temporary file is created exclusively, named with a token that the folder's
    lock records before it exists; after kill -9 the next holder of the lock removes it,
    and a user's file with such a name, not recorded, is never touched."""
    out = tmp_path / "out"
    out.mkdir()
    theirs = out / ".unidyn-tmp-0123456789ab.csv"
    theirs.write_text("mine")
    script = textwrap.dedent(f"""
        import os, signal
        from unidyn.results.folders import FolderLock, Ledger
        lock = FolderLock({str(out)!r})
        def write(tmp):
            tmp.write_text("half")
            os.kill(os.getpid(), signal.SIGKILL)
        Ledger(lock.folder, "results", ("a.csv",), lock).write_with("a.csv", write)
    """)
    p = subprocess.run([sys.executable, "-c", script], timeout=120)
    assert p.returncode == -signal.SIGKILL
    left = sorted(n for n in os.listdir(out) if n.startswith(".unidyn-tmp-"))
    assert len(left) == 2
    with outdir.FolderLock(out):
        pass
    assert sorted(os.listdir(out)) == [theirs.name] and theirs.read_text() == "mine"


def test_every_kind_of_write_names_its_file_on_a_full_disk(tmp_path):
    """A full disk at a figure (write_file), a manifest or a file of a Ledger, and an
    append: the file named, the space left, and that the earlier content is kept."""
    import errno

    def full(tmp):
        with open(tmp, "wb") as fh:
            fh.write(b"z" * 2500)
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    fig = tmp_path / "figure.png"
    fig.write_bytes(b"before")
    with pytest.raises(outdir.DiskFull) as err:
        outdir.write_file(fig, full)
    assert re.search(rf"writing {re.escape(str(fig))} \(2.5 kB of it written, [0-9.]+ "
                     rf"(bytes|kB|MB|GB) free\); {re.escape(str(fig))} is as it was",
                     str(err.value)), str(err.value)
    assert fig.read_bytes() == b"before" and os.listdir(tmp_path) == ["figure.png"]
    ledger = outdir.Ledger(tmp_path, "results", NAMES)
    ledger.write("a.csv", "x\n")
    with pytest.raises(outdir.DiskFull, match=r"writing .*a\.csv \(.* free\); .*a\.csv is as "
                                              r"it was"):
        ledger.write_with("a.csv", full)
    assert (tmp_path / "a.csv").read_text() == "x\n" and ledger.owns("a.csv")
    with pytest.raises(outdir.DiskFull, match=r"writing .*b\.csv .*b\.csv was not written"):
        ledger.write_with("b.csv", full)
    assert not (tmp_path / "b.csv").exists()
    assert sorted(os.listdir(tmp_path)) == [".unidyn-results.json", "a.csv", "figure.png"]


def test_a_list_of_files_in_a_message_stays_one_short_line():
    """A few names are all shown; a long list is its count and three examples of
    different kinds, in the list's order."""
    assert outdir.list_files([]) == ""
    assert outdir.list_files(["a.csv", "b.json", "c.png", "d.png"]) == "a.csv, b.json, c.png, d.png"
    names = [f"point{i:02d}.csv" for i in range(29)] + ["summary.json", "metrics.png"]
    assert outdir.list_files(names) == "31 files, e.g. point00.csv, summary.json, metrics.png"
    same = [f"r{i}.csv" for i in range(10)]
    assert outdir.list_files(same) == "10 files, e.g. r0.csv, r1.csv, r2.csv"


def test_a_refusal_for_many_held_files_names_their_number_and_examples(tmp_path):
    out = tmp_path / "out"
    names = tuple(f"point{i:02d}.csv" for i in range(30)) + ("summary.json",)
    with staged_output(out, kind="results", names=names, overwrite=False) as st:
        for n in names:
            (st.path / n).write_text(n)
    with pytest.raises(ValidationError) as err:
        with staged_output(out, kind="results", names=names, overwrite=False):
            pass
    text = str(err.value)
    assert "(31 files, e.g. point00.csv, point01.csv, summary.json)" in text
    assert "point29.csv" not in text and "\n" not in text
