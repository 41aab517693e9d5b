r"""The paper's equations in components: the arithmetic every engine runs.

Each equation has one name: its public form takes and returns arrays
(:mod:`unidyn.model.unicycle`, :mod:`unidyn.model.laws`, whose docstrings write the
equation out), and its form here, the same name with ``_components``, takes and returns
the vectors' components, the arithmetic both forms run: Eq. (1)
(:func:`point_velocity_components`), Eq. (2) (:func:`dynamics_components`, with the
speed and acceleration limits :func:`saturate`, :func:`limited_acceleration`), Eq. (11)
(:func:`regressor_components`), Eq. (10) and its time derivative
(:func:`kinematic_control_components`, :func:`kinematic_control_and_rate_components`),
Eqs. (12)/(14) (:func:`compensation_regressor_components`,
:func:`compensation_components`), Eqs. (18)/(20) (:func:`adaptation_rate_components`);
the reference trajectories; and the whole Fig. 2 loop built from them
(:func:`loop_signals`, :func:`loop_rates`, :func:`loop_derivative`).

The arguments may be Python floats or numpy arrays of any broadcastable shape
(the runs of a batch, the samples of a log), and numba compiles the same
functions for the batch engine and for identification (:mod:`unidyn.compiled`
registers every function of this module with numba, so they call each other in
compiled code). Components in, tuples of components out: no function allocates an
array of its own.

What this module may use, so that numba compiles it: arithmetic, comparisons,
``np.minimum/maximum/sqrt``, :func:`sin`, :func:`cos`, :func:`tanh` (numpy's, which
numba compiles to the maths library's), :func:`select` (not ``np.where``, which allocates an array per
call in compiled code), indexing, loops of fixed length, and calls to functions of
this module; no Python branch on a value (it may be an array).
"""

from __future__ import annotations

import math
from collections import namedtuple

import numpy as np

from .parameters import PAYLOAD_STEPS, THETA_NAMES

__all__ = ["select", "sin", "cos", "tanh", "point_velocity_components", "dynamics_components",
           "regressor_components", "saturate", "limited_acceleration", "kinematic_control_components",
           "kinematic_control_and_rate_components", "compensation_regressor_components", "compensation_components", "adaptation_rate_components",
           "figure_eight", "circle", "stepped_radius", "mass_scale", "payload_theta", "line", "loop_signals", "loop_rates",
           "loop_derivative", "loop_adaptation_rates", "STATE", "S", "NSTATE", "LOOP_PARAMETERS", "P",
           "reference_components", "FIGURE_EIGHT", "CIRCLE", "LINE", "SEGMENT", "PYTHON", "segment",
           "RADIUS_STEPS", "PAYLOAD_STEPS", "SWITCH_TOL", "clip_held", "speed_held", "clip_margin", "clip_side",
           "speed_margin", "speed_side", "loop_rates_held", "next_switch_time", "SWITCHES", "NSWITCH", "MODE",
           "AUTO"]

#: Adaptation is on for t >= adapt_from - SWITCH_TOL (s): the switch then falls on
#: the same side of a solver stage that lands on adapt_from up to rounding, in
#: every engine.
SWITCH_TOL = 1e-9


def select(condition, a, b):
    """a where condition holds, else b: ``np.where`` on arrays, a branch on one value
    (as in compiled code)."""
    if isinstance(condition, (bool, np.bool_)):
        return a if condition else b
    return np.where(condition, a, b)


def sin(x):
    """``np.sin``."""
    return np.sin(x)


def cos(x):
    """``np.cos``."""
    return np.cos(x)


def tanh(x):
    """``np.tanh``."""
    return np.tanh(x)


# --------------------------------------------------------------------------- robot
def point_velocity_components(psi, u, w, a):
    """Eq. (1), first two rows, in components: (x', y') of the point of interest h
    (:func:`unidyn.model.unicycle.point_velocity`)."""
    c = cos(psi)
    s = sin(psi)
    return u * c - a * w * s, u * s + a * w * c


def dynamics_components(u, w, u_ref, w_ref, th1, th2, th3, th4, th5, th6):
    """Eq. (2) in components: (u', w') under the commands u_ref, w_ref, no
    disturbance (:func:`unidyn.model.unicycle.dynamics`)."""
    return ((th3 * w * w - th4 * u + u_ref) / th1,
            (-th5 * u * w - th6 * w + w_ref) / th2)


def regressor_components(u, w, du, dw):
    """The regressor Y of Eq. (11) in components, row by row (12 entries)
    (:func:`unidyn.model.unicycle.regressor`)."""
    return (du, 0.0, -w * w, u, 0.0, 0.0,
            0.0, dw, 0.0, 0.0, u * w, w)


def mass_scale(t, steps):
    r"""The robot's mass at time t relative to the empty robot's: 1 before the first
    row of the payload schedule, :math:`m_k` from :math:`t_k` on
    (:math:`t \ge t_k - ` :data:`SWITCH_TOL`, the side of the switch every engine
    takes). ``steps`` = (t_1, m_1, t_2, m_2, ...) with increasing times, s, and
    scales > 0; a pair with t_k = inf never applies. With no step it is 1."""
    m = 1.0
    for k in range(0, len(steps), 2):
        m = select(t >= steps[k] - SWITCH_TOL, steps[k + 1], m)
    return m


def payload_theta(t, th1, th2, th3, th4, th5, th6, steps):
    r"""The robot's parameters at time t under the payload schedule ``steps``
    (:func:`mass_scale`, scale :math:`\mu`): (theta1..theta6) with theta1, theta2,
    theta3, theta5 multiplied by :math:`\mu` and theta4, theta6 kept.

    Section 2 writes the parameters from the physical ones:
    :math:`\theta_1 = \frac{R_a}{k_a}\frac{m r^2 + 2 I_e + 2 r k_{DT}}{2 r k_{PT}}`,
    :math:`\theta_2 = \frac{R_a}{k_a}\frac{I_e d^2 + 2 r^2 (I_z + m b^2) + 2 r d k_{DR}}{2 r d k_{PR}}`,
    :math:`\theta_3 = \frac{R_a}{k_a}\frac{m b r}{2 k_{PT}}`,
    :math:`\theta_5 = \frac{R_a}{k_a}\frac{m b r}{d k_{PR}}`, while theta4 and theta6
    hold only the motors' and the friction's constants. A load that multiplies the
    mass m and the inertia I_z by :math:`\mu` (carried with the robot's own
    distribution of mass, b unchanged) multiplies theta3 and theta5 exactly, and
    theta1 and theta2 where the rotors' inertia I_e and the servos' derivative gains
    are small against the body's terms (the approximation this makes); theta4 and
    theta6 do not change. Eq. (2) then sees the loaded robot."""
    m = mass_scale(t, steps)
    return th1 * m, th2 * m, th3 * m, th4, th5 * m, th6


def saturate(x, limit):
    """x clipped to [-limit, limit] (limit may be inf); NaN stays NaN."""
    if isinstance(x, float) and isinstance(limit, float):  # one value (np.float64 too)
        return min(max(x, -limit), limit)
    return np.minimum(np.maximum(x, -limit), limit)


def limited_acceleration(u, w, du, dw, speed_u, speed_w, accel_u, accel_w):
    """The acceleration limits on (du, dw), and no acceleration that pushes a velocity
    already at its speed limit beyond it (how the limits act on Eq. 2)."""
    du = saturate(du, accel_u)
    dw = saturate(dw, accel_w)
    return speed_held(u, du, speed_u, AUTO), speed_held(w, dw, speed_w, AUTO)


# ------------------------------------------------------------- the switches
# The limits make the loop a switched system: each of its switches is a value clipped
# to a limit (-1: at -limit, 0: not clipped, +1: at +limit), and between the times a
# switch flips the loop's right-hand side is smooth. The batch engine holds each switch
# over a step (its *mode*), so that every step integrates a smooth right-hand side,
# and ends a step where a switch's margin (``clip_margin``, ``speed_margin``: >= 0
# while the held side is right) crosses zero; the blocks decide each switch where
# they evaluate the loop (AUTO).

#: The loop's switches, in the order of a mode's entries after its time: the commands
#: u_ref, w_ref clipped to the speed limits, the accelerations of Eq. (2) clipped to
#: the acceleration limits, and u, w held at their speed limits.
SWITCHES = ("command_u", "command_w", "accel_u", "accel_w", "speed_u", "speed_w")
#: The number of switches.
NSWITCH = len(SWITCHES)
#: A mode: the time at which the time switches (adaptation, payload, the reference's steps) are
#: judged, then each switch's side.
MODE = ("time",) + SWITCHES
#: A switch's side decided by the values where the loop is evaluated.
AUTO = 2.0


def clip_held(x, limit, held):
    """x clipped to [-limit, limit] on the side ``held`` (-1, 0: x itself, +1), or as x
    lies where held is :data:`AUTO` (:func:`saturate`)."""
    return select(held == AUTO, saturate(x, limit),
                  select(held == 0.0, x, select(held > 0.0, limit, -limit)))


def clip_margin(x, limit, held):
    """How far x is inside the side ``held`` of its clip (-1, 0, +1): >= 0 while that
    side is the one x lies on (for 0: limit minus the size of x; for +1: x - limit)."""
    return select(held == 0.0, limit - abs(x), select(held > 0.0, x - limit, -x - limit))


def clip_side(x, limit):
    """The side x lies on: +1 above limit, -1 below -limit, else 0."""
    return select(x > limit, 1.0, select(x < -limit, -1.0, 0.0))


def speed_held(v, dv, speed, held):
    """The acceleration dv of a velocity v with the speed limit ``speed``: 0 where v is
    held at the limit (``held`` -1 or +1), dv where it is not (0); where held is
    :data:`AUTO`, 0 where v is at or beyond the limit and dv pushes it further."""
    auto = select(((v >= speed) & (dv > 0.0)) | ((v <= -speed) & (dv < 0.0)), 0.0, dv)
    return select(held == AUTO, auto, select(held == 0.0, dv, 0.0))


def speed_margin(v, dv, speed, held):
    """>= 0 while v's side ``held`` is right: not held (0), v within its limit
    (speed minus the size of v); held at +1 or -1, dv pushing it outward (held dv)."""
    return select(held == 0.0, speed - abs(v), held * dv)


def speed_side(v, dv, speed):
    """+1 or -1 where v is at or beyond that limit and dv pushes it further, else 0."""
    return select((v >= speed) & (dv > 0.0), 1.0, select((v <= -speed) & (dv < 0.0), -1.0, 0.0))


# --------------------------------------------------------------------- controllers
def kinematic_control_components(xd, yd, vxd, vyd, x, y, psi, a, kx, ky, lx, ly):
    """Eq. (10) in components: (u_d, w_d) that make h = (x, y) track
    h_d = (xd, yd) moving at (vxd, vyd) (:func:`unidyn.model.laws.kinematic_control`)."""
    nux = vxd + lx * tanh(kx * (xd - x) / lx)
    nuy = vyd + ly * tanh(ky * (yd - y) / ly)
    c = cos(psi)
    s = sin(psi)
    return c * nux + s * nuy, (-s * nux + c * nuy) / a


def kinematic_control_and_rate_components(xd, yd, vxd, vyd, axd, ayd, x, y, psi, u, w, a, kx, ky, lx, ly):
    """Eq. (10) and its time derivative along the motion, in components:
    (u_d, w_d, u_d', w_d') (:func:`unidyn.model.laws.kinematic_control_and_rate`), with
    h' from Eq. (1) at the velocities (u, w) and psi' = w."""
    tx = tanh(kx * (xd - x) / lx)
    ty = tanh(ky * (yd - y) / ly)
    nux = vxd + lx * tx
    nuy = vyd + ly * ty
    c = cos(psi)
    s = sin(psi)
    hdx, hdy = point_velocity_components(psi, u, w, a)
    # sech^2 = 1 - tanh^2 (exact to an absolute 1e-16: no cosh, which overflows)
    ndx = axd + kx * (1.0 - tx * tx) * (vxd - hdx)
    ndy = ayd + ky * (1.0 - ty * ty) * (vyd - hdy)
    # d/dt A^-1(psi) = w [[-sin, cos], [-cos/a, -sin/a]]
    return (c * nux + s * nuy, (-s * nux + c * nuy) / a,
            w * (-s * nux + c * nuy) + c * ndx + s * ndy,
            (w * (-c * nux - s * nuy) - s * ndx + c * ndy) / a)


def compensation_regressor_components(ud, wd, udd, wdd, u, w, ku, kw, lu, lw):
    """The regressor G of Eq. (14) in components, row by row (12 entries,
    G[0, 0..5], G[1, 0..5]) (:func:`unidyn.model.laws.compensation_regressor`)."""
    s1 = udd + lu * tanh(ku * (ud - u) / lu)
    s2 = wdd + lw * tanh(kw * (wd - w) / lw)
    return (s1, 0.0, -wd * w, ud, 0.0, 0.0,
            0.0, s2, ud * w - u * wd, 0.0, u * wd, wd)


def compensation_components(G, th):
    r"""Eq. (12) in the linear form of Eq. (14), :math:`v_r = G\hat\theta`, in
    components: (u_r, w_r) from the 12 entries of G and the six estimates th[0..5]
    (:func:`unidyn.model.laws.compensation`)."""
    ur = G[0] * th[0]
    wr = G[6] * th[0]
    for j in range(1, 6):
        ur = ur + G[j] * th[j]
        wr = wr + G[6 + j] * th[j]
    return ur, wr


def adaptation_rate_components(g0, g1, u_tilde, w_tilde, gamma, leak, theta_hat):
    """Eqs. (18)/(20) for one estimate j, in components:
    gamma_j (G[0, j] u~ + G[1, j] w~) - leak_j theta_hat_j
    (:func:`unidyn.model.laws.adaptation_rate`; ``leak`` from
    :func:`unidyn.model.laws.leakage_rate`)."""
    return gamma * (g0 * u_tilde + g1 * w_tilde) - leak * theta_hat


# -------------------------------------------------------------------- trajectories
# A kind of reference is a function below, of t and the kind's numbers, returning
# (x_d, y_d, x_d', y_d', x_d'', y_d''); its class in :mod:`unidyn.model.trajectories`
# holds its numbers, and its code names it in the parameter table (:data:`P`, entry
# ``trajectory``), where :func:`reference_components` reads it. A new kind: its function,
# its code and its line in :func:`reference_components` here, its class there.

#: The figure eight's code (:func:`figure_eight`) in the table entry ``trajectory``.
FIGURE_EIGHT = 0
#: The circle's code (:func:`circle`, the radius by :func:`stepped_radius`).
CIRCLE = 1
#: The line's code (:func:`line`; a goal point is a line at rest).
LINE = 2
#: The segment's code (:func:`segment`).
SEGMENT = 3
#: The code of a reference that is a Python function: not compiled, the engine calls it.
PYTHON = -1


def figure_eight(t, ax, ay, wx, wy, cx, cy):
    r"""The paper's figure eight (Section 5), :math:`x_d = c_x + A_x\sin\omega_x t,\
    y_d = c_y + A_y(\cos\omega_y t - 1)`: (x_d, y_d, x_d', y_d', x_d'', y_d'')."""
    sx = sin(wx * t)
    cxw = cos(wx * t)
    sy = sin(wy * t)
    cyw = cos(wy * t)
    return (cx + ax * sx, cy + ay * (cyw - 1.0), ax * wx * cxw, -ay * wy * sy,
            -ax * wx * wx * sx, -ay * wy * wy * cyw)


def circle(t, radius, omega, cx, cy, phase):
    r"""A circle, :math:`h_d = c + R[\cos(\omega t + \phi), \sin(\omega t + \phi)]`:
    (x_d, y_d, x_d', y_d', x_d'', y_d''). For a circle whose radius steps, R is the
    current radius (:func:`stepped_radius`), and the derivatives are those of the circle
    of that radius."""
    arg = omega * t + phase
    c = cos(arg)
    s = sin(arg)
    return (cx + radius * c, cy + radius * s, -radius * omega * s, radius * omega * c,
            -radius * omega * omega * c, -radius * omega * omega * s)


def stepped_radius(t, radius, steps):
    r"""The radius at time t of a circle whose radius steps (the circle of the authors'
    MATLAB package): ``radius`` before the first step, :math:`R_k` from :math:`t_k` on
    (:math:`t \ge t_k`). ``steps`` = (t_1, R_1, t_2, R_2, ...) with increasing times, s,
    and radii, m; a pair with t_k = inf never applies. With no step it is ``radius``
    itself."""
    r = radius
    for k in range(0, len(steps), 2):
        r = select(t >= steps[k], steps[k + 1], r)
    return r


def line(t, x0, y0, vx, vy):
    r"""A straight line at constant velocity, :math:`h_d = p_0 + v t`:
    (x_d, y_d, x_d', y_d', x_d'', y_d'')."""
    return x0 + vx * t, y0 + vy * t, vx + 0.0 * t, vy + 0.0 * t, 0.0 * t, 0.0 * t


def segment(t, ts, x0, y0, x1, y1, duration):
    r"""A straight segment from :math:`p_0` = (x0, y0) to :math:`p_1` = (x1, y1) travelled
    at constant speed in ``duration`` s (> 0), then :math:`p_1` held:
    :math:`h_d = p_0 + (p_1 - p_0)\,t / t_a` for :math:`t < t_a`, :math:`p_1` from
    :math:`t_a` on: (x_d, y_d, x_d', y_d', x_d'', y_d''). The velocity jumps to 0 at the
    arrival, judged at time ts (:math:`t_s \ge t_a - ` :data:`SWITCH_TOL`, the side of the
    switch every engine takes); the acceleration is 0 on both sides (no impulse)."""
    moving = ts < duration - SWITCH_TOL
    s = t / duration
    vx = select(moving, (x1 - x0) / duration, 0.0)
    vy = select(moving, (y1 - y0) / duration, 0.0)
    return (select(moving, x0 + (x1 - x0) * s, x1), select(moving, y0 + (y1 - y0) * s, y1),
            vx + 0.0 * t, vy + 0.0 * t, 0.0 * t, 0.0 * t)


def reference_components(t, ts, p):
    r"""(x_d, y_d, x_d', y_d', x_d'', y_d'') at time t of the reference one run's parameters
    p name (:data:`P`: its code in ``trajectory``, its numbers in ``path1``, ``path2``, ...
    in the order of its function's arguments after t), its steps judged at time ts (a
    circle's radius; the batch engine's step start, since a step never spans a step of
    the reference). p is one run's: this function branches on its code. An unknown code
    gives NaN."""
    code = p[P.trajectory]
    if code == FIGURE_EIGHT:
        return figure_eight(t, p[P.path1], p[P.path2], p[P.path3], p[P.path4], p[P.path5],
                            p[P.path6])
    if code == CIRCLE:
        steps = p[P.step_time1:P.step_time1 + 2 * RADIUS_STEPS]  # unused: at t = inf
        return circle(t, stepped_radius(ts, p[P.path1], steps), p[P.path2], p[P.path3],
                      p[P.path4], p[P.path5])
    if code == LINE:
        return line(t, p[P.path1], p[P.path2], p[P.path3], p[P.path4])
    if code == SEGMENT:
        return segment(t, ts, p[P.path1], p[P.path2], p[P.path3], p[P.path4], p[P.path5])
    nan = math.nan
    return nan, nan, nan, nan, nan, nan


#: The most radius steps of a circle the compiled engine holds (the table entries
#: ``step_time1``, ``step_radius1``, ...): eight, twice the schedule of the authors'
#: MATLAB package.
RADIUS_STEPS = 8


# ---------------------------------------------------------------- the Fig. 2 loop
#: The state of one run of the Fig. 2 loop: the robot (u, w unused for a kinematic
#: robot), the compensator's estimate, the derivative filter's states.
STATE = ("x", "y", "psi", "u", "w", "theta_hat1", "theta_hat2", "theta_hat3",
         "theta_hat4", "theta_hat5", "theta_hat6", "z_u", "z_w")
#: Index of each state by name (S.x, S.theta_hat1, ...).
S = namedtuple("LoopState", STATE)(*range(len(STATE)))
#: The number of states of the loop.
NSTATE = len(STATE)

#: The per-run parameter table of the Fig. 2 loop, one value per name; see
#: :meth:`unidyn.model.closed_loop.ClosedLoop.parameter_table`. ``dynamic`` (1: the robot has
#: Eq. 2, 0: kinematic), ``compensated`` (1: v_ref = G theta_hat, Eq. 14; 0: v_ref = v_d)
#: and ``filtered`` (1: v_d' from the filter (v_d - z)/tau; 0: the exact rate) are
#: 0/1; ``leak1..6`` are the leakage rates of :func:`adaptation_rate_components`; ``adapt_from`` is
#: inf where the estimate is not adapted; ``trajectory`` is the reference's code
#: (:data:`FIGURE_EIGHT`, ...), ``path1..6`` its numbers, in the order of its function's
#: arguments (:func:`reference_components`); ``step_time1``, ``step_radius1``, ... the
#: times the reference steps (the batch engine ends a step there), for a circle with
#: the radius from then on (:func:`stepped_radius`), for a segment its arrival (inf or 0: unused);
#: ``payload_time1``, ``payload_mass1``, ... the robot's payload schedule
#: (:func:`payload_theta`; theta1..6 are the empty robot's; time inf: unused).
LOOP_PARAMETERS = (
    THETA_NAMES + ("a", "kx", "ky", "lx", "ly", "ku", "kw", "lu", "lw")
    + tuple(f"gamma{j}" for j in range(1, 7)) + tuple(f"leak{j}" for j in range(1, 7))
    + ("adapt_from", "tau", "filtered", "dynamic", "compensated",
       "speed_u", "speed_w", "accel_u", "accel_w", "trajectory")
    + tuple(f"path{j}" for j in range(1, 7))
    + tuple(f"step_{v}{j}" for j in range(1, RADIUS_STEPS + 1) for v in ("time", "radius"))
    + tuple(f"payload_{v}{j}" for j in range(1, PAYLOAD_STEPS + 1) for v in ("time", "mass")))
#: Index of each parameter by name (P.kx, P.gamma1, ...).
P = namedtuple("LoopParameter", LOOP_PARAMETERS)(*range(len(LOOP_PARAMETERS)))


def loop_signals(X, ref, p, noise):
    r"""The signals of the Fig. 2 loop at state X: returns
    (u_d, w_d, u_d', w_d', G, u_ref, w_ref, u_meas, w_meas).

    :param X: the state, indexed by :data:`S` (X[S.x] a float, or an array of runs)
    :param ref: (x_d, y_d, x_d', y_d', x_d'', y_d'')
    :param p: the parameters, indexed by :data:`P`
    :param noise: (position noise x, y, velocity noise u, w), added to the measurements

    Eq. (10) on the measured position and heading, its exact rate (or the derivative
    filter), the regressor of Eq. (14) on the measured velocities, and the command:
    :math:`G\hat\theta` with compensation, v_d without (before the speed limits).
    """
    um = X[S.u] + noise[2]
    wm = X[S.w] + noise[3]
    ud, wd, rate_u, rate_w = kinematic_control_and_rate_components(
        ref[0], ref[1], ref[2], ref[3], ref[4], ref[5], X[S.x] + noise[0], X[S.y] + noise[1],
        X[S.psi], um, wm, p[P.a], p[P.kx], p[P.ky], p[P.lx], p[P.ly])
    filtered = p[P.filtered] != 0.0
    udd = select(filtered, (ud - X[S.z_u]) / p[P.tau], rate_u)
    wdd = select(filtered, (wd - X[S.z_w]) / p[P.tau], rate_w)
    G = compensation_regressor_components(ud, wd, udd, wdd, um, wm, p[P.ku], p[P.kw], p[P.lu], p[P.lw])
    ur, wr = compensation_components(G, (X[S.theta_hat1], X[S.theta_hat2], X[S.theta_hat3],
                              X[S.theta_hat4], X[S.theta_hat5], X[S.theta_hat6]))
    compensated = p[P.compensated] != 0.0
    return (ud, wd, udd, wdd, G, select(compensated, ur, ud), select(compensated, wr, wd),
            um, wm)


def loop_rates(t, X, ref, p, noise):
    r"""dX/dt of the Fig. 2 loop, as a tuple of the 13 rates in the order of :data:`S`,
    every switch decided at this point (:func:`loop_rates_held` with :data:`AUTO`).

    The commands are clipped to the speed limits; the robot follows Eqs. (1)-(2)
    with its parameters at time t under the payload schedule (:func:`payload_theta`;
    the compensator keeps its own estimate) and the acceleration limits
    (:func:`limited_acceleration`), or Eq. (1) with
    v = the clipped command for a kinematic robot; the estimate follows
    Eqs. (18)/(20) from ``adapt_from`` on (:func:`adaptation_rate_components`, with the velocity
    error v_d - v_meas); the derivative filter integrates v_d'. Arguments as
    :func:`loop_signals` (X and p may be tuples: the compiled engine passes one run's
    values in registers).
    """
    return loop_rates_held(t, X, ref, p, noise,
                           (t, AUTO, AUTO, AUTO, AUTO, AUTO, AUTO))[0]


def loop_rates_held(t, X, ref, p, noise, mode):
    r"""dX/dt of the Fig. 2 loop with its switches held as ``mode`` says
    (:data:`MODE`: the time at which adaptation and the payload are judged, then each
    switch's side or :data:`AUTO`), as :func:`loop_rates` describes it. Returns
    (the 13 rates; each switch's margin, >= 0 while its held side is right
    (:func:`clip_margin`, :func:`speed_margin`); the side each switch would take here
    given the sides held before it in :data:`SWITCHES` (:func:`clip_side`,
    :func:`speed_side`); the value each switch clips or holds: u_ref, w_ref, the
    accelerations of Eq. (2) before and after their limits). A reference whose radius
    steps is evaluated by the caller."""
    ts = mode[0]
    ud, wd, udd, wdd, G, u_ref, w_ref, um, wm = loop_signals(X, ref, p, noise)
    uc = clip_held(u_ref, p[P.speed_u], mode[1])
    wc = clip_held(w_ref, p[P.speed_w], mode[2])
    u = X[S.u]
    w = X[S.w]
    th1, th2, th3, th4, th5, th6 = payload_theta(
        ts, p[P.theta1], p[P.theta2], p[P.theta3], p[P.theta4], p[P.theta5], p[P.theta6],
        p[P.payload_time1:P.payload_time1 + 2 * PAYLOAD_STEPS])
    du0, dw0 = dynamics_components(u, w, uc, wc, th1, th2, th3, th4, th5, th6)
    du1 = clip_held(du0, p[P.accel_u], mode[3])
    dw1 = clip_held(dw0, p[P.accel_w], mode[4])
    du = speed_held(u, du1, p[P.speed_u], mode[5])
    dw = speed_held(w, dw1, p[P.speed_w], mode[6])
    dynamic = p[P.dynamic] != 0.0
    u_move = select(dynamic, u, uc)
    w_move = select(dynamic, w, wc)
    dx, dy = point_velocity_components(X[S.psi], u_move, w_move, p[P.a])
    on = ts >= p[P.adapt_from] - SWITCH_TOL
    u_tilde = ud - um
    w_tilde = wd - wm
    r = loop_adaptation_rates(G, u_tilde, w_tilde, p, X)
    filtered = p[P.filtered] != 0.0
    du = select(dynamic, du, 0.0)
    dw = select(dynamic, dw, 0.0)
    rates = (dx, dy, w_move, du, dw,
             select(on, r[0], 0.0), select(on, r[1], 0.0), select(on, r[2], 0.0),
             select(on, r[3], 0.0), select(on, r[4], 0.0), select(on, r[5], 0.0),
             select(filtered, udd, 0.0), select(filtered, wdd, 0.0))
    # a kinematic robot has only its commands' switches (its u, w are not states)
    margins = (clip_margin(u_ref, p[P.speed_u], mode[1]), clip_margin(w_ref, p[P.speed_w], mode[2]),
               select(dynamic, clip_margin(du0, p[P.accel_u], mode[3]), 1.0),
               select(dynamic, clip_margin(dw0, p[P.accel_w], mode[4]), 1.0),
               select(dynamic, speed_margin(u, du1, p[P.speed_u], mode[5]), 1.0),
               select(dynamic, speed_margin(w, dw1, p[P.speed_w], mode[6]), 1.0))
    sides = (clip_side(u_ref, p[P.speed_u]), clip_side(w_ref, p[P.speed_w]),
             select(dynamic, clip_side(du0, p[P.accel_u]), 0.0),
             select(dynamic, clip_side(dw0, p[P.accel_w]), 0.0),
             select(dynamic, speed_side(u, du1, p[P.speed_u]), 0.0),
             select(dynamic, speed_side(w, dw1, p[P.speed_w]), 0.0))
    # the values the switches clip: while one is held at its limit, they drive no rate
    # and no state's error sees them (the batch engine resolves them as it resolves the states)
    signals = (u_ref, w_ref, select(dynamic, du0, 0.0), select(dynamic, dw0, 0.0),
               select(dynamic, du1, 0.0), select(dynamic, dw1, 0.0))
    return rates, margins, sides, signals


def next_switch_time(t, p):
    """The first time after t (by more than :data:`SWITCH_TOL`) at which a time switch
    of the loop with parameters p flips: adaptation on (``adapt_from``), a payload
    step, a step of the reference (``step_time1``, ...: a circle's radius, a segment's
    arrival); inf if none. The batch engine ends a step there. Scalar arguments only (one
    run's t and parameter row): unlike the rest of this module, it branches on values."""
    first = math.inf
    if p[P.adapt_from] > t + SWITCH_TOL:
        first = min(first, p[P.adapt_from])
    for k in range(PAYLOAD_STEPS):
        tk = p[P.payload_time1 + 2 * k]
        if tk > t + SWITCH_TOL:
            first = min(first, tk)
    for k in range(RADIUS_STEPS):
        tk = p[P.step_time1 + 2 * k]
        if tk > t + SWITCH_TOL:
            first = min(first, tk)
    return first


def loop_adaptation_rates(G, u_tilde, w_tilde, p, X):
    """:func:`adaptation_rate_components` for the six estimates of the loop state X (parameters p
    indexed by :data:`P`), as a tuple."""
    return (
        adaptation_rate_components(G[0], G[6], u_tilde, w_tilde, p[P.gamma1], p[P.leak1], X[S.theta_hat1]),
        adaptation_rate_components(G[1], G[7], u_tilde, w_tilde, p[P.gamma2], p[P.leak2], X[S.theta_hat2]),
        adaptation_rate_components(G[2], G[8], u_tilde, w_tilde, p[P.gamma3], p[P.leak3], X[S.theta_hat3]),
        adaptation_rate_components(G[3], G[9], u_tilde, w_tilde, p[P.gamma4], p[P.leak4], X[S.theta_hat4]),
        adaptation_rate_components(G[4], G[10], u_tilde, w_tilde, p[P.gamma5], p[P.leak5], X[S.theta_hat5]),
        adaptation_rate_components(G[5], G[11], u_tilde, w_tilde, p[P.gamma6], p[P.leak6], X[S.theta_hat6]))


def loop_derivative(t, X, ref, p, noise, dX):
    """:func:`loop_rates` written into dX (indexed by :data:`S`)."""
    d = loop_rates(t, X, ref, p, noise)
    for i in range(len(STATE)):
        dX[i] = d[i]