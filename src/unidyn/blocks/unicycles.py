"""Robot blocks: the dynamic unicycle of Martins et al. (2017) and its kinematic limit."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from bdsim.components import ContinuousBlock

from unidyn._validate import ValidationError, flag, positive, real, vector
from unidyn.model.parameters import RobotParameters, payload_schedule
from unidyn.model.unicycle import Limits

from ..model import robots, unicycle
from .arguments import (
    check_blockargs,
    check_fixed_blockargs,
    limits_from_args,
    optional_limit,
    records_arguments,
)
from .signals import as_vector, check_finite, qualified_state_names


class DynamicUnicycle(ContinuousBlock):
    r"""
    :blockname:`DYNAMICUNICYCLE`

    Differential-drive robot with the velocity-based dynamic model of Martins et al. (2017).

    :inputs: 2 (3 with ``disturbance=True``)
    :outputs: 1 (2 with ``velocity_output=True``)
    :states: 5

    .. list-table::
        :header-rows: 1

        *   - Port type
            - Port number
            - Types
            - Description
        *   - Input
            - 0
            - float
            - :math:`u_{ref}`, linear velocity command, m/s (label ``v``)
        *   - Input
            - 1
            - float
            - :math:`\omega_{ref}`, angular velocity command, rad/s (label ``ω``)
        *   - Input
            - 2
            - ndarray(4)
            - :math:`\delta = (\delta_x, \delta_y, \delta_u, \delta_\omega)`, disturbance
              (only with ``disturbance=True``; label ``delta``)
        *   - Output
            - 0
            - ndarray(3)
            - :math:`q = (x, y, \psi)`, pose of the point of interest h, m and rad (label ``q``)
        *   - Output
            - 1
            - ndarray(2)
            - :math:`v = (u, \omega)`, actual velocities, m/s and rad/s, only with
              ``velocity_output=True`` (label ``velocity``)

    A drop-in replacement for the Robotics Toolbox's kinematic ``UNICYCLE``: the
    same input ports, labels and constructor arguments, with the pose on output
    0, but the commands now drive the robot's velocities through its dynamics,
    Eq. (2), instead of setting them:

    .. math::

        \dot x &= u\cos\psi - a\omega\sin\psi + \delta_x, \qquad
        \dot y = u\sin\psi + a\omega\cos\psi + \delta_y, \qquad
        \dot\psi = \omega \qquad &\text{Eq. (1)} \\
        \dot u &= \frac{\theta_3}{\theta_1}\omega^2 - \frac{\theta_4}{\theta_1}u
                 + \frac{u_{ref}}{\theta_1} + \delta_u, \qquad
        \dot\omega = -\frac{\theta_5}{\theta_2}u\omega - \frac{\theta_6}{\theta_2}\omega
                 + \frac{\omega_{ref}}{\theta_2} + \delta_\omega \qquad &\text{Eq. (2)}

    The velocity output is off by default: bdsim connects a whole block
    (``bd.connect(vehicle, xy, theta, vplot)``, as toolbox models do) only when
    it has a single output, so the default keeps such diagrams running unchanged.
    The Fig. 2 loop feeds the velocities back and turns it on.

    State order ``x, y, psi, u, w``, named ``<block name>:x`` ... in bdsim's
    ``out.xnames`` (``out.x[:, :3]`` is the pose and ``out.x[:, 3:]`` the velocities
    when the robot is the diagram's only stateful block). With ``a = 0`` (the
    default) h is the wheel-axle centre, as for ``UNICYCLE``. Commands are clipped
    to the speed limits, the accelerations to the acceleration limits, and a
    velocity at its limit is not pushed beyond it. The velocity output, and the
    velocities that move the pose, hold the speed limits exactly; the velocity
    states bdsim logs (``out.x``) may pass them by the solver's tolerance (see
    :meth:`within_limits`).

    :seealso: :class:`KinematicUnicycle`, :func:`unidyn.model.unicycle.unicycle_deriv`
    """

    nin = 2
    nout = 1
    inlabels = ("v", "ω")
    outlabels = ("q",)

    @records_arguments
    def __init__(self, robot: str | RobotParameters | Sequence[float] = "p3dx_laser",
                 a: float = 0.0, x0: Sequence[float] | None = None, speed_max: float = np.inf,
                 accel_max: float = np.inf, steer_max: float = np.inf,
                 angular_accel_max: float = np.inf, limits: Limits | None = None,
                 disturbance: bool = False, velocity_output: bool = False,
                 w: float | None = None, payload: Sequence | float | None = None,
                 **blockargs):
        r"""
        :param robot: preset name (see ``unidyn.model.robots.names()``), ``RobotParameters``
            or six numbers theta1..theta6, defaults to ``"p3dx_laser"``
        :type robot: str, RobotParameters or array_like(6)
        :param a: distance from the axle centre to the point of interest h, m, >= 0, defaults to 0
        :type a: float
        :param x0: initial pose (x, y, psi) with the robot at rest, or full state
            (x, y, psi, u, w) with \|u\| <= speed_max and \|w\| <= steer_max (else
            a ValidationError), defaults to zeros
        :type x0: array_like(3) or array_like(5), optional
        :param speed_max: max \|u\|, m/s, > 0 (inf or None: no limit), defaults to inf
        :type speed_max: float
        :param accel_max: max \|u'\|, m/s², > 0 (inf or None: no limit), defaults to inf
        :type accel_max: float
        :param steer_max: max \|w\|, rad/s, > 0 (inf or None: no limit), defaults to inf
        :type steer_max: float
        :param angular_accel_max: max \|w'\|, rad/s², > 0 (inf or None: no limit), defaults to inf
        :type angular_accel_max: float
        :param limits: all four limits at once (overrides the four arguments above)
        :type limits: unidyn.Limits, optional
        :param disturbance: add input 2, the disturbance delta of Eqs. (1)-(2)
        :type disturbance: bool
        :param velocity_output: add output 1, the actual velocities (u, w), defaults to False
        :type velocity_output: bool
        :param w: vehicle width, m, > 0; accepted for compatibility with ``UNICYCLE`` and
            unused: input 1 is the turn rate. (roboticstoolbox 1.4's ``UNICYCLE`` divides
            its ω input by ``w``, unlike its docstring, so a diagram built with ``w != 1``
            turns at a different rate after the swap.)
        :type w: float, optional
        :param payload: a load that changes during the run: rows ``[t, mass scale]``,
            from t (s) on the mass is that multiple of ``robot``'s (the empty robot),
            which multiplies theta1, theta2, theta3, theta5 in Eq. (2)
            (:func:`unidyn.model.equations.payload_theta`); increasing times, scales
            > 0, at most 8 rows; a number m is ``[[0, m]]``; defaults to none
        :type payload: list of [float, float], float or None
        :param blockargs: common block options (``name``, ``inputs``, ...)
        :type blockargs: dict
        """
        self.params = robots.resolve(robot)
        self.theta = self.params.theta
        self.payload = payload_schedule(payload)
        self.a = real("a", a, low=0.0)
        self.limits = limits_from_args(limits, speed_max, steer_max, accel_max, angular_accel_max)
        self.width = None if w is None else positive("w", w)
        self.x0 = np.zeros(5) if x0 is None else x0
        disturbance = flag("disturbance", disturbance)
        self.disturbance = bool(disturbance)
        if self.disturbance:
            blockargs.setdefault("inames", ["v", "ω", "delta"])
            blockargs.setdefault("nin", 3)
        velocity_output = flag("velocity_output", velocity_output)
        self.velocity_output = bool(velocity_output)
        if self.velocity_output:
            blockargs.setdefault("onames", ["q", "velocity"])
            blockargs.setdefault("nout", 2)
        check_blockargs(self, blockargs)
        self._own_state_names = blockargs.get("snames") is not None
        super().__init__(nstates=5, x0=self.x0, **blockargs)
        self.type = "dynamicunicycle"

    #: the states, named ``<block name>:<state>`` in ``out.xnames``
    STATES = ("x", "y", "psi", "u", "w")

    @property
    def x0(self) -> np.ndarray:
        """The initial state (x, y, psi, u, w), m, rad, m/s, rad/s, used by the next run.

        Set it to a pose (x, y, psi), the robot at rest, or to a whole state, within
        the speed limits. ``_x0`` is the same property: toolbox scripts (RVC3's
        ``bd['vehicle']._x0 = (x, y, theta)``) and bdsim use that name."""
        return self._state0

    @x0.setter
    def x0(self, value) -> None:
        x0 = vector("x0", value, (3, 5))
        if x0.shape[0] == 3:
            x0 = np.r_[x0, 0.0, 0.0]
        for j, name, lim, unit in ((3, "u", self.limits.speed_max, "m/s"),
                                   (4, "w", self.limits.steer_max, "rad/s")):
            if abs(x0[j]) > lim:
                raise ValidationError(
                    f"DynamicUnicycle: the initial speed x0[{j}] ({name} = {x0[j]:g} {unit}) is beyond "
                    f"the limit {lim:g} {unit}; start the robot within its limits")
        self._state0 = x0
        self.arguments["x0"] = value  # the block is rebuilt with the x0 it runs from

    _x0 = x0

    def check(self):
        if not self._own_state_names:
            qualified_state_names(self, self.STATES)
        super().check()

    def within_limits(self, x) -> np.ndarray:
        """The state ``x`` with its velocities clipped to the speed limits.

        The solution of Eqs. (1)-(2) never leaves the limits, but an adaptive
        solver's step that reaches one lands beyond it by up to its tolerance (0.1 %
        at bdsim's defaults), and the state stays there while the limit holds.
        Clipping moves the solver's state towards the exact solution, never away;
        the outputs and the right-hand side see the clipped state."""
        x = np.array(x, dtype=float)
        if self.limits.active:
            x[3:5] = np.clip(x[3:5], -self.limits.speed, self.limits.speed)
        return x

    def theta_at(self, t: float) -> np.ndarray:
        """theta1..theta6 of the robot at time t, s, under its ``payload`` schedule
        (:func:`unidyn.model.equations.payload_theta`)."""
        return unicycle.loaded_theta(self.theta, self.payload, t)

    def deriv(self, t, inports, x):
        v_ref = np.array([as_vector(inports[0], 1, self, "v", t)[0],
                          as_vector(inports[1], 1, self, "ω", t)[0]])
        delta = as_vector(inports[2], 4, self, "delta", t) if self.disturbance else None
        xd = unicycle.unicycle_deriv(self.within_limits(x), v_ref, self.theta_at(t), self.a,
                                     self.limits, delta)
        return check_finite(xd, self, "state derivative", t)

    def output(self, t, inports, x):
        x = self.within_limits(x)
        if self.velocity_output:
            return [x[0:3], x[3:5]]
        return [x[0:3]]


class KinematicUnicycle(ContinuousBlock):
    r"""
    :blockname:`KINEMATICUNICYCLE`

    Purely kinematic robot with a point of interest ahead of the axle (the paper's case 1).

    :inputs: 2
    :outputs: 1
    :states: 3

    .. list-table::
        :header-rows: 1

        *   - Port type
            - Port number
            - Types
            - Description
        *   - Input
            - 0
            - float
            - :math:`u_{ref}`, linear velocity command, m/s (label ``v``)
        *   - Input
            - 1
            - float
            - :math:`\omega_{ref}`, angular velocity command, rad/s (label ``ω``)
        *   - Output
            - 0
            - ndarray(3)
            - :math:`q = (x, y, \psi)`, pose of the point of interest h (label ``q``)

    Eq. (1) with :math:`v = v_{ref}` (an ideal velocity loop, commands clipped to
    the speed limits): the same inputs and pose output as :class:`DynamicUnicycle`
    and ``UNICYCLE``, so the three swap in a diagram.

    .. math::

        \dot x = u_{ref}\cos\psi - a\omega_{ref}\sin\psi, \quad
        \dot y = u_{ref}\sin\psi + a\omega_{ref}\cos\psi, \quad
        \dot\psi = \omega_{ref}
    """

    nin = 2
    nout = 1
    inlabels = ("v", "ω")
    outlabels = ("q",)

    @records_arguments
    def __init__(self, a: float = 0.0, x0: Sequence[float] | None = None,
                 speed_max: float = np.inf, steer_max: float = np.inf,
                 limits: Limits | None = None, **blockargs):
        r"""
        :param a: distance from the axle centre to the point of interest h, m, >= 0, defaults to 0
        :type a: float
        :param x0: initial pose (x, y, psi), defaults to zeros
        :type x0: array_like(3), optional
        :param speed_max: max \|u\|, m/s, > 0 (inf or None: no limit), defaults to inf
        :type speed_max: float
        :param steer_max: max \|w\|, rad/s, > 0 (inf or None: no limit), defaults to inf
        :type steer_max: float
        :param limits: speed limits as a ``unidyn.Limits`` (acceleration limits are ignored)
        :type limits: unidyn.Limits, optional
        :param blockargs: common block options
        :type blockargs: dict
        """
        self.a = real("a", a, low=0.0)
        self.limits = limits_from_args(limits, speed_max, steer_max, np.inf, np.inf)
        self.x0 = np.zeros(3) if x0 is None else x0
        check_blockargs(self, blockargs)
        self._own_state_names = blockargs.get("snames") is not None
        super().__init__(nstates=3, x0=self.x0, **blockargs)
        self.type = "kinematicunicycle"

    #: the states, named ``<block name>:<state>`` in ``out.xnames``
    STATES = ("x", "y", "psi")

    @property
    def x0(self) -> np.ndarray:
        """The initial pose (x, y, psi), m and rad, used by the next run; set it to
        a pose, or to a state (x, y, psi, u, w) of which the pose is kept. ``_x0``
        is the same property (the name toolbox scripts and bdsim use)."""
        return self._state0

    @x0.setter
    def x0(self, value) -> None:
        self._state0 = vector("x0", value, (3, 5))[:3]
        self.arguments["x0"] = value  # the block is rebuilt with the x0 it runs from

    _x0 = x0

    def check(self):
        if not self._own_state_names:
            qualified_state_names(self, self.STATES)
        super().check()

    def _v(self, t, inports):
        v = np.array([as_vector(inports[0], 1, self, "v", t)[0],
                      as_vector(inports[1], 1, self, "ω", t)[0]])
        return np.clip(v, -self.limits.speed, self.limits.speed)

    def deriv(self, t, inports, x):
        return unicycle.kinematic_unicycle_deriv(x, self._v(t, inports), self.a)

    def output(self, t, inports, x):
        return [np.array(x[0:3])]


class DynamicUnicycleWithVelocity(DynamicUnicycle):
    r"""
    :blockname:`DYNAMICUNICYCLEWITHVELOCITY`

    Dynamic unicycle of Eqs. (1)-(2) with its actual velocities as a second output (robot R of Fig. 2).

    :inputs: 2
    :outputs: 2
    :states: 5

    .. list-table::
        :header-rows: 1

        *   - Port type
            - Port number
            - Types
            - Description
        *   - Input
            - 0
            - float
            - :math:`u_{ref}`, linear velocity command, m/s (label ``v``)
        *   - Input
            - 1
            - float
            - :math:`\omega_{ref}`, angular velocity command, rad/s (label ``ω``)
        *   - Output
            - 0
            - ndarray(3)
            - :math:`q = (x, y, \psi)`, pose of the point of interest h, m and rad (label ``q``)
        *   - Output
            - 1
            - ndarray(2)
            - :math:`v = (u, \omega)`, actual velocities, m/s and rad/s (label ``velocity``)

    :class:`DynamicUnicycle` with ``velocity_output=True``, as a block whose ports
    never change (so that bdedit draws it): the robot R of the paper's Fig. 2,
    whose velocities are fed back to the kinematic controller and to the
    dynamic compensator.

    .. math::

        \dot x = u\cos\psi - a\omega\sin\psi, \quad
        \dot y = u\sin\psi + a\omega\cos\psi, \quad
        \dot\psi = \omega \qquad \text{Eq. (1)} \\
        \dot u = \frac{\theta_3}{\theta_1}\omega^2 - \frac{\theta_4}{\theta_1}u
                 + \frac{u_{ref}}{\theta_1}, \quad
        \dot\omega = -\frac{\theta_5}{\theta_2}u\omega - \frac{\theta_6}{\theta_2}\omega
                 + \frac{\omega_{ref}}{\theta_2} \qquad \text{Eq. (2)}

    A limit left at None is no limit.

    :seealso: :class:`DynamicUnicycle`, :func:`unidyn.model.unicycle.unicycle_deriv`
    """

    nin = 2
    nout = 2
    inlabels = ("v", "ω")
    outlabels = ("q", "velocity")

    @records_arguments
    def __init__(self, robot: str | RobotParameters | Sequence[float] = "p3dx_laser",
                 a: float = 0.0, x0: Sequence[float] = (0.0, 0.0, 0.0),
                 speed_max: float | None = None, accel_max: float | None = None,
                 steer_max: float | None = None, angular_accel_max: float | None = None,
                 payload: Sequence | float | None = None, **blockargs):
        r"""
        :param robot: preset name (``unidyn.model.robots.names()``) or six numbers theta1..theta6, defaults to p3dx_laser
        :type robot: str, RobotParameters or array_like(6)
        :param a: distance from the axle centre to the point of interest h, m, >= 0, defaults to 0
        :type a: float
        :param x0: initial pose (x, y, psi) with the robot at rest, or state (x, y, psi, u, w), defaults to (0, 0, 0)
        :type x0: array_like(3) or array_like(5)
        :param speed_max: max \|u\|, m/s, > 0, or None for no limit, defaults to None
        :type speed_max: float or None
        :param accel_max: max \|u'\|, m/s², > 0, or None for no limit, defaults to None
        :type accel_max: float or None
        :param steer_max: max \|w\|, rad/s, > 0, or None for no limit, defaults to None
        :type steer_max: float or None
        :param angular_accel_max: max \|w'\|, rad/s², > 0, or None for no limit, defaults to None
        :type angular_accel_max: float or None
        :param payload: rows ``[t, mass scale]``: from t (s) on the mass is that multiple
            of the empty robot's (see :class:`DynamicUnicycle`), defaults to none
        :type payload: list of [float, float], float or None
        :param blockargs: common block options (``name``, ``inputs``, ...)
        :type blockargs: dict
        """
        check_fixed_blockargs(self, blockargs)
        super().__init__(robot=robot, a=a, x0=x0,
                         speed_max=optional_limit("speed_max", speed_max),
                         accel_max=optional_limit("accel_max", accel_max),
                         steer_max=optional_limit("steer_max", steer_max),
                         angular_accel_max=optional_limit("angular_accel_max", angular_accel_max),
                         velocity_output=True, payload=payload, **blockargs)
