"""The output-error fit of :func:`~unidyn.identification.identify` (its default):
Eq. (2) replayed over the log with the commands as the robot applied them
(:mod:`~unidyn.identification.replay`), theta, the input delay and each piece's
initial velocities adjusted until the simulated velocities match the measured ones
(bounded Levenberg-Marquardt, :mod:`~unidyn.identification.least_squares`); its
covariance, and what the residuals say about the fit: whether they are white,
whether the robot saturates, which parameters the log does not determine."""

from __future__ import annotations

import math

import numpy as np

from .least_squares import levenberg_marquardt, normal_equations
from .logs import COLUMNS
from .replay import simulate_held, step_length

#: The output-error fit explores time constants theta1/theta4, theta2/theta6 of
#: at least this many sample intervals (faster ones are not resolved by the log)
TAU_MIN_SAMPLES = 0.05
# Ljung-Box statistic over 10 lags above which residuals are not white (chi2(10), p = 0.001)
_WHITE_Q = 29.588
# correlation of the velocity errors with the cube of the fitted velocity (beyond its
# linear part) below which the robot looks saturated: logs made by Eq. (2) with
# clipped commands give -0.7 to -0.85, unclipped ones stay within +/- 0.1
_SATURATION_CORR = -0.3


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


def output_error_fit(D, segs, theta0, sig, linear, delay, est_delay, dt_med, v0=None,
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
    Minv, dead = scaled_inverse(M)
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


def scaled_inverse(M, tol=1e-10):
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
