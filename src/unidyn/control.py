r"""The controllers of Fig. 2 as pure functions: kinematic controller (Eq. 10),
dynamic compensation (Eqs. 12 and 14) and its adaptive update (Eqs. 18 and 20).

Shapes follow :mod:`unidyn.model`: a leading batch axis is allowed everywhere.
Nothing here imports bdsim.
"""

from __future__ import annotations

import numpy as np

from .model import point_velocity

__all__ = ["kinematic_control", "kinematic_control_rate", "compensation_regressor",
           "compensation", "adaptation_rate", "LEAKAGE_FORMS", "PAPER_GAMMA", "PAPER_SIGMA"]

#: Forms of the sigma-modification (leakage) term in the update law:
#: ``"paper"`` is Eq. (20), ``- gamma Sigma theta_hat``; ``"fx44850"`` is the
#: authors' Simulink package, ``- Sigma theta_hat``; ``"none"`` is Eq. (18).
LEAKAGE_FORMS = ("paper", "fx44850", "none")

#: The adaptation gains (the diagonal of gamma) and leakage (of Sigma) of the
#: paper's simulations (Section 5), for Eqs. (18)/(20).
PAPER_GAMMA = (1.7, 1.1, 0.5, 0.3, 0.01, 0.5)
PAPER_SIGMA = (0.0005, 0.001, 0.001, 0.00006, 0.001, 0.001)

#: Adaptation is on for t >= adapt_from - SWITCH_TOL (s): the switch then falls on
#: the same side of a solver stage that lands on adapt_from up to rounding, in
#: every engine.
SWITCH_TOL = 1e-9


def adaptation_on(t, adapt_from):
    """Whether the update law is switched on at time t (see :data:`SWITCH_TOL`)."""
    return t >= adapt_from - SWITCH_TOL


def _inv_jacobian(psi, a):
    """A^-1(psi) of Eq. (10), shape (..., 2, 2)."""
    c, s = np.cos(psi), np.sin(psi)
    out = np.empty(np.shape(c) + (2, 2))
    out[..., 0, 0] = c
    out[..., 0, 1] = s
    out[..., 1, 0] = -s / a
    out[..., 1, 1] = c / a
    return out


def kinematic_control(h_d, h_d_dot, h, psi, a, k, l):
    r"""Kinematic trajectory-tracking controller, Eq. (10).

    .. math::

        \begin{bmatrix} u_d \\ \omega_d \end{bmatrix} =
        \begin{bmatrix} \cos\psi & \sin\psi \\ -\frac{\sin\psi}{a} & \frac{\cos\psi}{a} \end{bmatrix}
        \begin{bmatrix} \dot x_d + l_x \tanh(k_x \tilde x / l_x) \\
                        \dot y_d + l_y \tanh(k_y \tilde y / l_y) \end{bmatrix},
        \qquad \tilde h = h_d - h

    :param h_d: desired position of h, m, shape ``(..., 2)``
    :param h_d_dot: desired velocity, m/s, shape ``(..., 2)``
    :param h: measured position of h, m, shape ``(..., 2)``
    :param psi: measured heading, rad, shape ``(...)``
    :param a: offset of h ahead of the axle centre, m, > 0
    :param k: gains [k_x, k_y], 1/s
    :param l: saturation constants [l_x, l_y], m/s
    :return: v_d = [u_d, w_d], shape ``(..., 2)``
    """
    k = np.asarray(k, dtype=float)
    l = np.asarray(l, dtype=float)
    h_tilde = np.asarray(h_d, dtype=float) - np.asarray(h, dtype=float)
    nu = np.asarray(h_d_dot, dtype=float) + l * np.tanh(k * h_tilde / l)
    return (_inv_jacobian(psi, a) @ nu[..., None])[..., 0]


def kinematic_control_rate(h_d, h_d_dot, h_d_ddot, h, psi, v, a, k, l):
    r"""Time derivative of Eq. (10) along the motion (the exact v_d').

    .. math::

        \dot v_d = \frac{d A^{-1}(\psi)}{dt}\,\nu + A^{-1}(\psi)\,\dot\nu,\quad
        \nu = \dot h_d + L\tanh(K\tilde h/L),\quad
        \dot\nu = \ddot h_d + K\,\mathrm{sech}^2(K\tilde h/L)\,(\dot h_d - \dot h)

    with :math:`\dot h` from Eq. (1) and :math:`\dot\psi = \omega`.

    :param v: the robot's actual (or measured) velocities [u, w], shape ``(..., 2)``
    :return: [u_d', w_d'], shape ``(..., 2)``
    """
    k = np.asarray(k, dtype=float)
    l = np.asarray(l, dtype=float)
    v = np.asarray(v, dtype=float)
    h_d_dot = np.asarray(h_d_dot, dtype=float)
    h_tilde = np.asarray(h_d, dtype=float) - np.asarray(h, dtype=float)
    z = k * h_tilde / l
    nu = h_d_dot + l * np.tanh(z)
    c, s = np.cos(psi), np.sin(psi)
    w = v[..., 1]
    h_dot = point_velocity(psi, v, a)
    nu_dot = np.asarray(h_d_ddot, dtype=float) + k / np.cosh(z) ** 2 * (h_d_dot - h_dot)
    # d/dt A^-1(psi) = w [[-sin, cos], [-cos/a, -sin/a]]
    out = np.empty(np.broadcast(nu[..., 0], w).shape + (2,))
    out[..., 0] = w * (-s * nu[..., 0] + c * nu[..., 1]) + c * nu_dot[..., 0] + s * nu_dot[..., 1]
    out[..., 1] = (w * (-c * nu[..., 0] - s * nu[..., 1]) - s * nu_dot[..., 0]
                   + c * nu_dot[..., 1]) / a
    return out


def compensation_regressor(v_d, v_d_dot, v, k, l):
    r"""The regressor G of the dynamic compensation, Eq. (14): :math:`v_r = G\hat\theta`.

    .. math::

        G = \begin{bmatrix} \sigma_1 & 0 & -\omega_d\omega & u_d & 0 & 0 \\
            0 & \sigma_2 & u_d\omega - u\,\omega_d & 0 & u\,\omega_d & \omega_d \end{bmatrix},\quad
        \sigma_1 = \dot u_d + l_u\tanh\!\left(\frac{k_u}{l_u}\tilde u\right),\
        \sigma_2 = \dot\omega_d + l_\omega\tanh\!\left(\frac{k_\omega}{l_\omega}\tilde\omega\right)

    with :math:`\tilde v = v_d - v`.

    :param v_d: desired velocities from the kinematic controller, shape ``(..., 2)``
    :param v_d_dot: their time derivative, shape ``(..., 2)``
    :param v: measured velocities [u, w], shape ``(..., 2)``
    :param k: gains [k_u, k_w], 1/s
    :param l: saturation constants [l_u, l_w]
    :return: G, shape ``(..., 2, 6)``
    """
    k = np.asarray(k, dtype=float)
    l = np.asarray(l, dtype=float)
    v_d = np.asarray(v_d, dtype=float)
    v = np.asarray(v, dtype=float)
    sig = np.asarray(v_d_dot, dtype=float) + l * np.tanh(k * (v_d - v) / l)
    ud, wd = v_d[..., 0], v_d[..., 1]
    u, w = v[..., 0], v[..., 1]
    G = np.zeros(np.broadcast(sig[..., 0], u, ud).shape + (2, 6))
    G[..., 0, 0] = sig[..., 0]
    G[..., 0, 2] = -wd * w
    G[..., 0, 3] = ud
    G[..., 1, 1] = sig[..., 1]
    G[..., 1, 2] = ud * w - u * wd
    G[..., 1, 4] = u * wd
    G[..., 1, 5] = wd
    return G


def compensation(G, theta_hat):
    r"""The compensator's command, Eq. (12) in the linear form of Eq. (14):
    :math:`v_r = G\hat\theta`, shape ``(..., 2)``."""
    return (np.asarray(G) @ np.asarray(theta_hat, dtype=float)[..., None])[..., 0]


def adaptation_rate(G, v_tilde, theta_hat, gamma, sigma, leakage="paper"):
    r"""The parameter update law, Eq. (18) or its robust form Eq. (20).

    .. math::

        \dot{\hat\theta} = \gamma G^T \tilde v - \gamma\Sigma\hat\theta \quad (\text{Eq. 20, ``leakage="paper"``})

    ``leakage="fx44850"`` uses :math:`-\Sigma\hat\theta` (the authors' Simulink
    package); ``leakage="none"`` is Eq. (18), :math:`\gamma G^T\tilde v`.

    :param G: regressor of Eq. (14), shape ``(..., 2, 6)``
    :param v_tilde: velocity error v_d - v, shape ``(..., 2)``
    :param theta_hat: current estimate, shape ``(..., 6)``
    :param gamma: diagonal of the adaptation gain, shape ``(6,)``
    :param sigma: diagonal of the leakage gain Sigma, shape ``(6,)``
    """
    gamma = np.asarray(gamma, dtype=float)
    grad = (np.swapaxes(np.asarray(G), -1, -2) @ np.asarray(v_tilde, dtype=float)[..., None])[..., 0]
    rate = gamma * grad
    theta_hat = np.asarray(theta_hat, dtype=float)
    if leakage == "paper":
        rate = rate - gamma * np.asarray(sigma) * theta_hat
    elif leakage == "fx44850":
        rate = rate - np.asarray(sigma) * theta_hat
    elif leakage != "none":
        raise ValueError(f"leakage must be one of {LEAKAGE_FORMS}, got {leakage!r}")
    return rate
