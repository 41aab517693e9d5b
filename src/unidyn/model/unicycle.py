r"""The velocity-based dynamic model of a differential-drive robot (pure functions).

Martins, Sarcinelli-Filho, Carelli, J Intell Robot Syst (2017).

State ``x = [x, y, psi, u, w]``: position of the point of interest h (m), heading
(rad), linear (m/s) and angular (rad/s) velocity. Inputs ``v_ref = [u_ref, w_ref]``.

Every function is stateless and accepts a leading batch axis: arrays of shape
``(..., 5)`` for states and ``(..., 2)`` for velocities; ``theta`` has shape
``(6,)`` or ``(..., 6)``. Nothing here imports bdsim.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._validate import ValidationError, positive
from . import equations as eq
from .components import join, pair, parts, scalar

__all__ = ["Limits", "kinematics", "dynamics", "inertia", "coriolis", "damping",
           "regressor", "inverse_dynamics", "unicycle_deriv", "kinematic_unicycle_deriv",
           "point_velocity", "storage", "loaded_theta", "PAPER_LIMITS", "NO_LIMITS"]


@dataclass(frozen=True)
class Limits:
    r"""Speed and acceleration limits of the robot (the paper's Section 5).

    Commands are clipped to the speed limits, and the actual velocities are
    kept inside them; accelerations are clipped to the acceleration limits.
    All are applied inside the state derivative as pure functions of state and
    input, so they are exact under any adaptive ODE solver. JSON files
    (``summary.json``, ``sweep.json``) write an infinite limit as ``null``.

    :param speed_max: max \|u\|, m/s, > 0 (inf or None: no limit)
    :type speed_max: float
    :param steer_max: max \|w\|, rad/s, > 0 (inf or None: no limit)
    :type steer_max: float
    :param accel_max: max \|u'\|, m/s², > 0 (inf or None: no limit)
    :type accel_max: float
    :param angular_accel_max: max \|w'\|, rad/s², > 0 (inf or None: no limit)
    :type angular_accel_max: float
    """

    speed_max: float = np.inf
    steer_max: float = np.inf
    accel_max: float = np.inf
    angular_accel_max: float = np.inf

    def __post_init__(self):
        for k in ("speed_max", "steer_max", "accel_max", "angular_accel_max"):
            v = getattr(self, k)  # None (JSON's null): no limit
            object.__setattr__(self, k, np.inf if v is None else positive(k, v, allow_inf=True))
        speed = np.array([self.speed_max, self.steer_max])
        accel = np.array([self.accel_max, self.angular_accel_max])
        speed.flags.writeable = False
        accel.flags.writeable = False
        object.__setattr__(self, "_speed", speed)
        object.__setattr__(self, "_accel", accel)
        object.__setattr__(self, "_active", bool(np.isfinite(speed).any() or np.isfinite(accel).any()))

    @property
    def speed(self) -> np.ndarray:
        """[speed_max, steer_max] (read-only array)"""
        return self._speed

    @property
    def accel(self) -> np.ndarray:
        """[accel_max, angular_accel_max] (read-only array)"""
        return self._accel

    @property
    def active(self) -> bool:
        """True if any limit is finite."""
        return self._active

    def as_dict(self) -> dict:
        return {k: float(getattr(self, k)) for k in
                ("speed_max", "steer_max", "accel_max", "angular_accel_max")}


#: The limits of the paper's simulations (FX44850): 0.75 m/s, 1.745 rad/s, 0.3 m/s², 1.745 rad/s².
PAPER_LIMITS = Limits(0.75, 1.745, 0.3, 1.745)
#: No limits at all.
NO_LIMITS = Limits()


def _th(theta):
    return tuple(parts(theta))


def point_velocity(psi, v, a):
    r"""Velocity of the point of interest h, the first two rows of Eq. (1).

    .. math:: \dot x = u\cos\psi - a\,w\sin\psi, \quad \dot y = u\sin\psi + a\,w\cos\psi

    :param psi: heading, rad, shape ``(...)``
    :param v: [u, w], shape ``(..., 2)``
    :param a: offset of h ahead of the axle centre, m
    :return: [x', y'], shape ``(..., 2)``
    """
    return pair(*eq.point_velocity_components(scalar(psi), *parts(v), a))


def kinematics(x, a):
    r"""Eq. (1): [x', y', psi'] of the state ``x = [x, y, psi, u, w]`` (no disturbance).

    .. math::

        \dot x = u\cos\psi - a w\sin\psi,\quad
        \dot y = u\sin\psi + a w\cos\psi,\quad
        \dot\psi = w
    """
    x = np.asarray(x, dtype=float)
    out = np.empty(x.shape[:-1] + (3,))
    out[..., 0:2] = point_velocity(x[..., 2], x[..., 3:5], a)
    out[..., 2] = x[..., 4]
    return out


def dynamics(v, v_ref, theta):
    r"""Eq. (2): [u', w'] for velocities ``v`` and commands ``v_ref`` (no disturbance).

    .. math::

        \dot u = \frac{\theta_3}{\theta_1} w^2 - \frac{\theta_4}{\theta_1} u + \frac{u_{ref}}{\theta_1},\quad
        \dot w = -\frac{\theta_5}{\theta_2} u w - \frac{\theta_6}{\theta_2} w + \frac{w_{ref}}{\theta_2}
    """
    return pair(*eq.dynamics_components(*parts(v), *parts(v_ref), *_th(theta)))


def inertia(theta):
    r"""H = diag(theta1, theta2) of Eq. (6), shape ``(..., 2, 2)``."""
    t1, t2, *_ = _th(theta)
    z = np.zeros_like(t1)
    return np.stack([np.stack([t1, z], -1), np.stack([z, t2], -1)], -2)


def coriolis(v, theta):
    r"""C(v) = [[0, -theta3 w], [theta3 w, 0]] of Eq. (6) (skew-symmetric), shape ``(..., 2, 2)``."""
    v = np.asarray(v, dtype=float)
    t3 = _th(theta)[2]
    cw = t3 * v[..., 1]
    z = np.zeros_like(cw)
    return np.stack([np.stack([z, -cw], -1), np.stack([cw, z], -1)], -2)


def damping(v, theta):
    r"""F(v) = diag(theta4, theta6 + (theta5 - theta3) u) of Eq. (6), shape ``(..., 2, 2)``."""
    v = np.asarray(v, dtype=float)
    _, _, t3, t4, t5, t6 = _th(theta)
    f22 = t6 + (t5 - t3) * v[..., 0]
    f11 = np.broadcast_to(t4, f22.shape)
    z = np.zeros_like(f22)
    return np.stack([np.stack([f11, z], -1), np.stack([z, f22], -1)], -2)


def inverse_dynamics(v, v_dot, theta):
    r"""The command that produces acceleration ``v_dot`` at velocity ``v``, Eq. (6):
    :math:`v_{ref} = H\dot v + C(v) v + F(v) v`."""
    v = np.asarray(v, dtype=float)
    v_dot = np.asarray(v_dot, dtype=float)
    M = inertia(theta) @ v_dot[..., None] + (coriolis(v, theta) + damping(v, theta)) @ v[..., None]
    return M[..., 0]


def regressor(v, v_dot):
    r"""The regressor of the linear parametrisation, Eq. (11): :math:`v_{ref} = Y(v, \dot v)\,\theta`.

    .. math::

        Y = \begin{bmatrix} \dot u & 0 & -w^2 & u & 0 & 0 \\
                            0 & \dot w & 0 & 0 & u w & w \end{bmatrix}

    The compensator's regressor G of Eq. (14) is the same structure evaluated
    along the desired motion; see :func:`unidyn.model.laws.compensation_regressor`.

    :return: shape ``(..., 2, 6)``
    """
    Y = join(*eq.regressor_components(*parts(v), *parts(v_dot)))
    return Y.reshape(Y.shape[:-1] + (2, 6))


def storage(v, theta):
    r"""The storage function of Theorem 1, :math:`V = \tfrac12 v^T H v` (J-like units)."""
    v = np.asarray(v, dtype=float)
    t1, t2, *_ = _th(theta)
    return 0.5 * (t1 * v[..., 0] ** 2 + t2 * v[..., 1] ** 2)


def loaded_theta(theta, payload, t) -> np.ndarray:
    """theta1..theta6 of the robot whose empty parameters are ``theta`` at time t, s,
    under the payload schedule ``payload`` (rows ``(t_k, mass scale)``, validated by
    :func:`unidyn.model.parameters.payload_schedule`; Section 2's scaling,
    :func:`unidyn.model.equations.payload_theta`): shape (6,) for a number t, (N, 6)
    for an array of N times."""
    steps = tuple(v for row in payload for v in row)
    try:
        tt = np.asarray(t, dtype=float)
    except (TypeError, ValueError):
        raise ValidationError(f"t must be a time in s or an array of them, got {t!r:.80}") from None
    th = eq.payload_theta(tt if tt.ndim else float(tt), *np.asarray(theta, dtype=float), steps)
    return np.stack(np.broadcast_arrays(tt, *th)[1:], axis=-1).astype(float)


def unicycle_deriv(x, v_ref, theta, a, limits: Limits = NO_LIMITS, delta=None):
    r"""Full state derivative of the dynamic unicycle, Eqs. (1) and (2).

    :param x: state [x, y, psi, u, w], shape ``(..., 5)``
    :param v_ref: commands [u_ref, w_ref] (m/s, rad/s), shape ``(..., 2)``
    :param theta: parameters, shape ``(6,)`` or ``(..., 6)``
    :param a: offset of the point of interest, m
    :param limits: :class:`Limits`; commands are clipped to the speed limits,
        accelerations to the acceleration limits, and a velocity at its limit
        is not pushed beyond it
    :param delta: optional disturbance [delta_x, delta_y, delta_u, delta_w]
        added to x', y', u', w' (Eqs. 1-2; psi' has none)
    :return: x', shape ``(..., 5)``
    """
    _, _, psi, u, w = parts(x)
    u_ref, w_ref = parts(v_ref)
    speed, accel = limits.speed.tolist(), limits.accel.tolist()
    if limits.active:
        u_ref, w_ref = eq.saturate(u_ref, speed[0]), eq.saturate(w_ref, speed[1])
    du, dw = eq.dynamics_components(u, w, u_ref, w_ref, *_th(theta))
    dx, dy = eq.point_velocity_components(psi, u, w, a)
    if delta is not None:
        ex, ey, eu, ew = parts(delta)
        dx, dy, du, dw = dx + ex, dy + ey, du + eu, dw + ew
    if limits.active:
        du, dw = eq.limited_acceleration(u, w, du, dw, *speed, *accel)
    return join(dx, dy, w, du, dw)


def kinematic_unicycle_deriv(q, v_ref, a, limits: Limits = NO_LIMITS):
    r"""A purely kinematic robot (the paper's case 1): Eq. (1) with v = v_ref.

    :param q: pose [x, y, psi] of the point of interest, shape ``(..., 3)``
    :param v_ref: [u_ref, w_ref], clipped to the speed limits (acceleration limits
        have no meaning for a robot without velocity states and are ignored)
    :return: q', shape ``(..., 3)``
    """
    _, _, psi = parts(q)
    u, w = parts(v_ref)
    if limits.active:
        speed = limits.speed.tolist()
        u, w = eq.saturate(u, speed[0]), eq.saturate(w, speed[1])
    return join(*eq.point_velocity_components(psi, u, w, a), w)
