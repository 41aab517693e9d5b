r"""Identify theta1..theta6 of a differential-drive robot from logged data.

The dynamics of Eq. (2) are linear in the parameters, Eq. (11):

.. math::

    \begin{bmatrix} u_{ref} \\ w_{ref} \end{bmatrix} =
    \begin{bmatrix} \dot u & 0 & -w^2 & u & 0 & 0 \\
                    0 & \dot w & 0 & 0 & u w & w \end{bmatrix} \theta

so a log of the commands (u_ref, w_ref) and of the measured velocities (u, w)
gives theta by least squares. The two rows share no parameter and are solved as
two decoupled problems: row 1 gives (theta1, theta3, theta4), row 2 gives
(theta2, theta5, theta6).

Robots hold each command from its time stamp until the next one, and log at
10-50 Hz. Read as if the commands varied smoothly between samples, such a log
makes the estimate lag by half a sample: theta1 comes out too large by about
theta4 dt / 2 and theta2 by theta6 dt / 2 (+17 % and +37 % for a Pioneer at 10
Hz). So :func:`identify` by default simulates Eq. (2) over the log with the
commands held (or linear, ``commands="linear"``; optionally delayed) and fits
theta to the measured velocities (output error), starting from least squares on
the exact held-input discretisation of the linear part of Eq. (2). The
simulation is RK4 with steps of at most a tenth of the faster time constant that
never cross a change of command, compiled by numba when it is installed. Gaps
in the time stamps split a log into pieces, each with its own initial state;
several logs are fitted together. Standard errors come from the Jacobian of the
fit and the residual variance, with a Newey-West correction when the residuals
are not white, widened when the time stamps jitter (errors in the stamps bias
the fit; ``stamp_jitter=``). Time is in seconds: a log whose median step is over
a second (t in ms, us or ns) is refused with the likely unit, ``time_unit=``
reads it, and identified time constants over a minute are flagged. Every row
dropped or skipped while reading (exact duplicates, a units row, comment lines,
pieces too short) is listed in the result's warnings. The equation-error estimator (``method="equation-error"``: Eq. (11) through a
state-variable filter, see :mod:`unidyn.identification.equation_error`) gives the
first estimate for smooth commands.

The workflow, all pure numpy/scipy (nothing here imports bdsim)::

    >>> from unidyn import identification as ident
    >>> exc = ident.excitation(90.0, 0.01, robot="p3dx")      # design the commands
    >>> log = ident.simulate_log("p3dx", exc, noise_std=0.01)  # or log a real robot
    >>> fit, test = ident.split_log(log, 60.0)                # estimation / held-out
    >>> res = ident.identify(fit, commands="linear")          # simulate_log's are smooth
    >>> res.theta.theta1                      # true 0.5338     # doctest: +SKIP
    0.5354...
    >>> ident.validate(res, test).fit         # NRMSE fit, %   # doctest: +SKIP
    {'u': 81.9..., 'w': 95.0...}
    >>> print(res.summary())                  # table, warnings  # doctest: +SKIP
    >>> res.save("out/p3dx")                  # out/p3dx/theta.json  # doctest: +SKIP

``theta.json`` is read back by ``unidyn.model.robots.resolve("out/p3dx/theta.json")``.

The package is split by job: :mod:`~unidyn.identification.logs` reads and
checks logs, and :mod:`~unidyn.identification.bags` ROS recordings (``read_bag``:
commands held as the robot applied them, odometry at its stamps);
:mod:`~unidyn.identification.estimator` holds :func:`identify`, which runs
:mod:`~unidyn.identification.output_error` (from
:mod:`~unidyn.identification.first_estimate`) or
:mod:`~unidyn.identification.equation_error` (its docstring explains how the
velocity derivatives are handled), with :mod:`~unidyn.identification.intervals` and
:mod:`~unidyn.identification.checks`; :mod:`~unidyn.identification.replay` simulates
Eq. (2) over a log; :mod:`~unidyn.identification.design` designs commands and
simulates logs, and :mod:`~unidyn.identification.validation` compares a model with a
log.
"""

from __future__ import annotations

from .bags import read_bag
from .design import excitation, simulate_log
from .equation_error import SMOOTHING_METHODS
from .estimator import METHODS, identify
from .logs import (
    COLUMNS,
    TIME_UNITS,
    IdentificationWarning,
    MissingColumnsError,
    join_logs,
    load_log,
    segments,
    split_log,
)
from .replay import COMMAND_CONVENTIONS
from .results import IdentificationResult
from .validation import ValidationReport, nrmse_fit, plot_validation, validate, validation_report

__all__ = ["IdentificationResult", "ValidationReport", "MissingColumnsError",
           "IdentificationWarning", "identify",
           "load_log", "read_bag", "segments", "excitation", "simulate_log", "split_log",
           "validate", "plot_validation", "COLUMNS", "TIME_UNITS", "SMOOTHING_METHODS",
           "COMMAND_CONVENTIONS", "METHODS", "join_logs", "nrmse_fit", "validation_report"]
