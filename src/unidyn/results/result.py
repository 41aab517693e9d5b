"""Results of a closed-loop run: time series, the paper's metrics, files and figures."""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .. import __version__
from .._validate import ValidationError
from ..model.metrics import (
    BY_NAME,
    FINAL,
    INTEGRAL,
    INTEGRAL_NAMES,
    METRIC_NAMES,
    METRIC_UNITS,
    METRICS,
    running,
    sample_value,
)
from . import plots
from .folders import Stage, json_ready, staged_output, write_atomic

__all__ = ["Result", "metrics", "running", "distance", "write_atomic", "has_noise",
           "uncertainty", "RESULT_FILES", "RUN_FILES", "METRIC_NAMES", "INTEGRAL_NAMES",
           "METRIC_UNITS"]

#: The files of a run's results (figures may join them: see :func:`unidyn.results.plots.save_figures`).
RESULT_FILES = ("timeseries.csv", "summary.json")
#: Every file a run's folder may hold: the data, then the figures and the animation
#: that ``unidyn run`` adds (the names its manifest may list).
RUN_FILES = RESULT_FILES + ("path.png", "error.png", "positions.png", "velocities.png",
                            "theta_hat.png", "animation.gif")


#: Rows of a series taken at a time (no temporaries the size of the series).
_BLOCK = 1 << 16


def _floats(a) -> list:
    """Python floats of an array's values; a float32 value as its shortest decimal
    (0.1, not the 0.10000000149011612 of widening it to float64)."""
    a = np.asarray(a)
    if a.dtype == np.float32:
        return [float(str(v)) for v in a]
    return [float(v) for v in a]


def distance(a, b):
    """Row-wise Euclidean distance between (N, 2) arrays, in their floating type
    (a block of rows at a time: no temporaries the size of the series)."""
    a, b = np.asarray(a), np.asarray(b)
    out = np.empty(len(a), dtype=np.result_type(a, b, np.float16))  # ints: float64
    for i0 in range(0, len(a), _BLOCK):
        i1 = i0 + _BLOCK
        np.hypot(a[i0:i1, 0] - b[i0:i1, 0], a[i0:i1, 1] - b[i0:i1, 1], out=out[i0:i1])
    return out


def _metrics_of(running_, error) -> dict:
    """The metrics dict from their values so far at the last logged sample and the
    logged distance error (a final value: as logged)."""
    last = running_[-1] if len(running_) else np.full(len(METRICS), np.nan)
    out = {}
    for m, v in zip(METRICS, last):
        out[m.name] = float(v)
        if m.rule == FINAL:  # the logged value, in its precision
            out[m.name] = _floats(error[-1:])[0] if len(error) else float("nan")
    return out


def metrics(t, error, velocity) -> dict:
    """The run's figures of merit (:data:`unidyn.model.metrics.METRICS`: name, unit and
    what each is) over the samples given: the trapezoidal rule on them for an integral.

    A :class:`Result`'s metrics are these over every sample of the run, whatever it
    logged (:attr:`Result.running`).
    """
    return _metrics_of(running(t, error, velocity), np.asarray(error))


def has_noise(scenario) -> bool:
    """Whether ``scenario`` feeds measurement noise to its controllers (a noise with
    both standard deviations zero is none)."""
    noise = scenario.noise
    return noise is not None and (noise.position_std > 0 or noise.velocity_std > 0)


def uncertainty(result) -> str:
    """Which uncertainty to quote for a run's metrics, in a sentence (its print,
    ``summary.json`` and ``unidyn run`` say it).

    A run with measurement noise is one sample of it: another seed moves its metrics by
    far more than they are integrated wrong, so their spread over seeds is the
    uncertainty to quote, and the numerical error is the integration's alone. A
    noise-free run is deterministic: its numerical error is its uncertainty."""
    sc = result.scenario
    if has_noise(sc):
        return (f"one sample of the measurement noise (seed {sc.noise.seed}): another seed "
                f"gives other values, and their spread over seeds is the uncertainty to "
                f"quote (unidyn.run(scenario, seeds=N) or unidyn run --seeds N: mean ± "
                f"standard error); the numerical error is the integration's alone, not an "
                f"error bar")
    if result.sensitive:
        return ("no noise, but sensitive: a perturbation of 1e-12 m moves the metrics by "
                "their numerical error; no tolerance converges them, quote them as an "
                "order of magnitude")
    if result.numerical_error is None:
        return ("no noise: deterministic; numerical error not estimated (the batch engine, "
                "engine='batch', estimates it)")
    return "no noise: deterministic; quote each metric with its numerical error"


#: Rows of timeseries.csv formatted at a time.
_CSV_BLOCK = 10_000


@dataclass
class Result:
    r"""One run of a :class:`~unidyn.Scenario`.

    Arrays are sampled on a uniform grid of step ``scenario.Ts`` (N points):

    :ivar t: time, s, (N,)
    :ivar pose: (x, y, psi) of the point of interest h, (N, 3)
    :ivar velocity: actual (u, w) of the robot, (N, 2) (for the kinematic case, the clipped commands)
    :ivar reference: desired position h_d, (N, 2)
    :ivar v_d: kinematic controller's output, (N, 2)
    :ivar v_ref: commands applied to the robot, (N, 2)
    :ivar error: distance error \|h_d - h\|, m, (N,)
    :ivar theta_hat: parameter estimate, (N, 6) (constant for non-adaptive cases)

    ``v_d``, ``v_ref`` and ``theta_hat`` are ``None`` where the scenario's
    ``log_series`` leaves them out (the others are always there).
    :ivar metrics: see :func:`metrics`, over every sample computed (``log_every``
        thins the series, not the metrics); for a run that stopped, those of the part
        computed (``complete`` says which)
    :ivar running: each metric from t = 0 to each logged sample, (N, metrics), float64,
        in the order of :data:`METRIC_NAMES` (an integral so far, a peak so far, a final
        value at that sample), accumulated at every sample: what :meth:`window`
        subtracts
    :ivar numerical_error: the estimated relative error of each metric (relative to its
        own size, or to the mean error of the run, IAE / T, where the metric's entry
        says so: ``error_final``) and of the logged series
        ``position``, ``heading``, ``distance_error`` and ``theta_hat`` (the largest
        error over the samples, relative to the series' largest value), from the batch
        engine's own estimate
        (:func:`unidyn.simulate_batch`); ``None`` where not estimated (the diagram, a
        run that stopped)
    :ivar sensitive: True where the run amplifies perturbations so that no tolerance
        converges it (the batch engine's probe; ``message`` says by how much): its
        metrics are kept, and their spread over noise seeds is the uncertainty to quote
    :ivar complete: True when every sample was computed; False if the run stopped
        early (see ``message``)
    :ivar message: why the run stopped early, or what limits its accuracy ("" when
        nothing does)
    :ivar engine: ``"bdsim"`` (the diagram) or ``"batch"``
    :ivar backend: what actually integrated the run: ``"solve_ivp RK45"`` (or the
        solver method used) for the diagram, ``"compiled"`` or ``"plain"``
        for the batch engine
    :ivar log_every: samples are logged every ``log_every`` steps of ``Ts``
    :ivar steps: the steps the batch engine kept over the whole run (its error control
        chooses them; ``None`` for the diagram)
    :ivar rejected: the steps the batch engine took again shorter, their error beyond
        the tolerance
    :ivar rtol: the relative tolerance the batch engine returned the run at (``None``
        for the diagram)
    :ivar estimate: how ``numerical_error`` was obtained: ``"tightened"`` (the run
        against the same run at a looser tolerance), ``"probe"`` (sensitive: how far a
        perturbed start moved it), or ``""`` (not estimated)
    """

    scenario: object
    t: np.ndarray
    pose: np.ndarray
    velocity: np.ndarray
    reference: np.ndarray
    v_d: np.ndarray | None
    v_ref: np.ndarray | None
    theta_hat: np.ndarray | None
    engine: str = "bdsim"
    complete: bool = True
    message: str = ""
    steps: int | None = None
    rejected: int | None = None
    backend: str = ""
    running: np.ndarray | None = None
    numerical_error: dict | None = None
    sensitive: bool = False
    rtol: float | None = None
    estimate: str = ""
    error: np.ndarray = field(init=False)
    metrics: dict = field(init=False)

    def __post_init__(self):
        self.complete = bool(self.complete)
        self.sensitive = bool(self.sensitive)
        self.message = str(self.message)
        self.error = distance(self.reference, self.pose)
        if self.running is None:  # from the series (every sample, where all are logged)
            self.running = running(self.t, self.error, self.velocity)
        self.metrics = _metrics_of(self.running, self.error)

    def __repr__(self) -> str:
        """A dozen lines: the run, its engine, whether it completed, its metrics and
        final estimate. The series are attributes (``t``, ``pose``, ...);
        :meth:`summary` holds everything that ``summary.json`` does."""
        sc = self.scenario
        robot = getattr(sc.robot, "name", "") or "custom robot"
        lines = [f"unidyn.Result: {sc.case} loop" + (f" {sc.name!r}" if sc.name else ""),
                 f"  robot {robot}, reference {type(sc.trajectory).__name__}, T = {sc.T:g} s, "
                 f"{len(self.t)} samples every {sc.Ts * sc.log_every:g} s",
                 f"  engine {self.engine}" + (f" ({self.backend})" if self.backend else "")
                 + (", complete" if self.complete else f", INCOMPLETE: {self.message}")]
        if self.complete and self.message:
            lines.append(f"  note: {self.message}")
        if not self.complete:
            lines.append(f"  metrics of the part computed, to t = {self.t[-1] if len(self.t) else 0:g} s:")
        noisy = has_noise(sc)
        if noisy:  # which uncertainty to quote, before the numbers it qualifies
            lines += [f"  noise seed {sc.noise.seed}: these metrics are one sample of the noise; quote "
                      f"their spread over seeds,", "    unidyn.run(scenario, seeds=N): "
                      "mean ± standard error (n)"]
        else:
            lines.append("  no noise: deterministic, each metric to its numerical error")
        err = self.numerical_error or {}
        for k, v in self.metrics.items():
            unit, note = BY_NAME[k].unit, BY_NAME[k].note
            line = f"  {k:12s} {'-' if v is None else f'{v:.6g}'}" + (f" {unit}" if unit else "")
            if note:
                line += f" ({note})"
            if k in err and not noisy:
                line += f"  (numerical error {err[k]:.1e} relative)"
            lines.append(line)
        if self.numerical_error is None:
            lines.append("  numerical error: not estimated" + (" (the diagram integrates once)"
                                                              if self.engine == "bdsim" else ""))
        elif noisy and err:
            lines.append(f"  numerical error at most {max(err.values()):.1e} relative: the "
                         f"integration's, not an error bar")
        lines.append("  sensitive    " + (("True: no tolerance converges it"
                                           + ("; quote the spread over seeds" if noisy else ""))
                                          if self.sensitive else "False"))
        spec = sc.case_spec
        if self.theta_hat is not None and len(self.t) and spec.compensated:
            # only what the loop has: an estimate where it adapts, the compensator's
            # fixed parameters where it compensates exactly, nothing without compensator
            values = " ".join(f"{v:.4g}" for v in self.theta_hat[-1])
            if spec.adaptive:
                lines.append(f"  theta_hat(T) {values}"
                             + (f"  (numerical error {err['theta_hat']:.1e} relative)"
                                if "theta_hat" in err and not noisy else ""))
            else:
                lines.append(f"  theta_hat    {values}  (fixed: exact compensation)")
        lines.append("  series: t, pose, velocity, reference, error"
                     + "".join(f", {k}" for k in ("v_d", "v_ref", "theta_hat")
                               if getattr(self, k) is not None)
                     + "; plots: plot_path(), plot_error(), ...; save(folder)")
        return "\n".join(lines)

    @property
    def integrals(self) -> np.ndarray:
        """The integral metrics (:data:`INTEGRAL_NAMES`) from t = 0 to each logged
        sample, (N, their number): those columns of :attr:`running`."""
        return self.running[:, [METRIC_NAMES.index(k) for k in INTEGRAL_NAMES]]

    # ------------------------------------------------------------------ #
    def window(self, t0: float, t1: float) -> dict:
        """Metrics over t0 <= t <= t1 (e.g. the paper's before/after windows, Section 5's
        IAE over 15-30 s), from the integrals accumulated at every sample: between the
        first and the last logged sample in the window (with ``log_every`` 1, every
        sample), and the final values at the last; not a peak, which every sample of the
        window would give (:attr:`running` holds each peak from t = 0).

        :raises ValidationError: the window is not within the run's samples"""
        m = np.flatnonzero((self.t >= t0 - 1e-9) & (self.t <= t1 + 1e-9))
        if len(m) < 2 or t0 < self.t[0] - 1e-9 or t1 > self.t[-1] + 1e-9:
            span = f"{self.t[0]:g}-{self.t[-1]:g} s" if len(self.t) else "no samples"
            raise ValidationError(f"the window {t0:g}-{t1:g} s is not covered by the run's "
                                  f"samples ({span})")
        i0, i1 = m[0], m[-1]
        w = slice(i1, i1 + 1)
        effort = np.sum(np.asarray(self.velocity[w], dtype=float) ** 2, axis=-1)
        out = {}
        for j, metric in enumerate(METRICS):
            if metric.rule == INTEGRAL:
                out[metric.name] = float(self.running[i1, j] - self.running[i0, j])
            elif metric.rule == FINAL:
                out[metric.name] = _floats(sample_value(j, self.t[w], self.error[w],
                                                        effort)[-1:])[0]
        return out

    def summary(self) -> dict:
        """What ``summary.json`` holds: scenario, metrics, provenance."""
        sc = self.scenario
        notes = []
        out = {
            "unidyn_version": __version__,
            "engine": self.engine,
            "backend": self.backend,
            "steps": self.steps,
            "rejected": self.rejected,
            "complete": self.complete,
            "message": self.message,
            "scenario": json_ready(sc.to_dict()),  # no limit: null
            "seed": None if sc.noise is None else sc.noise.seed,
            "samples": int(len(self.t)),
            "t_end": float(self.t[-1]) if len(self.t) else 0.0,
            "metrics": _finite_or_null(self.metrics, "metrics", notes),
            "numerical_error": _finite_or_null(self.numerical_error, "numerical_error", notes),
            "sensitive": self.sensitive,
            "estimate": self.estimate,
            "rtol": self.rtol,
            "uncertainty": uncertainty(self),
            "theta_hat_final": (_finite_or_null(_floats(self.theta_hat[-1]), "theta_hat_final", notes)
                                if len(self.t) and self.theta_hat is not None else None),
        }
        if notes:
            out["notes"] = notes
        return out

    def to_json(self) -> str:
        """``summary()`` as strict JSON: a non-finite number is written as ``null``
        (with a line in ``notes``), never as ``Infinity`` or ``NaN``."""
        return json.dumps(self.summary(), indent=2, default=_json_default, allow_nan=False) + "\n"

    def save(self, folder, overwrite: bool = False) -> Path:
        """Write ``timeseries.csv`` and ``summary.json`` into ``folder`` (created if
        needed, a symbolic link followed) and return it.

        A folder that holds an earlier run's results is refused unless ``overwrite``
        (True or False); then the earlier run's files are replaced, and those this one
        does not write (its figures) removed. Only files that the folder's manifest
        ``.unidyn-run.json`` proves unidyn wrote, by their content, are replaced or
        removed: a file of yours with a result's name is refused, never touched. The files are written in full before
        any is replaced, so an error or an interrupt leaves the folder as it was (see
        :mod:`unidyn.results.folders`). Inside a :func:`~unidyn.results.folders.staged_output`
        block, pass its :class:`~unidyn.results.folders.Stage`: the files are written
        into it, to be moved into place with the block's other files."""
        if isinstance(folder, Stage):
            self._write(folder.path)
            return folder.path
        with staged_output(folder, kind="run", names=RUN_FILES, overwrite=overwrite,
                           what="run results", option="folder",
                           flag="overwrite=True") as stage:
            self._write(stage.path)
        return Path(folder)

    def series_columns(self) -> dict:
        """The columns of ``timeseries.csv``: name -> series (those logged)."""
        cols = {"t": self.t, "x": self.pose[:, 0], "y": self.pose[:, 1], "psi": self.pose[:, 2],
                "u": self.velocity[:, 0], "w": self.velocity[:, 1],
                "x_d": self.reference[:, 0], "y_d": self.reference[:, 1]}
        if self.v_d is not None:  # the series logged (Scenario.log_series)
            cols.update(u_d=self.v_d[:, 0], w_d=self.v_d[:, 1])
        if self.v_ref is not None:
            cols.update(u_ref=self.v_ref[:, 0], w_ref=self.v_ref[:, 1])
        cols["error"] = self.error
        if self.theta_hat is not None:
            for i in range(6):
                cols[f"theta_hat{i + 1}"] = self.theta_hat[:, i]
        return cols

    def series_text(self, lead: str = ""):
        """The rows of ``timeseries.csv`` as text, a block at a time (no copy of the
        whole series in memory), each row after ``lead`` (a first column's value and
        its comma)."""
        # float32 series: the 9 digits that give each value back exactly (t is float64)
        fmt = "%.10g" if self.pose.dtype == np.float64 else "%.9g"
        columns = list(self.series_columns().values())
        line = (lead.replace("%", "%%") + ",".join(["%.10g"] + [fmt] * (len(columns) - 1))
                + "\n")
        # formatted a block at a time (not np.savetxt: its wrapper keeps each block's
        # text alive until the garbage collector runs, 260 MB for a 10^6-sample run)
        for i in range(0, len(self.t), _CSV_BLOCK):
            block = np.column_stack([c[i:i + _CSV_BLOCK] for c in columns])
            yield (line * len(block)) % tuple(block.ravel().tolist())

    def _write(self, folder: Path) -> None:
        header = ",".join(self.series_columns()) + "\n"
        write_atomic(folder / "timeseries.csv", header, more=self.series_text())
        write_atomic(folder / "summary.json", self.to_json())

    # plotting helpers (matplotlib is imported only when one is called)
    def plot_path(self, ax=None, **kw):
        return plots.plot_path(self, ax=ax, **kw)

    def plot_error(self, ax=None, **kw):
        return plots.plot_error(self, ax=ax, **kw)

    def plot_positions(self, axes=None, **kw):
        return plots.plot_positions(self, axes=axes, **kw)

    def plot_velocities(self, axes=None, **kw):
        return plots.plot_velocities(self, axes=axes, **kw)

    def plot_theta_hat(self, ax=None, **kw):
        return plots.plot_theta_hat(self, ax=ax, **kw)


def _finite_or_null(value, where: str, notes: list):
    """``value`` (a dict or list of numbers, or None) with every non-finite number
    replaced by None; each replacement adds a line to ``notes``."""
    if value is None:
        return None
    items = value.items() if isinstance(value, dict) else enumerate(value)
    out = dict(value) if isinstance(value, dict) else list(value)
    for k, v in items:
        if v is not None and not np.isfinite(v):
            notes.append(f"{where}[{k!r}] was {float(v)!r}, written as null")
            out[k] = None
    return out


def _json_default(o):
    if isinstance(o, (np.floating, np.integer)):
        return o.item()
    if isinstance(o, np.ndarray):
        return o.tolist()
    raise TypeError(f"not JSON serialisable: {type(o).__name__}")
