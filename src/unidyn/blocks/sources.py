"""Source blocks: reference trajectories with analytic derivatives, and held measurement noise."""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np
from bdsim.components import Clock, SampledBlock, SourceBlock

from unidyn._validate import ValidationError, integer, nonnegative, positive, vector
from unidyn.model import trajectories as traj

from .arguments import check_blockargs, check_clock, check_fixed_blockargs, records_arguments


class TrajectorySource(SourceBlock):
    r"""
    :blockname:`TRAJECTORYSOURCE`

    Reference trajectory from any ``unidyn.model.trajectories.Trajectory`` or user callable.

    :inputs: 0
    :outputs: 3
    :states: 0

    .. list-table::
        :header-rows: 1

        *   - Port type
            - Port number
            - Types
            - Description
        *   - Output
            - 0
            - ndarray(2)
            - :math:`h_d`, desired position, m (label ``h_d``)
        *   - Output
            - 1
            - ndarray(2)
            - :math:`\dot h_d`, desired velocity, m/s (label ``h_d_dot``)
        *   - Output
            - 2
            - ndarray(2)
            - :math:`\ddot h_d`, desired acceleration, m/s² (label ``h_d_ddot``)

    A callable ``f(t) -> (h_d, h_d_dot)`` is wrapped in
    :class:`unidyn.model.trajectories.FunctionTrajectory`; its second derivative is
    then a central difference unless ``acceleration`` is given.

    .. math:: (h_d(t), \dot h_d(t), \ddot h_d(t))
    """

    nin = 0
    nout = 3
    outlabels = ("h_d", "h_d_dot", "h_d_ddot")

    @records_arguments
    def __init__(self, trajectory: traj.Trajectory | dict | Callable,
                 acceleration: Callable | None = None, **blockargs):
        r"""
        :param trajectory: a Trajectory, a trajectory spec dict, or a callable t -> (h_d, h_d_dot)
        :type trajectory: Trajectory, dict or callable
        :param acceleration: for a callable, optional t -> h_d_ddot
        :type acceleration: callable, optional
        :param blockargs: common block options
        :type blockargs: dict
        """
        if callable(trajectory) and not isinstance(trajectory, traj.Trajectory):
            self.trajectory = traj.FunctionTrajectory(trajectory, acceleration)
        else:
            if acceleration is not None:
                raise ValidationError("acceleration is only for a callable trajectory; a "
                                      f"{type(trajectory).__name__} has its own derivatives")
            self.trajectory = traj.from_spec(trajectory)
        check_blockargs(self, blockargs)
        super().__init__(**blockargs)
        self.type = "trajectorysource"

    def output(self, t, inports, x):
        return list(self.trajectory.evaluate(t))


class FigureEight(TrajectorySource):
    r"""
    :blockname:`FIGUREEIGHT`

    The paper's figure-eight reference (Section 5).

    :inputs: 0
    :outputs: 3
    :states: 0

    .. list-table::
        :header-rows: 1

        *   - Port type
            - Port number
            - Types
            - Description
        *   - Output
            - 0
            - ndarray(2)
            - :math:`h_d`, desired position, m (label ``h_d``)
        *   - Output
            - 1
            - ndarray(2)
            - :math:`\dot h_d`, desired velocity, m/s (label ``h_d_dot``)
        *   - Output
            - 2
            - ndarray(2)
            - :math:`\ddot h_d`, desired acceleration, m/s² (label ``h_d_ddot``)

    .. math:: x_d = A_x\sin(\omega_x t), \quad y_d = A_y(\cos(\omega_y t) - 1)

    Defaults are the paper's: A_x = A_y = 1 m, omega_x = 0.5, omega_y = 0.25 rad/s.
    """

    #: the trajectory it produces, whose parameters are the block's
    trajectory_class = traj.FigureEight
    nin = 0
    nout = 3
    outlabels = ("h_d", "h_d_dot", "h_d_ddot")

    @records_arguments
    def __init__(self, ax: float = 1.0, ay: float = 1.0, wx: float = 0.5, wy: float = 0.25,
                 center: Sequence[float] = (0.0, 0.0), **blockargs):
        r"""
        :param ax: x amplitude, m, > 0
        :type ax: float
        :param ay: y amplitude, m, > 0
        :type ay: float
        :param wx: x angular frequency, rad/s, > 0
        :type wx: float
        :param wy: y angular frequency, rad/s, > 0
        :type wy: float
        :param center: offset of the whole path, m
        :type center: array_like(2)
        :param blockargs: common block options
        :type blockargs: dict
        """
        check_blockargs(self, blockargs)
        super().__init__(traj.FigureEight(ax, ay, wx, wy, _pair("center", center)), **blockargs)
        self.type = "figureeight"


class Circle(TrajectorySource):
    r"""
    :blockname:`CIRCLE`

    A circular reference at constant angular rate, whose radius may step (the circle of
    the authors' MATLAB package): ``radius=[(0, 1.0), (60, 0.9), (120, 1.0)]`` is 1 m,
    0.9 m from 60 s on, 1 m again from 120 s on.

    :inputs: 0
    :outputs: 3
    :states: 0

    .. list-table::
        :header-rows: 1

        *   - Port type
            - Port number
            - Types
            - Description
        *   - Output
            - 0
            - ndarray(2)
            - :math:`h_d`, desired position, m (label ``h_d``)
        *   - Output
            - 1
            - ndarray(2)
            - :math:`\dot h_d`, desired velocity, m/s (label ``h_d_dot``)
        *   - Output
            - 2
            - ndarray(2)
            - :math:`\ddot h_d`, desired acceleration, m/s² (label ``h_d_ddot``)

    .. math:: h_d = c + R(t)\,(\cos(\omega t + \phi), \sin(\omega t + \phi))

    At a step, :math:`h_d` jumps radially by the change of radius, while
    :math:`\dot h_d` and :math:`\ddot h_d` are those of the circle of the current
    radius (no impulse), as in the MATLAB package; see
    :class:`unidyn.model.trajectories.Circle`.
    """

    #: the trajectory it produces, whose parameters are the block's
    trajectory_class = traj.Circle
    nin = 0
    nout = 3
    outlabels = ("h_d", "h_d_dot", "h_d_ddot")

    @records_arguments
    def __init__(self, radius: float | Sequence[Sequence[float]] = 1.0, omega: float = 0.2,
                 center: Sequence[float] = (0.0, 0.0), phase: float = 0.0, **blockargs):
        r"""
        :param radius: R, m, > 0; or a schedule, rows [t, R]: from t (s) on the radius is R (m), the first row at t = 0, times increasing, at most 8 steps after it
        :type radius: float or list of [t, R]
        :param omega: angular rate, rad/s, nonzero (negative: clockwise)
        :type omega: float
        :param center: c, m
        :type center: array_like(2)
        :param phase: phi, rad
        :type phase: float
        :param blockargs: common block options
        :type blockargs: dict
        """
        check_blockargs(self, blockargs)
        super().__init__(traj.Circle(radius, omega, _pair("center", center), phase), **blockargs)
        self.type = "circle"


class Line(TrajectorySource):
    r"""
    :blockname:`LINE`

    A straight-line reference at constant velocity.

    :inputs: 0
    :outputs: 3
    :states: 0

    .. list-table::
        :header-rows: 1

        *   - Port type
            - Port number
            - Types
            - Description
        *   - Output
            - 0
            - ndarray(2)
            - :math:`h_d`, desired position, m (label ``h_d``)
        *   - Output
            - 1
            - ndarray(2)
            - :math:`\dot h_d`, desired velocity, m/s (label ``h_d_dot``)
        *   - Output
            - 2
            - ndarray(2)
            - :math:`\ddot h_d = 0` (label ``h_d_ddot``)

    .. math:: h_d = p_0 + v\,t
    """

    #: the trajectory it produces, whose parameters are the block's
    trajectory_class = traj.Line
    nin = 0
    nout = 3
    outlabels = ("h_d", "h_d_dot", "h_d_ddot")

    @records_arguments
    def __init__(self, start: Sequence[float] = (0.0, 0.0),
                 velocity: Sequence[float] = (0.2, 0.0), **blockargs):
        r"""
        :param start: p_0, m
        :type start: array_like(2)
        :param velocity: v, m/s
        :type velocity: array_like(2)
        :param blockargs: common block options
        :type blockargs: dict
        """
        check_blockargs(self, blockargs)
        super().__init__(traj.Line(start, velocity), **blockargs)
        self.type = "line"


class Point(TrajectorySource):
    r"""
    :blockname:`POINT`

    A fixed goal point, at rest (the positioning task of the authors' MATLAB package):
    with it, the kinematic controller (Eq. 10) drives h to the point.

    :inputs: 0
    :outputs: 3
    :states: 0

    .. list-table::
        :header-rows: 1

        *   - Port type
            - Port number
            - Types
            - Description
        *   - Output
            - 0
            - ndarray(2)
            - :math:`h_d = (x, y)`, the goal, m (label ``h_d``)
        *   - Output
            - 1
            - ndarray(2)
            - :math:`\dot h_d = 0` (label ``h_d_dot``)
        *   - Output
            - 2
            - ndarray(2)
            - :math:`\ddot h_d = 0` (label ``h_d_ddot``)
    """

    #: the trajectory it produces, whose parameters are the block's
    trajectory_class = traj.Point
    nin = 0
    nout = 3
    outlabels = ("h_d", "h_d_dot", "h_d_ddot")

    @records_arguments
    def __init__(self, x: float = 1.0, y: float = 1.0, **blockargs):
        r"""
        :param x: the goal's x, m
        :type x: float
        :param y: the goal's y, m
        :type y: float
        :param blockargs: common block options
        :type blockargs: dict
        """
        check_blockargs(self, blockargs)
        super().__init__(traj.Point(x, y), **blockargs)
        self.type = "point"


class Segment(TrajectorySource):
    r"""
    :blockname:`SEGMENT`

    A straight segment from ``start`` to ``end`` at constant ``speed``, then the end held:
    the robot is sent to a point along a straight path and stops there.

    :inputs: 0
    :outputs: 3
    :states: 0

    .. list-table::
        :header-rows: 1

        *   - Port type
            - Port number
            - Types
            - Description
        *   - Output
            - 0
            - ndarray(2)
            - :math:`h_d`, desired position, m (label ``h_d``)
        *   - Output
            - 1
            - ndarray(2)
            - :math:`\dot h_d`, desired velocity, m/s; 0 from the arrival on (label ``h_d_dot``)
        *   - Output
            - 2
            - ndarray(2)
            - :math:`\ddot h_d = 0` (label ``h_d_ddot``)

    .. math:: h_d = p_0 + (p_1 - p_0)\,\min(t / t_a, 1), \quad t_a = |p_1 - p_0| / v

    At the arrival :math:`t_a` the desired velocity jumps to 0 (no impulse in
    :math:`\ddot h_d`); see :class:`unidyn.model.trajectories.Segment`.
    """

    #: the trajectory it produces, whose parameters are the block's
    trajectory_class = traj.Segment
    nin = 0
    nout = 3
    outlabels = ("h_d", "h_d_dot", "h_d_ddot")

    @records_arguments
    def __init__(self, start: Sequence[float] = (0.0, 0.0), end: Sequence[float] = (1.0, 0.0),
                 speed: float = 0.2, **blockargs):
        r"""
        :param start: p_0, m
        :type start: array_like(2)
        :param end: p_1, m, not p_0
        :type end: array_like(2)
        :param speed: v, m/s, > 0
        :type speed: float
        :param blockargs: common block options
        :type blockargs: dict
        """
        check_blockargs(self, blockargs)
        super().__init__(traj.Segment(start, end, speed), **blockargs)
        self.type = "segment"


def trajectory_block(trajectory: traj.Trajectory | dict | Callable, **blockargs) -> TrajectorySource:
    """The source block of a reference: the block of its kind (:class:`FigureEight`,
    :class:`Circle`, :class:`Line`, :class:`Point`, :class:`Segment`: its
    ``trajectory_class``) with the trajectory's own parameters (a ``.bd`` file then holds
    them as numbers bdedit shows), else a :class:`TrajectorySource` of it.

    :param trajectory: a Trajectory, a trajectory spec dict, or a callable t -> (h_d, h_d_dot)
    :param blockargs: common block options (``bd``, ``name``, ...)
    """
    if isinstance(trajectory, (traj.Trajectory, dict, str)):
        trajectory = traj.from_spec(trajectory)
        for cls in TrajectorySource.__subclasses__():
            if type(trajectory) is getattr(cls, "trajectory_class", None):
                spec = trajectory.to_spec()
                del spec["type"]
                return cls(**spec, **blockargs)
    return TrajectorySource(trajectory, **blockargs)


def _pair(name, value):
    return tuple(vector(name, value, 2).tolist())


class MeasurementNoise(SampledBlock):
    r"""
    :blockname:`MEASUREMENTNOISE`

    Adds seeded white noise, held over each clock period, to chosen components of a signal.

    :inputs: 1
    :outputs: 1
    :states: len(indices) (discrete)

    .. list-table::
        :header-rows: 1

        *   - Port type
            - Port number
            - Types
            - Description
        *   - Input
            - 0
            - ndarray(n)
            - :math:`s`, the true signal (label ``s``)
        *   - Output
            - 0
            - ndarray(n)
            - :math:`s + \eta`, the measured signal (label ``s_meas``)

    The noise :math:`\eta` on the components ``indices`` is
    ``std * rng.standard_normal(len(indices))``, a new draw at every tick of the
    clock and held in between (the paper's noise, Section 5); other
    components pass unchanged (the paper feeds psi back clean). The k-th held
    value is the k-th draw of ``numpy.random.default_rng(seed)``, so a run is
    reproducible from its seed.

    .. math:: s_{meas}(t) = s(t) + \eta_k, \quad t_k \le t < t_{k+1}
    """

    nin = 1
    nout = 1
    inlabels = ("s",)
    outlabels = ("s_meas",)

    @records_arguments
    def __init__(self, clock: Clock, std: float = 0.01,
                 seed: int | np.random.SeedSequence = 0, indices: Sequence[int] = (0, 1),
                 **blockargs):
        r"""
        :param clock: the sampling clock (name it)
        :type clock: bdsim Clock
        :param std: standard deviation, in the signal's unit, >= 0
        :type std: float
        :param seed: seed of the generator (int >= 0 or numpy SeedSequence)
        :type seed: int or SeedSequence
        :param indices: components of the input that get noise, defaults to (0, 1)
        :type indices: sequence of int
        :param blockargs: common block options
        :type blockargs: dict
        """
        self.std = nonnegative("std", std)
        if isinstance(seed, bool) or not (isinstance(seed, (int, np.integer)) and seed >= 0
                                          or isinstance(seed, np.random.SeedSequence)):
            raise ValidationError(f"seed must be an integer >= 0 or a SeedSequence, got {seed!r}")
        self.seed = seed
        if isinstance(indices, (str, bytes)) or not all(
                isinstance(i, (int, np.integer)) and not isinstance(i, (bool, np.bool_))
                for i in (indices if hasattr(indices, "__iter__") else [None])):
            raise ValidationError(f"indices must be a sequence of integers, got {indices!r}")
        idx = [int(i) for i in indices]
        if not idx or min(idx) < 0 or len(set(idx)) != len(idx):
            raise ValidationError(f"indices must be distinct integers >= 0, got {indices!r}")
        self.indices = np.array(idx)
        self._rng = np.random.default_rng(self.seed)
        x0 = self.std * self._rng.standard_normal(len(idx))
        check_blockargs(self, blockargs)
        super().__init__(clock=check_clock(clock, type(self).__name__), x0=x0, feedthrough=True, **blockargs)
        self.type = "measurementnoise"

    def start(self, simstate=None):
        # restart the stream so every run of the diagram sees the same noise
        super().start(simstate)
        self._rng = np.random.default_rng(self.seed)
        self._rng.standard_normal(len(self.indices))  # the first draw is x0

    def output(self, t, inports, x):
        s = np.array(np.asarray(inports[0], dtype=float).reshape(-1))
        if self.indices.max() >= s.shape[0]:
            raise ValidationError(f"block {self.name!r}: indices {self.indices.tolist()} out of "
                                  f"range for an input of {s.shape[0]} elements")
        s[self.indices] += x
        return [s]

    def next(self, t, inports, x):
        return self.std * self._rng.standard_normal(len(self.indices))


class SensorNoise(MeasurementNoise):
    r"""
    :blockname:`SENSORNOISE`

    Seeded white noise held over each sample period, on a clock of the diagram found (or made) by name.

    :inputs: 1
    :outputs: 1
    :states: len(indices) (discrete)

    .. list-table::
        :header-rows: 1

        *   - Port type
            - Port number
            - Types
            - Description
        *   - Input
            - 0
            - ndarray(n)
            - :math:`s`, the true signal (label ``s``)
        *   - Output
            - 0
            - ndarray(n)
            - :math:`s + \eta`, the measured signal (label ``s_meas``)

    :class:`MeasurementNoise` whose clock is given by its period ``Ts`` and its
    name, so that the block can be drawn in bdedit and loaded from a ``.bd`` file
    (which cannot hold a bdsim clock): the first block naming a clock creates it in
    its diagram, later blocks naming it share it (a clock of that name with another
    period is an error). The noise of the paper's Section 5: a new draw
    ``std * rng.standard_normal(len(indices))`` at every tick (the first tick is at
    t = Ts; the first draw is held over [0, Ts)), added to the components
    ``indices``, the others passed unchanged.

    The generator is ``numpy.random.default_rng`` of ``seed``, or with ``stream = k``
    of the k-th stream spawned from ``seed``
    (``numpy.random.SeedSequence(seed, spawn_key=(k,))``): the streams of
    :func:`unidyn.model.noise.noise_seeds`, 0 for the position and 1 for the velocity
    noise of a run with that seed.

    .. math:: s_{meas}(t) = s(t) + \eta_k, \quad t_k \le t < t_{k+1}
    """

    nin = 1
    nout = 1
    inlabels = ("s",)
    outlabels = ("s_meas",)

    @records_arguments
    def __init__(self, Ts: float = 0.1, clock_name: str = "sensor", std: float = 0.01,
                 seed: int | np.random.SeedSequence = 0, stream: int | None = None,
                 indices: Sequence[int] = (0, 1), **blockargs):
        r"""
        :param Ts: sample period of the clock, s, > 0; 0.1 (default)
        :type Ts: float
        :param clock_name: name of the clock, shared by the blocks that name it, defaults to sensor
        :type clock_name: str
        :param std: standard deviation, in the signal's unit, >= 0; 0.01 (default)
        :type std: float
        :param seed: seed of the generator (int >= 0, or a numpy SeedSequence), defaults to 0
        :type seed: int
        :param stream: None to seed the generator with seed, or k >= 0 for the k-th stream spawned from seed, defaults to None
        :type stream: int or None
        :param indices: components of the input that get noise, defaults to (0, 1)
        :type indices: array_like
        :param blockargs: common block options
        :type blockargs: dict
        """
        check_fixed_blockargs(self, blockargs)
        Ts = positive("Ts", Ts)
        if not isinstance(clock_name, str) or not clock_name:
            raise ValidationError(f"SensorNoise: clock_name must be a non-empty string, got {clock_name!r}")
        if stream is not None:
            stream = integer("stream", stream, 0)
            if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
                raise ValidationError(f"SensorNoise: with a stream, seed must be an integer >= 0, got {seed!r}")
            seed = np.random.SeedSequence(int(seed), spawn_key=(stream,))
        self.Ts = Ts
        self.clock_name = clock_name
        self.stream = stream
        bd = blockargs.get("bd")
        if bd is None:
            raise ValidationError("SensorNoise: needs the block diagram to find or make its clock "
                                  "(create it as bd.SENSORNOISE(...), or pass bd=)")
        clock = next((c for c in bd.clocklist if c.name == clock_name), None)
        if clock is None:
            clock = bd.clock(Ts, name=clock_name)
        elif not np.isclose(clock.T, Ts, rtol=1e-12, atol=0.0) or clock.offset != 0:
            raise ValidationError(
                f"SensorNoise: the diagram's clock {clock_name!r} has period {clock.T:g} s "
                f"(offset {clock.offset:g} s), not Ts = {Ts:g} s; name another clock")
        super().__init__(clock, std=std, seed=seed, indices=indices, **blockargs)
