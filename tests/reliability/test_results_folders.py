"""Where users keep results: ``--out`` as a symbolic link, a folder with the user's own
files and folders, another process writing inside it, ``.`` and ``..``, a file system
mounted inside, a full disk; and ``save()`` from Python keeping the command line's
rule. Real folders, real ``python -m unidyn`` processes; afterwards the results are
where they belong and everything else is as it was, byte for byte."""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

pytestmark = pytest.mark.reliability


def cli(cwd: Path, *args, timeout=180):
    env = dict(os.environ, MPLBACKEND="Agg", PYTHONUNBUFFERED="1")
    p = subprocess.run([sys.executable, "-m", "unidyn", *map(str, args)], cwd=cwd, env=env,
                       capture_output=True, text=True, timeout=timeout)
    assert "Traceback" not in p.stderr, p.stderr
    return p.returncode, p.stdout, p.stderr


def tree(folder: Path, skip=()) -> dict:
    """Every file and link under ``folder`` (relative path -> bytes, or the link's
    target), but for the names in ``skip`` at its top."""
    out = {}
    for root, dirs, names in os.walk(folder):
        rel = Path(root).relative_to(folder)
        for n in names + [d for d in dirs if os.path.islink(Path(root) / d)]:
            p = Path(root) / n
            if rel == Path(".") and n in skip:
                continue
            out[str(rel / n)] = ("->", os.readlink(p)) if p.is_symlink() else p.read_bytes()
    return out


RUN = {"timeseries.csv", "summary.json", "path.png", "error.png", "positions.png",
       "velocities.png", "theta_hat.png", ".unidyn-run.json", ".unidyn.lock"}


def users_files(folder: Path) -> None:
    """A folder as a user has it: notes, a hidden file, a sub-folder, a link."""
    (folder / "data" / "deep").mkdir(parents=True, exist_ok=True)
    (folder / "notes.txt").write_text("my notes\n")
    (folder / ".bashrc").write_text("export A=1\n")
    (folder / "data" / "raw.csv").write_bytes(os.urandom(5000))
    (folder / "data" / "deep" / "x.bin").write_bytes(os.urandom(300))
    os.symlink("data/raw.csv", folder / "raw-link")


def T_of(folder: Path) -> float:
    return json.loads((folder / "summary.json").read_text())["scenario"]["T"]


@pytest.mark.slow
def test_out_as_a_symbolic_link_writes_into_its_target(tmp_path):
    store = tmp_path / "store" / "results"
    store.mkdir(parents=True)
    users_files(store)
    mine = tree(store)
    work = tmp_path / "work"
    work.mkdir()
    os.symlink(store, work / "out")
    assert cli(work, "run", "--T", "1", "--out", "out")[0] == 0
    code, text, err = cli(work, "run", "--T", "2", "--overwrite", "--out", "out")
    assert code == 0, err
    assert "written    out/" in text
    assert os.readlink(work / "out") == str(store)  # still the link, to the same place
    assert sorted(os.listdir(work)) == ["out"]  # nothing beside it
    assert T_of(store) == 2.0 and tree(store, RUN) == mine
    assert not (store / ".unidyn.lock").exists()
    assert [n for n in os.listdir(store) if n.startswith(".unidyn")] == [".unidyn-run.json"]


_LOGGER = textwrap.dedent("""
    import sys, time
    failed = 0
    for i in range(40):
        try:
            with open("log.txt", "a") as fh:      # relative: the logger's cwd is --out
                fh.write(f"{i}\\n")
        except OSError:
            failed += 1
        time.sleep(0.1)
    print(failed)
""")


@pytest.mark.slow
def test_another_process_writing_inside_out_during_an_overwrite_loses_nothing(tmp_path):
    out = tmp_path / "out"
    assert cli(tmp_path, "run", "--T", "1", "--out", out)[0] == 0
    logger = subprocess.Popen([sys.executable, "-c", _LOGGER], cwd=out, text=True,
                              stdout=subprocess.PIPE)
    code, _, err = cli(tmp_path, "run", "--T", "2", "--overwrite", "--out", out)
    logger_out, _ = logger.communicate(timeout=60)
    assert code == 0, err
    assert logger_out.strip() == "0"  # every write of the logger succeeded
    assert (out / "log.txt").read_text() == "".join(f"{i}\n" for i in range(40))
    assert T_of(out) == 2.0


@pytest.mark.slow
@pytest.mark.parametrize("where", [".", ".."])
def test_out_as_the_working_folder_or_its_parent(tmp_path, where):
    top = tmp_path / "top"
    cwd = top / "sub"
    cwd.mkdir(parents=True)
    users_files(cwd)
    (top / "beside.txt").write_text("the parent's own file\n")
    before, inode = tree(top), top.stat().st_ino
    target = cwd if where == "." else top
    assert cli(cwd, "run", "--T", "1", "--out", where)[0] == 0
    code, text, err = cli(cwd, "run", "--T", "2", "--overwrite", "--out", where)
    assert code == 0, err
    assert f"written    {where}/" in text
    assert T_of(target) == 2.0
    results = {n for n in RUN if (target / n).exists()}
    assert tree(top, {} if where == "." else RUN) == {
        **before, **{f"sub/{n}": (cwd / n).read_bytes() for n in results if where == "."}}
    assert top.stat().st_ino == inode and cwd.is_dir()
    # without --overwrite: one line, in flags
    code, _, err = cli(cwd, "run", "--T", "1", "--out", where)
    assert code == 2 and len(err.strip().splitlines()) == 1 and "--overwrite" in err, err


def test_an_empty_out_is_refused_in_one_line(tmp_path):
    code, _, err = cli(tmp_path, "run", "--T", "1", "--out", "")
    assert code == 2 and err.strip() == ("unidyn: error: --out is empty; give a folder "
                                         "(--out . for the current one)")
    assert os.listdir(tmp_path) == []


def _mount_tmpfs(path: Path, size: str) -> None:
    path.mkdir(parents=True, exist_ok=True)
    p = subprocess.run(["mount", "-t", "tmpfs", "-o", f"size={size}", "tmpfs", str(path)],
                       capture_output=True, text=True)
    if p.returncode != 0:
        pytest.skip(f"cannot mount a tmpfs here: {(p.stderr or p.stdout).strip()}")


def _umount(path: Path) -> None:
    subprocess.run(["umount", str(path)], check=False)


@pytest.mark.slow
def test_a_file_system_mounted_inside_out_is_left_alone(tmp_path):
    out = tmp_path / "out"
    _mount_tmpfs(out / "mnt", "1m")
    try:
        (out / "mnt" / "on-the-mount.txt").write_text("keep me\n")
        assert cli(tmp_path, "run", "--T", "1", "--out", out)[0] == 0
        assert cli(tmp_path, "run", "--T", "2", "--overwrite", "--out", out)[0] == 0
        assert os.path.ismount(out / "mnt")
        assert tree(out / "mnt") == {"on-the-mount.txt": b"keep me\n"}
        assert not (out / "on-the-mount.txt").exists() and T_of(out) == 2.0
    finally:
        _umount(out / "mnt")


@pytest.mark.slow
def test_a_full_disk_names_the_file_and_keeps_the_earlier_results(tmp_path):
    out = tmp_path / "small"
    _mount_tmpfs(out, "1m")
    try:
        assert cli(tmp_path, "run", "--T", "1", "--out", out)[0] == 0
        (out / "notes.txt").write_text("mine\n")
        before = tree(out, {".unidyn.lock"})
        # 20001 samples: a timeseries.csv of several MB, which cannot fit
        code, _, err = cli(tmp_path, "run", "--T", "2000", "--engine", "batch",
                           "--overwrite", "--out", out)
        assert code == 2, err
        line = err.strip().splitlines()[-1]
        said = re.fullmatch(
            rf"unidyn: error: No space left on device writing {re.escape(str(out))}/"
            rf"timeseries.csv \((?:[0-9.]+ (?:bytes|kB|MB) of it written, )?([0-9.]+) "
            rf"(bytes|kB|MB) free\); the earlier results in "
            rf"{re.escape(str(out))} are intact \(nothing was replaced\)", line)
        assert said, err
        # the free space it names is what the disk had then: a little less than now,
        # once the run's private folder is gone (a few kB of a 1 MB disk)
        free = os.statvfs(out).f_bavail * os.statvfs(out).f_frsize
        stated = float(said.group(1)) * {"bytes": 1, "kB": 1e3, "MB": 1e6}[said.group(2)]
        assert 0.97 * free <= stated <= free + 1e3, (stated, free)
        assert tree(out, {".unidyn.lock"}) == before
        assert [n for n in os.listdir(out) if n.startswith(".unidyn")] == [".unidyn-run.json"]
        # into an empty folder on the full disk: nothing is left behind
        code, _, err = cli(tmp_path, "run", "--T", "2000", "--engine", "batch",
                           "--out", out / "fresh")
        assert code == 2 and "nothing was written to" in err and "timeseries.csv" in err, err
        assert not (out / "fresh").exists()
    finally:
        _umount(out)


@pytest.mark.slow
def test_a_full_disk_during_a_sweep_names_the_file_and_keeps_the_finished_rows(tmp_path):
    spec = tmp_path / "s.toml"
    spec.write_text('[base]\ncase = "kinematic"\nT = 0.2\nnoise = "off"\n'
                    '[grid]\nkx = {start = 0.01, stop = 3, num = 300}\n')
    assert cli(tmp_path, "sweep", spec, "--out", "whole", "--no-progress")[0] == 0
    out = tmp_path / "small"
    _mount_tmpfs(out, "1m")
    try:
        (out / "notes.txt").write_text("mine\n")
        free = os.statvfs(out)
        filler = out / "filler.bin"  # leaves 40 kB: the first rows fit, not all 300
        filler.write_bytes(b"\0" * (free.f_bavail * free.f_frsize - 40_000))
        # its estimated 56 kB of rows are refused up front, nothing written
        code, _, err = cli(tmp_path, "sweep", spec, "--out", out, "--no-progress")
        assert code == 2 and re.search(r"more than 50% of the free disk \(about [\d.]+ kB at its "
                                       r"largest\): 300 points to run", err) and "--yes" in err, err
        assert {p.name for p in out.iterdir()} - {"lost+found"} == {"filler.bin", "notes.txt"}
        # started anyway, the disk fills up after the first rows
        code, _, err = cli(tmp_path, "sweep", spec, "--out", out, "--no-progress",
                           "--chunk-size", "20", "--yes")
        assert code == 2, err
        line = err.strip().splitlines()[-1]
        assert line.startswith("unidyn: error: No space left on device writing "
                               f"{out}/"), err
        assert f"points are in {out}/metrics.csv, intact; run the same command again" in line
        assert len(err.strip().splitlines()) == 1, err
        assert (out / "notes.txt").read_text() == "mine\n"
        filler.unlink()
        assert cli(tmp_path, "sweep", spec, "--out", out, "--no-progress")[0] == 0
        assert (out / "metrics.csv").read_bytes() == (tmp_path / "whole" / "metrics.csv").read_bytes()
    finally:
        _umount(out)


@pytest.mark.slow
def test_files_of_the_users_named_like_results_are_refused_with_or_without_overwrite(tmp_path):
    """A folder holding the user's path.png, animation.gif, theta_hat.png and notes:
    ``unidyn run`` refuses up front, naming them, and changes nothing."""
    out = tmp_path / "mine"
    out.mkdir()
    for name in ("path.png", "animation.gif", "theta_hat.png", "notes.txt"):
        (out / name).write_bytes(os.urandom(100))
    before = tree(out)
    for extra in ([], ["--overwrite"]):
        code, _, err = cli(tmp_path, "run", "--paper", "3", "--T", "1", "--out", out, *extra)
        assert code == 2 and len(err.strip().splitlines()) == 1, err
        assert ("holds path.png, theta_hat.png, animation.gif, named like unidyn's run "
                "results but not written by unidyn") in err, err
        assert "move them elsewhere or choose another --out" in err
        assert tree(out) == before


@pytest.mark.slow
def test_save_from_python_keeps_the_command_lines_rule(tmp_path):
    from unidyn import ValidationError
    from unidyn.engine.batch import simulate_batch
    from unidyn.model.scenario import Scenario
    out = tmp_path / "R"
    assert cli(tmp_path, "run", "--case", "adaptive", "--T", "1", "--out", out)[0] == 0
    (out / "mine.txt").write_text("mine\n")
    before = tree(out)
    r = simulate_batch([Scenario.paper(1, T=0.5)], progress=False)[0]
    with pytest.raises(ValidationError, match=r"already holds run results \(\d+ files, e.g. "
                                              r"timeseries.csv, summary.json.*\); "
                                              r"pass overwrite=True"):
        r.save(out)
    assert tree(out) == before
    assert r.save(out, overwrite=True) == out
    # the earlier run's figures went with it (its manifest listed them); the rest stayed
    assert sorted(os.listdir(out)) == [".unidyn-run.json", "mine.txt", "summary.json",
                                       "timeseries.csv"]
    assert T_of(out) == 0.5 and (out / "mine.txt").read_text() == "mine\n"
    code, text, err = cli(tmp_path, "run", "--from", out, "--out", tmp_path / "again")
    assert code == 0, err


@pytest.mark.slow
def test_run_from_a_folder_whose_replacement_was_cut_short_says_so(tmp_path):
    out = tmp_path / "R"
    assert cli(tmp_path, "run", "--T", "1", "--out", out)[0] == 0
    manifest = out / ".unidyn-run.json"
    manifest.write_text(json.dumps({**json.loads(manifest.read_text()), "complete": False}))
    code, _, err = cli(tmp_path, "run", "--from", out, "--out", tmp_path / "again")
    assert code == 2 and len(err.strip().splitlines()) == 1 and "cut short" in err, err
    assert not (tmp_path / "again").exists()


@pytest.mark.slow
def test_sweep_messages_speak_in_flags(tmp_path):
    f = tmp_path / "s.toml"
    f.write_text('[base]\ncase = "kinematic"\nT = 0.5\nnoise = "off"\n[grid]\nkx = [1.0, 2.0]\n')
    g = tmp_path / "g.toml"
    g.write_text(f.read_text().replace("[1.0, 2.0]", "[3.0]"))  # a different sweep
    assert cli(tmp_path, "sweep", f, "--out", "S", "--no-progress")[0] == 0
    record = tmp_path / "S" / "sweep.json"
    for extra in ([g], [f, "--no-resume"]):
        code, _, err = cli(tmp_path, "sweep", *extra, "--out", "S", "--no-progress")
        assert code == 2 and len(err.strip().splitlines()) == 1, err
        assert "--overwrite" in err and "overwrite=True" not in err, err
        assert "resume=False" not in err, err
    code, _, err = cli(tmp_path, "sweep", f, "--out", "S", "--no-progress", "--overwrite")
    assert code == 0, err
    assert json.loads(record.read_text())["finished"] is True


@pytest.mark.slow
def test_sweep_and_identify_into_the_working_folder_touch_only_their_files(tmp_path):
    """``unidyn sweep --out .`` started over, ``unidyn identify --out .`` replaced: the
    working folder stays the same folder, with the user's files byte for byte."""
    from .test_nothing_lost import write_log
    cwd = tmp_path / "work"
    cwd.mkdir()
    users_files(cwd)
    write_log(cwd / "log.csv", 1, T=20.0)
    (cwd / "s.toml").write_text('[base]\ncase = "kinematic"\nT = 0.5\nnoise = "off"\n'
                                '[grid]\nkx = [1.0, 2.0]\n')
    mine, inode = tree(cwd), cwd.stat().st_ino
    ours = {"metrics.csv", "sweep.json", ".sweep-id", "metrics.png", ".unidyn-sweep.json",
            "theta.json", "validation.json", "validation.png", ".unidyn-identify.json"}
    for extra in ([], ["--no-resume", "--overwrite"]):
        code, _, err = cli(cwd, "sweep", "s.toml", "--out", ".", "--no-progress", *extra)
        assert code == 0, err
    for extra in ([], ["--overwrite"]):
        code, _, err = cli(cwd, "identify", "log.csv", "--out", ".", *extra)
        assert code == 0, err
    assert tree(cwd, ours) == mine and cwd.stat().st_ino == inode
    assert set(os.listdir(cwd)) == set(mine) - {"data/raw.csv", "data/deep/x.bin"} | {
        "data"} | ours
