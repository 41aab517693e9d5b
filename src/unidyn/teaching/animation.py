r"""Animations of a run: the robot driving along its path, written as a GIF or MP4 file.

:func:`animate` draws, frame by frame, the reference path, the robot (a triangle
at the wheel-axle centre B pointing along the heading psi, and a dot at the
point of interest h, a metres ahead of B) and the trail of h. It works
headless: the figure is drawn by matplotlib's Agg renderer whatever the active
backend, and nothing is shown. GIFs are written with Pillow (a dependency of
matplotlib), MP4 files with ffmpeg when it is installed.

It accepts a :class:`~unidyn.Result`, a :class:`Motion` (poses from any
source, e.g. a bdsim run of a toolbox diagram), or a list of them to draw
several robots on one set of axes::

    from unidyn.teaching.animation import animate, Motion
    animate(unidyn.simulate(unidyn.Scenario.paper(4, T=60)), "adaptive.gif")
    animate([Motion(out1.t, out1.x[:, :3], label="UNICYCLE"),
             Motion(out2.t, out2.x[:, :3], label="DYNAMICUNICYCLE")], "both.gif")

In a notebook, ``IPython.display.Image(filename=animate(...))`` shows the GIF
(or use :func:`show`).
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from numbers import Integral
from pathlib import Path

import numpy as np

from .._validate import ValidationError, flag, positive, real, vector
from ..results.figstyle import as_text
from ..results.ownership import write_file

__all__ = ["Motion", "animate", "show", "DEFAULT_MAX_FRAMES", "MAX_FRAMES", "SUFFIXES"]

#: Without ``frames`` or ``speedup``, an animation has at most this many frames:
#: it plays in real time when that fits, and faster otherwise.
DEFAULT_MAX_FRAMES = 200
#: Hard limit on the number of frames (ask for a larger ``speedup`` instead).
MAX_FRAMES = 5000
#: File types :func:`animate` writes.
SUFFIXES = (".gif", ".mp4")


@dataclass(frozen=True)
class Motion:
    r"""The poses of one robot over time, ready to animate.

    :param t: sample times, s, shape (N,), non-decreasing
    :type t: array_like(N)
    :param pose: (x, y, psi) of the point of interest h at each time, m and rad, shape (N, 3)
        (extra columns, e.g. the velocities of a full state vector, are ignored)
    :type pose: array_like(N, 3)
    :param reference: the desired position h_d at each time, m, shape (N, 2), optional
    :type reference: array_like(N, 2) or None
    :param a: distance from the wheel-axle centre B to h along the heading, m, >= 0
        (0 for the toolbox's ``UNICYCLE``, whose pose is that of B)
    :type a: float
    :param label: legend entry
    :type label: str
    """

    t: np.ndarray
    pose: np.ndarray
    reference: np.ndarray | None = None
    a: float = 0.0
    label: str = ""

    def __post_init__(self):
        t = np.asarray(self.t, dtype=float).reshape(-1)
        if t.size == 0 or not np.all(np.isfinite(t)):
            raise ValidationError("Motion.t must be a non-empty vector of finite times")
        if np.any(np.diff(t) < 0):
            raise ValidationError("Motion.t must be non-decreasing")
        pose = _matrix("Motion.pose", self.pose, len(t), 3)
        ref = None if self.reference is None else _matrix("Motion.reference", self.reference,
                                                          len(t), 2)
        object.__setattr__(self, "t", t)
        object.__setattr__(self, "pose", pose)
        object.__setattr__(self, "reference", ref)
        object.__setattr__(self, "a", real("Motion.a", self.a, low=0.0))
        if not isinstance(self.label, str):
            raise ValidationError(f"Motion.label must be a string, got {self.label!r}")

    @classmethod
    def from_result(cls, result, label: str | None = None) -> "Motion":
        """The motion of a :class:`~unidyn.Result` (h, its reference, and the scenario's a)."""
        sc = getattr(result, "scenario", None)
        a = getattr(sc, "a", 0.0) if sc is not None else 0.0
        if label is None:  # the scenario's name as written (a $ in it starts no mathtext)
            label = (as_text(getattr(sc, "name", "") or getattr(sc, "case", ""))
                     if sc is not None else "")
        return cls(result.t, result.pose, getattr(result, "reference", None), a, label)

    def at(self, times) -> tuple[np.ndarray, np.ndarray | None]:
        """Pose (and reference) interpolated at ``times`` (held constant outside the run).
        The heading is interpolated unwrapped, so a turn through +-pi stays smooth."""
        times = np.asarray(times, dtype=float)
        if len(self.t) == 1:
            pose = np.repeat(self.pose, len(times), axis=0)
            ref = None if self.reference is None else np.repeat(self.reference, len(times), axis=0)
            return pose, ref
        psi = np.unwrap(self.pose[:, 2])
        pose = np.column_stack([np.interp(times, self.t, self.pose[:, 0]),
                                np.interp(times, self.t, self.pose[:, 1]),
                                np.interp(times, self.t, psi)])
        ref = None
        if self.reference is not None:
            ref = np.column_stack([np.interp(times, self.t, self.reference[:, i]) for i in (0, 1)])
        return pose, ref


def _matrix(name, value, n, cols):
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise ValidationError(f"{name} must be a numeric array of shape ({n}, {cols})") from None
    if arr.ndim == 1 and cols == 3 and arr.shape[0] >= 3 and n == 1:
        arr = arr.reshape(1, -1)
    if arr.ndim != 2 or arr.shape[0] != n or arr.shape[1] < cols:
        raise ValidationError(f"{name} must have shape ({n}, {cols}), got {arr.shape}")
    arr = arr[:, :cols]
    if not np.all(np.isfinite(arr)):
        raise ValidationError(f"{name} contains NaN or infinite values")
    return arr


def _motions(result) -> list:
    items = list(result) if isinstance(result, (list, tuple)) else [result]
    if not items:
        raise ValidationError("nothing to animate: the list of results is empty")
    out = []
    for item in items:
        if isinstance(item, Motion):
            out.append(item)
        elif hasattr(item, "t") and hasattr(item, "pose"):
            out.append(Motion.from_result(item))
        else:
            raise ValidationError(
                "result must be a unidyn.Result, a unidyn.teaching.animation.Motion, or a list of them; "
                f"got {type(item).__name__}")
    return out


def _frame_count(duration, fps, speedup, frames) -> int:
    if frames is not None and speedup is not None:
        raise ValidationError("give either frames or speedup, not both")
    if frames is not None:
        if isinstance(frames, bool) or not isinstance(frames, Integral) or frames < 1:
            raise ValidationError(f"frames must be an integer >= 1, got {frames!r}")
        n = int(frames)
    elif speedup is not None:
        speedup = positive("speedup", speedup)
        n = int(math.floor(duration * fps / speedup + 1e-9)) + 1
    else:
        n = min(DEFAULT_MAX_FRAMES, int(math.floor(duration * fps + 1e-9)) + 1)
    if n > MAX_FRAMES:
        raise ValidationError(
            f"the animation would have {n} frames (more than {MAX_FRAMES}); "
            "use a larger speedup or fewer frames")
    return n


def _body(L):
    """The robot's outline in its own frame (x forward), centred on the axle."""
    return np.array([[0.6 * L, 0.0], [-0.4 * L, 0.35 * L], [-0.4 * L, -0.35 * L]])


def animate(result, path, fps=20, speedup=None, trail=True, frames=None, *, robot_size=None,
            reference=True, dpi=100, figsize=(5.5, 5.6), title=None) -> Path:
    r"""Write an animation of one or more runs to ``path`` (``.gif`` or ``.mp4``).

    Each frame shows the reference path (dashed) and the current desired
    position (x), the robot as a triangle at its wheel-axle centre
    :math:`B = h - a(\cos\psi, \sin\psi)` pointing along :math:`\psi`, the
    point of interest h (dot) and the trail of h. Frames are evenly spaced from
    the first to the last sample; poses between samples are interpolated.

    Number of frames: ``frames`` if given; else, with ``speedup`` (simulated
    seconds per second of playback), about ``duration * fps / speedup``; else
    real time if that takes at most :data:`DEFAULT_MAX_FRAMES` (200) frames, and
    otherwise 200 frames spread over the whole run. A GIF has exactly that many
    frames: the time stamp in the title makes every frame distinct (except for a
    run of zero duration, whose identical frames the GIF writer merges).

    :param result: a :class:`~unidyn.Result`, a :class:`Motion`, or a list of them
    :type result: Result, Motion or list
    :param path: output file, ending in ``.gif`` (Pillow) or ``.mp4`` (needs ffmpeg);
        its folder must exist; an existing file is replaced
    :type path: str or os.PathLike
    :param fps: frames per second of playback, > 0, defaults to 20
    :type fps: float
    :param speedup: simulated seconds per second of playback, > 0; exclusive with ``frames``
    :type speedup: float, optional
    :param trail: draw the path of h so far (True), none (False), or only its last
        ``trail`` seconds (a number > 0)
    :type trail: bool or float
    :param frames: number of frames, integer >= 1; exclusive with ``speedup``
    :type frames: int, optional
    :param robot_size: length of the drawn robot, m, > 0; default 9 % of the drawing's extent
    :type robot_size: float, optional
    :param reference: draw the reference path when the run has one, defaults to True
    :type reference: bool
    :param dpi: resolution, dots per inch, > 0, defaults to 100
    :type dpi: float
    :param figsize: figure size (width, height), inches, defaults to (5.5, 5.6)
    :type figsize: array_like(2)
    :param title: text shown before the time stamp, defaults to none
    :type title: str, optional
    :return: the path written
    :rtype: pathlib.Path
    :raises ValidationError: for a bad argument, an unsupported suffix, a missing
        folder, or ``.mp4`` without ffmpeg
    """
    from matplotlib import animation as mpl_animation

    motions = _motions(result)
    path, fps, trail_len, robot_size, reference, dpi, figsize = _checked_options(
        path, fps, trail, robot_size, reference, dpi, figsize, title)
    suffix = path.suffix.lower()
    if suffix == ".mp4" and not mpl_animation.writers.is_available("ffmpeg"):
        raise ValidationError("writing .mp4 needs ffmpeg, which was not found; "
                              "install ffmpeg or write a .gif")
    times, decimals = _frame_times(motions, fps, speedup, frames)
    t0, t1 = times[0], times[-1]
    # poses at the frame times, and a dense copy for the trails
    frames_at = [m.at(times) for m in motions]
    dense_t = np.union1d(times, np.concatenate([m.t for m in motions]))
    dense_t = dense_t[(dense_t >= t0) & (dense_t <= t1)]
    dense = [m.at(dense_t)[0] for m in motions]

    fig, ax, L = _figure(motions, reference, robot_size, figsize, dpi)
    body = _body(L)
    drawn_refs, ref_marks = _draw_references(ax, motions, reference)
    artists = _draw_robots(ax, motions, body)
    _legend(ax, motions, bool(drawn_refs))
    stamp = ax.set_title("")
    dynamic = [stamp] + [a for group in artists for a in group] + [m for m in ref_marks if m]

    def update(i, tf):
        for k, (m, (pose, ref)) in enumerate(zip(motions, frames_at)):
            line, poly, stick, dot = artists[k]
            x, y, psi = pose[i]
            c, s = math.cos(psi), math.sin(psi)
            bx, by = x - m.a * c, y - m.a * s
            poly.set_xy(body @ np.array([[c, s], [-s, c]]) + [bx, by])
            stick.set_data([bx, x], [by, y])
            dot.set_data([x], [y])
            if trail_len > 0:
                sel = (dense_t <= tf) & (dense_t >= tf - trail_len)
                line.set_data(dense[k][sel, 0], dense[k][sel, 1])
            if ref_marks[k] is not None:
                ref_marks[k].set_data([ref[i, 0]], [ref[i, 1]])
        text = f"t = {tf:.{decimals}f} s"
        stamp.set_text(f"{title}   {text}" if title else text)

    def write(tmp):
        if suffix == ".gif":
            _write_gif(fig, dynamic, update, times, fps, tmp)
        else:
            writer = mpl_animation.FFMpegWriter(fps=fps)
            with writer.saving(fig, tmp, dpi):
                for i, tf in enumerate(times):
                    update(i, tf)
                    writer.grab_frame()
    write_file(path, write)  # a temporary file beside it, then a rename
    return path


def _checked_options(path, fps, trail, robot_size, reference, dpi, figsize, title):
    """:func:`animate`'s options checked: (path, fps, trail length in s, robot_size,
    reference, dpi, figsize); a bad one raises ValidationError naming it."""
    if not isinstance(path, (str, os.PathLike)):
        raise ValidationError(f"path must be a file name (str or PathLike), got {path!r}")
    path = Path(path)
    if path.suffix.lower() not in SUFFIXES:
        raise ValidationError(f"path must end in .gif or .mp4, got {str(path)!r}")
    if not path.parent.is_dir():
        raise ValidationError(f"the folder of {str(path)!r} does not exist")
    fps = positive("fps", fps)
    if trail is True or trail is False:
        trail_len = math.inf if trail else 0.0
    else:
        trail_len = positive("trail", trail)
    robot_size = None if robot_size is None else positive("robot_size", robot_size)
    reference = flag("reference", reference)
    dpi = positive("dpi", dpi)
    figsize = tuple(vector("figsize", figsize, 2).tolist())
    if min(figsize) <= 0:
        raise ValidationError(f"figsize must be two sizes > 0, got {figsize}")
    if title is not None and not isinstance(title, str):
        raise ValidationError(f"title must be a string, got {title!r}")
    return path, fps, trail_len, robot_size, reference, dpi, figsize


def _frame_times(motions, fps, speedup, frames):
    """The frames' times, evenly spaced over the runs, and the decimals that keep every
    frame's time stamp distinct."""
    t0 = min(m.t[0] for m in motions)
    t1 = max(m.t[-1] for m in motions)
    n = _frame_count(t1 - t0, fps, speedup, frames)
    times = np.linspace(t0, t1, n) if n > 1 else np.array([t1])
    step = (t1 - t0) / (n - 1) if n > 1 else 1.0
    decimals = 1 if step <= 0 else min(12, max(1, math.ceil(-math.log10(step))))
    return times, decimals


def _figure(motions, reference, robot_size, figsize, dpi):
    """The figure and its axes, showing every path (and reference) with room for the
    robot drawn ``L`` m long at their ends: (fig, ax, L)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    pts = [m.pose[:, :2] for m in motions]
    if reference:
        pts += [m.reference for m in motions if m.reference is not None]
    pts = np.vstack(pts)
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    span = float(max(hi - lo))
    L = robot_size if robot_size is not None else (0.09 * span if span > 0 else 0.3)
    margin = 0.6 * L + max(m.a for m in motions) + 0.05 * span

    fig = Figure(figsize=figsize, dpi=dpi)
    FigureCanvasAgg(fig)
    left, right, bottom, top = 0.14, 0.96, 0.27, 0.93
    fig.subplots_adjust(left=left, right=right, top=top, bottom=bottom)
    ax = fig.add_subplot(1, 1, 1)
    # the view: the drawing plus margins, widened in x or y to the shape of the axes so
    # that equal scales fill them
    lo, hi = lo - margin, hi + margin
    box = (figsize[1] * (top - bottom)) / (figsize[0] * (right - left))  # height / width
    width, height = hi - lo
    centre = (lo + hi) / 2
    if height < box * width:
        height = box * width
    else:
        width = height / box
    ax.set_xlim(centre[0] - width / 2, centre[0] + width / 2)
    ax.set_ylim(centre[1] - height / 2, centre[1] + height / 2)
    ax.set_aspect("equal", adjustable="box")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.grid(alpha=0.3)
    return fig, ax, L


def _draw_references(ax, motions, reference):
    """Each distinct reference path, once, and a mark per run for its moving desired
    position (None where the run draws none): (references drawn, marks)."""
    drawn_refs = []
    ref_marks = []
    for m in motions:
        if not reference or m.reference is None:
            ref_marks.append(None)
            continue
        if any(r.shape == m.reference.shape and np.array_equal(r, m.reference)
               for r in drawn_refs):
            ref_marks.append(None)
            continue
        drawn_refs.append(m.reference)
        ax.plot(m.reference[:, 0], m.reference[:, 1], "k--", lw=0.8,
                label="reference" if len(drawn_refs) == 1 else None)
        (mark,) = ax.plot([], [], "x", color="k", ms=9, mew=1.8, zorder=6)
        ref_marks.append(mark)
    return drawn_refs, ref_marks


def _draw_robots(ax, motions, body):
    """Each run's moving artists, empty until a frame places them: (trail, body,
    stick from the axle to h, point h)."""
    from matplotlib.patches import Polygon

    artists = []
    for k, m in enumerate(motions):
        color = f"C{k}"
        (line,) = ax.plot([], [], "-", color=color, lw=1.2, label=m.label or None)
        poly = Polygon(body, closed=True, fc=color, ec="k", lw=0.6, alpha=0.85, zorder=3)
        ax.add_patch(poly)
        (stick,) = ax.plot([], [], "-", color="k", lw=0.8, zorder=4)
        (dot,) = ax.plot([], [], "o", color="k", mfc="white", mew=1.2, ms=6, zorder=5)
        artists.append((line, poly, stick, dot))
    return artists


def _legend(ax, motions, with_reference):
    """Every marker explained, under the axes: the reference and its moving point, each
    robot's trail, and (once) what the triangle and the dot are."""
    from matplotlib.lines import Line2D
    handles = []
    if with_reference:
        handles.append(Line2D([], [], color="k", ls="--", lw=0.8, label="reference"))
        handles.append(Line2D([], [], ls="none", marker="x", color="k", ms=8, mew=1.8,
                              label="desired position $h_d(t)$"))
    for k, m in enumerate(motions):
        if m.label:
            handles.append(Line2D([], [], color=f"C{k}", lw=1.2, label=f"path of h: {m.label}"))
    handles.append(Line2D([], [], ls="none", marker=(3, 0, -90), ms=9, mfc="C0", mec="k",
                          mew=0.6, label="robot (axle centre, heading)"))
    handles.append(Line2D([], [], ls="none", marker="o", color="k", mfc="white", mew=1.2, ms=6,
                          label="point h"))
    ax.legend(handles=handles, loc="upper center", bbox_to_anchor=(0.5, -0.12), ncol=2,
              fontsize=8, frameon=False, handletextpad=0.4, columnspacing=1.0)


def _write_gif(fig, dynamic, update, times, fps, filename):
    """Render the frames by blitting (the axes, ticks and reference are drawn once;
    each frame redraws only the moving artists) and write them with Pillow, as
    matplotlib's PillowWriter does, on one shared palette."""
    from PIL import Image

    canvas = fig.canvas
    for a in dynamic:
        a.set_animated(True)
    canvas.draw()
    background = canvas.copy_from_bbox(fig.bbox)
    size = canvas.get_width_height()

    def render(i, tf):
        update(i, tf)
        canvas.restore_region(background)
        for a in dynamic:
            fig.draw_artist(a)
        return Image.frombuffer("RGBA", size, canvas.buffer_rgba(), "raw", "RGBA", 0, 1).convert("RGB")

    # one palette for all frames, from the last frame (every robot and its whole trail)
    palette = render(len(times) - 1, times[-1]).quantize(colors=64, method=Image.Quantize.MEDIANCUT)
    images = [render(i, tf).quantize(palette=palette, dither=Image.Dither.NONE)
              for i, tf in enumerate(times)]
    duration = max(10, int(round(1000.0 / fps)))
    images[0].save(filename, format="GIF", save_all=True, append_images=images[1:],
                   duration=duration, loop=0, disposal=1)


def show(result, path="animation.gif", **kwargs):
    """Write an animation with :func:`animate` and return it as an object a notebook
    displays inline: ``IPython.display.Image`` for a GIF, ``IPython.display.Video``
    (embedded) for an MP4. The file's path is the object's ``filename``.

    :param result: as for :func:`animate`
    :param path: output file, defaults to ``animation.gif`` in the working folder
    :param kwargs: any other argument of :func:`animate`
    """
    written = animate(result, path, **kwargs)
    from IPython.display import Image, Video
    if written.suffix.lower() == ".mp4":
        return Video(str(written), embed=True)
    return Image(filename=str(written))
