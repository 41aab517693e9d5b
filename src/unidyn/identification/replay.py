"""Eq. (2) integrated over a log with its commands as the robot applied them: held
from each time stamp to the next (as firmware applies them) or linear between them,
optionally delayed. Two independent integrators restart wherever a command jumps or
kinks: :func:`simulate_held`, RK4 with a fixed step (:func:`rk4_step`), compiled where
numba is installed (the output-error fit of :func:`unidyn.identification.identify` and
:func:`unidyn.identification.validate`), and :func:`simulate_stepwise`, scipy's DOP853
on Eqs. (1)-(2) (:func:`unidyn.identification.simulate_log`, validation with limits).
"""

from __future__ import annotations

import math

import numpy as np

from ..compiled import jit
from ..model.equations import dynamics_components
from ..model.unicycle import unicycle_deriv

#: How the logged commands act between their time stamps.
COMMAND_CONVENTIONS = ("held", "linear")


# not cached itself: numba's cache index records a signature's types by their module
@jit(inline=True)
def rk4_step(f, t, x, h, args, K, y):
    """One classical Runge-Kutta (RK4) step of length h from (t, x) of
    dx/dt = f(t, x, args), x updated in place (f writes its rates into its last
    argument); K (4, n) and y (n,) are scratch."""
    n = x.shape[0]
    f(t, x, args, K[0])
    for i in range(n):
        y[i] = x[i] + 0.5 * h * K[0, i]
    f(t + 0.5 * h, y, args, K[1])
    for i in range(n):
        y[i] = x[i] + 0.5 * h * K[1, i]
    f(t + 0.5 * h, y, args, K[2])
    for i in range(n):
        y[i] = x[i] + h * K[2, i]
    f(t + h, y, args, K[3])
    c = h / 6.0
    for i in range(n):
        x[i] += c * (K[0, i] + 2.0 * K[1, i] + 2.0 * K[2, i] + K[3, i])


@jit(inline=True)
def robot_rates(t, v, args, out):
    """Eq. (2): (u', w') at velocities v under the command of one piece of a log,
    args = (theta, u_ref, w_ref, its slopes in time, the time they are read at)."""
    th, cu, cw, su, sw, t0 = args
    out[0], out[1] = dynamics_components(v[0], v[1], cu + su * (t - t0), cw + sw * (t - t0),
                                        th[0], th[1], th[2], th[3], th[4], th[5])


def _sim_segments(theta, t, u_ref, w_ref, segments, v0, delay, linear, hmax, out):
    """Eq. (2) over each segment [segments[s, 0], segments[s, 1]) of a log (rows), from
    the velocities v0[s], the logged commands held to the next stamp (or linear between
    them, ``linear``), delayed by ``delay`` s; the velocities at the stamps into out
    (N, 2). RK4 steps of at most ``hmax`` s, every instant where the delayed command jumps
    or kinks a step boundary (no step crosses one: fourth order). Before a segment's
    first stamp (plus the delay) its first command is in force."""
    th = (theta[0], theta[1], theta[2], theta[3], theta[4], theta[5])
    v = np.empty(2)
    K = np.empty((4, 2))
    y = np.empty(2)
    for s in range(segments.shape[0]):
        a = segments[s, 0]
        b = segments[s, 1]
        v[0] = v0[s, 0]
        v[1] = v0[s, 1]
        out[a, 0] = v[0]
        out[a, 1] = v[1]
        j = a
        for k in range(a, b - 1):
            tb = t[k + 1]
            eps = 1e-9 * (tb - t[k])
            cur = t[k]
            while cur < tb - eps:
                while j + 1 < b and t[j + 1] + delay <= cur + eps:
                    j += 1
                nxt = tb
                if j + 1 < b and t[j + 1] + delay < tb - eps:
                    nxt = t[j + 1] + delay
                if cur + eps < t[j] + delay < nxt:     # a linear ramp starts (first command)
                    nxt = t[j] + delay
                n = max(1, int(math.ceil((nxt - cur) / hmax - 1e-6)))
                h = (nxt - cur) / n
                # the command over this piece: constant (held) or a line in time (linear)
                su = 0.0
                sw = 0.0
                if linear and j + 1 < b and cur + eps >= t[j] + delay:
                    su = (u_ref[j + 1] - u_ref[j]) / (t[j + 1] - t[j])
                    sw = (w_ref[j + 1] - w_ref[j]) / (t[j + 1] - t[j])
                args = (th, u_ref[j], w_ref[j], su, sw, t[j] + delay)
                for i in range(n):
                    rk4_step(robot_rates, cur + i * h, v, h, args, K, y)
                cur = nxt
            out[k + 1, 0] = v[0]
            out[k + 1, 1] = v[1]


# compiled where numba is installed (the ``fast`` extra); without it the same code runs
# in Python
_sim_compiled = jit(_sim_segments, entry="the log simulator of identification")


def step_length(theta, dt) -> float:
    """The longest RK4 step: a tenth of the faster time constant (local error about
    (h / tau)^5 / 120 = 1e-7), within [dt / 20, dt] for the median sample interval dt (a
    time constant under dt / 20 settles within a sample, unresolved by the log; RK4 is
    stable to h / tau = 2.78, and exact in the steady state of a held command)."""
    th = np.asarray(theta, dtype=float)
    tau = min(th[0] / th[3], th[1] / th[5]) if th[3] > 0 and th[5] > 0 else th[0]
    if not tau > 0 or not math.isfinite(tau):
        return dt / 4
    return float(min(dt, max(tau / 10.0, dt / 20.0)))


def simulate_held(theta, t, u_ref, w_ref, segs, v0, delay=0.0, linear=False, hmax=None,
                  out=None):
    """Velocities (N, 2) of Eq. (2) over the pieces ``segs`` [(start, stop)] of a log,
    each from its [u, w] in ``v0``, the commands held (or ``linear``), delayed by
    ``delay`` s; RK4 steps of at most ``hmax`` s (:func:`step_length`; see
    :func:`_sim_segments`). Rows outside the pieces are left (NaN in a new ``out``)."""
    theta = np.ascontiguousarray(theta, dtype=float)
    segments = np.array(segs, dtype=np.int64).reshape(-1, 2)
    if hmax is None:
        steps = [np.diff(t[a:b]) for a, b in segs if b - a > 1]
        hmax = step_length(theta, float(np.median(np.concatenate(steps))) if steps else 1.0)
    if out is None:
        out = np.full((t.size, 2), np.nan)
    _sim_compiled(theta, t, u_ref, w_ref, segments,
                  np.ascontiguousarray(v0, dtype=float).reshape(-1, 2), float(delay),
                  bool(linear), float(hmax), out)
    return out


def simulate_stepwise(theta, t, u_ref, w_ref, x0, limits, linear, delay):
    """Eqs. (1)-(2) with the commands held (or linear) between time stamps and
    delayed by ``delay`` s: scipy's DOP853 (rtol 1e-10) restarted at every
    instant where the command jumps or kinks, so no step crosses one."""
    from scipy.integrate import ode
    ref = np.stack([u_ref, w_ref], axis=1)
    n = t.size
    state = {"j": 0}

    def command(tt):
        j = state["j"]
        tau = tt - delay
        if not linear or tau <= t[0] or j + 1 >= n:
            return ref[j]
        f = min(max((tau - t[j]) / (t[j + 1] - t[j]), 0.0), 1.0)
        return ref[j] + f * (ref[j + 1] - ref[j])

    r = ode(lambda tt, x: unicycle_deriv(x, command(tt), theta, 0.0, limits))
    r.set_integrator("dop853", rtol=1e-10, atol=1e-12, nsteps=100000)
    brk = np.union1d(t, t[(t + delay > t[0]) & (t + delay < t[-1])] + delay)
    # a delayed time stamp that meets another one to rounding is the same instant
    brk = brk[np.concatenate([[True], np.diff(brk) > 1e-9 * float(np.median(np.diff(t)))])]
    brk[-1] = t[-1]
    X = np.empty((n, 5))
    X[0] = x0
    x = np.asarray(x0, dtype=float)
    k_out = 1
    for a, b in zip(brk[:-1], brk[1:]):
        # the command in force on (a, b): the last one stamped at or before a - delay
        state["j"] = max(int(np.searchsorted(t, a - delay + 1e-12 * (b - a), "right")) - 1, 0)
        r.set_initial_value(x, a)
        x = r.integrate(b)
        if not r.successful():  # pragma: no cover - the model is smooth and stable
            raise RuntimeError(f"simulation failed at t = {a:g} s")
        while k_out < n and t[k_out] <= b + 1e-12 * (b - a):
            X[k_out] = x
            k_out += 1
    return X
