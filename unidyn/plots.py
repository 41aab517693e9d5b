"""Plotting helpers for :class:`~unidyn.result.Result`: the paper's figure types.

Each function draws into a given matplotlib axis (or a new figure) and returns
the axis; nothing is shown, so they work headless (``MPLBACKEND=Agg``).
"""

from __future__ import annotations

import numpy as np

__all__ = ["plot_path", "plot_error", "plot_positions", "plot_velocities", "plot_theta_hat",
           "compare_paths", "compare_errors", "save_figures"]


def _ax(ax, **fig_kw):
    if ax is not None:
        return ax
    import matplotlib.pyplot as plt
    _, ax = plt.subplots(**fig_kw)
    return ax


def _label(result):
    return result.scenario.name or result.scenario.case


def plot_path(result, ax=None, reference=True, label=None):
    """Robot path (point h) against the reference path, as in Figs. 3, 5, 7, 9."""
    ax = _ax(ax, figsize=(5, 5))
    if reference:
        ax.plot(result.reference[:, 0], result.reference[:, 1], "k--", lw=1, label="reference")
    ax.plot(result.pose[:, 0], result.pose[:, 1], lw=1.2, label=label or _label(result))
    ax.plot(result.pose[0, 0], result.pose[0, 1], "o", ms=4, color="C3")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_aspect("equal", adjustable="datalim")
    ax.legend(loc="best", fontsize="small")
    return ax


def plot_error(result, ax=None, label=None):
    """Distance error |h_d - h| against time, as in Figs. 4, 6, 8, 10."""
    ax = _ax(ax, figsize=(7, 3))
    ax.plot(result.t, result.error, lw=1, label=label or _label(result))
    ax.set_xlabel("t [s]")
    ax.set_ylabel("distance error [m]")
    ax.grid(alpha=0.3)
    return ax


def plot_positions(result, axes=None):
    """x and y of h against the reference, over time."""
    if axes is None:
        import matplotlib.pyplot as plt
        _, axes = plt.subplots(2, 1, sharex=True, figsize=(7, 4))
    for i, (ax, n) in enumerate(zip(axes, ("x", "y"))):
        ax.plot(result.t, result.reference[:, i], "k--", lw=1, label=f"{n}_d")
        ax.plot(result.t, result.pose[:, i], lw=1, label=n)
        ax.set_ylabel(f"{n} [m]")
        ax.legend(loc="upper right", fontsize="small")
    axes[-1].set_xlabel("t [s]")
    return axes


def plot_velocities(result, axes=None):
    """u and w: the kinematic controller's reference v_d against the actual velocities."""
    if axes is None:
        import matplotlib.pyplot as plt
        _, axes = plt.subplots(2, 1, sharex=True, figsize=(7, 4))
    for i, (ax, n, unit) in enumerate(zip(axes, ("u", "w"), ("m/s", "rad/s"))):
        ax.plot(result.t, result.v_d[:, i], "k--", lw=0.8, label=f"{n}_d")
        ax.plot(result.t, result.velocity[:, i], lw=1, label=n)
        ax.set_ylabel(f"{n} [{unit}]")
        ax.legend(loc="upper right", fontsize="small")
    axes[-1].set_xlabel("t [s]")
    return axes


def plot_theta_hat(result, ax=None, relative=True):
    """The parameter estimate over time, each divided by the robot's true value
    (``relative=True``) so the six share one axis."""
    ax = _ax(ax, figsize=(7, 3))
    theta = result.scenario.robot.theta
    for i in range(6):
        y = result.theta_hat[:, i] / theta[i] if relative else result.theta_hat[:, i]
        ax.plot(result.t, y, lw=1, label=f"θ̂{i + 1}")
    ax.set_xlabel("t [s]")
    ax.set_ylabel("θ̂ / θ" if relative else "θ̂")
    ax.legend(ncol=3, fontsize="small")
    ax.grid(alpha=0.3)
    return ax


def compare_paths(results, ax=None):
    """Several runs' paths on one axis, with the first run's reference."""
    ax = _ax(ax, figsize=(5, 5))
    for k, r in enumerate(results):
        plot_path(r, ax=ax, reference=(k == 0))
    return ax


def compare_errors(results, ax=None):
    ax = _ax(ax, figsize=(7, 3))
    for r in results:
        plot_error(r, ax=ax)
    ax.legend(fontsize="small")
    return ax


def save_figures(result, folder, dpi=110) -> list:
    """Write path.png, error.png, positions.png, velocities.png and (adaptive)
    theta_hat.png into ``folder``; returns the paths written."""
    from pathlib import Path

    import matplotlib.pyplot as plt
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    written = []

    def done(fig, name):
        fig.tight_layout()
        p = folder / name
        fig.savefig(p, dpi=dpi)
        plt.close(fig)
        written.append(p)

    ax = plot_path(result)
    done(ax.figure, "path.png")
    ax = plot_error(result)
    done(ax.figure, "error.png")
    axes = plot_positions(result)
    done(axes[0].figure, "positions.png")
    axes = plot_velocities(result)
    done(axes[0].figure, "velocities.png")
    if result.scenario.case == "adaptive":
        ax = plot_theta_hat(result)
        done(ax.figure, "theta_hat.png")
    return written
