"""Validation: a model simulated from a log's commands (Eq. (2)) against the
velocities the log measured, as numbers and as a figure.
"""

from __future__ import annotations

import math

import numpy as np

from .._validate import ValidationError, choice, nonnegative, positive, vector
from ..model import robots
from ..model.unicycle import NO_LIMITS, Limits
from ..results.figstyle import label, size, styled, ylim_from_data
from .checks import fit_refused
from .logs import load_log, segments
from .replay import COMMAND_CONVENTIONS, simulate_held, simulate_stepwise
from .results import IdentificationResult, ValidationReport


def nrmse_fit(y, yhat) -> float:
    """NRMSE fit of ``yhat`` to ``y``, %: 100 (1 - ||y - yhat|| / ||y - mean(y)||);
    100 is perfect, 0 no better than the mean (NaN for a constant ``y``)."""
    den = float(np.linalg.norm(y - np.mean(y)))
    if den == 0:
        return math.nan
    return 100.0 * (1.0 - float(np.linalg.norm(y - yhat)) / den)


def validate(theta, log, columns=None, v0=None, limits: Limits = NO_LIMITS,
             commands: str | None = None, delay: float | None = None,
             gap: float | None = None, time_unit: str | None = None,
             scale=None) -> ValidationReport:
    r"""Simulate a model from a log's commands and compare with its measured velocities.

    Use a held-out log (not the one identified from; see :func:`split_log`). The
    log is split at gaps as in :func:`identify`; each piece is simulated from
    its first measured velocities (or ``v0`` for the first piece), with the
    commands applied by the convention and delay of the identification (or
    those given). Without limits the simulation is the compiled RK4 of the
    output-error fit (numba when installed): a 10^6-sample log validates in
    about a second. With limits it is scipy's DOP853, restarted at every sample.

    :param theta: an :class:`IdentificationResult`, :class:`RobotParameters`,
        robot name or six numbers
    :param log: as for :func:`identify`
    :param columns: as for :func:`identify`
    :param v0: initial [u, w] of the first piece
    :param limits: limits applied inside the model, as in :func:`simulate_log`
    :param commands: ``"held"`` or ``"linear"``; default the result's, else held
    :param delay: input delay, s; default the result's, else 0
    :param gap: as for :func:`identify`
    :param time_unit: the unit of the log's time column, as for :func:`identify`
    :param scale: factors that bring columns to m/s and rad/s, as for :func:`identify`
    :return: :class:`ValidationReport` with NRMSE fit (%) and RMSE per channel
    """
    if isinstance(theta, IdentificationResult):
        commands = theta.commands if commands is None else commands
        delay = theta.delay if delay is None else delay
        theta = theta.theta
    rp = robots.resolve(theta, "theta")
    commands = choice("commands", "held" if commands is None else commands,
                      COMMAND_CONVENTIONS)
    delay = nonnegative("delay", 0.0 if delay is None else delay)
    if gap is not None:
        gap = positive("gap", gap)
    if not isinstance(limits, Limits):
        raise ValidationError(f"limits must be a unidyn.model.unicycle.Limits, got {limits!r}")
    d = load_log(log, columns, time_unit, scale)
    segs = segments(d["t"], gap)
    with fit_refused("the validation's simulation"):
        return validation_report(rp, d, segs, commands, delay,
                                  None if v0 is None else vector("v0", v0, 2), limits)


def validation_report(rp, d, segs, commands, delay, v0=None, limits=NO_LIMITS):
    """The :class:`ValidationReport` of robot ``rp`` on the checked log arrays ``d``
    (t, u_ref, w_ref, u, w, e.g. joined by :func:`unidyn.identification.join_logs`)
    over its pieces ``segs`` [(start, stop)]: each piece simulated by Eq. (2)
    from its first measured velocities (``v0`` for the first piece), with the
    commands ``"held"`` or ``"linear"`` and delayed by ``delay`` s; with active
    ``limits`` by scipy's DOP853, else by the compiled RK4."""
    t = d["t"]
    V0 = np.array([[d["u"][a], d["w"][a]] for a, _ in segs])
    if v0 is not None:
        V0[0] = v0
    if limits.active:
        V = np.full((t.size, 2), np.nan)
        for (a, b), vv in zip(segs, V0):
            X = simulate_stepwise(rp.theta, t[a:b], d["u_ref"][a:b], d["w_ref"][a:b],
                                   np.array([0.0, 0.0, 0.0, vv[0], vv[1]]), limits,
                                   commands == "linear", delay) if b - a > 1 else \
                np.array([[0.0, 0.0, 0.0, vv[0], vv[1]]])
            V[a:b] = X[:, 3:5]
    else:
        V = simulate_held(rp.theta, t, d["u_ref"], d["w_ref"], segs, V0, delay,
                           commands == "linear")
    fit = {"u": nrmse_fit(d["u"], V[:, 0]), "w": nrmse_fit(d["w"], V[:, 1])}
    rmse = {"u": float(np.sqrt(np.mean((d["u"] - V[:, 0]) ** 2))),
            "w": float(np.sqrt(np.mean((d["w"] - V[:, 1]) ** 2)))}
    return ValidationReport(theta=rp, t=t, u=d["u"], w=d["w"], u_sim=V[:, 0],
                            w_sim=V[:, 1], u_ref=d["u_ref"], w_ref=d["w_ref"], fit=fit, rmse=rmse)


@styled
def plot_validation(report: ValidationReport, ax=None):
    """Plot measured and simulated u and w of a :class:`ValidationReport`, and
    their differences.

    The measured trace is drawn over the simulated one (thin and dark), so that
    where they agree the measurement stays visible; below each, the residual
    (measured minus simulated) shows what the model leaves unexplained. Never
    calls ``plt.show()``; works with any backend, including Agg.

    :param report: from :func:`validate`
    :param ax: four matplotlib Axes (u, its residual, w, its residual), or two
        (u, w) for no residual panels; default a new figure with four rows
    :return: the Axes
    """
    if not isinstance(report, ValidationReport):
        raise ValidationError(f"report must be a ValidationReport, got {type(report).__name__}")
    if ax is None:
        import matplotlib.pyplot as plt
        _, ax = plt.subplots(4, 1, sharex=True, figsize=size(2, 0.7), layout="constrained",
                             gridspec_kw={"height_ratios": [3, 1, 3, 1]})
    ax = list(np.ravel(ax))
    if len(ax) not in (2, 4):
        raise ValidationError(f"ax must be four Axes (u, its residual, w, its residual) or "
                              f"two (u, w), got {len(ax)}")
    t = np.asarray(report.t, dtype=float)
    dt = np.diff(t)
    # break the lines at gaps in the log instead of drawing across them
    cut = np.flatnonzero(dt > 5.0 * np.median(dt)) + 1 if dt.size else np.array([], int)

    def broken(y):
        return np.insert(np.asarray(y, dtype=float), cut, np.nan)

    tb = broken(t)
    step = len(ax) // 2
    for a, k, sym, unit in ((ax[0], "u", "u", "m/s"), (ax[step], "w", "\u03c9", "rad/s")):
        measured, simulated = getattr(report, k), getattr(report, f"{k}_sim")
        a.plot(tb, broken(measured), lw=0.6, color="0.15", zorder=3, label="measured")
        a.plot(tb, broken(simulated), lw=1.6, color="C0", alpha=0.8, zorder=2,
               label=f"simulated, \u03b8 = {report.theta.name or 'identified'}")
        a.set_title(f"{sym}: fit {report.fit[k]:.1f} % (NRMSE)", loc="right", fontsize=7,
                    pad=2)
        a.set_ylabel(label(sym, unit))
        ylim_from_data(a)
        if step == 2:
            r = ax[ax.index(a) + 1]
            r.axhline(0.0, lw=0.6, color="0.5")
            r.plot(tb, broken(np.asarray(measured, float) - np.asarray(simulated, float)),
                   lw=0.6, color="C3")
            r.set_ylabel(label(f"{sym} res.", unit))
    ax[-1].set_xlabel(label("t", "s"))
    # one legend for the panels, under them: the data keep the figure's width
    ax[0].figure.legend(*ax[0].get_legend_handles_labels(), loc="outside lower center",
                        ncol=2, frameon=False)
    return ax
