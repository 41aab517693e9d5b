"""Run a :class:`~unidyn.Scenario` through the bdsim diagram of Fig. 2."""

from __future__ import annotations

import numpy as np

from ._validate import ValidationError, positive
from .result import Result
from .scenario import Scenario

__all__ = ["simulate", "DEFAULT_RTOL", "DEFAULT_ATOL"]

DEFAULT_RTOL = 1e-8
DEFAULT_ATOL = 1e-10


def simulate(scenario: Scenario, *, rtol: float = DEFAULT_RTOL, atol: float = DEFAULT_ATOL,
             method: str = "RK45", **builder_args) -> Result:
    """Simulate ``scenario`` with bdsim (Fig. 2 diagram, :func:`unidyn.diagrams.build_fig2`).

    The continuous states are integrated by ``scipy.integrate.solve_ivp``
    (``method``) with relative and absolute tolerances ``rtol``, ``atol``;
    results are sampled every ``scenario.Ts``.

    :param builder_args: factories passed to :func:`unidyn.diagrams.build_fig2`
        (``robot=``, ``controller=``, ``compensator=``, ``trajectory=``)
    :return: :class:`Result`
    """
    if not isinstance(scenario, Scenario):
        raise ValidationError(f"scenario must be a unidyn.Scenario, got {type(scenario).__name__}")
    rtol = positive("rtol", rtol)
    atol = positive("atol", atol)
    from .diagrams import build_fig2, new_simulator

    sim = new_simulator()
    fig = build_fig2(sim, scenario, **builder_args)
    roles = list(fig.watch)
    import contextlib
    import io
    with contextlib.redirect_stdout(io.StringIO()):  # bdsim's notes on unconnected outputs
        fig.bd.compile()
    sc = scenario
    out = sim.run(fig.bd, T=sc.T, dt=sc.Ts, watch=[fig.watch[r] for r in roles],
                  solver=method, solver_args=dict(rtol=rtol, atol=atol, max_step=sc.Ts))
    t = np.asarray(out.t, dtype=float)
    y = out[".ywatch"] if ".ywatch" in out else None
    signals = {r: np.asarray(y[i], dtype=float).reshape(len(t), -1) for i, r in enumerate(roles)}
    # bdsim restarts integration at clock ticks and may log a tick twice: keep
    # the last sample at each grid time and check that the grid is complete
    grid = np.round(t / sc.Ts).astype(int)
    keep = np.r_[grid[1:] != grid[:-1], True]
    t, grid = t[keep], grid[keep]
    signals = {k: v[keep] for k, v in signals.items()}
    if not np.array_equal(grid, np.arange(len(grid))) or len(grid) != sc.steps + 1:
        raise RuntimeError(f"bdsim returned {len(grid)} samples, expected {sc.steps + 1} "
                           f"on a grid of step {sc.Ts}")
    t = grid * sc.Ts
    velocity = signals.get("velocity")
    if velocity is None:  # kinematic robot: v = v_d clipped to the speed limits
        velocity = np.clip(signals["v_d"], -sc.limits.speed, sc.limits.speed)
    theta_hat = signals.get("theta_hat")
    if theta_hat is None:
        theta_hat = np.tile(sc.theta_hat_initial, (len(t), 1))
    return Result(scenario=sc, t=t, pose=signals["pose"], velocity=velocity,
                  reference=signals["reference"], v_d=signals["v_d"], v_ref=signals["v_ref"],
                  theta_hat=theta_hat, engine="bdsim")
