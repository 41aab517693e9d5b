"""What a run logs: the columns of a sample (:data:`LOG_COLUMNS`, by name
:data:`LOG`), the series of a result they make (:data:`LOG_SERIES`), and which samples
are kept (:func:`logged`: every ``log_every``-th, and the one where a run stopped),
shared by the engines and their results.
"""

from __future__ import annotations

from collections import namedtuple

import numpy as np

from .equations import STATE, S

__all__ = ["LOG_COLUMNS", "LOG", "NLOG", "LOGGED_STATES", "LOG_SERIES", "log_layout",
           "logged", "log_row", "log_length"]

#: The states a sample logs as they are: pose, velocity (a kinematic robot's: its
#: clipped command) and theta_hat (not the derivative filter's).
LOGGED_STATES = S.theta_hat6 + 1
#: The log's columns: those states, then h_d, v_d and v_ref (after the speed limits).
LOG_COLUMNS = STATE[:LOGGED_STATES] + ("x_d", "y_d", "u_d", "w_d", "u_ref", "w_ref")
#: Each column's index by its name (``LOG.x_d``).
LOG = namedtuple("LogColumn", LOG_COLUMNS)(*range(len(LOG_COLUMNS)))
NLOG = len(LOG_COLUMNS)

#: Where each series of a :class:`~unidyn.Result` lies in a row of the full log.
LOG_SERIES = {"pose": slice(LOG.x, LOG.psi + 1), "velocity": slice(LOG.u, LOG.w + 1),
              "theta_hat": slice(LOG.theta_hat1, LOG.theta_hat6 + 1),
              "reference": slice(LOG.x_d, LOG.y_d + 1), "v_d": slice(LOG.u_d, LOG.w_d + 1),
              "v_ref": slice(LOG.u_ref, LOG.w_ref + 1)}


def log_layout(series):
    """(the columns of :data:`LOG_COLUMNS` kept for the named series, as an index array;
    where each kept series lies in a row)."""
    keep, where = [], {}
    for k, sl in LOG_SERIES.items():  # in the order of the columns
        if k in series:
            columns = range(NLOG)[sl]
            where[k] = slice(len(keep), len(keep) + len(columns))
            keep += columns
    return np.array(keep, dtype=np.int64), where


def logged(k, every, stopped):
    """Whether sample k (a number or an array) is logged: every ``every``-th sample, and
    the one where a run stopped (``stopped``: sample k is that one)."""
    return (k % every == 0) | stopped


def log_row(k, every):
    """The row of the log that sample k takes where it is logged."""
    return k // every + (k % every != 0)


def log_length(last, every, stopped):
    """The rows of the log that samples 0..last take (``stopped``: the run stopped at
    ``last``)."""
    return log_row(last, every) + logged(last, every, stopped)
