"""One figure style for every figure unidyn writes, and small helpers that apply it.

Sizes are those of a journal page: :data:`COLUMN` (one column, 3.5 in) and
:data:`PAGE` (two columns, 7.0 in) wide, with 8 pt text, so a figure reads at the
width it would be printed at. Axis labels write units one way, ``u (m/s)``
(:func:`label`). Use :func:`style` as a context manager or :func:`styled` as a
decorator around any function that draws::

    from unidyn import figstyle

    with figstyle.style():
        fig, ax = plt.subplots(figsize=figstyle.size(1.0, 0.7))
        ax.plot(t, e)
        ax.set(xlabel=figstyle.label("t", "s"), ylabel=figstyle.label("distance error", "m"))
        figstyle.ylim_from_data(ax, floor=0)
        figstyle.legend(ax)                    # in the emptiest corner
        figstyle.save(fig, "error.png")

    @figstyle.styled                           # the same style for a whole function
    def plot_something(...): ...

For lecture slides, ``figstyle.style("slides")`` draws everything (unidyn's own
plots inside it included) :data:`SLIDES_SCALE` times larger: text, lines and figure
sizes, so a one-column figure fills half a 16:9 slide at a readable size::

    with figstyle.style("slides"):
        unidyn.results.plots.plot_path(result)

Every figure starts from matplotlib's defaults, not from whatever style another
library set (roboticstoolbox's plotting module, which bdsim loads when it runs a
diagram, switches matplotlib to "ggplot" for the whole process).

Log axes get plain tick labels (1, 2, 5, 10, 20) with :func:`plain_log_axis`.
Nothing here shows a figure; everything works headless (``MPLBACKEND=Agg``).
"""

from __future__ import annotations

import contextlib
import contextvars
import functools
import math
import warnings

import numpy as np

__all__ = ["STYLE", "COLUMN", "PAGE", "DPI", "PRESETS", "SLIDES_SCALE", "style", "styled", "size", "label", "as_text", "legend",
           "emptiest_corner", "ylim_from_data", "plain_log_axis", "save", "REFERENCE",
           "START", "QUALITATIVE", "label_time_axis"]

#: Width of one column of a journal page, in.
COLUMN = 3.5
#: Width of a two-column figure, in.
PAGE = 7.0
#: Resolution of the PNG files, dots per inch (a 3.5 in figure is 700 px wide).
DPI = 200

#: matplotlib settings of every unidyn figure.
STYLE = {
    "font.size": 8,
    "axes.titlesize": 8,
    "axes.labelsize": 8,
    "xtick.labelsize": 7,
    "ytick.labelsize": 7,
    "legend.fontsize": 7,
    "legend.frameon": True,
    "legend.framealpha": 0.9,
    "legend.edgecolor": "0.8",
    "legend.handlelength": 2.2,
    "legend.borderaxespad": 0.4,
    "figure.titlesize": 9,
    "lines.linewidth": 1.1,
    "lines.markersize": 4,
    "axes.linewidth": 0.6,
    "axes.grid": True,
    "grid.linewidth": 0.4,
    "grid.alpha": 0.5,
    "axes.spines.top": False,
    "axes.spines.right": False,
    "xtick.major.width": 0.6,
    "ytick.major.width": 0.6,
    # tick labels as plain text: mathtext would parse and lay out every label as TeX
    "axes.formatter.use_mathtext": False,
    "axes.formatter.limits": (-3, 4),
    "figure.dpi": 100,
    "savefig.dpi": DPI,
    "savefig.bbox": None,  # the size asked for: constrained layout fits the content
    "savefig.pad_inches": 0.03,
    "figure.constrained_layout.use": True,
}

#: How the reference path is drawn: thin dashed black, once.
REFERENCE = {"color": "k", "ls": (0, (4, 2)), "lw": 0.8, "zorder": 3}
#: How the start of a path is marked (and named in the legend).
START = {"marker": "o", "ls": "none", "ms": 5, "mfc": "white", "mec": "C3", "mew": 1.2}

#: Six colours told apart by readers with any common colour-vision deficiency and in grey
#: print (Okabe and Ito's palette without its black, the reference's colour, and its
#: yellow, too faint on white), for lines that are one of a fixed set: the i-th of the six
#: parameter estimates is always drawn in the i-th.
QUALITATIVE = ("#0072B2", "#E69F00", "#009E73", "#CC79A7", "#56B4E9", "#D55E00")


#: How much larger the "slides" preset draws than the "paper" one (text 8 -> 14.4 pt,
#: a one-column figure 3.5 -> 6.3 in wide, about half a 13.3 in wide 16:9 slide).
SLIDES_SCALE = 1.8
#: Preset name -> scale of every size in :data:`STYLE` and of :func:`size`.
PRESETS = {"paper": 1.0, "slides": SLIDES_SCALE}

_SIZED = ("font.size", "axes.titlesize", "axes.labelsize", "xtick.labelsize", "ytick.labelsize",
          "legend.fontsize", "figure.titlesize", "lines.linewidth", "lines.markersize",
          "axes.linewidth", "grid.linewidth", "xtick.major.width", "ytick.major.width")
_preset = contextvars.ContextVar("unidyn_figstyle_preset", default="paper")


def _settings(preset: str) -> dict:
    scale = PRESETS[preset]
    return {k: (v * scale if k in _SIZED else v) for k, v in STYLE.items()}


@contextlib.contextmanager
def style(preset: str | None = None):
    """Context manager: unidyn's matplotlib settings (:data:`STYLE`) inside the block,
    on top of matplotlib's defaults. ``preset``: "paper" (journal sizes) or "slides"
    (:data:`SLIDES_SCALE` times larger); by default the enclosing block's preset, so
    unidyn's plot functions called inside ``style("slides")`` draw for slides."""
    import matplotlib
    import matplotlib.style
    preset = _preset.get() if preset is None else preset
    if preset not in PRESETS:
        raise ValueError(f"figure preset must be one of {', '.join(PRESETS)}, got {preset!r}")
    token = _preset.set(preset)
    try:
        with matplotlib.rc_context():
            # matplotlib's defaults first: no setting left by another library leaks in
            # (the backend and interactive mode are left as they are)
            matplotlib.style.use("default")
            matplotlib.rcParams.update(_settings(preset))
            yield
    finally:
        _preset.reset(token)


def styled(fn):
    """Decorator: run ``fn`` inside :func:`style` (with the enclosing block's preset)."""
    @functools.wraps(fn)
    def wrapper(*args, **kwargs):
        with style():
            return fn(*args, **kwargs)
    return wrapper


def size(width=1.0, aspect=0.75):
    """Figure size (w, h) in inches: ``width`` in columns (1: :data:`COLUMN`, 2: :data:`PAGE`)
    and height = ``aspect`` x width; scaled by the preset of the enclosing :func:`style`."""
    w = COLUMN if width == 1 else (PAGE if width == 2 else float(width) * COLUMN)
    w *= PRESETS[_preset.get()]
    return (w, w * aspect)


def label(name: str, unit: str | None = None) -> str:
    """An axis label in the one notation used everywhere: ``"u (m/s)"``; no unit: ``"u"``."""
    return f"{name} ({unit})" if unit else name


def label_time_axis(ax, name: str = "t", unit: str = "s") -> None:
    """Label the x axis of ``ax`` (``"t (s)"``) where its tick numbers are shown: under
    axes stacked on a shared x axis, only the bottom one shows them, and a label over an
    axis without numbers reads as a time axis that lost them."""
    if ax.xaxis.get_tick_params().get("labelbottom", True):
        ax.set_xlabel(label(name, unit))
    else:
        ax.set_xlabel("")


def _data_points(ax):
    """Every plotted point of ``ax`` in axes coordinates (0..1), lines densified."""
    to_axes = ax.transData + ax.transAxes.inverted()
    pts = []
    for line in ax.get_lines():
        xy = np.asarray(line.get_xydata(), dtype=float)
        xy = xy[np.all(np.isfinite(xy), axis=1)]
        if len(xy) == 0:
            continue
        if len(xy) > 1 and line.get_linestyle() not in ("None", "none", "", " "):
            # points along the segments, so that a long straight segment counts
            seg = np.linspace(0, 1, 6)[:-1, None, None]
            xy = (xy[:-1][None] * (1 - seg) + xy[1:][None] * seg).reshape(-1, 2)
        pts.append(to_axes.transform(xy))
    for coll in ax.collections:
        offs = np.asarray(coll.get_offsets(), dtype=float)
        if offs.size:
            pts.append(to_axes.transform(offs))
    return np.vstack(pts) if pts else np.zeros((0, 2))


_CORNERS = ("upper right", "upper left", "lower left", "lower right")


def emptiest_corner(ax, box=(0.4, 0.3)):
    """The corner of ``ax`` (a matplotlib ``loc`` string) whose ``box`` (width,
    height in axes fractions) holds the fewest plotted points."""
    pts = _data_points(ax)
    w, h = box
    best, best_n = _CORNERS[0], math.inf
    for loc in _CORNERS:
        x_ok = pts[:, 0] >= 1 - w if "right" in loc else pts[:, 0] <= w
        y_ok = pts[:, 1] >= 1 - h if "upper" in loc else pts[:, 1] <= h
        n = int(np.count_nonzero(x_ok & y_ok))
        if n < best_n:
            best, best_n = loc, n
    return best, best_n


def as_text(text: str, limit: int = 60) -> str:
    """A user's label (a scenario's name, a variant's label) as matplotlib text: on one
    line, shown as written (a ``$`` starts no mathtext), at most ``limit`` characters."""
    text = " ".join(str(text).split())
    text = text if len(text) <= limit else text[:limit - 3] + "..."
    return text.replace("$", r"\$")


def _measure(fig) -> None:
    """Put the axes of ``fig`` where a draw puts them (its layout engine, if any, then
    each axes' aspect), for measuring its artists without drawing them. A legend wider
    than its axes, placed only to be measured, can leave constrained layout no room for
    a moment; its warning is not the user's concern."""
    engine = fig.get_layout_engine()
    if engine is not None:
        with warnings.catch_warnings():
            warnings.filterwarnings("ignore", "constrained_layout not applied")
            engine.execute(fig)
    for ax in fig.axes:
        ax.apply_aspect()


def legend(ax, *, outside=None, fallback="right", **kwargs):
    """Place the legend of ``ax`` where it hides no data.

    ``outside``: ``"right"`` or ``"below"`` put it outside the axes; ``None``
    (default) puts it in the corner of the axes that holds no plotted point,
    measured with the legend's own size, and outside (``fallback``: ``"right"``
    or ``"below"``) when every corner holds data.
    """
    if outside == "right":
        return ax.legend(loc="upper left", bbox_to_anchor=(1.02, 1.0), borderaxespad=0, **kwargs)
    if outside == "below":
        ncol = kwargs.pop("ncol", 1)
        fig = ax.figure
        from matplotlib.layout_engine import ConstrainedLayoutEngine
        if fig.axes == [ax] and isinstance(fig.get_layout_engine(), ConstrainedLayoutEngine):
            # the figure's own legend, which constrained layout puts under the x label
            # (standing for the axis' legend: one placed here before is replaced)
            for old in [g for g in fig.legends if getattr(g, "_unidyn_below", False)]:
                old.remove()
            if ax.get_legend() is not None:
                ax.get_legend().remove()
            handles, labels = ax.get_legend_handles_labels()

            def below(**extra):
                return fig.legend(handles, labels, loc="outside lower center", ncol=ncol,
                                  frameon=False, **kwargs, **extra)
            leg = below()
            try:  # wider than the figure: smaller type, down to 5 pt
                _measure(fig)
                width = leg.get_window_extent().width
                if width > 0.98 * fig.bbox.width and "fontsize" not in kwargs:
                    size = leg.get_texts()[0].get_fontsize() * 0.94 * fig.bbox.width / width
                    leg.remove()
                    leg = below(fontsize=max(size, 5.0))
            except Exception:  # pragma: no cover - backends without a renderer
                pass
            leg._unidyn_below = True
            return leg
        leg = ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.2), ncol=ncol,
                        borderaxespad=0, frameon=False, **kwargs)
        try:  # just under the axis' tick labels and x label, once the layout has settled
            for _ in range(4):
                _measure(fig)
                under = ax.xaxis.get_tightbbox().transformed(ax.transAxes.inverted()).y0
                y = min(under, 0.0) - 0.03
                if abs(y - leg.get_bbox_to_anchor().transformed(
                        ax.transAxes.inverted()).y0) < 1e-3:
                    break
                leg.set_bbox_to_anchor((0.5, y), transform=ax.transAxes)
        except Exception:  # pragma: no cover - backends without a renderer
            pass
        return leg
    leg = ax.legend(loc="upper right", **kwargs)
    fig = ax.figure
    try:
        renderer = fig.canvas.get_renderer()
        _measure(fig)
        lb = leg.get_window_extent(renderer).transformed(ax.transAxes.inverted())
        box = (lb.width + 0.03, lb.height + 0.03)
    except Exception:  # pragma: no cover - backends without a renderer
        box = (0.4, 0.3)
    loc, n = emptiest_corner(ax, box)
    leg.remove()
    if n > 0 or box[0] > 0.75 or box[1] > 0.75:  # no free corner, or no room beside it
        return legend(ax, outside=fallback, **kwargs)
    return ax.legend(loc=loc, **kwargs)


def ylim_from_data(ax, *, floor=None, pad=0.06, lines=None):
    """Set the y-limits of ``ax`` to its data (or ``lines``) plus ``pad`` of the range on
    each side; ``floor`` (e.g. 0 for an error) fixes the lower limit."""
    ys = [np.asarray(l.get_ydata(), dtype=float) for l in (lines or ax.get_lines())]
    ys = [y[np.isfinite(y)] for y in ys if np.size(y)]
    ys = [y for y in ys if y.size]
    if not ys:
        return ax.get_ylim()
    lo = min(float(y.min()) for y in ys)
    hi = max(float(y.max()) for y in ys)
    if floor is not None:
        lo = floor
    span = hi - lo if hi > lo else max(abs(hi), 1.0) * 0.1
    ax.set_ylim(lo if floor is not None else lo - pad * span, hi + pad * span)
    return ax.get_ylim()


def _plain(v, _pos=None):
    if v <= 0:
        return ""
    return f"{v:g}" if 1e-3 <= v < 1e5 else f"{v:.0e}"


def plain_log_axis(ax, axis="y", subs=(1.0, 2.0, 5.0)):
    """Log scale on ``axis`` with plain tick labels at 1, 2, 5, 10, 20, ... (no
    ``6x10^0`` labels); unlabelled minor ticks in between."""
    from matplotlib.ticker import FuncFormatter, LogLocator, NullFormatter
    a = ax.yaxis if axis == "y" else ax.xaxis
    (ax.set_yscale if axis == "y" else ax.set_xscale)("log")
    a.set_major_locator(LogLocator(base=10, subs=subs))
    a.set_major_formatter(FuncFormatter(_plain))
    a.set_minor_locator(LogLocator(base=10, subs=np.arange(1, 10)))
    a.set_minor_formatter(NullFormatter())


def save(fig, path, dpi=DPI):
    """Write ``fig`` to ``path`` (PNG) through a temporary file and a rename
    (:func:`unidyn.results.folders.write_file`), so an interrupted write never leaves a
    half-written figure; a full disk names the file. Closes the figure. Returns the
    path."""
    import matplotlib.pyplot as plt

    from .ownership import write_file
    try:
        return write_file(path, lambda tmp: fig.savefig(tmp, dpi=dpi))
    finally:
        plt.close(fig)
