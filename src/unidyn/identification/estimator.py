"""The entry point of identification, :func:`identify`: the options and the logs
read and checked, the output-error fit (:mod:`~unidyn.identification.output_error`,
from :mod:`~unidyn.identification.first_estimate`) or the equation-error estimate
(:mod:`~unidyn.identification.equation_error`) run, and their intervals
(:mod:`~unidyn.identification.intervals`) and warnings
(:mod:`~unidyn.identification.checks`) gathered into an
:class:`~unidyn.identification.IdentificationResult`."""

from __future__ import annotations

import contextlib
import dataclasses
import math
import sys
import warnings as _warnings_mod
from dataclasses import dataclass

import numpy as np
from tqdm import tqdm

from .._validate import ValidationError, choice, integer, nonnegative, positive, short_repr
from ..model.parameters import RobotParameters
from .bags import row_commands
from .checks import (
    check_excitation,
    check_memory,
    check_physical,
    check_units,
    estimate_warnings,
    fit_refused,
)
from .equation_error import SMOOTHING_METHODS, equation_error_fit, white_noise_std
from .first_estimate import first_estimate
from .intervals import JITTER_MIN, ci95, jitter_widening, lag_widening, measured_stamp_jitter
from .logs import (
    COLUMNS,
    IdentificationWarning,
    check_layout,
    check_measured,
    join_logs,
    pose_factors,
)
from .output_error import output_error_fit
from .replay import COMMAND_CONVENTIONS
from .results import THETA_NAMES, IdentificationResult
from .validation import validation_report

#: The estimators of :func:`identify`.
METHODS = ("output-error", "equation-error")
# a parameter whose information rests on less than this share of the samples is
# reported as not identifiable (see the share of :func:`~unidyn.identification.output_error.output_error_fit`): a multisine excitation gives
# 0.08 to 0.25, ten one-sample blips in a minute and a half of constant commands 0.007
# to 0.07
_MIN_SHARE = 0.005
# logs of more rows than this show a progress bar on a terminal
_PROGRESS_ROWS = 100_000


def _emit(res):
    """Issue the result's warnings as :class:`IdentificationWarning` and return it."""
    for text in res.warnings:
        _warnings_mod.warn(text, IdentificationWarning, stacklevel=3)
    return res


def identify(log, *more_logs, commands: str = "held", delay=0.0,
             method: str = "output-error", smoothing: str = "filter",
             window: float | None = None, order: int = 3, noise_std=None, columns=None,
             name: str = "identified", rel_stderr_max: float = 0.25, validate: bool = True,
             gap: float | None = None, check_commands: bool = True,
             time_unit: str | None = None,
             stamp_jitter: float | None = None,
             progress: bool | None = None, scale=None) -> IdentificationResult:
    r"""Estimate theta1..theta6 of Eq. (2) from one or more logs of one robot.

    The default ``method="output-error"`` simulates Eq. (2) over every piece of
    every log with the logged commands applied as the robot received them, and
    adjusts theta (and each piece's initial velocities, and the input delay if
    asked) so that the simulated velocities match the measured ones
    (bounded Levenberg-Marquardt, each channel weighted by its noise level;
    derivatives by finite differences of the compiled simulation, held once in
    single precision, so that a log of 10^6 rows fits in a few hundred MB).
    Logs read from bags (:func:`~unidyn.identification.read_bag`) are refitted
    once with each row's command weighted by the fitted response (see
    :func:`~unidyn.identification.bags.held_weighted`), and with unstamped
    commands the intervals allow for the recorder's lag (``RECORDER_LAG``).
    It starts from a least-squares estimate: for held commands the exact
    discretisation of the linear part of Eq. (2) under a held input,
    u[k+1] = a u[k] + b u_ref[k] + c w[k]^2 with a = exp(-theta4 dt / theta1),
    b = (1 - a) / theta4, c = theta3 b (and its twin for w); for linear
    commands, Eq. (11) through the state-variable filter. ``"equation-error"``
    stops at Eq. (11) through the filter (or a Savitzky-Golay fit), which treats
    the commands as smooth.

    :param log: t (s), u_ref (m/s), w_ref (rad/s), u (m/s), w (rad/s): a mapping,
        structured array, object with attributes or CSV path (see :func:`load_log`)
    :param more_logs: further logs of the same robot, identified together
        (each with its own initial state)
    :param commands: how the logged commands act between time stamps:
        ``"held"`` (default; each command from its time stamp until the next,
        as robot firmware applies them) or ``"linear"`` (varying linearly, for
        commands that are samples of a smooth signal)
    :param delay: input delay: seconds (>= 0), a string ``"N samples"`` (in
        median sample intervals), or ``"auto"`` to estimate it (0..4 samples)
    :param method: ``"output-error"`` (default) or ``"equation-error"``
    :param smoothing: for the equation-error estimate: ``"filter"`` (default)
        or ``"savgol"``
    :param window: the filter / fit window of the equation-error estimate, s
        (default automatic)
    :param order: polynomial degree of the Savitzky-Golay fit, 2..6
    :param noise_std: std of the white noise on u and w (a number or a pair):
        ``None`` (default) estimates it from the log. It weights the two
        channels of the output-error fit and sets the equation-error noise-bias
        correction (0 switches that off)
    :param columns: mapping from t, u_ref, w_ref, u, w to the log's own names
    :param name: the name given to the identified :class:`RobotParameters`
    :param rel_stderr_max: theta3 or theta5 with a standard error above this
        fraction of its magnitude is reported as unidentified, > 0
    :param validate: simulate the identified model over the logs from their
        first measured velocities and keep the report (``result.validation``)
    :param gap: a time step longer than this (s) splits a log; default 1.4 times
        the median time step (a step of 1.4 to 5 median steps means missing rows,
        whose held commands are unknown; a longer one a gap)
    :param check_commands: also fit the other command convention and warn when
        it fits the log clearly better
    :param time_unit: the unit of the logs' time column, ``"s"``, ``"ms"``,
        ``"us"`` or ``"ns"`` (see :func:`load_log`); default seconds, refusing
        a median time step over 1 s as almost surely another unit
    :param stamp_jitter: the std of the error of the time stamps, s, when known
        (0: the stamps are exact, as when the samples are irregular but stamped
        when taken). Default None: measured from the stamps as if the samples
        were taken on a regular clock. Above a thousandth of the median step,
        the output-error intervals are widened for it (stamp errors bias the
        fit: it is repeated with as much jitter again added to the stamps, and
        the shift and scatter of the estimates are added to the standard
        errors) and a warning says by how much
    :param scale: factors that bring the logs' columns to m/s and rad/s, e.g.
        ``{"u_ref": 0.01}`` for linear-speed commands logged in cm/s (see
        :func:`load_log`). A log whose gain from a command to its measured velocity
        (1/theta4, 1/theta6) is far from 1 is refused, naming the likely units
    :param progress: a progress bar on stderr while the fits run: None (default)
        for logs of more than 100,000 rows when stderr is a terminal; True or False
        to force it on or off
    :raises ValidationError: for a bad log (see :func:`load_log`; every row it
        drops or skips is reported in ``warnings``), a log whose fit needs more
        memory than the system has available (about 250 bytes a row), constant
        commands or no motion (nothing to identify), a window that does not fit the
        log, or a non-positive theta1, theta2, theta4 or theta6 (no physical robot
        has one; the message lists the likely causes)
    :return: :class:`IdentificationResult`
    """
    commands, method, smoothing, order, window, rel_stderr_max, gap, stamp_jitter = \
        _checked_options(commands, method, smoothing, order, window, rel_stderr_max, name,
                         gap, stamp_jitter, validate, check_commands)
    if progress is not None and not isinstance(progress, (bool, np.bool_)):
        raise ValidationError(f"progress must be None, True or False, got {short_repr(progress)}")
    lg = _read_logs((log,) + more_logs, columns, gap, time_unit, stamp_jitter, commands,
                    delay, window, noise_std, scale)
    check_memory(lg, method)
    with _progress_bar(lg, progress) as lg.tick, fit_refused():
        res = _identify(lg, method, smoothing, window, order, rel_stderr_max, name,
                        check_commands, validate)
    return _emit(res)


def _identify(lg, method, smoothing, window, order, rel_stderr_max, name, check_commands,
              validate):
    if method == "equation-error":
        res = _identify_equation_error(lg, smoothing, window, order, rel_stderr_max, name)
    else:
        theta0, start_kind, m0 = first_estimate(lg.D, lg.segs, lg.linear, lg.delay,
                                                lg.delay_auto, lg.dt_med, smoothing, window,
                                                order, lg.su, lg.sw)
        oe = _weighted_oe_fit(lg, theta0, m0 * lg.dt_med if lg.delay_auto else lg.delay)
        if lg.recorded and not lg.linear and oe["delay"] == 0:
            # the commands of the rows weighted as the robot's response weighs them
            lg.D.update(row_commands(lg.recorded, oe["theta"]))
            oe = _weighted_oe_fit(lg, oe["theta"], 0.0)
        stderr, warns = _oe_intervals(lg, oe, rel_stderr_max)
        if check_commands:
            warns += _command_check(lg, oe)
        res = _oe_result(lg, oe, stderr, warns, start_kind, name)
    if validate:
        res = _with_validation(res, lg.D, lg.segs)
    return res


@contextlib.contextmanager
def _progress_bar(lg, progress):
    """A tqdm progress bar on stderr counting the simulations of the fits (for logs
    over ``_PROGRESS_ROWS`` rows, on a terminal; ``progress`` True or False forces it
    on or off), as the callable to tick; None without a bar."""
    show = lg.D["t"].size > _PROGRESS_ROWS if progress is None else bool(progress)
    if not show:
        yield None
        return
    bar = tqdm(desc=f"identify ({lg.D['t'].size} rows)", unit=" simulations",
               file=sys.stderr, disable=None if progress is None else False, leave=False)
    try:
        yield bar.update
    finally:
        bar.close()


def _checked_options(commands, method, smoothing, order, window, rel_stderr_max, name,
                     gap, stamp_jitter, validate, check_commands):
    """The options of :func:`identify` checked (one clear line for a bad one)."""
    commands = choice("commands", commands, COMMAND_CONVENTIONS)
    method = choice("method", method, METHODS)
    smoothing = choice("smoothing", smoothing, SMOOTHING_METHODS)
    order = integer("order", order, 2, 6)
    if window is not None:
        window = positive("window", window)
    rel_stderr_max = positive("rel_stderr_max", rel_stderr_max)
    if not isinstance(name, str):
        raise ValidationError(f"name must be a string, got {short_repr(name)}")
    if gap is not None:
        gap = positive("gap", gap)
    if stamp_jitter is not None:
        stamp_jitter = nonnegative("stamp_jitter", stamp_jitter)
    for flag, v in (("validate", validate), ("check_commands", check_commands)):
        if not isinstance(v, (bool, np.bool_)):
            raise ValidationError(f"{flag} must be True or False, got {short_repr(v)}")
    return commands, method, smoothing, order, window, rel_stderr_max, gap, stamp_jitter


@dataclass
class _Logs:
    """The joined logs of one :func:`identify` call and what is read from them."""
    D: dict                 # the joined columns (see join_logs)
    segs: list              # (start, stop) rows of each piece
    n_logs: int
    commands: str
    dt_med: float           # median time step, s
    delay: float            # s (0 when it is to be estimated)
    delay_auto: bool
    su: float               # noise std of u and w
    sw: float
    stamp_jitter: float | None
    warnings: list          # about the logs: missing rows, gaps, dropped rows
    tick: object = None     # called as the fits advance (a progress bar), or None
    recorded: list = None   # the logs read from bags, with the commands as recorded

    @property
    def linear(self) -> bool:
        return self.commands == "linear"

    def description(self, delay) -> str:
        n_used = sum(b - a for a, b in self.segs)
        return (f"identified from {n_used} samples in {len(self.segs)} piece(s) of "
                f"{self.n_logs} log(s), commands={self.commands!r}, delay={delay:g} s")


def _read_logs(logs, columns, gap, time_unit, stamp_jitter, commands, delay, window,
               noise_std, scale=None) -> _Logs:
    """Join the logs, check that they can be identified from, read the delay and
    the noise levels, and note missing rows and gaps."""
    stamp_jitter = _recorded_jitter(logs, stamp_jitter)
    D, segs, _, _ = join_logs(logs, columns, gap, time_unit, scale)
    t, u_ref, w_ref, u, w = (D[k] for k in COLUMNS)
    check_excitation(u_ref, w_ref)
    check_measured(u_ref, w_ref, u, w)
    layout_warnings = check_layout(D, segs, columns)
    dt_med = float(np.median(np.concatenate([np.diff(t[a:b]) for a, b in segs])))
    delay_auto, delay = _delay_seconds(delay, dt_med)
    longest = max(t[b - 1] - t[a] for a, b in segs)
    if delay > longest / 3:  # the commands shifted by it would leave too little to fit
        raise ValidationError(f"delay must be <= a third of the longest piece of the log "
                              f"({longest / 3:g} s), got {delay:g} s")
    if window is not None and window > longest / 3:
        raise ValidationError(f"window must be <= a third of the longest piece of the log "
                              f"({longest / 3:g} s), got {window!r}")
    if noise_std is None:
        su = _pooled_noise(t, u, segs)
        sw = _pooled_noise(t, w, segs)
    else:
        su, sw = _pair("noise_std", noise_std)
    warns = []
    n_missing, n_gaps = D.get("missing", (0, 0))
    if n_missing:
        warns.append(f"{n_missing} missing row(s) detected (time steps of 1.4 to 5 times the "
                     f"median step): the commands held while they were missing are unknown, "
                     f"so the log is split there into pieces, each with its own initial "
                     f"state (set gap= to change this)")
    if n_gaps:
        warns.append(f"{n_gaps} gap(s) in the log(s) (time steps over 5 times the median "
                     f"step): the log is split there into pieces, each with its own initial "
                     f"state")
    warns += D["notes"]     # rows dropped or skipped, short pieces not used
    warns += layout_warnings
    recorded = [lg for lg in logs if isinstance(lg, dict) and "commands" in lg]
    if len(recorded) != len(logs) or sum(lg["t"].size for lg in recorded) != D["t"].size:
        recorded = None
    return _Logs(D, segs, len(logs), commands, dt_med, delay, delay_auto, su, sw,
                 stamp_jitter, warns, recorded=recorded)


def _identify_equation_error(lg, smoothing, window, order, rel_stderr_max, name):
    """Eq. (11) through the filter or the Savitzky-Golay fit, as a result."""
    fit = equation_error_fit(lg.D, lg.segs, smoothing, window, order, lg.su, lg.sw)
    theta, cov, resid, keep_t, conds, r2, ew, win, uk, wk = fit
    stderr = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    check_physical(theta, stderr)
    check_units(theta, stderr)
    warns = lg.warnings + ew + estimate_warnings(theta, stderr, conds, uk, wk, lg.dt_med,
                                                 rel_stderr_max, pose_factors(lg.D, lg.segs))
    if not lg.linear:
        warns.append(
            "the equation-error estimate treats the commands as smooth between samples; "
            "for commands held between samples it is biased by about half a sample "
            f"(theta1 by about theta4 dt / 2 = {theta[3] * lg.dt_med / 2:.3g} s): use "
            "method='output-error'")
    rp = RobotParameters(*theta.tolist(), name=name,
                         source=f"{lg.description(lg.delay)}, method='equation-error', "
                                f"smoothing={smoothing!r}, window={win:g} s")
    return IdentificationResult(
        theta=rp, stderr=stderr, ci95=ci95(theta, stderr), residuals=resid, t=keep_t,
        condition_numbers=tuple(conds), warnings=warns, smoothing=smoothing, window=win,
        order=order if smoothing == "savgol" else None, n_samples=int(keep_t.size),
        fit_r2=tuple(r2), noise_std=(lg.su, lg.sw), method="equation-error",
        commands=lg.commands, delay=lg.delay, segments=len(lg.segs), n_logs=lg.n_logs)


def _weighted_oe_fit(lg, theta0, delay):
    """The output-error fit weighted by the noise levels; refitted once with the
    residuals' own levels when they differ by more than 25 %."""
    u, w = lg.D["u"], lg.D["w"]
    floor_u = 1e-9 * max(float(np.sqrt(np.mean(u * u))), 1e-9)
    floor_w = 1e-9 * max(float(np.sqrt(np.mean(w * w))), 1e-9)
    sig = np.array([max(lg.su, floor_u), max(lg.sw, floor_w)])
    oe = output_error_fit(lg.D, lg.segs, theta0, sig, lg.linear, delay, lg.delay_auto,
                          lg.dt_med, progress=lg.tick)
    if np.any(np.abs(oe["rms"] / sig - 1.0) > 0.25):
        sig = np.maximum(oe["rms"], [floor_u, floor_w])
        oe = output_error_fit(lg.D, lg.segs, oe["theta"], sig, lg.linear, oe["delay"],
                              lg.delay_auto, lg.dt_med, v0=oe["v0"], progress=lg.tick)
    return oe


def _oe_intervals(lg, oe, rel_stderr_max):
    """The standard errors of theta (widened for stamp jitter) and the warnings
    about the estimate, starting with those about the logs."""
    theta = oe["theta"]
    stderr = np.sqrt(np.clip(np.diag(oe["cov"])[:6], 0.0, None))
    check_physical(theta, stderr)
    check_units(theta, stderr)
    warns = list(lg.warnings)
    t = lg.D["t"]
    jitter = measured_stamp_jitter(t, lg.segs) if lg.stamp_jitter is None else lg.stamp_jitter
    if jitter > JITTER_MIN * lg.dt_med:
        stderr, note = jitter_widening(lg.D, lg.segs, oe, theta, stderr, lg.linear,
                                       lg.dt_med, jitter)
        warns.append(note)
    unstamped = lg.recorded and not all(r["commands"]["stamped"] for r in lg.recorded)
    if unstamped and not lg.linear and oe["delay"] == 0:
        stderr, note = lag_widening(lg, oe, theta, stderr)
        warns.append(note)
    idx = oe["rows"]
    for i in np.flatnonzero(oe["share"] < _MIN_SHARE):
        if i in oe["dead"]:
            continue
        stderr[i] = math.inf
        warns.append(f"{THETA_NAMES[i]} is not identifiable from this log: its estimate "
                     f"{theta[i]:.4g} rests on {100 * oe['share'][i]:.2g} % of the samples "
                     f"(the few moments that excite it, such as isolated steps in otherwise "
                     f"steady commands), too few for its interval to mean anything; it is "
                     f"reported without one. Excite it throughout the log (see excitation())")
    for i in oe["dead"]:
        warns.append(f"{THETA_NAMES[i]} is not identifiable from this log: the simulated "
                     f"velocities do not depend on it (or only through a combination with other "
                     f"parameters), so its value is arbitrary and its standard error is "
                     f"reported as inf")
    warns += estimate_warnings(theta, stderr, oe["conds"], lg.D["u"][idx], lg.D["w"][idx],
                               lg.dt_med, rel_stderr_max, pose_factors(lg.D, lg.segs))
    return stderr, warns + oe["warnings"]


def _command_check(lg, oe) -> list:
    """A warning when the other command convention fits the log clearly better."""
    other = "held" if lg.linear else "linear"
    alt = output_error_fit(lg.D, lg.segs, oe["theta"], oe["sig"], not lg.linear, oe["delay"],
                           False, lg.dt_med, v0=oe["v0"], covariance=False, progress=lg.tick)
    gain = oe["cost"] - alt["cost"]
    # an absolute floor (noise), and a relative one: a log that Eq. (2) does not
    # fit (a saturating robot) can fit a little better either way
    if gain <= max(25.0, 1e-3 * oe["rows"].size, 0.02 * oe["cost"]):
        return []
    if other == "held":
        why = ("the commands are held between samples, or take effect later than "
               "their time stamps (see delay='auto')")
    else:
        why = ("the commands vary smoothly between samples, or take effect earlier "
               "than their time stamps (by about half a sample; delay cannot be "
               "negative, so delay='auto' cannot fix that: check how the commands "
               "and the velocities are time-stamped)")
    return [f"the log fits clearly better with commands={other!r} (sum of squared "
            f"normalised velocity errors {alt['cost']:.4g} against {oe['cost']:.4g}): "
            f"{why}; with the wrong convention theta1 and theta2 are biased by about "
            f"half a sample"]


def _oe_result(lg, oe, stderr, warns, start_kind, name):
    """The :class:`IdentificationResult` of the output-error fit."""
    theta, idx, est_delay = oe["theta"], oe["rows"], oe["delay"]
    rp = RobotParameters(*theta.tolist(), name=name,
                         source=f"{lg.description(est_delay)}, method='output-error' from a "
                                f"{start_kind} start")
    return IdentificationResult(
        theta=rp, stderr=stderr, ci95=ci95(theta, stderr), residuals=oe["residuals"],
        t=lg.D["t"][idx], condition_numbers=tuple(oe["conds"]), warnings=warns,
        smoothing=None, window=None, order=None, n_samples=int(idx.size),
        fit_r2=tuple(oe["r2"]), noise_std=tuple(float(x) for x in oe["rms"]),
        method="output-error", commands=lg.commands, delay=float(est_delay),
        delay_stderr=float(oe["delay_stderr"]) if lg.delay_auto else 0.0,
        segments=len(lg.segs), n_logs=lg.n_logs, whiteness=tuple(oe["whiteness"]),
        v0=oe["v0"])


def _recorded_jitter(logs, stamp_jitter):
    """``stamp_jitter`` where every log says it and the caller did not.

    A log read from a ROS bag (:func:`~unidyn.identification.read_bag`) carries
    ``stamp_jitter = 0``: its samples are at their header stamps, irregular but
    exact, so no widening is due. (Its recording-gap threshold is read by
    :func:`~unidyn.identification.join_logs`.)
    """
    said = [lg for lg in logs if isinstance(lg, dict) and "stamp_jitter" in lg]
    if stamp_jitter is None and said and len(said) == len(logs):
        stamp_jitter = max(float(lg["stamp_jitter"]) for lg in said)
    return stamp_jitter


def read_delay(delay) -> tuple[str, float]:
    """The ``delay`` argument of :func:`identify` (and ``unidyn identify --delay``)
    read: ``("auto", 0.0)`` to estimate it, ``("samples", N)`` for ``"N samples"``
    (0 <= N <= 1000, in median sample intervals), or ``("s", seconds)`` for a number
    of seconds >= 0, given as a number or as text (``"0.1"``).

    :raises ValidationError: for anything else, naming ``delay``
    """
    if isinstance(delay, str):
        text = delay.strip().lower()
        if text == "auto":
            return "auto", 0.0
        num, _, unit = text.partition(" ")
        try:
            n = float(num)
        except ValueError:
            n = math.nan
        if unit.strip() in ("sample", "samples") and math.isfinite(n) and 0 <= n <= 1000:
            return "samples", n
        if not unit and math.isfinite(n) and n >= 0:
            return "s", n
        raise ValidationError(f"delay must be seconds >= 0, 'N samples' or 'auto', got "
                              f"{short_repr(delay)}")
    return "s", nonnegative("delay", delay)


def _delay_seconds(delay, dt_med):
    """(estimate?, delay in seconds) from the ``delay`` argument."""
    kind, value = read_delay(delay)
    return kind == "auto", value * dt_med if kind == "samples" else value


def _pooled_noise(t, y, segs) -> float:
    var, n = 0.0, 0
    for a, b in segs:
        if b - a >= 5:
            var += white_noise_std(t[a:b], y[a:b]) ** 2 * (b - a)
            n += b - a
    return float(math.sqrt(var / n)) if n else 0.0


def _pair(name, value):
    v = np.atleast_1d(np.asarray(value, dtype=float)) if not isinstance(value, (str, bytes)) \
        else np.array([])
    if v.ndim != 1 or v.size not in (1, 2) or not np.all(np.isfinite(v)) or np.any(v < 0):
        raise ValidationError(f"{name} must be None, a number >= 0 or a pair (on u, on w) of "
                              f"numbers >= 0, got {value!r}")
    return (float(v[0]), float(v[-1]))


def _with_validation(res, D, segs):
    rep = validation_report(res.theta, D, segs, res.commands, res.delay)
    return dataclasses.replace(res, validation=rep)
