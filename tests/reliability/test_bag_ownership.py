"""``unidyn run --bag FILE.mcap`` writes a file outside ``--out``, under the same rules
as a results folder's files: a recording is replaced only where the folder's manifest
(``.unidyn-bag.json``) proves unidyn wrote it, never through a link, never by an
incomplete run; what a killed run left is removed by the next; a full disk names the
recording, the space left and what was kept. Each command is a real process, and
every file of the user's is compared by its SHA-256 before and after."""

from __future__ import annotations

import errno
import hashlib
import os
import signal
import subprocess
import sys
from pathlib import Path

import pytest

pytest.importorskip("rosbags")

from unidyn.results.folders import DiskFull  # noqa: E402
from unidyn.results.rosbag import BAG_NAME, check_bag_target  # noqa: E402

pytestmark = [pytest.mark.reliability, pytest.mark.slow]

RUN = ["run", "--paper", "1", "--T", "0.5", "--engine", "batch"]
DIVERGING = ["--set", 'trajectory={type = "circle", radius = 1e300, omega = 1e300}',
             "--set", "noise=off", "--T", "2"]


def unidyn(cwd, *args):
    env = dict(os.environ, MPLBACKEND="Agg")
    p = subprocess.run([sys.executable, "-m", "unidyn", *map(str, args)], cwd=cwd, env=env,
                       capture_output=True, text=True, timeout=300)
    return p.returncode, p.stdout, p.stderr


def sha(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def test_a_recording_of_the_users_is_never_replaced(tmp_path):
    """--overwrite is for --out: a recording unidyn did not write, where the bag goes,
    is refused before the run, with or without it."""
    mine = tmp_path / "robot_recording.mcap"
    mine.write_bytes(b"a recording of a real robot" * 100)
    before = sha(mine)
    for flags in ([], ["--overwrite"]):
        code, _, err = unidyn(tmp_path, *RUN, "--out", tmp_path / "out", *flags,
                              "--bag", mine)
        assert code == 2 and str(mine) in err and "never replaces it" in err, err
        assert len(err.strip().splitlines()) == 1
        assert sha(mine) == before
    assert not (tmp_path / "out").exists()  # refused before the run


def test_a_link_where_the_bag_goes_is_neither_followed_nor_replaced(tmp_path):
    real = tmp_path / "real.mcap"
    real.write_bytes(b"the user's real recording")
    link = tmp_path / "link.mcap"
    link.symlink_to(real)
    before = sha(real)
    code, _, err = unidyn(tmp_path, *RUN, "--out", tmp_path / "out", "--overwrite",
                          "--bag", link)
    assert code == 2 and "symbolic link" in err, err
    assert link.is_symlink() and os.readlink(link) == str(real) and sha(real) == before


def test_unidyns_recording_is_replaced_only_when_asked_and_never_by_an_incomplete_run(
        tmp_path):
    bag = tmp_path / "run.mcap"
    code, out, err = unidyn(tmp_path, *RUN, "--out", tmp_path / "out", "--bag", bag)
    assert code == 0 and f"written    {bag}" in out, err
    first = sha(bag)
    # without --overwrite: refused, the recording unidyn wrote kept
    code, _, err = unidyn(tmp_path, *RUN, "--out", tmp_path / "out2", "--bag", bag)
    assert code == 2 and "pass --overwrite" in err and sha(bag) == first
    # a run that stops early replaces neither the complete results nor the recording
    code, out, err = unidyn(tmp_path, "run", *DIVERGING, "--out", tmp_path / "out",
                            "--overwrite", "--bag", bag)
    assert code == 1, err
    assert f"kept       {bag} as it was" in out and sha(bag) == first
    # a complete run with --overwrite replaces it: it is unidyn's
    code, out, err = unidyn(tmp_path, *RUN, "--T", "0.7", "--out", tmp_path / "out",
                            "--overwrite", "--bag", bag)
    assert code == 0 and sha(bag) != first, err
    # and once edited, it is the user's: never replaced
    with open(bag, "ab") as fh:
        fh.write(b"edited")
    edited = sha(bag)
    code, _, err = unidyn(tmp_path, *RUN, "--out", tmp_path / "out", "--overwrite",
                          "--bag", bag)
    assert code == 2 and "unidyn did not write" in err and sha(bag) == edited


KILLED = """
import os, signal, sys
from pathlib import Path
from unidyn.results.rosbag import check_bag_target
target = check_bag_target(sys.argv[1])
def write(folder):
    part = Path(folder) / "run"
    part.mkdir()
    (part / "run.mcap").write_bytes(b"x" * 3_000_000)  # a recording half written
    os.kill(os.getpid(), signal.SIGKILL)
target.write(write)
"""


def test_what_a_run_killed_while_writing_its_bag_left_is_removed_by_the_next(tmp_path):
    bag = tmp_path / "run.mcap"
    theirs = tmp_path / ".unidyn-bag-new-0123456789ab"  # named like unidyn's: the user's
    theirs.mkdir()
    (theirs / "keep.txt").write_text("mine")
    env = dict(os.environ, MPLBACKEND="Agg")
    p = subprocess.run([sys.executable, "-c", KILLED, str(bag)], env=env, timeout=300)
    assert p.returncode == -signal.SIGKILL
    left = sorted(n for n in os.listdir(tmp_path) if n.startswith(".unidyn-bag-new-"))
    assert len(left) == 2 and not bag.exists()  # the killed run's, and the user's
    code, _, err = unidyn(tmp_path, *RUN, "--out", tmp_path / "out", "--bag", bag)
    assert code == 0, err
    assert sorted(n for n in os.listdir(tmp_path) if n.startswith(".unidyn-bag-new-")) \
        == [theirs.name]
    assert (theirs / "keep.txt").read_text() == "mine"
    assert not (tmp_path / ".unidyn.lock").exists()


def test_a_full_disk_while_writing_the_bag_names_it_and_keeps_the_earlier_one(tmp_path):
    """The writer fails as a full disk makes it fail (ENOSPC from a write of its own):
    one line naming the recording, how much was written, the space left, what was kept;
    no temporary file or private folder is left."""
    bag = tmp_path / "run.mcap"

    def full(folder):
        part = Path(folder) / "run.mcap"
        with open(part, "wb") as fh:
            fh.write(b"y" * 5000)
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    def good(folder):
        part = Path(folder) / "run.mcap"
        part.write_bytes(b"a recording unidyn wrote")
        return part

    with pytest.raises(DiskFull) as err:
        check_bag_target(bag).write(full)
    text = str(err.value)
    assert f"writing {bag} (" in text and " free)" in text and f"no {bag} was written" in text
    assert sorted(os.listdir(tmp_path)) == []
    assert check_bag_target(bag).write(good) and bag.read_bytes() == b"a recording unidyn wrote"
    with pytest.raises(DiskFull) as err:
        check_bag_target(bag, overwrite=True).write(full)
    assert f"the earlier {bag} is as it was" in str(err.value)
    assert bag.read_bytes() == b"a recording unidyn wrote"
    assert sorted(os.listdir(tmp_path)) == [".unidyn-bag.json", "run.mcap"]


@pytest.mark.parametrize("name", ["run.txt", ".unidyn-tmp-0123456789ab.mcap", "a/"])
def test_only_mcap_names_are_taken(tmp_path, name):
    from unidyn._validate import ValidationError
    with pytest.raises(ValidationError, match="--bag"):
        check_bag_target(tmp_path / name)
    assert BAG_NAME.fullmatch("run.MCAP")


def test_a_real_full_disk_at_the_bag_is_one_line_and_keeps_the_results(tmp_path):
    """A recording too big for its file system (a 256 kB tmpfs): one line naming it,
    the space left and that none was written; the run's results in --out intact; no
    private folder or temporary file left on the small file system."""
    small = tmp_path / "small"
    small.mkdir()
    p = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=256k", "tmpfs", str(small)],
                       capture_output=True, text=True)
    if p.returncode != 0:
        pytest.skip(f"cannot mount a tmpfs here: {(p.stderr or p.stdout).strip()}")
    try:
        (small / "notes.txt").write_text("mine\n")
        bag = small / "run.mcap"
        code, _, err = unidyn(tmp_path, "run", "--paper", "1", "--T", "300", "--engine",
                              "batch", "--out", tmp_path / "out", "--bag", bag)
        line = err.strip().splitlines()[-1]
        assert code == 2 and line.startswith(f"unidyn: error: No space left on device "
                                             f"writing {bag} ("), err
        assert " free" in line and line.endswith(f"no {bag} was written"), line
        assert sorted(os.listdir(small)) == ["notes.txt"]
        assert (tmp_path / "out" / "summary.json").exists()
    finally:
        subprocess.run(["umount", str(small)], check=False)
