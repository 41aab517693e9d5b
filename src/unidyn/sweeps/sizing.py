"""How big a sweep is, said before it starts: its points, the time they should take and
the disk they will fill (:func:`size_sweep`), and whether it is too big to start
without being asked to (:attr:`SweepSize.refusal`).

The time is measured, not guessed: the sweep's first chunk (at most
:data:`CALIBRATION_POINTS` of its points, with their seeds as the sweep runs them) is
run here twice, shortened to two durations (the second long enough to take about
:data:`CALIBRATION_SECONDS`), after a first run that loads the compiled engine; a
straight line through the two times gives the chunk's fixed cost and its cost per
simulated second, and so the time of the whole sweep at its own ``T``; the time to
build the chunk's scenarios is added. The disk is the size of the rows
those runs give, as ``metrics.csv`` writes them, times the points to run."""

from __future__ import annotations

import math
import os
import shutil
import time
from dataclasses import dataclass
from pathlib import Path

from .._validate import ValidationError
from ..progress import duration

__all__ = ["SweepSize", "size_sweep", "LONG_SWEEP", "DISK_SHARE", "CALIBRATION_POINTS",
           "CALIBRATION_T"]

#: A sweep estimated to take longer than this (s) does not start without ``yes``.
LONG_SWEEP = 3600.0
#: A sweep whose files would take more than this share of the free disk does not start
#: without ``yes``.
DISK_SHARE = 0.5
#: Points of the first chunk timed for the estimate, at most.
CALIBRATION_POINTS = 16
#: Simulated seconds of the first timing run (where the sweep's runs are longer).
CALIBRATION_T = 1.0
#: Wall seconds the second timing run is made to take, about (its duration at most 50
#: times the first's and at most the sweep's own).
CALIBRATION_SECONDS = 0.3


@dataclass(frozen=True)
class SweepSize:
    """A sweep's size before it runs.

    :ivar points: points to run (those not finished already)
    :ivar total: points of the sweep
    :ivar seconds: estimated wall time of the points to run
    :ivar timed: points whose runs the estimate was measured on
    :ivar bytes: estimated bytes of the files written (``metrics.csv``, and
        ``statistics.csv`` where the sweep varies ``seed``)
    :ivar peak: estimated disk needed at the most: ``bytes`` and a second copy of
        ``metrics.csv`` while it is rewritten sorted at the end
    :ivar free: free bytes on the output folder's disk
    :ivar workers: Dask workers sharing the points (1 here)
    """

    points: int
    total: int
    seconds: float
    timed: int
    bytes: int
    peak: int
    free: int
    workers: int = 1

    @property
    def line(self) -> str:
        """The size for a reader, one line."""
        done = self.total - self.points
        return (f"{self.points:,} points to run" + (f" ({done:,} done)" if done else "")
                + f", {_about(self.seconds)}"
                + (f" on {self.workers} Dask workers" if self.workers > 1 else "")
                + f" (timed on {self.timed} point{'s' if self.timed != 1 else ''}), "
                f"about {amount(self.bytes)} written ({amount(self.free)} free)")

    @property
    def refusal(self) -> str:
        """Why the sweep should not start without being asked to ("" where it may): it
        would take longer than :data:`LONG_SWEEP`, or more than :data:`DISK_SHARE` of
        the free disk."""
        why = []
        if self.seconds > LONG_SWEEP:
            why.append(f"longer than {LONG_SWEEP / 3600:g} h")
        if self.peak > DISK_SHARE * self.free:
            why.append(f"more than {DISK_SHARE:.0%} of the free disk (about "
                       f"{amount(self.peak)} at its largest)")
        if not why:
            return ""
        return (f"the sweep would take {' and '.join(why)}: {self.line}; pass yes=True to "
                f"start it anyway, run it on Dask (dask_address='local' for this machine's "
                f"cores, or a scheduler's address 'tcp://host:8786'), or make it smaller")


def amount(n: float) -> str:
    """Bytes for a reader: "820 B", "3.1 MB", "1.2 GB"."""
    for unit, size in (("TB", 1e12), ("GB", 1e9), ("MB", 1e6), ("kB", 1e3)):
        if n >= size:
            return f"{n / size:.1f} {unit}"
    return f"{n:.0f} B"


def free_bytes(folder: Path) -> int:
    """Free bytes on the disk that holds ``folder`` (or its nearest existing parent)."""
    folder = Path(os.path.abspath(folder))
    while not folder.exists() and folder.parent != folder:
        folder = folder.parent
    return shutil.disk_usage(folder).free


def size_sweep(sweep, out_dir, chunks, run_chunk, columns, rows_text, points: int,
               workers: int = 1) -> SweepSize:
    """The size of a sweep's ``points`` still to run, written into ``out_dir``, timed on
    the first of ``chunks`` (an iterator of the chunks the sweep runs, see
    :func:`unidyn.sweeps.sweep.run_sweep`) with ``run_chunk(chunk)`` (its rows);
    ``rows_text(columns, rows)`` is how metrics.csv writes rows."""
    free = free_bytes(out_dir)
    start = time.perf_counter()
    first = next(iter(chunks), None)
    built = time.perf_counter() - start  # the chunk's scenarios, built and checked
    if first is None or points == 0:
        return SweepSize(0, len(sweep), 0.0, 0, 0, 0, free, workers)
    sample = first[:CALIBRATION_POINTS]
    T = max(p[2].T for p in sample)
    rows, seconds = _timed(sample, run_chunk, T)
    timed = sum(1 for p in sample if p[3]) or len(sample)
    # the chunk's runs, written or not, per written point, as the sweep pays for them
    # (on the workers), and the time to build a point's scenario (here)
    run = seconds / timed * _T_scale(sweep, T) / max(workers, 1)
    build = built / len(first)
    row_bytes = len(rows_text(columns, rows, header=False).encode()) / max(len(rows), 1)
    csv_bytes = len(rows_text(columns, []).encode()) + row_bytes * len(sweep)
    stats = row_bytes * len(sweep) / len(sweep.grid["seed"]) if "seed" in sweep.grid else 0
    return SweepSize(points=points, total=len(sweep),
                     seconds=(run + build) * points, timed=len(sample),
                     bytes=round(csv_bytes + stats), peak=round(2 * csv_bytes + stats),
                     free=free, workers=workers)


def _T_scale(sweep, T: float) -> float:
    """The mean duration of the sweep's points over that of the points timed, where
    ``T`` is one of the grid's axes (1 otherwise)."""
    if "T" not in sweep.grid or T <= 0:
        return 1.0
    values = [float(v) for v in sweep.grid["T"]]
    return sum(values) / len(values) / T


def _timed(sample, run_chunk, T: float):
    """The rows of ``sample`` and the estimated seconds its runs take at their own ``T``.
    After a short first run that loads the engine, the sample is timed at a duration of
    :data:`CALIBRATION_T` s, then at one long enough to take about
    :data:`CALIBRATION_SECONDS` (at most ``T``, timed as it is where reached); a
    straight line through the two times gives the time at ``T``."""
    run_chunk(_shortened(sample, min(T, CALIBRATION_T / 8))[0])  # the engine loaded
    t_a, T_a, rows = _clock(run_chunk, sample, min(T, CALIBRATION_T))
    if T_a >= T:
        return rows, t_a
    t_b, T_b, rows = _clock(run_chunk, sample, min(
        T, T_a * min(max(CALIBRATION_SECONDS / max(t_a, 1e-6), 2.0), 50.0)))
    if T_b >= T:
        return rows, t_b
    slope = (t_b - t_a) / (T_b - T_a) if T_b > T_a else 0.0
    if slope <= 0:  # the two times did not tell the cost per second apart
        return rows, t_b * T / T_b
    return rows, max(t_b + slope * (T - T_b), 0.0)


def _clock(run_chunk, sample, T: float):
    """The seconds the sample's runs take shortened to ``T``, the duration they had (the
    longest of the runs) and their rows."""
    chunk, T = _shortened(sample, T)
    start = time.perf_counter()
    rows = run_chunk(chunk)
    return time.perf_counter() - start, T, rows


def _shortened(sample, T: float) -> tuple:
    """The sample's points with their duration cut to about ``T`` (whole sample times;
    as they are where their scenario allows no shorter run), and the longest duration."""
    out = []
    for index, params, sc, write in sample:
        short = sc
        if T < sc.T:
            try:
                short = sc.replace(T=max(math.floor(T / sc.Ts + 1e-9), 1) * sc.Ts)
            except (ValidationError, ValueError):
                pass
        out.append((index, params, short, write))
    return out, max(p[2].T for p in out)


def _about(seconds: float) -> str:
    text = duration(seconds)
    return text if text.startswith("under") else f"about {text}"
