"""Controller blocks of Fig. 2: the kinematic controller K (Eq. 10) and the dynamic
compensator D (Eqs. 12, 14, 18, 20), continuous or sampled on a bdsim clock."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from bdsim.components import Clock, ContinuousBlock, FunctionBlock, SampledBlock

from unidyn._validate import (
    ValidationError,
    choice,
    flag,
    nonnegative,
    positive,
    positive_vector,
    vector,
)
from unidyn.model.laws import PAPER_GAMMA, PAPER_SIGMA
from unidyn.model.parameters import RobotParameters

from ..model import laws, robots
from .arguments import check_blockargs, check_clock, check_fixed_blockargs, records_arguments
from .signals import as_vector, check_finite

VD_DOT_CONTINUOUS = ("input", "filter")
VD_DOT_SAMPLED = ("input", "difference")


def _gains(kx, ky, lx, ly, a):
    return (np.array([positive("kx", kx), positive("ky", ky)]),
            np.array([positive("lx", lx), positive("ly", ly)]),
            positive("a", a))


class KinematicController(FunctionBlock):
    r"""
    :blockname:`KINEMATICCONTROLLER`

    Kinematic trajectory-tracking controller K of Fig. 2, Eq. (10), evaluated continuously.

    :inputs: 3 (5 with ``rate=True``)
    :outputs: 1 (2 with ``rate=True``)
    :states: 0

    .. list-table::
        :header-rows: 1

        *   - Port type
            - Port number
            - Types
            - Description
        *   - Input
            - 0
            - ndarray(2)
            - :math:`h_d`, desired position of the point of interest, m (label ``h_d``)
        *   - Input
            - 1
            - ndarray(2)
            - :math:`\dot h_d`, desired velocity, m/s (label ``h_d_dot``)
        *   - Input
            - 2
            - ndarray(3)
            - :math:`q = (x, y, \psi)`, measured pose of h, the robot's output 0 (label ``q``)
        *   - Input
            - 3
            - ndarray(2)
            - :math:`\ddot h_d`, desired acceleration, m/s², only with ``rate=True`` (label ``h_d_ddot``)
        *   - Input
            - 4
            - ndarray(2)
            - :math:`v = (u, \omega)`, measured velocities, only with ``rate=True`` (label ``v``)
        *   - Output
            - 0
            - ndarray(2)
            - :math:`v_d = (u_d, \omega_d)`, desired velocities, m/s and rad/s (label ``v_d``)
        *   - Output
            - 1
            - ndarray(2)
            - :math:`\dot v_d`, their exact time derivative, only with ``rate=True`` (label ``v_d_dot``)

    .. math::

        \begin{bmatrix} u_d \\ \omega_d \end{bmatrix} =
        \begin{bmatrix} \cos\psi & \sin\psi \\ -\frac{\sin\psi}{a} & \frac{\cos\psi}{a} \end{bmatrix}
        \begin{bmatrix} \dot x_d + l_x \tanh(k_x \tilde x / l_x) \\
                        \dot y_d + l_y \tanh(k_y \tilde y / l_y) \end{bmatrix} \qquad \text{Eq. (10)}

    With ``rate=True`` the block also outputs :math:`\dot v_d`, Eq. (10)
    differentiated along the motion (see :func:`unidyn.model.laws.kinematic_control_rate`),
    for the compensator's ``vd_dot="input"``.

    :seealso: :class:`SampledKinematicController`, :func:`unidyn.model.laws.kinematic_control`
    """

    nin = 3
    nout = 1
    inlabels = ("h_d", "h_d_dot", "q")
    outlabels = ("v_d",)

    @records_arguments
    def __init__(self, a: float = 0.2, kx: float = 0.1, ky: float = 0.1, lx: float = 0.1,
                 ly: float = 0.1, rate: bool = False, **blockargs):
        r"""
        :param a: distance from the axle centre to the controlled point h, m, > 0, defaults to 0.2
        :type a: float
        :param kx: gain on the x error, 1/s, > 0, defaults to 0.1
        :type kx: float
        :param ky: gain on the y error, 1/s, > 0, defaults to 0.1
        :type ky: float
        :param lx: saturation of the x correction, m/s, > 0, defaults to 0.1
        :type lx: float
        :param ly: saturation of the y correction, m/s, > 0, defaults to 0.1
        :type ly: float
        :param rate: add inputs h_d_ddot and v and output v_d_dot, defaults to False
        :type rate: bool
        :param blockargs: common block options
        :type blockargs: dict
        """
        self.k, self.l, self.a = _gains(kx, ky, lx, ly, a)
        rate = flag("rate", rate)
        self.rate = bool(rate)
        if self.rate:
            blockargs.setdefault("inames", ["h_d", "h_d_dot", "q", "h_d_ddot", "v"])
            blockargs.setdefault("onames", ["v_d", "v_d_dot"])
            blockargs.setdefault("nin", 5)
            blockargs.setdefault("nout", 2)
        check_blockargs(self, blockargs)
        super().__init__(**blockargs)
        self.type = "kinematiccontroller"

    def output(self, t, inports, x):
        h_d = as_vector(inports[0], 2, self, "h_d", t)
        h_d_dot = as_vector(inports[1], 2, self, "h_d_dot", t)
        q = as_vector(inports[2], 3, self, "q", t)
        if not self.rate:
            return [laws.kinematic_control(h_d, h_d_dot, q[:2], q[2], self.a, self.k, self.l)]
        h_d_ddot = as_vector(inports[3], 2, self, "h_d_ddot", t)
        v = as_vector(inports[4], 2, self, "v", t)
        return list(laws.kinematic_control_and_rate(h_d, h_d_dot, h_d_ddot, q[:2], q[2], v,
                                                    self.a, self.k, self.l))


class SampledKinematicController(SampledBlock):
    r"""
    :blockname:`SAMPLEDKINEMATICCONTROLLER`

    Kinematic controller K of Eq. (10) as a digital controller on a bdsim clock.

    :inputs: 3
    :outputs: 1
    :states: 2 (discrete)

    .. list-table::
        :header-rows: 1

        *   - Port type
            - Port number
            - Types
            - Description
        *   - Input
            - 0
            - ndarray(2)
            - :math:`h_d`, desired position, m (label ``h_d``)
        *   - Input
            - 1
            - ndarray(2)
            - :math:`\dot h_d`, desired velocity, m/s (label ``h_d_dot``)
        *   - Input
            - 2
            - ndarray(3)
            - :math:`q = (x, y, \psi)`, measured pose (label ``q``)
        *   - Output
            - 0
            - ndarray(2)
            - :math:`v_d = (u_d, \omega_d)`, held between ticks (label ``v_d``)

    At each clock tick :math:`t_k = kT` the block evaluates Eq. (10) on its
    inputs and holds the result until the next tick (zero-order hold). A bdsim
    clock first ticks at t = T, so the output is ``v_d0`` (default zero: robot at
    rest) over [0, T).

    .. math:: v_d(t) = \text{Eq. (10)}(h_d(t_k), \dot h_d(t_k), q(t_k)), \quad t_k \le t < t_{k+1}
    """

    nin = 3
    nout = 1
    inlabels = ("h_d", "h_d_dot", "q")
    outlabels = ("v_d",)

    @records_arguments
    def __init__(self, clock: Clock, a: float = 0.2, kx: float = 0.1, ky: float = 0.1,
                 lx: float = 0.1, ly: float = 0.1, v_d0: Sequence[float] = (0.0, 0.0),
                 **blockargs):
        r"""
        :param clock: the controller's clock (name it)
        :type clock: bdsim Clock
        :param a: distance from the axle centre to h, m, > 0, defaults to 0.2
        :type a: float
        :param kx: gain on the x error, 1/s, > 0
        :type kx: float
        :param ky: gain on the y error, 1/s, > 0
        :type ky: float
        :param lx: saturation of the x correction, m/s, > 0
        :type lx: float
        :param ly: saturation of the y correction, m/s, > 0
        :type ly: float
        :param v_d0: output before the first tick, defaults to (0, 0)
        :type v_d0: array_like(2)
        :param blockargs: common block options
        :type blockargs: dict
        """
        self.k, self.l, self.a = _gains(kx, ky, lx, ly, a)
        check_blockargs(self, blockargs)
        super().__init__(clock=check_clock(clock, type(self).__name__), x0=vector("v_d0", v_d0, 2), **blockargs)
        self.type = "sampledkinematiccontroller"

    def output(self, t, inports, x):
        return [np.array(x)]

    def next(self, t, inports, x):
        h_d = as_vector(inports[0], 2, self, "h_d", t)
        h_d_dot = as_vector(inports[1], 2, self, "h_d_dot", t)
        q = as_vector(inports[2], 3, self, "q", t)
        return laws.kinematic_control(h_d, h_d_dot, q[:2], q[2], self.a, self.k, self.l)


class _CompensatorSettings:
    """Validated settings shared by the continuous and sampled compensators."""

    def __init__(self, theta_hat0, ku, kw, lu, lw, adaptive, gamma, sigma, adapt_from, leakage):
        self.theta_hat0 = robots.resolve(theta_hat0, "theta_hat0").theta
        self.k = np.array([positive("ku", ku), positive("kw", kw)])
        self.l = np.array([positive("lu", lu), positive("lw", lw)])
        adaptive = flag("adaptive", adaptive)
        self.adaptive = bool(adaptive)
        self.gamma = positive_vector("gamma", gamma, 6)
        self.sigma = vector("sigma", sigma, 6)
        if np.any(self.sigma < 0):
            raise ValidationError(f"every element of sigma must be >= 0, got {self.sigma.tolist()}")
        self.adapt_from = nonnegative("adapt_from", adapt_from)
        self.leakage = choice("leakage", leakage, laws.LEAKAGE_FORMS)

    def command(self, v_d, v_d_dot, v, theta_hat):
        G = laws.compensation_regressor(v_d, v_d_dot, v, self.k, self.l)
        return G, laws.compensation(G, theta_hat)

    def rate(self, t, G, v_d, v, theta_hat):
        if not self.adaptive or not laws.adaptation_on(t, self.adapt_from):
            return np.zeros(6)
        return laws.adaptation_rate(G, v_d - v, theta_hat, self.gamma, self.sigma, self.leakage)



class DynamicCompensator(ContinuousBlock):
    r"""
    :blockname:`DYNAMICCOMPENSATOR`

    Dynamic compensation controller D of Fig. 2, exact or adaptive, evaluated continuously.

    :inputs: 2 (3 with ``vd_dot="input"``)
    :outputs: 2
    :states: 6 (8 with ``vd_dot="filter"``)

    .. list-table::
        :header-rows: 1

        *   - Port type
            - Port number
            - Types
            - Description
        *   - Input
            - 0
            - ndarray(2)
            - :math:`v_d = (u_d, \omega_d)`, desired velocities from K, m/s and rad/s (label ``v_d``)
        *   - Input
            - 1
            - ndarray(2)
            - :math:`v = (u, \omega)`, measured velocities of the robot (label ``v``)
        *   - Input
            - 2
            - ndarray(2)
            - :math:`\dot v_d`, only with ``vd_dot="input"`` (label ``v_d_dot``)
        *   - Output
            - 0
            - ndarray(2)
            - :math:`v_r = (u_r, \omega_r)`, velocity commands for the robot (label ``v_r``)
        *   - Output
            - 1
            - ndarray(6)
            - :math:`\hat\theta`, current parameter estimate (label ``theta_hat``)

    The command is linear in the parameter estimate, Eqs. (12) and (14):

    .. math::

        v_r = G\hat\theta, \quad
        G = \begin{bmatrix} \sigma_1 & 0 & -\omega_d\omega & u_d & 0 & 0 \\
            0 & \sigma_2 & u_d\omega - u\omega_d & 0 & u\omega_d & \omega_d \end{bmatrix}, \quad
        \sigma = \dot v_d + L\tanh(K\tilde v / L), \quad \tilde v = v_d - v

    With ``adaptive=False`` :math:`\hat\theta = \hat\theta_0` is fixed (exact
    compensation when it equals the robot's theta). With ``adaptive=True`` it
    follows, from ``t = adapt_from`` on, Eq. (18) or the sigma-modified Eq. (20):

    .. math::

        \dot{\hat\theta} = \gamma G^T\tilde v - \gamma\Sigma\hat\theta \quad (\text{``leakage="paper"``}), \qquad
        \dot{\hat\theta} = \gamma G^T\tilde v - \Sigma\hat\theta \quad (\text{``"fx44850"``}), \qquad
        \dot{\hat\theta} = \gamma G^T\tilde v \quad (\text{``"none"``, Eq. 18})

    :math:`\dot v_d` comes either from input 2 (``vd_dot="input"``, e.g. the exact
    rate output of :class:`KinematicController` with ``rate=True``) or from a
    first-order derivative filter on :math:`v_d` (``vd_dot="filter"``):
    :math:`\dot z = (v_d - z)/\tau`, :math:`\dot v_d \approx (v_d - z)/\tau`,
    with :math:`z(0) = 0`, the continuous analogue of Simulink's Derivative block.
    """

    nin = 2
    nout = 2
    inlabels = ("v_d", "v")
    outlabels = ("v_r", "theta_hat")

    @records_arguments
    def __init__(self, theta_hat0: str | RobotParameters | Sequence[float] = "p3dx_laser",
                 ku: float = 4.0, kw: float = 4.0, lu: float = 1.0, lw: float = 1.0,
                 adaptive: bool = False, gamma: Sequence[float] = PAPER_GAMMA,
                 sigma: Sequence[float] = PAPER_SIGMA, adapt_from: float = 0.0,
                 leakage: str = "paper", vd_dot: str = "filter", tau: float = 0.05,
                 **blockargs):
        r"""
        :param theta_hat0: initial (or fixed) estimate: robot name, ``RobotParameters``
            or six numbers, defaults to ``"p3dx_laser"``
        :type theta_hat0: str, RobotParameters or array_like(6)
        :param ku: gain on the linear-velocity error, 1/s, > 0, defaults to 4
        :type ku: float
        :param kw: gain on the angular-velocity error, 1/s, > 0, defaults to 4
        :type kw: float
        :param lu: saturation of the linear correction, m/s², > 0, defaults to 1
        :type lu: float
        :param lw: saturation of the angular correction, rad/s², > 0, defaults to 1
        :type lw: float
        :param adaptive: update the estimate with Eq. (18)/(20), defaults to False
        :type adaptive: bool
        :param gamma: diagonal of the adaptation gain, six values > 0, defaults to the paper's
        :type gamma: array_like(6)
        :param sigma: diagonal of the leakage gain Sigma, six values >= 0, defaults to the paper's
        :type sigma: array_like(6)
        :param adapt_from: time the update is switched on, s, >= 0, defaults to 0
        :type adapt_from: float
        :param leakage: ``"paper"`` (Eq. 20), ``"fx44850"`` or ``"none"`` (Eq. 18)
        :type leakage: str
        :param vd_dot: source of the derivative of v_d: ``"input"`` or ``"filter"``
        :type vd_dot: str
        :param tau: time constant of the derivative filter, s, > 0, defaults to 0.05
        :type tau: float
        :param blockargs: common block options
        :type blockargs: dict
        """
        self.settings = _CompensatorSettings(theta_hat0, ku, kw, lu, lw, adaptive, gamma,
                                             sigma, adapt_from, leakage)
        self.vd_dot = choice("vd_dot", vd_dot, VD_DOT_CONTINUOUS)
        self.tau = positive("tau", tau)
        snames = [f"theta_hat{i}" for i in range(1, 7)]
        x0 = self.settings.theta_hat0
        if self.vd_dot == "input":
            blockargs.setdefault("inames", ["v_d", "v", "v_d_dot"])
            blockargs.setdefault("nin", 3)
        else:
            snames += ["z_u", "z_w"]
            x0 = np.r_[x0, 0.0, 0.0]
        check_blockargs(self, blockargs)
        super().__init__(nstates=len(x0), x0=x0, feedthrough=True, snames=snames, **blockargs)
        self.type = "dynamiccompensator"
        self._last = None

    def _signals(self, t, inports, x):
        v_d = as_vector(inports[0], 2, self, "v_d", t)
        v = as_vector(inports[1], 2, self, "v", t)
        if self.vd_dot == "input":
            v_d_dot = as_vector(inports[2], 2, self, "v_d_dot", t)
        else:
            v_d_dot = (v_d - x[6:8]) / self.tau
        return v_d, v, v_d_dot

    def _evaluate(self, t, inports, x):
        """Signals and the regressor at (t, inputs, x). bdsim asks for the output and
        then the derivative at the same point: the second call reuses the first."""
        v_d, v, v_d_dot = self._signals(t, inports, x)
        key = (t, v_d.tobytes(), v.tobytes(), v_d_dot.tobytes(), np.asarray(x).tobytes())
        if self._last is not None and self._last[0] == key:
            return self._last[1]
        theta_hat = np.array(x[:6])
        G, v_r = self.settings.command(v_d, v_d_dot, v, theta_hat)
        value = (v_d, v, v_d_dot, theta_hat, G, v_r)
        self._last = (key, value)
        return value

    def start(self, simstate=None):
        super().start(simstate)
        self._last = None

    def output(self, t, inports, x):
        _, _, _, theta_hat, _, v_r = self._evaluate(t, inports, x)
        return [check_finite(v_r, self, "output v_r", t), check_finite(theta_hat, self, "theta_hat", t)]

    def deriv(self, t, inports, x):
        v_d, v, v_d_dot, theta_hat, G, _ = self._evaluate(t, inports, x)
        dtheta = self.settings.rate(t, G, v_d, v, theta_hat)
        if self.vd_dot == "input":
            return dtheta
        return np.concatenate([dtheta, v_d_dot])


class SampledDynamicCompensator(SampledBlock):
    r"""
    :blockname:`SAMPLEDDYNAMICCOMPENSATOR`

    Dynamic compensator D of Eqs. (12)-(20) as a digital controller on a bdsim clock.

    :inputs: 2 (3 with ``vd_dot="input"``)
    :outputs: 2
    :states: 10 (discrete)

    .. list-table::
        :header-rows: 1

        *   - Port type
            - Port number
            - Types
            - Description
        *   - Input
            - 0
            - ndarray(2)
            - :math:`v_d`, desired velocities (label ``v_d``)
        *   - Input
            - 1
            - ndarray(2)
            - :math:`v`, measured velocities (label ``v``)
        *   - Input
            - 2
            - ndarray(2)
            - :math:`\dot v_d`, only with ``vd_dot="input"`` (label ``v_d_dot``)
        *   - Output
            - 0
            - ndarray(2)
            - :math:`v_r`, held between ticks (label ``v_r``)
        *   - Output
            - 1
            - ndarray(6)
            - :math:`\hat\theta` (label ``theta_hat``)

    At each tick :math:`t_k` the block computes :math:`v_r = G\hat\theta_k`
    (Eq. 14) and holds it; :math:`\dot v_d` is the backward difference
    :math:`(v_d(t_k) - v_d(t_{k-1}))/T` (``vd_dot="difference"``, zero at the
    first tick) or input 2. The estimate is updated by an Euler step of
    Eq. (18)/(20): :math:`\hat\theta_{k+1} = \hat\theta_k + T\dot{\hat\theta}_k`.

    .. math:: v_r(t) = G_k\hat\theta_k, \quad t_k \le t < t_{k+1}
    """

    nin = 2
    nout = 2
    inlabels = ("v_d", "v")
    outlabels = ("v_r", "theta_hat")

    @records_arguments
    def __init__(self, clock: Clock,
                 theta_hat0: str | RobotParameters | Sequence[float] = "p3dx_laser",
                 ku: float = 4.0, kw: float = 4.0, lu: float = 1.0, lw: float = 1.0,
                 adaptive: bool = False, gamma: Sequence[float] = PAPER_GAMMA,
                 sigma: Sequence[float] = PAPER_SIGMA, adapt_from: float = 0.0,
                 leakage: str = "paper", vd_dot: str = "difference", **blockargs):
        r"""
        :param clock: the controller's clock (name it)
        :type clock: bdsim Clock
        :param theta_hat0: initial (or fixed) estimate: robot name, ``RobotParameters`` or six numbers
        :type theta_hat0: str, RobotParameters or array_like(6)
        :param ku: gain on the linear-velocity error, 1/s, > 0
        :type ku: float
        :param kw: gain on the angular-velocity error, 1/s, > 0
        :type kw: float
        :param lu: saturation of the linear correction, > 0
        :type lu: float
        :param lw: saturation of the angular correction, > 0
        :type lw: float
        :param adaptive: update the estimate, defaults to False
        :type adaptive: bool
        :param gamma: diagonal of the adaptation gain, six values > 0
        :type gamma: array_like(6)
        :param sigma: diagonal of Sigma, six values >= 0
        :type sigma: array_like(6)
        :param adapt_from: time the update is switched on, s, >= 0
        :type adapt_from: float
        :param leakage: ``"paper"``, ``"fx44850"`` or ``"none"``
        :type leakage: str
        :param vd_dot: ``"difference"`` or ``"input"``
        :type vd_dot: str
        :param blockargs: common block options
        :type blockargs: dict
        """
        self.settings = _CompensatorSettings(theta_hat0, ku, kw, lu, lw, adaptive, gamma,
                                             sigma, adapt_from, leakage)
        self.vd_dot = choice("vd_dot", vd_dot, VD_DOT_SAMPLED)
        if self.vd_dot == "input":
            blockargs.setdefault("inames", ["v_d", "v", "v_d_dot"])
            blockargs.setdefault("nin", 3)
        # state: theta_hat (6), held v_r (2), previous v_d (2)
        x0 = np.r_[self.settings.theta_hat0, 0.0, 0.0, np.nan, np.nan]
        check_blockargs(self, blockargs)
        super().__init__(clock=check_clock(clock, type(self).__name__), x0=x0, **blockargs)
        self.type = "sampleddynamiccompensator"

    def output(self, t, inports, x):
        return [np.array(x[6:8]), np.array(x[0:6])]

    def next(self, t, inports, x):
        v_d = as_vector(inports[0], 2, self, "v_d", t)
        v = as_vector(inports[1], 2, self, "v", t)
        if self.vd_dot == "input":
            v_d_dot = as_vector(inports[2], 2, self, "v_d_dot", t)
        elif np.all(np.isfinite(x[8:10])):
            v_d_dot = (v_d - x[8:10]) / self.T
        else:
            v_d_dot = np.zeros(2)
        theta_hat = np.array(x[0:6])
        G, v_r = self.settings.command(v_d, v_d_dot, v, theta_hat)
        theta_next = theta_hat + self.T * self.settings.rate(t, G, v_d, v, theta_hat)
        check_finite(v_r, self, "output v_r", t)
        check_finite(theta_next, self, "theta_hat", t)
        return np.r_[theta_next, v_r, v_d]


class KinematicControllerWithRate(KinematicController):
    r"""
    :blockname:`KINEMATICCONTROLLERWITHRATE`

    Kinematic controller K of Fig. 2, Eq. (10), with the exact rate of its output as a second output.

    :inputs: 5
    :outputs: 2
    :states: 0

    .. list-table::
        :header-rows: 1

        *   - Port type
            - Port number
            - Types
            - Description
        *   - Input
            - 0
            - ndarray(2)
            - :math:`h_d`, desired position of the point of interest, m (label ``h_d``)
        *   - Input
            - 1
            - ndarray(2)
            - :math:`\dot h_d`, desired velocity, m/s (label ``h_d_dot``)
        *   - Input
            - 2
            - ndarray(3)
            - :math:`q = (x, y, \psi)`, measured pose of h (label ``q``)
        *   - Input
            - 3
            - ndarray(2)
            - :math:`\ddot h_d`, desired acceleration, m/s² (label ``h_d_ddot``)
        *   - Input
            - 4
            - ndarray(2)
            - :math:`v = (u, \omega)`, measured velocities, m/s and rad/s (label ``v``)
        *   - Output
            - 0
            - ndarray(2)
            - :math:`v_d = (u_d, \omega_d)`, desired velocities, m/s and rad/s (label ``v_d``)
        *   - Output
            - 1
            - ndarray(2)
            - :math:`\dot v_d`, their exact time derivative, m/s² and rad/s² (label ``v_d_dot``)

    :class:`KinematicController` with ``rate=True``, as a block whose ports never
    change (so that bdedit draws it). Output 0 is Eq. (10); output 1 is Eq. (10)
    differentiated along the motion (:func:`unidyn.model.laws.kinematic_control_rate`),
    the :math:`\dot v_d` of the compensator's Eq. (12); Eq. (10) is written out at
    :class:`KinematicController`.

    :seealso: :class:`KinematicController`, :class:`DynamicCompensatorWithRateInput`
    """

    nin = 5
    nout = 2
    inlabels = ("h_d", "h_d_dot", "q", "h_d_ddot", "v")
    outlabels = ("v_d", "v_d_dot")

    @records_arguments
    def __init__(self, a: float = 0.2, kx: float = 0.1, ky: float = 0.1, lx: float = 0.1,
                 ly: float = 0.1, **blockargs):
        r"""
        :param a: distance from the axle centre to the controlled point h, m, > 0; 0.2 (default)
        :type a: float
        :param kx: gain on the x error, 1/s, > 0; 0.1 (default)
        :type kx: float
        :param ky: gain on the y error, 1/s, > 0; 0.1 (default)
        :type ky: float
        :param lx: saturation of the x correction, m/s, > 0; 0.1 (default)
        :type lx: float
        :param ly: saturation of the y correction, m/s, > 0; 0.1 (default)
        :type ly: float
        :param blockargs: common block options
        :type blockargs: dict
        """
        check_fixed_blockargs(self, blockargs)
        super().__init__(a=a, kx=kx, ky=ky, lx=lx, ly=ly, rate=True, **blockargs)


class DynamicCompensatorWithRateInput(DynamicCompensator):
    r"""
    :blockname:`DYNAMICCOMPENSATORWITHRATEINPUT`

    Dynamic compensation controller D of Fig. 2 (Eqs. 12, 14, 18, 20) taking the rate of v_d as an input.

    :inputs: 3
    :outputs: 2
    :states: 6

    .. list-table::
        :header-rows: 1

        *   - Port type
            - Port number
            - Types
            - Description
        *   - Input
            - 0
            - ndarray(2)
            - :math:`v_d = (u_d, \omega_d)`, desired velocities from K, m/s and rad/s (label ``v_d``)
        *   - Input
            - 1
            - ndarray(2)
            - :math:`v = (u, \omega)`, measured velocities of the robot (label ``v``)
        *   - Input
            - 2
            - ndarray(2)
            - :math:`\dot v_d`, rate of the desired velocities, e.g. output 1 of
              :class:`KinematicControllerWithRate` (label ``v_d_dot``)
        *   - Output
            - 0
            - ndarray(2)
            - :math:`v_r = (u_r, \omega_r)`, velocity commands for the robot (label ``v_r``)
        *   - Output
            - 1
            - ndarray(6)
            - :math:`\hat\theta`, current parameter estimate (label ``theta_hat``)

    :class:`DynamicCompensator` with ``vd_dot="input"``, as a block whose ports
    never change (so that bdedit draws it). The command is Eqs. (12)/(14),
    :math:`v_r = G\hat\theta` (written out at :class:`DynamicCompensator`), with :math:`\hat\theta = \hat\theta_0` fixed (``adaptive=False``: exact
    compensation when it equals the robot's theta, the paper's third simulation)
    or, from ``t = adapt_from`` on, updated by Eq. (20) (``leakage="paper"``,
    :math:`\dot{\hat\theta} = \gamma G^T\tilde v - \gamma\Sigma\hat\theta`), by the
    form :math:`\gamma G^T\tilde v - \Sigma\hat\theta` (``"fx44850"``) or by Eq. (18)
    without leakage (``"none"``): the paper's fourth simulation.

    :seealso: :class:`DynamicCompensator`, :func:`unidyn.model.laws.compensation`
    """

    nin = 3
    nout = 2
    inlabels = ("v_d", "v", "v_d_dot")
    outlabels = ("v_r", "theta_hat")

    @records_arguments
    def __init__(self, theta_hat0: str | RobotParameters | Sequence[float] = "p3dx_laser",
                 ku: float = 4.0, kw: float = 4.0, lu: float = 1.0, lw: float = 1.0,
                 adaptive: bool = False, gamma: Sequence[float] | None = None,
                 sigma: Sequence[float] | None = None, adapt_from: float = 0.0,
                 leakage: str = "paper", **blockargs):
        r"""
        :param theta_hat0: initial (or fixed) estimate: a robot preset name or six numbers, defaults to p3dx_laser
        :type theta_hat0: str, RobotParameters or array_like(6)
        :param ku: gain on the linear-velocity error, 1/s, > 0, defaults to 4
        :type ku: float
        :param kw: gain on the angular-velocity error, 1/s, > 0, defaults to 4
        :type kw: float
        :param lu: saturation of the linear correction, m/s², > 0, defaults to 1
        :type lu: float
        :param lw: saturation of the angular correction, rad/s², > 0, defaults to 1
        :type lw: float
        :param adaptive: update the estimate with Eq. (18)/(20), defaults to False
        :type adaptive: bool
        :param gamma: diagonal of the adaptation gain, six values > 0, or None for the paper's, defaults to None
        :type gamma: array_like(6) or None
        :param sigma: diagonal of the leakage gain Sigma, six values >= 0, or None for the paper's, defaults to None
        :type sigma: array_like(6) or None
        :param adapt_from: time the update is switched on, s, >= 0, defaults to 0
        :type adapt_from: float
        :param leakage: form of the leakage term: "paper" (Eq. 20), "fx44850" or "none" (Eq. 18), defaults to paper
        :type leakage: str
        :param blockargs: common block options
        :type blockargs: dict
        """
        check_fixed_blockargs(self, blockargs)
        super().__init__(theta_hat0=theta_hat0, ku=ku, kw=kw, lu=lu, lw=lw, adaptive=adaptive,
                         gamma=PAPER_GAMMA if gamma is None else gamma,
                         sigma=PAPER_SIGMA if sigma is None else sigma,
                         adapt_from=adapt_from, leakage=leakage, vd_dot="input", **blockargs)
