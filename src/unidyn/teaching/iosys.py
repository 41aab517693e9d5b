r"""The robot, the controllers and the Fig. 2 loop as python-control I/O systems.

Martins, Sarcinelli-Filho, Carelli, J Intell Robot Syst (2017). Every system here
is a :class:`control.NonlinearIOSystem` whose update and output functions call the
core functions of :mod:`unidyn.model.unicycle` and :mod:`unidyn.model.laws` (the equations are
not written again here), with named signals (units: m, rad, m/s, rad/s, m/s²):

- :func:`to_iosys`, the robot of Eqs. (1)-(2): inputs ``u_ref, w_ref``; states and
  outputs ``x, y, psi, u, w``. :func:`kinematic_iosys` is the purely kinematic robot
  (states ``x, y, psi``, same inputs and outputs); :func:`velocity_iosys` is Eq. (2) alone
  (states and outputs ``u, w``).
- :func:`kinematic_controller`, Eq. (10): inputs ``x_d, y_d, x_d_dot, y_d_dot`` (and
  ``x_d_ddot, y_d_ddot``), ``x, y, psi`` (and ``u, w``); outputs ``u_d, w_d`` (and the
  exact rate ``u_d_dot, w_d_dot``).
- :func:`compensator`, Eq. (14), adaptive with Eqs. (18)/(20): inputs ``u_d, w_d,
  u_d_dot, w_d_dot, u, w``; outputs ``u_ref, w_ref`` (adaptive: also ``theta_hat1..6``,
  its states).
- :func:`reference_iosys`: no inputs; outputs ``x_d, y_d, x_d_dot, y_d_dot, x_d_ddot,
  y_d_ddot``.

:func:`fig2_loop` wires them with :func:`control.interconnect` as the paper's
Fig. 2 (the same loop as :func:`unidyn.simulate` and :func:`unidyn.simulate_batch`,
continuous control with the exact v_d'); the measurement noise enters as the
loop's inputs ``n_x, n_y, n_u, n_w``. :func:`velocity_loop`, :func:`velocity_tf`,
:func:`linearize_robot` and :func:`tracking_loop` are its linearisations.

The arguments a system is built from are also its python-control parameters
(``sys.params``): ``params={"a": 0.5}`` given to :func:`control.input_output_response`,
:func:`control.linearize`, ... replaces the value, checked as the constructor checks
it; an argument that cannot change there (``rate``, ``adaptive``, the adaptive
estimate's initial value) is refused. python-control hands one set of parameters to
every system of an interconnection, so a name means one value there: the robot's
and the controller's ``a`` are the same offset, as in Eq. (10).

Needs the optional dependency python-control (``pip install unidyn[control]``);
``import unidyn`` does not import it.
"""

from __future__ import annotations

from typing import NamedTuple

try:
    import control as ct
except ImportError:  # pragma: no cover - exercised by a test that hides the package
    raise ImportError("unidyn.teaching.iosys needs python-control: pip install unidyn[control]") from None

import numpy as np

from .._validate import ValidationError, nonnegative, positive, vector
from ..model import laws, robots, trajectories, unicycle
from ..model.cases import CASE_SPECS
from ..model.laws import LEAKAGE_FORMS, PAPER_GAMMA, PAPER_SIGMA
from ..model.scenario import Scenario
from ..model.unicycle import NO_LIMITS, Limits

__all__ = ["to_iosys", "kinematic_iosys", "velocity_iosys", "kinematic_controller",
           "compensator", "reference_iosys", "fig2_loop", "fig2_initial_state",
           "simulate_fig2", "velocity_loop", "velocity_tf", "VelocityTF", "linearize_robot",
           "tracking_loop", "ROBOT_SIGNALS", "REFERENCE_SIGNALS", "NOISE_SIGNALS",
           "LINEAR_CASES"]

#: States and outputs of the robot, as in the paper: position of h, heading, velocities.
ROBOT_SIGNALS = ("x", "y", "psi", "u", "w")
#: The reference h_d and its first two derivatives.
REFERENCE_SIGNALS = ("x_d", "y_d", "x_d_dot", "y_d_dot", "x_d_ddot", "y_d_ddot")
#: Measurement noise added to x, y (fed to Eq. 10) and to u, w (fed to Eqs. 10, 14, 18/20).
NOISE_SIGNALS = ("n_x", "n_y", "n_u", "n_w")
#: The cases :func:`tracking_loop` linearises (Section 5, without adaptation).
LINEAR_CASES = tuple(name for name, spec in CASE_SPECS.items() if not spec.adaptive)
_THETA_HAT = tuple(f"theta_hat{j}" for j in range(1, 7))


def _limits(limits) -> Limits:
    if limits is None:
        return NO_LIMITS
    if isinstance(limits, dict):
        return Limits(**limits)
    if not isinstance(limits, Limits):
        raise ValidationError(f"limits must be a unidyn.Limits, a dict of it or None, "
                              f"got {limits!r}")
    return limits


class _Parameters:
    """A system's python-control parameters (``sys.params``): the arguments it was
    built with, which ``params=`` of python-control's simulation, linearisation and
    evaluation functions replace, each checked as the constructor checks it. An
    argument that shapes the system's signals (``rate``, ``adaptive``, ``name``) is
    refused there. Other names are left to the other systems of an interconnection,
    to which python-control passes the same parameters."""

    def __init__(self, system: str, checks: dict, fixed=("name",), **built):
        self.system, self.checks = system, checks
        self.fixed = {k: "shapes the system's signals" for k in fixed} if not isinstance(fixed, dict) else fixed
        self.built = {k: checks[k](v) for k, v in built.items()}
        self._last = (None, None)

    def __call__(self, params) -> dict:
        """The parameter values for ``params`` (checked once per python-control call)."""
        params = {} if params is None else params
        if params is self._last[0]:
            return self._last[1]
        for k, why in self.fixed.items():
            if k in params:
                raise ValidationError(f"{self.system}: {k!r} {why}, so params cannot change "
                                      f"it; build the system with {k}=")
        values = {k: (self.checks[k](params[k]) if k in params and params[k] is not v else v)
                  for k, v in self.built.items()}
        self._last = (params, values)
        return values


def _robot(name):
    return lambda value: robots.resolve(value, name)


def _a_robot(value):
    return nonnegative("a", value)


# ------------------------------------------------------------------------- robot
def to_iosys(robot="p3dx_laser", a: float = 0.0, limits=None, name: str = "robot"):
    r"""The dynamic unicycle, Eqs. (1) and (2), as a :class:`control.NonlinearIOSystem`.

    .. math::

        \dot x = u\cos\psi - a\omega\sin\psi,\quad \dot y = u\sin\psi + a\omega\cos\psi,
        \quad \dot\psi = \omega \qquad \text{(Eq. 1)}

        \dot u = \frac{\theta_3}{\theta_1}\omega^2 - \frac{\theta_4}{\theta_1}u
                 + \frac{u_{ref}}{\theta_1},\quad
        \dot\omega = -\frac{\theta_5}{\theta_2}u\omega - \frac{\theta_6}{\theta_2}\omega
                 + \frac{\omega_{ref}}{\theta_2} \qquad \text{(Eq. 2)}

    The update function is :func:`unidyn.model.unicycle.unicycle_deriv`; the outputs are the
    states.

    ``robot``, ``a`` and ``limits`` are also the system's python-control parameters:
    ``params={"a": 0.5}`` given to :func:`control.input_output_response` (or
    :func:`control.linearize`, ...) replaces the value it was built with, checked as here.

    :param robot: a preset name, :class:`~unidyn.RobotParameters`, six numbers
        theta1..theta6 or a JSON file (as everywhere in unidyn)
    :param a: offset of the point of interest h ahead of the wheel axle, m, >= 0,
        defaults to 0 (the axle centre, as the ``DYNAMICUNICYCLE`` block)
    :param limits: :class:`~unidyn.Limits` (or its dict); ``None``: none (pure Eqs. 1-2)
    :param name: the system's name
    :return: inputs ``u_ref`` (m/s), ``w_ref`` (rad/s); states and outputs
        ``x, y`` (m), ``psi`` (rad), ``u`` (m/s), ``w`` (rad/s)
    """
    par = _Parameters(name, dict(robot=_robot("robot"), a=_a_robot, limits=_limits),
                      robot=robot, a=a, limits=limits)

    def update(t, x, u, params):
        p = par(params)
        return unicycle.unicycle_deriv(x, u, p["robot"].theta, p["a"], p["limits"])

    def output(t, x, u, params):
        par(params)
        return np.asarray(x, dtype=float)

    sys = ct.nlsys(update, output, inputs=("u_ref", "w_ref"), outputs=ROBOT_SIGNALS,
                   states=ROBOT_SIGNALS, name=name, params=par.built)
    sys.robot = par.built["robot"]
    return sys


def kinematic_iosys(a: float = 0.0, limits=None, name: str = "robot"):
    r"""A purely kinematic robot (the paper's case 1): Eq. (1) with v = v_ref
    (:func:`unidyn.model.unicycle.kinematic_unicycle_deriv`).

    States ``x, y, psi``; inputs ``u_ref, w_ref``; outputs ``x, y, psi, u, w``, with
    ``u, w`` the commands after the speed limits (the robot's velocities), so it
    can replace :func:`to_iosys` in a diagram. ``a`` (m, >= 0, defaults to 0 as in
    :func:`to_iosys`) and ``limits`` are its python-control parameters."""
    par = _Parameters(name, dict(a=_a_robot, limits=_limits), a=a, limits=limits)

    def update(t, q, v, params):
        p = par(params)
        return unicycle.kinematic_unicycle_deriv(q, v, p["a"], p["limits"])

    def output(t, q, v, params):
        lim = par(params)["limits"]
        v = np.asarray(v, dtype=float)
        if lim.active:
            v = np.clip(v, -lim.speed, lim.speed)
        return np.concatenate([np.asarray(q, dtype=float), v])

    return ct.nlsys(update, output, inputs=("u_ref", "w_ref"), outputs=ROBOT_SIGNALS,
                    states=ROBOT_SIGNALS[:3], name=name, params=par.built)


def velocity_iosys(robot="p3dx_laser", name: str = "velocity"):
    r"""The robot's velocity loop alone, Eq. (2) (:func:`unidyn.model.unicycle.dynamics`):
    states and outputs ``u, w``, inputs ``u_ref, w_ref``; ``robot`` is its python-control
    parameter."""
    par = _Parameters(name, dict(robot=_robot("robot")), robot=robot)

    def update(t, v, v_ref, params):
        return unicycle.dynamics(v, v_ref, par(params)["robot"].theta)

    def output(t, v, v_ref, params):
        par(params)
        return np.asarray(v, dtype=float)

    return ct.nlsys(update, output, inputs=("u_ref", "w_ref"), outputs=("u", "w"),
                    states=("u", "w"), name=name, params=par.built)


# -------------------------------------------------------------------- controllers
def kinematic_controller(a: float = 0.2, kx: float = 0.1, ky: float = 0.1, lx: float = 0.1,
                         ly: float = 0.1, rate: bool = True, name: str = "kinematic_controller"):
    r"""The kinematic controller, Eq. (10), as a static I/O system
    (:func:`unidyn.model.laws.kinematic_control`; with ``rate=True`` also its exact
    time derivative along the motion, :func:`unidyn.model.laws.kinematic_control_rate`).

    .. math::

        \begin{bmatrix} u_d \\ \omega_d \end{bmatrix} =
        \begin{bmatrix} \cos\psi & \sin\psi \\ -\frac{\sin\psi}{a} & \frac{\cos\psi}{a} \end{bmatrix}
        \begin{bmatrix} \dot x_d + l_x \tanh(k_x \tilde x / l_x) \\
                        \dot y_d + l_y \tanh(k_y \tilde y / l_y) \end{bmatrix}

    :param a: offset of h, m, > 0
    :param kx: gain, 1/s, > 0
    :param ky: gain, 1/s, > 0
    :param lx: saturation, m/s, > 0
    :param ly: saturation, m/s, > 0
    :param rate: also output ``u_d_dot, w_d_dot`` (needs the inputs ``x_d_ddot,
        y_d_ddot`` and the measured ``u, w``)
    :return: inputs ``x_d, y_d, x_d_dot, y_d_dot[, x_d_ddot, y_d_ddot], x, y, psi[, u, w]``;
        outputs ``u_d, w_d[, u_d_dot, w_d_dot]``; python-control parameters ``a, kx, ky,
        lx, ly``
    """
    par = _Parameters(name, {n: (lambda v, n=n: positive(n, v)) for n in ("a", "kx", "ky", "lx", "ly")},
                      fixed=("rate", "name"), a=a, kx=kx, ky=ky, lx=lx, ly=ly)

    def gains(params):
        p = par(params)
        return p["a"], np.array([p["kx"], p["ky"]]), np.array([p["lx"], p["ly"]])

    if rate:
        inputs = REFERENCE_SIGNALS + ("x", "y", "psi", "u", "w")

        def output(t, x, s, params):
            a, k, lim = gains(params)
            v_d = laws.kinematic_control(s[0:2], s[2:4], s[6:8], s[8], a, k, lim)
            v_d_dot = laws.kinematic_control_rate(s[0:2], s[2:4], s[4:6], s[6:8], s[8],
                                                  s[9:11], a, k, lim)
            return np.concatenate([v_d, v_d_dot])

        outputs = ("u_d", "w_d", "u_d_dot", "w_d_dot")
    else:
        inputs = REFERENCE_SIGNALS[:4] + ("x", "y", "psi")

        def output(t, x, s, params):
            a, k, lim = gains(params)
            return laws.kinematic_control(s[0:2], s[2:4], s[4:6], s[6], a, k, lim)

        outputs = ("u_d", "w_d")
    return ct.nlsys(None, output, inputs=inputs, outputs=outputs, name=name, params=par.built)


def compensator(theta_hat0="p3dx_laser", ku: float = 4.0, kw: float = 4.0, lu: float = 1.0,
                lw: float = 1.0, adaptive: bool = False, gamma=PAPER_GAMMA, sigma=PAPER_SIGMA,
                leakage: str = "paper", adapt_from: float = 0.0, name: str = "compensator"):
    r"""The dynamic compensator, Eq. (12) in the linear form of Eq. (14),
    :math:`v_r = G(v_d, \dot v_d, v)\,\hat\theta` (:func:`unidyn.model.laws.compensation_regressor`,
    :func:`unidyn.model.laws.compensation`); with ``adaptive=True`` the estimate is its
    state and follows Eq. (20) (or Eq. 18 with ``leakage="none"``) from ``adapt_from``
    on (:func:`unidyn.model.laws.adaptation_rate`):

    .. math:: \dot{\hat\theta} = \gamma G^T\tilde v - \gamma\Sigma\hat\theta,\quad \tilde v = v_d - v

    :param theta_hat0: the estimate (the initial one when adaptive): a robot as
        :func:`to_iosys` accepts; the exact compensator uses the robot's own theta
    :param ku: gain, 1/s, > 0
    :param kw: gain, 1/s, > 0
    :param lu: saturation, > 0
    :param lw: saturation, > 0
    :param adaptive: update the estimate (Eqs. 18/20)
    :param gamma: six adaptation gains, > 0 (the paper's by default)
    :param sigma: six leakage gains, >= 0 (the paper's by default)
    :param leakage: ``"paper"`` (Eq. 20), ``"fx44850"`` or ``"none"`` (Eq. 18)
    :param adapt_from: time the update is switched on, s, >= 0
    :return: inputs ``u_d, w_d, u_d_dot, w_d_dot, u, w``; outputs ``u_ref, w_ref``
        (adaptive: also ``theta_hat1..6``, which are then the states); python-control
        parameters ``ku, kw, lu, lw`` and ``theta_hat0`` (fixed estimate) or ``gamma,
        sigma, leakage, adapt_from`` (adaptive: the initial estimate is the initial state)
    """
    checks = {n: (lambda v, n=n: positive(n, v)) for n in ("ku", "kw", "lu", "lw")}
    gains = dict(ku=ku, kw=kw, lu=lu, lw=lw)
    inputs = ("u_d", "w_d", "u_d_dot", "w_d_dot", "u", "w")

    def regressor(s, p):
        return laws.compensation_regressor(s[0:2], s[2:4], s[4:6], np.array([p["ku"], p["kw"]]),
                                           np.array([p["lu"], p["lw"]]))

    if not adaptive:
        par = _Parameters(name, {**checks, "theta_hat0": _robot("theta_hat0")},
                          fixed=("adaptive", "name"), theta_hat0=theta_hat0, **gains)

        def output(t, x, s, params):
            p = par(params)
            return laws.compensation(regressor(s, p), p["theta_hat0"].theta)

        sys = ct.nlsys(None, output, inputs=inputs, outputs=("u_ref", "w_ref"),
                       name=name, params=par.built)
        sys.theta_hat0 = par.built["theta_hat0"].theta
        return sys
    th0 = robots.resolve(theta_hat0, "theta_hat0").theta
    par = _Parameters(
        name, {**checks, "gamma": _gamma, "sigma": _sigma, "leakage": _leakage,
               "adapt_from": lambda v: nonnegative("adapt_from", v)},
        fixed={"adaptive": "shapes the system's signals", "name": "shapes the system's signals",
               "theta_hat0": "is the initial state of the estimate (pass it as the initial state)"},
        gamma=gamma, sigma=sigma, leakage=leakage, adapt_from=adapt_from, **gains)

    def update(t, th, s, params):
        p = par(params)
        if not laws.adaptation_on(t, p["adapt_from"]):
            return np.zeros(6)
        return laws.adaptation_rate(regressor(s, p), s[0:2] - s[4:6], th, p["gamma"], p["sigma"],
                                    p["leakage"])

    def output(t, th, s, params):
        return np.concatenate([laws.compensation(regressor(s, par(params)), th), th])

    sys = ct.nlsys(update, output, inputs=inputs, outputs=("u_ref", "w_ref") + _THETA_HAT,
                   states=_THETA_HAT, name=name, params=par.built)
    sys.theta_hat0 = th0
    return sys


def _gamma(value):
    g = vector("gamma", value, (6,))
    if np.any(~(g > 0)):
        raise ValidationError(f"gamma must be six numbers > 0, got {g.tolist()}")
    return g


def _sigma(value):
    sg = vector("sigma", value, (6,))
    if np.any(~(sg >= 0)):
        raise ValidationError(f"sigma must be six numbers >= 0, got {sg.tolist()}")
    return sg


def _leakage(value):
    if value not in LEAKAGE_FORMS:
        raise ValidationError(f"leakage must be one of {', '.join(LEAKAGE_FORMS)}, got {value!r}")
    return value


def reference_iosys(trajectory=None, name: str = "reference"):
    r"""A reference h_d(t) (:mod:`unidyn.model.trajectories`; default the paper's figure
    eight) as a system without inputs or states: outputs ``x_d, y_d, x_d_dot, y_d_dot,
    x_d_ddot, y_d_ddot`` (m, m/s, m/s²)."""
    tr = trajectories.from_spec(trajectories.FigureEight() if trajectory is None else trajectory)

    def output(t, x, u, params):
        return np.concatenate([tr.position(t), tr.velocity(t), tr.acceleration(t)])

    return ct.nlsys(None, output, inputs=0, outputs=REFERENCE_SIGNALS, name=name)


# ------------------------------------------------------------------- the Fig. 2 loop
def _sensor(compensated: bool):
    """x, y (and u, w) plus their noise: what the controllers are fed."""
    if not compensated:  # no controller reads u, w
        def output(t, x, s, params):
            return s[0:2] + s[2:4]
        return ct.nlsys(None, output, inputs=("x", "y") + NOISE_SIGNALS,
                        outputs=("x_m", "y_m"), name="sensor")

    def output(t, x, s, params):
        return s[0:4] + s[4:8]
    return ct.nlsys(None, output, inputs=("x", "y", "u", "w") + NOISE_SIGNALS,
                    outputs=("x_m", "y_m", "u_m", "w_m"), name="sensor")


def fig2_loop(scenario=None, *, reference: bool = True, **changes):
    r"""The closed loop of the paper's Fig. 2 for a :class:`~unidyn.Scenario`, assembled
    with :func:`control.interconnect` from :func:`reference_iosys`,
    :func:`kinematic_controller` (Eq. 10), :func:`compensator` (Eqs. 14, 18/20) and
    :func:`to_iosys` (Eqs. 1-2; :func:`kinematic_iosys` for the kinematic case).

    The case decides the wiring, as in Section 5: ``kinematic`` (v = v_d),
    ``uncompensated`` (v_ref = v_d), ``compensated`` (v_ref = G theta_hat, Eq. 14) and
    ``adaptive`` (plus Eqs. 18/20 from ``adapt_from``). Continuous control with the
    exact v_d' (``vd_dot="analytic"``): the loop of :func:`unidyn.simulate_batch`.
    The scenario's limits are applied in the robot.

    :param scenario: a Scenario (default: the paper's simulation 4); ``changes`` are
        applied with :meth:`~unidyn.Scenario.replace`
    :param reference: include the scenario's trajectory as a subsystem; with
        ``False`` the reference signals ``x_d ... y_d_ddot`` are inputs of the loop
    :return: an interconnected system with inputs ``n_x, n_y, n_u, n_w`` (measurement
        noise; zero for a noise-free run), preceded by the reference signals when
        ``reference=False``; outputs ``x, y, psi, u, w, u_d, w_d, u_ref, w_ref``, then
        ``x_d, y_d`` when the reference is included, then ``theta_hat1..6`` for the
        adaptive case. Its initial state is :func:`fig2_initial_state`.
    """
    sc = Scenario.paper(4) if scenario is None else scenario
    if not isinstance(sc, Scenario):
        raise ValidationError(f"scenario must be a unidyn.Scenario, got {type(sc).__name__}")
    if changes:
        sc = sc.replace(**changes)
    if sc.control != "continuous" or sc.derivative != "analytic":
        raise ValidationError("fig2_loop builds continuous control with the exact v_d' "
                              "(control='continuous', vd_dot='analytic')")
    if sc.payload:
        raise ValidationError("fig2_loop builds a robot of constant theta; a scenario with a "
                              "payload schedule runs in unidyn.simulate or simulate_batch")
    spec = sc.case_spec
    dynamic, compensated = spec.dynamic, spec.compensated
    robot = (to_iosys(sc.robot, sc.a, sc.limits) if dynamic
             else kinematic_iosys(sc.a, sc.limits))
    K = kinematic_controller(sc.a, sc.kx, sc.ky, sc.lx, sc.ly, rate=compensated)
    systems = [robot, K, _sensor(compensated)]
    conn = [["sensor.x", "robot.x"], ["sensor.y", "robot.y"],
            ["kinematic_controller.x", "sensor.x_m"], ["kinematic_controller.y", "sensor.y_m"],
            ["kinematic_controller.psi", "robot.psi"]]
    ref_in = REFERENCE_SIGNALS if compensated else REFERENCE_SIGNALS[:4]
    inplist, inputs = [], []
    if reference:
        systems.insert(0, reference_iosys(sc.trajectory))
        conn += [[f"kinematic_controller.{s}", f"reference.{s}"] for s in ref_in]
    else:
        inplist += [[f"kinematic_controller.{s}"] for s in ref_in]
        inputs += list(ref_in)
    inplist += [[f"sensor.{n}"] for n in NOISE_SIGNALS]
    inputs += list(NOISE_SIGNALS)
    if compensated:
        D = compensator(sc.theta_hat_initial, sc.ku, sc.kw, sc.lu, sc.lw,
                        adaptive=spec.adaptive, gamma=sc.gamma, sigma=sc.sigma,
                        leakage=sc.leakage, adapt_from=sc.adapt_from)
        systems.append(D)
        conn += [["sensor.u", "robot.u"], ["sensor.w", "robot.w"],
                 ["kinematic_controller.u", "sensor.u_m"], ["kinematic_controller.w", "sensor.w_m"],
                 ["compensator.u", "sensor.u_m"], ["compensator.w", "sensor.w_m"],
                 ["robot.u_ref", "compensator.u_ref"], ["robot.w_ref", "compensator.w_ref"]]
        conn += [[f"compensator.{s}", f"kinematic_controller.{s}"]
                 for s in ("u_d", "w_d", "u_d_dot", "w_d_dot")]
        cmd = ["compensator.u_ref", "compensator.w_ref"]
    else:
        conn += [["robot.u_ref", "kinematic_controller.u_d"],
                 ["robot.w_ref", "kinematic_controller.w_d"]]
        cmd = ["kinematic_controller.u_d", "kinematic_controller.w_d"]
    outlist = ([f"robot.{s}" for s in ROBOT_SIGNALS]
               + ["kinematic_controller.u_d", "kinematic_controller.w_d"] + cmd)
    outputs = list(ROBOT_SIGNALS) + ["u_d", "w_d", "u_ref", "w_ref"]
    if reference:
        outlist += ["reference.x_d", "reference.y_d"]
        outputs += ["x_d", "y_d"]
    if spec.adaptive:
        outlist += [f"compensator.{s}" for s in _THETA_HAT]
        outputs += list(_THETA_HAT)
    # without compensation v_d' is not needed, nor is the reference's acceleration
    ignore = None if compensated or not reference else ["reference.x_d_ddot", "reference.y_d_ddot"]
    sys = ct.interconnect(systems, connections=conn, inplist=inplist, outlist=outlist,
                          inputs=inputs, outputs=outputs, name="fig2", ignore_outputs=ignore)
    sys.scenario = sc
    return sys


def fig2_initial_state(loop) -> np.ndarray:
    """The initial state of a :func:`fig2_loop` for its scenario: the robot at
    ``x0`` at rest, the estimate at ``theta_hat_initial`` (Section 5)."""
    sc = loop.scenario
    x0 = np.zeros(loop.nstates)
    idx = loop.state_index
    for s, v in zip(("x", "y", "psi"), sc.x0):
        x0[idx[f"robot_{s}"]] = v
    if sc.case_spec.adaptive:
        for j, s in enumerate(_THETA_HAT):
            x0[idx[f"compensator_{s}"]] = sc.theta_hat_initial[j]
    return x0


def simulate_fig2(scenario=None, t=None, rtol: float = 1e-9, atol: float = 1e-11, **changes):
    """Run :func:`fig2_loop` noise-free with :func:`control.input_output_response`
    (``solve_ivp``, LSODA) on the grid t = k Ts of the scenario (or ``t``).

    :return: the :class:`control.TimeResponseData` (``.outputs`` by the names of
        :func:`fig2_loop`, e.g. ``resp.outputs[resp.output_labels.index("x")]``)
    """
    loop = fig2_loop(scenario, **changes)
    sc = loop.scenario
    if t is None:
        t = np.arange(sc.steps + 1) * sc.Ts
    max_step = 0.5 * sc.Ts if sc.case_spec.adaptive else np.inf
    return ct.input_output_response(
        loop, t, np.zeros((len(NOISE_SIGNALS), len(t))), fig2_initial_state(loop),
        solve_ivp_method="LSODA",
        solve_ivp_kwargs=dict(rtol=rtol, atol=atol, max_step=max_step))


# ------------------------------------------------------------------- linearisations
def velocity_loop(robot="p3dx_laser", u0: float = 0.0, w0: float = 0.0):
    r"""The robot's velocity loop, Eq. (2), linearised about steady motion at
    (u0, w0): straight motion for ``w0 = 0``, a turn of radius u0/w0 otherwise.

    The operating commands hold the velocities steady,
    :math:`v_{ref,0} = C(v_0)v_0 + F(v_0)v_0` (Eq. 6,
    :func:`unidyn.model.unicycle.inverse_dynamics` with zero acceleration), and
    :func:`control.linearize` differentiates :func:`velocity_iosys` there:

    .. math::

        A = \begin{bmatrix} -\theta_4/\theta_1 & 2\theta_3\omega_0/\theta_1 \\
                            -\theta_5\omega_0/\theta_2 & -(\theta_6 + \theta_5 u_0)/\theta_2 \end{bmatrix},
        \quad B = \mathrm{diag}(1/\theta_1, 1/\theta_2),\quad C = I,\ D = 0

    About rest the channels decouple, with poles -theta4/theta1 and -theta6/theta2
    and DC gains 1/theta4 and 1/theta6 (:func:`velocity_tf`).

    :return: :class:`control.StateSpace` with states and outputs ``u, w`` (deviations
        from u0, w0) and inputs ``u_ref, w_ref`` (deviations from the operating commands)
    """
    p = robots.resolve(robot, "robot")
    v0 = np.array([float(u0), float(w0)])
    if not np.all(np.isfinite(v0)):
        raise ValidationError(f"u0 and w0 must be finite, got {u0!r}, {w0!r}")
    ueq = unicycle.inverse_dynamics(v0, np.zeros(2), p.theta)
    return ct.linearize(velocity_iosys(p), v0, ueq, copy_names=True, name="velocity_loop")


class VelocityTF(NamedTuple):
    """The two channels of the velocity loop, ``(G_u, G_w)``: a tuple that prints as
    the two transfer functions it holds."""

    G_u: object
    G_w: object

    def __repr__(self) -> str:
        return "\n".join(str(g).rstrip() for g in self)


def velocity_tf(robot="p3dx_laser", u0: float = 0.0, w0: float = 0.0) -> VelocityTF:
    r"""The two channels of :func:`velocity_loop` as transfer functions; about rest
    (the default) and about straight motion the channels decouple:

    .. math:: \frac{u}{u_{ref}} = \frac{1}{\theta_1 s + \theta_4},\qquad
              \frac{\omega}{\omega_{ref}} = \frac{1}{\theta_2 s + \theta_6 + \theta_5 u_0}

    :return: :class:`VelocityTF` ``(G_u, G_w)``, SISO :class:`control.TransferFunction`
        from ``u_ref`` to ``u`` and from ``w_ref`` to ``w`` (the diagonal of the loop; in
        a turn the off-diagonal coupling is left out, see :func:`velocity_loop`)
    """
    ss = velocity_loop(robot, u0, w0)
    out = []
    for i, (o, n) in enumerate((("u", "u_ref"), ("w", "w_ref"))):
        tf = ct.minreal(ct.tf(ss[i, i]), verbose=False)
        out.append(ct.tf(tf.num[0][0], tf.den[0][0], inputs=n, outputs=o, name=f"G_{o}"))
    return VelocityTF(*out)


def linearize_robot(robot="p3dx_laser", a: float = 0.0, u0: float = 0.0, w0: float = 0.0,
                    psi0: float = 0.0):
    r"""The whole robot, Eqs. (1)-(2), linearised at heading psi0 while moving steadily
    at (u0, w0) (:func:`control.linearize` of :func:`to_iosys`).

    The pose is not at rest there (h moves and turns), so this is the Jacobian at one
    point of the motion: its velocity block is :func:`velocity_loop`, and the pose
    rows are the derivatives of Eq. (1),
    :math:`\partial\dot x/\partial\psi = -u_0\sin\psi_0 - a\omega_0\cos\psi_0`, ...

    :param a: offset of h, m, >= 0, defaults to 0 (as :func:`to_iosys`)
    :return: :class:`control.StateSpace`, states/outputs ``x, y, psi, u, w``, inputs
        ``u_ref, w_ref`` (deviations from the point and its steady commands)
    """
    p = robots.resolve(robot, "robot")
    x0 = np.array([0.0, 0.0, float(psi0), float(u0), float(w0)])
    ueq = unicycle.inverse_dynamics(x0[3:5], np.zeros(2), p.theta)
    return ct.linearize(to_iosys(p, a), x0, ueq, copy_names=True, name="robot_linear")


def tracking_loop(scenario=None, V: float = 0.3, **changes):
    r"""The Fig. 2 loop linearised about tracking a straight line along x at speed V:
    h_d moves at (V, 0), the robot follows it exactly with psi = 0, u = V, w = 0.

    :func:`control.linearize` differentiates :func:`fig2_loop` (with the reference as
    inputs and no limits) there; the loop depends on h_d - h only, so the result is
    time-invariant in the error coordinates. A reference generator (states x_d,
    y_d, x_d_dot, y_d_dot driven by the reference acceleration) closes it, and the
    outputs are the tracking errors. For small errors the tanh of Eq. (10) is linear,
    so the kinematic case has poles -kx, -ky and -V/a (the heading's internal
    dynamics); the uncompensated case adds the robot's lags of Eq. (2), with the
    longitudinal poles :math:`\theta_1 s^2 + \theta_4 s + k_x = 0`.

    :param scenario: a Scenario of case ``kinematic``, ``uncompensated`` or
        ``compensated`` (default: the paper's simulation 2); ``changes`` are applied
        (e.g. ``kx=1, ky=1``)
    :param V: speed of the reference, m/s, > 0
    :return: :class:`control.StateSpace` with inputs ``x_d_ddot, y_d_ddot`` (the
        reference's acceleration, m/s²), ``n_x, n_y, n_u, n_w`` (measurement noise)
        and outputs ``e_x, e_y`` (h_d - h, m), ``u_ref, w_ref`` (commands), ``u, w``,
        ``psi``; its poles are those of the loop plus four at 0 (the reference generator)
    """
    sc = Scenario.paper(2) if scenario is None else scenario
    if changes:
        sc = sc.replace(**changes)
    if sc.case_spec.adaptive:
        raise ValidationError(f"tracking_loop linearises the cases {', '.join(LINEAR_CASES)}, "
                              f"got {sc.case!r} (adaptation is not a linear time-invariant loop)")
    V = positive("V", V)
    sc = sc.replace(limits=NO_LIMITS, noise=None)
    loop = fig2_loop(sc, reference=False)
    x0 = np.zeros(loop.nstates)
    idx = loop.state_index
    if sc.case_spec.dynamic:
        x0[idx["robot_u"]] = V
    u0 = np.zeros(loop.ninputs)
    u0[loop.input_index["x_d_dot"]] = V
    L = ct.linearize(loop, x0, u0)
    L = ct.ss(L.A, L.B, L.C, L.D, inputs=loop.input_labels, outputs=loop.output_labels,
              states=[s.split("_", 1)[1] for s in loop.state_labels], name="loop")
    Z, I2 = np.zeros((2, 2)), np.eye(2)
    gen = ct.ss(np.block([[Z, I2], [Z, Z]]), np.vstack([Z, I2]),
                np.vstack([np.eye(4), np.hstack([Z, Z])]), np.vstack([np.zeros((4, 2)), I2]),
                inputs=["acc_x", "acc_y"], outputs=list(REFERENCE_SIGNALS),
                states=["x_d", "y_d", "x_d_dot", "y_d_dot"], name="reference")
    ex = ct.summing_junction(inputs=["x_d", "-x"], output="e_x", name="error_x")
    ey = ct.summing_junction(inputs=["y_d", "-y"], output="e_y", name="error_y")
    out = ct.interconnect([gen, L, ex, ey],
                          inplist=["acc_x", "acc_y", *NOISE_SIGNALS],
                          inputs=["x_d_ddot", "y_d_ddot", *NOISE_SIGNALS],
                          outlist=["e_x", "e_y", "u_ref", "w_ref", "u", "w", "psi"],
                          outputs=["e_x", "e_y", "u_ref", "w_ref", "u", "w", "psi"],
                          name=f"{sc.case}_tracking_loop",
                          check_unused=False)
    out = ct.ss(out)
    out.scenario = sc
    return out
