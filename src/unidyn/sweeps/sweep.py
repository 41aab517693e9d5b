r"""Parameter sweeps: many runs of the Fig. 2 loop from one spec, in resumable chunks.

A :class:`Sweep` is a base scenario (fields of :class:`~unidyn.Scenario`), a grid
of axes (field -> values) and optional named variants; its points are every
variant crossed with every combination of the axes. :func:`run_sweep` runs the
points in chunks and appends one row per finished point to ``metrics.csv``, so
an interrupted sweep keeps what it finished and a re-run completes only the
rest. A sweep file (TOML)::

    name = "gain sweep"

    [base]                      # any Scenario field; defaults are the paper's
    case = "compensated"
    T = 250
    noise = "off"

    [grid]                      # axes, crossed; the last one varies fastest
    kxy = {start = 0.5, stop = 35, step = 0.5}   # kx = ky, 0.5, 1.0, ..., 35.0
    theta_hat_scale = [0.9, 1.0]                 # theta_hat0 = scale * robot theta

    [[variants]]                # optional; each is crossed with the grid
    label = "exact"
    theta_hat_scale = 1.0

Besides the Scenario fields, base, grid and variants accept four special keys:
``kxy`` (sets kx = ky), ``theta_hat_scale`` (theta_hat0 = scale x the robot's
theta), ``seed`` (noise.seed) and ``case``. A range is a table with ``start``,
``stop`` (included) and either ``step`` or ``num`` (with ``log = true`` for a
geometric range).

Sweep files and ``metrics.csv`` are read and written by :mod:`unidyn.sweeps.sweep_files`, the
sweep figures are drawn by :mod:`unidyn.results.plots`, chunks run on Dask through
:mod:`unidyn.sweeps.cluster`, and the paper's Fig. 11 sweep, its claims and its figure live in
:mod:`unidyn.paper` (:func:`~unidyn.paper.paper_fig11`,
:func:`~unidyn.paper.fig11_claims`, :func:`~unidyn.paper.plot_fig11`).
"""

from __future__ import annotations

import dataclasses
import errno
import functools
import json
import math
import operator
import sys
import time
import unicodedata
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .. import __version__
from .._errors import Interrupted
from .._validate import (
    BATCH_ATOL,
    BATCH_RTOL,
    MAX_NAME,
    ValidationError,
    choice,
    did_you_mean,
    flag,
    integer,
    tolerances,
)
from ..diagrams.simulate import simulate
from ..engine.batch import simulate_batch
from ..engines import ENGINES
from ..progress import QUIET, Progress
from ..results.folders import (
    Ledger,
    check_manifest,
    claimed_folder,
    disk_full,
    json_ready,
    output_folder,
)
from .cluster import connect_dask, run_on_dask, workers
from .plots import plot_metrics
from .sizing import SweepSize, size_sweep
from .statistics import seed_statistics, statistics_columns
from .sweep_files import (
    ID_NAME,
    MAX_POINTS,
    METRICS,
    RECORD_NAME,
    cell,
    check_keys,
    expand_range,
    finished_rows,
    is_number,
    plain,
    read_rows,
    read_sweep_id,
    read_sweep_record,
    read_toml,
    rows_text,
    scenario_from_layers,
    sweep_id_text,
    sweep_record_text,
    text,
)

__all__ = ["Sweep", "SweepPoint", "SweepPoints", "SweepRun", "SweepSize", "SweepTooBig",
           "run_sweep", "sweep_id", "SWEEP_FILES"]

#: Default points per chunk, by engine (:data:`unidyn.engines.ENGINES`): ``"batch"``,
#: :func:`unidyn.engine.batch.simulate_batch` once per chunk (sampled-control points go
#: through :func:`unidyn.simulate`); ``"bdsim"``, :func:`unidyn.simulate` per point.
DEFAULT_CHUNK = {"batch": 40, "bdsim": 1}

#: Chunks per Dask worker at least, where the chunk size is not given: a worker reports
#: a chunk when it has run all of it, so smaller chunks make finer progress.
DASK_CHUNKS = 8

_TOP_KEYS = ("name", "base", "grid", "variants", "rtol", "atol")


# -------------------------------------------------------------------------- Sweep

def _axis_values(axis, values) -> tuple:
    """A grid axis' values (a list, or a range table {start, stop, step}), checked: a
    name an axis may have, at least one value, none twice (1 and 1.0 are one value)."""
    where = f"grid.{axis}"
    if axis in ("variant", "label", "name"):
        raise ValidationError(f"{where}: {axis!r} cannot be a grid axis"
                              + (" (use [[variants]])" if axis != "name" else ""))
    check_keys("grid", {axis: None})
    if isinstance(values, Mapping):
        values = expand_range(where, values)
    elif isinstance(values, (list, tuple, np.ndarray)):
        values = [plain(v) for v in values]
    else:
        raise ValidationError(f"{where} must be a list of values or a range table "
                              f"{{start, stop, step}}, got {values!r}")
    if not values:
        raise ValidationError(f"{where} is empty; give at least one value")
    seen = set()
    for v in values:
        try:  # 1 and 1.0 are one value
            key = float(v) if is_number(v) else cell(v)
        except OverflowError:  # an integer beyond floats: refused with its point
            key = cell(v)
        if key in seen:
            raise ValidationError(f"{where} has the value {v!r} twice")
        seen.add(key)
    return tuple(values)


def _variant(where, v, labels: set) -> dict:
    """A variant's table, checked: its keys, and a label on one line, not too long, not
    among ``labels`` (which it joins)."""
    v = check_keys(where, v, allow_label=True)
    label = v.get("label")
    if not isinstance(label, str) or not label or any(
            unicodedata.category(c) in ("Cc", "Zl", "Zp") for c in label):
        raise ValidationError(f"{where} needs a label (a non-empty string on one line: "
                              f"no line breaks, tabs or control characters), got "
                              f"{label!r}")
    if len(label) > MAX_NAME:
        raise ValidationError(f"{where}.label is {len(label)} characters long; at most "
                              f"{MAX_NAME} are allowed (it names rows and legends)")
    if label in labels:
        raise ValidationError(f"{where}: label {label!r} is used twice")
    labels.add(label)
    return v


@dataclass(frozen=True)
class SweepPoint:
    """One point of a sweep: its index, its axis values and its scenario."""

    index: int
    params: dict
    scenario: object

    def __iter__(self):  # unpacks as (index, params, scenario)
        return iter((self.index, self.params, self.scenario))


class SweepPoints(Sequence):
    """The points of a sweep as a sequence: each built when it is read
    (:meth:`Sweep.point`), none kept."""

    def __init__(self, sweep: "Sweep"):
        self.sweep = sweep

    def __len__(self) -> int:
        return len(self.sweep)

    def __getitem__(self, i):
        if isinstance(i, slice):
            return [self.sweep.point(k) for k in range(*i.indices(len(self)))]
        n = len(self)
        k = operator.index(i)
        if not -n <= k < n:
            raise IndexError(f"sweep point {i} out of range (the sweep has {n} points)")
        return self.sweep.point(k % n)


@dataclass(frozen=True)
class Sweep:
    """A set of scenarios: ``base`` crossed with ``variants`` and the ``grid`` axes.

    Every value of every axis is checked on construction (with the first value of the
    other axes); the points are built as they are read (:meth:`points`), and a
    combination of values that makes no valid scenario is named when its point is.

    :param base: Scenario fields and special keys (``kxy``, ``theta_hat_scale``,
        ``seed``) shared by every point
    :param grid: axis -> list of values (or a range table, see the module doc); the
        axes are crossed, the last one varying fastest
    :param variants: tables of overrides, each with a unique ``label``; every
        variant is crossed with the grid (an axis called ``variant``, varying slowest)
    :param name: a label
    :param rtol: relative tolerance of the batch engine (:func:`unidyn.simulate_batch`)
    :param atol: absolute tolerance of the batch engine
    """

    base: dict = field(default_factory=dict)
    grid: dict = field(default_factory=dict)
    variants: tuple = ()
    name: str = ""
    rtol: float = BATCH_RTOL
    atol: float = BATCH_ATOL

    def __post_init__(self):
        s = lambda k, v: object.__setattr__(self, k, v)  # noqa: E731
        if not isinstance(self.name, str):
            raise ValidationError(f"name must be a string, got {self.name!r}")
        if len(self.name) > MAX_NAME:
            raise ValidationError(f"name is {len(self.name)} characters long; at most "
                                  f"{MAX_NAME} are allowed (it titles the figures)")
        rtol, atol = tolerances(self.rtol, self.atol)
        s("rtol", rtol)
        s("atol", atol)
        s("base", check_keys("base", self.base))
        if not isinstance(self.grid, Mapping):
            raise ValidationError(f"grid must be a table of axis = [values], got {self.grid!r}")
        grid = {str(axis): _axis_values(axis, values) for axis, values in self.grid.items()}
        s("grid", grid)
        if isinstance(self.variants, Mapping) or not isinstance(self.variants, (list, tuple)):
            raise ValidationError(f"variants must be a list of tables ([[variants]]), "
                                  f"got {self.variants!r}")
        labels = set()
        variants = [_variant(f"variants[{i}]", v, labels) for i, v in enumerate(self.variants)]
        s("variants", tuple(variants))
        n = max(len(self.variants), 1) * math.prod(len(v) for v in grid.values())
        if n > MAX_POINTS:
            raise ValidationError(f"the sweep has {n} points; at most {MAX_POINTS} are allowed")
        shape = (max(len(self.variants), 1),) + tuple(len(v) for v in grid.values())
        s("_shape", shape)
        s("_strides", tuple(math.prod(shape[k + 1:]) for k in range(len(shape))))
        self._check_each_value()

    def _check_each_value(self):
        """Each axis value checked once, with the first value of every other axis: a work
        that grows with the sum of the axes' lengths, not with their product (a seed sets
        the noise's seed alone: checked as a seed, its points not built)."""
        for axis, size in enumerate(self._shape):
            if axis and list(self.grid)[axis - 1] == "seed":
                for v in self.grid["seed"]:
                    integer("grid.seed", v, 0)
                continue
            for value in range(1 if axis else 0, size):
                self.point(value * self._strides[axis])

    # ------------------------------------------------------------------ #
    @property
    def axes(self) -> list:
        """The axis names, slowest first: ``variant`` (if there are variants), then the grid's."""
        return (["variant"] if self.variants else []) + list(self.grid)

    @property
    def shape(self) -> tuple:
        """The number of values of each axis: the variants' first (1 where there are
        none, and :attr:`axes` does not name it), then the grid's, in order."""
        return self._shape

    @property
    def columns(self) -> list:
        """The columns of metrics.csv."""
        return (["index"] + self.axes + ([] if "case" in self.axes else ["case"])
                + list(METRICS) + ["numerical_error", "estimate", "sensitive", "complete",
                                   "message"])

    def __len__(self) -> int:
        return math.prod(self.shape)

    def points(self) -> "SweepPoints":
        """Every point as (index, params, scenario), in a fixed order: variants slowest,
        then the grid axes in their order, the last fastest. A sequence built as it is
        read (:meth:`point`): its memory does not grow with the number of points."""
        return SweepPoints(self)

    def point(self, index: int) -> SweepPoint:
        """The point at ``index`` (0 to ``len(self) - 1``), its scenario built and checked;
        a combination of values that makes no valid scenario raises a
        :class:`ValidationError` naming the point."""
        digits = []
        for stride, size in zip(self._strides, self.shape):
            digits.append(index // stride % size)
        v = self.variants[digits[0]] if self.variants else None
        combo = [values[d] for values, d in zip(self.grid.values(), digits[1:])]
        axes = list(self.grid)
        params = {} if v is None else {"variant": v["label"]}
        params.update(zip(axes, combo))
        layers = [("base", self.base)]
        if v is not None:
            layers.append((f"variants[{v['label']}]",
                           {k: x for k, x in v.items() if k != "label"}))
        layers.append(("grid", dict(zip(axes, combo))))
        desc = ", ".join(f"{k}={text(x)}" for k, x in params.items())
        if len(desc) > MAX_NAME:
            desc = desc[:MAX_NAME - 3] + "..."
        try:
            sc = scenario_from_layers(layers, name=(f"{self.name} " if self.name else "")
                                      + f"#{index}" + (f" ({desc})" if desc else ""))
        except ValidationError as err:
            at = f"sweep point {index}" + (f" ({desc})" if desc else "")
            raise ValidationError(f"{at}: {err}") from None
        return SweepPoint(index, params, sc)

    def with_base(self, **changes) -> "Sweep":
        """A copy with some base keys changed (validated)."""
        return dataclasses.replace(self, base={**self.base, **changes})

    # ------------------------------------------------------------------ #
    def to_dict(self) -> dict:
        """Plain data (JSON-ready) that :meth:`from_dict` turns back into this sweep."""
        out = {"name": self.name, "base": dict(self.base),
               "grid": {k: list(v) for k, v in self.grid.items()}}
        if self.variants:
            out["variants"] = [dict(v) for v in self.variants]
        out["rtol"], out["atol"] = self.rtol, self.atol
        return out

    @classmethod
    def from_dict(cls, data) -> "Sweep":
        """Build from plain data (as read from TOML or JSON). Unknown keys raise."""
        if not isinstance(data, Mapping):
            raise ValidationError(f"a sweep must be a table, got {type(data).__name__}")
        unknown = [k for k in data if k not in _TOP_KEYS]
        if unknown:
            raise ValidationError(f"unknown sweep key {unknown[0]!r}"
                                  f"{did_you_mean(unknown[0], _TOP_KEYS)}; allowed: "
                                  f"{', '.join(_TOP_KEYS)}")
        return cls(**data)

    @classmethod
    def from_toml(cls, path) -> "Sweep":
        """Read a sweep file (see the module doc)."""
        data = read_toml(path, "sweep file")
        try:
            return cls.from_dict(data)
        except ValidationError as err:
            raise ValidationError(f"{path}: {err}") from None


# ----------------------------------------------------------------------- running

class SweepTooBig(ValidationError):
    """A sweep that would take longer than an hour or fill much of the free disk, not
    started without ``yes=True`` (:attr:`unidyn.sweeps.sizing.SweepSize.refusal`)."""


@dataclass
class SweepRun:
    """What :func:`run_sweep` did.

    :ivar out_dir: the output folder
    :ivar rows: every point's row of metrics.csv (see :func:`unidyn.sweeps.sweep_files.read_metrics`), by index
    :ivar ran: points simulated by this call
    :ivar skipped: points already in metrics.csv (resumed)
    :ivar seconds: wall time of this call
    :ivar failed: indices of points that did not complete (empty metrics)
    :ivar replaced: indices of the rows of an earlier sweep that this one replaced
        (``overwrite=True``)
    :ivar size: the size estimated before the first point ran (:class:`SweepSize`):
        its ``seconds`` beside :attr:`points_seconds` say how good the estimate was
    :ivar points_seconds: wall time from the first point run to the last row written
    """

    out_dir: Path
    rows: list
    ran: int
    skipped: int
    seconds: float
    failed: list
    replaced: tuple = ()
    size: SweepSize | None = None
    points_seconds: float = 0.0


def _row(index, params, result) -> dict:
    """One row of metrics.csv: the point's metrics (of the part computed, for a run
    that stopped: ``complete`` says which), the largest of their estimated numerical
    errors (empty where not estimated), whether the run is sensitive, and ``message``."""
    error = result.numerical_error
    return {"index": index, **params, "case": result.scenario.case,
            **{m: _metric(result.metrics[m]) for m in METRICS},
            # the row's numbers: its metrics' estimates (the series' are the run's)
            "numerical_error": None if not error else max(float(error[m]) for m in METRICS),
            "estimate": result.estimate or None,
            "sensitive": bool(result.sensitive), "complete": bool(result.complete),
            "message": result.message}


def _failed_row(index, params, case, message) -> dict:
    """The row of a point that failed before its first sample: no metrics."""
    return {"index": index, **params, "case": case, **{m: None for m in METRICS},
            "numerical_error": None, "estimate": None, "sensitive": False, "complete": False,
            "message": message}


def _metric(v):
    return None if v is None else float(v)


def _run_chunk(points, engine: str, rtol: float, atol: float, progress=False) -> list:
    """Run one chunk of the sweep (:func:`_chunk_rows`)."""
    return _chunk_rows(points, engine, rtol, atol, progress)


def _chunk_rows(points, engine: str, rtol: float, atol: float, progress=False,
                warn: bool = True) -> list:
    """Simulate a list of (index, params, scenario, write); return the metrics rows of
    those to write (the others are run for the tolerance their seeds start from:
    :func:`_chunks`). ``progress``: ``False``, or ``f(done, total)`` in samples, called
    by the chunk's batch call, or by its diagram run where the chunk is one point;
    ``warn``: a point that fails is named on stderr.

    Runs wherever it is called (here or on a Dask worker) and returns only the
    small rows, not the time series."""
    rows = [None] * len(points)
    batch = []
    for j, (index, params, sc, _) in enumerate(points):
        if engine == "batch" and sc.control == "continuous":
            batch.append(j)
            continue
        try:  # a chunk's one diagram run reports to the sweep's progress, else none
            own = progress if len(points) == 1 else False
            rows[j] = _row(index, params, simulate(sc, progress=own))
        except (RuntimeError, ArithmeticError) as err:  # before its first sample
            if warn:
                print(f"unidyn: warning: sweep point {index} failed: {err}", file=sys.stderr)
            rows[j] = _failed_row(index, params, sc.case, str(err))
    if batch:
        results = simulate_batch([points[j][2] for j in batch], rtol=rtol, atol=atol,
                                 estimate="per_point", progress=progress)
        for j, r in zip(batch, results):
            index, params, _, _ = points[j]
            rows[j] = _row(index, params, r)
    return [row for row, p in zip(rows, points) if p[3]]


def _share(bar, start: float, points: int):
    """The progress callable of a chunk's batch call: ``bar`` moved from ``start`` by
    the chunk's ``points`` in proportion to the call's samples done."""
    def moved(done, total):
        if total > 0:
            bar.to(start + points * min(done / total, 1.0))
    return moved


def _chunks(sweep, done, size: int):
    """The points not in ``done`` (indices), in chunks of at most ``size`` points and the
    run their seeds share, as lists of (index, params, scenario, write), built as they
    are asked for: the memory of a chunk, whatever the sweep's size.

    A point's runs over the ``seed`` axis (the points that differ in it alone) start
    from the tolerance the smallest seed's run needed
    (:func:`unidyn.simulate_batch`'s ``estimate="per_point"``): they go in one chunk
    where they fit, in several otherwise, and each chunk that holds one of them holds
    that run too, added unwritten where its row is written elsewhere, so that every row
    is the same however the sweep is cut or resumed."""
    def entries(indices, write):
        return [(*sweep.point(i), write) for i in indices]

    chunk = []
    for members, ref in _seed_groups(sweep):
        todo = [i for i in members if i not in done]
        if not todo:
            continue
        extra = [] if ref in todo else [ref]
        if len(extra) + len(todo) <= size:  # the point's seeds fit in a chunk: together
            if chunk and len(chunk) + len(extra) + len(todo) > size:
                yield chunk
                chunk = []
            chunk += entries(extra, False) + entries(todo, True)
            continue
        if chunk:
            yield chunk
            chunk = []
        if ref in todo:  # a point over more seeds than a chunk holds: cut, each part
            todo.remove(ref)  # with the shared run (written in the first)
            todo.insert(0, ref)
        part = max(size - 1, 1)
        for k in range(0, len(todo), part):
            written = todo[k:k + part]
            yield entries([] if ref in written else [ref], False) + entries(written, True)
    if chunk:
        yield chunk


def _seed_groups(sweep):
    """The sweep's points by the values of its axes other than ``seed``, in the order of
    their first index: (indices, the index of the smallest seed) for each; every point
    alone where ``seed`` is not an axis."""
    if "seed" not in sweep.grid:
        for i in range(len(sweep)):
            yield [i], i
        return
    at = 1 + list(sweep.grid).index("seed")  # (the variant axis is first)
    seeds, stride = sweep.grid["seed"], sweep._strides[at]
    smallest = min(range(len(seeds)), key=lambda j: seeds[j])
    for outer in range(math.prod(sweep.shape[:at])):
        for inner in range(stride):
            first = outer * len(seeds) * stride + inner
            yield [first + j * stride for j in range(len(seeds))], first + smallest * stride


#: Every file a sweep's folder may hold (the names its manifest may list): the rows, the
#: record of the sweep, its figure, and the Fig. 11 claims and figure of ``unidyn sweep
#: --paper-fig11``. None of them is carried over when a sweep starts over.
SWEEP_FILES = ("metrics.csv", RECORD_NAME, ID_NAME, "metrics.png", "statistics.csv", "claims.md",
               "fig11.png")


def sweep_id(sweep: Sweep) -> str:
    """A hash of a sweep's full definition (its base, grid, variants, name and tolerances,
    and the first point's complete scenario, so changed defaults count), the same
    whatever the engine: ``"sha256:..."``."""
    import hashlib
    first = sweep.points()[0].scenario.to_dict()
    text = json.dumps({"sweep": sweep.to_dict(), "first": first},
                      sort_keys=True, separators=(",", ":"), default=str)
    return "sha256:" + hashlib.sha256(text.encode()).hexdigest()


def _spec_record(sweep: Sweep, engine: str) -> dict:
    return {"unidyn_version": __version__, "engine": engine, "points": len(sweep),
            "id": sweep_id(sweep), "columns": sweep.columns, "sweep": sweep.to_dict()}


def _differences(old, new, where="") -> list:
    """The dotted keys where two plain-data sweep definitions differ."""
    if isinstance(old, dict) and isinstance(new, dict):
        out = []
        for k in sorted(set(old) | set(new), key=str):
            out += _differences(old.get(k), new.get(k), f"{where}.{k}" if where else str(k))
        return out
    return [] if old == new else [where or "the definition"]


def _what_is_held(out: Path, record: dict) -> tuple:
    """What ``out`` holds: ``(state, detail)`` with state ``"none"`` (no sweep),
    ``"same"``, ``"engine"`` (this sweep with another engine), ``"different"`` or
    ``"unknown"`` (rows that no record ties to a sweep)."""
    spec_path, csv_path = out / RECORD_NAME, out / "metrics.csv"
    if not spec_path.exists() and not csv_path.exists():
        return "none", ""
    problem = check_manifest(out, "sweep", SWEEP_FILES)
    if problem:  # a replacement killed half way: rows and record may not match
        return "unknown", problem.replace(f"{out} holds", "it holds")
    if spec_path.exists():
        try:
            old = read_sweep_record(out)
        except ValueError as err:  # a UnicodeDecodeError too
            return "unknown", f"its sweep.json is not valid JSON ({err})"
        # as written (no limit: null; an old file's Infinity reads as inf)
        old_def, new_def = json_ready(old.get("sweep")), json_ready(record["sweep"])
        if "id" in old:
            same = old["id"] == record["id"]
        else:  # written before sweeps had an id: compare the definitions
            same = old_def == new_def
        if not same:
            diff = _differences(old_def, new_def)
            return "different", ("it differs in " + ", ".join(diff[:5])
                                 + (", ..." if len(diff) > 5 else "")
                                 if diff and diff != ["the definition"] else
                                 "its definition differs")
        if old.get("engine") != record["engine"]:
            return "engine", f"it was run with engine {old.get('engine')!r}"
        return "same", ""
    held = read_sweep_id(out)
    if not held:
        return "unknown", "no sweep.json or .sweep-id records which sweep its rows belong to"
    if held[0] != record["id"]:
        return "different", "its .sweep-id names another sweep (sweep.json is missing)"
    if held[1:2] != [record["engine"]]:
        return "engine", f"it was run with engine {' '.join(held[1:2]) or 'unknown'!r}"
    return "same", ""


def rows_named(indices) -> str:
    """Finished rows of metrics.csv (point indices) as one phrase: counted, with their
    indices as ranges ("3 finished row(s) in metrics.csv (points 0-2)")."""
    indices = sorted(indices)
    if not indices:
        return "no finished rows"
    runs, start = [], indices[0]
    for a, b in zip(indices, indices[1:] + [None]):
        if b != a + 1:
            runs.append(f"{start}" if start == a else f"{start}-{a}")
            start = b
    text = ", ".join(runs[:8]) + (", ..." if len(runs) > 8 else "")
    return f"{len(indices)} finished row(s) in metrics.csv (points {text})"


def run_sweep(sweep: Sweep, out_dir, engine: str = "batch", chunk_size: int | None = None,
              resume: bool = True, progress: bool = True, dask_address=None,
              overwrite: bool = False, yes: bool = False) -> SweepRun:
    """Run every point of ``sweep``, writing into ``out_dir``:

    - ``sweep.json``: the spec, its id (:func:`sweep_id`), engine and library
      version (written first); ``.sweep-id``: the id and engine again, so rows
      never lose their record
    - ``metrics.csv``: one row per finished point (columns :attr:`Sweep.columns`),
      appended and flushed after each chunk, rewritten sorted by index at the end;
      each row with its metrics, the largest of their estimated numerical errors and
      whether the run is sensitive (:func:`unidyn.simulate_batch`); a point that did not
      complete has ``complete = false`` and the metrics of the part computed
    - ``statistics.csv``, where the grid varies ``seed``: one row per point of the other
      axes, each metric's mean, standard deviation and standard error over the seeds
      (:func:`unidyn.sweeps.statistics.seed_statistics`)
    - ``metrics.png``: IAE against the first numeric axis (:func:`unidyn.sweeps.plots.plot_metrics`)

    Finished rows are never deleted without ``overwrite``:

    - ``resume=True`` (default): the points already in ``metrics.csv`` are
      skipped. A folder that holds a different sweep, this sweep run with another
      engine, or rows with no record of their sweep is refused unless ``overwrite``,
      which starts over as below.
    - ``resume=False``: start over. A folder with finished rows is refused unless
      ``overwrite``.
    - starting over where there are finished rows writes the new sweep into a private
      folder inside ``out_dir`` and moves its files into place only when every point
      has run: an error or an interrupt leaves the old sweep as it was (the new rows
      are discarded). Files in ``out_dir`` that the sweep did not write are never
      touched (see :mod:`unidyn.results.folders`).

    While it runs, the folder is locked (``.unidyn.lock``, holding the PID): a
    second process writing the same folder is refused with :class:`FolderInUse`.
    A sweep that fails before its first row leaves no files behind.

    :param engine: ``"batch"`` (one :func:`~unidyn.engine.batch.simulate_batch` call per chunk;
        sampled-control points run through :func:`unidyn.simulate`) or ``"bdsim"``
    :param chunk_size: points per chunk (default 40 for batch, 1 for bdsim; on Dask,
        smaller where the sweep would give a worker fewer than :data:`DASK_CHUNKS`)
    :param resume: skip the points already in ``metrics.csv``; ``False`` starts over
    :param progress: show a tqdm progress bar on stderr (only when it is a terminal)
    :param dask_address: ``"local"`` (a local cluster), a Dask scheduler address or a
        ``distributed.Client``: the chunks run on its workers (which need unidyn
        installed), and rows are written as they arrive (see :func:`unidyn.sweeps.cluster.connect_dask`)
    :param overwrite: allow finished rows to be replaced
    :param yes: start a sweep estimated to take more than an hour, or more than half
        the free disk, which is otherwise refused (:class:`SweepTooBig`) before it
        writes anything; the estimate (:func:`unidyn.sweeps.sizing.size_sweep`: the
        points to run, the time measured on a few of them, the bytes of their rows) is
        printed on stderr before the first point runs, unless ``progress`` is false
    :return: :class:`SweepRun`
    """
    t0 = time.perf_counter()
    if not isinstance(sweep, Sweep):
        raise ValidationError(f"sweep must be a unidyn.sweeps.sweep.Sweep, got {type(sweep).__name__}")
    engine = choice("engine", engine, ENGINES)
    resume, overwrite = flag("resume", resume), flag("overwrite", overwrite)
    yes = flag("yes", yes)
    if chunk_size is not None:
        chunk_size = integer("chunk_size", chunk_size, 1)
    out = Path(out_dir)
    output_folder(out, "out_dir")  # one line for an empty name or a file
    record = _spec_record(sweep, engine)
    if dask_address is None:
        client, close = None, None
    else:
        client, close = connect_dask(dask_address)
    if chunk_size is None:  # on Dask, at least DASK_CHUNKS chunks per worker: their
        # progress, which comes by whole chunks, in steps of at most 1/DASK_CHUNKS
        chunk_size = DEFAULT_CHUNK[engine] if client is None else max(1, min(
            DEFAULT_CHUNK[engine], len(sweep) // (DASK_CHUNKS * workers(client))))
    plan = {"resume": False, "held": []}

    def replace(folder) -> bool:  # (under the folder's lock)
        state, detail = _what_is_held(folder, record)
        held = finished_rows(folder / "metrics.csv") if state != "none" else []
        if state == "same" and resume:
            plan["resume"] = True
            return False
        if held and not overwrite:
            raise ValidationError(_refusal(out, state, detail, held, resume))
        plan["held"] = held  # nothing finished to lose: start over in place
        return bool(held)

    try:
        with claimed_folder(out, kind="sweep", names=SWEEP_FILES, replace=replace,
                            what="sweep results", option="out_dir") as place:
            run = _run_in(sweep, place.path, record, engine, chunk_size, progress, client,
                          t0, resume=plan["resume"], lock=place.lock, yes=yes)
    except SweepTooBig:
        raise
    except BaseException as err:
        if plan["held"]:  # a replacement: the old rows are as they were
            raise _kept(err, f"{out} is as it was ({rows_named(plan['held'])}); the "  # noqa: B904 (err itself, or Ctrl-C as Interrupted)
                             f"new sweep's rows were discarded")
        raise
    finally:
        if close is not None:
            close()
    if plan["held"]:
        run.out_dir = out
        run.replaced = tuple(plan["held"])
    return run


def _refusal(out, state, detail, rows, resume) -> str:
    held = rows_named(rows)
    if state in ("same", "none") and not resume:
        return (f"{out} holds {held}; starting over (resume=False) would delete them: add "
                f"overwrite=True to replace them once the new sweep has finished, or choose "
                f"another output folder")
    what = {"engine": "this sweep run with another engine",
            "different": "a different sweep",
            "unknown": "sweep rows of unknown origin"}.get(state, "a sweep")
    return (f"{out} holds {what} ({detail}): {held}; pass overwrite=True to replace them "
            f"once this sweep has finished, or choose another output folder")


def _kept(err: BaseException, text: str) -> BaseException:
    """The exception to raise for ``err``, saying what the sweep left behind: Ctrl-C
    becomes :class:`Interrupted` with ``text`` as its ``kept`` (the command line prints
    it); any other error gets ``text`` as a note, shown with its traceback."""
    if isinstance(err, KeyboardInterrupt):
        return Interrupted(text)
    err.add_note(text)
    return err


def _rows_in(csv_path: Path, columns, n: int) -> tuple:
    """The rows of a sweep of ``n`` points in its metrics.csv, by index (the last of an
    index written twice), and whether every line of the file was read."""
    rows, clean = read_rows(csv_path, columns)
    by_index = {r["index"]: r for r in rows if 0 <= r["index"] < n}
    return [by_index[i] for i in sorted(by_index)], clean


def _resumed(ledger, csv_path, columns, n) -> set:
    """The indices of the rows a resumed sweep finds finished in ``csv_path`` (a line cut
    short by an interruption dropped from the file)."""
    if not csv_path.exists():
        return set()
    rows, clean = _rows_in(csv_path, columns, n)
    if not clean:
        ledger.write("metrics.csv", rows_text(columns, rows))
    return {r["index"] for r in rows}


def _finish(ledger, sweep, csv_path, record):
    """A sweep's last files, once every row is in metrics.csv (a full disk from here on
    loses none): the rows sorted, the record finished, the statistics over seeds and
    the figure. Returns (the rows, the indices of the incomplete ones)."""
    columns = sweep.columns
    rows, _ = _rows_in(csv_path, columns, len(sweep))  # every row, as the file holds it
    failed = [r["index"] for r in rows if not r["complete"]]
    try:
        ledger.write("metrics.csv", rows_text(columns, rows))
        ledger.write(RECORD_NAME, sweep_record_text(record, finished=True, failed=failed))
        if "seed" in sweep.axes:
            ledger.write("statistics.csv", rows_text(statistics_columns(sweep.axes),
                                                     seed_statistics(rows, sweep.axes)))
        try:
            ledger.write_with("metrics.png", lambda path: plot_metrics(sweep, rows, path))
        except ImportError:  # no matplotlib: the data is what matters
            pass
    except OSError as err:
        if err.errno not in (errno.ENOSPC, errno.EDQUOT):
            raise
        raise disk_full(err, f"all {len(rows)} of {len(sweep)} points are in {csv_path}, "
                             f"intact (free some space and run the same command again to "
                             f"write the rest)") from None
    return rows, failed


def _run_in(sweep, out, record, engine, chunk_size, progress, client, t0, resume,
            lock=None, yes=False) -> SweepRun:
    """Run the sweep in ``out`` (locked by the caller or private): resume from its rows,
    or start it afresh. Every file is written through the folder's :class:`Ledger`,
    which records its content before it changes."""
    columns = sweep.columns
    owner = lock if lock is not None and lock.folder == output_folder(out) else None
    ledger = Ledger(out, "sweep", SWEEP_FILES, owner)  # (not a private folder's)
    csv_path = out / "metrics.csv"
    # the indices of the finished rows (the rows stay in the file)
    done = _resumed(ledger, csv_path, columns, len(sweep)) if resume else set()
    try:  # the time and disk it will take, said (or refused) before anything is written
        size = size_sweep(sweep, out, _chunks(sweep, done, chunk_size),
                          functools.partial(_chunk_rows, engine=engine, rtol=sweep.rtol,
                                            atol=sweep.atol, warn=False),
                          columns, rows_text, points=len(sweep) - len(done),
                          workers=workers(client))
    except KeyboardInterrupt as err:
        raise _kept(err, f"no point had finished; nothing was written to {out}") from None
    if size.refusal and not yes:
        raise SweepTooBig(size.refusal)
    if progress and size.seconds >= QUIET:  # (a sweep over sooner says nothing, as its progress)
        print(f"sweep: {size.line}", file=sys.stderr, flush=True)
    written = []  # files this call created, removed again if it fails before a row
    try:
        if not done:
            ledger.write("metrics.csv", rows_text(columns, []))
            written.append("metrics.csv")
        ledger.write(ID_NAME, sweep_id_text(record))
        ledger.write(RECORD_NAME, sweep_record_text(record, finished=False))
    except OSError as err:
        if err.errno not in (errno.ENOSPC, errno.EDQUOT):
            raise
        raise disk_full(err, f"{rows_named(done)}, intact; no point was run" if done else
                        "no point was run") from None
    written += [ID_NAME, RECORD_NAME]

    chunks = _chunks(sweep, done, chunk_size)
    ran = 0  # rows this call appended (they are read back from the file at the end)
    started = time.perf_counter()
    # points done, in fractions of a chunk as its batch call advances (not on Dask,
    # whose workers report chunks only)
    bar = Progress(None if progress else False, len(sweep), desc="sweep", unit="point",
                   initial=len(done), leave=True)
    try:
        def take(rows):
            nonlocal ran
            ledger.append("metrics.csv", rows_text(columns, rows, header=False))
            ran += len(rows)
            bar.to(len(done) + ran)

        if client is None:
            for chunk in chunks:
                share = _share(bar, len(done) + ran, sum(p[3] for p in chunk))
                take(_run_chunk(chunk, engine, sweep.rtol, sweep.atol, share))
        else:
            run_on_dask(client, _run_chunk, chunks, take, engine=engine,
                        rtol=sweep.rtol, atol=sweep.atol)
    except BaseException as err:
        if not done and not ran:  # nothing finished: leave nothing behind
            for name in written:
                ledger.discard(name)
            kept = f"no point had finished; nothing was written to {out}"
        else:  # count what the file holds: Ctrl-C may land between a write and its count
            kept = (f"{len(set(finished_rows(csv_path)))} of {len(sweep)} points are in "
                    f"{csv_path}, intact; run the same command again to resume")
        if isinstance(err, OSError) and err.errno in (errno.ENOSPC, errno.EDQUOT):
            raise disk_full(err, kept, getattr(err, "path", None) or err.filename
                            or csv_path) from None
        raise _kept(err, kept)  # noqa: B904 (err itself, or Ctrl-C as Interrupted)
    finally:
        bar.close()

    points_seconds = time.perf_counter() - started
    rows, failed = _finish(ledger, sweep, csv_path, record)
    seconds = time.perf_counter() - t0
    return SweepRun(out_dir=out, rows=rows, ran=ran, skipped=len(done),
                    seconds=seconds, failed=failed, size=size,
                    points_seconds=points_seconds)
