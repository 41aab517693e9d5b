r"""The run's figures of merit, one entry each (:data:`METRICS`): what a metric is of,
how it accumulates over the samples, its unit and how it is printed. Both engines
accumulate them by these entries at every sample, whatever they log: the batch engine a
sample at a time (:func:`accumulate`, compiled with it), the diagram over its series
(:func:`running`); results, sweep files, statistics and plots read their names and
units here.

A metric is of the distance error :math:`|\tilde h| = |h_d - h|` (m) or of the control
effort :math:`u^2 + \omega^2` (the robot's velocities; a kinematic robot's clipped
commands), raised to ``power`` and weighted by t where ``timed``; by its ``rule`` it is
the integral of that over the run (the trapezoidal rule on the samples), its value at
the last sample, or its largest value over the samples.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

__all__ = ["Metric", "METRICS", "METRIC_NAMES", "INTEGRAL_NAMES", "METRIC_UNITS",
           "BY_NAME", "MEAN_ERROR", "INTEGRAL", "FINAL", "PEAK", "ERROR", "EFFORT",
           "NMETRIC", "sample_value", "accumulate", "running"]

#: How a metric accumulates over the samples: the integral over the run, the value at
#: its last sample, the largest value over its samples.
INTEGRAL, FINAL, PEAK = 0, 1, 2
#: What a metric is of: the distance error between h_d and h (m), the effort u² + ω².
ERROR, EFFORT = 0, 1


class Metric(NamedTuple):
    """One figure of merit of a run."""

    #: its key in ``Result.metrics``, summary.json, metrics.csv and runs.csv
    name: str
    #: how it is printed and labelled ("IAE")
    label: str
    unit: str
    #: what it is, in a line
    description: str
    #: :data:`INTEGRAL`, :data:`FINAL` or :data:`PEAK`
    rule: int
    #: :data:`ERROR` or :data:`EFFORT`
    of: int
    #: the power the quantity is raised to
    power: int = 1
    #: weighted by the time t
    timed: bool = False
    #: its numerical error is relative to its own size (else to the run's mean distance
    #: error, :data:`MEAN_ERROR` / T: a final error may end near zero)
    own_scale: bool = True
    #: its numerical error estimate takes part in choosing a run's tolerance (the batch
    #: engine's :data:`~unidyn.engine.batch.DECISIVE`)
    decisive: bool = True
    #: printed beside its unit
    note: str = ""


#: The metrics, in the order of ``Result.metrics`` and of the files' columns.
METRICS = (
    Metric("iae", "IAE", "m·s", "∫|h̃| dt, the paper's IAE (Fig. 11)", INTEGRAL, ERROR),
    Metric("ise", "ISE", "m²·s", "∫|h̃|² dt", INTEGRAL, ERROR, power=2),
    Metric("itae", "ITAE", "m·s²", "∫t |h̃| dt", INTEGRAL, ERROR, timed=True),
    Metric("itse", "ITSE", "m²·s²", "∫t |h̃|² dt", INTEGRAL, ERROR, power=2, timed=True),
    # a sum of two units, written once, simplified, as people write them
    Metric("energy", "energy", "m²/s + rad²/s",
           "∫(u² + ω²) dt, the two integrals added as a control-effort index",
           INTEGRAL, EFFORT, note="∫u² dt + ∫ω² dt"),
    Metric("error_final", "error(T)", "m", "|h̃(T)|, the distance error at the end",
           FINAL, ERROR, own_scale=False),
    Metric("peak_error", "peak error", "m", "max |h̃(t)|, the largest distance error over "
           "every sample", PEAK, ERROR, decisive=False),
)
METRIC_NAMES = tuple(m.name for m in METRICS)
#: The metrics that are integrals over the run (what a window of the run subtracts).
INTEGRAL_NAMES = tuple(m.name for m in METRICS if m.rule == INTEGRAL)
METRIC_UNITS = {m.name: m.unit for m in METRICS}
BY_NAME = {m.name: m for m in METRICS}
#: The metric whose value over the run's length is its mean distance error, the scale of
#: a metric's numerical error that is not relative to its own size.
MEAN_ERROR = "iae"
NMETRIC = len(METRICS)

# the entries as arrays, read by compiled code
_RULE = np.array([m.rule for m in METRICS])
_OF = np.array([m.of for m in METRICS])
_POWER = np.array([m.power for m in METRICS])
_TIMED = np.array([m.timed for m in METRICS])


def sample_value(j, t, error, effort):
    """What metric j accumulates at a sample at time t, s, with distance error ``error``,
    m, and effort u² + ω² ``effort`` (numbers or arrays of the samples)."""
    base = error if _OF[j] == ERROR else effort
    value = t * base if _TIMED[j] else base
    for _ in range(_POWER[j] - 1):
        value = value * base
    return value


def accumulate(k, Ts, error, effort, acc):
    """Sample k (at t = k Ts) into ``acc`` (2 :data:`NMETRIC` float64, zeros before
    sample 0): ``acc[j]`` metric j so far (an integral: the trapezoid from sample k - 1
    added), ``acc[NMETRIC + j]`` what it accumulated at sample k."""
    t1 = k * Ts
    half = 0.5 * (t1 - (k - 1) * Ts)
    for j in range(NMETRIC):
        value = sample_value(j, t1, error, effort)
        if _RULE[j] == INTEGRAL:
            if k > 0:
                acc[j] += half * (acc[NMETRIC + j] + value)
        elif _RULE[j] == PEAK and k > 0:
            acc[j] = max(acc[j], value)
        else:
            acc[j] = value
        acc[NMETRIC + j] = value


#: Samples accumulated at a time (float64), so that a long series in float32 needs no
#: float64 copy of itself.
_BLOCK = 1 << 16


def running(t, error, velocity) -> np.ndarray:
    """Each metric from t[0] to each sample, (N, :data:`NMETRIC`), float64, over the
    samples given (``error`` (N,), m; ``velocity`` (N, 2), the (u, w) whose squares add
    to the effort), as :func:`accumulate` takes them one at a time."""
    t = np.asarray(t, dtype=float)
    e, v = np.asarray(error), np.asarray(velocity)
    out = np.zeros((len(t), NMETRIC))
    if not len(t):
        return out
    with np.errstate(over="ignore", invalid="ignore"):  # beyond floats: inf (null in files)
        for i0 in range(0, max(len(t) - 1, 1), _BLOCK):  # a block at a time, sharing a sample
            i1 = min(len(t), i0 + _BLOCK + 1)
            tb, eb = t[i0:i1], e[i0:i1].astype(float)
            effort = np.sum(v[i0:i1].astype(float) ** 2, axis=-1)
            for j in range(NMETRIC):
                value = sample_value(j, tb, eb, effort)
                if _RULE[j] == INTEGRAL:
                    steps = 0.5 * (value[1:] + value[:-1]) * np.diff(tb)
                    out[i0 + 1:i1, j] = out[i0, j] + np.cumsum(steps)
                elif _RULE[j] == PEAK:
                    first = value[0] if i0 == 0 else max(out[i0, j], value[0])
                    out[i0:i1, j] = np.maximum.accumulate(np.r_[first, value[1:]])
                else:
                    out[i0:i1, j] = value
    return out
