"""Bounded nonlinear least squares for fits with many residuals and few parameters.

The output-error fit of a long log has two residuals a sample (10^6 to 10^7
rows) and about eight parameters. scipy's ``least_squares`` keeps several dense
copies of the Jacobian (its trust-region step takes the SVD of the scaled
matrix), some eight times the memory of the log itself. Here the Jacobian is
held once, in single precision (it only steers the steps: the minimum reached is
where the residuals stop decreasing, and the covariance is formed from it in
double precision), and every step is taken on the p x p normal equations,
accumulated in double precision a block of rows at a time: Levenberg-Marquardt
with Marquardt's diagonal scaling, steps projected onto the bounds.
"""

from __future__ import annotations

import numpy as np

# rows of the Jacobian converted to double precision at a time
_ROWS = 1 << 16


def normal_equations(J, f=None):
    """J^T J (and J^T f when ``f`` is given) in double precision, a block of rows at
    a time, for a tall Jacobian ``J`` (rows x p) of any float type."""
    p = J.shape[1]
    M, g = np.zeros((p, p)), np.zeros(p)
    for s in range(0, J.shape[0], _ROWS):
        B = np.asarray(J[s:s + _ROWS], dtype=float)
        M += B.T @ B
        if f is not None:
            g += B.T @ f[s:s + _ROWS]
    return (M, g) if f is not None else M


def levenberg_marquardt(fun, jac, p0, lb, ub, max_nfev=200, ftol=1e-10, xtol=1e-10,
                        gtol=1e-10):
    """Minimise sum(fun(p)^2) / 2 within lb <= p <= ub from ``p0``.

    :param fun: p -> residuals (float array)
    :param jac: (p, residuals at p) -> Jacobian (rows x len(p))
    :param max_nfev: most evaluations of ``fun`` (those inside ``jac`` not counted)
    :param ftol: stop when a step lowers the cost by less than this fraction of it
    :param xtol: stop when a step is shorter than this fraction of the (scaled) p
    :param gtol: stop when the scaled gradient is below this
    :return: the p reached
    """
    lb, ub = np.asarray(lb, float), np.asarray(ub, float)
    p = np.clip(np.asarray(p0, dtype=float), lb, ub)
    f = fun(p)
    cost, nfev, lam = 0.5 * float(f @ f), 1, 1e-3
    while nfev < max_nfev:
        J = jac(p, f)
        M, g = normal_equations(J, f)
        del J
        d = np.sqrt(np.diag(M))
        d[~(d > 0)] = 1.0
        A, b = M / np.outer(d, d), g / d
        if float(np.max(np.abs(b))) <= gtol * max(1.0, np.sqrt(2 * cost)):
            return p
        eye = np.diag(np.maximum(np.diag(A), 1e-12))
        while True:
            try:
                step = -np.linalg.solve(A + lam * eye, b) / d
            except np.linalg.LinAlgError:
                step = np.zeros_like(p)
            q = np.clip(p + step, lb, ub)
            fq = fun(q)
            nfev += 1
            cq = 0.5 * float(fq @ fq)
            if np.isfinite(cq) and cq <= cost:
                break
            lam *= 4.0
            if nfev >= max_nfev or lam > 1e16:
                return p
        small = np.linalg.norm((q - p) * d) <= xtol * (xtol + np.linalg.norm(p * d))
        # a small decrease ends the fit only for a near Gauss-Newton step, not a damped one
        flat = cost - cq <= ftol * cost and lam <= 1e-2
        p, f, cost = q, fq, cq
        lam = max(lam / 3.0, 1e-12)
        if small or flat:
            break
    return p
