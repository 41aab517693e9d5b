"""The estimators of :func:`identify`: output error (Eq. (2) simulated over the
log with its commands as the robot applied them, fitted to the measured
velocities) and equation error (Eq. (11) by least squares), their intervals and
warnings, and :class:`IdentificationResult`.

Equation error: why the velocity derivatives need care
------------------------------------------------------
The regressor needs u' and w'. A raw difference (u[k+1] - u[k]) / dt turns white
measurement noise of std sigma into derivative noise of std sqrt(2) sigma / dt:
sigma = 0.01 m/s at 100 Hz gives 1.4 m/s², several times the accelerations of a
robot limited to 0.3 m/s². Noise in a regressor column does not average out in
least squares: it biases the estimate towards zero (errors in variables), so
theta1 and theta2 would come out far too small. Two remedies are implemented
(``smoothing=``):

``"filter"`` (default): the state-variable filter. Both sides of Eq. (11) are
    passed through the same linear low-pass filter K, a zero-phase kernel
    K(tau) proportional to (1 - (tau/h)^2)^4 on |tau| <= h, h = window / 2
    (gain 0.5 at about 1.2 / window Hz). Because filtering commutes with the
    linear terms, K*u_ref = theta1 K*u' - theta3 K*(w^2) + theta4 K*u holds
    exactly for the true theta, whatever the window, and K*u' = K'*u is
    computed without differentiating the data (integration by parts; trapezoid
    weights on the actual, possibly irregular, time stamps). The filter
    introduces no smoothing bias; it only removes noise. The noise it leaves in
    the filtered regressors is removed from the normal equations
    (bias-compensated least squares): for white noise of std sigma_u, sigma_w the
    expected noise products of every regressor row are known functions of the
    filter weights, and the noise stds are estimated from the log (each sample
    against the line through its neighbours, median-based) unless given as
    ``noise_std``. Without this correction theta1 of a Pioneer 3-DX logged at
    20 Hz (10 Hz) for 120 s with noise std 0.01 comes out 4.8 % (9.9 %) low on
    average over ten noise seeds; with it the average error is +0.4 % (-1.1 %).
``"savgol"``: a Savitzky-Golay local polynomial fit of degree ``order`` over a
    window of ``window`` seconds centred on each sample, on the actual (possibly
    irregular) time stamps; on a uniform grid it equals
    ``scipy.signal.savgol_filter``. u, w, u', w' are the fitted values and
    slopes, and the commands are used unfiltered. The fit attenuates what the
    polynomial cannot follow within the window (the slope of sin(omega t) is
    scaled by about 1 - (omega h)^2 / 10 for degree 2 or 3), so the window must
    stay short compared to the motion, which lets the noise in.

The filter is the default because it is far more accurate. On the nine preset
robots (60 s multisine logs at 200 Hz, velocity noise std 0.01, six noise
seeds) the worst error on theta1, theta2, theta4 or theta6 was 1.2 % for the
filter and 96 %, 78 %, 32 % and 35 % for the Savitzky-Golay fit with windows of
0.1, 0.2, 0.4 and 0.8 s (too short: noise bias; too long: smoothing bias).

The default (automatic) filter window is 1.2 / f95, f95 the frequency below which
95 % of the power of the command rates lies, so that the filter passes the
excitation; it is then widened to twice the slower velocity time constant
max(theta1/theta4, theta2/theta6) of a first estimate when that is longer (a slow
robot's response has no content above its corner). Samples closer than half a
window to either end of the log are not used.

The nonlinear columns w^2 and u w are formed from the measured samples before
filtering; the constant sigma_w^2 that noise adds to E[w_meas^2] is subtracted.

Standard errors come from the least-squares covariance with a Newey-West
(Bartlett) correction over one window, since filtered residuals are correlated
over about that long. In simulation their ratio to the actual errors is within
about 0.5..1.5; they describe the noise, not model error.
"""

from __future__ import annotations

import contextlib
import math
import sys
import warnings as _warnings_mod
from dataclasses import dataclass

import numpy as np

from .._validate import ValidationError, choice, integer, nonnegative, positive
from ..model.unicycle import regressor
from ..model.parameters import RobotParameters
from ._simulate import COMMAND_CONVENTIONS, simulate_held, step_length
from .bags import held_weighted
from .least_squares import levenberg_marquardt, normal_equations
from .logs import (COLUMNS, TIME_UNITS, IdentificationWarning, _short, check_measured,
                   join_logs)
from .results import _NAMES, IdentificationResult
from .validation import validation_report

#: The ways of handling the velocity derivatives (see the module docstring).
SMOOTHING_METHODS = ("filter", "savgol")
#: The estimators of :func:`identify`.
METHODS = ("output-error", "equation-error")
# Ljung-Box statistic over 10 lags above which residuals are not white (chi2(10), p = 0.001)
_WHITE_Q = 29.588
# correlation of the velocity errors with the cube of the fitted velocity (beyond its
# linear part) below which the robot looks saturated: logs made by Eq. (2) with
# clipped commands give -0.7 to -0.85, unclipped ones stay within +/- 0.1
_SATURATION_CORR = -0.3
# The rows of Eq. (11): which parameters each decoupled problem estimates.
_ROW_PARAMS = ((0, 2, 3), (1, 4, 5))
_Z95 = 1.959963984540054
# Newey-West lag, in windows: filtered residuals are correlated over about one window
_LAG_WINDOWS = 1.0
#: The output-error fit explores time constants theta1/theta4, theta2/theta6 of
#: at least this many sample intervals (faster ones are not resolved by the log)
TAU_MIN_SAMPLES = 0.05
# automatic filter window = _AUTO_BAND / (the commands' 95 % band, Hz)
_AUTO_BAND = 1.2
#: theta1, theta2 or a velocity time constant above this (s) is flagged as
#: implausible for a wheeled robot (a log whose time is not in seconds)
MAX_TIME_CONSTANT = 60.0
# time stamps jittering by more than this fraction of the median step (std) widen
# the intervals (see _jitter_widening); rounding to microseconds stays below it
_JITTER_MIN = 1e-3
# a parameter whose information rests on less than this share of the samples is
# reported as not identifiable (see _information_share): a multisine excitation gives
# 0.08 to 0.25, ten one-sample blips in a minute and a half of constant commands 0.007
# to 0.07
_MIN_SHARE = 0.005
# fits repeated with added jitter to measure its effect
_JITTER_REPS = 4
# the shortest sampling step (s) of a robot's log: 10 kHz
_MIN_STEP = 1e-4
_UNIT_NAMES = {"ms": "milliseconds", "us": "microseconds", "ns": "nanoseconds"}


def _emit(res):
    """Issue the result's warnings as :class:`IdentificationWarning` and return it."""
    for text in res.warnings:
        _warnings_mod.warn(text, IdentificationWarning, stacklevel=3)
    return res


def _windows(t: np.ndarray, half: float, what: str, min_count: int):
    """Per sample i, the indices of the samples with |t_j - t_i| <= half (padded) and a mask."""
    eps = 1e-9 * half
    lo = np.searchsorted(t, t - half - eps, side="left")
    hi = np.searchsorted(t, t + half + eps, side="right")
    count = hi - lo
    interior = (t - t[0] >= half - eps) & (t[-1] - t >= half - eps)
    if np.any(count[interior] < min_count):
        k = int(np.flatnonzero(interior & (count < min_count))[0])
        raise ValidationError(
            f"window = {2 * half:g} s holds only {count[k]} sample(s) around t = {t[k]:g} s "
            f"(a gap in the log?); {what} needs at least {min_count}: increase window")
    m = int(count.max())
    idx = lo[:, None] + np.arange(m)
    mask = idx < hi[:, None]
    return np.minimum(idx, t.size - 1), mask, interior


def _trapezoid_weights(t: np.ndarray) -> np.ndarray:
    w = np.empty_like(t)
    w[1:-1] = 0.5 * (t[2:] - t[:-2])
    w[0] = 0.5 * (t[1] - t[0])
    w[-1] = 0.5 * (t[-1] - t[-2])
    return w


def _filter_weights(t, half, chunk=2048):
    """Yield (rows, idx, A, D): per chunk of rows, the sample indices of each
    row's window and the weights of the zero-phase filter K (A) and of its
    derivative K' (D), so that (K*y)(t_i) = sum_m A[i, m] y[idx[i, m]] and
    (K*y')(t_i) = sum_m D[i, m] y[idx[i, m]].

    K(tau) = c (1 - (tau/h)^2)^4 on |tau| <= h, of unit area; the convolution
    integrals use trapezoid weights on the actual time stamps, normalised so that a
    constant passes unchanged and has zero derivative.
    """
    idx, mask, interior = _windows(t, half, "the filter", 7)
    q = 4
    c = math.gamma(q + 1.5) / (math.sqrt(math.pi) * math.gamma(q + 1))
    dtw = _trapezoid_weights(t)
    for s in range(0, t.size, chunk):
        sl = slice(s, min(s + chunk, t.size))
        ii, mm = idx[sl], mask[sl]
        x = (t[sl, None] - t[ii]) / half           # tau / h with tau = t_i - t_j
        base = np.where(mm & (np.abs(x) < 1.0), 1.0 - x * x, 0.0)
        wts = dtw[ii]
        A = c * base ** q / half * wts
        norm = A.sum(axis=1, keepdims=True)
        A = A / np.where(norm > 0, norm, 1.0)
        D = c * q * base ** (q - 1) * (-2.0 * x) / half ** 2 * wts   # K'(tau) = dK/dtau
        D = D - D.sum(axis=1, keepdims=True) * A
        yield sl, ii, A, D, interior


def _eq11_columns(v, v_dot):
    """The regressor Y(v, v') of Eq. (11), :func:`unidyn.model.unicycle.regressor`, with each
    row reduced to the columns of its own parameters (``_ROW_PARAMS``): shape
    (..., 2, 3), row 1 [u', -w^2, u] (theta1, theta3, theta4), row 2
    [w', u w, w] (theta2, theta5, theta6). Every regressor the estimators form
    comes from here."""
    Y = regressor(v, v_dot)
    return np.stack([Y[..., r, list(cols)] for r, cols in enumerate(_ROW_PARAMS)], axis=-2)


def _coupling(u, w, chunk=1 << 16):
    """The coupling columns of Eq. (11) per sample, (w^2, u w), from
    :func:`_eq11_columns` a block of samples at a time (its (n, 2, 3) arrays for a
    whole long log would be many times the log's size)."""
    w2, uw = np.empty(u.size), np.empty(u.size)
    for s in range(0, u.size, chunk):
        v = np.stack([u[s:s + chunk], w[s:s + chunk]], axis=1)
        Y0 = _eq11_columns(v, np.zeros_like(v))
        w2[s:s + chunk], uw[s:s + chunk] = -Y0[:, 0, 1], Y0[:, 1, 1]
    return w2, uw


def _eq11_parts(v):
    """Y(v, 0) and Y(0, v) of :func:`_eq11_columns` per sample, each with a
    (2, 3) mask of its columns that are not zero throughout; see
    :func:`_filtered_eq11`."""
    P = _eq11_columns(v, np.zeros_like(v))
    Q = _eq11_columns(np.zeros_like(v), v)
    return P, Q, P.any(axis=0), Q.any(axis=0)


def _filtered_eq11(parts, smooth, slope):
    """The regressor of Eq. (11) through the filter K, K * Y(v, v'), without
    differentiating the data; shape (rows, 2, 3) as :func:`_eq11_columns`.

    :func:`unidyn.model.unicycle.regressor` cannot be called on (v, v') here because v'
    is not available: the noisy samples must not be differenced. Y is linear in
    v' and its v' entries do not depend on v, so Y(v, v') = Y(v, 0) + Y(0, v'),
    and K * v' = K' * v (integration by parts). Hence
    K * Y(v, v') = K * Y(v, 0) + K' * Y(0, v): the regressor is evaluated per
    sample at (v, 0) and at (0, v) (``parts``, from :func:`_eq11_parts`), and
    the first is filtered by ``smooth`` (applies K to a per-sample series) and
    the second by ``slope`` (applies K'). Columns that are zero throughout (the
    structural zeros) are not filtered.
    """
    P, Q, p_any, q_any = parts
    cols = []
    for r in range(2):
        for j in range(3):
            col = smooth(P[:, r, j]) if p_any[r, j] or not q_any[r, j] else None
            if q_any[r, j]:
                col = slope(Q[:, r, j]) if col is None else col + slope(Q[:, r, j])
            cols.append(col)
    return np.stack(cols, axis=-1).reshape(-1, 2, 3)


def _filter_regression(t, u_ref, w_ref, u, w, half):
    """Both sides of Eq. (11) through the filter K, with the moments that the
    measurement noise adds to each row's regressor (for the bias correction).

    Returns y (N, 2), X (N, 2, 3), interior mask, and a dict of per-row sums of
    products of the weights: DD = sum D^2, DA = sum D A, AA = sum A^2,
    AAu = sum A^2 u, DAu = sum D A u, AAuu = sum A^2 u^2, AAww = sum A^2 w^2.
    """
    n = t.size
    dt = np.diff(t)
    dt_med = float(np.median(dt))
    if np.max(np.abs(dt - dt_med)) <= 1e-6 * dt_med:
        return _filter_regression_uniform(t, u_ref, w_ref, u, w, half, dt_med)
    y = np.empty((n, 2))
    X = np.empty((n, 2, 3))
    mom = {k: np.empty(n) for k in ("DD", "DA", "AA", "AAu", "DAu", "AAuu", "AAww")}
    parts = _eq11_parts(np.stack([u, w], axis=1))
    interior = None
    for sl, ii, A, D, interior in _filter_weights(t, half):
        ui, wi = u[ii], w[ii]
        y[sl, 0] = np.einsum("nm,nm->n", A, u_ref[ii])
        y[sl, 1] = np.einsum("nm,nm->n", A, w_ref[ii])
        X[sl] = _filtered_eq11(parts, lambda z: np.einsum("nm,nm->n", A, z[ii]),
                               lambda z: np.einsum("nm,nm->n", D, z[ii]))
        AA, DA = A * A, D * A
        mom["DD"][sl] = np.einsum("nm,nm->n", D, D)
        mom["DA"][sl] = DA.sum(axis=1)
        mom["AA"][sl] = AA.sum(axis=1)
        mom["AAu"][sl] = np.einsum("nm,nm->n", AA, ui)
        mom["DAu"][sl] = np.einsum("nm,nm->n", DA, ui)
        mom["AAuu"][sl] = np.einsum("nm,nm->n", AA, ui * ui)
        mom["AAww"][sl] = np.einsum("nm,nm->n", AA, wi * wi)
    return y, X, interior, mom


def _filter_regression_uniform(t, u_ref, w_ref, u, w, half, dt):
    """:func:`_filter_regression` on a uniform grid: the same weights for every
    row whose window lies inside the log, applied by convolution."""
    n = t.size
    eps = 1e-9 * half
    m = int(math.floor((half + eps) / dt))
    interior = (t - t[0] >= half - eps) & (t[-1] - t >= half - eps)
    if m < 3 or 2 * m + 1 > n:
        _windows(t, half, "the filter", 7)        # raises the standard message
    q = 4
    c = math.gamma(q + 1.5) / (math.sqrt(math.pi) * math.gamma(q + 1))
    x = -np.arange(-m, m + 1) * dt / half          # tau / h for sample i + k, tau = -k dt
    base = np.where(np.abs(x) < 1.0, 1.0 - x * x, 0.0)
    A = c * base ** q / half * dt
    A = A / A.sum()
    D = c * q * base ** (q - 1) * (-2.0 * x) / half ** 2 * dt
    D = D - D.sum() * A

    def conv(sig, ker):
        out = np.full(n, np.nan)
        out[m:n - m] = np.convolve(sig, ker[::-1], mode="valid")
        return out

    y = np.stack([conv(u_ref, A), conv(w_ref, A)], axis=1)
    X = _filtered_eq11(_eq11_parts(np.stack([u, w], axis=1)), lambda z: conv(z, A),
                       lambda z: conv(z, D))
    AA, DA = A * A, D * A
    mom = {"DD": np.full(n, float(D @ D)), "DA": np.full(n, float(DA.sum())),
           "AA": np.full(n, float(AA.sum())), "AAu": conv(u, AA), "DAu": conv(u, DA),
           "AAuu": conv(u * u, AA), "AAww": conv(w * w, AA)}
    return y, X, interior, mom


def _noise_moments(mom, su2, sw2):
    """Per-row expected noise products E[n n^T] (N, 2, 3, 3) of the filtered
    regressors, and the mean offset of the -w^2 column, for white noise of
    variances su2 (on u) and sw2 (on w), independent between u and w."""
    n = mom["DD"].size
    E = np.zeros((n, 2, 3, 3))
    # row 1: [K'*u, -K*(w^2), K*u]; noise of (w+m)^2 - sigma^2 is 2 w m + m^2 - sigma^2
    E[:, 0, 0, 0] = su2 * mom["DD"]
    E[:, 0, 0, 2] = E[:, 0, 2, 0] = su2 * mom["DA"]
    E[:, 0, 2, 2] = su2 * mom["AA"]
    E[:, 0, 1, 1] = 4 * sw2 * mom["AAww"] - 2 * sw2 * sw2 * mom["AA"]
    # row 2: [K'*w, K*(u w), K*w]; noise of u w is u m + w n + n m
    E[:, 1, 0, 0] = sw2 * mom["DD"]
    E[:, 1, 0, 2] = E[:, 1, 2, 0] = sw2 * mom["DA"]
    E[:, 1, 2, 2] = sw2 * mom["AA"]
    E[:, 1, 0, 1] = E[:, 1, 1, 0] = sw2 * mom["DAu"]
    E[:, 1, 2, 1] = E[:, 1, 1, 2] = sw2 * mom["AAu"]
    E[:, 1, 1, 1] = sw2 * mom["AAuu"] + su2 * mom["AAww"] - su2 * sw2 * mom["AA"]
    return E


def _noise_std(t, y) -> float:
    """Robust estimate of the std of white noise on samples y(t).

    Each sample is compared with the straight line through its two neighbours;
    for white noise of std s the difference has std s sqrt(1 + a^2 + b^2)
    (a, b the interpolation weights), while a smooth signal contributes only its
    curvature times dt^2. The median of the squared, normalised differences
    (divided by 0.4549, the median of chi-square with one degree of freedom)
    makes the estimate insensitive to outliers and to occasional sharp motion.
    """
    h1 = t[1:-1] - t[:-2]
    h2 = t[2:] - t[1:-1]
    a = h2 / (h1 + h2)
    b = h1 / (h1 + h2)
    r = y[1:-1] - (a * y[:-2] + b * y[2:])
    z = r * r / (1.0 + a * a + b * b)
    return float(math.sqrt(np.median(z) / 0.454936423119572))


def _local_poly(t, signals, half, order, chunk=2048):
    """Savitzky-Golay-style local polynomial fit on the actual time stamps.

    Returns (values (N, m), slopes (N, m), interior mask).
    """
    idx, mask, interior = _windows(t, half, f"a degree-{order} fit", order + 2)
    sig = np.asarray(signals, dtype=float)
    val = np.empty((t.size, sig.shape[1]))
    der = np.empty_like(val)
    powers = np.arange(order + 1)
    for s in range(0, t.size, chunk):
        sl = slice(s, s + chunk)
        ii, mm = idx[sl], mask[sl]
        x = (t[ii] - t[sl, None]) / half
        V = np.where(mm[..., None], x[..., None] ** powers, 0.0)       # (n, M, p+1)
        A = np.einsum("nmi,nmj->nij", V, V)
        B = np.einsum("nmi,nmc->nic", V, sig[ii])
        coef = np.linalg.solve(A, B)
        val[sl] = coef[:, 0, :]
        der[sl] = coef[:, 1, :] / half
    return val, der, interior


def _lstsq(X: np.ndarray, y: np.ndarray, lag: int, E: np.ndarray | None = None):
    """Least squares with column scaling and a Newey-West covariance.

    With ``E`` (per-row expected noise products of the regressor, (n, p, p)), the
    normal matrix is corrected for the noise in the regressor (bias-compensated
    least squares): (X^T X - sum E) beta = X^T y.

    Returns (beta, cov, residuals, condition number of the column-scaled regressor,
    whether the correction left the normal matrix positive definite).
    """
    n, p = X.shape
    scale = np.linalg.norm(X, axis=0)
    Xs = X / scale
    sv = np.linalg.svd(Xs, compute_uv=False)
    cond = float(sv[0] / sv[-1]) if sv[-1] > 0 else math.inf
    M = Xs.T @ Xs
    Es = None
    ok = True
    if E is not None:
        Es = E / np.outer(scale, scale)
        Mc = M - Es.sum(axis=0)
        if np.linalg.eigvalsh(Mc)[0] > 0.05 * np.linalg.eigvalsh(M)[0]:
            M = Mc
        else:
            ok, Es = False, None
    beta_s = np.linalg.solve(M, Xs.T @ y)
    r = y - Xs @ beta_s
    g = Xs * r[:, None]
    if Es is not None:
        g = g + Es @ beta_s
    S = g.T @ g
    for k in range(1, min(lag, n - 1) + 1):
        G = g[k:].T @ g[:-k]
        S += (1.0 - k / (lag + 1.0)) * (G + G.T)
    Minv = np.linalg.inv(M)
    cov_s = Minv @ S @ Minv * n / max(n - p, 1)
    return beta_s / scale, cov_s / np.outer(scale, scale), r, cond, ok


# ------------------------------------------------------------------ identification

def identify(log, *more_logs, commands: str = "held", delay=0.0,
             method: str = "output-error", smoothing: str = "filter",
             window: float | None = None, order: int = 3, noise_std=None, columns=None,
             name: str = "identified", rel_stderr_max: float = 0.25, validate: bool = True,
             gap: float | None = None, check_commands: bool = True,
             time_unit: str | None = None,
             stamp_jitter: float | None = None,
             progress: bool | None = None) -> IdentificationResult:
    r"""Estimate theta1..theta6 of Eq. (2) from one or more logs of one robot.

    The default ``method="output-error"`` simulates Eq. (2) over every piece of
    every log with the logged commands applied as the robot received them, and
    adjusts theta (and each piece's initial velocities, and the input delay if
    asked) so that the simulated velocities match the measured ones
    (bounded Levenberg-Marquardt, each channel weighted by its noise level;
    derivatives by finite differences of the compiled simulation, held once in
    single precision, so that a log of 10^6 rows fits in a few hundred MB).
    Logs read from bags (:func:`~unidyn.identification.read_bag`) are refitted
    once with each row's command weighted by the fitted response (see
    :func:`~unidyn.identification.bags.held_weighted`), and with unstamped
    commands the intervals allow for the recorder's lag (``RECORDER_LAG``).
    It starts from a least-squares estimate: for held commands the exact
    discretisation of the linear part of Eq. (2) under a held input,
    u[k+1] = a u[k] + b u_ref[k] + c w[k]^2 with a = exp(-theta4 dt / theta1),
    b = (1 - a) / theta4, c = theta3 b (and its twin for w); for linear
    commands, Eq. (11) through the state-variable filter. ``"equation-error"``
    stops at Eq. (11) through the filter (or a Savitzky-Golay fit), which treats
    the commands as smooth.

    :param log: t (s), u_ref (m/s), w_ref (rad/s), u (m/s), w (rad/s): a mapping,
        structured array, object with attributes or CSV path (see :func:`load_log`)
    :param more_logs: further logs of the same robot, identified together
        (each with its own initial state)
    :param commands: how the logged commands act between time stamps:
        ``"held"`` (default; each command from its time stamp until the next,
        as robot firmware applies them) or ``"linear"`` (varying linearly, for
        commands that are samples of a smooth signal)
    :param delay: input delay: seconds (>= 0), a string ``"N samples"`` (in
        median sample intervals), or ``"auto"`` to estimate it (0..4 samples)
    :param method: ``"output-error"`` (default) or ``"equation-error"``
    :param smoothing: for the equation-error estimate: ``"filter"`` (default)
        or ``"savgol"``
    :param window: the filter / fit window of the equation-error estimate, s
        (default automatic)
    :param order: polynomial degree of the Savitzky-Golay fit, 2..6
    :param noise_std: std of the white noise on u and w (a number or a pair):
        ``None`` (default) estimates it from the log. It weights the two
        channels of the output-error fit and sets the equation-error noise-bias
        correction (0 switches that off)
    :param columns: mapping from t, u_ref, w_ref, u, w to the log's own names
    :param name: the name given to the identified :class:`RobotParameters`
    :param rel_stderr_max: theta3 or theta5 with a standard error above this
        fraction of its magnitude is reported as unidentified, > 0
    :param validate: simulate the identified model over the logs from their
        first measured velocities and keep the report (``result.validation``)
    :param gap: a time step longer than this (s) splits a log; default 1.4 times
        the median time step (a step of 1.4 to 5 median steps means missing rows,
        whose held commands are unknown; a longer one a gap)
    :param check_commands: also fit the other command convention and warn when
        it fits the log clearly better
    :param time_unit: the unit of the logs' time column, ``"s"``, ``"ms"``,
        ``"us"`` or ``"ns"`` (see :func:`load_log`); default seconds, refusing
        a median time step over 1 s as almost surely another unit
    :param stamp_jitter: the std of the error of the time stamps, s, when known
        (0: the stamps are exact, as when the samples are irregular but stamped
        when taken). Default None: measured from the stamps as if the samples
        were taken on a regular clock. Above a thousandth of the median step,
        the output-error intervals are widened for it (stamp errors bias the
        fit: it is repeated with as much jitter again added to the stamps, and
        the shift and scatter of the estimates are added to the standard
        errors) and a warning says by how much
    :param progress: a progress bar on stderr while the fits run: None (default)
        for logs of more than 100,000 rows when stderr is a terminal; True or False
        to force it on or off
    :raises ValidationError: for a bad log (see :func:`load_log`; every row it
        drops or skips is reported in ``warnings``), a log whose fit needs more
        memory than the system has available (about 250 bytes a row), constant
        commands or no motion (nothing to identify), a window that does not fit the
        log, or a non-positive theta1, theta2, theta4 or theta6 (no physical robot
        has one; the message lists the likely causes)
    :return: :class:`IdentificationResult`
    """
    commands, method, smoothing, order, window, rel_stderr_max, gap, stamp_jitter = \
        _checked_options(commands, method, smoothing, order, window, rel_stderr_max, name,
                         gap, stamp_jitter, validate, check_commands)
    if progress is not None and not isinstance(progress, (bool, np.bool_)):
        raise ValidationError(f"progress must be None, True or False, got {_short(progress)}")
    lg = _read_logs((log,) + more_logs, columns, gap, time_unit, stamp_jitter, commands,
                    delay, window, noise_std)
    _check_memory(lg, method)
    with _progress_bar(lg, progress) as lg.tick:
        res = _identify(lg, method, smoothing, window, order, rel_stderr_max, name,
                        check_commands, validate)
    return _emit(res)


def _identify(lg, method, smoothing, window, order, rel_stderr_max, name, check_commands,
              validate):
    if method == "equation-error":
        res = _identify_equation_error(lg, smoothing, window, order, rel_stderr_max, name)
    else:
        theta0, start_kind, m0 = _start(lg.D, lg.segs, lg.linear, lg.delay, lg.delay_auto,
                                        lg.dt_med, smoothing, window, order, lg.su, lg.sw)
        oe = _weighted_oe_fit(lg, theta0, m0 * lg.dt_med if lg.delay_auto else lg.delay)
        if lg.recorded and not lg.linear and oe["delay"] == 0:
            # the commands of the rows weighted as the robot's response weighs them
            lg.D.update(_row_commands(lg.recorded, oe["theta"]))
            oe = _weighted_oe_fit(lg, oe["theta"], 0.0)
        stderr, warns = _oe_intervals(lg, oe, rel_stderr_max)
        if check_commands:
            warns += _command_check(lg, oe)
        res = _oe_result(lg, oe, stderr, warns, start_kind, name)
    if validate:
        res = _with_validation(res, lg.D, lg.segs)
    return res


# memory the output-error fit holds per row of the log beyond the log's own columns,
# bytes (its single-precision Jacobian, simulated and measured velocities, residuals,
# the validation's copies: 2.2 GB in all for 10^7 rows), and per parameter fitted
# beyond the first eight
_BYTES_PER_ROW = 250
_BYTES_PER_ROW_PARAM = 8
# logs of more rows than this show a progress bar on a terminal
_PROGRESS_ROWS = 100_000


def _available_memory() -> float | None:
    """Bytes of memory the system can give this process now (Linux), else None."""
    try:
        with open("/proc/meminfo") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    return float(line.split()[1]) * 1024
    except OSError:
        pass
    return None


def _memory_needed(rows: int, pieces: int = 1) -> float:
    """Bytes the output-error fit of a log of ``rows`` rows in ``pieces`` pieces
    needs beyond the log itself (about 250 a row)."""
    extra = max(2 * pieces - 2, 0)
    return rows * (_BYTES_PER_ROW + _BYTES_PER_ROW_PARAM * extra)


def _check_memory(lg, method):
    """Refuse, before the fit, a log whose fit would not fit in the memory available."""
    if method != "output-error":
        return
    need = _memory_needed(lg.D["t"].size, len(lg.segs))
    have = _available_memory()
    if have is not None and need > have:
        raise ValidationError(
            f"the log's {lg.D['t'].size} rows need about {need / 1e9:.2g} GB of memory to "
            f"identify from and {have / 1e9:.2g} GB are available: identify from a part "
            f"(split_log), or on a machine with more memory")


@contextlib.contextmanager
def _progress_bar(lg, progress):
    """A tqdm progress bar on stderr counting the simulations of the fits (for logs
    over ``_PROGRESS_ROWS`` rows, on a terminal; ``progress`` True or False forces it
    on or off), as the callable to tick; None without a bar."""
    show = lg.D["t"].size > _PROGRESS_ROWS if progress is None else bool(progress)
    if not show:
        yield None
        return
    from tqdm import tqdm
    bar = tqdm(desc=f"identify ({lg.D['t'].size} rows)", unit=" simulations",
               file=sys.stderr, disable=None if progress is None else False, leave=False)
    try:
        yield bar.update
    finally:
        bar.close()


def _checked_options(commands, method, smoothing, order, window, rel_stderr_max, name,
                     gap, stamp_jitter, validate, check_commands):
    """The options of :func:`identify` checked (one clear line for a bad one)."""
    commands = choice("commands", commands, COMMAND_CONVENTIONS)
    method = choice("method", method, METHODS)
    smoothing = choice("smoothing", smoothing, SMOOTHING_METHODS)
    order = integer("order", order, 2, 6)
    if window is not None:
        window = positive("window", window)
    rel_stderr_max = positive("rel_stderr_max", rel_stderr_max)
    if not isinstance(name, str):
        raise ValidationError(f"name must be a string, got {_short(name)}")
    if gap is not None:
        gap = positive("gap", gap)
    if stamp_jitter is not None:
        stamp_jitter = nonnegative("stamp_jitter", stamp_jitter)
    for flag, v in (("validate", validate), ("check_commands", check_commands)):
        if not isinstance(v, (bool, np.bool_)):
            raise ValidationError(f"{flag} must be True or False, got {_short(v)}")
    return commands, method, smoothing, order, window, rel_stderr_max, gap, stamp_jitter


@dataclass
class _Logs:
    """The joined logs of one :func:`identify` call and what is read from them."""
    D: dict                 # the joined columns (see join_logs)
    segs: list              # (start, stop) rows of each piece
    n_logs: int
    commands: str
    dt_med: float           # median time step, s
    delay: float            # s (0 when it is to be estimated)
    delay_auto: bool
    su: float               # noise std of u and w
    sw: float
    stamp_jitter: float | None
    warnings: list          # about the logs: missing rows, gaps, dropped rows
    tick: object = None     # called as the fits advance (a progress bar), or None
    recorded: list = None   # the logs read from bags, with the commands as recorded

    @property
    def linear(self) -> bool:
        return self.commands == "linear"

    def description(self, delay) -> str:
        n_used = sum(b - a for a, b in self.segs)
        return (f"identified from {n_used} samples in {len(self.segs)} piece(s) of "
                f"{self.n_logs} log(s), commands={self.commands!r}, delay={delay:g} s")


def _read_logs(logs, columns, gap, time_unit, stamp_jitter, commands, delay, window,
               noise_std) -> _Logs:
    """Join the logs, check that they can be identified from, read the delay and
    the noise levels, and note missing rows and gaps."""
    stamp_jitter = _recorded_jitter(logs, stamp_jitter)
    D, segs, _, _ = join_logs(logs, columns, gap, time_unit)
    t, u_ref, w_ref, u, w = (D[k] for k in COLUMNS)
    _check_excitation(u_ref, w_ref)
    check_measured(u_ref, w_ref, u, w)
    dt_med = float(np.median(np.concatenate([np.diff(t[a:b]) for a, b in segs])))
    delay_auto, delay = _delay_arg(delay, dt_med)
    longest = max(t[b - 1] - t[a] for a, b in segs)
    if delay > longest / 3:  # the commands shifted by it would leave too little to fit
        raise ValidationError(f"delay must be <= a third of the longest piece of the log "
                              f"({longest / 3:g} s), got {delay:g} s")
    if window is not None and window > longest / 3:
        raise ValidationError(f"window must be <= a third of the longest piece of the log "
                              f"({longest / 3:g} s), got {window!r}")
    if noise_std is None:
        su = _pooled_noise(t, u, segs)
        sw = _pooled_noise(t, w, segs)
    else:
        su, sw = _pair("noise_std", noise_std)
    warns = []
    n_missing, n_gaps = D.get("missing", (0, 0))
    if n_missing:
        warns.append(f"{n_missing} missing row(s) detected (time steps of 1.4 to 5 times the "
                     f"median step): the commands held while they were missing are unknown, "
                     f"so the log is split there into pieces, each with its own initial "
                     f"state (set gap= to change this)")
    if n_gaps:
        warns.append(f"{n_gaps} gap(s) in the log(s) (time steps over 5 times the median "
                     f"step): the log is split there into pieces, each with its own initial "
                     f"state")
    warns += D["notes"]     # rows dropped or skipped, short pieces not used
    recorded = [lg for lg in logs if isinstance(lg, dict) and "commands" in lg]
    if len(recorded) != len(logs) or sum(lg["t"].size for lg in recorded) != D["t"].size:
        recorded = None
    return _Logs(D, segs, len(logs), commands, dt_med, delay, delay_auto, su, sw,
                 stamp_jitter, warns, recorded=recorded)


def _identify_equation_error(lg, smoothing, window, order, rel_stderr_max, name):
    """Eq. (11) through the filter or the Savitzky-Golay fit, as a result."""
    fit = _equation_error(lg.D, lg.segs, smoothing, window, order, lg.su, lg.sw)
    theta, cov, resid, keep_t, conds, r2, ew, win, uk, wk = fit
    stderr = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    _check_physical(theta, stderr)
    warns = lg.warnings + ew + _warnings(theta, stderr, conds, uk, wk, lg.dt_med,
                                         rel_stderr_max)
    if not lg.linear:
        warns.append(
            "the equation-error estimate treats the commands as smooth between samples; "
            "for commands held between samples it is biased by about half a sample "
            f"(theta1 by about theta4 dt / 2 = {theta[3] * lg.dt_med / 2:.3g} s): use "
            "method='output-error'")
    rp = RobotParameters(*theta.tolist(), name=name,
                         source=f"{lg.description(lg.delay)}, method='equation-error', "
                                f"smoothing={smoothing!r}, window={win:g} s")
    return IdentificationResult(
        theta=rp, stderr=stderr, ci95=_ci(theta, stderr), residuals=resid, t=keep_t,
        condition_numbers=tuple(conds), warnings=warns, smoothing=smoothing, window=win,
        order=order if smoothing == "savgol" else None, n_samples=int(keep_t.size),
        fit_r2=tuple(r2), noise_std=(lg.su, lg.sw), method="equation-error",
        commands=lg.commands, delay=lg.delay, segments=len(lg.segs), n_logs=lg.n_logs)


def _weighted_oe_fit(lg, theta0, delay):
    """The output-error fit weighted by the noise levels; refitted once with the
    residuals' own levels when they differ by more than 25 %."""
    u, w = lg.D["u"], lg.D["w"]
    floor_u = 1e-9 * max(float(np.sqrt(np.mean(u * u))), 1e-9)
    floor_w = 1e-9 * max(float(np.sqrt(np.mean(w * w))), 1e-9)
    sig = np.array([max(lg.su, floor_u), max(lg.sw, floor_w)])
    oe = _oe_fit(lg.D, lg.segs, theta0, sig, lg.linear, delay, lg.delay_auto, lg.dt_med,
                 progress=lg.tick)
    if np.any(np.abs(oe["rms"] / sig - 1.0) > 0.25):
        sig = np.maximum(oe["rms"], [floor_u, floor_w])
        oe = _oe_fit(lg.D, lg.segs, oe["theta"], sig, lg.linear, oe["delay"], lg.delay_auto,
                     lg.dt_med, v0=oe["v0"], progress=lg.tick)
    return oe


def _oe_intervals(lg, oe, rel_stderr_max):
    """The standard errors of theta (widened for stamp jitter) and the warnings
    about the estimate, starting with those about the logs."""
    theta = oe["theta"]
    stderr = np.sqrt(np.clip(np.diag(oe["cov"])[:6], 0.0, None))
    _check_physical(theta, stderr)
    warns = list(lg.warnings)
    t = lg.D["t"]
    jitter = _stamp_jitter(t, lg.segs) if lg.stamp_jitter is None else lg.stamp_jitter
    if jitter > _JITTER_MIN * lg.dt_med:
        stderr, note = _jitter_widening(lg.D, lg.segs, oe, theta, stderr, lg.linear,
                                        lg.dt_med, jitter)
        warns.append(note)
    unstamped = lg.recorded and not all(r["commands"]["stamped"] for r in lg.recorded)
    if unstamped and not lg.linear and oe["delay"] == 0:
        stderr, note = _lag_widening(lg, oe, theta, stderr)
        warns.append(note)
    idx = oe["rows"]
    for i in np.flatnonzero(oe["share"] < _MIN_SHARE):
        if i in oe["dead"]:
            continue
        stderr[i] = math.inf
        warns.append(f"{_NAMES[i]} is not identifiable from this log: its estimate "
                     f"{theta[i]:.4g} rests on {100 * oe['share'][i]:.2g} % of the samples "
                     f"(the few moments that excite it, such as isolated steps in otherwise "
                     f"steady commands), too few for its interval to mean anything; it is "
                     f"reported without one. Excite it throughout the log (see excitation())")
    for i in oe["dead"]:
        warns.append(f"{_NAMES[i]} is not identifiable from this log: the simulated velocities "
                     f"do not depend on it (or only through a combination with other "
                     f"parameters), so its value is arbitrary and its standard error is "
                     f"reported as inf")
    warns += _warnings(theta, stderr, oe["conds"], lg.D["u"][idx], lg.D["w"][idx], lg.dt_med,
                       rel_stderr_max)
    return stderr, warns + oe["warnings"]


def _command_check(lg, oe) -> list:
    """A warning when the other command convention fits the log clearly better."""
    other = "held" if lg.linear else "linear"
    alt = _oe_fit(lg.D, lg.segs, oe["theta"], oe["sig"], not lg.linear, oe["delay"], False,
                  lg.dt_med, v0=oe["v0"], covariance=False, progress=lg.tick)
    gain = oe["cost"] - alt["cost"]
    # an absolute floor (noise), and a relative one: a log that Eq. (2) does not
    # fit (a saturating robot) can fit a little better either way
    if gain <= max(25.0, 1e-3 * oe["rows"].size, 0.02 * oe["cost"]):
        return []
    if other == "held":
        why = ("the commands are held between samples, or take effect later than "
               "their time stamps (see delay='auto')")
    else:
        why = ("the commands vary smoothly between samples, or take effect earlier "
               "than their time stamps (by about half a sample; delay cannot be "
               "negative, so delay='auto' cannot fix that: check how the commands "
               "and the velocities are time-stamped)")
    return [f"the log fits clearly better with commands={other!r} (sum of squared "
            f"normalised velocity errors {alt['cost']:.4g} against {oe['cost']:.4g}): "
            f"{why}; with the wrong convention theta1 and theta2 are biased by about "
            f"half a sample"]


def _oe_result(lg, oe, stderr, warns, start_kind, name):
    """The :class:`IdentificationResult` of the output-error fit."""
    theta, idx, est_delay = oe["theta"], oe["rows"], oe["delay"]
    rp = RobotParameters(*theta.tolist(), name=name,
                         source=f"{lg.description(est_delay)}, method='output-error' from a "
                                f"{start_kind} start")
    return IdentificationResult(
        theta=rp, stderr=stderr, ci95=_ci(theta, stderr), residuals=oe["residuals"],
        t=lg.D["t"][idx], condition_numbers=tuple(oe["conds"]), warnings=warns,
        smoothing=None, window=None, order=None, n_samples=int(idx.size),
        fit_r2=tuple(oe["r2"]), noise_std=tuple(float(x) for x in oe["rms"]),
        method="output-error", commands=lg.commands, delay=float(est_delay),
        delay_stderr=float(oe["delay_stderr"]) if lg.delay_auto else 0.0,
        segments=len(lg.segs), n_logs=lg.n_logs, whiteness=tuple(oe["whiteness"]),
        v0=oe["v0"])


def _recorded_jitter(logs, stamp_jitter):
    """``stamp_jitter`` where every log says it and the caller did not.

    A log read from a ROS bag (:func:`~unidyn.identification.read_bag`) carries
    ``stamp_jitter = 0``: its samples are at their header stamps, irregular but
    exact, so no widening is due. (Its recording-gap threshold is read by
    :func:`~unidyn.identification.join_logs`.)
    """
    said = [lg for lg in logs if isinstance(lg, dict) and "stamp_jitter" in lg]
    if stamp_jitter is None and said and len(said) == len(logs):
        stamp_jitter = max(float(lg["stamp_jitter"]) for lg in said)
    return stamp_jitter


def _stamp_jitter(t, segs) -> float:
    """The std of the error in the time stamps, s, if the samples were taken on
    a regular clock: each stamp against the mean of its neighbours (median-based,
    as :func:`_noise_std`), pooled over the pieces."""
    var, n = 0.0, 0
    for a, b in segs:
        if b - a >= 5:
            var += _noise_std(np.arange(b - a, dtype=float), t[a:b] - t[a]) ** 2 * (b - a)
            n += b - a
    return float(math.sqrt(var / n)) if n else 0.0


def _jitter_widening(D, segs, oe, theta, stderr, linear, dt_med, jitter):
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
        fk = _oe_fit({**D, "t": tk}, segs, theta, oe["sig"], linear, oe["delay"], False,
                     dt_med, v0=oe["v0"], covariance=False)
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
    grown = [f"{_NAMES[i]} x{wide[i] / stderr[i]:.2g}" for i in range(6)
             if stderr[i] > 0 and wide[i] > 1.1 * stderr[i]]
    return wide, grown


def _row_commands(recorded, theta, lags=None):
    """u_ref, w_ref of the rows of logs read from bags, from their commands as
    recorded (each delayed by ``lags``, one array per log, s), each row's held value
    weighted by the response of time constant theta1/theta4 (u) or theta2/theta6
    (w): see :func:`~unidyn.identification.bags.held_weighted`."""
    tau_u = theta[0] / theta[3] if theta[3] > 0 else math.inf
    tau_w = theta[1] / theta[5] if theta[5] > 0 else math.inf
    out = {"u_ref": [], "w_ref": []}
    for k, log in enumerate(recorded):
        c = log["commands"]
        c_t = c["t"] if lags is None else np.sort(c["t"] + lags[k])
        for key, tau in (("u_ref", tau_u), ("w_ref", tau_w)):
            out[key].append(held_weighted(c_t, c[key], log["t"], tau, log.get("cmd_timeout")))
    return {k: np.concatenate(v) for k, v in out.items()}


#: The most by which a recorder receives a command after the robot does (s): an
#: unstamped command's time in a bag is when the recorder received it, a few ms
#: after the robot started to apply it (one delivery on the same computer).
RECORDER_LAG = 0.005


def _lag_widening(lg, oe, theta, stderr):
    """Standard errors that allow for unstamped commands timed by the recorder: the
    fit repeated ``_JITTER_REPS`` times with each command applied up to
    ``RECORDER_LAG`` earlier than recorded (uniform, seeded); the shift and the
    scatter of the estimates are added to the standard errors, as for stamp jitter
    (:func:`_jitter_widening`). The time a robot applied a command is not in the
    bag, and a lag of a few ms biases theta1 and theta2 like a delay (by about
    theta4 and theta6 times the lag)."""
    rng = np.random.default_rng(1)
    reps = []
    for _ in range(_JITTER_REPS):
        lags = [-rng.uniform(0.0, RECORDER_LAG, r["commands"]["t"].size) for r in lg.recorded]
        D = {**lg.D, **_row_commands(lg.recorded, theta, lags)}
        fk = _oe_fit(D, lg.segs, theta, oe["sig"], False, 0.0, False, lg.dt_med,
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


def _ci(theta, stderr):
    return np.stack([theta - _Z95 * stderr, theta + _Z95 * stderr], axis=1)


def _delay_arg(delay, dt_med):
    """(estimate?, delay in seconds) from the ``delay`` argument."""
    if isinstance(delay, str):
        text = delay.strip().lower()
        if text == "auto":
            return True, 0.0
        num, _, unit = text.partition(" ")
        if unit.strip() in ("sample", "samples"):
            try:
                n = float(num)
            except ValueError:
                n = math.nan
            if math.isfinite(n) and 0 <= n <= 1000:
                return False, n * dt_med
        raise ValidationError(f"delay must be seconds >= 0, 'N samples' or 'auto', got "
                              f"{_short(delay)}")
    return False, nonnegative("delay", delay)


def _pooled_noise(t, y, segs) -> float:
    var, n = 0.0, 0
    for a, b in segs:
        if b - a >= 5:
            var += _noise_std(t[a:b], y[a:b]) ** 2 * (b - a)
            n += b - a
    return float(math.sqrt(var / n)) if n else 0.0


def _start(D, segs, linear, delay, delay_auto, dt_med, smoothing, window, order, su, sw):
    """A first estimate of theta: (theta, what it came from, delay in samples)."""
    errors = []
    last = None
    order_ = ("filter", "arx") if linear else ("arx", "filter")
    for kind in order_:
        try:
            if kind == "arx":
                th, m = _arx(D, segs, delay, delay_auto, dt_med)
            else:
                th = _equation_error(D, segs, smoothing, window, order, su, sw)[0]
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
        _check_physical(last, np.full(6, math.nan))
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
    w2, uw = _coupling(u, w)      # the coupling columns of Eq. (11) of each sample
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


class _OutputErrorProblem:
    """The output-error fit's parameter vector p = (theta, [delay], initial
    velocities of each piece), its bounds, and its residuals and Jacobian.

    Bounds: theta1, theta2, theta4, theta6 > 0 and the estimated delay within
    0..4 samples. The fit explores no time constant theta1 / theta4 or
    theta2 / theta6 below ``TAU_MIN_SAMPLES`` sample intervals (a faster
    response settles within the sample and is not resolved by the log; the
    simulation's step, a tenth of the time constant, stays bounded): the
    simulation holds such a theta at that limit, so the errors do not improve
    past it.
    """

    def __init__(self, D, segs, theta0, sig, linear, delay, est_delay, dt_med, v0):
        self.t, self.u_ref, self.w_ref, u, w = (D[k] for k in COLUMNS)
        self.segs, self.sig, self.linear, self.delay = segs, sig, linear, delay
        self.nd = 1 if est_delay else 0
        self.dt_med = dt_med
        self.pos = np.cumsum([0] + [b - a for a, b in segs])
        self.measured = (u, w)
        self._idx = None
        self.hmax = step_length(theta0, dt_med)
        self.tau_min = TAU_MIN_SAMPLES * dt_med
        self.buf = np.full((self.t.size, 2), np.nan)
        if v0 is None:
            v0 = np.array([[u[a], w[a]] for a, _ in segs])
        p0 = np.concatenate([theta0, [delay] if self.nd else [],
                             np.asarray(v0, float).ravel()])
        self.lb = np.full(p0.size, -np.inf)
        self.ub = np.full(p0.size, np.inf)
        self.lb[[0, 1, 3, 5]] = 1e-9
        if self.nd:
            self.lb[6], self.ub[6] = 0.0, 4.0 * dt_med
            p0[6] = min(max(p0[6], 0.02 * dt_med), 3.98 * dt_med)
        p0 = np.minimum(np.maximum(p0, self.lb + 1e-12), self.ub - 1e-12)
        for i, j in ((0, 3), (1, 5)):
            p0[i] = max(p0[i], 1.001 * self.tau_min * p0[j])
        self.p0 = p0
        self.progress = None     # called after each simulation of the fit

    def unpack(self, p):
        """(theta held at the fastest time constant explored, delay, v0)."""
        th = np.array(p[:6], dtype=float)
        th[0] = max(th[0], self.tau_min * th[3])
        th[1] = max(th[1], self.tau_min * th[5])
        dl = p[6] if self.nd else self.delay
        return th, dl, np.asarray(p[6 + self.nd:]).reshape(len(self.segs), 2)

    def sim(self, p, which=None):
        """The simulated (u, w) on the fitted rows (all pieces, or piece ``which``)."""
        th, dl, vv = self.unpack(p)
        segs = self.segs if which is None else [self.segs[which]]
        vv = vv if which is None else vv[which:which + 1]
        simulate_held(th, self.t, self.u_ref, self.w_ref, segs, vv, dl, self.linear,
                      self.hmax, out=self.buf)
        return self.buf[self.idx]

    @property
    def idx(self):
        """The rows of the log that are fitted (those of its pieces)."""
        if self._idx is None:
            self._idx = np.concatenate([np.arange(a, b) for a, b in self.segs])
        return self._idx

    @property
    def Y(self):
        """The measured (u, w) on the fitted rows, (rows, 2) (a new array)."""
        u, w = self.measured
        return np.stack([u[self.idx], w[self.idx]], axis=1)

    def _errors(self, p, out, which=None):
        """The velocity errors (u of every row, then w; each channel divided by its
        noise level) written into ``out`` (all rows, or piece ``which`` only: its
        rows of ``out`` are written), without temporaries the size of the log."""
        th, dl, vv = self.unpack(p)
        segs = self.segs if which is None else [self.segs[which]]
        vv = vv if which is None else vv[which:which + 1]
        simulate_held(th, self.t, self.u_ref, self.w_ref, segs, vv, dl, self.linear,
                      self.hmax, out=self.buf)
        if self.progress is not None:
            self.progress()
        n = int(self.pos[-1])
        pieces = range(len(self.segs)) if which is None else [which]
        for c in range(2):
            for s in pieces:
                a, b = self.segs[s]
                o = out[c * n + self.pos[s]:c * n + self.pos[s + 1]]
                np.subtract(self.buf[a:b, c], self.measured[c][a:b], out=o)
                o /= self.sig[c]
        return out

    def fun(self, p):
        """The velocity errors, each channel divided by its noise level."""
        return self._errors(p, np.empty(2 * int(self.pos[-1])))

    def jac(self, p, f=None):
        """Forward differences of :meth:`fun` (``f``: its value at ``p``), in single
        precision (see :mod:`~unidyn.identification.least_squares`); a piece's
        initial velocities act on its own rows only, so they are varied one piece
        at a time."""
        f = self.fun(p) if f is None else f
        n, nd = int(self.pos[-1]), self.nd
        J = np.zeros((2 * n, p.size), dtype=np.float32)
        work = np.empty(2 * n)
        for i in range(p.size):
            if i < 6:
                h = 1e-7 * max(abs(p[i]), 1e-3)
            elif nd and i == 6:
                h = 1e-4 * self.dt_med
                h = h if p[i] + h <= self.ub[6] else -h
            else:
                h = 1e-7 * max(abs(p[i]), 1e-2)
            q = np.array(p, dtype=float)
            q[i] += h
            if i < 6 + nd:
                self._errors(q, work)
                work -= f
                work /= h
                J[:, i] = work
            else:
                s = (i - 6 - nd) // 2
                self._errors(q, work, which=s)
                for rows in (slice(self.pos[s], self.pos[s + 1]),
                             slice(n + self.pos[s], n + self.pos[s + 1])):
                    J[rows, i] = (work[rows] - f[rows]) / h
        return J

    def solve(self, p0, max_nfev):
        """Levenberg-Marquardt within the bounds, each parameter scaled by its
        column of the Jacobian (the Jacobian held once, in single precision: see
        :mod:`~unidyn.identification.least_squares`)."""
        x = levenberg_marquardt(self.fun, self.jac, p0, self.lb, self.ub, max_nfev=max_nfev)
        th, dl, _ = self.unpack(x)
        p = np.array(x)
        p[:6] = th       # a time constant below the explored limit is reported at it
        return p


def _oe_fit(D, segs, theta0, sig, linear, delay, est_delay, dt_med, v0=None,
            covariance=True, max_nfev=200, progress=None):
    """The output-error fit (see :func:`identify`). Returns a dict with theta,
    delay, v0, cost (sum of squared normalised errors), rms per channel, rows,
    residuals, and with ``covariance``: cov, conds, r2, whiteness, warnings,
    dead, delay_stderr."""
    prob = _OutputErrorProblem(D, segs, theta0, sig, linear, delay, est_delay, dt_med, v0)
    prob.progress = progress
    p = prob.solve(prob.p0, max_nfev)
    # a faster robot than the start needs more RK4 steps: refine once
    if step_length(p[:6], dt_med) < 0.8 * prob.hmax:
        prob.hmax = step_length(p[:6], dt_med)
        p = prob.solve(p, max_nfev)
    th, dl, vv = prob.unpack(p)
    S = prob.sim(p)
    R = prob.Y - S
    n = prob.idx.size
    rms = np.sqrt(np.sum(R * R, axis=0) / max(n - p.size / 2, 1))
    out = {"theta": th.copy(), "delay": float(dl), "v0": vv.copy(), "rows": prob.idx,
           "cost": float(np.sum((R / sig) ** 2)), "rms": rms, "sig": sig.copy(),
           "residuals": R}
    if covariance:
        out.update(_oe_covariance(prob, p, S, R, rms, th))
    return out


def _oe_covariance(prob, p, S, R, rms, th):
    """The covariance of p at the solution, s^2 (J^T J)^-1 with J weighted by
    each channel's residual level and s^2 the sum of squared normalised errors
    over 2 n - (number of parameters); Newey-West when the errors are not white.
    With the diagnostics read from the residuals: conds, r2, whiteness,
    warnings (correlated errors, saturation), dead, delay_stderr."""
    n, npar, nd = prob.idx.size, p.size, prob.nd
    J = prob.jac(p)
    # the channels' own noise levels, not the weights used to fit
    scale = prob.sig / np.maximum(rms, 1e-300)
    J[:n] *= scale[0]
    J[n:] *= scale[1]
    Z = R / rms                                   # normalised residuals
    rho, lb_q, white = _whiteness(Z, prob.pos)
    M = normal_equations(J)
    Minv, dead = _scaled_inverse(M)
    cov = Minv * (float(np.sum(Z * Z)) / max(2 * n - npar, 1))
    warns = []
    if not all(white):
        cov = _newey_west(cov, Minv, J, Z, prob, th)
        big = max(float(np.max(np.abs(r))) for r in rho)
        Y = prob.Y
        tiny = all(rms[c] < 1e-4 * max(float(np.std(Y[:, c])), 1e-300) for c in range(2))
        if big > 0.1 and not tiny:
            ch = " and ".join(k for k, ok in zip(("u", "w"), white) if not ok)
            warns.append(
                f"the velocity errors on {ch} are not white (autocorrelation up to "
                f"{big:.2f} within 10 samples): Eq. (2) with these commands leaves "
                f"dynamics unexplained (an input delay, see delay='auto'; the other command "
                f"convention; saturation or friction; filtered velocity measurements); the "
                f"intervals allow for correlated errors but the estimate may be biased")
    conds = []
    for c, cols in ((0, [0, 2, 3]), (1, [1, 4, 5])):
        # the condition number of the channel's columns, scaled to unit length, from
        # their normal matrix (its eigenvalues are the squared singular values)
        B = normal_equations(J[c * n:(c + 1) * n])[np.ix_(cols, cols)]
        nb = np.sqrt(np.diag(B))
        ev = np.linalg.eigvalsh(B / np.outer(*(2 * [np.where(nb > 0, nb, 1.0)])))
        conds.append(float(np.sqrt(ev[-1] / ev[0])) if ev[0] > 0 else math.inf)
    share = _information_share(J, Minv)
    del J
    sat, sat_warns = _saturation(S, R, prob.Y)
    warns += sat_warns
    r2 = []
    for c in range(2):
        Yc = prob.Y[:, c]
        ss = float(np.sum((Yc - Yc.mean()) ** 2))
        r2.append(1.0 - float(R[:, c] @ R[:, c]) / ss if ss > 0 else math.nan)
    cov[dead, :] = 0.0
    cov[:, dead] = 0.0
    cov[dead, dead] = math.inf
    return dict(cov=cov, conds=conds, r2=r2, whiteness=[float(q) for q in lb_q],
                warnings=warns, saturation=sat, share=share,
                dead=[i for i in np.flatnonzero(dead) if i < 6],
                delay_stderr=float(np.sqrt(max(cov[6, 6], 0.0))) if nd else 0.0)


def _information_share(J, Minv, chunk=1 << 16):
    """Per parameter of theta, the share of the rows its estimate rests on: the
    effective number (sum r^2)^2 / sum r^4 of the rows of r = J Minv[:, i] (the
    part of its Jacobian column that no other parameter's explains), over the
    number of rows. A parameter that only a few moments of the log excite (a blip
    in otherwise constant commands) has a small share: its interval, computed as
    if the model were exact at those few moments, is not to be trusted."""
    s2, s4 = np.zeros(6), np.zeros(6)
    C = Minv[:, :6]
    for s in range(0, J.shape[0], chunk):
        r = np.asarray(J[s:s + chunk], dtype=float) @ C
        r2 = r * r
        s2 += r2.sum(axis=0)
        s4 += (r2 * r2).sum(axis=0)
    return np.where(s4 > 0, s2 * s2 / np.where(s4 > 0, s4, 1.0), 0.0) / J.shape[0]


def _whiteness(Z, pos, L=10):
    """Per channel: the residual autocorrelations at lags 1..L within the
    pieces, the portmanteau statistic n sum rho^2, and whether it is below the
    95 % point of chi^2(L). Returns (rho, q, white)."""
    n = Z.shape[0]
    rho, lb_q, white = [], [], []
    for c in range(2):
        num = np.zeros(L)
        den = 0.0
        for s in range(len(pos) - 1):
            z = Z[pos[s]:pos[s + 1], c]
            den += float(z @ z)
            for lag in range(1, L + 1):
                if z.size > lag:
                    num[lag - 1] += float(z[lag:] @ z[:-lag])
        r_ = num / max(den, 1e-300)
        q = n * float(np.sum(r_ * r_))
        rho.append(r_)
        lb_q.append(q)
        white.append(q <= _WHITE_Q)
    return rho, lb_q, white


def _newey_west(cov, Minv, J, Z, prob, th):
    """The covariance allowing for correlated errors: Newey-West (Bartlett)
    over a few of the slower time constant, per channel and piece; each
    variance at least the white-noise one."""
    n, nd, npar = prob.idx.size, prob.nd, J.shape[1]
    tau = max(th[0] / th[3], th[1] / th[5])
    lag = int(min(max(4 * tau / prob.dt_med, 5), 200))
    Sm = np.zeros((npar, npar))
    for c in range(2):
        for s in range(len(prob.segs)):
            a, b = prob.pos[s], prob.pos[s + 1]
            # only theta, the delay and this piece's initial state act on its rows
            cols = list(range(6 + nd)) + [6 + nd + 2 * s, 7 + nd + 2 * s]
            g = J[c * n + a:c * n + b][:, cols] * Z[a:b, c][:, None]
            Sb = g.T @ g
            for k in range(1, min(lag, b - a - 1) + 1):
                G = g[k:].T @ g[:-k]
                Sb += (1.0 - k / (lag + 1.0)) * (G + G.T)
            Sm[np.ix_(cols, cols)] += Sb
    cov_nw = Minv @ Sm @ Minv
    return np.where(np.eye(npar, dtype=bool), np.maximum(np.diag(cov), np.diag(cov_nw)),
                    cov_nw)


def _saturation(S, R, Y):
    """Errors that grow with the size of the velocity (an odd nonlinearity: the
    cube of the simulated velocity, beyond its linear part): the correlation
    per channel and a warning for each channel below ``_SATURATION_CORR``."""
    sat, warns = [], []
    for c in range(2):
        f = S[:, c] ** 3     # beyond its linear part: less its regression on 1 and u (w)
        f -= np.mean(f)
        x = S[:, c] - np.mean(S[:, c])
        xx = float(x @ x)
        if xx > 0:
            f -= (float(x @ f) / xx) * x
        nf, nr = float(np.linalg.norm(f)), float(np.linalg.norm(R[:, c]))
        sat.append(float(f @ R[:, c]) / (nf * nr) if nf > 0 and nr > 0 else 0.0)
    for c, (k, unit) in enumerate((("u", "m/s"), ("w", "rad/s"))):
        if sat[c] < _SATURATION_CORR:
            big = float(np.max(np.abs(Y[:, c])))
            warns.append(
                f"the velocity errors on {k} shrink the robot's fast motion: they correlate "
                f"{sat[c]:.2f} with the cube of the fitted {k} (measured |{k}| up to {big:.3g} "
                f"{unit}), as when the motors or the firmware limit the speed or the command. "
                f"Eq. (2) has no such limit, so the fit trades accuracy at low speed for the "
                f"clipped peaks; identify on a log whose commands stay within the robot's reach "
                f"(see excitation()), or leave out the saturated stretches")
    return sat, warns


def _scaled_inverse(M, tol=1e-10):
    """The inverse of a normal matrix M = J^T J, computed on its column-scaled
    (correlation) form so that a parameter with small but real sensitivity
    gets its large variance rather than the near-zero one a pseudo-inverse of
    the unscaled M gives. Parameters with zero sensitivity, or in an (almost)
    exactly collinear combination (an eigenvalue of the scaled matrix below
    ``tol``), are not identifiable: they are returned in the mask ``dead``, and
    the inverse is taken over the others (their rows and columns are 0).
    Returns (inverse, dead mask)."""
    p = M.shape[0]
    d = np.sqrt(np.clip(np.diag(M), 0.0, None))
    dead = ~(d > 1e-150 * max(float(d.max()), 1e-300))
    for _ in range(p):
        live = np.flatnonzero(~dead)
        if live.size == 0:
            break
        Ms = M[np.ix_(live, live)] / np.outer(d[live], d[live])
        ev, V = np.linalg.eigh(Ms)
        if ev[0] >= tol * ev[-1]:
            break
        # the parameter that carries most of the null direction goes first
        dead[live[int(np.argmax(np.abs(V[:, 0])))]] = True
    Minv = np.zeros_like(M)
    live = np.flatnonzero(~dead)
    if live.size:
        Ms = M[np.ix_(live, live)] / np.outer(d[live], d[live])
        Minv[np.ix_(live, live)] = np.linalg.inv(Ms) / np.outer(d[live], d[live])
    return Minv, dead


def _equation_error(D, segs, smoothing, window, order, su, sw):
    """Eq. (11) by least squares over the segments long enough for the window
    (the original estimator; see the module docstring). Returns theta, cov,
    residuals, row times, condition numbers, R^2, warnings, window, and the
    u, w of the rows."""
    t = D["t"]
    spans = [(t[b - 1] - t[a], a, b) for a, b in segs]
    dt_med = float(np.median(np.concatenate([np.diff(t[a:b]) for a, b in segs])))
    span, a0, b0 = max(spans)
    if window is None and smoothing == "savgol":
        window = max(0.3, (order + 3) * dt_med)
    auto = window is None
    if auto:
        lo, hi = 12 * dt_med, span / 10
        if lo > span / 3:
            raise ValidationError(f"the longest piece of the log ({b0 - a0} samples over "
                                  f"{span:g} s) is too short for the filter's window of 12 "
                                  f"sampling intervals ({lo:g} s, at most a third of it)")
        hi = max(hi, lo)
        window = min(max(_AUTO_BAND / _command_band(t[a0:b0], D["u_ref"][a0:b0],
                                                    D["w_ref"][a0:b0], dt_med), lo), hi)
    if window > span / 3:
        raise ValidationError(f"window must be <= a third of the longest piece of the log "
                              f"({span / 3:g} s), got {window!r}")

    def usable(win):
        return [(a, b) for s_, a, b in spans if s_ >= 3 * win]

    fit = _solve(D, usable(window), smoothing, window, order, su, sw)
    if auto and smoothing == "filter":
        th = fit[0]
        if th[0] > 0 and th[1] > 0 and th[3] > 0 and th[5] > 0:
            tau = max(th[0] / th[3], th[1] / th[5])
            w2 = min(max(2.0 * tau, window), span / 10 if span / 10 > window else window)
            if w2 > 1.25 * window:
                window = w2
                fit = _solve(D, usable(window), smoothing, window, order, su, sw)
    return (fit[0], fit[1], fit[2], fit[3], fit[4], fit[5], fit[6], window, fit[7], fit[8])


def _solve(D, segs, smoothing, window, order, su, sw):
    """One least-squares solution of both rows of Eq. (11) with a given window,
    over the pieces ``segs`` of the log."""
    half = 0.5 * window
    Xs, ys, Es, ts, us, ws = [[], []], [[], []], [[], []], [], [], []
    use_E = smoothing == "filter" and (su > 0 or sw > 0)
    for a, b in segs:
        t, u_ref, w_ref, u, w = (D[k][a:b] for k in COLUMNS)
        if smoothing == "filter":
            yy, XX, interior, mom = _filter_regression(t, u_ref, w_ref, u, w, half)
            XX[:, 0, 1] += sw * sw          # E[(w + m)^2] = w^2 + sigma_w^2
            E = _noise_moments(mom, su * su, sw * sw) if use_E else None
            rows = [(XX[:, r, :], yy[:, r], None if E is None else E[:, r]) for r in (0, 1)]
        else:
            val, der, interior = _local_poly(t, np.stack([u, w], axis=1), half, order)
            XX = _eq11_columns(val, der)
            rows = [(XX[:, 0, :], u_ref, None), (XX[:, 1, :], w_ref, None)]
        keep = interior
        for r, (X, y, E) in enumerate(rows):
            Xs[r].append(X[keep])
            ys[r].append(y[keep])
            if E is not None:
                Es[r].append(E[keep])
        ts.append(t[keep])
        us.append(u[keep])
        ws.append(w[keep])
    nkeep = sum(x.size for x in ts)
    if nkeep < 20:
        raise ValidationError(f"only {nkeep} samples lie at least half a window "
                              f"({half:g} s) from the ends of the log's pieces; at least 20 are "
                              f"needed: use a longer log or a shorter window")
    dt_med = float(np.median(np.concatenate([np.diff(D["t"][a:b]) for a, b in segs])))
    lag = max(1, int(round(_LAG_WINDOWS * window / dt_med)))

    theta = np.zeros(6)
    cov = np.zeros((6, 6))
    resid = np.zeros((nkeep, 2))
    conds, r2, warns = [], [], []
    for row in range(2):
        X = np.concatenate(Xs[row])
        y = np.concatenate(ys[row])
        E = np.concatenate(Es[row]) if Es[row] else None
        params = _ROW_PARAMS[row]
        norms = np.linalg.norm(X, axis=0)
        dead = [_NAMES[params[j]] for j in range(3) if not norms[j] > 0]
        if dead:
            what = "u" if row == 0 else "w"
            raise ValidationError(
                f"the measured {what} gives a zero regressor column for {', '.join(dead)}: the "
                f"log has no {'linear' if row == 0 else 'angular'} motion to identify from")
        beta, c, r, cond, ok = _lstsq(X, y, lag, E)
        if not np.isfinite(cond) or cond > 1e10:
            raise ValidationError(
                f"the regression for {', '.join(_NAMES[p] for p in params)} is singular "
                f"(condition number {cond:.3g}): the log does not excite these parameters; "
                f"vary both commands, with turning at speed (see excitation())")
        if not ok:
            warns.append(f"the measurement noise (std {su:.3g} on u, {sw:.3g} on w) is too large "
                         f"for the filtered signals of row {row + 1}: the noise-bias correction "
                         f"was skipped and {', '.join(_NAMES[p] for p in params)} are biased "
                         f"towards zero; use a wider window or a longer, stronger excitation")
        theta[list(params)] = beta
        cov[np.ix_(params, params)] = c
        resid[:, row] = r
        conds.append(cond)
        ss = float(np.sum((y - y.mean()) ** 2))
        r2.append(1.0 - float(r @ r) / ss if ss > 0 else math.nan)
    return (theta, cov, resid, np.concatenate(ts), conds, r2, warns, np.concatenate(us),
            np.concatenate(ws))


def _command_band(t, u_ref, w_ref, dt) -> float:
    """The frequency (Hz) below which 95 % of the power of the command rates
    u_ref' and w_ref' lies (the larger of the two), from their spectra on a
    uniform grid."""
    n = int(min(2 ** 20, max(64, round((t[-1] - t[0]) / dt) + 1)))
    tu = np.linspace(t[0], t[-1], n)
    h = tu[1] - tu[0]
    out = 0.0
    for c in (u_ref, w_ref):
        x = np.gradient(np.interp(tu, t, c), h)
        p = np.abs(np.fft.rfft((x - x.mean()) * np.hanning(n))) ** 2
        cum = np.cumsum(p)
        if cum[-1] > 0:
            k = int(np.searchsorted(cum, 0.95 * cum[-1]))
            out = max(out, (k + 0.5) / (n * h))
    return out if out > 0 else 1.0


def _pair(name, value):
    v = np.atleast_1d(np.asarray(value, dtype=float)) if not isinstance(value, (str, bytes)) \
        else np.array([])
    if v.ndim != 1 or v.size not in (1, 2) or not np.all(np.isfinite(v)) or np.any(v < 0):
        raise ValidationError(f"{name} must be None, a number >= 0 or a pair (on u, on w) of "
                              f"numbers >= 0, got {value!r}")
    return (float(v[0]), float(v[-1]))


def _check_excitation(u_ref, w_ref):
    for k, v, unit, params in (("u_ref", u_ref, "m/s", "theta1, theta3, theta4"),
                               ("w_ref", w_ref, "rad/s", "theta2, theta5, theta6")):
        spread = float(np.ptp(v))
        if spread <= 1e-9 * max(1.0, float(np.max(np.abs(v)))):
            raise ValidationError(
                f"log column {k!r} is constant ({v[0]:g} {unit}) throughout: no excitation, "
                f"{params} cannot be identified; vary the command (see excitation())")


def _check_physical(theta, stderr):
    bad = [(k, theta[i], stderr[i]) for i, k in enumerate(_NAMES)
           if i in (0, 1, 3, 5) and not theta[i] > 0]
    if bad:
        desc = ", ".join(f"{k} = {v:.4g} (stderr {s:.2g})" for k, v, s in bad)
        raise ValidationError(
            f"identified {desc}: theta1, theta2, theta4 and theta6 must be > 0 for any physical "
            f"robot (Section 2). Likely causes: commands and measured velocities swapped or in "
            f"different units or signs, a time stamp offset between them, saturated commands "
            f"or accelerations, or too little excitation; check the log and its columns")


def _warnings(theta, stderr, conds, u, w, dt, rel_max) -> list:
    out = []
    rms = lambda a: float(np.sqrt(np.mean(np.square(a))))  # noqa: E731
    w2, uw = _coupling(u, w)
    turning = (f"rms(w^2) = {rms(w2):.3g} rad²/s², rms(u*w) = {rms(uw):.3g} "
               f"m·rad/s², "
               f"rms(u) = {rms(u):.3g} m/s, rms(w) = {rms(w):.3g} rad/s")
    for i, term in ((2, "-w^2 (centripetal)"), (4, "u*w (Coriolis)")):
        k = _NAMES[i]
        if not stderr[i] <= rel_max * abs(theta[i]):
            half = _Z95 * stderr[i]
            what = ("is not distinguishable from zero" if half >= abs(theta[i]) else
                    f"is poorly determined (+/- {100 * half / abs(theta[i]):.0f} %)")
            out.append(
                f"{k} is unidentified: {theta[i]:.3g} +/- {half:.2g} (95 %) {what}. Either the "
                f"centre of mass is close to the wheel axle (b ~ 0, so {k} ~ 0), or the log has "
                f"too little turning at speed to excite the {term} term ({turning}); excite "
                f"with simultaneous linear and angular speed (see excitation()) before relying "
                f"on {k}")
    for row, c in enumerate(conds):
        if c > 1e4:
            ps = ", ".join(_NAMES[p] for p in _ROW_PARAMS[row])
            out.append(f"the regression for {ps} is ill-conditioned (condition number {c:.3g} "
                       f"after column scaling): their estimates are strongly correlated")
    for i in (3, 5):
        if theta[i] < 0.8:
            out.append(f"{_NAMES[i]} = {theta[i]:.4g} is well below 1; Section 2 gives "
                       f"{_NAMES[i]} = 1 + (Ra/ka)(ka kb/Ra + Be)(...) >= 1 (identified sets "
                       f"reach 0.956): check the scale of the measured velocities against "
                       f"the commands")
    for i, j in ((0, 3), (1, 5)):
        tau = theta[i] / theta[j] if theta[j] > 0 else math.nan
        if tau <= 1.05 * TAU_MIN_SAMPLES * dt:
            out.append(f"the time constant {_NAMES[i]}/{_NAMES[j]} is not resolvable at this "
                       f"sampling rate: the fit reached the shortest one it explores, "
                       f"{tau:.3g} s (1/{1 / TAU_MIN_SAMPLES:g} of the {dt:g} s sample "
                       f"interval), so the response settles within one sample; {_NAMES[i]} "
                       f"is only known to be about this small or smaller (its interval is "
                       f"not meaningful): log faster to identify it")
        elif tau < 2 * dt:
            out.append(f"the time constant {_NAMES[i]}/{_NAMES[j]} = {tau:.3g} s is shorter "
                       f"than two sampling intervals (2 x {dt:g} s): the log barely resolves "
                       f"it, so {_NAMES[i]} rests on the command convention and delay being "
                       f"right; log faster if you can")
    for i, j in ((0, 3), (1, 5)):
        tau = max(theta[i], theta[i] / theta[j] if theta[j] > 0 else 0.0)
        if tau > MAX_TIME_CONSTANT:
            unit = next((u for u in ("ms", "us", "ns") if tau * TIME_UNITS[u] <= 10.0), "ns")
            # time in another unit also shows as steps that, in that unit, are a robot's
            # sampling (at most 10 kHz); a log at a robot's rate read in seconds is not
            # in another unit: the log, not its unit, is what is wrong
            why = (f"is t in {_UNIT_NAMES[unit]}? pass time_unit='{unit}'"
                   if dt * TIME_UNITS[unit] >= _MIN_STEP
                   else "the log does not determine it: check that the measured velocities "
                        "respond to the commands (units, signs, the frame of the odometry) "
                        "and that the commands vary (see excitation())")
            out.append(f"{_NAMES[i]} = {theta[i]:.4g} s and {_NAMES[i]}/{_NAMES[j]} = "
                       f"{theta[i] / theta[j]:.4g} s: a time constant over "
                       f"{MAX_TIME_CONSTANT:g} s is implausible for a wheeled robot (tenths of a "
                       f"second to seconds); {why}")
    for i in (0, 1):
        if theta[i] > 0 and 2 * stderr[i] > theta[i]:
            out.append(f"{_NAMES[i]} = {theta[i]:.3g} s has a standard error of "
                       f"{stderr[i]:.2g} s: the log has too little acceleration to "
                       f"identify it")
    return out


def _with_validation(res, D, segs):
    from dataclasses import replace
    rep = validation_report(res.theta, D, segs, res.commands, res.delay)
    return replace(res, validation=rep)
