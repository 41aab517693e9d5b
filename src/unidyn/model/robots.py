"""Identified parameter sets of real robots: the paper's Table 1 and the block help of
the authors' MATLAB/Simulink package.

Where each preset's numbers come from (``source`` of :func:`get`, printed by
``unidyn robots``):

=====================  ==================================================================
preset                 source
=====================  ==================================================================
``p3dx``               Table 1 of Martins et al. (2017), column P3: Pioneer 3-DX with no
                       extra equipment
``p3dx_laser``         Table 1, column P3laser: Pioneer 3-DX with laser scanner and
                       omnidirectional camera, the robot of the paper's simulations
                       (Section 5); Table 1 prints theta3 and theta5 rounded (-0.0005,
                       0.0026), the digits here are FX44850's block help
``wheelchair_55kg``    Table 1, column RW55: robotic wheelchair carrying a 55 kg person
``wheelchair_125kg``   Table 1, column RW125: the same wheelchair, 125 kg person
``khepera3``           Table 1, column KIII: Khepera III
``p3dx_laut``          FX44850's block help, "Pioneer 3-DX (Laut 2011)"; see below
``pioneer2``           FX44850's block help: Pioneer 2 without onboard computer
``pioneer2_computer``  FX44850's block help: Pioneer 2 with onboard computer
``robulab10``          FX44850's block help: RobuLAB-10
=====================  ==================================================================

FX44850 is the authors' MATLAB/Simulink package, MATLAB Central File Exchange 44850
("Velocity-based dynamic model and adaptive controller for differential steered
mobile robot", the paper's reference 19); its block help lists all nine sets, Table
1's five among them with the same values.

The Laut set is labelled differently in two places of FX44850: its block help names
it a Pioneer 3-DX, its read-me a Khepera III. unidyn follows the block help: its
theta1 = 0.2183 s and theta2 = 0.1918 s are those of a robot of a Pioneer's mass,
near the other Pioneer sets (0.20-0.53 s, 0.14-0.28 s), ten and three times Table 1's
Khepera III (0.0228 s, 0.0568 s). Use :func:`get` with one of :func:`names`::

    >>> from unidyn import robots
    >>> robots.get("p3dx_laser").theta1
    0.2604
"""

from __future__ import annotations

from .._validate import ValidationError, did_you_mean, string_keys
from .parameters import THETA_NAMES, RobotParameters

__all__ = ["get", "names", "SPEED_LIMITS"]

_TABLE1 = "Martins et al. 2017, Table 1"
_FX = "block help of FX44850 (the authors' MATLAB package, File Exchange 44850)"

_PRESETS = {
    "p3dx": ((0.5338, 0.2168, -0.0134, 0.9560, -0.0843, 1.0590),
             "Pioneer 3-DX", _TABLE1 + ", column P3"),
    "p3dx_laser": ((0.2604, 0.2509, -0.000499, 0.9965, 0.00263, 1.0768),
                   "Pioneer 3-DX with laser (the paper's simulations)",
                   _TABLE1 + ", column P3laser (printed rounded as -0.0005, 0.0026); "
                   "full precision from the " + _FX),
    "wheelchair_55kg": ((0.3759, 0.0188, 0.0128, 1.0027, -0.0015, 0.9808),
                        "robotic wheelchair, 55 kg person", _TABLE1 + ", column RW55"),
    "wheelchair_125kg": ((0.4263, 0.0289, 0.0058, 0.9883, 0.0134, 0.9931),
                         "robotic wheelchair, 125 kg person", _TABLE1 + ", column RW125"),
    "khepera3": ((0.0228, 0.0568, -0.0001, 1.0030, 0.0732, 0.9981),
                 "Khepera III", _TABLE1 + ", column KIII"),
    "p3dx_laut": ((0.2183, 0.1918, -0.0050, 0.9993, -0.0279, 1.0142),
                  "Pioneer 3-DX (Laut 2011)",
                  _FX + " (its read-me labels the same set Khepera III)"),
    "pioneer2": ((0.1992, 0.13736, 0.001954, 0.9907, 0.01554, 0.9866),
                 "Pioneer 2, no onboard computer", _FX),
    "pioneer2_computer": ((0.3037, 0.2768, -0.0004018, 0.9835, 0.003818, 1.0725),
                          "Pioneer 2 with onboard computer", _FX),
    "robulab10": ((6.06, 0.284, 0.54, 6.48, 1.26, 1.8), "RobuLAB-10", _FX),
}

#: Maximum linear speed (m/s) the paper uses to check property 3 for each preset.
SPEED_LIMITS = {
    "p3dx": 1.2, "p3dx_laser": 1.2, "p3dx_laut": 1.2, "pioneer2": 1.2,
    "pioneer2_computer": 1.2, "wheelchair_55kg": 1.5, "wheelchair_125kg": 1.5,
    "khepera3": 0.5,
}


def names() -> list[str]:
    """The names of the preset robots, Table 1's first, then the others."""
    return list(_PRESETS)


def get(name) -> RobotParameters:
    """The identified :class:`RobotParameters` of a preset robot.

    :param name: one of :func:`names`, or a :class:`RobotParameters` (returned as is)
    :raises ValidationError: for an unknown name (the message lists the known ones)
    """
    if isinstance(name, RobotParameters):
        return name
    if not isinstance(name, str) or name not in _PRESETS:
        raise ValidationError(f"unknown robot {name!r}; known robots: {', '.join(_PRESETS)}")
    theta, label, source = _PRESETS[name]
    return RobotParameters(*theta, name=name, source=f"{label}; {source}")


def resolve(robot, what: str = "robot") -> RobotParameters:
    """A robot name, a :class:`RobotParameters` or six numbers -> :class:`RobotParameters`.

    A string ending in ``.json`` is read as a file holding theta1..theta6 (as
    written by :meth:`RobotParameters.as_dict`).
    """
    if isinstance(robot, RobotParameters):
        return robot
    if isinstance(robot, str):
        if robot.endswith(".json"):
            return _from_json(robot, what)
        try:
            return get(robot)
        except ValidationError as err:
            raise ValidationError(f"{what}: {err}") from None
    if isinstance(robot, dict):
        string_keys(what, robot)
        unknown = sorted(set(robot) - set(THETA_NAMES) - {"name", "source"})
        if unknown:
            hint = did_you_mean(unknown[0], THETA_NAMES + ("name",))
            raise ValidationError(f"{what}: unknown key {unknown[0]!r}{hint}; a robot table has "
                                  f"theta1..theta6 (and optionally name)")
        missing = [k for k in THETA_NAMES if k not in robot]
        if missing:
            raise ValidationError(f"{what}: missing {missing[0]}")
        name = robot.get("name", "custom")
        try:
            return RobotParameters(*(robot[k] for k in THETA_NAMES),
                                   name=name if isinstance(name, str) else repr(name))
        except ValidationError as err:
            raise ValidationError(f"{what}: {err}") from None
    try:
        return RobotParameters.from_vector(robot)
    except ValidationError as err:
        raise ValidationError(
            f"{what} must be a robot name ({', '.join(_PRESETS)}), RobotParameters "
            f"or six numbers: {err}") from None


def _from_json(path: str, what: str) -> RobotParameters:
    import json
    from pathlib import Path
    try:
        data = json.loads(Path(path).read_text())
    except (OSError, ValueError) as err:
        raise ValidationError(f"{what}: cannot read {path}: {err}") from None
    if isinstance(data, dict) and "theta" in data and isinstance(data["theta"], dict):
        data = data["theta"]
    if not isinstance(data, dict):
        raise ValidationError(f"{what}: {path} must hold a JSON object with theta1..theta6")
    data = {k: v for k, v in data.items() if k in THETA_NAMES + ("name",)}
    return resolve({**data, "name": data.get("name", Path(path).stem)}, f"{what} ({path})")
