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

The workflow, all pure numpy/scipy (nothing here imports bdsim)::

    >>> from unidyn import identification as ident
    >>> exc = ident.excitation(90.0, 0.01, robot="p3dx")      # design the commands
    >>> log = ident.simulate_log("p3dx", exc, noise_std=0.01)  # or log a real robot
    >>> fit, test = ident.split_log(log, 60.0)                # estimation / held-out
    >>> res = ident.identify(fit)
    >>> res.theta.theta1                      # true 0.5338     # doctest: +SKIP
    0.5354...
    >>> ident.validate(res, test).fit         # NRMSE fit, %   # doctest: +SKIP
    {'u': 81.9..., 'w': 95.0...}
    >>> print(res.summary())                  # table, warnings  # doctest: +SKIP
    >>> res.save("out/p3dx")                  # out/p3dx/theta.json  # doctest: +SKIP

``theta.json`` is read back by ``unidyn.robots.resolve("out/p3dx/theta.json")``.

Why the velocity derivatives need care
--------------------------------------
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

import csv
import json
import math
import os
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from . import robots
from ._validate import ValidationError, choice, nonnegative, positive, real, vector
from .model import NO_LIMITS, PAPER_LIMITS, Limits, unicycle_deriv
from .parameters import RobotParameters

__all__ = ["IdentificationResult", "ValidationReport", "identify", "load_log", "excitation",
           "simulate_log", "split_log", "validate", "plot_validation", "COLUMNS",
           "SMOOTHING_METHODS"]

#: The canonical column names of a log.
COLUMNS = ("t", "u_ref", "w_ref", "u", "w")
#: The ways of handling the velocity derivatives (see the module docstring).
SMOOTHING_METHODS = ("filter", "savgol")
_NAMES = ("theta1", "theta2", "theta3", "theta4", "theta5", "theta6")
# The rows of Eq. (11): which parameters each decoupled problem estimates.
_ROW_PARAMS = ((0, 2, 3), (1, 4, 5))
_Z95 = 1.959963984540054
# Newey-West lag, in windows: filtered residuals are correlated over about one window
_LAG_WINDOWS = 1.0
# automatic filter window = _AUTO_BAND / (the commands' 95 % band, Hz)
_AUTO_BAND = 1.2


# --------------------------------------------------------------------------- logs

def _column_map(columns) -> dict:
    if columns is None:
        return {k: k for k in COLUMNS}
    if not isinstance(columns, Mapping):
        raise ValidationError(f"columns must be a mapping from {', '.join(COLUMNS)} to the "
                              f"log's column names, got {columns!r}")
    unknown = [k for k in columns if k not in COLUMNS]
    if unknown:
        raise ValidationError(f"columns: unknown key(s) {', '.join(map(repr, unknown))}; "
                              f"allowed keys are {', '.join(COLUMNS)}")
    out = {k: k for k in COLUMNS}
    for k, v in columns.items():
        if not isinstance(v, str):
            raise ValidationError(f"columns[{k!r}] must be a column name (str), got {v!r}")
        out[k] = v
    return out


def _read_csv(path: Path) -> dict:
    try:
        with open(path, newline="") as fh:
            rows = list(csv.reader(fh))
    except OSError as err:
        raise ValidationError(f"log: cannot read {path}: {err}") from None
    rows = [r for r in rows if r and any(c.strip() for c in r)]
    if not rows:
        raise ValidationError(f"log: {path} is empty; expected a header row naming the columns")
    header = [h.strip() for h in rows[0]]
    data = {h: [] for h in header}
    for lineno, row in enumerate(rows[1:], start=2):
        if len(row) != len(header):
            raise ValidationError(f"log: {path} line {lineno} has {len(row)} fields, the header "
                                  f"has {len(header)}")
        for h, cell in zip(header, row):
            try:
                data[h].append(float(cell))
            except ValueError:
                raise ValidationError(f"log: {path} line {lineno}, column {h!r}: {cell!r} is "
                                      f"not a number") from None
    return data


def _get_columns(log) -> tuple[dict | None, object, str]:
    """(mapping or None, object, description) of a log's raw columns."""
    if isinstance(log, (str, os.PathLike)):
        path = Path(log)
        return _read_csv(path), None, f"CSV file {path}"
    if isinstance(log, np.ndarray):
        if log.dtype.names is None:
            raise ValidationError("log: a numpy array must be a structured array with named "
                                  f"fields ({', '.join(COLUMNS)}), got dtype {log.dtype}")
        return {n: log[n] for n in log.dtype.names}, None, "structured array"
    if isinstance(log, Mapping) or (hasattr(log, "keys") and hasattr(log, "__getitem__")):
        return {k: log[k] for k in log.keys()}, None, "mapping"
    return None, log, type(log).__name__


def load_log(log, columns=None) -> dict:
    """Read and check a log; return a dict of 1-D float arrays t, u_ref, w_ref, u, w.

    :param log: a mapping (dict, pandas DataFrame, npz file) or an object with
        attributes, holding arrays t (s), u_ref (m/s), w_ref (rad/s), u (m/s) and
        w (rad/s); a numpy structured array with those fields; or the path of a
        CSV file whose first row names the columns
    :param columns: optional mapping from the names above to the log's own
        column names, e.g. ``{"u": "v_meas", "w": "omega_meas"}``
    :raises ValidationError: for a missing column (all are named), columns of
        different lengths, NaN or inf, time that is not strictly increasing
        (repeated or going back), or fewer than 20 samples
    """
    cmap = _column_map(columns)
    data, obj, what = _get_columns(log)
    available = list(data) if data is not None else [k for k in dir(obj) if not k.startswith("_")]
    missing = [f"{k!r}" + (f" (as {cmap[k]!r})" if cmap[k] != k else "")
               for k in COLUMNS if (cmap[k] not in data if data is not None
                                    else not hasattr(obj, cmap[k]))]
    if missing:
        raise ValidationError(f"log ({what}) is missing column(s) {', '.join(missing)}; "
                              f"it has {', '.join(map(repr, available)) or 'no columns'}. "
                              f"Pass columns={{...}} to map other names")
    out = {}
    n = None
    for k in COLUMNS:
        raw = data[cmap[k]] if data is not None else getattr(obj, cmap[k])
        try:
            arr = np.asarray(raw, dtype=float)
        except (TypeError, ValueError):
            raise ValidationError(f"log column {k!r} must hold numbers") from None
        if arr.ndim != 1:
            arr = arr.reshape(-1) if arr.size == max(arr.shape, default=0) else arr
        if arr.ndim != 1:
            raise ValidationError(f"log column {k!r} must be one-dimensional, got shape "
                                  f"{arr.shape}")
        bad = np.flatnonzero(~np.isfinite(arr))
        if bad.size:
            raise ValidationError(f"log column {k!r} has {bad.size} NaN/inf value(s), first at "
                                  f"sample {bad[0]} ({arr[bad[0]]!r}); all values must be finite")
        if n is None:
            n = arr.size
        elif arr.size != n:
            raise ValidationError(f"log columns must have equal lengths: {k!r} has {arr.size} "
                                  f"samples, 't' has {n}")
        out[k] = arr.copy()
    if n < 20:
        raise ValidationError(f"log has {n} samples; at least 20 are needed")
    dt = np.diff(out["t"])
    if np.any(dt <= 0):
        k = int(np.flatnonzero(dt <= 0)[0])
        kind = "repeated" if dt[k] == 0 else "going back"
        raise ValidationError(f"log time 't' must be strictly increasing; it is {kind} at "
                              f"sample {k + 1}: t[{k}] = {out['t'][k]!r}, t[{k + 1}] = "
                              f"{out['t'][k + 1]!r}")
    return out


def split_log(log, t_split: float, columns=None) -> tuple[dict, dict]:
    """Split a log at time ``t_split``: (samples with t < t_split, samples with t >= t_split).

    Use the first part to identify and the second, held out, to :func:`validate`.
    """
    d = load_log(log, columns)
    t_split = real("t_split", t_split, low=d["t"][0], high=d["t"][-1], low_open=True,
                   high_open=True)
    m = d["t"] < t_split
    extra = {k: np.asarray(v) for k, v in (log.items() if isinstance(log, Mapping) else [])
             if k not in COLUMNS and np.ndim(v) >= 1 and len(v) == m.size}
    first = {k: v[m] for k, v in {**d, **extra}.items()}
    second = {k: v[~m] for k, v in {**d, **extra}.items()}
    return first, second


# ------------------------------------------------------------ filtering and fitting

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
    ww, uw = w * w, u * w
    interior = None
    for sl, ii, A, D, interior in _filter_weights(t, half):
        ui, wi = u[ii], w[ii]
        y[sl, 0] = np.einsum("nm,nm->n", A, u_ref[ii])
        y[sl, 1] = np.einsum("nm,nm->n", A, w_ref[ii])
        X[sl, 0, 0] = np.einsum("nm,nm->n", D, ui)
        X[sl, 0, 1] = -np.einsum("nm,nm->n", A, ww[ii])
        X[sl, 0, 2] = np.einsum("nm,nm->n", A, ui)
        X[sl, 1, 0] = np.einsum("nm,nm->n", D, wi)
        X[sl, 1, 1] = np.einsum("nm,nm->n", A, uw[ii])
        X[sl, 1, 2] = np.einsum("nm,nm->n", A, wi)
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
    X = np.empty((n, 2, 3))
    X[:, 0, 0] = conv(u, D)
    X[:, 0, 1] = -conv(w * w, A)
    X[:, 0, 2] = conv(u, A)
    X[:, 1, 0] = conv(w, D)
    X[:, 1, 1] = conv(u * w, A)
    X[:, 1, 2] = conv(w, A)
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


# -------------------------------------------------------------------- the result

@dataclass(frozen=True)
class IdentificationResult:
    """What :func:`identify` found.

    :param theta: the identified parameters
    :param stderr: standard errors of theta1..theta6 (Newey-West corrected LS covariance)
    :param ci95: 95 % confidence intervals, shape (6, 2), theta -/+ 1.96 stderr
    :param residuals: equation errors of the two rows, shape (N, 2), in the units
        of u_ref and w_ref (filtered, for ``smoothing="filter"``)
    :param t: the times of the N regression rows, s
    :param condition_numbers: condition numbers of the two column-scaled regressors
        (row 1: theta1, theta3, theta4; row 2: theta2, theta5, theta6)
    :param warnings: plain-language problems found (poor excitation, non-physical values)
    :param smoothing: ``"filter"`` or ``"savgol"``
    :param window: the filter / fit window, s
    :param order: polynomial degree of the Savitzky-Golay fit (``None`` for the filter)
    :param n_samples: the number of regression rows N
    :param fit_r2: coefficient of determination of each row's regression, in [0, 1]
    :param noise_std: the std of the measurement noise on u and w used in the
        noise-bias correction (estimated from the log unless given)
    """

    theta: RobotParameters
    stderr: np.ndarray
    ci95: np.ndarray
    residuals: np.ndarray
    t: np.ndarray
    condition_numbers: tuple
    warnings: list = field(default_factory=list)
    smoothing: str = "filter"
    window: float = 1.0
    order: int | None = None
    n_samples: int = 0
    fit_r2: tuple = (math.nan, math.nan)
    noise_std: tuple = (0.0, 0.0)

    @property
    def theta_vector(self) -> np.ndarray:
        """theta1..theta6 as an array."""
        return self.theta.theta

    def relative_stderr(self) -> np.ndarray:
        """stderr / |theta| (inf where theta is 0)."""
        th = np.abs(self.theta.theta)
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.where(th > 0, self.stderr / th, np.inf)

    def as_dict(self) -> dict:
        """A JSON-ready dict: theta1..theta6 and name at the top level (as
        :func:`unidyn.robots.resolve` reads them from a ``.json`` file), plus the
        standard errors, intervals, condition numbers, warnings and settings."""
        def num(x):
            x = float(x)
            return x if math.isfinite(x) else None
        d = {k: float(v) for k, v in zip(_NAMES, self.theta.theta)}
        d["name"] = self.theta.name
        d["source"] = self.theta.source
        d["stderr"] = {k: num(v) for k, v in zip(_NAMES, self.stderr)}
        d["ci95"] = {k: [num(lo), num(hi)] for k, (lo, hi) in zip(_NAMES, self.ci95)}
        d["condition_numbers"] = [num(c) for c in self.condition_numbers]
        d["fit_r2"] = [num(c) for c in self.fit_r2]
        d["warnings"] = list(self.warnings)
        d["smoothing"] = self.smoothing
        d["window"] = float(self.window)
        d["order"] = self.order
        d["n_samples"] = int(self.n_samples)
        d["noise_std"] = [num(x) for x in self.noise_std]
        return d

    def save(self, folder) -> Path:
        """Write ``theta.json`` (see :meth:`as_dict`) into ``folder`` (created if
        needed) and return its path."""
        folder = Path(folder)
        folder.mkdir(parents=True, exist_ok=True)
        path = folder / "theta.json"
        path.write_text(json.dumps(self.as_dict(), indent=2, allow_nan=False) + "\n")
        return path

    def summary(self) -> str:
        """A readable table of the estimates."""
        lines = [f"{'':8s} {'estimate':>12s} {'stderr':>10s} {'95% CI':>27s}"]
        for k, v, s, (lo, hi) in zip(_NAMES, self.theta.theta, self.stderr, self.ci95):
            lines.append(f"{k:8s} {v:12.6g} {s:10.3g} [{lo:12.6g}, {hi:12.6g}]")
        lines.append(f"condition numbers: {self.condition_numbers[0]:.3g}, "
                     f"{self.condition_numbers[1]:.3g}; R^2: {self.fit_r2[0]:.6f}, "
                     f"{self.fit_r2[1]:.6f}")
        lines += [f"warning: {w}" for w in self.warnings]
        return "\n".join(lines)


# ------------------------------------------------------------------ identification

def identify(log, smoothing: str = "filter", window: float | None = None, order: int = 3,
             noise_std=None, columns=None, name: str = "identified",
             rel_stderr_max: float = 0.25) -> IdentificationResult:
    r"""Least-squares estimate of theta from a log, Eq. (11), as two decoupled problems.

    Row 1, :math:`u_{ref} = \theta_1\dot u - \theta_3 w^2 + \theta_4 u`, gives
    theta1, theta3, theta4; row 2, :math:`w_{ref} = \theta_2\dot w + \theta_5 u w +
    \theta_6 w`, gives theta2, theta5, theta6. See the module docstring for how
    the derivatives are handled and why.

    :param log: t (s), u_ref (m/s), w_ref (rad/s), u (m/s), w (rad/s): a mapping,
        structured array, object with attributes or CSV path (see :func:`load_log`).
        Time may be uniform or irregular. The commands are taken as the values in
        force at each time stamp; the velocities may be noisy.
    :param smoothing: ``"filter"`` (default; the same zero-phase low-pass filter on
        both sides of Eq. (11)) or ``"savgol"`` (local polynomial fit of the
        velocities and their slopes on the time grid)
    :param window: total width of the filter kernel or of the fit window, s, > 0,
        at most a third of the log. ``None`` (default): automatic for the filter
        (see the module docstring; about 1.2 s for 1 Hz commands), and
        max(0.3 s, (order + 3) samples) for ``"savgol"``. It must hold at least 7
        (filter) or order + 2 (fit) samples everywhere. A wider filter passes less
        noise but also less of the excitation (gain 0.5 at about 1.2 / window Hz);
        the fit's window must stay short compared to the motion
    :param order: degree of the local polynomial for ``"savgol"``, 2..6
    :param noise_std: std of the white noise on the measured u and w, used by the
        filter's noise-bias correction: ``None`` (default) estimates it from the
        log; a number or a pair (on u, on w) gives it; 0 switches the correction off
    :param columns: mapping from t, u_ref, w_ref, u, w to the log's own names
    :param name: the name given to the identified :class:`RobotParameters`
    :param rel_stderr_max: theta3 or theta5 with a standard error above this
        fraction of its magnitude (default 0.25: a 95 % interval wider than about
        +/- 50 %) is reported as unidentified in ``warnings``, > 0
    :raises ValidationError: for a bad log (see :func:`load_log`), constant
        commands or no motion (nothing to identify), a window that does not fit the
        log, or a non-positive theta1, theta2, theta4 or theta6 (no physical robot
        has one; the message lists the likely causes)
    :return: :class:`IdentificationResult`
    """
    smoothing = choice("smoothing", smoothing, SMOOTHING_METHODS)
    if isinstance(order, bool) or not isinstance(order, (int, np.integer)) or not 2 <= order <= 6:
        raise ValidationError(f"order must be an integer in 2..6, got {order!r}")
    order = int(order)
    auto = window is None
    if not auto:
        window = positive("window", window)
    rel_stderr_max = positive("rel_stderr_max", rel_stderr_max)
    if not isinstance(name, str):
        raise ValidationError(f"name must be a string, got {name!r}")
    d = load_log(log, columns)
    t, u_ref, w_ref, u, w = (d[k] for k in COLUMNS)
    _check_excitation(u_ref, w_ref)
    span = t[-1] - t[0]
    dt_med = float(np.median(np.diff(t)))
    if noise_std is None:
        su, sw = _noise_std(t, u), _noise_std(t, w)
    else:
        su, sw = _pair("noise_std", noise_std)

    if auto and smoothing == "savgol":
        window = max(0.3, (order + 3) * dt_med)
    elif auto:
        # pass the commands' band, then widen to twice the slower time constant
        lo, hi = 12 * dt_med, span / 10
        if lo > span / 3:
            raise ValidationError(f"log of {t.size} samples over {span:g} s is too short for "
                                  f"the filter's window of 12 sampling intervals "
                                  f"({lo:g} s, at most a third of the log)")
        hi = max(hi, lo)
        window = min(max(_AUTO_BAND / _command_band(t, u_ref, w_ref, dt_med), lo), hi)
        fit = _solve(d, smoothing, window, order, su, sw)
        th = fit[0]
        if th[0] > 0 and th[1] > 0 and th[3] > 0 and th[5] > 0:
            tau = max(th[0] / th[3], th[1] / th[5])
            w2 = min(max(2.0 * tau, window), hi)
            if w2 > 1.25 * window:
                window = w2
                fit = _solve(d, smoothing, window, order, su, sw)
    if not auto or smoothing == "savgol":
        if window > span / 3:
            raise ValidationError(f"window must be <= a third of the log's duration "
                                  f"({span / 3:g} s), got {window!r}")
        fit = _solve(d, smoothing, window, order, su, sw)
    theta, cov, resid, keep, conds, r2, warns = fit
    stderr = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    ci95 = np.stack([theta - _Z95 * stderr, theta + _Z95 * stderr], axis=1)

    _check_physical(theta, stderr)
    warns = warns + _warnings(theta, stderr, conds, u[keep], w[keep], dt_med, rel_stderr_max)
    params = RobotParameters(*theta.tolist(), name=name,
                             source=f"identified from {t.size} samples ({t[0]:g}..{t[-1]:g} s), "
                                    f"smoothing={smoothing!r}, window={window:g} s")
    return IdentificationResult(theta=params, stderr=stderr, ci95=ci95, residuals=resid,
                                t=t[keep], condition_numbers=tuple(conds), warnings=warns,
                                smoothing=smoothing, window=window,
                                order=order if smoothing == "savgol" else None,
                                n_samples=int(keep.sum()), fit_r2=tuple(r2),
                                noise_std=(su, sw))


def _solve(d, smoothing, window, order, su, sw):
    """One least-squares solution of both rows of Eq. (11) with a given window."""
    t, u_ref, w_ref, u, w = (d[k] for k in COLUMNS)
    half = 0.5 * window
    if smoothing == "filter":
        yy, XX, interior, mom = _filter_regression(t, u_ref, w_ref, u, w, half)
        XX[:, 0, 1] += sw * sw          # E[(w + m)^2] = w^2 + sigma_w^2
        E = _noise_moments(mom, su * su, sw * sw) if su > 0 or sw > 0 else None
        rows = [(XX[:, r, :], yy[:, r], None if E is None else E[:, r]) for r in (0, 1)]
    else:
        val, der, interior = _local_poly(t, np.stack([u, w], axis=1), half, order)
        us, ws = val[:, 0], val[:, 1]
        rows = [(np.stack([der[:, 0], -ws * ws, us], axis=1), u_ref, None),
                (np.stack([der[:, 1], us * ws, ws], axis=1), w_ref, None)]
    keep = interior
    if keep.sum() < 20:
        raise ValidationError(f"only {int(keep.sum())} samples lie at least half a window "
                              f"({half:g} s) from the ends of the log; at least 20 are needed: "
                              f"use a longer log or a shorter window")
    dt_med = float(np.median(np.diff(t)))
    lag = max(1, int(round(_LAG_WINDOWS * window / dt_med)))

    theta = np.zeros(6)
    cov = np.zeros((6, 6))
    resid = np.zeros((int(keep.sum()), 2))
    conds, r2, warns = [], [], []
    for row, (X, y, E) in enumerate(rows):
        X, y = X[keep], y[keep]
        E = None if E is None else E[keep]
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
    return theta, cov, resid, keep, conds, r2, warns


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
    turning = (f"rms(w^2) = {rms(w * w):.3g} rad²/s², rms(u*w) = {rms(u * w):.3g} m·rad/s², "
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
    for i in (0, 1):
        if theta[i] < 2 * dt:
            out.append(f"{_NAMES[i]} = {theta[i]:.3g} s is shorter than two sampling "
                       f"intervals ({dt:g} s): the log cannot resolve this time constant")
        if theta[i] > 0 and 2 * stderr[i] > theta[i]:
            out.append(f"{_NAMES[i]} = {theta[i]:.3g} s has a standard error of "
                       f"{stderr[i]:.2g} s: the log has too little acceleration to "
                       f"identify it")
    return out


# -------------------------------------------------------------------- excitation

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
    :param limits: :class:`unidyn.model.Limits` to respect (speed limits must be
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
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise ValidationError(f"seed must be an integer >= 0, got {seed!r}")
    amplitude = real("amplitude", amplitude, low=0.0, high=1.0, low_open=True)
    if isinstance(limits, Mapping):
        limits = Limits(**limits)
    if not isinstance(limits, Limits):
        raise ValidationError(f"limits must be a unidyn.model.Limits, got {limits!r}")
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
        if isinstance(n_freq, bool) or not isinstance(n_freq, (int, np.integer)) or n_freq < 1:
            raise ValidationError(f"n_freq must be an integer >= 1, got {n_freq!r}")
        if isinstance(crest_iterations, bool) or \
                not isinstance(crest_iterations, (int, np.integer)) or crest_iterations < 0:
            raise ValidationError(f"crest_iterations must be an integer >= 0, "
                                  f"got {crest_iterations!r}")
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


# -------------------------------------------------------------------- simulation

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
                 limits: Limits = NO_LIMITS) -> dict:
    r"""Simulate the dynamic model, Eqs. (1)-(2) with a = 0, and log it like a robot.

    The commands are interpolated between their samples by a cubic spline through
    them (smooth, and equal to the logged command at every time stamp), and the
    model :func:`unidyn.model.unicycle_deriv` is integrated by
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
    :return: dict with t, u_ref, w_ref, u, w (measured), and the noise-free
        u_true, w_true, x, y, psi
    """
    rp = robots.resolve(robot, "robot")
    noise_std = nonnegative("noise_std", noise_std)
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise ValidationError(f"seed must be an integer >= 0, got {seed!r}")
    if not isinstance(limits, Limits):
        raise ValidationError(f"limits must be a unidyn.model.Limits, got {limits!r}")
    need = ("t", "u_ref", "w_ref")
    if not isinstance(excitation, Mapping) or any(k not in excitation for k in need):
        have = list(excitation) if isinstance(excitation, Mapping) else type(excitation).__name__
        raise ValidationError(f"excitation must be a mapping with t, u_ref and w_ref (as from "
                              f"excitation()), got {have}")
    n = int(np.size(excitation["t"]))
    try:
        d = load_log({**{k: excitation[k] for k in need}, "u": np.zeros(n), "w": np.zeros(n)})
    except ValidationError as err:
        raise ValidationError(f"excitation: {err}") from None
    x0 = np.zeros(5) if x0 is None else vector("x0", x0, 5)
    X = _simulate(rp.theta, d["t"], d["u_ref"], d["w_ref"], x0, limits)
    rng = np.random.default_rng(seed)
    noise = noise_std * rng.standard_normal((d["t"].size, 2)) if noise_std > 0 else 0.0
    v = X[:, 3:5] + noise
    return {"t": d["t"], "u_ref": d["u_ref"], "w_ref": d["w_ref"], "u": v[:, 0], "w": v[:, 1],
            "u_true": X[:, 3], "w_true": X[:, 4], "x": X[:, 0], "y": X[:, 1], "psi": X[:, 2]}


# -------------------------------------------------------------------- validation

@dataclass(frozen=True)
class ValidationReport:
    """How well a model reproduces a log when simulated from its commands.

    :param theta: the model simulated
    :param t: time, s
    :param u, w: measured velocities (the log)
    :param u_sim, w_sim: simulated velocities
    :param u_ref, w_ref: the logged commands the simulation was driven by
    :param fit: NRMSE fit per channel, %, 100 (1 - ||y - yhat|| / ||y - mean(y)||)
        (100 is perfect; 0 is no better than the mean; can be negative)
    :param rmse: root-mean-square error per channel (m/s, rad/s)
    """

    theta: RobotParameters
    t: np.ndarray
    u: np.ndarray
    w: np.ndarray
    u_sim: np.ndarray
    w_sim: np.ndarray
    u_ref: np.ndarray
    w_ref: np.ndarray
    fit: dict
    rmse: dict

    def as_dict(self) -> dict:
        """Fit numbers only, JSON-ready."""
        return {"name": self.theta.name, "fit": dict(self.fit), "rmse": dict(self.rmse)}


def _nrmse_fit(y, yhat) -> float:
    den = float(np.linalg.norm(y - np.mean(y)))
    if den == 0:
        return math.nan
    return 100.0 * (1.0 - float(np.linalg.norm(y - yhat)) / den)


def validate(theta, log, columns=None, v0=None, limits: Limits = NO_LIMITS) -> ValidationReport:
    r"""Simulate a model from a log's commands and compare with its measured velocities.

    Use a held-out log (not the one identified from; see :func:`split_log`). The
    commands are interpolated as in :func:`simulate_log`; the simulation starts
    from ``v0`` or, by default, from the first measured velocities.

    :param theta: an :class:`IdentificationResult`, :class:`RobotParameters`,
        robot name or six numbers
    :param log: as for :func:`identify`
    :param columns: as for :func:`identify`
    :param v0: initial [u, w]
    :param limits: limits applied inside the model, as in :func:`simulate_log`
    :return: :class:`ValidationReport` with NRMSE fit (%) and RMSE per channel
    """
    if isinstance(theta, IdentificationResult):
        theta = theta.theta
    rp = robots.resolve(theta, "theta")
    if not isinstance(limits, Limits):
        raise ValidationError(f"limits must be a unidyn.model.Limits, got {limits!r}")
    d = load_log(log, columns)
    if v0 is None:
        v0 = [d["u"][0], d["w"][0]]
    else:
        v0 = vector("v0", v0, 2)
    x0 = np.array([0.0, 0.0, 0.0, v0[0], v0[1]])
    X = _simulate(rp.theta, d["t"], d["u_ref"], d["w_ref"], x0, limits)
    fit = {"u": _nrmse_fit(d["u"], X[:, 3]), "w": _nrmse_fit(d["w"], X[:, 4])}
    rmse = {"u": float(np.sqrt(np.mean((d["u"] - X[:, 3]) ** 2))),
            "w": float(np.sqrt(np.mean((d["w"] - X[:, 4]) ** 2)))}
    return ValidationReport(theta=rp, t=d["t"], u=d["u"], w=d["w"], u_sim=X[:, 3],
                            w_sim=X[:, 4], u_ref=d["u_ref"], w_ref=d["w_ref"], fit=fit, rmse=rmse)


def plot_validation(report: ValidationReport, ax=None):
    """Plot measured and simulated u and w of a :class:`ValidationReport`.

    Never calls ``plt.show()``; works with any backend, including Agg.

    :param report: from :func:`validate`
    :param ax: two matplotlib Axes (u, w); default a new figure with two rows
    :return: the two Axes
    """
    if not isinstance(report, ValidationReport):
        raise ValidationError(f"report must be a ValidationReport, got {type(report).__name__}")
    if ax is None:
        import matplotlib.pyplot as plt
        _, ax = plt.subplots(2, 1, sharex=True, figsize=(8, 5))
    ax = list(np.ravel(ax))
    if len(ax) != 2:
        raise ValidationError(f"ax must be two Axes (u, w), got {len(ax)}")
    for a, k, unit in ((ax[0], "u", "m/s"), (ax[1], "w", "rad/s")):
        a.plot(report.t, getattr(report, k), lw=0.6, color="0.6", label=f"{k} measured")
        a.plot(report.t, getattr(report, f"{k}_sim"), lw=1.2, color="C0",
               label=f"{k} simulated ({report.theta.name}), fit {report.fit[k]:.1f} %")
        a.set_ylabel(f"{k} ({unit})")
        a.legend(loc="upper right", fontsize="small")
    ax[1].set_xlabel("t (s)")
    return ax
