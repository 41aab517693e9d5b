"""A sweep's points built as they are read, its chunks built as they are run, and its
size said (or the sweep refused) before it starts."""

import itertools
import os
import resource
import subprocess
import sys

import pytest

from unidyn import ValidationError
from unidyn.cli import main
from unidyn.sweeps import sweep as sw
from unidyn.sweeps.sizing import DISK_SHARE, LONG_SWEEP, SweepSize
from unidyn.sweeps.sweep import Sweep, SweepTooBig, run_sweep

# ------------------------------------------------------------------ lazy points


def test_the_points_are_the_product_of_the_axes_in_order():
    kxy, ku = [0.5, 1.0, 2.0], [1.0, 4.0]
    variants = [{"label": "a"}, {"label": "b", "kw": 3.0}]
    s = Sweep(base={"T": 1.0, "case": "compensated"}, grid={"kxy": kxy, "ku": ku},
              variants=variants)
    expected = list(itertools.product(variants, kxy, ku))
    points = s.points()
    assert len(s) == len(points) == len(expected) == 12
    for index, (p, (v, k, u)) in enumerate(zip(points, expected, strict=True)):
        assert p.index == index
        assert p.params == {"variant": v["label"], "kxy": k, "ku": u}
        assert (p.scenario.kx, p.scenario.ky, p.scenario.ku) == (k, k, u)
        assert p.scenario.kw == v.get("kw", 4.0)  # the paper's kw where the variant keeps it
    assert points[-1].params == points[11].params and points[-12].index == 0
    assert [p.index for p in points[2:9:3]] == [2, 5, 8]
    with pytest.raises(IndexError, match="12 points"):
        points[12]


def test_a_combination_of_valid_values_that_makes_no_scenario_is_named_with_its_point(
        tmp_path):
    """Every value is checked on construction; T = 0.05 with Ts = 0.1 (each value valid
    with the other axis's first) is named when its point is read, and a sweep whose first
    chunk holds it stops before writing anything."""
    s = Sweep(base={"case": "compensated"}, grid={"T": [1.0, 0.05], "Ts": [0.01, 0.1]})
    assert s.points()[2].scenario.T == 0.05
    with pytest.raises(ValidationError, match=r"sweep point 3 \(T=0.05, Ts=0.1\).*Ts"):
        s.points()[3]
    with pytest.raises(ValidationError, match="sweep point 3"):
        run_sweep(s, tmp_path / "out", progress=False)
    assert not (tmp_path / "out").exists()
    with pytest.raises(ValidationError, match=r"grid.T|sweep point 1 .*T=0.05"):
        Sweep(base={"case": "compensated", "Ts": 0.1}, grid={"T": [1.0, 0.05]})


# ------------------------------------------------------------------ lazy chunks

def seed_sweep(**kw):
    """The seed axis first (slowest), its smallest seed in the middle."""
    return Sweep(base={"T": 0.5, "case": "compensated"},
                 grid={"seed": [2, 0, 1], "kxy": [0.5, 1.0, 2.0]}, **kw)


@pytest.mark.parametrize("size", [1, 2, 4, 40])
@pytest.mark.parametrize("done", [set(), {1, 4, 7}, {0, 2, 3, 5, 8}])
def test_chunks_write_every_pending_point_once_with_the_run_its_seeds_share(size, done):
    s = seed_sweep()
    group = {}  # points by their values of the other axes, found from their params
    for p in s.points():
        group.setdefault(p.params["kxy"], []).append(p)
    smallest = {k: min(ps, key=lambda p: p.params["seed"]).index for k, ps in group.items()}
    written = []
    for chunk in sw._chunks(s, done, size):
        assert len(chunk) <= max(size, 2)  # more only for one point and its sibling
        indices = {c[0] for c in chunk}
        for index, params, sc, write in chunk:
            assert sc == s.points()[index].scenario
            assert smallest[params["kxy"]] in indices  # the run whose estimate it shares
            if write:
                written.append(index)
            else:  # only the shared run is run unwritten: its row is written once elsewhere
                assert index == smallest[params["kxy"]]
    assert sorted(written) == sorted(set(range(len(s))) - done)


def test_a_point_over_many_seeds_is_cut_into_chunks_each_with_the_shared_run():
    """100,000 seeds of one gain: chunks of 40 built as they are asked for, each with the
    smallest seed's run; the sweep is made without building its 100,000 scenarios."""
    s = Sweep(base={"T": 1.0, "case": "compensated"},
              grid={"kxy": [1.0], "seed": list(range(100_000, 0, -1))})
    chunks = sw._chunks(s, set(), 40)
    for _ in range(3):
        chunk = next(chunks)
        assert len(chunk) <= 40
        assert any(sc.noise.seed == 1 for _, _, sc, _ in chunk)


def test_rows_are_the_same_however_the_sweep_is_cut(tmp_path):
    """The seed axis slowest: chunks of one group and of the whole sweep give the same
    rows, numerical error estimates included."""
    one = run_sweep(seed_sweep(), tmp_path / "one", chunk_size=1, progress=False)
    whole = run_sweep(seed_sweep(), tmp_path / "whole", chunk_size=40, progress=False)
    assert one.rows == whole.rows
    assert all(r["numerical_error"] is not None for r in one.rows)


# ------------------------------------------------------------------ refusal

def size(**kw):
    base = dict(points=10, total=10, seconds=10.0, timed=4, bytes=1000, peak=2000,
                free=10**9)
    return SweepSize(**{**base, **kw})


def test_a_sweep_over_an_hour_or_half_the_free_disk_is_refused_saying_how_to_run_it():
    assert size(seconds=LONG_SWEEP).refusal == ""
    assert size(peak=int(DISK_SHARE * 10**9)).refusal == ""
    long = size(seconds=LONG_SWEEP + 60).refusal
    assert long.startswith("the sweep would take longer than 1 h: 10 points to run, "
                           "about 1 h 1 min (timed on 4 points)")
    assert long.count("1 h 1 min") == 1
    assert "yes=True" in long and "dask_address='local'" in long
    full = size(peak=int(DISK_SHARE * 10**9) + 1).refusal
    assert full.startswith("the sweep would take more than 50% of the free disk (about "
                           "500.0 MB at its largest): ")
    assert "(1.0 GB free)" in full


def test_the_command_line_names_the_flags_in_the_refusal():
    from unidyn.cli.errors import flag_words
    text = flag_words(size(seconds=2 * LONG_SWEEP).refusal)
    assert "pass --yes to start it anyway" in text and "(--dask 'local'" in text


@pytest.mark.slow
def test_a_million_point_sweep_file_is_sized_and_refused_in_seconds(tmp_path):
    """A 1000 x 1000 grid of 250 s runs: the command answers with its points, time and
    disk and refuses without --yes, under CI with no stdin, without building the million
    scenarios (a few seconds of CPU and the memory of a few points, where building them
    took minutes and gigabytes); nothing is written."""
    f = tmp_path / "big.toml"
    f.write_text('name = "big"\n[base]\ncase = "compensated"\nT = 250\nnoise = "off"\n'
                 "[grid]\nkxy = {start = 0.001, stop = 1.0, num = 1000}\n"
                 "ku = {start = 0.001, stop = 1.0, num = 1000}\n")
    env = {**os.environ, "MPLBACKEND": "Agg", "CI": "true"}
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    p = subprocess.run([sys.executable, "-m", "unidyn", "sweep", str(f), "--out",
                        str(tmp_path / "out")], capture_output=True, text=True, env=env,
                       stdin=subprocess.DEVNULL, timeout=120)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    assert p.returncode == 2, p.stderr
    assert "1,000,000 points" in p.stdout
    error, = [ln for ln in p.stderr.splitlines() if ln.startswith("unidyn: error:")]
    assert "the sweep would take longer than 1 h: " in error and " h " in error
    assert "1,000,000 points to run" in error and "MB written" in error
    assert "--yes" in error and "--dask" in error
    assert not (tmp_path / "out").exists()
    cpu = (after.ru_utime + after.ru_stime) - (before.ru_utime + before.ru_stime)
    assert cpu < 60, cpu
    assert after.ru_maxrss < 1_000_000, after.ru_maxrss  # kB: under 1 GB


@pytest.mark.slow
def test_no_progress_silences_the_size_as_it_does_the_progress(tmp_path, capsys):
    f = tmp_path / "s.toml"
    f.write_text('[base]\ncase = "compensated"\nT = 30\nnoise = "off"\n'
                 "[grid]\nkxy = [0.5, 1.0]\n")  # seconds of the diagram's runs
    main(["sweep", str(f), "--out", str(tmp_path / "a"), "--engine", "bdsim"])
    said = capsys.readouterr().err
    assert said.startswith("sweep: 2 points to run, about "), said
    main(["sweep", str(f), "--out", str(tmp_path / "b"), "--engine", "bdsim", "--no-progress"])
    assert capsys.readouterr().err == ""


@pytest.mark.slow
def test_run_sweep_refuses_a_sweep_of_hours_before_writing_anything(tmp_path):
    s = Sweep(base={"case": "compensated", "T": 250.0, "noise": "off"},
              grid={"kxy": {"start": 0.001, "stop": 1.0, "num": 1000},
                    "ku": {"start": 0.001, "stop": 1.0, "num": 1000}})
    refused = r"longer than 1 h: 1,000,000 points to run, about \d+ h .*yes=True"
    with pytest.raises(SweepTooBig, match=refused):
        run_sweep(s, tmp_path / "out", progress=False)
    assert not (tmp_path / "out").exists()
