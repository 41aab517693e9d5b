"""Plotting helpers for :class:`~unidyn.results.result.Result`: the paper's figure types.

Each function draws into a given matplotlib axis (or a new figure, sized for a
journal column) and returns the axis; nothing is shown, so they work headless
(``MPLBACKEND=Agg``). All of them draw in unidyn's figure style
(:mod:`unidyn.results.figstyle`): units written ``x (m)``, legends where they hide no data,
y-limits from the data. :func:`save_figures` writes a run's figures:

- ``path.png``: the path of h against the reference (Figs. 3a, 5a, 7a, 9a);
- ``error.png``: the distance error |h_d - h| over time (Figs. 3b, 5b, 7b, 9b);
- ``positions.png``: x and y of h against x_d, y_d over time (Figs. 4a, 6a, 8a, 10a);
- ``velocities.png``: u and omega against the kinematic controller's u_d, omega_d
  (Figs. 4b, 6b, 8b, 10b);
- ``theta_hat.png`` (adaptive runs): each of the six estimates against its true value.

A sweep's figure is drawn by :func:`unidyn.sweeps.plots.plot_metrics`; the paper's
Fig. 11 by :func:`unidyn.paper.plot_fig11`.
"""

from __future__ import annotations

import numpy as np

from ..model.cases import CASE_SPECS
from . import figstyle
from .figstyle import REFERENCE, START
from .figstyle import label as _unit

__all__ = ["plot_path", "plot_error", "plot_positions", "plot_velocities", "plot_theta_hat",
           "compare_paths", "compare_errors", "save_figures", "reference_period",
           "reference_once", "equal_limits", "run_title",
           "CASE_TITLES"]

#: A true parameter smaller than this fraction of the largest |theta_i| counts as
#: "near zero": its estimate is not divided by it.
NEAR_ZERO = 0.01


def _ax(ax, figsize):
    if ax is not None:
        return ax
    import matplotlib.pyplot as plt
    _, ax = plt.subplots(figsize=figsize)
    return ax


def _label(result):
    return figstyle.as_text(result.scenario.name) or result.scenario.case


#: What each case of the loop is, for titles (:data:`unidyn.model.cases.CASE_SPECS`).
CASE_TITLES = {name: spec.title for name, spec in CASE_SPECS.items()}


def run_title(scenario) -> str:
    """A figure title naming a run: its name (if it has one), its case, then its
    robot, kinematic gains and noise, e.g. ``"adaptive dynamic compensation\n
    p3dx_laser, kx = ky = 0.1, noise seed 1"``."""
    s = scenario
    gains = f"kx = ky = {s.kx:g}" if s.kx == s.ky else f"kx = {s.kx:g}, ky = {s.ky:g}"
    noise = "noise-free" if s.noise is None else f"noise seed {s.noise.seed}"
    lines = [figstyle.as_text(s.name)] if s.name else []
    return "\n".join(lines + [s.case_spec.title,
                              f"{figstyle.as_text(s.robot.name, limit=24)}, {gains}, {noise}"])


def reference_period(trajectory):
    """The period of a trajectory, s, or ``None`` (not periodic, or a period so long
    that drawing the whole run is as good): its kind's ``period``
    (:class:`unidyn.model.trajectories.Trajectory`)."""
    return getattr(trajectory, "period", None)


def reference_once(result):
    """The reference path over its first period (the whole run if shorter or not
    periodic), densely sampled from the trajectory when the scenario has one:
    ``(xy, period)`` with ``period`` None when the whole run is returned."""
    sc = getattr(result, "scenario", None)
    traj = getattr(sc, "trajectory", None)
    t_end = float(result.t[-1])
    period = reference_period(traj) if traj is not None else None
    if period is not None and period >= t_end:
        period = None
    span = period if period is not None else t_end
    if traj is not None and hasattr(traj, "position"):
        t = np.linspace(float(result.t[0]), float(result.t[0]) + span, 1000)
        with np.errstate(all="ignore"):  # a reference beyond floats (the run stopped): NaN
            xy = np.asarray(traj.position(t), dtype=float).reshape(len(t), 2)
        return xy, period
    m = result.t <= result.t[0] + span + 1e-9
    return np.asarray(result.reference)[m], period


def _time_axis(ax, t):
    """The x range of a time plot: the run's span (a run stopped at its first
    sample has none: matplotlib's own range then)."""
    if len(t) and t[-1] > t[0]:
        ax.set_xlim(t[0], t[-1])


def _reference_label(period):
    return "reference" if period is None else f"reference (one period, {period:.1f} s)"


@figstyle.styled
def plot_path(result, ax=None, reference=True, label=None, start=True, legend=True):
    """Robot path (point h) against the reference path, as in Figs. 3, 5, 7, 9.

    The reference is drawn once, over its first period (a figure eight traced many
    times would otherwise look solid); the start of h is marked and named.
    """
    from matplotlib.ticker import MaxNLocator
    ax = _ax(ax, figstyle.size(1, 1.05))
    if reference:
        xy, period = reference_once(result)
        ax.plot(xy[:, 0], xy[:, 1], **REFERENCE, label=_reference_label(period))
    ax.plot(result.pose[:, 0], result.pose[:, 1], color="C0",
            label=label or f"path of h, {_label(result)}")
    if start:
        ax.plot(result.pose[0, 0], result.pose[0, 1], **START, zorder=5, label="start")
    ax.set_xlabel(_unit("x", "m"))
    ax.set_ylabel(_unit("y", "m"))
    equal_limits(ax)
    ax.xaxis.set_major_locator(MaxNLocator(5, steps=[1, 2, 2.5, 5, 10]))
    ax.yaxis.set_major_locator(MaxNLocator(5, steps=[1, 2, 2.5, 5, 10]))
    if legend:
        figstyle.legend(ax, fallback="below")
    return ax


def equal_limits(ax, margin=0.06):
    """Equal scales on x and y, limits from every line of ``ax`` plus a margin."""
    pts = np.vstack([np.asarray(l.get_xydata(), dtype=float) for l in ax.get_lines()])
    pts = pts[np.all(np.isfinite(pts), axis=1)]
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    pad = margin * max(float(np.max(hi - lo)), 1e-3)
    ax.set_xlim(lo[0] - pad, hi[0] + pad)
    ax.set_ylim(lo[1] - pad, hi[1] + pad)
    ax.set_aspect("equal", adjustable="box")


@figstyle.styled
def plot_error(result, ax=None, label=None, legend=False):
    """Distance error |h_d - h| against time, as in Figs. 4, 6, 8, 10; y-limits from
    this run's data (from 0)."""
    ax = _ax(ax, figstyle.size(1, 0.6))
    ax.plot(result.t, result.error, color="C0", label=label or _label(result))
    figstyle.label_time_axis(ax)
    ax.set_ylabel(_unit("distance error", "m"))
    _time_axis(ax, result.t)
    figstyle.ylim_from_data(ax, floor=0)
    if legend:
        figstyle.legend(ax)
    return ax


def _two_panels(axes, height=0.85):
    if axes is None:
        import matplotlib.pyplot as plt
        _, axes = plt.subplots(2, 1, sharex=True, figsize=figstyle.size(1, height))
    return axes


@figstyle.styled
def plot_positions(result, axes=None):
    """x and y of h against the reference x_d, y_d over time (Figs. 4a, 6a, 8a, 10a)."""
    axes = _two_panels(axes)
    for i, (ax, n) in enumerate(zip(axes, ("x", "y"))):
        ax.plot(result.t, result.reference[:, i], **REFERENCE, label=f"${n}_d$")
        ax.plot(result.t, result.pose[:, i], color="C0", lw=0.9, label=f"${n}$")
        ax.set_ylabel(_unit(f"${n}$", "m"))
        _time_axis(ax, result.t)
        figstyle.ylim_from_data(ax)
    axes[-1].set_xlabel(_unit("t", "s"))
    _legend_below(axes, ["$x_d$, $y_d$ (reference)", "$x$, $y$ (robot)"])
    return axes


@figstyle.styled
def plot_velocities(result, axes=None):
    """u and omega: the kinematic controller's output v_d (the velocities it asks for,
    Eq. 10) against the actual velocities (Figs. 4b, 6b, 8b, 10b)."""
    axes = _two_panels(axes)
    for i, (ax, n, unit) in enumerate(zip(axes, ("u", r"\omega"), ("m/s", "rad/s"))):
        if result.v_d is not None:  # not logged when the scenario's log_series leaves it out
            ax.plot(result.t, result.v_d[:, i], **REFERENCE, label=f"${n}_d$")
        ax.plot(result.t, result.velocity[:, i], color="C0", lw=0.9, label=f"${n}$")
        ax.set_ylabel(_unit(f"${n}$", unit))
        _time_axis(ax, result.t)
        figstyle.ylim_from_data(ax)
    axes[-1].set_xlabel(_unit("t", "s"))
    _legend_below(axes, (["$u_d$, $\\omega_d$ (kinematic controller)"]
                         if result.v_d is not None else []) + ["$u$, $\\omega$ (robot)"])
    return axes


def _legend_below(axes, labels):
    """One legend for a figure's panels, under them, so that the data keep the
    figure's whole width and the panels' axes line up."""
    axes[0].figure.legend(axes[0].get_lines()[:len(labels)], labels,
                          loc="outside lower center", ncol=len(labels), frameon=False)


def _theta_units():
    # Eq. (2) with u in m/s and omega in rad/s: theta1, theta2 time constants (s),
    # theta3 s·m/rad², theta4 and theta6 dimensionless, theta5 s/m
    return ("s", "s", "s·m/rad²", None, "s/m", None)


@figstyle.styled
def plot_theta_hat(result, ax=None, relative=True, panels=False):
    r"""The parameter estimate over time.

    With ``panels=True`` (or six axes as ``ax``): one panel per component,
    :math:`\hat\theta_i` against its true value (dashed), each with its own
    y-limits, so all six are readable whatever their size (``theta_hat.png``);
    returns the six axes. Otherwise one axis (``ax`` or a new one): the estimates
    divided by the true values (``relative=True``), leaving out the components whose
    true value is near zero (smaller than 1 % of the largest), whose ratio would
    swamp the rest; ``relative=False`` plots the raw estimates. Returns the axis.
    The true values are the robot's at each time, which a ``payload`` schedule changes
    (:meth:`unidyn.Scenario.theta_at`).
    """
    if result.theta_hat is None:
        raise ValueError("this result has no theta_hat: its scenario's log_series leaves it "
                         "out (log_series=('theta_hat', ...) keeps it)")
    theta = np.asarray(result.scenario.robot.theta, dtype=float)
    th = np.asarray(result.theta_hat, dtype=float)
    t = result.t
    true = result.scenario.theta_at(t)  # (N, 6): a load steps it
    t_on = getattr(result.scenario, "adapt_from", None)
    single = not panels and not isinstance(ax, (list, tuple, np.ndarray))
    if single:
        ax = _ax(ax, figstyle.size(1, 0.7))
        small = np.abs(theta) < NEAR_ZERO * np.max(np.abs(theta))
        for i in range(6):
            if relative and small[i]:
                continue
            y = th[:, i] / true[:, i] if relative else th[:, i]
            ax.plot(t, y, lw=1, color=figstyle.QUALITATIVE[i], label=rf"$\hat\theta_{i + 1}$")
        if relative:
            ax.axhline(1.0, **REFERENCE, label="true value")
        figstyle.label_time_axis(ax)
        ax.set_ylabel(r"$\hat\theta_i\,/\,\theta_i$" if relative else r"$\hat\theta_i$")
        ax.set_xlim(t[0], t[-1])
        figstyle.ylim_from_data(ax)
        if relative and small.any():
            left_out = ", ".join(rf"$\hat\theta_{i + 1}$" for i in np.flatnonzero(small))
            ax.set_title(f"{left_out} left out: true value near 0", fontsize=7)
        figstyle.legend(ax, outside="right")
        return ax
    if ax is None:
        import matplotlib.pyplot as plt
        _, ax = plt.subplots(3, 2, sharex=True, figsize=figstyle.size(2, 0.55))
    axes = np.asarray(ax).reshape(-1)
    units = _theta_units()
    for i, a in enumerate(axes[:6]):
        size = np.nanmax(np.abs(np.append(th[:, i], true[:, i])))
        power = 3 * int(np.floor(np.log10(size) / 3)) if 0 < size < 1e-2 else 0
        scale = 10.0 ** power  # tiny values in 10^-3 units, not an offset label
        a.plot(t, th[:, i] / scale, color="C0", label="estimate")
        a.plot(t, true[:, i] / scale, **REFERENCE, label="true value")
        if t_on is not None and t[0] < t_on < t[-1]:
            a.axvline(t_on, color="0.5", lw=0.7, ls=":", label="adaptation on")
        unit = " ".join(u for u in (f"$10^{{{power}}}$" if power else "", units[i] or "") if u)
        a.set_ylabel(_unit(rf"$\hat\theta_{i + 1}$", unit or None))
        _time_axis(a, t)
        lines = [l for l in a.get_lines() if l.get_label() != "adaptation on"]
        figstyle.ylim_from_data(a, lines=lines, pad=0.12)
    for a in axes[-2:]:
        a.set_xlabel(_unit("t", "s"))
    handles, labels = axes[0].get_legend_handles_labels()
    axes[0].figure.legend(handles, labels, loc="outside lower center", ncol=len(labels),
                          frameon=False, title="The update law (Eq. 18 or 20) keeps the estimates bounded; they need not "
                          "reach the true values,\nwhich takes a reference that excites every "
                          "parameter (persistent excitation).",
                          title_fontproperties={"size": 6.5})
    return axes


@figstyle.styled
def compare_paths(results, ax=None):
    """Several runs' paths on one axis, with the first run's reference."""
    ax = _ax(ax, figstyle.size(1, 0.95))
    for k, r in enumerate(results):
        plot_path(r, ax=ax, reference=(k == 0), start=(k == 0), legend=False)
        ax.get_lines()[-1 - (k == 0)].set_color(f"C{k}")
    figstyle.legend(ax)
    return ax


@figstyle.styled
def compare_errors(results, ax=None):
    ax = _ax(ax, figstyle.size(1, 0.6))
    for k, r in enumerate(results):
        plot_error(r, ax=ax)
        ax.get_lines()[-1].set_color(f"C{k}")
    figstyle.ylim_from_data(ax, floor=0)
    figstyle.legend(ax)
    return ax


@figstyle.styled
def save_figures(result, folder, dpi=figstyle.DPI) -> list:
    """Write path.png, error.png, positions.png, velocities.png and (adaptive, with
    theta_hat logged) theta_hat.png into ``folder``, each titled with the run
    (:func:`run_title`); returns the paths written."""
    from pathlib import Path

    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    written = []

    title = run_title(result.scenario)

    def done(fig, name):
        fig.suptitle(title, fontsize=7)
        written.append(figstyle.save(fig, folder / name, dpi=dpi))

    done(plot_path(result).figure, "path.png")
    done(plot_error(result).figure, "error.png")
    done(plot_positions(result)[0].figure, "positions.png")
    done(plot_velocities(result)[0].figure, "velocities.png")
    if result.scenario.case_spec.adaptive and result.theta_hat is not None:
        done(plot_theta_hat(result, panels=True)[0].figure, "theta_hat.png")
    return written
