"""The equation-error estimate of :func:`~unidyn.identification.identify`
(``method="equation-error"``, and the first estimate for smooth commands): Eq. (11)
by least squares, each row a decoupled problem.

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

import math

import numpy as np

from .._validate import ValidationError
from ..model.unicycle import regressor
from .logs import COLUMNS
from .results import THETA_NAMES

#: The ways of handling the velocity derivatives (see the module docstring).
SMOOTHING_METHODS = ("filter", "savgol")
#: The rows of Eq. (11): which parameters each decoupled problem estimates.
ROW_PARAMS = ((0, 2, 3), (1, 4, 5))
# Newey-West lag, in windows: filtered residuals are correlated over about one window
_LAG_WINDOWS = 1.0
# automatic filter window = _AUTO_BAND / (the commands' 95 % band, Hz)
_AUTO_BAND = 1.2


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
    row reduced to the columns of its own parameters (``ROW_PARAMS``): shape
    (..., 2, 3), row 1 [u', -w^2, u] (theta1, theta3, theta4), row 2
    [w', u w, w] (theta2, theta5, theta6). Every regressor the estimators form
    comes from here."""
    Y = regressor(v, v_dot)
    return np.stack([Y[..., r, list(cols)] for r, cols in enumerate(ROW_PARAMS)], axis=-2)


def coupling(u, w, chunk=1 << 16):
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
    for sl, ii, A, D, interior in _filter_weights(t, half):  # noqa: B007 (the last is returned)
        ui, wi = u[ii], w[ii]
        y[sl, 0] = np.einsum("nm,nm->n", A, u_ref[ii])
        y[sl, 1] = np.einsum("nm,nm->n", A, w_ref[ii])
        X[sl] = _filtered_eq11(parts, lambda z, A=A, ii=ii: np.einsum("nm,nm->n", A, z[ii]),
                               lambda z, D=D, ii=ii: np.einsum("nm,nm->n", D, z[ii]))
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


def white_noise_std(t, y) -> float:
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


def equation_error_fit(D, segs, smoothing, window, order, su, sw):
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
        params = ROW_PARAMS[row]
        norms = np.linalg.norm(X, axis=0)
        dead = [THETA_NAMES[params[j]] for j in range(3) if not norms[j] > 0]
        if dead:
            what = "u" if row == 0 else "w"
            raise ValidationError(
                f"the measured {what} gives a zero regressor column for {', '.join(dead)}: the "
                f"log has no {'linear' if row == 0 else 'angular'} motion to identify from")
        beta, c, r, cond, ok = _lstsq(X, y, lag, E)
        if not np.isfinite(cond) or cond > 1e10:
            raise ValidationError(
                f"the regression for {', '.join(THETA_NAMES[p] for p in params)} is singular "
                f"(condition number {cond:.3g}): the log does not excite these parameters; "
                f"vary both commands, with turning at speed (see excitation())")
        if not ok:
            warns.append(f"the measurement noise (std {su:.3g} on u, {sw:.3g} on w) is too large "
                         f"for the filtered signals of row {row + 1}: the noise-bias correction "
                         f"was skipped and {', '.join(THETA_NAMES[p] for p in params)} are biased "
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
