r"""The closed loop of Fig. 2 as one pure right-hand side, batched over scenarios:
:func:`unidyn.model.equations.loop_derivative` on all runs at once with numpy, what
``solve_ivp`` integrates for the converged references the engines are checked against
(:meth:`ClosedLoop.converged`); also the batch engine's parameter table, noise and
initial state. Continuous control only.

The state of a run (13 values): ``x, y, psi, u, w`` (u, w unused for a kinematic robot),
``theta_hat1..6``, ``z_u, z_w`` (the derivative filter's, with ``vd_dot="filter"``). The
noise is held over each interval [k Ts, (k+1) Ts): the k-th draw of the seeded generators
the diagram's noise blocks use.
"""

from __future__ import annotations

import numpy as np

from . import equations, laws
from .equations import LOOP_PARAMETERS, NSTATE, PYTHON, P
from .noise import HeldNoise, noise_seeds
from .parameters import THETA_NAMES
from .scenario import Scenario

__all__ = ["ClosedLoop"]

#: Noise values (rows x runs) drawn per window: 2 x 16 MB however long the run.
NOISE_WINDOW_VALUES = 1_000_000
#: The converged reference's longest step, s: a tenth of the shortest episode of
#: clipping seen at the gains where Fig. 11 ends (about 15 ms of an acceleration limit
#: switching on and off), so that its error control sees every such episode.
MAX_STEP = 1e-3


class ClosedLoop:
    """The Fig. 2 loop for a batch of scenarios sharing ``T`` and ``Ts``.

    :param scenarios: one :class:`~unidyn.Scenario` or a sequence of them
    """

    def __init__(self, scenarios):
        if isinstance(scenarios, Scenario):
            scenarios = [scenarios]
        scs = list(scenarios)
        if not scs:
            raise ValueError("scenarios must not be empty")
        T, Ts = scs[0].T, scs[0].Ts
        for s in scs:
            if not isinstance(s, Scenario):
                raise TypeError(f"expected Scenario, got {type(s).__name__}")
            if s.control != "continuous":
                raise ValueError("ClosedLoop models continuous control only")
            if s.T != T or s.Ts != Ts:
                raise ValueError("all scenarios of a batch must share T and Ts")
        self.scenarios = scs
        self.T, self.Ts = T, Ts
        self.steps = scs[0].steps
        B = self.B = len(scs)
        self.P = self.parameter_table()
        self.vmax = self.P[:, [P.speed_u, P.speed_w]]
        # each distinct trajectory evaluated once (a Python function: by identity)
        keys = [id(s.trajectory) if hasattr(s.trajectory, "f") else repr(s.trajectory)
                for s in scs]
        first = {}
        self.traj_index = np.array([first.setdefault(k, len(first)) for k in keys], dtype=int)
        self.trajectories = [scs[keys.index(k)].trajectory for k in first]
        # a reference that is a Python function: its index among them, for the engine
        python = self.P[:, P.trajectory] == PYTHON
        self.P[python, P.path1] = self.traj_index[python]
        # noise, held per interval, drawn a window of rows at a time (noise_window); a
        # kinematic robot has no velocities to measure
        seeds = [None if s.noise is None else noise_seeds(s.noise.seed) for s in scs]
        self._noise_sources = [(None, None) if q is None else (
            HeldNoise(q[0], s.noise.position_std),
            None if not s.case_spec.dynamic else HeldNoise(q[1], s.noise.velocity_std))
            for s, q in zip(scs, seeds)]
        self.noise_k0 = self.noise_end = 0
        self.pos_noise = self.vel_noise = np.zeros((B, 0, 2))
        self.noise_window(0, NOISE_WINDOW_VALUES // B)

    def noise_window(self, k0: int, rows: int):
        """Draw the held noise of intervals k0 .. k0 + rows - 1 (at most to the last) into
        ``pos_noise``, ``vel_noise`` (B, rows, 2), row 0 interval ``noise_k0`` = k0.
        Windows follow each other, each run's generators going on where they stopped:
        the values of one draw of the whole run (:func:`unidyn.model.noise.held_sequence`)."""
        if k0 != self.noise_end:
            raise ValueError(f"noise windows follow each other: the next starts at interval "
                             f"{self.noise_end}, not {k0}")
        rows = max(1, min(int(rows), self.steps + 1 - k0))
        if self.pos_noise.shape[1] != rows:
            self.pos_noise = np.zeros((self.B, rows, 2))
            self.vel_noise = np.zeros((self.B, rows, 2))
        for i, (pos, vel) in enumerate(self._noise_sources):
            if pos is not None:
                pos.draw(self.pos_noise[i])
            if vel is not None:
                vel.draw(self.vel_noise[i])
        self.noise_k0, self.noise_end = k0, k0 + rows

    def next_noise_window(self, k: int):
        """At interval k = the end of the current window, draw the next one."""
        if k == self.noise_end:
            self.noise_window(k, self.pos_noise.shape[1])

    def initial_state(self) -> np.ndarray:
        X = np.zeros((self.B, NSTATE))
        for i, s in enumerate(self.scenarios):
            X[i, 0:3] = s.x0
            X[i, 5:11] = s.theta_hat_initial
        return X

    def reference(self, t):
        """(x_d, y_d, x_d', y_d', x_d'', y_d''), each (B,), at time t."""
        values = np.array([np.concatenate(tr.evaluate(t))
                           for tr in self.trajectories])[self.traj_index]
        return tuple(values.T)

    def parameter_table(self) -> np.ndarray:
        """The per-run parameters, (B, len(LOOP_PARAMETERS)): row i holds run i's
        values in the order of :data:`unidyn.model.equations.LOOP_PARAMETERS`."""
        table = np.zeros((self.B, len(LOOP_PARAMETERS)))
        for i, s in enumerate(self.scenarios):
            spec = s.case_spec
            values = dict(
                zip(THETA_NAMES, s.robot.theta),
                a=s.a, kx=s.kx, ky=s.ky, lx=s.lx, ly=s.ly, ku=s.ku, kw=s.kw, lu=s.lu, lw=s.lw,
                adapt_from=s.adapt_from if spec.adaptive else np.inf, tau=s.tau,
                filtered=float(s.derivative == "filter"), dynamic=float(spec.dynamic),
                compensated=float(spec.compensated),
                speed_u=s.limits.speed[0], speed_w=s.limits.speed[1],
                accel_u=s.limits.accel[0], accel_w=s.limits.accel[1],
                # the reference's code and numbers (a Python function: path1, its index)
                **s.trajectory.table())
            leak = laws.leakage_rate(s.gamma, s.sigma, s.leakage)
            for j in range(6):
                values[f"gamma{j + 1}"] = s.gamma[j]
                values[f"leak{j + 1}"] = leak[j]
            load = list(s.payload) + [(np.inf, 1.0)] * (equations.PAYLOAD_STEPS - len(s.payload))
            for j, (t_load, m_load) in enumerate(load):
                values[f"payload_time{j + 1}"], values[f"payload_mass{j + 1}"] = t_load, m_load
            for name, v in values.items():
                table[i, getattr(P, name)] = v
        return table

    def _noise(self, k):
        """The held noise of interval k (inside the current window; see noise_window)."""
        if not self.noise_k0 <= k < self.noise_end:
            raise IndexError(f"interval {k} is outside the noise window "
                             f"[{self.noise_k0}, {self.noise_end})")
        j = k - self.noise_k0
        return (self.pos_noise[:, j, 0], self.pos_noise[:, j, 1],
                self.vel_noise[:, j, 0], self.vel_noise[:, j, 1])

    def rhs(self, t, X, k):
        """dX/dt, (B, 13), at time t in noise interval k
        (:func:`unidyn.model.equations.loop_derivative` on all runs at once). k must lie in
        the current noise window (:meth:`noise_window`; the first is drawn on creation)."""
        dX = np.empty((NSTATE, X.shape[0]))
        equations.loop_derivative(t, X.T, self.reference(t), self.P.T, self._noise(k), dX)
        return dX.T

    def converged(self, rtol: float = 1e-11, atol: float = 1e-13, method: str = "DOP853",
                  max_step: float = MAX_STEP):
        """The runs' states at every sample t = k Ts, (B, steps + 1, 13), by scipy's
        ``solve_ivp`` restarted at every sample (the noise held over each interval, a
        speed limit hard at each sample), its steps at most ``max_step`` s: the solution
        the engines are checked against (``tests/engine/test_accuracy.py``,
        ``benchmarks/engines.py``). The limits switch the loop's rates (clipping an
        acceleration, holding a speed); the step's cap keeps every episode of clipping
        longer than about two steps in view of the error control, which a step that jumps
        over it cannot see (:data:`MAX_STEP`). Independent of the batch engine's
        location of the switches: it evaluates the limits where it evaluates the loop."""
        from scipy.integrate import solve_ivp
        out = np.empty((self.B, self.steps + 1, NSTATE))
        X = out[:, 0] = self.initial_state()
        for k in range(self.steps):
            self.next_noise_window(k)
            sol = solve_ivp(lambda t, x, k=k: self.rhs(t, x.reshape(self.B, NSTATE), k).ravel(),
                            (k * self.Ts, (k + 1) * self.Ts), X.ravel(), method=method,
                            rtol=rtol, atol=atol, max_step=max_step)
            X = sol.y[:, -1].reshape(self.B, NSTATE).copy()
            X[:, 3:5] = np.clip(X[:, 3:5], -self.vmax, self.vmax)
            out[:, k + 1] = X
        return out
