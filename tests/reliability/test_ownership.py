"""Results you own, by construction: whatever a results folder holds (a user's files
named like results, links, folders, edited results, manifests listing ``..``,
absolute paths or someone else's files; files, folders and links named as unidyn
names its own lock, private folders, temporary files and the place of partial
results), a command changes only files that unidyn provably wrote there. A property test over random folders, each command a real
process: ``unidyn run``, ``unidyn sweep``, ``unidyn identify``, ``Result.save`` and
``IdentificationResult.save``, with and without overwriting."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from unidyn import datasets
from unidyn.identification.results import IDENTIFY_FILES
from unidyn.results.result import RUN_FILES
from unidyn.sweeps.sweep import SWEEP_FILES

pytestmark = [pytest.mark.reliability, pytest.mark.slow]

LOG = datasets.path("log.csv")
SWEEP = '[base]\ncase = "kinematic"\nT = 0.3\nnoise = "off"\n[grid]\nkx = [1.0, 2.0]\n'
RESULT_SAVE = ("import sys, unidyn; r = unidyn.run(unidyn.Scenario.paper(1, T=0.3), "
               "engine='batch'); r.save(sys.argv[1], overwrite=sys.argv[2] == '1')")
IDENT_SAVE = ("import sys, unidyn.identification as i; i.identify(sys.argv[3]).save(sys.argv[1], "
              "overwrite=sys.argv[2] == '1')")

#: command -> (kind of its results, the names that kind writes)
KINDS = {"run": ("run", RUN_FILES), "save": ("run", RUN_FILES),
         "sweep": ("sweep", SWEEP_FILES), "identify": ("identify", IDENTIFY_FILES),
         "identify-save": ("identify", IDENTIFY_FILES)}


def command(which: str, out: Path, overwrite: bool, work: Path) -> list:
    unidyn = [sys.executable, "-m", "unidyn"]
    flag = ["--overwrite"] if overwrite else []
    return {"run": unidyn + ["run", "--paper", "1", "--T", "0.3", "--engine", "batch",
                             "--out", str(out)] + flag,
            "sweep": unidyn + ["sweep", str(work / "s.toml"), "--out", str(out),
                               "--no-progress"] + flag,
            "identify": unidyn + ["identify", str(LOG), "--out", str(out)] + flag,
            "save": [sys.executable, "-c", RESULT_SAVE, str(out), str(int(overwrite))],
            "identify-save": [sys.executable, "-c", IDENT_SAVE, str(out),
                              str(int(overwrite)), str(LOG)]}[which]


def execute(argv, cwd):
    env = dict(os.environ, MPLBACKEND="Agg")
    return subprocess.run(argv, cwd=cwd, env=env, capture_output=True, text=True, timeout=300)


@pytest.fixture(scope="module")
def genuine():
    """Results folders as unidyn writes them, one per kind, to copy from."""
    work = Path(tempfile.mkdtemp(prefix="unidyn-genuine-"))
    (work / "s.toml").write_text(SWEEP)
    for which in ("run", "sweep", "identify"):
        p = execute(command(which, work / which, False, work), work)
        assert p.returncode == 0, p.stderr
    yield work
    shutil.rmtree(work, ignore_errors=True)


def plant_entry(path: Path, plant: str, user_bytes: bytes, victim: Path) -> None:
    """A user's file, folder or link at ``path``."""
    if plant == "file":
        path.write_bytes(user_bytes or b"my notes")
    elif plant == "empty file":
        path.touch()
    elif plant == "link to a file":
        path.symlink_to(victim / "precious.txt")
    elif plant == "link to a folder":
        path.symlink_to(victim)
    elif plant == "dangling link":
        path.symlink_to(victim / "nowhere")
    else:
        path.mkdir()
        (path / "cat.jpg").write_bytes(b"a cat")


def snapshot(root: Path) -> dict:
    """Every file and link under ``root``: bytes, or the link's target."""
    out = {}
    for folder, dirs, names in os.walk(root):
        for n in names + [d for d in dirs if os.path.islink(Path(folder) / d)]:
            p = Path(folder) / n
            out[p.relative_to(root).as_posix()] = (("->", os.readlink(p)) if p.is_symlink()
                                                   else p.read_bytes())
    return out


#: what a name of the kind's may be in the folder before the command (unidyn's own
#: files more often, so that many commands go ahead and replace them)
STATES = ("absent", "genuine", "genuine", "genuine", "user bytes", "edited", "link", "folder")
G, U, E, L, A = "genuine", "user bytes", "edited", "link", "absent"
#: entries a manifest someone else wrote may add
INTRUDERS = ("../victim/precious.txt", "{victim}", "..", "/", ".", "notes.txt",
             "sub/../../victim/precious.txt", "")
#: the names of unidyn's own scaffolding ({kind}: the command's), as a user may have
#: them: ``out.incomplete`` is beside ``out``
SCAFFOLD = (".unidyn.lock", ".unidyn-{kind}-new-2024", ".unidyn-{kind}-new-0123456789ab",
            ".unidyn-run-new-x", ".unidyn-tmp-summary.json", "../out.incomplete")
#: what a user's entry by such a name is
PLANTS = ("file", "empty file", "link to a file", "link to a folder", "dangling link",
          "folder")


@example(which="run", overwrite=True, states=[G, G, U, G, G, G, A, A], intruder=None,
         user_bytes=b"my figure", scaffold=[])
@example(which="save", overwrite=True, states=[G, E, G, G, L, G, A, A], intruder=None,
         user_bytes=b"", scaffold=[])
@example(which="sweep", overwrite=True, states=[G, G, G, E, U, A], intruder=None,
         user_bytes=b"# my claims", scaffold=[])
@example(which="identify", overwrite=True, states=[G, U, G], intruder=None, user_bytes=b"{}",
         scaffold=[])
@example(which="identify-save", overwrite=False, states=[G, G, G],
         intruder="../victim/precious.txt", user_bytes=b"", scaffold=[])
@example(which="run", overwrite=True, states=[G] * 6 + [A, A], intruder="{victim}",
         user_bytes=b"", scaffold=[])
@example(which="run", overwrite=True, states=[G] * 6 + [A, A], intruder=None,
         user_bytes=b"my notes", scaffold=[(".unidyn.lock", "file"),
                                           (".unidyn-{kind}-new-2024", "folder")])
@example(which="sweep", overwrite=False, states=[A] * 6, intruder=None, user_bytes=b"",
         scaffold=[(".unidyn-{kind}-new-0123456789ab", "folder"),
                   ("../out.incomplete", "link to a folder")])
@example(which="identify", overwrite=True, states=[G, G, G], intruder=None, user_bytes=b"",
         scaffold=[(".unidyn.lock", "link to a file")])
@settings(max_examples=24, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
@given(which=st.sampled_from(sorted(KINDS)), overwrite=st.booleans(),
       states=st.lists(st.sampled_from(STATES), min_size=6, max_size=8),
       intruder=st.none() | st.sampled_from(INTRUDERS),
       user_bytes=st.binary(min_size=0, max_size=64),
       scaffold=st.lists(st.tuples(st.sampled_from(SCAFFOLD), st.sampled_from(PLANTS)),
                         max_size=3, unique_by=lambda p: p[0]))
def test_nothing_that_unidyn_did_not_write_changes(genuine, which, overwrite, states,
                                                   intruder, user_bytes, scaffold):
    kind, names = KINDS[which]
    source = genuine / {"run": "run", "save": "run", "sweep": "sweep"}.get(which, "identify")
    top = Path(tempfile.mkdtemp(prefix="unidyn-own-"))
    try:
        (top / "s.toml").write_text(SWEEP)
        out, victim = top / "out", top / "victim"
        victim.mkdir()
        (victim / "precious.txt").write_text("the thesis\n")
        out.mkdir()
        (out / "notes.txt").write_text("my notes\n")
        manifest = out / f".unidyn-{kind}.json"
        shutil.copy(source / manifest.name, manifest)
        mine = set()  # what unidyn wrote, as it wrote it: the only files that may change
        present = []  # the states of the names put in the folder
        for name, state in zip(names, states):
            p = out / name
            if state == "absent" or not (source / name).exists():
                continue
            present.append(state)
            if state in ("genuine", "edited"):
                shutil.copy(source / name, p)
                if state == "edited":
                    with open(p, "ab") as fh:
                        fh.write(b"\nedited")
                else:
                    mine.add(name)
            elif state == "user bytes":
                p.write_bytes(user_bytes)
            elif state == "link":
                p.symlink_to(victim / "precious.txt")
            else:
                (p / "inside").mkdir(parents=True)
                (p / "inside" / "mine.txt").write_text("mine\n")
        if intruder is not None:  # a manifest someone else wrote: nothing is unidyn's
            m = json.loads(manifest.read_text())
            first = next(iter(m["files"].values()))
            m["files"][intruder.format(victim=victim / "precious.txt")] = first
            manifest.write_text(json.dumps(m))
            mine = set()
        elif not mine and not any(s == "genuine" for s in states):
            manifest.unlink()
        if mine:
            mine.add(manifest.name)
        for name, plant in scaffold:
            plant_entry(out / name.format(kind=kind), plant, user_bytes, victim)
        before = snapshot(top)
        p = execute(command(which, out, overwrite, top), top)
        after = snapshot(top)
        changed = sorted(k for k in before if after.get(k) != before[k])
        foreign = [k for k in changed if k.removeprefix("out/") not in mine]
        planted = tuple(os.path.normpath(f"out/{n.format(kind=kind)}") + "/"
                        for n, _ in scaffold)
        foreign += [k for k in after if k not in before  # nothing new outside out, or
                    and (not k.startswith("out/") or k.startswith(planted))]  # in theirs
        assert not foreign, (which, overwrite, states, intruder, foreign, p.stderr[-2000:])
        assert "AttributeError" not in p.stderr and "NameError" not in p.stderr, p.stderr
        locked = any(n == ".unidyn.lock" for n, _ in scaffold)
        if intruder is None and set(present) <= {"genuine"} and not locked and (
                overwrite or which == "sweep" or not present):  # nothing in the way
            assert p.returncode == 0, (which, overwrite, states, p.stderr[-2000:])
        if locked:  # a lock unidyn did not make: refused, naming it
            assert p.returncode != 0 and ".unidyn.lock" in p.stderr, p.stderr
        if intruder is not None and not locked:  # refused in one line naming the manifest
            assert p.returncode != 0 and manifest.name in p.stderr, p.stderr
        if which in ("run", "sweep", "identify") and p.returncode != 0:  # the command line:
            assert len(p.stderr.strip().splitlines()) == 1, p.stderr  # one line, no traceback
    finally:
        shutil.rmtree(top, ignore_errors=True)
