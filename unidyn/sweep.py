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

:func:`paper_fig11` is the sweep of the paper's Fig. 11 and :func:`fig11_claims`
compares its metrics with what the paper says of them.
"""

from __future__ import annotations

import csv
import dataclasses
import io
import itertools
import json
import math
import os
import sys
import time
from collections.abc import Mapping
from dataclasses import dataclass, field
from numbers import Real
from pathlib import Path

import numpy as np

from ._validate import ValidationError, choice, positive, real
from .batch import DEFAULT_SUBSTEPS
from .noise import NoiseSpec, PAPER_NOISE
from .outdir import LOCK_NAME, FolderInUse, FolderLock, staged_output
from .result import write_atomic

__all__ = ["Sweep", "Point", "SweepRun", "run_sweep", "read_metrics", "plot_metrics",
           "paper_fig11", "fig11_claims", "format_fig11_claims", "plot_fig11", "Fig11Claim",
           "FIG11_CASES", "SPECIAL_KEYS", "METRICS", "ENGINES", "MissingDependency",
           "read_toml", "sweep_id", "connect_dask", "FolderLock", "FolderInUse"]

#: Keys that are not Scenario fields but set one or more of them.
SPECIAL_KEYS = ("kxy", "theta_hat_scale", "seed")
#: The per-point metrics written to metrics.csv (see :func:`unidyn.result.metrics`).
METRICS = ("iae", "ise", "itae", "energy", "error_final")
#: ``"batch"``: :func:`unidyn.batch.simulate_batch`, one call per chunk (sampled-control
#: points go through :func:`unidyn.simulate`); ``"bdsim"``: :func:`unidyn.simulate` per point.
ENGINES = ("batch", "bdsim")
#: Default points per chunk, by engine.
DEFAULT_CHUNK = {"batch": 40, "bdsim": 1}
#: A sweep with more points than this is refused (almost surely a typo in a range).
MAX_POINTS = 1_000_000
#: The longest sweep name accepted (it titles the figures and names every point).
MAX_NAME = 200

_TOP_KEYS = ("name", "base", "grid", "variants", "substeps")
_CONFLICTS = {"kxy": ("kx", "ky"), "theta_hat_scale": ("theta_hat0",)}


class MissingDependency(ImportError):
    """An optional dependency needed for the requested feature is not installed."""


# --------------------------------------------------------------------------- TOML

def _toml():
    try:
        import tomllib
    except ModuleNotFoundError:  # Python < 3.11
        try:
            import tomli as tomllib
        except ModuleNotFoundError:
            raise MissingDependency("reading TOML on Python < 3.11 needs tomli "
                                    "(pip install tomli)") from None
    return tomllib


def read_toml(path, what: str = "file") -> dict:
    """Read a TOML file; a missing file raises ``FileNotFoundError``, malformed TOML a
    :class:`ValidationError` naming the file, line and column."""
    path = Path(path)
    tomllib = _toml()
    try:
        with open(path, "rb") as fh:
            return tomllib.load(fh)
    except FileNotFoundError:
        raise FileNotFoundError(f"{what} {path} does not exist") from None
    except IsADirectoryError:
        raise ValidationError(f"{what} {path} is a folder, not a TOML file") from None
    except tomllib.TOMLDecodeError as err:
        raise ValidationError(f"{path}: malformed TOML: {err}") from None
    except UnicodeDecodeError as err:
        raise ValidationError(f"{path}: not a UTF-8 text file: {err}") from None
    except RecursionError:
        raise ValidationError(f"{path}: TOML nested too deeply to read") from None


def parse_toml_value(text: str):
    """A TOML value (``0.5``, ``[0, 0, 0]``, ``{seed = 3}``, ``"p3dx"``); text that is
    not a TOML value is returned as the string itself (so ``p3dx`` needs no quotes)."""
    tomllib = _toml()
    try:
        return tomllib.loads(f"v = {text}")["v"]
    except tomllib.TOMLDecodeError:
        return text
    except RecursionError:
        raise ValidationError("value nested too deeply to read") from None


# ------------------------------------------------------------------ plain values

def _plain(v):
    """Plain data (str, float, int, bool, list, dict, None) for Scenario-typed values."""
    from .model import Limits
    from .parameters import RobotParameters
    from .trajectories import Trajectory
    if isinstance(v, (NoiseSpec, Limits)):
        return v.as_dict()
    if isinstance(v, RobotParameters):
        from . import robots
        try:
            if v.name in robots.names() and robots.get(v.name) == v:
                return v.name
        except ValidationError:
            pass
        return {**v.as_dict(), "name": v.name}
    if isinstance(v, Trajectory):
        return _plain(v.to_spec())
    if isinstance(v, (np.floating, np.integer, np.bool_)):
        return v.item()
    if isinstance(v, (tuple, list, np.ndarray)):
        return [_plain(x) for x in (v.tolist() if isinstance(v, np.ndarray) else v)]
    if isinstance(v, Mapping):
        return {str(k): _plain(x) for k, x in v.items()}
    return v


def _is_number(v) -> bool:
    return isinstance(v, Real) and not isinstance(v, bool)


def _expand_range(where: str, spec: Mapping) -> list:
    allowed = {"start", "stop", "step", "num", "log"}
    unknown = sorted(set(spec) - allowed)
    if unknown:
        raise ValidationError(f"{where}: unknown range key {unknown[0]!r}; a range has start, "
                              f"stop and step (or num, with log = true for a geometric range)")
    for k in ("start", "stop"):
        if k not in spec:
            raise ValidationError(f"{where}: a range needs {k!r} (and step or num)")
    start = real(f"{where}.start", spec["start"])
    stop = real(f"{where}.stop", spec["stop"])
    if ("step" in spec) == ("num" in spec):
        raise ValidationError(f"{where}: a range needs exactly one of 'step' and 'num'")
    log = spec.get("log", False)
    if not isinstance(log, bool):
        raise ValidationError(f"{where}.log must be true or false, got {log!r}")
    if stop < start:
        raise ValidationError(f"{where}: stop ({stop:g}) must be >= start ({start:g})")
    if "step" in spec:
        step = spec["step"]
        if log:
            raise ValidationError(f"{where}: log = true needs num, not step")
        step = real(f"{where}.step", step, low=0.0, low_open=True)
        n = int(math.floor((stop - start) / step + 1e-9)) + 1
        if n > MAX_POINTS:
            raise ValidationError(f"{where}: {n} values; at most {MAX_POINTS} are allowed")
        # 12 significant digits: 0.1 + 2 * 0.1 is 0.3, not 0.30000000000000004
        return [float(f"{start + i * float(step):.12g}") for i in range(n)]
    num = spec["num"]
    if isinstance(num, bool) or not isinstance(num, int) or not 1 <= num <= MAX_POINTS:
        raise ValidationError(f"{where}.num must be an integer in 1..{MAX_POINTS}, got {num!r}")
    if log:
        if start <= 0:
            raise ValidationError(f"{where}: a geometric range needs start > 0, got {start:g}")
        vals = np.geomspace(start, stop, num)
    else:
        vals = np.linspace(start, stop, num)
    return [float(f"{v:.12g}") for v in vals]


def _check_keys(where: str, d, allow_label: bool = False) -> dict:
    from .scenario import Scenario
    if not isinstance(d, Mapping):
        raise ValidationError(f"{where} must be a table of scenario fields, got {d!r}")
    known = {f.name for f in dataclasses.fields(Scenario)} | set(SPECIAL_KEYS)
    if allow_label:
        known.add("label")
    for k in d:
        if k not in known:
            import difflib
            close = difflib.get_close_matches(str(k), known, n=1)
            hint = f" (did you mean {close[0]!r}?)" if close else ""
            raise ValidationError(f"{where}: unknown key {k!r}{hint}; allowed: scenario fields "
                                  f"and {', '.join(SPECIAL_KEYS)}")
    return {str(k): _plain(v) for k, v in d.items()}


def _special(where: str, key: str, value):
    if key == "seed":
        if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 0:
            raise ValidationError(f"{where}.seed must be an integer >= 0, got {value!r}")
        return int(value)
    return positive(f"{where}.{key}", value)


def _build(layers, name: str = ""):
    """The Scenario of a stack of layers [(where, dict)]: later layers override earlier ones;
    the special keys are applied last."""
    from .scenario import Scenario
    fields, fields_from, special = {}, {}, {}
    for where, d in layers:
        for k, v in d.items():
            if k == "label":
                continue
            if k in SPECIAL_KEYS:
                special[k] = (where, _special(where, k, v))
            else:
                fields[k] = v
                fields_from[k] = where
    for key, (where, _) in special.items():
        for f in _CONFLICTS.get(key, ()):
            if f in fields:
                raise ValidationError(f"{where}.{key} and {fields_from[f]}.{f} both set "
                                      f"{f}; use one of them")
    if name and "name" not in fields:
        fields["name"] = name
    sc = Scenario.from_dict(fields)
    if "kxy" in special:
        k = special["kxy"][1]
        sc = sc.replace(kx=k, ky=k)
    if "theta_hat_scale" in special:
        sc = sc.replace(theta_hat0=sc.robot.scaled(special["theta_hat_scale"][1]))
    if "seed" in special:
        where, seed = special["seed"]
        if sc.noise is None:
            raise ValidationError(f"{where}.seed is set but noise is off; give noise "
                                  f"(e.g. noise = {{position_std = 0.01, velocity_std = 0.0141}})")
        sc = sc.replace(noise=dataclasses.replace(sc.noise, seed=seed))
    return sc


def _cell(v) -> str:
    """A CSV cell: round-trip text for numbers, JSON for lists and tables."""
    if v is None:
        return ""
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, float):
        return repr(v)
    if isinstance(v, (int, str)):
        return str(v)
    return json.dumps(v, sort_keys=True, separators=(",", ":"))


# -------------------------------------------------------------------------- Sweep

@dataclass(frozen=True)
class Point:
    """One point of a sweep: its index, its axis values and its scenario."""

    index: int
    params: dict
    scenario: object

    def __iter__(self):  # unpacks as (index, params, scenario)
        return iter((self.index, self.params, self.scenario))


@dataclass(frozen=True)
class Sweep:
    """A set of scenarios: ``base`` crossed with ``variants`` and the ``grid`` axes.

    Every point is built (and so validated) on construction.

    :param base: Scenario fields and special keys (``kxy``, ``theta_hat_scale``,
        ``seed``) shared by every point
    :param grid: axis -> list of values (or a range table, see the module doc); the
        axes are crossed, the last one varying fastest
    :param variants: tables of overrides, each with a unique ``label``; every
        variant is crossed with the grid (an axis called ``variant``, varying slowest)
    :param name: a label
    :param substeps: RK4 steps per sample interval of the batch engine, integer >= 1
    """

    base: dict = field(default_factory=dict)
    grid: dict = field(default_factory=dict)
    variants: tuple = ()
    name: str = ""
    substeps: int = DEFAULT_SUBSTEPS

    def __post_init__(self):
        s = lambda k, v: object.__setattr__(self, k, v)  # noqa: E731
        if not isinstance(self.name, str):
            raise ValidationError(f"name must be a string, got {self.name!r}")
        if len(self.name) > MAX_NAME:
            raise ValidationError(f"name is {len(self.name)} characters long; at most "
                                  f"{MAX_NAME} are allowed (it titles the figures)")
        from .batch import MAX_SUBSTEPS
        if (isinstance(self.substeps, bool) or not isinstance(self.substeps, (int, np.integer))
                or not 1 <= self.substeps <= MAX_SUBSTEPS):
            raise ValidationError(f"substeps must be an integer in 1..{MAX_SUBSTEPS}, "
                                  f"got {self.substeps!r}")
        s("substeps", int(self.substeps))
        s("base", _check_keys("base", self.base))
        if not isinstance(self.grid, Mapping):
            raise ValidationError(f"grid must be a table of axis = [values], got {self.grid!r}")
        grid = {}
        for axis, values in self.grid.items():
            where = f"grid.{axis}"
            if axis in ("variant", "label", "name"):
                raise ValidationError(f"{where}: {axis!r} cannot be a grid axis"
                                      + (" (use [[variants]])" if axis != "name" else ""))
            _check_keys("grid", {axis: None})
            if isinstance(values, Mapping):
                values = _expand_range(where, values)
            elif isinstance(values, (list, tuple, np.ndarray)):
                values = [_plain(v) for v in values]
            else:
                raise ValidationError(f"{where} must be a list of values or a range table "
                                      f"{{start, stop, step}}, got {values!r}")
            if not values:
                raise ValidationError(f"{where} is empty; give at least one value")
            seen = set()
            for v in values:
                key = _cell(v)
                if key in seen:
                    raise ValidationError(f"{where} has the value {v!r} twice")
                seen.add(key)
            grid[str(axis)] = tuple(values)
        s("grid", grid)
        if isinstance(self.variants, Mapping) or not isinstance(self.variants, (list, tuple)):
            raise ValidationError(f"variants must be a list of tables ([[variants]]), "
                                  f"got {self.variants!r}")
        variants, labels = [], set()
        for i, v in enumerate(self.variants):
            where = f"variants[{i}]"
            v = _check_keys(where, v, allow_label=True)
            label = v.get("label")
            if not isinstance(label, str) or not label:
                raise ValidationError(f"{where} needs a label (a non-empty string), got {label!r}")
            if len(label) > MAX_NAME:
                raise ValidationError(f"{where}.label is {len(label)} characters long; at most "
                                      f"{MAX_NAME} are allowed (it names rows and legends)")
            if label in labels:
                raise ValidationError(f"{where}: label {label!r} is used twice")
            labels.add(label)
            variants.append(v)
        s("variants", tuple(variants))
        n = max(len(self.variants), 1) * math.prod(len(v) for v in grid.values())
        if n > MAX_POINTS:
            raise ValidationError(f"the sweep has {n} points; at most {MAX_POINTS} are allowed")
        object.__setattr__(self, "_points", None)
        self.points()

    # ------------------------------------------------------------------ #
    @property
    def axes(self) -> list:
        """The axis names, slowest first: ``variant`` (if there are variants), then the grid's."""
        return (["variant"] if self.variants else []) + list(self.grid)

    @property
    def columns(self) -> list:
        """The columns of metrics.csv."""
        return (["index"] + self.axes + ([] if "case" in self.axes else ["case"])
                + list(METRICS) + ["complete"])

    def __len__(self) -> int:
        return len(self.points())

    def points(self) -> list:
        """Every point as (index, params, scenario), in a fixed order: variants slowest,
        then the grid axes in their order, the last fastest."""
        if self._points is not None:
            return list(self._points)
        out = []
        variants = self.variants or (None,)
        axes = list(self.grid)
        index = 0
        for v in variants:
            for combo in itertools.product(*(self.grid[a] for a in axes)):
                params = {} if v is None else {"variant": v["label"]}
                params.update(zip(axes, combo))
                layers = [("base", self.base)]
                if v is not None:
                    layers.append((f"variants[{v['label']}]", v))
                layers.append(("grid", dict(zip(axes, combo))))
                desc = ", ".join(f"{k}={_cell(x)}" for k, x in params.items())
                if len(desc) > MAX_NAME:
                    desc = desc[:MAX_NAME - 3] + "..."
                try:
                    sc = _build(layers, name=(f"{self.name} " if self.name else "")
                                + f"#{index}" + (f" ({desc})" if desc else ""))
                except ValidationError as err:
                    at = f"sweep point {index}" + (f" ({desc})" if desc else "")
                    raise ValidationError(f"{at}: {err}") from None
                out.append(Point(index, params, sc))
                index += 1
        object.__setattr__(self, "_points", tuple(out))
        return list(out)

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
        out["substeps"] = self.substeps
        return out

    @classmethod
    def from_dict(cls, data) -> "Sweep":
        """Build from plain data (as read from TOML or JSON). Unknown keys raise."""
        if not isinstance(data, Mapping):
            raise ValidationError(f"a sweep must be a table, got {type(data).__name__}")
        unknown = [k for k in data if k not in _TOP_KEYS]
        if unknown:
            raise ValidationError(f"unknown sweep key {unknown[0]!r}; allowed: "
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

@dataclass
class SweepRun:
    """What :func:`run_sweep` did.

    :ivar out_dir: the output folder
    :ivar rows: every point's row of metrics.csv (see :func:`read_metrics`), by index
    :ivar ran: points simulated by this call
    :ivar skipped: points already in metrics.csv (resumed)
    :ivar seconds: wall time of this call
    :ivar failed: indices of points that did not complete (empty metrics)
    :ivar replaced: indices of the rows of an earlier sweep that this one replaced
        (``overwrite=True``)
    """

    out_dir: Path
    rows: list
    ran: int
    skipped: int
    seconds: float
    failed: list
    replaced: tuple = ()


def _row(index, params, case, metrics, complete) -> dict:
    """One row of metrics.csv. A point that did not complete has empty (``None``)
    metrics: the metrics of a partial run are not a result."""
    complete = bool(complete)
    return {"index": index, **params, "case": case,
            **{m: (_metric(metrics[m]) if complete else None) for m in METRICS},
            "complete": complete}


def _metric(v):
    return None if v is None else float(v)


def _run_chunk(points, engine: str, substeps: int) -> list:
    """Simulate a list of (index, params, scenario); return their metrics rows.

    Runs wherever it is called (here or on a Dask worker) and returns only the
    small rows, not the time series."""
    from .runner import simulate
    rows = [None] * len(points)
    batch = []
    for j, (index, params, sc) in enumerate(points):
        if engine == "batch" and sc.control == "continuous":
            batch.append(j)
            continue
        try:
            r = simulate(sc)
            rows[j] = _row(index, params, sc.case, r.metrics, r.complete)
        except (RuntimeError, ArithmeticError) as err:
            print(f"unidyn: warning: sweep point {index} failed: {err}", file=sys.stderr)
            rows[j] = _row(index, params, sc.case, {m: None for m in METRICS}, False)
    if batch:
        from .batch import simulate_batch
        results = simulate_batch([points[j][2] for j in batch], substeps=substeps)
        for j, r in zip(batch, results):
            index, params, sc = points[j]
            rows[j] = _row(index, params, sc.case, r.metrics, r.complete)
    return rows


class _NoBar:
    def update(self, k):
        pass

    def close(self):
        pass


def _progress_bar(enabled, total, initial):
    """A tqdm progress bar on stderr, or nothing when disabled, when stderr is not a
    terminal (a log file, a pipe, a test) or when tqdm is not installed."""
    if not enabled or not sys.stderr.isatty():
        return _NoBar()
    try:
        from tqdm import tqdm
    except ImportError:
        return _NoBar()
    return tqdm(total=total, initial=initial, desc="sweep", unit="pt", file=sys.stderr,
                dynamic_ncols=True)


def _read_rows(path: Path, columns: list):
    """(rows, clean): the complete rows of metrics.csv, and whether every line parsed."""
    text = path.read_text()
    if not text.strip():
        return [], False
    lines = text.splitlines(keepends=True)
    clean = text.endswith("\n")
    if not clean:
        lines = lines[:-1]  # a line cut short by an interruption
    reader = csv.reader(io.StringIO("".join(lines)))
    header = next(reader, None)
    if header != columns:
        raise ValidationError(f"{path} has columns {header}, this sweep writes {columns}; "
                              f"use another output folder or resume=False (--no-resume)")
    rows = []
    for rec in reader:
        if len(rec) != len(columns):
            clean = False
            continue
        try:
            rows.append(_parse_row(dict(zip(columns, rec))))
        except ValueError:
            clean = False
    return rows, clean


def _parse_cell(text: str):
    if text == "":
        return None
    try:
        return json.loads(text)
    except ValueError:
        try:
            return float(text)  # nan, inf
        except ValueError:
            return text


def _parse_row(rec: dict) -> dict:
    out = {}
    for k, v in rec.items():
        if k == "index":
            out[k] = int(v)
        elif k in METRICS:
            out[k] = None if v == "" else float(v)  # empty: the point did not complete
        elif k == "complete":
            if v not in ("true", "false"):
                raise ValueError(v)
            out[k] = v == "true"
        elif k == "case":
            out[k] = v
        else:
            out[k] = _parse_cell(v)
    return out


def read_metrics(path) -> list:
    """The rows of a sweep's metrics.csv (a file or the sweep's folder), sorted by index:
    dicts with ``index`` (int), the axes, ``case``, the metrics (float; ``None`` for a
    point that did not complete) and ``complete`` (bool)."""
    path = Path(path)
    if path.is_dir():
        path = path / "metrics.csv"
    if not path.exists():
        raise FileNotFoundError(f"{path} does not exist")
    with open(path, newline="") as fh:
        header = next(csv.reader(fh), None)
    if not header or "index" not in header or "iae" not in header:
        raise ValidationError(f"{path} is not a sweep's metrics.csv (no index/iae columns)")
    rows, _ = _read_rows(path, header)
    return sorted(rows, key=lambda r: r["index"])


def _write_rows(fh, columns, rows):
    w = csv.writer(fh, lineterminator="\n")
    for r in rows:
        w.writerow([_cell(r[c]) for c in columns])


def _rows_text(columns, rows) -> str:
    buf = io.StringIO()
    csv.writer(buf, lineterminator="\n").writerow(columns)
    _write_rows(buf, columns, rows)
    return buf.getvalue()


def connect_dask(address, option: str = "dask_address"):
    """A ``distributed.Client`` for ``address`` and a function that closes what was
    opened here.

    :param address: ``"local"`` (a cluster of worker processes on this machine, at
        most two), a scheduler address (``"tcp://host:8786"``) or a
        ``distributed.Client`` (used as it is and left open)
    :param option: how the caller names the address in messages (``"--dask"``)
    :raises ValidationError: the address is not a string, or no scheduler answers there
    """
    try:
        import distributed
    except ImportError:
        raise MissingDependency("running a sweep on Dask needs dask.distributed "
                                "(pip install 'unidyn[dask]')") from None
    if isinstance(address, distributed.Client):
        return address, lambda: None
    if not isinstance(address, str) or not address.strip():
        raise ValidationError(f"{option} must be 'local' or a scheduler address (e.g. "
                              f"'tcp://host:8786'), or a distributed.Client; got {address!r}")
    address = address.strip()
    if address == "local":
        import logging
        workers = max(1, min(2, os.cpu_count() or 1))
        logging.getLogger("distributed").setLevel(logging.ERROR)
        cluster = distributed.LocalCluster(n_workers=workers, threads_per_worker=1,
                                           processes=True, dashboard_address=None)
        client = distributed.Client(cluster)

        def close():
            client.close()
            cluster.close()

        return client, close
    try:
        client = distributed.Client(address, timeout="5s")
    except (OSError, TimeoutError, ValueError, TypeError) as err:
        detail = " ".join(str(err).split()) or type(err).__name__
        raise ValidationError(f"{option} {address}: cannot connect to a Dask scheduler there "
                              f"({detail[:300]}); give the address of a running scheduler "
                              f"(tcp://host:8786) or 'local'") from None
    return client, client.close


#: The file beside metrics.csv that records which sweep its rows belong to.
ID_NAME = ".sweep-id"
#: Files whose presence means a folder holds a sweep's results.
_SWEEP_RESULTS = ("metrics.csv", "sweep.json")
#: Every file a sweep writes (none of them is carried over when a sweep starts over).
_SWEEP_OWNED = ("metrics.csv", "sweep.json", "metrics.png", "claims.md", "fig11.png", ID_NAME)




def sweep_id(sweep: Sweep) -> str:
    """A hash of a sweep's full definition (its base, grid, variants, name and substeps,
    and the first point's complete scenario, so changed defaults count), the same
    whatever the engine: ``"sha256:..."``."""
    import hashlib
    text = json.dumps({"sweep": sweep.to_dict(), "first": sweep.points()[0].scenario.to_dict()},
                      sort_keys=True, separators=(",", ":"), default=str)
    return "sha256:" + hashlib.sha256(text.encode()).hexdigest()


def _spec_record(sweep: Sweep, engine: str) -> dict:
    from . import __version__
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


def _finished_rows(csv_path: Path) -> list:
    """The indices of the rows in a metrics.csv, whatever its columns."""
    try:
        with open(csv_path, newline="") as fh:
            reader = csv.reader(fh)
            header = next(reader, None) or []
            at = header.index("index") if "index" in header else 0
            out = []
            for rec in reader:
                try:
                    out.append(int(rec[at]))
                except (ValueError, IndexError):
                    pass
            return out
    except (OSError, UnicodeDecodeError, csv.Error):
        return []


def _what_is_held(out: Path, record: dict) -> tuple:
    """What ``out`` holds: ``(state, detail)`` with state ``"none"`` (no sweep),
    ``"same"``, ``"engine"`` (this sweep with another engine), ``"different"`` or
    ``"unknown"`` (rows that no record ties to a sweep)."""
    spec_path, csv_path, id_path = out / "sweep.json", out / "metrics.csv", out / ID_NAME
    if not spec_path.exists() and not csv_path.exists():
        return "none", ""
    if spec_path.exists():
        try:
            old = json.loads(spec_path.read_text())
            if not isinstance(old, dict):
                raise ValueError("not a table")
        except (ValueError, UnicodeDecodeError) as err:
            return "unknown", f"its sweep.json is not valid JSON ({err})"
        if "id" in old:
            same = old["id"] == record["id"]
        else:  # written before sweeps had an id: compare the definitions
            same = old.get("sweep") == record["sweep"]
        if not same:
            diff = _differences(old.get("sweep"), record["sweep"])
            return "different", ("it differs in " + ", ".join(diff[:5])
                                 + (", ..." if len(diff) > 5 else "")
                                 if diff and diff != ["the definition"] else
                                 "its definition differs")
        if old.get("engine") != record["engine"]:
            return "engine", f"it was run with engine {old.get('engine')!r}"
        return "same", ""
    try:
        held = id_path.read_text().split()
    except (OSError, UnicodeDecodeError):
        held = []
    if not held:
        return "unknown", "no sweep.json or .sweep-id records which sweep its rows belong to"
    if held[0] != record["id"]:
        return "different", "its .sweep-id names another sweep (sweep.json is missing)"
    if held[1:2] != [record["engine"]]:
        return "engine", f"it was run with engine {' '.join(held[1:2]) or 'unknown'!r}"
    return "same", ""


def _rows_named(indices) -> str:
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
              overwrite: bool = False) -> SweepRun:
    """Run every point of ``sweep``, writing into ``out_dir``:

    - ``sweep.json``: the spec, its id (:func:`sweep_id`), engine and library
      version (written first); ``.sweep-id``: the id and engine again, so rows
      never lose their record
    - ``metrics.csv``: one row per finished point (columns :attr:`Sweep.columns`),
      appended and flushed after each chunk, rewritten sorted by index at the end;
      a point that did not complete has ``complete = false`` and empty metrics
    - ``metrics.png``: IAE against the first numeric axis (:func:`plot_metrics`)

    Finished rows are never deleted without ``overwrite``:

    - ``resume=True`` (default): the points already in ``metrics.csv`` are
      skipped. A folder that holds a different sweep, this sweep run with another
      engine, or rows with no record of their sweep is refused unless ``overwrite``,
      which starts over as below.
    - ``resume=False``: start over. A folder with finished rows is refused unless
      ``overwrite``.
    - starting over where there are finished rows writes the new sweep into a fresh
      folder beside ``out_dir`` and swaps it in only when every point has run: an
      error or an interrupt leaves the old sweep as it was (the new rows are
      discarded).

    While it runs, the folder is locked (``.unidyn.lock``, holding the PID): a
    second process writing the same folder is refused with :class:`FolderInUse`.
    A sweep that fails before its first row leaves no files behind.

    :param engine: ``"batch"`` (one :func:`~unidyn.batch.simulate_batch` call per chunk;
        sampled-control points run through :func:`unidyn.simulate`) or ``"bdsim"``
    :param chunk_size: points per chunk (default 40 for batch, 1 for bdsim)
    :param resume: skip the points already in ``metrics.csv``; ``False`` starts over
    :param progress: show a tqdm progress bar on stderr (only when it is a terminal)
    :param dask_address: ``"local"`` (a local cluster), a Dask scheduler address or a
        ``distributed.Client``: the chunks run on its workers (which need unidyn
        installed), and rows are written as they arrive (see :func:`connect_dask`)
    :param overwrite: allow finished rows to be replaced
    :return: :class:`SweepRun`
    """
    t0 = time.perf_counter()
    if not isinstance(sweep, Sweep):
        raise ValidationError(f"sweep must be a unidyn.sweep.Sweep, got {type(sweep).__name__}")
    engine = choice("engine", engine, ENGINES)
    if chunk_size is None:
        chunk_size = DEFAULT_CHUNK[engine]
    if isinstance(chunk_size, bool) or not isinstance(chunk_size, (int, np.integer)) or chunk_size < 1:
        raise ValidationError(f"chunk_size must be an integer >= 1, got {chunk_size!r}")
    chunk_size = int(chunk_size)
    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        raise ValidationError(f"output folder {out} is a file")
    record = _spec_record(sweep, engine)
    client, close = (None, None) if dask_address is None else connect_dask(dask_address)
    created = not out.exists()
    try:
        out.mkdir(parents=True, exist_ok=True)
        with FolderLock(out) as lock:
            try:
                state, detail = _what_is_held(out, record)
                rows_held = _finished_rows(out / "metrics.csv") if state != "none" else []
                if state == "same" and resume:
                    return _run_in(sweep, out, record, engine, chunk_size, progress, client,
                                   t0, resume=True)
                if rows_held and not overwrite:
                    raise ValidationError(_refusal(out, state, detail, rows_held, resume))
                if not rows_held:  # nothing finished to lose: start over in place
                    return _run_in(sweep, out, record, engine, chunk_size, progress, client,
                                   t0, resume=False)
                try:
                    with staged_output(out, overwrite=True, results=_SWEEP_RESULTS,
                                       what="sweep results", owned=_SWEEP_OWNED,
                                       lock=False) as stage:  # held above
                        run = _run_in(sweep, stage.path, record, engine, chunk_size,
                                      progress, client, t0, resume=False)
                except BaseException as err:
                    _detail(err, f"{out} is as it was ({_rows_named(rows_held)}); the new "
                                 f"sweep's rows were discarded")
                    raise
                run.out_dir = out
                run.replaced = tuple(rows_held)
                return run
            except BaseException:
                if created:
                    lock.release()
                    _remove_if_empty(out)
                raise
    finally:
        if close is not None:
            close()


def _refusal(out, state, detail, rows, resume) -> str:
    held = _rows_named(rows)
    if state in ("same", "none") and not resume:
        return (f"{out} holds {held}; starting over (resume=False, --no-resume) would "
                f"delete them: add overwrite=True (--overwrite) to replace them once the new "
                f"sweep has finished, or choose another output folder")
    what = {"engine": "this sweep run with another engine",
            "different": "a different sweep",
            "unknown": "sweep rows of unknown origin"}.get(state, "a sweep")
    return (f"{out} holds {what} ({detail}): {held}; pass overwrite=True (--overwrite) to "
            f"replace them once this sweep has finished, or choose another output folder")


def _detail(err: BaseException, text: str) -> None:
    """Say on an exception what the sweep left behind (the command line prints it)."""
    try:
        err.unidyn_detail = text
    except (AttributeError, TypeError):  # pragma: no cover - exceptions without a __dict__
        pass


def _remove_if_empty(folder: Path) -> None:
    try:
        folder.rmdir()
    except OSError:
        pass


def _run_in(sweep, out, record, engine, chunk_size, progress, client, t0, resume) -> SweepRun:
    """Run the sweep in ``out`` (locked by the caller or private): resume from its rows,
    or start it afresh."""
    columns = sweep.columns
    csv_path, spec_path, id_path = out / "metrics.csv", out / "sweep.json", out / ID_NAME
    done = {}
    if resume and csv_path.exists():
        rows, clean = _read_rows(csv_path, columns)
        valid = {p.index for p in sweep.points()}
        done = {r["index"]: r for r in rows if r["index"] in valid}
        if not clean:  # drop a line cut short by an interruption
            write_atomic(csv_path, _rows_text(columns, sorted(done.values(),
                                                              key=lambda r: r["index"])))
    written = []  # files this call created, removed again if it fails before a row
    if not done:
        write_atomic(csv_path, _rows_text(columns, []))
        written.append(csv_path)
    write_atomic(id_path, f"{record['id']} {record['engine']}\n")
    write_atomic(spec_path, json.dumps({**record, "finished": False}, indent=2) + "\n")
    written += [id_path, spec_path]

    pending = [p for p in sweep.points() if p.index not in done]
    chunks = [[tuple(p) for p in pending[i:i + chunk_size]]
              for i in range(0, len(pending), chunk_size)]
    new_rows = []
    bar = _progress_bar(progress, len(sweep), len(done))
    try:
        with open(csv_path, "a", newline="") as fh:

            def take(rows):
                _write_rows(fh, columns, rows)
                fh.flush()
                os.fsync(fh.fileno())
                new_rows.extend(rows)
                bar.update(len(rows))

            if client is None:
                for chunk in chunks:
                    take(_run_chunk(chunk, engine, sweep.substeps))
            elif chunks:
                _run_on_dask(client, chunks, engine, sweep.substeps, take)
    except BaseException as err:
        if not done and not new_rows:  # nothing finished: leave nothing behind
            for p in written:
                try:
                    p.unlink()
                except FileNotFoundError:
                    pass
            _detail(err, f"no point had finished; nothing was written to {out}")
        else:  # count what the file holds: Ctrl-C may land between a write and its count
            _detail(err, f"{len(set(_finished_rows(csv_path)))} of {len(sweep)} points are in "
                         f"{out / 'metrics.csv'}; run the same command again to resume")
        raise
    finally:
        bar.close()

    rows = sorted([*done.values(), *new_rows], key=lambda r: r["index"])
    write_atomic(csv_path, _rows_text(columns, rows))
    failed = [r["index"] for r in rows if not r["complete"]]
    seconds = time.perf_counter() - t0
    write_atomic(spec_path, json.dumps({**record, "finished": True, "failed": failed},
                                       indent=2) + "\n")
    try:
        plot_metrics(sweep, rows, out / "metrics.png")
    except ImportError:  # no matplotlib: the data is what matters
        pass
    return SweepRun(out_dir=out, rows=rows, ran=len(new_rows), skipped=len(done),
                    seconds=seconds, failed=failed)


def _run_on_dask(client, chunks, engine, substeps, take):
    from distributed import as_completed
    futures = client.map(_run_chunk, chunks, engine=engine, substeps=substeps, pure=False)
    try:
        for fut in as_completed(futures):
            take(fut.result())
    except BaseException:
        client.cancel(futures)
        raise


# ----------------------------------------------------------------------- plotting

def _numeric_axis(sweep: Sweep):
    for a in sweep.grid:
        if all(_is_number(v) for v in sweep.grid[a]):
            return a
    return None


def plot_metrics(sweep: Sweep, rows, path, metric: str = "iae"):
    """IAE (or another metric) against the first numeric axis, one line per combination
    of the other axes (a variant by its label); log scale with plain tick labels when
    the values span more than a decade. In unidyn's figure style (:mod:`unidyn.figstyle`)."""
    import matplotlib.pyplot as plt

    from . import figstyle
    choice("metric", metric, METRICS)
    x_axis = _numeric_axis(sweep)
    others = [a for a in sweep.axes if a != x_axis]
    with figstyle.style():
        fig, ax = plt.subplots(figsize=figstyle.size(1, 0.75))
        lines = {}
        for r in rows:
            key = tuple(_cell(r[a]) for a in others)
            x = r[x_axis] if x_axis else r["index"]
            y = r[metric] if r["complete"] else math.nan
            lines.setdefault(key, []).append((x, y))
        for key, pts in lines.items():
            pts.sort()
            xs, ys = zip(*pts)
            label = ", ".join(str(k) if a == "variant" else f"{a} = {k}"
                              for a, k in zip(others, key)) or None
            ax.plot(xs, ys, "o-" if len(pts) < 30 else "-", ms=3, label=label)
        vals = np.array([r[metric] for r in rows if r["complete"]], dtype=float)
        vals = vals[np.isfinite(vals)]
        if vals.size and vals.min() > 0 and vals.max() / vals.min() > 10:
            figstyle.plain_log_axis(ax, "y")
        elif vals.size:
            figstyle.ylim_from_data(ax, floor=0 if vals.min() >= 0 else None)
        ax.set_xlabel(_AXIS_LABELS.get(x_axis, x_axis) if x_axis else "point index")
        ax.set_ylabel(_METRIC_LABELS[metric])
        ax.set_title(sweep.name or "sweep")
        ax.grid(True, which="major")
        if 1 < len(lines) <= 12:
            figstyle.legend(ax, fallback="below")
        return figstyle.save(fig, path)


#: Axis labels of the metrics (units as in :func:`unidyn.result.metrics`).
_METRIC_LABELS = {"iae": "IAE (m·s)", "ise": "ISE (m²·s)", "itae": "ITAE (m·s²)",
                  "energy": "control effort ∫(u² + ω²) dt", "error_final": "final error (m)"}
#: Axis labels of the special sweep keys and common numeric fields.
_AXIS_LABELS = {"kxy": "$k_x = k_y$ (1/s)", "kx": "$k_x$ (1/s)", "ky": "$k_y$ (1/s)",
                "ku": "$k_u$ (1/s)", "kw": "$k_\\omega$ (1/s)", "a": "a (m)", "T": "T (s)",
                "theta_hat_scale": "$\\hat\\theta(0)\\,/\\,\\theta$",
                "adapt_from": "adaptation on at (s)", "seed": "noise seed"}


# ------------------------------------------------------------------ the paper's Fig. 11

#: The four cases of Fig. 11, by variant label.
FIG11_CASES = {
    "a": "(a) kinematic controller only",
    "b": "(b) compensation, θ̂ = 0.9 θ, no update",
    "c": "(c) adaptive from t = 0, θ̂(0) = 0.9 θ",
    "d": "(d) exact θ̂, no update",
}


def paper_fig11(T: float = 250.0, gains=None, noise=PAPER_NOISE, *, base=None,
                substeps: int = DEFAULT_SUBSTEPS) -> Sweep:
    """The sweep of the paper's Fig. 11: IAE over ``T`` for kx = ky in ``gains``
    (default 0.5, 1.0, ..., 35: 70 values), four variants:

    - ``a``: kinematic controller only on the dynamic robot (case ``uncompensated``)
    - ``b``: compensation with theta_hat0 = 0.9 theta, no update (``compensated``)
    - ``c``: the same, updating from t = 0 (``adaptive``, ``adapt_from = 0``)
    - ``d``: exact theta_hat, no update (``compensated``, scale 1.0)

    Everything else is the paper's Section 5 setting (spec section 5).

    :param noise: a NoiseSpec (default: the paper's stated noise), its dict, or
        ``None`` for noise-free runs
    :param base: further Scenario fields for every point (e.g. ``{"vd_dot": "filter"}``)
    """
    if gains is None:
        gains = np.arange(0.5, 35.0 + 1e-9, 0.5)
    gains = [float(g) for g in np.atleast_1d(np.asarray(gains, dtype=float))]
    b = {"T": T, "noise": None if noise is None else _plain(noise)}
    if base:
        b.update(base)
    if b["noise"] is None:
        b["noise"] = "off"
    variants = (
        {"label": "a", "case": "uncompensated"},
        {"label": "b", "case": "compensated", "theta_hat_scale": 0.9},
        {"label": "c", "case": "adaptive", "adapt_from": 0.0, "theta_hat_scale": 0.9},
        {"label": "d", "case": "compensated", "theta_hat_scale": 1.0},
    )
    return Sweep(base=b, grid={"kxy": gains}, variants=variants,
                 name="Fig. 11 (IAE against kx = ky)", substeps=substeps)


@dataclass(frozen=True)
class Fig11Claim:
    """One thing the paper says of Fig. 11, the criterion used, the measured numbers,
    and whether it holds (``None``: the sweep does not cover it)."""

    claim: str
    criterion: str
    measured: str
    holds: bool | None


def _fig11_rows(metrics) -> tuple[list, dict, list]:
    """(ks, table, skipped): the gains every case has a complete point for, IAE by case
    and gain, and the (case, gain) of every point that did not complete (left out)."""
    rows = read_metrics(metrics) if isinstance(metrics, (str, os.PathLike)) else list(metrics)
    table = {lab: {} for lab in FIG11_CASES}
    skipped = []
    for r in rows:
        if "variant" not in r or "kxy" not in r:
            raise ValidationError("fig11_claims needs rows with 'variant' and 'kxy' "
                                  "(the metrics of paper_fig11())")
        if r["variant"] in table:
            if not r.get("complete", True) or r.get("iae") is None:
                skipped.append((r["variant"], float(r["kxy"])))
                continue
            table[r["variant"]][float(r["kxy"])] = float(r["iae"])
    missing = [lab for lab, v in table.items() if not v]
    if missing:
        raise ValidationError(f"fig11_claims: no complete rows for case(s) {', '.join(missing)}"
                              + (f" ({len(skipped)} incomplete point(s) left out)"
                                 if skipped else ""))
    ks = sorted(set.intersection(*(set(v) for v in table.values())))
    if not ks:
        raise ValidationError("fig11_claims: the four cases share no value of kxy with "
                              "complete points")
    return ks, table, sorted(skipped)


def _fig11_table(metrics) -> tuple[list, dict]:
    """(ks, table) of :func:`_fig11_rows`: points that did not complete are left out."""
    ks, table, _ = _fig11_rows(metrics)
    return ks, table


def _kl(ks, limit=6) -> str:
    s = ", ".join(f"{k:g}" for k in ks[:limit])
    return s + (f", ... ({len(ks)} in all)" if len(ks) > limit else "")


def fig11_claims(metrics) -> list:
    """Compare Fig. 11 metrics (rows of :func:`read_metrics`, or the path of a
    metrics.csv) with what the paper says of its Fig. 11.

    Points that did not complete have no IAE: they are left out, and every claim
    they would have entered says how many were left out and where. Claims about one
    k (k = 1, 23) need that k in the sweep; otherwise they are reported with
    ``holds = None``.
    :return: list of :class:`Fig11Claim`
    """
    ks, tab, skipped = _fig11_rows(metrics)
    a, b, c, d = (tab[x] for x in "abcd")

    def left_out(labels, at=None) -> str:
        pts = [(lab, k) for lab, k in skipped if lab in labels and (at is None or k == at)]
        if not pts:
            return ""
        where = ", ".join(f"{lab} at k = {k:g}" for lab, k in pts[:6])
        more = f", ... ({len(pts)} in all)" if len(pts) > 6 else ""
        return f"; {len(pts)} incomplete point(s) left out ({where}{more})"

    out = []
    if 1.0 in a:
        out.append(Fig11Claim("(a) IAE above 8 at k = 1", "IAE_a(k = 1) > 8",
                              f"IAE_a(1) = {a[1.0]:.3f}", a[1.0] > 8))
    elif ("a", 1.0) in skipped:
        out.append(Fig11Claim("(a) IAE above 8 at k = 1", "IAE_a(k = 1) > 8",
                              "the run at k = 1 did not complete" + left_out("a", 1.0), None))
    else:
        out.append(Fig11Claim("(a) IAE above 8 at k = 1", "IAE_a(k = 1) > 8",
                              "k = 1 not in the sweep", None))
    ka = min(a, key=lambda k: (a[k], k))
    where = ""
    if ka == max(a):
        where = " (the largest k swept: still falling, no interior minimum)"
    elif ka == min(a):
        where = " (the smallest k swept)"
    at23 = f"; IAE_a(23) = {a[23.0]:.3f}" if 23.0 in a else ""
    covers = min(a) <= 23 <= max(a)
    out.append(Fig11Claim(
        "(a) smallest IAE, 1.24, at k = 23",
        "minimum of (a) at 18 <= k <= 28, value within 1.24 ± 25 %",
        f"minimum {a[ka]:.3f} at k = {ka:g}{where}{at23}"
        + ("" if covers else " (k = 23 is outside the sweep)") + left_out("a"),
        (18 <= ka <= 28 and abs(a[ka] - 1.24) <= 0.25 * 1.24) if covers else None))
    for lab, series in (("b", b), ("c", c)):
        bad = [k for k in ks if not series[k] < a[k]]
        ratio = max(series[k] / a[k] for k in ks)
        out.append(Fig11Claim(
            f"({lab}) below (a) for every k", f"IAE_{lab}(k) < IAE_a(k) at every k swept",
            f"below at {len(ks) - len(bad)} of {len(ks)} k"
            + (f"; not at k = {_kl(bad)}" if bad else "")
            + f"; largest IAE_{lab}/IAE_a = {ratio:.3f}" + left_out(("a", lab)),
            not bad))
    bad = [k for k in ks if not d[k] < min(a[k], b[k], c[k])]
    worst = max(ks, key=lambda k: d[k] - min(a[k], b[k], c[k]))
    out.append(Fig11Claim(
        "(d) lowest for every k", "IAE_d(k) < IAE of (a), (b) and (c) at every k swept",
        f"lowest at {len(ks) - len(bad)} of {len(ks)} k"
        + (f"; not at k = {_kl(bad)} (at k = {worst:g}: d {d[worst]:.3f}, "
           f"best other {min(a[worst], b[worst], c[worst]):.3f})" if bad else "")
        + left_out("abcd"),
        not bad))
    return out


def format_fig11_claims(claims, title: str | None = None) -> str:
    """A Markdown table of :func:`fig11_claims`."""
    rows = [] if title is None else [title, ""]
    rows += ["| the paper says | criterion | measured | holds |", "|---|---|---|---|"]
    for c in claims:
        holds = "n/a" if c.holds is None else ("yes" if c.holds else "NO")
        rows.append(f"| {c.claim} | {c.criterion} | {c.measured} | {holds} |")
    return "\n".join(rows)


def plot_fig11(metrics, path, title: str | None = None):
    """IAE against k = kx = ky for the four cases, log y with plain tick labels (1, 2,
    5, 10, 20), as the paper's Fig. 11. In unidyn's figure style (:mod:`unidyn.figstyle`)."""
    import matplotlib.pyplot as plt

    from . import figstyle
    ks, tab = _fig11_table(metrics)
    with figstyle.style():
        fig, ax = plt.subplots(figsize=figstyle.size(1, 0.95))
        for (lab, desc), mk in zip(FIG11_CASES.items(), ("o", "s", "^", "D")):
            ys = [tab[lab][k] if math.isfinite(tab[lab][k]) else math.nan for k in ks]
            ax.plot(ks, ys, "-", marker=mk, ms=2.5, markevery=max(1, len(ks) // 12),
                    label=desc)
        figstyle.plain_log_axis(ax, "y")
        ax.set_xlabel("$k_x = k_y$ (1/s)")
        ax.set_ylabel("IAE (m·s)")
        ax.set_title(title or "IAE against the kinematic controller's gain (Fig. 11)")
        ax.grid(True, which="major")
        ax.grid(True, which="minor", axis="y", alpha=0.2)
        figstyle.legend(ax, outside="below")
        return figstyle.save(fig, path)
