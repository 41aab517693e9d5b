"""A sweep's figure: a metric of its runs against its first numeric axis
(``metrics.png`` of :func:`unidyn.sweeps.sweep.run_sweep`), over seeds its mean with a
standard-error band; and the mean error of one scenario over seeds (``error.png`` of
:class:`unidyn.sweeps.seeds.SeedRuns`)."""

from __future__ import annotations

import math

import numpy as np

from .._validate import choice
from ..model.metrics import BY_NAME
from ..results import figstyle
from .statistics import mean_std_sem
from .sweep_files import METRICS, is_number, text

__all__ = ["plot_metrics", "plot_seed_error", "colours"]


def colours(n: int) -> list:
    """``n`` colours, none repeated: matplotlib's ten-colour cycle up to ten lines,
    the twenty of ``tab20`` up to twenty, then a sequential map."""
    import matplotlib
    if n <= 10:
        return [f"C{k}" for k in range(n)]
    if n <= 20:
        cmap = matplotlib.colormaps["tab20"]
        return [cmap(k) for k in range(n)]
    cmap = matplotlib.colormaps["viridis"]
    return [cmap(k / (n - 1)) for k in range(n)]


def _numeric_axis(sweep, exclude=None):
    for a in sweep.grid:
        if a != exclude and all(is_number(v) for v in sweep.grid[a]):
            return a
    return None


def _words(field: str, value) -> str:
    """A field and its value as a reader says them (plain text, no mathtext: a legend
    entry is shown as written): ``"θ̂(0)/θ = 0.9"``, ``"adaptation on at 0 s"``,
    ``"gamma = [1, 1, 1, 1, 1, 1]"``."""
    name, unit = _FIELD_WORDS.get(field, (field, ""))
    value = text(value)
    return (f"{name} {value}" if name.endswith(" at") else f"{name} = {value}") \
        + (f" {unit}" if unit else "")


def _legend_entry(sweep, axes, key) -> str:
    """A line of a sweep's figure in its legend: what tells it from the others first
    (its variant's label, the other axes' values), then the numbers its variant sets (its
    case is what its label names), in a reader's words: ``"b: θ̂(0)/θ = 0.9"``,
    ``"b, a = 0.15 m: θ̂(0)/θ = 0.9"``."""
    parts, sets = [], []
    for a, k in zip(axes, key):
        if a != "variant":
            parts.append(_words(a, k))
            continue
        parts.append(k)
        for v in sweep.variants:
            if text(v["label"]) == k:
                sets = [_words(f, x) for f, x in v.items() if f not in ("label", "case")]
    return ", ".join(parts) + (": " + ", ".join(sets) if sets else "")


#: The largest axis value drawn as such (matplotlib cannot place ticks near the largest
#: float); a sweep with larger values is drawn against its point index.
_LARGEST_X = 1e100


def plot_metrics(sweep, rows, path, metric: str = "iae"):
    """IAE (or another metric) against the first numeric axis, one line per combination
    of the other axes (a variant by its label and what it sets), each in its own colour;
    log scale with plain tick labels when the values span more than a decade. A sweep
    whose grid varies ``seed`` draws one line per combination of the axes other than
    the seed: the mean over the seeds whose run completed, shaded ± its standard
    error (:func:`unidyn.sweeps.statistics.mean_std_sem`). In unidyn's figure style
    (:mod:`unidyn.results.figstyle`).

    :param path: the PNG written (the figure closed); ``None``: the figure is returned"""
    import matplotlib.pyplot as plt

    choice("metric", metric, METRICS)
    x_axis = _numeric_axis(sweep, exclude="seed")
    if x_axis and not all(abs(float(r[x_axis])) < _LARGEST_X for r in rows):
        x_axis = None  # beyond what an axis can place ticks on: against the point index
    seeds = "seed" in sweep.axes and x_axis is not None
    others = [a for a in sweep.axes if a != x_axis and not (seeds and a == "seed")]
    lines = {}
    for r in rows:
        key = tuple(text(r[a]) for a in others)
        x = r[x_axis] if x_axis else r["index"]
        y = r[metric] if r["complete"] and r[metric] is not None else math.nan
        lines.setdefault(key, {}).setdefault(x, []).append(y)
    n_seeds = max((len(ys) for pts in lines.values() for ys in pts.values()), default=1)
    legend = 1 < len(lines) <= 12
    with figstyle.style():
        # taller by the legend's lines, which go below the axes if no corner is free
        fig, ax = plt.subplots(figsize=figstyle.size(1, 0.75 + 0.05 * len(lines) * legend))
        for (key, pts), colour in zip(lines.items(), colours(len(lines))):
            xs = sorted(pts)
            label = figstyle.as_text(_legend_entry(sweep, others, key), limit=64) or None
            if seeds:  # the mean over the seeds that completed, ± its standard error
                stats = [mean_std_sem([y for y in pts[x] if not math.isnan(y)]) for x in xs]
                ys = np.array([math.nan if m is None else m for m, _, _ in stats])
                se = np.array([0.0 if e is None else e for _, _, e in stats])
                ax.fill_between(xs, ys - se, ys + se, color=colour, alpha=0.25, lw=0)
            else:
                ys = [pts[x][0] for x in xs]
            ax.plot(xs, ys, "o-" if len(xs) < 30 else "-", ms=3, color=colour, label=label)
        vals = np.array([r[metric] for r in rows if r["complete"] and r[metric] is not None],
                        dtype=float)
        vals = vals[np.isfinite(vals)]
        if vals.size and vals.min() > 0 and vals.max() / vals.min() > 10:
            figstyle.plain_log_axis(ax, "y")
        elif vals.size:
            figstyle.ylim_from_data(ax, floor=0 if vals.min() >= 0 else None)
        ax.set_xlabel(_AXIS_LABELS.get(x_axis, x_axis) if x_axis else "point index")
        ax.set_ylabel(f"{BY_NAME[metric].label} ({BY_NAME[metric].unit})")
        ax.set_title((figstyle.as_text(sweep.name) or "sweep")
                     + (f"\nmean ± standard error over {n_seeds} noise seeds" if seeds else ""))
        ax.grid(True, which="major")
        if legend:
            figstyle.legend(ax, fallback="below")
        return fig if path is None else figstyle.save(fig, path)


@figstyle.styled
def plot_seed_error(runs, ax=None):
    """The distance error |h_d - h| against time over noise seeds
    (:class:`unidyn.sweeps.seeds.SeedRuns`): each seed's run thin and grey, their mean
    over the seeds whose run completed, shaded ± its standard error at each sample
    (:func:`unidyn.sweeps.statistics.mean_std_sem`)."""
    from ..results.plots import run_title
    if ax is None:
        import matplotlib.pyplot as plt
        _, ax = plt.subplots(figsize=figstyle.size(1, 0.7))
    done = [r for r in runs.results if r.complete]
    for k, r in enumerate(done):
        ax.plot(r.t, r.error, color="0.65", lw=0.4, label="each seed" if k == 0 else None)
    if done:
        t = done[0].t
        mean, _, se = mean_std_sem(np.array([r.error for r in done], dtype=float))
        if se is not None:
            ax.fill_between(t, mean - se, mean + se, color="C0", alpha=0.35, lw=0,
                            label="± standard error of the mean")
        ax.plot(t, mean, color="C0", lw=1.0, label=f"mean over {len(done)} seeds")
        ax.set_xlim(t[0], t[-1])
    else:
        ax.text(0.5, 0.5, "no run completed", transform=ax.transAxes, ha="center")
    ax.set_xlabel(figstyle.label("t", "s"))
    ax.set_ylabel(figstyle.label("distance error", "m"))
    figstyle.ylim_from_data(ax, floor=0)
    # the run's title, its seed the seeds
    title = run_title(runs.scenario).rpartition(", noise seed")[0]
    ax.set_title(f"{title}, noise seeds {_seed_range(runs.seeds)}", fontsize=7)
    if done:
        figstyle.legend(ax, fallback="below", ncol=3)
    return ax


def _seed_range(seeds) -> str:
    seeds = list(seeds)
    if seeds == list(range(seeds[0], seeds[0] + len(seeds))) and len(seeds) > 2:
        return f"{seeds[0]}-{seeds[-1]}"
    return ", ".join(map(str, seeds[:6])) + (", ..." if len(seeds) > 6 else "")


#: Axis labels of the special sweep keys and common numeric fields.
_AXIS_LABELS = {"kxy": "$k_x = k_y$ (1/s)", "kx": "$k_x$ (1/s)", "ky": "$k_y$ (1/s)",
                "ku": "$k_u$ (1/s)", "kw": "$k_\\omega$ (1/s)", "a": "a (m)", "T": "T (s)",
                "theta_hat_scale": "$\\hat\\theta(0)\\,/\\,\\theta$",
                "adapt_from": "adaptation on at (s)", "seed": "noise seed"}
#: How a legend names a field: (words, unit).
_FIELD_WORDS = {"kxy": ("kx = ky", "1/s"), "kx": ("kx", "1/s"), "ky": ("ky", "1/s"),
                "ku": ("ku", "1/s"), "kw": ("kω", "1/s"), "a": ("a", "m"), "T": ("T", "s"),
                "theta_hat_scale": ("θ̂(0)/θ", ""), "adapt_from": ("adaptation on at", "s"),
                "seed": ("noise seed", "")}
