"""A validated, immutable description of one closed-loop run (Fig. 2, Section 5).

Defaults are the paper's simulation settings (Section 5); ``Scenario.paper(n)``
gives the paper's simulation n = 1..4. Scenarios are plain data: they convert to
and from dicts (TOML and JSON files) and nothing in them is ever evaluated as code.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from .._validate import (
    ValidationError,
    choice,
    did_you_mean,
    nonnegative,
    positive,
    positive_vector,
    string_keys,
    vector,
)
from . import robots, trajectories
from .cases import CASE_SPECS, CASES, CaseSpec
from .laws import LEAKAGE_FORMS, PAPER_GAMMA, PAPER_SIGMA
from .noise import PAPER_NOISE, NoiseSpec
from .parameters import RobotParameters, payload_schedule
from .unicycle import PAPER_LIMITS, Limits, loaded_theta

__all__ = ["Scenario", "CASES", "CASE_SPECS", "CONTROL_MODES", "VD_DOT_METHODS", "PAPER_GAMMA",
           "PAPER_SIGMA"]

#: How the controllers run: evaluated with the plant, or sampled on a clock at Ts.
CONTROL_MODES = ("continuous", "sampled")
#: How the compensator gets v_d': the exact derivative of Eq. (10) along the
#: motion ("analytic"), a first-order derivative filter ("filter", continuous
#: control only) or a backward difference over Ts ("difference", sampled only).
VD_DOT_METHODS = ("analytic", "filter", "difference")
# v_d' methods each control mode can use (the sampled controller has no rate output)
_VD_DOT_FOR = {"continuous": ("analytic", "filter"), "sampled": ("difference",)}
#: The floating types a result's series can be logged in (``log_dtype``).
LOG_DTYPES = ("float64", "float32")
#: The series of a result that are always logged (the error and the metrics are
#: computed from them): pose (3 values a sample), velocity (2), reference (2).
ALWAYS_LOGGED = ("pose", "velocity", "reference")
#: The series a scenario may leave out of its log (``log_series``), with their
#: values per sample: v_d (2), v_ref (2), theta_hat (6).
OPTIONAL_SERIES = ("v_d", "v_ref", "theta_hat")
#: the values of ``noise`` that mean a noise-free run, besides None
NO_NOISE = (False, "none", "off")
_SERIES_WIDTH = {"pose": 3, "velocity": 2, "reference": 2, "v_d": 2, "v_ref": 2, "theta_hat": 6}
#: The most samples (T/Ts) one run may integrate, and the most bytes its log may
#: hold (:meth:`Scenario.logged_bytes` per logged sample, times T/Ts/log_every).
#: A run's memory is mostly its log (152 bytes per logged sample with every series
#: in float64, 80 in float32, 72 and 40 with only the series that are always
#: logged); the held noise is drawn a window at a time and the files are written by
#: streaming, so with these bounds a run stays within about 1 GB
#: (``python benchmarks/engines.py --memory`` measures it).
MAX_SAMPLES = 10_000_000
MAX_LOG_BYTES = 800_000_000
#: A state this many times beyond its physical scale (the speed limits, or the
#: reference's size and speed where there are none) counts as diverged: both
#: engines stop there (see :meth:`Scenario.divergence_bounds`).
DIVERGENCE_FACTOR = 1e6
#: Samples of [0, T] at which the reference is evaluated for its scale.
_SCALE_POINTS = 257


def _tuple(name, value, n):
    return tuple(vector(name, value, n).tolist())


@dataclass(frozen=True)
class Scenario:
    """One run of the Fig. 2 loop. All fields are validated on construction.

    :param case: ``"kinematic"`` (purely kinematic robot, v = v_d), ``"uncompensated"``
        (dynamic robot, v_ref = v_d), ``"compensated"`` (exact theta_hat) or ``"adaptive"``
    :param robot: the simulated robot: preset name, RobotParameters or six numbers
    :param a: offset of the controlled point h ahead of the axle centre, m, > 0
    :param x0: initial pose of h (x, y, psi), robot at rest, m and rad
    :param trajectory: the reference: a Trajectory or a spec dict ``{"type": ...}``
    :param kx, ky: kinematic-controller gains, 1/s, > 0 (Eq. 10)
    :param lx, ly: kinematic-controller saturations, m/s, > 0
    :param ku, kw: compensator gains, 1/s, > 0 (Eq. 12)
    :param lu, lw: compensator saturations, > 0
    :param theta_hat0: initial estimate; ``None`` means the robot's own theta for
        ``compensated`` and theta/1.5 (the paper's choice) for ``adaptive``
    :param gamma: diagonal of the adaptation gain, six values > 0 (Eq. 18)
    :param sigma: diagonal of Sigma, six values >= 0 (Eq. 20)
    :param adapt_from: time the update is switched on, s, >= 0
    :param leakage: ``"paper"`` (Eq. 20), ``"fx44850"`` or ``"none"`` (Eq. 18)
    :param noise: ``NoiseSpec`` (or a dict of it) or ``None`` for noise-free runs
    :param limits: the robot's ``Limits`` (or a dict), defaults to the paper's
    :param T: duration, s, > 0
    :param Ts: sample time of the noise, the sampled controllers and the results, s, > 0
    :param control: ``"continuous"`` or ``"sampled"``
    :param vd_dot: ``"analytic"`` or ``"filter"`` (continuous control), ``"difference"``
        (sampled control); ``None`` (default) picks ``"analytic"`` for continuous and
        ``"difference"`` for sampled control (see :attr:`derivative`)
    :param tau: time constant of the derivative filter, s, > 0
    :param name: a label
    :param log_every: log every ``log_every``-th sample of Ts, integer >= 1 that
        divides T/Ts (default 1: every sample). The integration and the noise are
        unchanged; only the stored series (and the metrics computed from them,
        on the logged grid) are thinned.
    :param log_dtype: ``"float64"`` (default) or ``"float32"``: the floating type of
        the result's series. The integration is float64 either way; float32 halves the
        memory of a long run (80 instead of 152 bytes per logged sample) and
        rounds the logged values to 7 significant digits (about 1e-7 m on a 1 m path),
        which is what the metrics are then computed from.
    :param log_series: the series the result keeps besides ``pose``, ``velocity``
        and ``reference`` (always logged: the error and the metrics come from them):
        any of ``"v_d"``, ``"v_ref"``, ``"theta_hat"``, as a list or a comma-separated
        string (default all three; the others are ``None`` in the result).
        ``log_series=()`` logs 72 bytes a sample in float64, 40 in float32
        (:meth:`logged_bytes`). The integration is the same.
    :param payload: a load that changes during the run: rows ``[t, mass scale]``,
        from t (s) on the robot's mass is that multiple of the empty robot's
        (``robot``), which scales theta1, theta2, theta3, theta5
        (:func:`unidyn.model.equations.payload_theta`, Section 2); increasing times,
        scales > 0, at most 8 rows, times within [0, T]; a number m is ``[[0, m]]``;
        default none; no effect on a kinematic robot (case ``kinematic``). The compensator keeps its own
        estimate: exact compensation uses the empty robot's theta, adaptive
        compensation follows the change (Eq. 20).
    """

    case: str = "adaptive"
    robot: RobotParameters = "p3dx_laser"
    a: float = 0.2
    x0: tuple = (0.2, 0.0, 0.0)
    trajectory: trajectories.Trajectory = field(default_factory=trajectories.FigureEight)
    kx: float = 0.1
    ky: float = 0.1
    lx: float = 0.1
    ly: float = 0.1
    ku: float = 4.0
    kw: float = 4.0
    lu: float = 1.0
    lw: float = 1.0
    theta_hat0: RobotParameters | None = None
    gamma: tuple = PAPER_GAMMA
    sigma: tuple = PAPER_SIGMA
    adapt_from: float = 100.0
    leakage: str = "paper"
    noise: NoiseSpec | None = PAPER_NOISE
    limits: Limits = PAPER_LIMITS
    T: float = 200.0
    Ts: float = 0.1
    control: str = "continuous"
    vd_dot: str | None = None
    tau: float = 0.05
    name: str = ""
    log_every: int = 1
    log_dtype: str = "float64"
    log_series: tuple = OPTIONAL_SERIES
    payload: tuple = ()

    def __new__(cls, *args, **fields):
        # a misspelt keyword is named in one line, with the close match and the fields
        # (the dataclass's __init__ would raise a bare TypeError)
        _check_fields(fields)
        return super().__new__(cls)

    def __post_init__(self):
        # each field through its rules (:data:`_RULES`), in order: a rule sees the
        # fields before it already checked
        for name, rule in _RULES:
            object.__setattr__(self, name, rule(getattr(self, name), name, self))

    # ------------------------------------------------------------------ #
    @property
    def case_spec(self) -> CaseSpec:
        """What the case is (:class:`~unidyn.model.cases.CaseSpec`): which robot
        (``.dynamic``), which compensation (``.compensated``), whether it adapts
        (``.adaptive``)."""
        return CASE_SPECS[self.case]

    @property
    def theta_hat_initial(self) -> np.ndarray:
        """The estimate the compensator starts from (see ``theta_hat0``)."""
        if self.theta_hat0 is not None:
            return self.theta_hat0.theta
        divisor = self.case_spec.theta_hat_divisor
        return self.robot.theta if divisor == 1 else self.robot.theta / divisor

    def theta_at(self, t) -> np.ndarray:
        """The robot's theta1..theta6 at time t, s (a number: shape (6,); an array of N
        times: (N, 6)), under the ``payload`` schedule (Section 2's scaling,
        :func:`unidyn.model.equations.payload_theta`): what the estimate would track."""
        return loaded_theta(self.robot.theta, self.payload, t)

    @property
    def derivative(self) -> str:
        """The v_d' method in use: ``vd_dot``, or when unset ``"analytic"`` for
        continuous and ``"difference"`` for sampled control."""
        if self.vd_dot is not None:
            return self.vd_dot
        return "analytic" if self.control == "continuous" else "difference"

    @cached_property
    def reference_scale(self) -> tuple:
        r"""(max \|h_d\|, max \|h_d'\|, max \|h_d''\|) of the reference over [0, T], from
        257 evenly spaced samples (non-finite samples are ignored)."""
        t = np.linspace(0.0, self.T, _SCALE_POINTS)
        tr = self.trajectory
        out = []
        for fn in (tr.position, tr.velocity, tr.acceleration):
            try:
                with np.errstate(all="ignore"):
                    v = np.linalg.norm(np.asarray(fn(t), dtype=float).reshape(len(t), 2), axis=1)
                v = v[np.isfinite(v)]
                out.append(float(v.max()) if len(v) else 0.0)
            except Exception:  # a user trajectory that fails is reported by the engines
                out.append(0.0)
        return tuple(out)

    def divergence_bounds(self) -> np.ndarray:
        r"""[\|(x, y)\| bound in m, \|u\| bound in m/s, \|w\| bound in rad/s]: a state beyond
        one of these has diverged (both engines stop the run there).

        Each is :data:`DIVERGENCE_FACTOR` times a physical scale: the speed limits,
        or where a limit is infinite the speed the kinematic controller can ask for,
        \|h_d'\| + l (Eq. 10), and for positions the reference's size (at least 1 m)."""
        P, V, _ = self.reference_scale
        U = max(1.0, V + max(self.lx, self.ly))
        vmax, wmax = self.limits.speed
        return DIVERGENCE_FACTOR * np.array([
            max(1.0, P),
            vmax if np.isfinite(vmax) else U,
            wmax if np.isfinite(wmax) else max(1.0, U / self.a)])

    @staticmethod
    def divergence(which: int, value: float, bound: float) -> str:
        """What both engines say when the state leaves :meth:`divergence_bounds`:
        ``which`` 0 for the position, 1 for u, 2 for w."""
        what = (("the position |(x, y)|", "m", "the reference's size"),
                ("|u|", "m/s", "its limit, or what the controller asks for"),
                ("|w|", "rad/s", "its limit, or what the controller asks for"))[which]
        return (f"diverged: {what[0]} = {value:.3g} {what[1]} is beyond {bound:.3g} {what[1]} "
                f"({DIVERGENCE_FACTOR:g} times {what[2]})")

    def logged_bytes(self) -> int:
        """The bytes a result holds per logged sample: the time stamp (float64), the
        series logged (:data:`ALWAYS_LOGGED` and ``log_series``) and the error, in
        ``log_dtype``."""
        n = sum(_SERIES_WIDTH[k] for k in ALWAYS_LOGGED + self.log_series) + 1
        return 8 + n * np.dtype(self.log_dtype).itemsize

    @property
    def steps(self) -> int:
        """Number of sample intervals, round(T / Ts)."""
        return int(round(self.T / self.Ts))

    def replace(self, **changes) -> "Scenario":
        """A copy with some fields changed (validated). Unknown fields raise."""
        _check_fields(changes)
        return dataclasses.replace(self, **changes)

    @classmethod
    def paper(cls, n: int, **changes) -> "Scenario":
        """The paper's simulation n (Section 5): 1 kinematic robot, 2 dynamic robot
        without compensation, 3 exact compensation, 4 adaptive compensation from t = 100 s."""
        if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n not in (1, 2, 3, 4):
            raise ValidationError(f"paper simulation n must be 1, 2, 3 or 4, got {n!r}")
        _check_fields(changes)
        base = {"case": CASES[n - 1], "name": f"paper simulation {n} ({CASES[n - 1]})"}
        return cls(**{**base, **changes})

    # ------------------------------------------------------------------ #
    def to_dict(self) -> dict:
        """Plain data (str, float, list, dict) that ``from_dict`` turns back into this scenario."""
        return {f.name: plain_value(getattr(self, f.name)) for f in dataclasses.fields(self)}

    @classmethod
    def from_dict(cls, data) -> "Scenario":
        """Build from plain data (as read from TOML or JSON). Unknown keys raise. A
        scenario file is read by :func:`unidyn.read_scenario`."""
        if not isinstance(data, dict):
            raise ValidationError(f"a scenario must be a table of fields, got {type(data).__name__}")
        _check_fields(data)
        data = dict(data)
        if isinstance(data.get("theta_hat0"), str) and data["theta_hat0"] in ("default", ""):
            data["theta_hat0"] = None
        try:
            return cls(**data)
        except TypeError as err:  # e.g. a list where a number was expected, deep inside
            raise ValidationError(f"scenario: {err}") from None


# ------------------------------------------------------------------ the rules of the fields

def _alone(check):
    """The rule of a check that reads no other field: ``check(name, value)``."""
    return lambda value, name, sc: check(name, value)


def _sigma(value, name, sc):
    sig = vector(name, value, 6)
    if np.any(sig < 0):
        raise ValidationError(f"every element of sigma must be >= 0, got {sig.tolist()}")
    return tuple(sig.tolist())


def _noise(value, name, sc):
    if isinstance(value, (bool, str)) and value in NO_NOISE:
        return None  # as scenario files write it: noise = "off"
    if isinstance(value, dict):
        return _build(name, NoiseSpec, value)
    if value is not None and not isinstance(value, NoiseSpec):
        raise ValidationError(f"noise must be None (or \"off\"), a NoiseSpec or a dict "
                              f"with position_std, velocity_std, seed; got {value!r}")
    return value


def _limits(value, name, sc):
    if isinstance(value, dict):
        return _build(name, Limits, value)
    if not isinstance(value, Limits):
        raise ValidationError(f"limits must be a Limits or a dict with speed_max, steer_max, "
                              f"accel_max, angular_accel_max; got {value!r}")
    return value


def _vd_dot(value, name, sc):
    """After ``control``: a method that control mode can use."""
    if value is not None:
        choice(name, value, VD_DOT_METHODS)
        allowed = _VD_DOT_FOR[sc.control]
        if value not in allowed:
            raise ValidationError(
                f"vd_dot={value!r} cannot be used with control={sc.control!r}; "
                f"use one of {', '.join(map(repr, allowed))} (or leave vd_dot unset)")
    return value


def _samples(value, name, sc):
    """After ``T`` and ``Ts``: Ts within T, T a whole number of samples, not too many."""
    T, Ts = sc.T, value
    if Ts > T:
        raise ValidationError(f"Ts must be <= T ({T:g} s), got {Ts!r}")
    if T / Ts > MAX_SAMPLES:
        raise ValidationError(f"T/Ts must be at most {MAX_SAMPLES:.0e} samples, got "
                              f"T = {T:g} s, Ts = {Ts:g} s")
    ratio = T / Ts
    if abs(ratio - round(ratio)) > 1e-9 * max(1.0, ratio):
        lo, hi = math.floor(ratio) * Ts, math.ceil(ratio) * Ts
        raise ValidationError(
            f"T must be a whole number of samples of Ts: T = {T!r} s, Ts = {Ts!r} s "
            f"give T/Ts = {ratio:.6g}; use T = {lo:.10g} s or T = {hi:.10g} s "
            f"(or a Ts that divides T)")
    return value


def _x0_within_bounds(value, name, sc):
    """After the reference, gains, limits and T: the start not already diverged."""
    if abs(value[2]) > DIVERGENCE_FACTOR:
        raise ValidationError(f"x0: the initial heading psi must be within "
                              f"+-{DIVERGENCE_FACTOR:g} rad, got {value[2]!r}")
    if math.hypot(value[0], value[1]) > DIVERGENCE_FACTOR:  # cheap test first
        bound = sc.divergence_bounds()[0]
        if not math.hypot(value[0], value[1]) <= bound:
            raise ValidationError(
                f"x0: the initial position ({value[0]:g}, {value[1]:g}) m is more than "
                f"{DIVERGENCE_FACTOR:g} times the reference's size away from the origin; "
                f"|(x, y)| must be at most {bound:g} m")
    return value


def _log_every(value, name, sc):
    """After T and Ts: a whole divisor of T/Ts."""
    if (isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1
            or sc.steps % int(value) != 0):
        raise ValidationError(f"log_every must be an integer >= 1 that divides T/Ts = "
                              f"{sc.steps}, got {value!r}")
    return int(value)


def _log_fits(value, name, sc):
    """After the log's fields: the log within :data:`MAX_LOG_BYTES`."""
    cap = MAX_LOG_BYTES // sc.logged_bytes()
    if sc.steps // sc.log_every > cap:
        need = -(-sc.steps // cap)
        need = next(d for d in range(need, sc.steps + 1) if sc.steps % d == 0)
        other = []
        if sc.log_dtype == "float64":
            other.append("log_dtype='float32'")
        if sc.log_series:
            other.append("log_series=() (only pose, velocity and reference)")
        raise ValidationError(
            f"T/Ts/log_every must be at most {cap:.2e} logged samples with log_dtype = "
            f"{sc.log_dtype!r} and log_series = {list(sc.log_series)} "
            f"({sc.logged_bytes()} bytes a sample; {MAX_LOG_BYTES / 1e6:.0f} MB in all); "
            f"T = {sc.T:g} s, Ts = {sc.Ts:g} s give {sc.steps} samples: "
            f"set log_every >= {need} (a divisor of {sc.steps})"
            + (f", or {' or '.join(other)}" if other else ""))
    return value


def _payload_within_run(value, name, sc):
    """After T: a load that changes after the run's end changes nothing, so is refused."""
    late = [t for t, _ in value if t > sc.T]
    if late:
        raise ValidationError(f"{name}: a row at t = {late[0]:g} s is after the run's end, "
                              f"T = {sc.T:g} s; every row's time must be within [0, T]")
    return value


def _name(value, name, sc):
    if not isinstance(value, str):
        raise ValidationError(f"name must be a string, got {value!r}")
    return value


#: What :class:`Scenario` checks, in order: (field, rule). A rule takes the value as
#: given, the field's name and the scenario (its fields before this rule already
#: checked) and returns the value kept; a bad value raises a ValidationError of one
#: line naming the field. A field whose rule reads other fields comes again after them.
_RULES = (
    ("case", _alone(lambda name, v: choice(name, v, CASES))),
    ("robot", _alone(lambda name, v: robots.resolve(v, name))),
    ("a", _alone(positive)),
    ("x0", _alone(lambda name, v: _tuple(name, v, 3))),
    ("trajectory", _alone(lambda name, v: trajectories.from_spec(v))),
    *((k, _alone(positive))
      for k in ("kx", "ky", "lx", "ly", "ku", "kw", "lu", "lw", "T", "Ts", "tau")),
    ("theta_hat0", _alone(lambda name, v: None if v is None else robots.resolve(v, name))),
    ("gamma", _alone(lambda name, v: tuple(positive_vector(name, v, 6).tolist()))),
    ("sigma", _sigma),
    ("adapt_from", _alone(nonnegative)),
    ("leakage", _alone(lambda name, v: choice(name, v, LEAKAGE_FORMS))),
    ("noise", _noise),
    ("limits", _limits),
    ("control", _alone(lambda name, v: choice(name, v, CONTROL_MODES))),
    ("vd_dot", _vd_dot),
    ("Ts", _samples),
    ("x0", _x0_within_bounds),
    ("log_every", _log_every),
    ("log_dtype", _alone(lambda name, v: choice(name, v, LOG_DTYPES))),
    ("log_series", _alone(lambda name, v: _log_series(v))),
    ("log_series", _log_fits),
    ("name", _name),
    ("payload", _alone(lambda name, v: payload_schedule(v))),
    ("payload", _payload_within_run),
)


def _is_preset(p: RobotParameters) -> bool:
    try:
        return p.name in robots.names() and robots.get(p.name) == p
    except ValidationError:
        return False


def plain_value(v):
    """Plain data (str, float, int, bool, list, dict, None) for the value of a Scenario
    field, as TOML and JSON hold it: a preset robot by its name, any other robot as its
    table, a trajectory by its spec, noise and limits as tables, tuples and arrays as
    lists, numpy scalars as Python numbers. The one serialiser of scenario values, used
    by :meth:`Scenario.to_dict` and by the sweep files."""
    if isinstance(v, RobotParameters):
        return v.name if _is_preset(v) else {**v.as_dict(), "name": v.name}
    if isinstance(v, trajectories.Trajectory):
        return plain_value(v.to_spec())
    if isinstance(v, (NoiseSpec, Limits)):
        return v.as_dict()
    if isinstance(v, (np.floating, np.integer, np.bool_)):
        return v.item()
    if isinstance(v, np.ndarray):
        v = v.tolist()
    if isinstance(v, (tuple, list)):
        return [plain_value(x) for x in v]
    if isinstance(v, dict):
        return {str(k): plain_value(x) for k, x in v.items()}
    return v


def _log_series(value) -> tuple:
    """``log_series`` validated: the optional series named, in the order of
    :data:`OPTIONAL_SERIES` (a list, or a string of names separated by commas; the
    series that are always logged may be named too)."""
    if isinstance(value, str):
        value = tuple(v.strip() for v in value.split(",") if v.strip())
    elif isinstance(value, np.ndarray) and value.ndim == 1:
        value = value.tolist()
    if not isinstance(value, (tuple, list)) or not all(isinstance(v, str) for v in value):
        raise ValidationError(f"log_series must be a list of series names (any of "
                              f"{', '.join(OPTIONAL_SERIES)}), got {value!r}")
    unknown = [v for v in value if v not in OPTIONAL_SERIES + ALWAYS_LOGGED]
    if unknown:
        raise ValidationError(f"log_series: unknown series {unknown[0]!r}"
                              f"{did_you_mean(unknown[0], OPTIONAL_SERIES + ALWAYS_LOGGED)}; allowed: "
                              f"{', '.join(OPTIONAL_SERIES)} ({', '.join(ALWAYS_LOGGED)} "
                              f"are always logged)")
    return tuple(k for k in OPTIONAL_SERIES if k in value)


def _check_fields(data):
    bad = [k for k in data if not isinstance(k, str)]
    if bad:
        raise ValidationError(f"scenario field names must be strings, got {bad[0]!r}")
    known = {f.name for f in dataclasses.fields(Scenario)}
    unknown = sorted(set(data) - known)
    if unknown:
        raise ValidationError(f"unknown scenario field {unknown[0]!r}"
                              f"{did_you_mean(unknown[0], known)}; "
                              f"known fields: {', '.join(sorted(known))}")


def _build(what, cls, data):
    string_keys(what, data)
    known = {f.name for f in dataclasses.fields(cls)}
    unknown = sorted(set(data) - known)
    if unknown:
        raise ValidationError(f"unknown {what}.{unknown[0]}{did_you_mean(unknown[0], known)}; "
                              f"allowed: {', '.join(sorted(known))}")
    return cls(**data)


class _Shown:
    """A default value as the signature shows it."""

    def __init__(self, text):
        self.text = text

    def __repr__(self):
        return self.text


def _signature(*first):
    """``Scenario(case='adaptive', ..., gamma=PAPER_GAMMA, noise=PAPER_NOISE, ...)``: the
    fields with their defaults, a long default by the name it has in this module (the
    dataclass's own signature, with the annotations and every default written out, is
    about 1,000 characters); ``first``: positional parameters before them (``self``)."""
    import inspect
    params = [inspect.Parameter(n, inspect.Parameter.POSITIONAL_ONLY) for n in first]
    for f in dataclasses.fields(Scenario):
        value = f.default if f.default is not dataclasses.MISSING else f.default_factory()
        text = repr(value)
        if len(text) > 20:
            text = next((n for n, v in globals().items() if v is value and n.isupper()),
                        f"{type(value).__name__}()")
        params.append(inspect.Parameter(f.name, inspect.Parameter.POSITIONAL_OR_KEYWORD,
                                        default=_Shown(text)))
    return inspect.Signature(params)


Scenario.__signature__ = _signature()
Scenario.__init__.__signature__ = _signature("self")
