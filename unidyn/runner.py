"""Run a :class:`~unidyn.Scenario` through the bdsim diagram of Fig. 2."""

from __future__ import annotations

import contextlib
import io

import numpy as np

from ._validate import ValidationError, positive
from .result import Result
from .scenario import Scenario

__all__ = ["simulate", "SimulationError", "DEFAULT_RTOL", "DEFAULT_ATOL"]


class SimulationError(RuntimeError):
    """A run stopped early (e.g. a non-finite signal). ``result`` holds what was
    computed up to the failure, marked ``complete=False``; the message says when,
    where and for which scenario."""

    def __init__(self, message, result=None):
        super().__init__(message)
        self.result = result


def _root_cause(err):
    seen = []
    e = err
    while e is not None and e not in seen:
        seen.append(e)
        e = e.__cause__ or e.__context__
    from unidyn.blocks._common import NonFiniteSignalError
    for e in seen:
        if isinstance(e, (NonFiniteSignalError, ValidationError)):
            return e
    return seen[-1]

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
    :raises SimulationError: if the run stops early (for instance a block meets a
        NaN); its ``result`` attribute holds the samples logged before the failure,
        with ``complete=False``
    """
    if not isinstance(scenario, Scenario):
        raise ValidationError(f"scenario must be a unidyn.Scenario, got {type(scenario).__name__}")
    rtol = positive("rtol", rtol)
    atol = positive("atol", atol)
    from .diagrams import build_fig2, new_simulator

    sim = new_simulator()
    fig = build_fig2(sim, scenario, **builder_args)
    roles = list(fig.watch)
    with contextlib.redirect_stdout(io.StringIO()):  # bdsim's notes on unconnected outputs
        fig.bd.compile()
    sc = scenario
    failure = None
    try:
        # bdsim prints a report of a failing block; the exception carries it to the user
        with contextlib.redirect_stdout(io.StringIO()):
            out = sim.run(fig.bd, T=sc.T, dt=sc.Ts, watch=[fig.watch[r] for r in roles],
                          solver=method, solver_args=dict(rtol=rtol, atol=atol, max_step=sc.Ts))
        t = np.asarray(out.t, dtype=float)
        y = out[".ywatch"]
    except Exception as err:  # keep what bdsim logged before the failure
        simstate = getattr(fig.blocks["robot"], "_simstate", None)
        if simstate is None:
            raise
        cause = _root_cause(err)
        failure = (f"{sc.name or sc.case}: run stopped at t = {getattr(simstate, 't', float('nan')):.6g} s: "
                   f"{type(cause).__name__}: {cause}")
        t = np.asarray(simstate.tlist, dtype=float)
        y = [list(p) for p in simstate.plist]
        n = min([len(t)] + [len(p) for p in y])
        t, y = t[:n], [p[:n] for p in y]
    if len(t) == 0:
        raise SimulationError(failure or "no samples", None)
    signals = {r: np.asarray(y[i], dtype=float).reshape(len(t), -1) for i, r in enumerate(roles)}
    # bdsim restarts integration at clock ticks and may log a tick twice: keep
    # the last sample at each grid time and check that the grid is complete
    grid = np.round(t / sc.Ts).astype(int)
    keep = np.r_[grid[1:] != grid[:-1], True]
    t, grid = t[keep], grid[keep]
    signals = {k: v[keep] for k, v in signals.items()}
    expected = sc.steps + 1 if failure is None else len(grid)
    if not np.array_equal(grid, np.arange(len(grid))) or len(grid) != expected:
        raise RuntimeError(f"bdsim returned {len(grid)} samples, expected {expected} "
                           f"on a grid of step {sc.Ts}")
    t = grid * sc.Ts
    velocity = signals.get("velocity")
    if velocity is None:  # kinematic robot: v = v_d clipped to the speed limits
        velocity = np.clip(signals["v_d"], -sc.limits.speed, sc.limits.speed)
    theta_hat = signals.get("theta_hat")
    if theta_hat is None:
        theta_hat = np.tile(sc.theta_hat_initial, (len(t), 1))
    result = Result(scenario=sc, t=t, pose=signals["pose"], velocity=velocity,
                    reference=signals["reference"], v_d=signals["v_d"], v_ref=signals["v_ref"],
                    theta_hat=theta_hat, engine="bdsim", complete=failure is None,
                    message=failure or "", backend=f"solve_ivp {method}")
    if failure is not None:
        raise SimulationError(failure, result)
    return result
