"""What identification returns: :class:`IdentificationResult` (from
:func:`~unidyn.identification.identify`) and :class:`ValidationReport` (from
:func:`~unidyn.identification.validate`, and inside an identification result).
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..model.parameters import THETA_NAMES, RobotParameters
from ..results.folders import Stage, staged_output, write_atomic

__all__ = ["IdentificationResult", "ValidationReport"]

#: Every file an identification's folder may hold: the estimate, then the validation
#: that ``unidyn identify`` adds (the names its manifest may list).
IDENTIFY_FILES = ("theta.json", "validation.json", "validation.png")


@dataclass(frozen=True)
class ValidationReport:
    """How well a model reproduces a log when simulated from its commands.

    :param theta: the model simulated
    :param t: time, s
    :param u, w: measured velocities (the log)
    :param u_sim, w_sim: simulated velocities
    :param u_ref, w_ref: the logged commands the simulation was driven by
    :param fit: NRMSE fit per channel, %, 100 (1 - ||y - yhat|| / ||y - mean(y)||)
        (100 is perfect; 0 is no better than the mean; can be negative)
    :param rmse: root-mean-square error per channel (m/s, rad/s)
    """

    theta: RobotParameters
    t: np.ndarray
    u: np.ndarray
    w: np.ndarray
    u_sim: np.ndarray
    w_sim: np.ndarray
    u_ref: np.ndarray
    w_ref: np.ndarray
    fit: dict
    rmse: dict

    def as_dict(self) -> dict:
        """Fit numbers only, JSON-ready."""
        return {"name": self.theta.name, "fit": dict(self.fit), "rmse": dict(self.rmse)}


@dataclass(frozen=True)
class IdentificationResult:
    """What :func:`identify` found.

    :param theta: the identified parameters
    :param stderr: standard errors of theta1..theta6 (output error: from the
        Jacobian of the fit and the residual variance, widened by a Newey-West
        correction when the residuals are not white; equation error: the
        Newey-West corrected least-squares covariance)
    :param ci95: 95 % confidence intervals, shape (6, 2), theta -/+ 1.96 stderr
    :param residuals: shape (N, 2): measured minus simulated u and w (output
        error), or the equation errors of the two rows of Eq. (11) (equation error)
    :param t: the times of the N rows, s (pieces and logs one after the other)
    :param condition_numbers: condition numbers of the column-scaled sensitivities
        of the two channels (u: theta1, theta3, theta4; w: theta2, theta5, theta6)
    :param warnings: plain-language problems found (poor excitation, sampling too
        slow, coloured residuals, wrong command convention, non-physical values)
    :param smoothing: ``"filter"`` or ``"savgol"`` (equation error), else None
    :param window: the filter / fit window, s (equation error), else None
    :param order: polynomial degree of the Savitzky-Golay fit, else None
    :param n_samples: the number of rows N
    :param fit_r2: coefficient of determination of each channel (row), <= 1
    :param noise_std: the noise std on u and w: the residuals' (output error) or
        the one used in the noise-bias correction (equation error)
    :param method: ``"output-error"`` or ``"equation-error"``
    :param commands: the command convention, ``"held"`` or ``"linear"``
    :param delay: the input delay used or estimated, s
    :param delay_stderr: its standard error when estimated, s
    :param segments: the number of pieces (logs split at gaps) used
    :param n_logs: the number of logs
    :param whiteness: Ljung-Box statistics (10 lags) of the u and w residuals
        (about 10 for white residuals; above 29.6 they are not white)
    :param v0: the estimated initial [u, w] of each piece, shape (segments, 2)
    :param validation: the in-sample :class:`ValidationReport` (``validate=True``)
    """

    theta: RobotParameters
    stderr: np.ndarray
    ci95: np.ndarray
    residuals: np.ndarray
    t: np.ndarray
    condition_numbers: tuple
    warnings: list = field(default_factory=list)
    smoothing: str | None = None
    window: float | None = None
    order: int | None = None
    n_samples: int = 0
    fit_r2: tuple = (math.nan, math.nan)
    noise_std: tuple = (0.0, 0.0)
    method: str = "output-error"
    commands: str = "held"
    delay: float = 0.0
    delay_stderr: float = 0.0
    segments: int = 1
    n_logs: int = 1
    whiteness: tuple = (math.nan, math.nan)
    v0: np.ndarray | None = None
    validation: "ValidationReport | None" = None

    @property
    def theta_vector(self) -> np.ndarray:
        """theta1..theta6 as an array."""
        return self.theta.theta

    def relative_stderr(self) -> np.ndarray:
        """stderr / |theta| (inf where theta is 0)."""
        th = np.abs(self.theta.theta)
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.where(th > 0, self.stderr / th, np.inf)

    def as_dict(self) -> dict:
        """A JSON-ready dict: theta1..theta6 and name at the top level (as
        :func:`unidyn.model.robots.resolve` reads them from a ``.json`` file), plus the
        standard errors, intervals, condition numbers, warnings and settings."""
        def num(x):
            x = float(x)
            return x if math.isfinite(x) else None
        d = {k: float(v) for k, v in zip(THETA_NAMES, self.theta.theta)}
        d["name"] = self.theta.name
        d["source"] = self.theta.source
        d["stderr"] = {k: num(v) for k, v in zip(THETA_NAMES, self.stderr)}
        d["ci95"] = {k: [num(lo), num(hi)] for k, (lo, hi) in zip(THETA_NAMES, self.ci95)}
        d["condition_numbers"] = [num(c) for c in self.condition_numbers]
        d["fit_r2"] = [num(c) for c in self.fit_r2]
        d["warnings"] = list(self.warnings)
        d["method"] = self.method
        d["commands"] = self.commands
        d["delay"] = float(self.delay)
        d["delay_stderr"] = float(self.delay_stderr)
        d["segments"] = int(self.segments)
        d["n_logs"] = int(self.n_logs)
        d["whiteness"] = [num(x) for x in self.whiteness]
        d["smoothing"] = self.smoothing
        d["window"] = None if self.window is None else float(self.window)
        d["order"] = self.order
        if self.validation is not None:
            d["validation"] = self.validation.as_dict()
        d["n_samples"] = int(self.n_samples)
        d["noise_std"] = [num(x) for x in self.noise_std]
        return d

    def save(self, folder, overwrite: bool = False) -> Path:
        """Write ``theta.json`` (see :meth:`as_dict`) into ``folder`` (created if
        needed) and return its path. A folder holding an earlier identification is
        refused unless ``overwrite`` (True or False); then its ``theta.json``,
        ``validation.json`` and ``validation.png`` are replaced or removed, nothing else,
        and only if their content proves unidyn wrote them (see
        :mod:`unidyn.results.folders`). Inside a
        :func:`~unidyn.results.folders.staged_output` block, pass its
        :class:`~unidyn.results.folders.Stage` to write into it."""
        text = json.dumps(self.as_dict(), indent=2, allow_nan=False) + "\n"
        if isinstance(folder, Stage):
            write_atomic(folder.path / "theta.json", text)
            return folder.path / "theta.json"
        with staged_output(folder, kind="identify", names=IDENTIFY_FILES,
                           overwrite=overwrite, what="identification results",
                           option="folder", flag="overwrite=True") as stage:
            write_atomic(stage.path / "theta.json", text)
        return Path(folder) / "theta.json"

    def summary(self) -> str:
        """A readable table of the estimates."""
        lines = [f"{'':8s} {'estimate':>12s} {'stderr':>10s} {'95% CI':>27s}"]
        for k, v, s, (lo, hi) in zip(THETA_NAMES, self.theta.theta, self.stderr, self.ci95):
            lines.append(f"{k:8s} {v:12.6g} {s:10.3g} [{lo:12.6g}, {hi:12.6g}]")
        lines.append(f"{self.method}, commands {self.commands}, delay {self.delay:.4g} s"
                     + (f" (stderr {self.delay_stderr:.2g} s)" if self.delay_stderr else "")
                     + f"; {self.n_samples} samples in {self.segments} piece(s) of "
                     f"{self.n_logs} log(s)")
        lines.append(f"condition numbers: {self.condition_numbers[0]:.3g}, "
                     f"{self.condition_numbers[1]:.3g}; R^2: {self.fit_r2[0]:.6f}, "
                     f"{self.fit_r2[1]:.6f}; noise std {self.noise_std[0]:.3g} (u), "
                     f"{self.noise_std[1]:.3g} (w)")
        if self.validation is not None:
            f = self.validation.fit
            lines.append(f"in-sample simulation fit: u {f['u']:.1f} %, w {f['w']:.1f} %")
        lines += [f"warning: {w}" for w in self.warnings]
        return "\n".join(lines)

    def __repr__(self) -> str:
        """:meth:`summary` in at most a dozen and a half lines: the estimates with their
        intervals, how they were fitted, and the first warnings (all of them are in
        ``warnings``; every field is in :meth:`as_dict`)."""
        head = self.summary().split("\nwarning: ")[0].splitlines()
        shown, more = self.warnings[:3], len(self.warnings) - 3
        lines = ["unidyn IdentificationResult:", *head]
        lines += [f"warning: {_first_line(w)}" for w in shown]
        if more > 0:
            lines.append(f"... and {more} more warning(s) in .warnings")
        return "\n".join(lines)


def _first_line(text: str, limit: int = 160) -> str:
    line = str(text).splitlines()[0] if str(text) else ""
    return line if len(line) <= limit else line[:limit - 3] + "..."
