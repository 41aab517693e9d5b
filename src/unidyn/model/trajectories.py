r"""Reference trajectories h_d(t) with analytic first and second derivatives
(the functions of :mod:`unidyn.model.equations`).

Each trajectory is an immutable object with ``position(t)``, ``velocity(t)`` and
``acceleration(t)``; ``t`` may be a scalar or an array, and the result has shape
``t.shape + (2,)``. :func:`from_spec` builds one from a plain dict (as read
from a TOML scenario file): data only, nothing is evaluated.

:data:`KINDS` is the table of the kinds: one class each, which holds the kind's name
(``type`` in a file), its code and numbers in the batch engine's parameter table
(:meth:`Trajectory.table`) and the function of :mod:`unidyn.model.equations` both
evaluate. The engines, scenario and ``.bd`` files and the blocks read the kinds from it.
A new kind is its class here, in :data:`KINDS`; its function, its code and its line in
:func:`~unidyn.model.equations.reference_components`; and its block in
:mod:`unidyn.blocks.sources` (bdsim finds blocks by reading their classes' source).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field
from fractions import Fraction
from typing import Callable

import numpy as np

from .._validate import ValidationError, did_you_mean, positive, real, string_keys, vector
from . import equations as eq
from .schedules import step_rows

__all__ = ["Trajectory", "FigureEight", "Circle", "Line", "Point", "FunctionTrajectory", "from_spec",
           "KINDS"]


class Trajectory:
    """Base class: a planar reference h_d(t) for the point of interest."""

    kind = "trajectory"
    #: its code in the batch engine's parameter table (entry ``trajectory``): a constant of
    #: :mod:`unidyn.model.equations` naming the function the compiled engine evaluates;
    #: :data:`~unidyn.model.equations.PYTHON`: none, the engine calls :meth:`evaluate`
    code = eq.PYTHON
    #: its period, s, or None (not periodic)
    period = None

    def position(self, t):  # pragma: no cover - abstract
        raise NotImplementedError

    def velocity(self, t):  # pragma: no cover - abstract
        raise NotImplementedError

    def acceleration(self, t):  # pragma: no cover - abstract
        raise NotImplementedError

    def __call__(self, t):
        """(h_d, h_d_dot) at time t."""
        return self.position(t), self.velocity(t)

    def evaluate(self, t):
        """(h_d, h_d_dot, h_d_ddot) at time t: position, velocity and acceleration."""
        return self.position(t), self.velocity(t), self.acceleration(t)

    def to_spec(self) -> dict:
        """A plain dict that :func:`from_spec` turns back into this trajectory."""
        return {"type": self.kind, **asdict(self)}

    def table(self) -> dict:
        """Its entries in the batch engine's parameter table, by name
        (:data:`unidyn.model.equations.LOOP_PARAMETERS`): the code; for a compiled kind
        its numbers (``path1``, ...: :meth:`arguments`) and the times it steps at
        (``step_time1``, ...), where the engine ends a step."""
        return {"trajectory": self.code}


def _t(t):
    """t as a float (arithmetic on a float is faster than on a 0-d array, and the
    blocks call this once per solver stage), else an array."""
    return t if isinstance(t, float) else np.asarray(t, dtype=float)


def _xy(x, y):
    """Stack two arrays of equal shape into shape + (2,) (faster than np.stack)."""
    if np.ndim(x) == 0 and np.ndim(y) == 0:
        return np.array([x, y], dtype=float)
    out = np.empty(np.broadcast_shapes(np.shape(x), np.shape(y)) + (2,))
    out[..., 0] = x
    out[..., 1] = y
    return out


class _FromEquations(Trajectory):
    """A trajectory given by one function of :mod:`unidyn.model.equations`, which
    ``_eval(t)`` calls: its six values (x, y, x', y', x'', y'') are the position, velocity and
    acceleration. The compiled engine calls the same function, by the class's
    :attr:`~Trajectory.code`, with the numbers :meth:`arguments` gives."""

    def _eval(self, t):  # pragma: no cover - abstract
        raise NotImplementedError

    def arguments(self) -> tuple:  # pragma: no cover - abstract
        """The numbers its function takes after t, in order (at most six)."""
        raise NotImplementedError

    def table(self) -> dict:
        entries = {"trajectory": self.code}
        entries.update((f"path{j + 1}", float(v)) for j, v in enumerate(self.arguments()))
        return entries

    def position(self, t):
        return _xy(*self._eval(t)[0:2])

    def velocity(self, t):
        return _xy(*self._eval(t)[2:4])

    def acceleration(self, t):
        return _xy(*self._eval(t)[4:6])

    def evaluate(self, t):
        x, y, dx, dy, ddx, ddy = self._eval(t)
        return _xy(x, y), _xy(dx, dy), _xy(ddx, ddy)


@dataclass(frozen=True)
class FigureEight(_FromEquations):
    r"""The paper's figure eight (Section 5), starting at the origin:

    .. math:: x_d = A_x\sin(\omega_x t),\quad y_d = A_y(\cos(\omega_y t) - 1)

    Defaults: A_x = A_y = 1 m, omega_x = 0.5 rad/s, omega_y = 0.25 rad/s (period 8 pi s).

    :param ax: x amplitude, m, > 0
    :param ay: y amplitude, m, > 0
    :param wx: x angular frequency, rad/s, > 0
    :param wy: y angular frequency, rad/s, > 0
    :param center: [x, y] added to the path, m
    """

    kind = "figure_eight"
    code = eq.FIGURE_EIGHT
    ax: float = 1.0
    ay: float = 1.0
    wx: float = 0.5
    wy: float = 0.25
    center: tuple = (0.0, 0.0)

    def __post_init__(self):
        for k in ("ax", "ay", "wx", "wy"):
            object.__setattr__(self, k, positive(k, getattr(self, k)))
        object.__setattr__(self, "center", tuple(vector("center", self.center, 2).tolist()))

    def arguments(self) -> tuple:
        return (self.ax, self.ay, self.wx, self.wy, *self.center)

    def _eval(self, t):
        return eq.figure_eight(_t(t), *self.arguments())

    @property
    def period(self):
        """2 pi q / omega_y where omega_x / omega_y = p / q (q at most 24), else None."""
        ratio = Fraction(self.wx / self.wy).limit_denominator(24)
        if abs(float(ratio) - self.wx / self.wy) > 1e-9:
            return None
        return 2 * math.pi * ratio.denominator / self.wy


@dataclass(frozen=True)
class Circle(_FromEquations):
    r"""A circle travelled at constant angular rate:

    .. math:: h_d = c + R(t)\,[\cos(\omega t + \phi), \sin(\omega t + \phi)]

    The radius is a number, or a schedule whose radius steps (the circle of the authors'
    MATLAB package): rows ``[t, R]``, from time t (s) on the radius is R (m), the first
    row at t = 0. That package's circle, 1 m, 0.1 m smaller from 60 s to 120 s and
    from 180 s to 240 s, at 0.1 rad/s, is::

        Circle(radius=[(0, 1.0), (60, 0.9), (120, 1.0), (180, 0.9), (240, 1.0)], omega=0.1)

    At a step the position jumps radially by the change of radius. The velocity and
    acceleration are those of the circle of the current radius, :math:`R\omega` and
    :math:`R\omega^2` in size, as that package computes them: the jump has no impulse
    in :math:`\dot h_d`, which is therefore not the derivative of :math:`h_d` at a step.
    From :math:`t_k` on (:math:`t \ge t_k`) the new radius holds.

    :param radius: R, m, > 0; or the schedule, a list of ``[t, R]`` rows with t in s
        (0 first, then increasing; at most :data:`~unidyn.model.equations.RADIUS_STEPS`
        steps after 0) and R > 0 in m. A one-row schedule is the number R.
    :param omega: angular rate, rad/s (negative: clockwise), nonzero
    :param center: c, m
    :param phase: phi, rad
    """

    kind = "circle"
    code = eq.CIRCLE
    radius: float | tuple = 1.0
    omega: float = 0.2
    center: tuple = (0.0, 0.0)
    phase: float = 0.0

    def __post_init__(self):
        schedule = _radius_schedule(self.radius)
        object.__setattr__(self, "radius", schedule if len(schedule) > 1 else schedule[0][1])
        om = real("omega", self.omega)
        if om == 0:
            raise ValidationError("omega must be nonzero, got 0.0")
        object.__setattr__(self, "omega", om)
        object.__setattr__(self, "phase", real("phase", self.phase))
        object.__setattr__(self, "center", tuple(vector("center", self.center, 2).tolist()))

    @property
    def radius_schedule(self) -> tuple:
        """The radius as ``((0.0, R_0), (t_1, R_1), ...)``: from t_k (s) on, R_k (m);
        a constant radius is the one row ``((0.0, R),)``."""
        return self.radius if isinstance(self.radius, tuple) else ((0.0, self.radius),)

    def radius_at(self, t):
        """The radius at time t (s), m (a float, or an array of t's shape)."""
        return eq.stepped_radius(_t(t), self.radius_schedule[0][1], self._steps)

    @property
    def _steps(self) -> tuple:
        """The steps as :func:`unidyn.model.equations.stepped_radius` takes them."""
        return tuple(v for row in self.radius_schedule[1:] for v in row)

    def arguments(self) -> tuple:
        """The radius at t = 0 (the engine steps it: :meth:`table`), then the others."""
        return (self.radius_schedule[0][1], self.omega, *self.center, self.phase)

    def _eval(self, t):
        t = _t(t)
        return eq.circle(t, self.radius_at(t), self.omega, *self.center, self.phase)

    def table(self) -> dict:
        entries = super().table()
        (_, radius), *steps = self.radius_schedule
        steps += [(math.inf, radius)] * (eq.RADIUS_STEPS - len(steps))
        for j, (t_step, r_step) in enumerate(steps):
            entries[f"step_time{j + 1}"], entries[f"step_radius{j + 1}"] = t_step, r_step
        return entries

    @property
    def period(self):
        """2 pi / abs(omega), s, for a radius that does not step, else None."""
        return 2 * math.pi / abs(self.omega) if len(self.radius_schedule) == 1 else None


def _radius_schedule(value) -> tuple:
    """A circle's radius (a number > 0, or rows [t, R]) as the rows ((0.0, R_0), ...)."""
    what = ("radius must be a number > 0 (m) or a schedule of [t, R] rows (t in s from 0 "
            "on, increasing; R > 0 in m)")
    if isinstance(value, (str, bytes, dict, type(None))):
        raise ValidationError(f"{what}, got {value!r:.120}")
    if isinstance(value, np.ndarray):
        value = value.tolist()  # a 0-d array: its number
    if not isinstance(value, (list, tuple)):
        return ((0.0, positive("radius", value)),)
    if not value:
        raise ValidationError(f"{what}, got {value!r:.120}")
    if len(value) > eq.RADIUS_STEPS + 1:
        raise ValidationError(f"radius: a schedule has at most {eq.RADIUS_STEPS} steps after "
                              f"its row at t = 0, got {len(value) - 1}")
    rows = step_rows("radius", value, what, "R")
    if rows[0][0] != 0.0:
        raise ValidationError(f"radius: a schedule starts with the radius at t = 0, "
                              f"[0, R]; its first row has t = {rows[0][0]:g}")
    return rows


@dataclass(frozen=True)
class Line(_FromEquations):
    r"""A straight line at constant velocity: :math:`h_d = p_0 + v t`.

    :param start: p_0, m
    :param velocity: v, m/s
    """

    kind = "line"
    code = eq.LINE
    start: tuple = (0.0, 0.0)
    velocity_: tuple = field(default=(0.2, 0.0), metadata={"name": "velocity"})

    def __init__(self, start=(0.0, 0.0), velocity=(0.2, 0.0)):
        object.__setattr__(self, "start", tuple(vector("start", start, 2).tolist()))
        object.__setattr__(self, "velocity_", tuple(vector("velocity", velocity, 2).tolist()))

    def arguments(self) -> tuple:
        return (*self.start, *self.velocity_)

    def _eval(self, t):
        return eq.line(_t(t), *self.arguments())

    def to_spec(self) -> dict:
        return {"type": self.kind, "start": list(self.start), "velocity": list(self.velocity_)}


class Point(Line):
    r"""A fixed goal point (the positioning task of the authors' MATLAB package):
    :math:`h_d = (x, y)`, at rest. Eq. (10) then reads
    :math:`v_d = A^{-1}(\psi)\,L \tanh(K \tilde h / L)`: h goes to the point.
    The engines evaluate it as a :class:`Line` with zero velocity.

    :param x: the point's x, m
    :param y: the point's y, m
    """

    kind = "point"

    def __init__(self, x: float = 1.0, y: float = 1.0):
        super().__init__(start=(real("x", x), real("y", y)), velocity=(0.0, 0.0))

    @property
    def x(self) -> float:
        return self.start[0]

    @property
    def y(self) -> float:
        return self.start[1]

    def __repr__(self) -> str:
        return f"Point(x={self.x!r}, y={self.y!r})"

    def to_spec(self) -> dict:
        return {"type": self.kind, "x": self.x, "y": self.y}


@dataclass(frozen=True)
class Segment(_FromEquations):
    r"""A straight segment travelled at constant speed, then its end held: the robot is
    sent from :math:`p_0` to :math:`p_1` at speed v and stops there.

    .. math:: h_d = p_0 + (p_1 - p_0)\,\min(t / t_a, 1), \quad t_a = |p_1 - p_0| / v

    At the arrival :math:`t_a` the desired velocity :math:`\dot h_d` jumps from
    :math:`v (p_1 - p_0) / |p_1 - p_0|` to 0, and with it the feedforward of Eq. (10);
    :math:`\ddot h_d` (the exact rate of Eq. 10, which Eq. 12 compensates with) is 0 on
    both sides: the jump has no impulse. The reference is not smoothed: the batch engine
    ends a step at :math:`t_a`, as at a circle's radius step, so that each of its steps
    integrates a smooth right-hand side; bdsim's solver integrates across it under its
    error control.

    :param start: p_0, m
    :param end: p_1, m, not p_0 (a goal at rest from the start is a :class:`Point`)
    :param speed: v, m/s, > 0
    """

    kind = "segment"
    code = eq.SEGMENT
    start: tuple = (0.0, 0.0)
    end: tuple = (1.0, 0.0)
    speed: float = 0.2

    def __post_init__(self):
        object.__setattr__(self, "start", tuple(vector("start", self.start, 2).tolist()))
        object.__setattr__(self, "end", tuple(vector("end", self.end, 2).tolist()))
        object.__setattr__(self, "speed", positive("speed", self.speed))
        if self.start == self.end:
            raise ValidationError(f"end must differ from start, both {list(self.start)}; a "
                                  f"goal at rest from the start is a trajectory of type 'point'")

    @property
    def duration(self) -> float:
        """t_a, the time of the arrival at the end, s."""
        return math.hypot(self.end[0] - self.start[0], self.end[1] - self.start[1]) / self.speed

    def arguments(self) -> tuple:
        return (*self.start, *self.end, self.duration)

    def _eval(self, t):
        t = _t(t)
        return eq.segment(t, t, *self.arguments())

    def table(self) -> dict:
        return {**super().table(), "step_time1": self.duration}  # a step ends at the arrival


class FunctionTrajectory(Trajectory):
    r"""Wraps a user callable ``f(t) -> (h_d, h_d_dot)`` (scalar t).

    :param f: the callable; it must return two 2-vectors
    :param acceleration: optional callable ``t -> h_d_ddot``; without it the
        second derivative is a central difference of ``h_d_dot`` with step ``dt``
    :param dt: step of that difference, s, > 0
    """

    kind = "function"

    def __init__(self, f: Callable, acceleration: Callable | None = None, dt: float = 1e-4):
        if not callable(f):
            raise ValidationError(f"f must be callable t -> (h_d, h_d_dot), got {f!r}")
        if acceleration is not None and not callable(acceleration):
            raise ValidationError(f"acceleration must be callable or None, got {acceleration!r}")
        self.f = f
        self._acc = acceleration
        self.dt = positive("dt", dt)
        try:
            p, v = f(0.0)
            vector("f(0)[0] (h_d)", p, 2)
            vector("f(0)[1] (h_d_dot)", v, 2)
        except ValidationError:
            raise
        except Exception as err:
            raise ValidationError(f"f(0.0) must return (h_d, h_d_dot), two 2-vectors: {err}") from None

    def _map(self, t, fn):
        t = np.asarray(t, dtype=float)
        flat = [np.asarray(fn(float(ti)), dtype=float) for ti in t.reshape(-1)]
        return np.array(flat).reshape(t.shape + (2,))

    def position(self, t):
        return self._map(t, lambda s: self.f(s)[0])

    def velocity(self, t):
        return self._map(t, lambda s: self.f(s)[1])

    def acceleration(self, t):
        if self._acc is not None:
            return self._map(t, self._acc)
        h = self.dt
        return (self.velocity(_t(t) + h) - self.velocity(_t(t) - h)) / (2 * h)

    def to_spec(self) -> dict:
        """A record of the wrapped callable (for summaries); :func:`from_spec` refuses
        to rebuild it, since a file cannot hold the code."""
        name = getattr(self.f, "__qualname__", None) or repr(self.f)
        return {"type": "function", "callable": f"{getattr(self.f, '__module__', '?')}.{name}"}


def _table_of_kinds(*classes) -> dict:
    """{kind: class}; a name taken twice, or a code shared but by a kind and its base
    (a point is evaluated as a line), is an error here, at import."""
    kinds = {}
    for cls in classes:
        if cls.kind in kinds:
            raise TypeError(f"two trajectory kinds are named {cls.kind!r}")
        for other in kinds.values():
            if cls.code == other.code and not issubclass(cls, other):
                raise TypeError(f"trajectory kinds {other.kind!r} and {cls.kind!r} share "
                                f"the code {cls.code}")
        kinds[cls.kind] = cls
    return kinds


#: The kinds a scenario file names by ``type``, each evaluated compiled by the batch engine.
KINDS = _table_of_kinds(FigureEight, Circle, Line, Point, Segment)


def from_spec(spec) -> Trajectory:
    """A trajectory from a :class:`Trajectory`, a kind name, or a dict with ``type``.

    ``{"type": "circle", "radius": 2.0}`` -> ``Circle(radius=2.0)``. Unknown
    types or keys raise :class:`~unidyn.ValidationError`.
    """
    if isinstance(spec, Trajectory):
        return spec
    if isinstance(spec, str):
        spec = {"type": spec}
    if not isinstance(spec, dict):
        raise ValidationError(f"trajectory must be a dict with 'type' ({', '.join(KINDS)}), "
                              f"a name or a Trajectory; got {spec!r}")
    spec = dict(string_keys("trajectory", spec))
    kind = spec.pop("type", None)
    if not isinstance(kind, str):
        raise ValidationError(f"trajectory type must be one of {', '.join(KINDS)}; got {kind!r}"
                              f"{did_you_mean(kind, KINDS)}")
    if kind == "function":
        raise ValidationError("trajectory of type 'function' wraps Python code and cannot be "
                              f"rebuilt from a file; use one of {', '.join(KINDS)}, or pass a "
                              "FunctionTrajectory from Python")
    if kind not in KINDS:
        raise ValidationError(f"trajectory type must be one of {', '.join(KINDS)}; got {kind!r}"
                              f"{did_you_mean(kind, KINDS)}")
    cls = KINDS[kind]
    import inspect
    allowed = [p for p in inspect.signature(cls).parameters]
    unknown = sorted(set(spec) - set(allowed))
    if unknown:
        raise ValidationError(f"unknown trajectory.{unknown[0]} for type {kind!r}"
                              f"{did_you_mean(unknown[0], allowed)}; "
                              f"allowed keys: {', '.join(allowed)}")
    try:
        return cls(**spec)
    except ValidationError as err:
        raise ValidationError(f"trajectory: {err}") from None
