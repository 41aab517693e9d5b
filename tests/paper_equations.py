"""The paper's equations typed in again from its text, for tests to hold the library to:
written out component by component, sharing nothing with ``unidyn``, so that a slip in
the library cannot hide in its own expected value. One definition each, for every test."""

import math

import numpy as np


def eq1(pose, v, a):
    """Eq. (1): the pose rates of the point h, a m ahead of the axle, at velocity v."""
    _, _, psi = pose
    u, w = v
    return np.array([u * math.cos(psi) - a * w * math.sin(psi),
                     u * math.sin(psi) + a * w * math.cos(psi), w])


def eq2(v, v_ref, theta):
    """Eq. (2): the velocity rates of the dynamic model."""
    t1, t2, t3, t4, t5, t6 = theta
    u, w = v
    return np.array([t3 / t1 * w * w - t4 / t1 * u + v_ref[0] / t1,
                     -t5 / t2 * u * w - t6 / t2 * w + v_ref[1] / t2])


def eq10(h_d, h_d_dot, h, psi, a, k, l):
    """Eq. (10): v_d = A^-1(psi) (h_d' + L tanh(K h~ / L)), h~ = h_d - h."""
    nu_x = h_d_dot[0] + l[0] * math.tanh(k[0] * (h_d[0] - h[0]) / l[0])
    nu_y = h_d_dot[1] + l[1] * math.tanh(k[1] * (h_d[1] - h[1]) / l[1])
    c, s = math.cos(psi), math.sin(psi)
    return np.array([c * nu_x + s * nu_y, (-s * nu_x + c * nu_y) / a])


def eq14(v_d, v_d_dot, v, k, l):
    """The regressor G of Eq. (14), v_r = G theta_hat, with
    sigma = v_d' + L tanh(K (v_d - v) / L) (Eq. 12)."""
    ud, wd = v_d
    u, w = v
    s1 = v_d_dot[0] + l[0] * math.tanh(k[0] * (ud - u) / l[0])
    s2 = v_d_dot[1] + l[1] * math.tanh(k[1] * (wd - w) / l[1])
    return np.array([[s1, 0.0, -wd * w, ud, 0.0, 0.0],
                     [0.0, s2, ud * w - u * wd, 0.0, u * wd, wd]])
