r"""The closed loop of Fig. 2 as one pure right-hand side, batched over scenarios.

This is the same loop the bdsim diagram of :func:`unidyn.diagrams.build_fig2`
wires, written as one function of time and state using the same core functions
(:mod:`unidyn.model`, :mod:`unidyn.control`). It serves as the independent
reference the diagram is tested against, and as the right-hand side of the batch
engine. Continuous control only (``Scenario.control == "continuous"``).

State of each run (13 values): ``x, y, psi, u, w`` (robot; u and w unused for a
kinematic robot), ``theta_hat1..6`` (compensator estimate), ``z_u, z_w``
(derivative-filter states, used with ``vd_dot="filter"``).

Noise is white and held over each interval [k Ts, (k+1) Ts): the k-th draw of
the same seeded generators the bdsim noise blocks use, so both see the same numbers.
"""

from __future__ import annotations

import numpy as np

from . import control, model
from .noise import held_sequence, noise_seeds
from .scenario import CASES, Scenario

__all__ = ["ClosedLoop", "NSTATE"]

NSTATE = 13
_KIN, _UNC, _COMP, _ADAPT = (CASES.index(c) for c in CASES)


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
        f = lambda attr: np.array([getattr(s, attr) for s in scs], dtype=float)  # noqa: E731
        self.case = np.array([CASES.index(s.case) for s in scs])
        self.theta = np.array([s.robot.theta for s in scs])
        self.a = f("a")
        self.kK = np.stack([f("kx"), f("ky")], -1)
        self.lK = np.stack([f("lx"), f("ly")], -1)
        self.kD = np.stack([f("ku"), f("kw")], -1)
        self.lD = np.stack([f("lu"), f("lw")], -1)
        self.gamma = np.array([s.gamma for s in scs])
        self.sigma = np.array([s.sigma for s in scs])
        self.adapt_from = np.where(self.case == _ADAPT, f("adapt_from"), np.inf)
        self.tau = f("tau")
        self.filt = np.array([s.derivative == "filter" for s in scs])
        self.leak = np.array([{"paper": 0, "fx44850": 1, "none": 2}[s.leakage] for s in scs])
        self.vmax = np.array([s.limits.speed for s in scs])
        self.amax = np.array([s.limits.accel for s in scs])
        self.dynamic = self.case != _KIN
        self.compensated = self.case >= _COMP
        # trajectories: evaluate each distinct one once
        self._traj = {}
        self.traj_index = np.empty(B, dtype=int)
        for i, s in enumerate(scs):
            key = repr(s.trajectory) if not hasattr(s.trajectory, "f") else id(s.trajectory)
            if key not in self._traj:
                self._traj[key] = (len(self._traj), s.trajectory)
            self.traj_index[i] = self._traj[key][0]
        self._trajs = [tr for _, tr in sorted(self._traj.values(), key=lambda p: p[0])]
        # noise, held per interval (steps + 1 rows: the last covers t = T)
        n = self.steps + 1
        self.pos_noise = np.zeros((B, n, 2))
        self.vel_noise = np.zeros((B, n, 2))
        for i, s in enumerate(scs):
            if s.noise is None:
                continue
            pos_seed, vel_seed = noise_seeds(s.noise.seed)
            self.pos_noise[i] = held_sequence(pos_seed, s.noise.position_std, n)
            if s.case != "kinematic":  # a kinematic robot has no velocities to measure
                self.vel_noise[i] = held_sequence(vel_seed, s.noise.velocity_std, n)

    # ------------------------------------------------------------------ #
    def initial_state(self) -> np.ndarray:
        X = np.zeros((self.B, NSTATE))
        for i, s in enumerate(self.scenarios):
            X[i, 0:3] = s.x0
            X[i, 5:11] = s.theta_hat_initial
        return X

    def reference(self, t):
        """h_d, h_d_dot, h_d_ddot at time t, each (B, 2)."""
        out = []
        for tr in self._trajs:
            out.append((tr.position(t), tr.velocity(t), tr.acceleration(t)))
        idx = self.traj_index
        return tuple(np.array([o[j] for o in out])[idx] for j in range(3))

    def signals(self, t, X, k):
        """Everything the loop computes at (t, X) in interval k: a dict of (B, ...) arrays."""
        h, psi, v = X[:, 0:2], X[:, 2], X[:, 3:5]
        theta_hat, z = X[:, 5:11], X[:, 11:13]
        h_d, h_d_dot, h_d_ddot = self.reference(t)
        h_meas = h + self.pos_noise[:, k]
        v_meas = v + self.vel_noise[:, k]
        v_d = control.kinematic_control(h_d, h_d_dot, h_meas, psi, self.a, self.kK, self.lK)
        rate = control.kinematic_control_rate(h_d, h_d_dot, h_d_ddot, h_meas, psi, v_meas,
                                              self.a, self.kK, self.lK)
        v_d_dot = np.where(self.filt[:, None], (v_d - z) / self.tau[:, None], rate)
        G = control.compensation_regressor(v_d, v_d_dot, v_meas, self.kD, self.lD)
        v_r = control.compensation(G, theta_hat)
        v_ref = np.where(self.compensated[:, None], v_r, v_d)
        return dict(h_d=h_d, v_d=v_d, v_d_dot=v_d_dot, G=G, v_ref=v_ref, v_meas=v_meas)

    def rhs(self, t, X, k):
        """dX/dt, (B, 13), at time t in noise interval k."""
        s = self.signals(t, X, k)
        dX = np.zeros_like(X)
        lim_v = np.clip(s["v_ref"], -self.vmax, self.vmax)
        # dynamic robot, Eqs. (1)-(2) with limits
        vdot = model.dynamics(X[:, 3:5], lim_v, self.theta)
        vdot = np.clip(vdot, -self.amax, self.amax)
        v = X[:, 3:5]
        outward = ((v >= self.vmax) & (vdot > 0)) | ((v <= -self.vmax) & (vdot < 0))
        vdot = np.where(outward, 0.0, vdot)
        v_move = np.where(self.dynamic[:, None], v, lim_v)
        dX[:, 0:2] = model.point_velocity(X[:, 2], v_move, self.a)
        dX[:, 2] = v_move[:, 1]
        dX[:, 3:5] = np.where(self.dynamic[:, None], vdot, 0.0)
        # adaptation, Eqs. (18)/(20), switched on at adapt_from
        v_tilde = s["v_d"] - s["v_meas"]
        grad = np.einsum("bij,bi->bj", s["G"], v_tilde)
        th = X[:, 5:11]
        leak = np.select([self.leak[:, None] == 0, self.leak[:, None] == 1],
                         [self.gamma * self.sigma * th, self.sigma * th], 0.0)
        on = control.adaptation_on(t, self.adapt_from)[:, None]
        dX[:, 5:11] = np.where(on, self.gamma * grad - leak, 0.0)
        dX[:, 11:13] = np.where(self.filt[:, None], s["v_d_dot"], 0.0)
        return dX
