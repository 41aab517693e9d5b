"""Progress as every long job shows it (unidyn.progress.Progress): off a terminal a
plain line when a tenth more is done or every few seconds, with the time left; on a
terminal a bar; nothing from a job that ends within a second."""

import dataclasses
import io
import os
import re
import subprocess
import sys

import pytest

from unidyn.progress import EVERY, QUIET, Progress, duration


class Clock:
    """A clock the test moves by hand."""

    def __init__(self):
        self.now = 100.0

    def __call__(self):
        return self.now


class Terminal(io.StringIO):
    def isatty(self):
        return True


def lines(stream):
    return [ln for ln in stream.getvalue().splitlines() if ln]


def test_off_a_terminal_a_line_per_tenth_with_the_time_left():
    clock, out = Clock(), io.StringIO()
    bar = Progress(None, 1000, desc="job", unit="sample", stream=out, clock=clock)
    for _ in range(40):  # 1000 samples at 25 samples per 0.25 s: 10 s in all
        clock.now += 0.25
        bar.advance(25)
    bar.close()
    shown = lines(out)
    # a line at each tenth, then the last one
    assert len(shown) == 11, shown
    assert shown[0] == "job: 100 of 1,000 samples (10 %), 1 s elapsed, about 9 s left"
    assert shown[5] == "job: 600 of 1,000 samples (60 %), 6 s elapsed, about 4 s left"
    assert shown[-2] == "job: 1,000 of 1,000 samples (100 %), 10 s elapsed"
    assert shown[-1] == "job: 1,000 samples in 10 s"


def test_a_slow_job_speaks_every_few_seconds_between_tenths():
    clock, out = Clock(), io.StringIO()
    bar = Progress(True, 1000, desc="slow", stream=out, clock=clock)
    for _ in range(30):  # 1 sample a second: no tenth is reached in 30 s
        clock.now += 1.0
        bar.advance(1)
    shown = lines(out)
    assert len(shown) == int((30 - QUIET) // EVERY) + (QUIET % EVERY != 0), shown
    left = [int(m) for m in re.findall(r"about (\d+) min", out.getvalue())]
    assert left and all(15 <= m <= 17 for m in left), shown  # (1000 - n) s at 1 sample/s


def test_a_short_job_and_a_disabled_one_say_nothing():
    clock, out = Clock(), io.StringIO()
    bar = Progress(None, 10, stream=out, clock=clock)
    for _ in range(10):
        clock.now += QUIET / 20
        bar.advance(1)
    bar.close()
    bar = Progress(False, 10, stream=out, clock=clock)
    clock.now += 60
    bar.advance(10)
    bar.close()
    bar = Progress(None, 10, show=False, stream=out, clock=clock)
    clock.now += 60
    bar.advance(10)
    bar.close()
    assert out.getvalue() == ""


def test_a_resumed_job_estimates_from_the_part_it_ran():
    clock, out = Clock(), io.StringIO()
    bar = Progress(None, 100, unit="point", initial=50, stream=out, clock=clock)
    clock.now += 5
    bar.advance(10)  # 10 points in 5 s, 40 to go: 20 s
    assert lines(out) == ["unidyn: 60 of 100 points (60 %), 5 s elapsed, about 20 s left"]


def test_a_growing_total_and_a_callable():
    seen = []
    bar = Progress(lambda d, t: seen.append((d, t)), 10)
    bar.advance(4)
    bar.grow(10)
    bar.to(3)  # never back
    bar.to(8)
    assert seen == [(4, 10), (8, 20)]


def test_on_a_terminal_a_bar():
    term = Terminal()
    bar = Progress(None, 8, desc="sweep", unit="point", leave=True, stream=term)
    bar.advance(8)
    bar.close()
    assert "sweep: 100%" in term.getvalue() and "8/8" in term.getvalue()


def test_durations_read_as_a_person_says_them():
    assert [duration(s) for s in (0.4, 59.4, 200, 7500)] == ["under 1 s", "59 s", "3 min 20 s",
                                                             "2 h 5 min"]


@pytest.mark.slow
def test_a_sweep_off_a_terminal_speaks_and_ends_saying_what_it_wrote(tmp_path):
    """A real process whose stderr is a pipe: lines with the time left while it runs,
    then what it wrote and how long it took."""
    f = tmp_path / "s.toml"
    f.write_text('name = "gains"\n[base]\ncase = "compensated"\nT = 150\nnoise = "off"\n'
                 '[grid]\nkxy = {start = 0.5, stop = 20, step = 0.5}\n')
    env = {**os.environ, "MPLBACKEND": "Agg"}
    p = subprocess.run([sys.executable, "-m", "unidyn", "sweep", str(f), "--out",
                        str(tmp_path / "o"), "--chunk-size", "4"], capture_output=True,
                       text=True, env=env, timeout=600)
    assert p.returncode == 0, p.stderr
    said = [ln for ln in p.stderr.splitlines() if ln.startswith("sweep: ")]
    assert said, p.stderr
    if "points to run" in said[0]:  # first its size, where estimated at a second or more
        assert re.fullmatch(r"sweep: 40 points to run, about \d+ (s|min \d+ s) \(timed on 4 "
                            r"points\), about [\d.]+ kB written \([\d.]+ [kMGT]?B free\)",
                            said.pop(0)), p.stderr
    for ln in said[:-1]:
        assert re.fullmatch(r"sweep: \d+ of 40 points \(\d+ %\), \d+ s elapsed"
                            r"(, (about \d+ (s|min \d+ s)|under 1 s) left)?", ln), ln
    assert re.fullmatch(r"sweep: 40 points in \d+ s", said[-1]), said
    assert "\r" not in p.stderr  # no bar drawn into a pipe
    assert re.search(r"ran 40 points in [\d.]+ s; written .*o/ \(metrics.csv", p.stdout)


def test_work_that_did_not_finish_ends_without_a_closing_line():
    clock, out = Clock(), io.StringIO()
    with pytest.raises(KeyboardInterrupt):
        with Progress(None, 100, desc="cut", stream=out, clock=clock) as bar:
            clock.now += 2
            bar.advance(50)
            raise KeyboardInterrupt
    assert lines(out) == ["cut: 50 of 100 samples (50 %), 2 s elapsed, about 2 s left"]


@pytest.mark.slow
def test_a_seeds_run_off_a_terminal_speaks_and_ends_saying_what_it_wrote(tmp_path):
    env = {**os.environ, "MPLBACKEND": "Agg"}
    p = subprocess.run([sys.executable, "-m", "unidyn", "run", "--paper", "3", "--seeds", "200",
                        "--engine", "batch", "--out", str(tmp_path / "o")], capture_output=True,
                       text=True, env=env, timeout=600)
    assert p.returncode == 0, p.stderr
    said = [ln for ln in p.stderr.splitlines() if ln.startswith("unidyn batch: ")]
    assert any(re.fullmatch(r"unidyn batch: [\d,]+ of [\d,]+ samples \(\d+ %\), \d+ s "
                            r"elapsed, about \d+ s left", ln) for ln in said), p.stderr
    assert re.fullmatch(r"unidyn batch: [\d,]+ samples in \d+ s", said[-1]), said
    assert re.search(r"^wall time +[\d.]+ s$", p.stdout, re.M)
    assert re.search(r"^written +.*o/ \(runs.csv", p.stdout, re.M)


def test_parts_of_a_unit_count_as_not_yet_done():
    clock, out = Clock(), io.StringIO()
    bar = Progress(None, 2, unit="point", stream=out, clock=clock)
    clock.now += 9
    bar.to(1.6)  # a sweep's second point 60 % run
    assert lines(out) == ["unidyn: 1 of 2 points (80 %), 9 s elapsed, about 2 s left"]
    clock.now += 1.5
    bar.to(1.9)
    assert lines(out)[-1] == "unidyn: 1 of 2 points (95 %), 10 s elapsed, under 1 s left"


@pytest.mark.parametrize("estimate", ["per_point", "each"])
def test_the_batch_engine_counts_the_work_it_does(estimate):
    # four noise seeds of one point: the work counted at the start (each run and its
    # probe, or once for a run that starts from its sibling's tolerance) plus what each
    # tighter pass adds is the work done, so the last report reads 100 %
    import unidyn
    from unidyn.engine.batch import simulate_batch
    sc = unidyn.Scenario.paper(3, T=5.0)
    seen = []
    runs = [sc.replace(noise=dataclasses.replace(sc.noise, seed=s)) for s in range(4)]
    simulate_batch(runs, progress=lambda done, total: seen.append((done, total)),
                   estimate=estimate)
    done, total = seen[-1]
    assert done == total and total >= 4 * sc.steps, seen[-3:]
    assert all(d <= t for d, t in seen)
