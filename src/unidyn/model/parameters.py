"""Dynamic parameters theta1..theta6 of the velocity-based model.

Martins, Sarcinelli-Filho and Carelli, "A Velocity-Based Dynamic Model and Its
Properties for Differential Drive Mobile Robots", J Intell Robot Syst (2017),
Section 2 and Eq. (2).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .._validate import ValidationError, nonnegative, positive, real, vector
from .schedules import step_rows

__all__ = ["RobotParameters", "THETA_NAMES", "MASS_PARAMETERS", "PAYLOAD_STEPS",
           "payload_schedule"]

#: The six parameters by name, in the order of the vector theta (Eq. 2).
THETA_NAMES = ("theta1", "theta2", "theta3", "theta4", "theta5", "theta6")
#: Indices (0-based) of the parameters that scale with the robot's mass: theta1,
#: theta2, theta3, theta5 (Section 2; see :meth:`RobotParameters.with_mass`).
MASS_PARAMETERS = (0, 1, 2, 4)
#: The most rows a payload schedule holds (:func:`payload_schedule`; the table entries
#: ``payload_time1``, ``payload_mass1``, ... of the engines).
PAYLOAD_STEPS = 8
_POSITIVE = ("theta1", "theta2", "theta4", "theta6")


@dataclass(frozen=True)
class RobotParameters:
    """The six identified parameters of the dynamic model, Eq. (2).

    Immutable. ``theta1``, ``theta2``, ``theta4`` and ``theta6`` are strictly
    positive for every physical robot (Section 2); ``theta3`` and ``theta5``
    may have either sign and vanish when the centre of mass lies on the wheel
    axle (b = 0).

    :param theta1: time constant of the linear-velocity loop, s, > 0
    :type theta1: float
    :param theta2: time constant of the angular-velocity loop, s, > 0
    :type theta2: float
    :param theta3: centripetal coupling, s·m/rad², any sign
    :type theta3: float
    :param theta4: linear-velocity damping, dimensionless, > 0
    :type theta4: float
    :param theta5: Coriolis coupling, s/m, any sign
    :type theta5: float
    :param theta6: angular-velocity damping, dimensionless, > 0
    :type theta6: float
    :param name: a label for reports and plots
    :type name: str
    :param source: where the numbers come from
    :type source: str
    """

    theta1: float
    theta2: float
    theta3: float
    theta4: float
    theta5: float
    theta6: float
    name: str = field(default="custom", compare=False)
    source: str = field(default="", compare=False)

    def __post_init__(self):
        for k in THETA_NAMES:
            v = getattr(self, k)
            if k in _POSITIVE:
                v = real(k, v, low=0.0, low_open=True)
            else:
                v = real(k, v)
            object.__setattr__(self, k, v)
        if not isinstance(self.name, str):
            raise ValidationError(f"name must be a string, got {self.name!r}")
        if not isinstance(self.source, str):
            raise ValidationError(f"source must be a string, got {self.source!r}")

    @property
    def theta(self) -> np.ndarray:
        """The parameter vector [theta1, ..., theta6] (a fresh array)."""
        return np.array([getattr(self, k) for k in THETA_NAMES])

    @classmethod
    def from_vector(cls, theta, name: str = "custom", source: str = "") -> "RobotParameters":
        """Build from a sequence of six numbers [theta1, ..., theta6]."""
        t = vector("theta", theta, 6)
        return cls(*t.tolist(), name=name, source=source)

    def scaled(self, factor: float, name: str | None = None) -> "RobotParameters":
        """All six parameters multiplied by ``factor`` > 0 (e.g. 1/1.5 for the paper's
        initial estimate of Section 5)."""
        f = positive("factor", factor)
        return RobotParameters.from_vector(self.theta * f, name=name or f"{self.name} x {f:g}")

    def with_mass(self, scale: float, name: str | None = None) -> "RobotParameters":
        r"""The robot whose mass is ``scale`` (> 0) times this one's, the load carried
        with the robot's own distribution of mass: theta1, theta2, theta3 and theta5
        multiplied by ``scale``, theta4 and theta6 kept
        (:func:`unidyn.model.equations.payload_theta` writes out why, from the
        expressions of Section 2)."""
        f = positive("payload", scale)
        th = self.theta
        th[list(MASS_PARAMETERS)] *= f
        return RobotParameters.from_vector(th, name=name or f"{self.name} x{f:g} mass")

    def as_dict(self) -> dict:
        """theta1..theta6 by name (for JSON and TOML)."""
        return {k: float(v) for k, v in zip(THETA_NAMES, self.theta)}

    @classmethod
    def from_physical(cls, m, Iz, Ra, ka, kb, Be, Ie, r, b, d, kPT, kPR, kDT=0.0, kDR=0.0,
                      name: str = "physical") -> "RobotParameters":
        r"""theta from the robot's physical parameters (Section 2 of the paper).

        .. math::

            \theta_1 &= \frac{R_a}{k_a}\frac{m r^2 + 2 I_e + 2 r k_{DT}}{2 r k_{PT}}, &
            \theta_2 &= \frac{R_a}{k_a}\frac{I_e d^2 + 2 r^2 (I_z + m b^2) + 2 r d k_{DR}}{2 r d k_{PR}}, \\
            \theta_3 &= \frac{R_a}{k_a}\frac{m b r}{2 k_{PT}}, &
            \theta_4 &= \frac{R_a}{k_a}\frac{k_a k_b / R_a + B_e}{r k_{PT}} + 1, \\
            \theta_5 &= \frac{R_a}{k_a}\frac{m b r}{d k_{PR}}, &
            \theta_6 &= \frac{R_a}{k_a}\frac{(k_a k_b / R_a + B_e) d}{2 r k_{PR}} + 1.

        :param m: robot mass, kg, > 0
        :type m: float
        :param Iz: moment of inertia about the vertical axis through G, kg·m², >= 0
        :type Iz: float
        :param Ra: motor armature resistance, Ohm, > 0
        :type Ra: float
        :param ka: motor torque constant, N·m/A, > 0
        :type ka: float
        :param kb: motor back-emf constant, V·s/rad, >= 0
        :type kb: float
        :param Be: viscous friction of each motor-gear-wheel group, N·m·s/rad, >= 0
        :type Be: float
        :param Ie: moment of inertia of each rotor-gear-wheel group, kg·m², >= 0
        :type Ie: float
        :param r: wheel radius, m, > 0
        :type r: float
        :param b: distance from the wheel-axle centre to the centre of mass, m (any sign)
        :type b: float
        :param d: distance between the wheels' contact points, m, > 0
        :type d: float
        :param kPT: proportional gain of the wheel servo, translation, > 0
        :type kPT: float
        :param kPR: proportional gain of the wheel servo, rotation, > 0
        :type kPR: float
        :param kDT: derivative gain of the wheel servo, translation, >= 0
        :type kDT: float
        :param kDR: derivative gain of the wheel servo, rotation, >= 0
        :type kDR: float
        :param name: label of the resulting parameter set
        :type name: str
        """
        m = positive("m", m)
        Iz = nonnegative("Iz", Iz)
        Ra = positive("Ra", Ra)
        ka = positive("ka", ka)
        kb = nonnegative("kb", kb)
        Be = nonnegative("Be", Be)
        Ie = nonnegative("Ie", Ie)
        r = positive("r", r)
        b = real("b", b)
        d = positive("d", d)
        kPT = positive("kPT", kPT)
        kPR = positive("kPR", kPR)
        kDT = nonnegative("kDT", kDT)
        kDR = nonnegative("kDR", kDR)
        g = Ra / ka
        damping = ka * kb / Ra + Be
        return cls(
            theta1=g * (m * r**2 + 2 * Ie + 2 * r * kDT) / (2 * r * kPT),
            theta2=g * (Ie * d**2 + 2 * r**2 * (Iz + m * b**2) + 2 * r * d * kDR) / (2 * r * d * kPR),
            theta3=g * m * b * r / (2 * kPT),
            theta4=g * damping / (r * kPT) + 1,
            theta5=g * m * b * r / (d * kPR),
            theta6=g * damping * d / (2 * r * kPR) + 1,
            name=name,
            source="computed from physical parameters (Martins et al. 2017, Section 2)",
        )

    def __str__(self) -> str:
        vals = ", ".join(f"{k}={v:.6g}" for k, v in zip(THETA_NAMES, self.theta))
        return f"RobotParameters({self.name}: {vals})"


def payload_schedule(value, name: str = "payload") -> tuple:
    """A payload schedule validated: rows ``(t, mass scale)``, from time t (s, >= 0) on
    the robot's mass is ``mass scale`` (> 0) times the empty robot's; before the first
    row it is the empty robot's. Times increase strictly; at most
    :data:`PAYLOAD_STEPS` rows. A number m is the schedule ``[[0, m]]`` (loaded from
    the start); ``None`` or an empty list is no payload, ``()``.

    :raises ValidationError: one line naming ``name`` and what is allowed
    """
    what = (f"{name} must be a mass scale > 0 or a schedule of [t, mass scale] rows "
            f"(t >= 0 in s, increasing; mass scale > 0, 1 = the empty robot; at most "
            f"{PAYLOAD_STEPS} rows)")
    if value is None:
        return ()
    if isinstance(value, np.ndarray):
        value = value.tolist()
    if isinstance(value, (str, bytes, dict, bool, np.bool_)):
        raise ValidationError(f"{what}, got {value!r:.120}")
    if not isinstance(value, (list, tuple)):
        return ((0.0, positive(name, value)),)
    if len(value) > PAYLOAD_STEPS:
        raise ValidationError(f"{name}: a schedule has at most {PAYLOAD_STEPS} rows, got "
                              f"{len(value)}")
    return step_rows(name, value, what, "mass scale")
