r"""Batch engine: many continuous-control scenarios integrated at once (numpy).

The right-hand side is :class:`unidyn.closedloop.ClosedLoop` (the core
functions of :mod:`unidyn.model` and :mod:`unidyn.control`, vectorised over
runs). Each noise interval [k Ts, (k+1) Ts) is integrated with ``substeps``
classical Runge-Kutta (RK4) steps, for all runs at once; the noise is constant
inside an interval, exactly as in the bdsim diagram. Results are sampled at the
same grid t = k Ts as :func:`unidyn.simulate`.

The speed limits are enforced exactly: a step that would end beyond one ends on
it (the diagram's adaptive solver holds them to its tolerance). Accuracy is that
of RK4 with step Ts/substeps: fourth order where the loop is
smooth. Two events are not smooth: the limits' clipping (a kink in the
right-hand side) and switching adaptation on at ``adapt_from`` (a jump), which a
fixed step integrates with an error proportional to the step (about 5e-6 m at
substeps=100 for the paper's case 4; bdsim's adaptive solver resolves it). ``tests/evals/test_engines.py`` measures the
agreement with the bdsim diagram; ``benchmarks/engines.py`` the speed.
"""

from __future__ import annotations

import numpy as np

from ._validate import ValidationError
from .closedloop import ClosedLoop
from .result import Result
from .scenario import Scenario

__all__ = ["simulate_batch", "DEFAULT_SUBSTEPS"]

#: RK4 steps per sample interval Ts. With Ts = 0.1 s this is a 10 ms step; on the
#: Fig. 11 grid the IAE is then within about 1e-4 (relative) of the bdsim diagram
#: (benchmarks/engines.py prints the measured accuracy).
DEFAULT_SUBSTEPS = 10


def _group(scenarios):
    groups = {}
    for i, s in enumerate(scenarios):
        groups.setdefault((s.T, s.Ts), []).append(i)
    return groups


BACKENDS = ("auto", "numba", "numpy")

#: RK4 is stable for real eigenvalues lambda with |lambda h| < 2.78, and accurate
#: to about 1e-5 per unit time at |lambda h| = 0.5; the step is kept below
#: STEP_RATE_LIMIT / (fastest rate of the loop).
STEP_RATE_LIMIT = 0.5


def fastest_rate(sc: Scenario) -> tuple[float, str]:
    """The fastest decay rate (1/s) in the loop of ``sc`` and what it comes from.

    The candidates are the robot's velocity loops (theta4/theta1, theta6/theta2,
    Eq. 2, with the speed-dependent term of F at the speed limit), the designed
    error dynamics of the kinematic controller (kx, ky) and of the compensator
    (ku, kw), the derivative filter (1/tau) and, conservatively, the update law
    (gamma_i times the square of a typical regressor entry)."""
    th = sc.robot.theta
    vmax = sc.limits.speed_max if np.isfinite(sc.limits.speed_max) else 1.0
    f22 = th[5] + abs(th[4] - th[2]) * vmax
    rates = {f"robot time constant theta1/theta4 = {th[0] / th[3]:.3g} s": th[3] / th[0],
             f"robot time constant theta2/theta6 = {th[1] / f22:.3g} s": f22 / th[1],
             f"kinematic gains kx, ky = {sc.kx:g}, {sc.ky:g} 1/s": max(sc.kx, sc.ky)}
    if sc.case in ("compensated", "adaptive"):
        # with exact compensation the velocity error decays at ku, kw plus H^-1 F
        rates[f"compensator gains ku, kw = {sc.ku:g}, {sc.kw:g} 1/s"] = max(sc.ku, sc.kw)
        if sc.derivative == "filter":
            rates[f"derivative filter tau = {sc.tau:g} s"] = 1.0 / sc.tau
    what = max(rates, key=rates.get)
    return rates[what], what


#: The most RK4 steps per sample interval the engine takes before it refuses.
MAX_SUBSTEPS = 10_000


def stable_substeps(sc: Scenario, substeps: int) -> int:
    """``substeps``, raised where needed so that the RK4 step Ts/substeps stays
    below STEP_RATE_LIMIT / :func:`fastest_rate` (a fast robot such as the
    Khepera III needs a shorter step than the Pioneer, and so does a high gain).

    :raises ValidationError: if that needs more than :data:`MAX_SUBSTEPS` steps per
        sample; the message names the time constant responsible
    """
    rate, what = fastest_rate(sc)
    need = sc.Ts * rate / STEP_RATE_LIMIT
    if not np.isfinite(need) or need > MAX_SUBSTEPS:
        raise ValidationError(
            f"{sc.name or sc.case}: the batch engine would need more than {MAX_SUBSTEPS} RK4 "
            f"steps per {sc.Ts:g} s sample for the fastest rate of this loop ({what}); use a "
            f"shorter Ts, or unidyn.simulate (the bdsim diagram, adaptive step)")
    return max(int(substeps), int(np.ceil(need - 1e-9)))


def simulate_batch(scenarios, *, substeps: int = DEFAULT_SUBSTEPS, backend: str = "auto",
                   progress=None) -> list:
    """Simulate many scenarios at once; returns one :class:`~unidyn.Result` per scenario,
    in order.

    Scenarios are grouped by (T, Ts) and each group is integrated as one
    vectorised system. Only continuous control is supported here (sampled
    control runs through :func:`unidyn.simulate`).

    :param scenarios: a sequence of :class:`~unidyn.Scenario`
    :param substeps: RK4 steps per sample interval, integer >= 1; raised
        automatically where a run's fastest time constant needs a shorter step for
        RK4 to be stable (:func:`stable_substeps`; the value used is ``Result.substeps``)
    :param backend: ``"numba"`` (compiled kernel, :mod:`unidyn._kernels`; needs numba and
        the built-in trajectories), ``"numpy"`` (vectorised numpy), or ``"auto"`` (numba
        when it can be used, else numpy). Both integrate the same equations with the
        same steps and agree to rounding.
    :param progress: optional callable ``f(done_intervals, total_intervals)`` (numpy backend)
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
    if (isinstance(substeps, bool) or not isinstance(substeps, (int, np.integer))
            or not 1 <= substeps <= MAX_SUBSTEPS):
        raise ValidationError(f"substeps must be an integer in 1..{MAX_SUBSTEPS}, got {substeps!r}")
    if backend not in BACKENDS:
        raise ValidationError(f"backend must be one of {', '.join(BACKENDS)}; got {backend!r}")
    from . import _kernels
    compilable = all(getattr(s.trajectory, "kind", None) in _kernels.TRAJ_CODES for s in scs)
    if backend == "numba" and not _kernels.AVAILABLE:
        raise ValidationError("backend='numba' needs numba (pip install unidyn[fast])")
    if backend == "numba" and not compilable:
        raise ValidationError("backend='numba' supports the figure_eight, circle and line "
                              "trajectories only; use backend='numpy' for a FunctionTrajectory")
    use_numba = backend == "numba" or (backend == "auto" and _kernels.AVAILABLE and compilable)
    results = [None] * len(scs)
    for (T, Ts), idx in _group(scs).items():
        m = np.array([stable_substeps(scs[i], int(substeps)) for i in idx])
        loop = ClosedLoop([scs[i] for i in idx])
        if use_numba:  # each run with its own step
            group = _integrate_numba(loop, m, progress)
        else:  # one vectorised step for the group: the smallest any run needs
            m[:] = m.max()
            group = _integrate(loop, int(m[0]), progress)
        for j, r in enumerate(group):
            r.substeps = int(m[j])
            results[idx[j]] = r
    return results


def _integrate_numba(loop: ClosedLoop, m, progress):
    from . import _kernels
    n, B = loop.steps, loop.B
    Xs = np.full((B, n + 1, 13), np.nan)
    SIG = np.full((B, n + 1, 8), np.nan)
    stops = np.zeros(B, dtype=np.int64)
    _kernels.run_batch(loop.initial_state(), _kernels.pack(loop), loop.pos_noise, loop.vel_noise,
                       float(loop.Ts), int(n), np.asarray(m, dtype=np.int64), Xs, SIG, stops)
    if progress is not None:
        progress(n, n)
    return _results(loop, Xs, SIG, stops, "numba (compiled)")


def _integrate(loop: ClosedLoop, m: int, progress):
    """The numpy backend: fills the same arrays as the compiled kernel."""
    Ts, n, B = loop.Ts, loop.steps, loop.B
    h = Ts / m
    X = loop.initial_state()
    Xs = np.full((B, n + 1, 13), np.nan)
    SIG = np.full((B, n + 1, 8), np.nan)
    stops = np.full(B, n, dtype=np.int64)

    def record(k, X, t, noise_k):
        s = loop.signals(t, X, noise_k)
        Xs[:, k] = X
        SIG[:, k] = np.concatenate([s["h_d"], s["v_d"], s["v_d_dot"], s["v_ref"]], axis=1)

    record(0, X, 0.0, 0)
    for k in range(n):
        t0 = k * Ts
        for j in range(m):
            t = t0 + j * h
            k1 = loop.rhs(t, X, k)
            k2 = loop.rhs(t + h / 2, X + h / 2 * k1, k)
            k3 = loop.rhs(t + h / 2, X + h / 2 * k2, k)
            k4 = loop.rhs(t + h, X + h * k3, k)
            X = X + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
            # the speed limits are hard: a step that crosses one ends on it
            X[:, 3:5] = np.clip(X[:, 3:5], -loop.vmax, loop.vmax)
        # the sample at the end of interval k is logged with interval k's
        # measurement, as the diagram logs it just before the clock tick
        record(k + 1, X, (k + 1) * Ts, k)
        if progress is not None:
            progress(k + 1, n)
        if not np.isfinite(Xs[:, : k + 2]).all(axis=(1, 2)).any():
            stops[:] = k + 1  # every run has failed: stop integrating
            break
    return _results(loop, Xs, SIG, stops, "numpy")


def _results(loop: ClosedLoop, Xs, SIG, stops, backend: str) -> list:
    """One Result per run from the sampled states Xs (B, n+1, 13) and signals SIG
    (B, n+1, 8: h_d, v_d, v_d', v_ref); stops[i] is the last sample written. A run
    with a non-finite state keeps its finite part and is marked incomplete."""
    n = loop.steps
    t = np.arange(n + 1) * loop.Ts
    out = []
    for i, sc in enumerate(loop.scenarios):
        X_i = Xs[i, : int(stops[i]) + 1]
        finite = np.all(np.isfinite(X_i), axis=1)
        complete = int(stops[i]) == n and bool(finite.all())
        stop = len(X_i) if finite.all() else int(np.argmin(finite))
        message = "" if complete else (f"non-finite state at t = {stop * loop.Ts:.6g} s "
                                       f"(scenario {sc.name or sc.case})")
        X_i = X_i[:stop]
        S = SIG[i, :stop]
        v_ref = np.clip(S[:, 6:8], -loop.vmax[i], loop.vmax[i])
        vel = X_i[:, 3:5] if sc.case != "kinematic" else v_ref
        out.append(Result(scenario=sc, t=t[:stop], pose=X_i[:, 0:3], velocity=vel,
                          reference=S[:, 0:2], v_d=S[:, 2:4], v_ref=v_ref,
                          theta_hat=X_i[:, 5:11], engine="batch", complete=complete,
                          message=message, backend=backend))
    return out
