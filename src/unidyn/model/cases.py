"""The four cases of the Fig. 2 loop (Section 5) as data: which robot is simulated,
which compensation drives it, whether the estimate adapts.

A case's name is decoded here only: the diagram, the batch engine, the python-control
bridge and the figures read the :class:`CaseSpec` of a scenario
(:attr:`unidyn.Scenario.case_spec`), never the name itself.
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["CaseSpec", "CASE_SPECS", "CASES", "ROBOT_MODELS", "COMPENSATIONS"]

#: The robots a case simulates: ``"kinematic"`` (Eq. 1 alone, v = v_ref) or
#: ``"dynamic"`` (Eqs. 1-2, the velocity-based dynamic model).
ROBOT_MODELS = ("kinematic", "dynamic")
#: What sits between the kinematic controller and the robot: ``"none"`` (v_ref = v_d),
#: ``"exact"`` (Eq. 14 with an estimate held fixed: the robot's own theta unless
#: ``theta_hat0`` says otherwise) or ``"adaptive"`` (Eq. 14 with the update of
#: Eq. 18 or 20).
COMPENSATIONS = ("none", "exact", "adaptive")


@dataclass(frozen=True)
class CaseSpec:
    """What one case of the loop is.

    :param name: the case's name, as a scenario writes it (``case = "adaptive"``)
    :param robot: one of :data:`ROBOT_MODELS`
    :param compensation: one of :data:`COMPENSATIONS`; a kinematic robot has none
    :param theta_hat_divisor: the initial estimate when ``theta_hat0`` is unset: the
        robot's theta divided by this (the paper's simulation 4 starts from theta/1.5)
    :param title: what the case is, in words, for figures
    """

    name: str
    robot: str
    compensation: str
    theta_hat_divisor: float
    title: str

    def __post_init__(self):
        if self.robot not in ROBOT_MODELS:
            raise ValueError(f"robot must be one of {ROBOT_MODELS}, got {self.robot!r}")
        if self.compensation not in COMPENSATIONS:
            raise ValueError(f"compensation must be one of {COMPENSATIONS}, "
                             f"got {self.compensation!r}")
        if self.robot == "kinematic" and self.compensation != "none":
            raise ValueError("a kinematic robot has no dynamics to compensate")

    @property
    def dynamic(self) -> bool:
        """The robot has the dynamics of Eq. (2) (its u, w are states)."""
        return self.robot == "dynamic"

    @property
    def compensated(self) -> bool:
        """The dynamic compensator of Eq. (14) computes v_ref (it reads u, w and v_d')."""
        return self.compensation != "none"

    @property
    def adaptive(self) -> bool:
        """The estimate theta_hat is updated (Eqs. 18, 20) from ``adapt_from`` on."""
        return self.compensation == "adaptive"


#: The cases of Section 5, by name, in the paper's order (simulations 1-4).
CASE_SPECS = {spec.name: spec for spec in (
    CaseSpec("kinematic", "kinematic", "none", 1.0, "kinematic robot (v = v_d)"),
    CaseSpec("uncompensated", "dynamic", "none", 1.0, "dynamic robot, no compensation"),
    CaseSpec("compensated", "dynamic", "exact", 1.0, "exact dynamic compensation"),
    CaseSpec("adaptive", "dynamic", "adaptive", 1.5, "adaptive dynamic compensation"),
)}
#: The cases' names, in the paper's order.
CASES = tuple(CASE_SPECS)
