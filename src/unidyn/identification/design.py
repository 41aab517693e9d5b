"""Designing commands that excite all six parameters of Eq. (11), and
simulating a robot's log from them (Eqs. (1)-(2)).
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np

from .._validate import ValidationError, choice, integer, nonnegative, positive, real, vector
from ..model import robots
from ..model.unicycle import NO_LIMITS, PAPER_LIMITS, Limits, unicycle_deriv
from .logs import load_log
from .replay import COMMAND_CONVENTIONS, simulate_stepwise


def excitation(T: float, dt: float, robot=None, limits: Limits = PAPER_LIMITS,
               kind: str = "multisine", seed: int = 0, amplitude: float = 0.8,
               u_mean: float | None = None, f_min: float | None = None,
               f_max: float | None = None, n_freq: int = 24,
               crest_iterations: int = 50) -> dict:
    r"""Commands that excite all six parameters, within a robot's limits.

    ``"multisine"``: for each command a sum of ``n_freq`` sinusoids at harmonics
    of 1/T, log-spaced between ``f_min`` and ``f_max``. u_ref oscillates around a
    forward speed ``u_mean`` and w_ref around zero, with independent phases, so
    the robot turns both ways at varying forward speed: the w^2 and u w columns
    of Eq. (11), which carry theta3 and theta5, are excited ("turning at
    speed"). The amplitudes are proportional to 1 / min(f, f_c): equal
    acceleration per component below a corner f_c and equal speed above it, with
    f_c chosen (per command) so that the speed and the rate limits below are
    reached together; low frequencies then carry the speed range (theta3, theta4,
    theta5, theta6) and high ones the accelerations (theta1, theta2). The phases
    start seeded-random and get ``crest_iterations`` rounds of crest-factor
    reduction (clip and re-project), which lowers the peak for a given rms. The
    commands fade in from 0 (raised cosine over a few seconds): the robot starts
    at rest.

    ``"prbs"``: maximum-length pseudo-random binary sequences (seeded start
    states) switching u_ref between u_mean +/- a and w_ref between +/- b, with
    ramps between the levels at the rate limit below instead of steps, and a
    clock period of 1 / (2 f_max) or 1.5 times the ramp's duration, whichever is
    longer (each level is then held for a while).

    Scaling: |u_ref| <= amplitude speed_max, |w_ref| <= amplitude steer_max, and
    the command rates |u_ref'| <= amplitude accel_max theta4 and |w_ref'| <=
    amplitude angular_accel_max theta6 (theta4 = theta6 = 1 without a robot).
    For the linear part of Eq. (2), u' is u_ref'/theta4 seen through a
    first-order lag, so the response's accelerations then stay within the
    limits too; the couplings theta3 w^2 and theta5 u w can add a little.

    :param T: duration, s, > 0
    :param dt: sample interval, s, > 0 and <= T / 20
    :param robot: optional robot (name, :class:`RobotParameters` or six numbers);
        it sets theta4 and theta6 above and the default f_max
    :param limits: :class:`unidyn.model.unicycle.Limits` to respect (speed limits must be
        finite); default the paper's ``PAPER_LIMITS``
    :param kind: ``"multisine"`` or ``"prbs"``
    :param seed: integer seed of the phases / sequences, >= 0
    :param amplitude: fraction of each limit to use, in (0, 1]
    :param u_mean: mean forward speed command, m/s; default 0.45 amplitude speed_max
    :param f_min: lowest frequency, Hz; default 2 / T
    :param f_max: highest frequency, Hz; default 1 Hz or, with a robot whose
        slower velocity loop is faster than that, its corner frequency
        1 / (2 pi max(theta1/theta4, theta2/theta6)); at most 1 / (10 dt). Within
        a speed range, higher frequencies mean larger accelerations, which is
        what identifies theta1 and theta2
    :param n_freq: number of sinusoids per command (multisine), >= 1
    :param crest_iterations: rounds of crest-factor reduction (multisine), >= 0
    :return: dict with t (s), u_ref (m/s), w_ref (rad/s) and the settings used
    """
    T = positive("T", T)
    dt = positive("dt", dt)
    if dt > T / 20:
        raise ValidationError(f"dt must be <= T / 20 ({T / 20:g} s), got {dt!r}")
    kind = choice("kind", kind, ("multisine", "prbs"))
    seed = integer("seed", seed, 0)
    amplitude = real("amplitude", amplitude, low=0.0, high=1.0, low_open=True)
    if isinstance(limits, Mapping):
        limits = Limits(**limits)
    if not isinstance(limits, Limits):
        raise ValidationError(f"limits must be a unidyn.model.unicycle.Limits, got {limits!r}")
    for k in ("speed_max", "steer_max"):
        if not math.isfinite(getattr(limits, k)):
            raise ValidationError(f"limits.{k} must be finite to size the excitation, got inf")
    th4 = th6 = 1.0
    f_default = 1.0
    if robot is not None:
        rp = robots.resolve(robot, "robot")
        th4, th6 = rp.theta4, rp.theta6
        tau = max(rp.theta1 / rp.theta4, rp.theta2 / rp.theta6)
        f_default = max(f_default, 1.0 / (2 * math.pi * tau))
    f_min = 2.0 / T if f_min is None else positive("f_min", f_min)
    f_max = min(f_default, 0.1 / dt) if f_max is None else positive("f_max", f_max)
    if f_max <= f_min:
        raise ValidationError(f"f_max must be > f_min ({f_min:g} Hz), got {f_max!r}")
    if f_max > 0.5 / dt:
        raise ValidationError(f"f_max must be <= the Nyquist frequency 1/(2 dt) = "
                              f"{0.5 / dt:g} Hz, got {f_max!r}")
    vmax = amplitude * limits.speed_max
    wmax = amplitude * limits.steer_max
    u_mean = 0.45 * vmax if u_mean is None else real("u_mean", u_mean, low=-vmax, high=vmax,
                                                     low_open=True, high_open=True)
    amax = amplitude * limits.accel_max * th4
    awmax = amplitude * limits.angular_accel_max * th6
    n = int(round(T / dt)) + 1
    t = np.arange(n) * dt
    rng = np.random.default_rng(seed)
    if kind == "multisine":
        n_freq = integer("n_freq", n_freq, 1)
        crest_iterations = integer("crest_iterations", crest_iterations, 0)
        k_lo = max(1, int(math.ceil(f_min * T - 1e-9)))
        k_hi = max(k_lo, int(math.floor(f_max * T + 1e-9)))
        ks = np.unique(np.round(np.geomspace(k_lo, k_hi, int(n_freq))).astype(int))
        f = ks / T
        shapes, corners = [], []
        for osc, rate in ((vmax - abs(u_mean), amax), (wmax, awmax)):
            ph0 = rng.uniform(0.0, 2 * math.pi, f.size)
            fc = _corner(ks, T, osc, rate)
            a = 1.0 / np.minimum(f, fc)
            ph = _low_crest_phases(ks, a * 2 * math.pi * f, ph0, crest_iterations)
            arg = 2 * math.pi * f[:, None] * t[None, :] + ph[:, None]
            s = (a[:, None] * np.sin(arg)).sum(axis=0)
            ds = (a[:, None] * 2 * math.pi * f[:, None] * np.cos(arg)).sum(axis=0)
            shapes.append((s, ds))
            corners.append(fc)
        (su, dsu), (sw, dsw) = shapes
        # start from rest: raised-cosine fade-in, long enough that the fade alone
        # uses at most half of the rate limit
        t_fade = min(T / 4, max(1.0, math.pi * abs(u_mean) / amax
                                if math.isfinite(amax) else 0.0))
        ph = np.clip(t / t_fade, 0.0, 1.0)
        e = 0.5 - 0.5 * np.cos(math.pi * ph)
        de = np.where(ph < 1.0, 0.5 * math.pi / t_fade * np.sin(math.pi * ph), 0.0)
        cu = _scale(u_mean, su, dsu, e, de, vmax - abs(u_mean), amax)
        cw = _scale(0.0, sw, dsw, e, de, wmax, awmax)
        u_ref = e * (u_mean + cu * su)
        w_ref = e * cw * sw
        settings = {"frequencies": f, "corner_frequencies": tuple(corners)}
    else:
        from scipy.signal import max_len_seq
        refs, clocks = [], []
        for mean, level, rate in ((u_mean, vmax - abs(u_mean), amax), (0.0, wmax, awmax)):
            # hold each level at least half as long as the ramp to it takes
            ramp = 2 * level / rate if math.isfinite(rate) else 0.0
            clock = max(1.0 / (2.0 * f_max), 1.5 * ramp)
            n_bits = max(4, int(math.ceil(math.log2(T / clock + 1))))
            state = rng.integers(0, 2, n_bits)
            if not state.any():
                state[0] = 1
            seq = max_len_seq(n_bits, state=state)[0].astype(float) * 2 - 1
            k = (t / clock).astype(int) % seq.size
            step = rate * dt if math.isfinite(rate) else math.inf
            refs.append(_rate_limit(mean + level * seq[k], step))
            clocks.append(clock)
        u_ref, w_ref = refs
        settings = {"clocks": tuple(clocks)}
    return {"t": t, "u_ref": u_ref, "w_ref": w_ref, "kind": kind, "seed": int(seed),
            **settings}


def _corner(ks, T, osc_max, rate_max) -> float:
    """Corner frequency f_c of the amplitude profile 1 / min(f, f_c) at which the
    speed and the rate limits bind together (bisection; zero phases as a proxy)."""
    f = ks / T
    if not math.isfinite(rate_max):
        return float(f[-1])
    m = max(256, 8 * int(ks.max()) + 8)
    tau = np.arange(m) / m
    ph = np.linspace(0.0, 2 * math.pi, f.size, endpoint=False) * np.arange(f.size) / 2
    arg = 2 * math.pi * ks[:, None] * tau + ph[:, None]
    sin, cos = np.sin(arg), np.cos(arg)

    def ratio(fc):   # > 1: the rate limit binds first
        a = 1.0 / np.minimum(f, fc)
        peak_s = np.max(np.abs((a[:, None] * sin).sum(axis=0)))
        peak_ds = np.max(np.abs((a[:, None] * 2 * math.pi * f[:, None] * cos).sum(axis=0)))
        return osc_max * peak_ds / (rate_max * peak_s)

    lo, hi = math.log(f[0]), math.log(f[-1])
    if ratio(f[-1]) >= 1.0:
        return float(f[-1])
    if ratio(f[0]) <= 1.0:
        return float(f[0])
    for _ in range(30):
        mid = 0.5 * (lo + hi)
        if ratio(math.exp(mid)) > 1.0:
            lo = mid
        else:
            hi = mid
    return float(math.exp(0.5 * (lo + hi)))


def _low_crest_phases(ks, amp, phases, iterations):
    """Lower the peak of x(tau) = sum amp cos(2 pi k tau / P + phase) over one period
    by clipping and re-projecting onto the harmonics ks (Van der Ouderaa, Schoukens
    and Renneboog, IEEE Trans. Instrum. Meas. 37(2), 1988); amplitudes are kept."""
    m = max(256, 8 * int(ks.max()) + 8)
    tau = np.arange(m) / m
    best, best_peak = phases, math.inf
    for _ in range(int(iterations) + 1):
        x = (amp[:, None] * np.cos(2 * math.pi * ks[:, None] * tau + phases[:, None])).sum(axis=0)
        peak = float(np.max(np.abs(x)))
        if peak < best_peak:
            best, best_peak = phases, peak
        clip = 0.85 * peak
        X = np.fft.rfft(np.clip(x, -clip, clip))
        phases = np.angle(X[ks])
    return best


def _scale(mean, s, ds, e, de, osc_max, rate_max) -> float:
    """The largest c <= the speed bound for which e (mean + c s) keeps its rate
    within rate_max (a few shrinking steps; the fade is the only coupling)."""
    c = osc_max / np.max(np.abs(s))
    if math.isfinite(rate_max):
        c = min(c, rate_max / np.max(np.abs(ds)))
        for _ in range(40):
            rate = np.max(np.abs(de * (mean + c * s) + e * c * ds))
            if rate <= rate_max * (1 + 1e-9):
                break
            c *= 0.95
    return float(c)


def _rate_limit(target: np.ndarray, step: float) -> np.ndarray:
    """Follow ``target`` from rest (0) moving at most ``step`` per sample."""
    out = np.empty_like(target)
    prev = 0.0
    for k in range(target.size):
        prev = prev + min(max(target[k] - prev, -step), step)
        out[k] = prev
    return out


def _simulate(theta, t, u_ref, w_ref, x0, limits):
    from scipy.integrate import solve_ivp
    from scipy.interpolate import CubicSpline
    cmd = CubicSpline(t, np.stack([u_ref, w_ref], axis=1))

    def rhs(tt, x):
        return unicycle_deriv(x, cmd(tt), theta, 0.0, limits)

    # LSODA switches to BDF where the fast velocity loops (theta1, theta2 of a few
    # tens of ms) make the problem stiff; at these tolerances it matches DOP853 at
    # rtol 1e-12 to about 1e-9 on every preset, several times faster.
    sol = solve_ivp(rhs, (t[0], t[-1]), x0, method="LSODA", t_eval=t, rtol=1e-9, atol=1e-11)
    if not sol.success:  # pragma: no cover - the model is smooth and stable
        raise RuntimeError(f"simulation failed: {sol.message}")
    return sol.y.T


def simulate_log(robot, excitation, noise_std: float = 0.0, seed: int = 0, x0=None,
                 limits: Limits = NO_LIMITS, commands: str = "spline",
                 delay: float = 0.0) -> dict:
    r"""Simulate the dynamic model, Eqs. (1)-(2) with a = 0, and log it like a robot.

    The commands are interpolated between their samples by a cubic spline through
    them (smooth, and equal to the logged command at every time stamp), and the
    model :func:`unidyn.model.unicycle.unicycle_deriv` is integrated by
    ``scipy.integrate.solve_ivp`` (LSODA, rtol 1e-9, atol 1e-11). Seeded white
    Gaussian noise of std ``noise_std`` is then added to the logged u and w
    (m/s and rad/s alike); the commands and the pose are logged without noise.

    :param robot: robot name, :class:`RobotParameters` or six numbers
    :param excitation: dict (or log) with t, u_ref, w_ref, e.g. from :func:`excitation`;
        t may be irregular
    :param noise_std: std of the velocity measurement noise, >= 0
    :param seed: integer seed of the noise, >= 0
    :param x0: initial state [x, y, psi, u, w]; default at rest at the origin
    :param limits: limits applied inside the model (default none)
    :param commands: how the robot applies the commands between their time
        stamps: ``"spline"`` (default: a cubic spline through them, smooth),
        ``"held"`` (each held until the next, as robot firmware does: the
        integration restarts at every sample, DOP853, rtol 1e-10) or
        ``"linear"`` (linear between samples, same integration)
    :param delay: with ``"held"`` or ``"linear"``, the command stamped t acts
        from t + delay, s, >= 0
    :return: dict with t, u_ref, w_ref, u, w (measured), and the noise-free
        u_true, w_true, x, y, psi
    """
    commands = choice("commands", commands, ("spline",) + COMMAND_CONVENTIONS)
    delay = nonnegative("delay", delay)
    if delay and commands == "spline":
        raise ValidationError("delay needs commands='held' or 'linear'")
    rp = robots.resolve(robot, "robot")
    noise_std = nonnegative("noise_std", noise_std)
    seed = integer("seed", seed, 0)
    if not isinstance(limits, Limits):
        raise ValidationError(f"limits must be a unidyn.model.unicycle.Limits, got {limits!r}")
    need = ("t", "u_ref", "w_ref")
    if not isinstance(excitation, Mapping) or any(k not in excitation for k in need):
        have = list(excitation) if isinstance(excitation, Mapping) else type(excitation).__name__
        raise ValidationError(f"excitation must be a mapping with t, u_ref and w_ref (as from "
                              f"excitation()), got {have}")
    n = int(np.size(excitation["t"]))
    try:
        d = load_log({**{k: excitation[k] for k in need}, "u": np.zeros(n), "w": np.zeros(n)},
                     time_unit="s")          # designed commands: t is in seconds
    except ValidationError as err:
        raise ValidationError(f"excitation: {err}") from None
    x0 = np.zeros(5) if x0 is None else vector("x0", x0, 5)
    if commands == "spline":
        X = _simulate(rp.theta, d["t"], d["u_ref"], d["w_ref"], x0, limits)
    else:
        X = simulate_stepwise(rp.theta, d["t"], d["u_ref"], d["w_ref"], x0, limits,
                               commands == "linear", delay)
    rng = np.random.default_rng(seed)
    noise = noise_std * rng.standard_normal((d["t"].size, 2)) if noise_std > 0 else 0.0
    v = X[:, 3:5] + noise
    return {"t": d["t"], "u_ref": d["u_ref"], "w_ref": d["w_ref"], "u": v[:, 0], "w": v[:, 1],
            "u_true": X[:, 3], "w_true": X[:, 4], "x": X[:, 0], "y": X[:, 1], "psi": X[:, 2]}
