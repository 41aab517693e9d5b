r"""The controllers of Fig. 2 as pure functions: kinematic controller (Eq. 10),
dynamic compensation (Eqs. 12 and 14) and its adaptive update (Eqs. 18 and 20).

Shapes follow :mod:`unidyn.model.unicycle`: a leading batch axis is allowed everywhere.
The arithmetic is that of :mod:`unidyn.model.equations`; these functions give it
array-shaped arguments and results. Nothing here imports bdsim.
"""

from __future__ import annotations

import numpy as np

from . import equations as eq
from .components import join, pair, parts, scalar
from .equations import SWITCH_TOL

__all__ = ["kinematic_control", "kinematic_control_rate", "kinematic_control_and_rate",
           "compensation_regressor", "compensation", "adaptation_rate", "leakage_rate",
           "LEAKAGE_FORMS", "PAPER_GAMMA", "PAPER_SIGMA", "SWITCH_TOL"]

#: Forms of the sigma-modification (leakage) term in the update law:
#: ``"paper"`` is Eq. (20), ``- gamma Sigma theta_hat``; ``"fx44850"`` is the
#: authors' Simulink package, ``- Sigma theta_hat``; ``"none"`` is Eq. (18).
LEAKAGE_FORMS = ("paper", "fx44850", "none")

#: The adaptation gains (the diagonal of gamma) and leakage (of Sigma) of the
#: paper's simulations (Section 5), for Eqs. (18)/(20).
PAPER_GAMMA = (1.7, 1.1, 0.5, 0.3, 0.01, 0.5)
PAPER_SIGMA = (0.0005, 0.001, 0.001, 0.00006, 0.001, 0.001)


def adaptation_on(t, adapt_from):
    """Whether the update law is switched on at time t (see :data:`SWITCH_TOL`)."""
    return t >= adapt_from - SWITCH_TOL


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
    return pair(*eq.kinematic_control_components(*parts(h_d), *parts(h_d_dot), *parts(h), scalar(psi),
                                   a, *parts(k, 2), *parts(l, 2)))


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
    return kinematic_control_and_rate(h_d, h_d_dot, h_d_ddot, h, psi, v, a, k, l)[1]


def kinematic_control_and_rate(h_d, h_d_dot, h_d_ddot, h, psi, v, a, k, l):
    """Eq. (10) and its time derivative at once (:func:`kinematic_control`,
    :func:`kinematic_control_rate`): (v_d, v_d'), each shape ``(..., 2)``."""
    ud, wd, udd, wdd = eq.kinematic_control_and_rate_components(
        *parts(h_d), *parts(h_d_dot), *parts(h_d_ddot), *parts(h), scalar(psi), *parts(v),
        a, *parts(k, 2), *parts(l, 2))
    return pair(ud, wd), pair(udd, wdd)


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
    G = join(*eq.compensation_regressor_components(*parts(v_d), *parts(v_d_dot), *parts(v),
                                         *parts(k, 2), *parts(l, 2)))
    return G.reshape(G.shape[:-1] + (2, 6))


def compensation(G, theta_hat):
    r"""The compensator's command, Eq. (12) in the linear form of Eq. (14):
    :math:`v_r = G\hat\theta`, shape ``(..., 2)``."""
    G = np.asarray(G, dtype=float)
    return pair(*eq.compensation_components(parts(G.reshape(G.shape[:-2] + (12,))), parts(theta_hat)))


def leakage_rate(gamma, sigma, leakage="paper"):
    r"""The leakage rates :math:`\lambda_j` of :func:`unidyn.model.equations.adaptation_rate_components`
    for a named leakage form: :math:`\gamma_j\sigma_j` for ``"paper"`` (Eq. 20),
    :math:`\sigma_j` for ``"fx44850"`` (the authors' Simulink package), 0 for
    ``"none"`` (Eq. 18)."""
    gamma = np.asarray(gamma, dtype=float)
    sigma = np.asarray(sigma, dtype=float)
    if leakage == "paper":
        return gamma * sigma
    if leakage == "fx44850":
        return np.broadcast_to(sigma, np.broadcast_shapes(gamma.shape, sigma.shape)).copy()
    if leakage == "none":
        return np.zeros(np.broadcast_shapes(gamma.shape, sigma.shape))
    raise ValueError(f"leakage must be one of {LEAKAGE_FORMS}, got {leakage!r}")


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
    leak = parts(leakage_rate(gamma, sigma, leakage), 6)
    G = np.asarray(G, dtype=float)
    g = parts(G.reshape(G.shape[:-2] + (12,)))
    ut, wt = parts(v_tilde)
    return join(*(eq.adaptation_rate_components(g[j], g[6 + j], ut, wt, gj, leak[j], th)
                   for j, (gj, th) in enumerate(zip(parts(gamma, 6), parts(theta_hat)))))
