"""The uncertainty of an estimate of theta beyond its covariance: 95 % intervals,
and standard errors widened for what the residuals cannot show: time stamps that
jitter, and commands timed by the recorder rather than the robot (each measured by
refitting with as much error again, simulation-extrapolation)."""

from __future__ import annotations

import math

import numpy as np

from .bags import row_commands
from .equation_error import white_noise_std
from .output_error import output_error_fit
from .results import THETA_NAMES

#: The 97.5 % point of the standard normal: a 95 % interval is theta +/- Z95 stderr.
Z95 = 1.959963984540054
#: Time stamps jittering by more than this fraction of the median step (std) widen
#: the intervals (see jitter_widening); rounding to microseconds stays below it
JITTER_MIN = 1e-3
# fits repeated with added jitter to measure its effect
_JITTER_REPS = 4
#: The most by which a recorder receives a command after the robot does (s): an
#: unstamped command's time in a bag is when the recorder received it, a few ms
#: after the robot started to apply it (one delivery on the same computer).
RECORDER_LAG = 0.005


def ci95(theta, stderr):
    """The 95 % intervals of ``theta`` (rows [low, high]) from its standard errors."""
    return np.stack([theta - Z95 * stderr, theta + Z95 * stderr], axis=1)


def measured_stamp_jitter(t, segs) -> float:
    """The std of the error in the time stamps, s, if the samples were taken on
    a regular clock: each stamp against the mean of its neighbours (median-based,
    as :func:`white_noise_std`), pooled over the pieces."""
    var, n = 0.0, 0
    for a, b in segs:
        if b - a >= 5:
            var += white_noise_std(np.arange(b - a, dtype=float), t[a:b] - t[a]) ** 2 * (b - a)
            n += b - a
    return float(math.sqrt(var / n)) if n else 0.0


def jitter_widening(D, segs, oe, theta, stderr, linear, dt_med, jitter):
    """Standard errors that allow for time stamps in error by ``jitter`` (std, s),
    and the warning saying so.

    An error in a time stamp misplaces both the measured velocity and the moment
    the command changed, an error in the regressor that biases theta (most for
    time constants of about a sample) and that the residuals do not reveal.
    Its effect is measured by simulation-extrapolation: the fit is repeated
    ``_JITTER_REPS`` times with every stamp moved by a further random error of
    the measured std (seeded). Adding as much jitter again moves the estimate by
    about the bias the log's own jitter caused (the bias grows with the jitter's
    variance), and the repeats scatter by about the spread it adds; both are
    added to the standard errors: stderr^2 + shift^2 + scatter^2.
    """
    t = D["t"]
    rng = np.random.default_rng(0)
    reps = []
    for _ in range(_JITTER_REPS):
        tk = t.copy()
        for a, b in segs:
            tk[a:b] = np.sort(t[a:b] + jitter * rng.standard_normal(b - a))
        fk = output_error_fit({**D, "t": tk}, segs, theta, oe["sig"], linear, oe["delay"],
                              False, dt_med, v0=oe["v0"], covariance=False)
        reps.append(fk["theta"])
    wide, grown = _widened(np.array(reps), theta, stderr)
    note = (f"the time stamps jitter by about {1e3 * jitter:.3g} ms (std; "
            f"{100 * jitter / dt_med:.2g} % of the {dt_med:.4g} s step), as when a logger stamps "
            f"samples when it writes them: timing errors bias theta. The intervals allow for "
            f"it (refitted {_JITTER_REPS} times with as much jitter again; standard errors "
            + (f"widened: {', '.join(grown)})" if grown else "barely changed)")
            + "; stamp the samples when they are taken if you can")
    return wide, note


def _widened(reps, theta, stderr):
    """Standard errors with the shift and the scatter of refitted estimates ``reps``
    (one row a refit) added, and the parameters whose error grew by over 10 %, as
    text (``"theta1 x1.5"``)."""
    shift = reps.mean(axis=0) - theta
    wide = np.sqrt(stderr ** 2 + shift ** 2 + reps.var(axis=0, ddof=1))
    wide = np.where(np.isfinite(stderr), wide, stderr)
    grown = [f"{THETA_NAMES[i]} x{wide[i] / stderr[i]:.2g}" for i in range(6)
             if stderr[i] > 0 and wide[i] > 1.1 * stderr[i]]
    return wide, grown


def lag_widening(lg, oe, theta, stderr):
    """Standard errors that allow for unstamped commands timed by the recorder: the
    fit repeated ``_JITTER_REPS`` times with each command applied up to
    ``RECORDER_LAG`` earlier than recorded (uniform, seeded); the shift and the
    scatter of the estimates are added to the standard errors, as for stamp jitter
    (:func:`jitter_widening`). The time a robot applied a command is not in the
    bag, and a lag of a few ms biases theta1 and theta2 like a delay (by about
    theta4 and theta6 times the lag)."""
    rng = np.random.default_rng(1)
    reps = []
    for _ in range(_JITTER_REPS):
        lags = [-rng.uniform(0.0, RECORDER_LAG, r["commands"]["t"].size) for r in lg.recorded]
        D = {**lg.D, **row_commands(lg.recorded, theta, lags)}
        fk = output_error_fit(D, lg.segs, theta, oe["sig"], False, 0.0, False, lg.dt_med,
                              v0=oe["v0"], covariance=False, progress=lg.tick)
        reps.append(fk["theta"])
    wide, grown = _widened(np.array(reps), theta, stderr)
    note = (f"the commands carry no stamps: their times are when the recorder received "
            f"them, up to {1e3 * RECORDER_LAG:g} ms after the robot applied them. The "
            f"intervals allow for it (refitted {_JITTER_REPS} times with the commands that "
            f"much earlier; standard errors "
            + (f"widened: {', '.join(grown)})" if grown else "barely changed)")
            + "; commands stamped when the robot takes them (TwistStamped) avoid this")
    return wide, note
