r"""The IAE over a window of a run: Section 5's performance index
:math:`\mathrm{IAE} = \int |E(t)|\,dt`, :math:`E = \|\tilde h\|` the distance error,
taken between two times, as the paper's experiment reports it (15-30 s and 45-60 s)."""

from __future__ import annotations

import numpy as np

from .._validate import ValidationError

__all__ = ["window_iae"]


def window_iae(result, t0: float, t1: float) -> float:
    r""":math:`\int_{t_0}^{t_1} |\tilde h|\,dt`, m·s, by the trapezoidal rule on the
    samples of ``result`` (anything with ``t`` and ``error``) in [t0, t1], whose ends
    must fall on samples (within 1e-6 s).

    :raises ValidationError: the samples do not cover [t0, t1]
    """
    t = np.asarray(result.t, dtype=float)
    m = (t >= t0 - 1e-9) & (t <= t1 + 1e-9)
    if m.sum() < 2 or abs(t[m][0] - t0) > 1e-6 or abs(t[m][-1] - t1) > 1e-6:
        span = f"{t[0]:g}-{t[-1]:g} s" if len(t) else "no samples"
        raise ValidationError(f"the window {t0:g}-{t1:g} s is not covered by the result's "
                              f"samples ({span})")
    from scipy.integrate import trapezoid  # numpy's own needs numpy 2
    return float(trapezoid(np.asarray(result.error, dtype=float)[m], t[m]))
