"""The first estimate of theta, from which the output-error fit of
:func:`~unidyn.identification.identify` starts: least squares on the exact
held-input discretisation of the linear part of Eq. (2) (held commands), or the
filtered equation error of Eq. (11) (smooth commands), whichever gives a physical
robot first."""

from __future__ import annotations

import math

import numpy as np

from .._validate import ValidationError
from .checks import check_physical
from .equation_error import coupling, equation_error_fit
from .logs import COLUMNS


def first_estimate(D, segs, linear, delay, delay_auto, dt_med, smoothing, window, order, su, sw):
    """A first estimate of theta: (theta, what it came from, delay in samples)."""
    errors = []
    last = None
    order_ = ("filter", "arx") if linear else ("arx", "filter")
    for kind in order_:
        try:
            if kind == "arx":
                th, m = _arx(D, segs, delay, delay_auto, dt_med)
            else:
                th = equation_error_fit(D, segs, smoothing, window, order, su, sw)[0]
                m = delay / dt_med
                if delay_auto:
                    m = _arx(D, segs, 0.0, True, dt_med)[1]
            if th[0] > 0 and th[1] > 0 and th[3] > 0 and th[5] > 0 and np.all(np.isfinite(th)):
                return th, ("held-command least-squares" if kind == "arx"
                            else "filtered equation-error"), m
            errors.append(f"{kind}: non-physical {np.round(th, 4).tolist()}")
            if np.all(np.isfinite(th)):
                last = th
        except ValidationError as err:
            errors.append(f"{kind}: {err}")
    if last is not None:
        check_physical(last, np.full(6, math.nan))
    raise ValidationError("no first estimate of theta could be made from the log (" +
                          "; ".join(errors) + "). Check that the commands vary and that the "
                          "measured velocities respond to them (units, signs, columns)")


def _arx(D, segs, delay, auto, dt_med):
    """Least squares on the exact held-input discretisation of the linear part of
    Eq. (2) (see :func:`identify`), on the sample steps within 5 % of the median
    step; the coupling terms are taken constant over a step. With ``auto`` the
    whole delay in samples 0..3 with the smallest residual is used; otherwise
    ``delay`` is rounded to whole samples. Returns (theta, delay in samples)."""
    t, u_ref, w_ref, u, w = (D[k] for k in COLUMNS)
    w2, uw = coupling(u, w)      # the coupling columns of Eq. (11) of each sample
    cands = range(4) if auto else [int(round(delay / dt_med))]
    best = None
    for m in cands:
        rows = []
        for a, b in segs:
            k = np.arange(a + m, b - 1)
            if k.size:
                rows.append(k[np.abs(t[k + 1] - t[k] - dt_med) <= 0.05 * dt_med])
        k = np.concatenate(rows) if rows else np.array([], dtype=int)
        if k.size < 20:
            raise ValidationError(f"only {k.size} regular sample steps: the held-command "
                                  f"estimate needs 20")
        th = np.zeros(6)
        cost = 0.0
        for (y, x, ref, coup, sign, (ia, ic, ib)) in (
                (u, u, u_ref, w2, 1.0, (0, 2, 3)), (w, w, w_ref, uw, -1.0, (1, 4, 5))):
            X = np.stack([x[k], ref[k - m], coup[k]], axis=1)
            sc = np.linalg.norm(X, axis=0)
            if np.any(sc == 0):
                raise ValidationError("a regressor column is zero (no motion)")
            X /= sc                  # three columns: their normal equations, in place
            yk = y[k + 1]
            beta = np.linalg.solve(X.T @ X, X.T @ yk)
            r = yk - X @ beta
            cost += float(r @ r) / max(float(np.var(y[k + 1])), 1e-300)
            aa, bb, cc = beta / sc
            if not (0 < aa < 1 and bb > 0):
                th[:] = math.nan
                break
            lin = (1 - aa) / bb
            th[ib] = lin
            th[ia] = -lin * dt_med / math.log(aa)
            th[ic] = sign * cc / bb
        if np.all(np.isfinite(th)) and (best is None or cost < best[0]):
            best = (cost, th, m)
    if best is None:
        raise ValidationError("the held-command least squares gave no stable first-order "
                              "response")
    return best[1], best[2]
