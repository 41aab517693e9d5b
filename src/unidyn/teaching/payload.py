r"""Picking up a load: a robot on the paper's figure eight whose mass changes at mid-run,
under the kinematic controller, exact compensation for the empty robot and adaptive
compensation, side by side (the scenario's ``payload`` schedule; Section 2 for which
parameters the mass scales, :func:`unidyn.model.equations.payload_theta`).

- :func:`pickup_scenarios`: the three runs of one load (mass scale, time);
- :func:`pickup_iae`: their IAE over a window before the load and over the last one;
- :func:`plot_pickup`: the distance error of the three and the adaptive estimate
  theta_hat relative to the empty robot's theta;
- :func:`pickup_sweep`: the IAE after the load against its mass, for the three.

Exact compensation keeps the empty robot's theta (Eq. 12 with theta_hat = theta of the
empty robot); adaptive compensation starts from the same estimate and updates it from
t = 0 (Eq. 20), so it follows the change.
"""

from __future__ import annotations

import numpy as np

from ..engine.batch import simulate_batch
from ..model.scenario import Scenario
from ..results import figstyle

__all__ = ["PICKUP_CONTROLLERS", "pickup_scenarios", "pickup_iae", "plot_pickup",
           "pickup_sweep"]

#: The three controllers, by the Scenario case that runs them.
PICKUP_CONTROLLERS = {"uncompensated": "kinematic controller (Eq. 10)",
                      "compensated": "exact compensation, empty robot's θ (Eq. 12)",
                      "adaptive": "adaptive compensation (Eqs. 12, 20)"}


def pickup_scenarios(mass: float = 2.0, at: float = 100.0, T: float = 200.0, noise=None,
                     robot="p3dx_laser", **changes) -> dict:
    """The three runs of a load of ``mass`` times the empty robot's mass picked up at
    ``at`` s, on the paper's figure eight for ``T`` s (the paper's gains and limits;
    ``noise`` None, a NoiseSpec or a dict; other Scenario fields in ``changes``):
    controller case -> Scenario."""
    base = Scenario(robot=robot, T=T, noise=noise, payload=[[at, mass]], **changes)
    return {case: base.replace(case=case, adapt_from=0.0, theta_hat0=base.robot,
                               name=f"{desc}, load x{mass:g} at {at:g} s")
            for case, desc in PICKUP_CONTROLLERS.items()}


def pickup_iae(results: dict, at: float, window: float = 25.0) -> dict:
    """Controller case -> (IAE over the ``window`` s before the load, IAE over the last
    ``window`` s of the run), m·s; 25 s is one lap of the figure eight, 8 pi s, rounded."""
    return {case: (r.window(at - window, at)["iae"], r.window(r.t[-1] - window, r.t[-1])["iae"])
            for case, r in results.items()}


def plot_pickup(results: dict, path, at: float):
    """Two panels: the distance error of each controller against time, the load's time
    marked; the adaptive estimate theta_hat_j / theta_j (empty robot), with the loaded
    robot's ratio (the mass scale for theta1, theta2, theta5, 1 for theta4, theta6)
    dashed; theta3, near zero for the paper's robot, is left out (its ratio says
    nothing)."""
    import matplotlib.pyplot as plt  # here: matplotlib is optional and slow to import

    with figstyle.style():
        fig, (ax_e, ax_th) = plt.subplots(2, 1, figsize=figstyle.size(2, 0.7), sharex=True)
        for case, desc in PICKUP_CONTROLLERS.items():
            r = results[case]
            ax_e.plot(r.t, r.error, lw=0.8, label=desc)
        for ax in (ax_e, ax_th):
            ax.axvline(at, color="C3", lw=0.8, ls=":")
        ax_e.set_ylabel(figstyle.label("distance error", "m"))
        ax_e.set_ylim(0, None)
        ax_e.set_title(f"load picked up at t = {at:g} s (dotted)")
        figstyle.legend(ax_e)
        r = results["adaptive"]
        theta = r.scenario.robot.theta
        mass = r.scenario.payload[-1][1]
        for j in (0, 1, 3, 4, 5):  # theta3 (near zero for the paper's robot) left out
            ax_th.plot(r.t, r.theta_hat[:, j] / theta[j], lw=0.8, label=f"$\\theta_{j + 1}$")
        ax_th.axhline(mass, color="k", lw=0.6, ls="--")
        ax_th.axhline(1.0, color="k", lw=0.6, ls="--")
        ax_th.set_xlabel(figstyle.label("t", "s"))
        ax_th.set_ylabel(r"$\hat\theta_j / \theta_j$ (empty robot)")
        figstyle.legend(ax_th, outside="right")
        return figstyle.save(fig, path)


def pickup_sweep(masses, at: float = 100.0, T: float = 200.0, noise=None,
                 window: float = 25.0, **changes) -> dict:
    """The IAE over the last ``window`` s against the load's mass scale, for each
    controller (one batch of runs): controller case -> array of IAE, m·s, in the order
    of ``masses`` (``changes``: other Scenario fields, as :func:`pickup_scenarios`)."""
    masses = [float(m) for m in masses]
    cases = list(PICKUP_CONTROLLERS)
    scs = [pickup_scenarios(m, at, T, noise, **changes)[c] for m in masses for c in cases]
    results = simulate_batch(scs, progress=False)
    iae = np.array([r.window(T - window, T)["iae"] for r in results]).reshape(len(masses),
                                                                           len(cases))
    return {c: iae[:, i] for i, c in enumerate(cases)}
