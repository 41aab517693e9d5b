r"""Batch engine: many continuous-control scenarios integrated at once (numpy).

The right-hand side is :class:`unidyn.closedloop.ClosedLoop` (the core
functions of :mod:`unidyn.model` and :mod:`unidyn.control`, vectorised over
runs). Each noise interval [k Ts, (k+1) Ts) is integrated with ``substeps``
classical Runge-Kutta (RK4) steps, for all runs at once; the noise is constant
inside an interval, exactly as in the bdsim diagram. Results are sampled at the
same grid t = k Ts as :func:`unidyn.simulate`.

Accuracy is that of RK4 with step Ts/substeps (fourth order where the loop is
smooth; the limits' clipping and the switch-on of adaptation are kinks, where
the local error is larger). ``tests/evals/test_engines.py`` measures the
agreement with the bdsim diagram; ``benchmarks/engines.py`` the speed.
"""

from __future__ import annotations

import numpy as np

from ._validate import ValidationError
from .closedloop import ClosedLoop
from .result import Result
from .scenario import Scenario

__all__ = ["simulate_batch", "DEFAULT_SUBSTEPS"]

#: RK4 steps per sample interval Ts. With Ts = 0.1 s this is a 5 ms step.
DEFAULT_SUBSTEPS = 20


def _group(scenarios):
    groups = {}
    for i, s in enumerate(scenarios):
        groups.setdefault((s.T, s.Ts), []).append(i)
    return groups


def simulate_batch(scenarios, *, substeps: int = DEFAULT_SUBSTEPS, progress=None) -> list:
    """Simulate many scenarios at once; returns one :class:`~unidyn.Result` per scenario,
    in order.

    Scenarios are grouped by (T, Ts) and each group is integrated as one
    vectorised system. Only continuous control is supported here (sampled
    control runs through :func:`unidyn.simulate`).

    :param scenarios: a sequence of :class:`~unidyn.Scenario`
    :param substeps: RK4 steps per sample interval, integer >= 1
    :param progress: optional callable ``f(done_intervals, total_intervals)``
    """
    scs = list(scenarios)
    if not scs:
        return []
    for s in scs:
        if not isinstance(s, Scenario):
            raise ValidationError(f"scenarios must be unidyn.Scenario objects, got {type(s).__name__}")
        if s.control != "continuous":
            raise ValidationError("the batch engine runs control='continuous' only; "
                                  "use unidyn.simulate (engine 'bdsim') for sampled control")
    if isinstance(substeps, bool) or not isinstance(substeps, (int, np.integer)) or substeps < 1:
        raise ValidationError(f"substeps must be an integer >= 1, got {substeps!r}")
    results = [None] * len(scs)
    for (T, Ts), idx in _group(scs).items():
        loop = ClosedLoop([scs[i] for i in idx])
        for j, r in enumerate(_integrate(loop, int(substeps), progress)):
            results[idx[j]] = r
    return results


def _integrate(loop: ClosedLoop, m: int, progress):
    Ts, n = loop.Ts, loop.steps
    h = Ts / m
    X = loop.initial_state()
    B = loop.B
    traj = np.empty((n + 1, B, 13))
    sig_vd = np.empty((n + 1, B, 2))
    sig_vref = np.empty((n + 1, B, 2))
    sig_ref = np.empty((n + 1, B, 2))
    complete = np.ones(B, dtype=bool)
    message = [""] * B
    last = n

    def record(k, X, t):
        kk = min(k, n)
        s = loop.signals(t, X, kk)
        traj[k] = X
        sig_vd[k] = s["v_d"]
        sig_vref[k] = np.clip(s["v_ref"], -loop.vmax, loop.vmax)
        sig_ref[k] = s["h_d"]

    record(0, X, 0.0)
    for k in range(n):
        t0 = k * Ts
        for j in range(m):
            t = t0 + j * h
            k1 = loop.rhs(t, X, k)
            k2 = loop.rhs(t + h / 2, X + h / 2 * k1, k)
            k3 = loop.rhs(t + h / 2, X + h / 2 * k2, k)
            k4 = loop.rhs(t + h, X + h * k3, k)
            X = X + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
        # the sample at the end of interval k is taken with interval k+1's
        # measurement, as the diagram logs it after the clock tick
        record(k + 1, X, (k + 1) * Ts)
        if progress is not None:
            progress(k + 1, n)
        bad = ~np.all(np.isfinite(X), axis=1)
        if bad.any():
            for i in np.flatnonzero(bad & complete):
                complete[i] = False
                message[i] = (f"non-finite state at t = {(k + 1) * Ts:.6g} s "
                              f"(scenario {loop.scenarios[i].name or loop.scenarios[i].case})")
            if not complete.any():
                last = k + 1
                break
    out = []
    t = np.arange(n + 1) * Ts
    for i, sc in enumerate(loop.scenarios):
        stop = n + 1
        if not complete[i]:
            # keep the finite part of the run
            finite = np.all(np.isfinite(traj[: last + 1, i]), axis=1)
            stop = int(np.argmin(finite)) if not finite.all() else last + 1
        X_i = traj[:stop, i]
        vel = X_i[:, 3:5] if sc.case != "kinematic" else sig_vref[:stop, i]
        out.append(Result(scenario=sc, t=t[:stop], pose=X_i[:, 0:3], velocity=vel,
                          reference=sig_ref[:stop, i], v_d=sig_vd[:stop, i],
                          v_ref=sig_vref[:stop, i], theta_hat=X_i[:, 5:11], engine="batch",
                          complete=bool(complete[i]), message=message[i]))
    return out
