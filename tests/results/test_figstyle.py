"""The figure style: periods of the references, plain log tick labels, legends that hide
no data, y-limits from the data, per-component theta_hat panels, file modes."""

import math
import os
import sys
import warnings
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402

import unidyn  # noqa: E402
from unidyn.model.trajectories import Circle, FigureEight, Line  # noqa: E402
from unidyn.results import figstyle  # noqa: E402
from unidyn.results.plots import (  # noqa: E402
    plot_error,
    plot_theta_hat,
    reference_once,
    reference_period,
    save_figures,
)

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


def _umask():
    m = os.umask(0)
    os.umask(m)
    return m


@pytest.fixture(scope="module")
def adaptive_run():
    """The paper's simulation 4 over 130 s (adaptation from t = 100 s), batch engine."""
    return unidyn.simulate_batch([unidyn.Scenario.paper(4, T=130)])[0]


def test_reference_periods_are_the_analytic_ones():
    assert reference_period(FigureEight()) == pytest.approx(8 * math.pi)        # lcm(4 pi, 8 pi)
    # sin(0.5 t) has period 4 pi, cos(0.3 t) 20 pi / 3: together 20 pi
    assert reference_period(FigureEight(wx=0.5, wy=0.3)) == pytest.approx(20 * math.pi)
    assert reference_period(Circle(omega=-0.2)) == pytest.approx(10 * math.pi)
    assert reference_period(Line()) is None
    assert reference_period(FigureEight(wx=1.0, wy=math.sqrt(2))) is None      # not periodic


def test_reference_is_drawn_once_and_closes(adaptive_run):
    xy, period = reference_once(adaptive_run)
    assert period == pytest.approx(8 * math.pi)
    np.testing.assert_allclose(xy[0], xy[-1], atol=1e-12)       # one full period, closed
    # it is the trajectory itself: x = sin(0.5 t), y = cos(0.25 t) - 1
    t = np.linspace(0, period, len(xy))
    np.testing.assert_allclose(xy, np.column_stack([np.sin(0.5 * t), np.cos(0.25 * t) - 1]),
                               atol=1e-12)


def test_plain_log_tick_labels():
    with figstyle.style():
        fig, ax = plt.subplots()
        x = np.linspace(0.5, 35, 70)
        ax.plot(x, 1.3 + 20 * np.exp(-x))
        figstyle.plain_log_axis(ax, "y")
        ax.set_ylim(0.9, 25)
        fig.canvas.draw()
        labels = [t.get_text() for t in ax.get_yticklabels()
                  if 0.9 <= t.get_position()[1] <= 25]
        minor = [t.get_text() for t in ax.yaxis.get_minorticklabels()]
    plt.close(fig)
    assert labels == ["1", "2", "5", "10", "20"]
    assert not any(minor)


def _covered(pts, box):
    """Which display points ``pts`` (N, 2) lie within ``box`` (a matplotlib Bbox)."""
    return (pts[:, 0] >= box.x0) & (pts[:, 0] <= box.x1) & (pts[:, 1] >= box.y0) & (
        pts[:, 1] <= box.y1)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_legend_covers_no_data_point(seed):
    rng = np.random.default_rng(seed)
    with figstyle.style():
        fig, ax = plt.subplots(figsize=figstyle.size(1, 0.75))
        # data filling the whole axes except one random corner
        corner = rng.integers(4)
        x = rng.uniform(0, 1, 400)
        y = rng.uniform(0, 1, 400)
        keep = ~(((x > 0.55) == (corner % 2 == 0)) & ((y > 0.55) == (corner < 2)))
        ax.plot(x[keep], y[keep], "o", ms=2, label="data")
        ax.plot([0, 1], [0.02, 0.02], label="baseline")
        ax.set_xlim(-0.02, 1.02)
        ax.set_ylim(-0.02, 1.02)
        leg = figstyle.legend(ax)
        fig.canvas.draw()
        box = leg.get_window_extent()
        pts = ax.transData.transform(np.column_stack([x[keep], y[keep]]))
    plt.close(fig)
    assert not _covered(pts, box).any()


def test_legend_beside_equal_axes_covers_no_data_point():
    """A path figure's equal axes take their shape when drawn: the legend is measured
    against that shape, not the box constrained layout gives them (a flat path leaves no
    corner where the legend fits, and the legend goes below)."""
    with figstyle.style():
        fig, ax = plt.subplots(figsize=figstyle.size(1, 1.05))
        x = np.linspace(0.0, 0.2, 400)
        y = 0.01 * np.sin(40 * x)
        ax.plot(x, y, label="path of h")
        ax.plot(x[::40], -y[::40], "o", ms=2, label="samples")
        ax.set_aspect("equal", adjustable="box")
        leg = figstyle.legend(ax, fallback="below")
        fig.canvas.draw()
        box = leg.get_window_extent()
        pts = ax.transData.transform(np.column_stack([x, y]))
    plt.close(fig)
    assert not _covered(pts, box).any()


def _overlap(a, b):
    return a.x0 < b.x1 and b.x0 < a.x1 and a.y0 < b.y1 and b.y0 < a.y1


@pytest.mark.parametrize("panels", [1, 2])
def test_a_legend_below_covers_neither_labels_nor_data(panels):
    """Below the axes means below its tick labels and x label too, alone in its figure
    or beside other axes."""
    with figstyle.style():
        fig, axes = plt.subplots(1, panels, figsize=figstyle.size(1, 0.75), squeeze=False)
        ax = axes[0, 0]
        for k in range(4):
            ax.plot([0, 30], [k, k + 1], label=f"{k}: a rather long description, k = {k}")
        ax.set_xlabel("$k_x = k_y$ (1/s)")
        leg = figstyle.legend(ax, outside="below")
        fig.canvas.draw()
        box = leg.get_window_extent()
        hidden = [ax.xaxis.label.get_window_extent(), ax.get_window_extent()] + [
            t.get_window_extent() for t in ax.get_xticklabels() if t.get_text()]
    plt.close(fig)
    assert not [b for b in hidden if _overlap(box, b)]
    assert box.y1 <= hidden[0].y0 and box.y0 >= 0     # under the x label, in the figure


def _spy_saves(monkeypatch):
    """The figures figstyle.save writes, as (suptitle, legend texts), in order."""
    seen = []
    save = figstyle.save

    def spy(fig, *args, **kwargs):
        legends = fig.legends + [ax.get_legend() for ax in fig.axes if ax.get_legend()]
        seen.append((fig.get_suptitle(), [t.get_text() for leg in legends
                                          for t in leg.get_texts()]))
        return save(fig, *args, **kwargs)

    monkeypatch.setattr(figstyle, "save", spy)
    return seen


def test_a_legend_below_under_tight_layout_covers_no_label():
    """Only constrained layout makes room for a figure legend "outside"; under tight
    layout the legend stays the axis' own, placed under the x label."""
    with figstyle.style():
        fig, ax = plt.subplots(figsize=figstyle.size(1, 0.75), layout="tight")
        for k in range(3):
            ax.plot([0, 1], [k, k + 1], label=f"line {k}")
        ax.set_xlabel("x (m)")
        leg = figstyle.legend(ax, outside="below")
        figstyle.legend(ax, outside="below")  # twice: still one legend
        fig.canvas.draw()
        box, label = leg.get_window_extent(), ax.xaxis.label.get_window_extent()
        n = len(fig.legends) + (ax.get_legend() is not None)
    plt.close(fig)
    assert n == 1 and box.y1 <= label.y0


def test_a_legend_below_placed_twice_is_one_legend():
    with figstyle.style():
        fig, ax = plt.subplots(figsize=figstyle.size(1, 0.75))
        ax.plot([0, 1], [0, 1], label="a")
        figstyle.legend(ax, outside="below")
        figstyle.legend(ax, outside="below")
        n = len(fig.legends) + (ax.get_legend() is not None)
    plt.close(fig)
    assert n == 1


def test_saved_run_figures_name_the_run(adaptive_run, tmp_path, monkeypatch):
    from unidyn.results.plots import run_title
    assert run_title(adaptive_run.scenario) == (
        "paper simulation 4 (adaptive)\nadaptive dynamic compensation\n"
        "p3dx_laser, kx = ky = 0.1, noise seed 0")
    sc = unidyn.Scenario(case="compensated", name="cost $x$ (a", noise=None, T=2, kx=0.3)
    assert run_title(sc) == ("cost \\$x\\$ (a\nexact dynamic compensation\n"
                             "p3dx_laser, kx = 0.3, ky = 0.1, noise-free")
    seen = _spy_saves(monkeypatch)
    # a $ in the name is drawn as written, not parsed as mathtext (which would fail here)
    written = save_figures(unidyn.simulate_batch([sc])[0], tmp_path)
    assert len(seen) == len(written) == 4 and {t for t, _ in seen} == {run_title(sc)}


def test_a_sweep_legend_says_what_each_variant_sets_beside_its_label(tmp_path, monkeypatch):
    from unidyn.sweeps.plots import plot_metrics
    from unidyn.sweeps.sweep import Sweep, run_sweep
    s = Sweep(base={"T": 0.3, "noise": "off"}, grid={"kxy": [1.0, 2.0]},
              variants=[{"label": "a", "case": "uncompensated"},
                        {"label": "b", "case": "compensated", "theta_hat_scale": 0.9},
                        {"label": "$c$"}])
    run = run_sweep(s, tmp_path / "s", progress=False)
    seen = _spy_saves(monkeypatch)
    plot_metrics(s, run.rows, tmp_path / "m.png")
    # the case is what the label names ("no compensation: uncompensated" said it twice)
    # and a field in a reader's words, not its name in the files
    assert seen[0][1] == ["a", "b: θ̂(0)/θ = 0.9", "\\$c\\$"]


def test_a_sweep_with_long_legends_and_a_dollar_in_its_name_fits_its_figure(tmp_path,
                                                                             monkeypatch):
    """Twelve lines whose variants set six fields each: every entry within 64
    characters, the legend inside the figure, the axes not squeezed away; a name with
    unbalanced mathtext is drawn as written."""
    from unidyn.sweeps.plots import plot_metrics
    from unidyn.sweeps.sweep import Sweep, run_sweep
    sets = {"case": "compensated", "theta_hat_scale": 0.9, "ku": 3.0, "kw": 3.0, "lu": 0.8,
            "lw": 0.8}
    s = Sweep(name="price $x_$ test", base={"T": 0.2, "noise": "off"},
              grid={"kxy": [1.0, 2.0], "a": [0.15, 0.2, 0.25]},
              variants=[dict(sets, label=f"variant number {k}") for k in range(4)])
    run = run_sweep(s, tmp_path / "s", progress=False)
    figures = []
    save = figstyle.save

    def keep(fig, *args, **kwargs):
        fig.canvas.draw()
        legends = fig.legends + [ax.get_legend() for ax in fig.axes if ax.get_legend()]
        figures.append((fig.bbox, fig.axes[0].get_window_extent(),
                        [leg.get_window_extent() for leg in legends],
                        [t.get_text() for leg in legends for t in leg.get_texts()]))
        return save(fig, *args, **kwargs)

    monkeypatch.setattr(figstyle, "save", keep)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no "axes sizes collapsed to zero"
        plot_metrics(s, run.rows, tmp_path / "m.png")
    fig_box, ax_box, boxes, texts = figures[0]
    assert len(texts) == 12 and max(len(t) for t in texts) <= 64
    assert all(fig_box.x0 <= b.x0 and b.x1 <= fig_box.x1 and fig_box.y0 <= b.y0
               for b in boxes)
    assert ax_box.height > 0.3 * fig_box.height


def test_error_panel_limits_come_from_the_data(adaptive_run):
    ax = plot_error(adaptive_run)
    lo, hi = ax.get_ylim()
    plt.close(ax.figure)
    e = adaptive_run.error
    assert lo == 0 and e.max() < hi <= 1.1 * e.max()


def test_theta_hat_true_values_step_where_a_load_is_picked_up():
    sc = unidyn.Scenario.paper(4, T=20.0, adapt_from=0.0, payload=[[10.0, 2.0]], noise=None)
    r, = unidyn.simulate_batch([sc])
    th = np.asarray(sc.robot.theta)
    axes = plot_theta_hat(r, panels=True)
    after = r.t >= 10.0
    for i, ax in enumerate(axes):
        true = [l for l in ax.get_lines() if l.get_label() == "true value"][0]
        scale = 1e-3 if "10^{-3}" in ax.get_ylabel() else 1.0
        y = np.asarray(true.get_ydata()) * scale
        mass = 2.0 if i in (0, 1, 2, 4) else 1.0  # Section 2: theta4, theta6 carry no mass
        np.testing.assert_allclose(y[~after], th[i], rtol=1e-12)
        np.testing.assert_allclose(y[after], mass * th[i], rtol=1e-12)
    plt.close(axes[0].figure)
    ax = plot_theta_hat(r)  # ratios to the loaded robot's values after the load
    first = ax.get_lines()[0]
    np.testing.assert_allclose(first.get_ydata()[after], r.theta_hat[after, 0] / (2 * th[0]))
    plt.close(ax.figure)


def test_theta_hat_panels_show_each_estimate_and_its_true_value(adaptive_run):
    axes = plot_theta_hat(adaptive_run, panels=True)
    theta = adaptive_run.scenario.robot.theta
    for i, ax in enumerate(axes):
        lo, hi = ax.get_ylim()
        # tiny components are drawn in 10^-3 units (named in the label), not with an
        # offset label over the panel
        scale = 1e-3 if "10^{-3}" in ax.get_ylabel() else 1.0
        assert ax.yaxis.get_offset_text().get_text() == ""
        est = adaptive_run.theta_hat[:, i] / scale
        theta_i = theta[i] / scale
        assert lo < min(est.min(), theta_i) and max(est.max(), theta_i) < hi
        # readable: the component's own range fills at least half of its panel
        span = max(est.max(), theta_i) - min(est.min(), theta_i)
        assert span > 0.5 * (hi - lo)
    plt.close(axes[0].figure)
    # one axis: ratios only for the true values not near zero (theta3, theta5 are ~1e-3)
    ax = plot_theta_hat(adaptive_run)
    names = [l.get_label() for l in ax.get_lines()]
    plt.close(ax.figure)
    assert names[:4] == [r"$\hat\theta_1$", r"$\hat\theta_2$", r"$\hat\theta_4$",
                         r"$\hat\theta_6$"]


def test_files_get_the_usual_mode(adaptive_run, tmp_path):
    written = save_figures(adaptive_run, tmp_path / "figs")
    assert [p.name for p in written] == ["path.png", "error.png", "positions.png",
                                         "velocities.png", "theta_hat.png"]
    from unidyn.teaching.animation import animate
    gif = animate(adaptive_run, tmp_path / "a.gif", frames=3)
    for p in written + [gif]:
        assert (p.stat().st_mode & 0o777) == 0o666 & ~_umask(), p
    assert not [p for p in tmp_path.rglob(".*")]      # no temporary file left behind


def test_section5_script_refuses_to_replace_results(tmp_path, capsys):
    sys.path.insert(0, str(EXAMPLES))
    try:
        import paper_section5
    finally:
        sys.path.remove(str(EXAMPLES))
    out = tmp_path / "s5"
    out.mkdir()
    (out / "section5.png").write_bytes(b"earlier results")
    for extra in ([], ["--overwrite"]):  # not unidyn's: never replaced
        assert paper_section5.main(["--out", str(out), "--T", "1", *extra]) == 2
        err = capsys.readouterr().err
        assert "section5.png, named like unidyn's Section 5 results but not written" in err
        assert (out / "section5.png").read_bytes() == b"earlier results"


def test_no_style_leaks_in_from_another_library(adaptive_run):
    """roboticstoolbox's plotting module switches the whole process to "ggplot" (grey
    axes, its colour cycle) when bdsim loads it; unidyn's figures still start from
    matplotlib's defaults, and the process's settings are as they were afterwards."""
    from unidyn.results.plots import plot_velocities
    with plt.style.context("ggplot"):
        leaked = matplotlib.rcParams["axes.facecolor"]
        axes = plot_velocities(adaptive_run)
        assert matplotlib.rcParams["axes.facecolor"] == leaked != "white"
    assert [ax.get_facecolor() for ax in axes] == [(1.0, 1.0, 1.0, 1.0)] * 2
    default_first = matplotlib.rcParamsDefault["axes.prop_cycle"].by_key()["color"][0]
    actual = [ln for ln in axes[0].get_lines() if ln.get_label() == "$u$"]
    assert matplotlib.colors.same_color(actual[0].get_color(), default_first)
    plt.close(axes[0].figure)


def test_velocities_name_the_kinematic_controllers_output(adaptive_run):
    from unidyn.results.plots import plot_velocities
    axes = plot_velocities(adaptive_run)
    fig = axes[0].figure
    labels = [t.get_text() for t in fig.legends[0].get_texts()]
    # one legend under both panels, which keep the figure's width and line up
    fig.canvas.draw()
    boxes = [ax.get_window_extent() for ax in axes]
    plt.close(fig)
    assert labels == [r"$u_d$, $\omega_d$ (kinematic controller)", r"$u$, $\omega$ (robot)"]
    assert boxes[0].x0 == boxes[1].x0 and boxes[0].width == boxes[1].width
    assert boxes[0].width > 0.75 * fig.bbox.width


def test_slides_preset_scales_text_lines_and_figures_of_unidyns_plots(adaptive_run):
    ax = plot_error(adaptive_run)
    paper = (ax.figure.get_size_inches(), ax.xaxis.label.get_fontsize(), ax.get_lines()[0].get_lw())
    plt.close(ax.figure)
    with figstyle.style("slides"):
        ax = plot_error(adaptive_run)
        slides = (ax.figure.get_size_inches(), ax.xaxis.label.get_fontsize(), ax.get_lines()[0].get_lw())
        plt.close(ax.figure)
    k = figstyle.SLIDES_SCALE
    np.testing.assert_allclose(slides[0], k * paper[0])
    assert slides[1] == pytest.approx(k * paper[1]) and slides[2] == pytest.approx(k * paper[2])
    # after the block, the paper preset again
    assert figstyle.size(1) == (figstyle.COLUMN, figstyle.COLUMN * 0.75)
    with pytest.raises(ValueError, match="figure preset must be one of paper, slides, got 'poster'"):
        with figstyle.style("poster"):
            pass


def test_section5_error_panels_share_one_scale(tmp_path, monkeypatch):
    """The four cases' distance errors are drawn on one y-scale, the largest error's."""
    sys.path.insert(0, str(EXAMPLES))
    try:
        import paper_section5
    finally:
        sys.path.remove(str(EXAMPLES))
    runs = unidyn.simulate_batch([unidyn.Scenario.paper(n, T=4) for n in (1, 2, 3, 4)])
    results = dict(zip((1, 2, 3, 4), runs))
    limits = []
    monkeypatch.setattr(figstyle, "save", lambda fig, path: limits.extend(
        ax.get_ylim() for ax in fig.axes[1:8:2]) or plt.close(fig))
    paper_section5.section5_figure(results, tmp_path / "section5.png")
    top = max(float(r.error.max()) for r in runs)
    assert len(limits) == 4 and len(set(limits)) == 1, limits
    assert limits[0][0] == 0 and top < limits[0][1] < 1.1 * top


def test_section5_inset_caption_stays_inside_the_inset(tmp_path, monkeypatch):
    """Case 3's zoom into the first seconds carries its caption inside its own axes,
    above its curve: nothing of it runs over the main panel."""
    sys.path.insert(0, str(EXAMPLES))
    try:
        import paper_section5
    finally:
        sys.path.remove(str(EXAMPLES))
    runs = unidyn.simulate_batch([unidyn.Scenario.paper(n, T=4) for n in (1, 2, 3, 4)])
    found = []

    def check(fig, path):
        fig.canvas.draw()
        (ins,) = fig.axes[5].child_axes
        box = ins.get_window_extent()
        for text in ins.texts:
            tb = text.get_window_extent()
            found.append((box.x0 <= tb.x0 and tb.x1 <= box.x1 and box.y0 <= tb.y0
                          and tb.y1 <= box.y1, tb))
            # above the curve: no point of it under the caption
            xy = ins.transData.transform(ins.get_lines()[0].get_xydata())
            under = (xy[:, 0] >= tb.x0) & (xy[:, 0] <= tb.x1) & (xy[:, 1] >= tb.y0)
            assert not under.any()
        plt.close(fig)

    monkeypatch.setattr(figstyle, "save", check)
    paper_section5.section5_figure(dict(zip((1, 2, 3, 4), runs)), tmp_path / "section5.png")
    assert found and all(inside for inside, _ in found), found


def _luminance_contrast(c1, c2):
    """WCAG contrast ratio of two colours (1: the same lightness)."""
    from matplotlib.colors import to_rgb

    def lum(c):
        rgb = np.array(to_rgb(c))
        lin = np.where(rgb <= 0.03928, rgb / 12.92, ((rgb + 0.055) / 1.055) ** 2.4)
        return float(lin @ [0.2126, 0.7152, 0.0722])
    a, b = sorted((lum(c1), lum(c2)))
    return (b + 0.05) / (a + 0.05)


def test_estimates_on_one_axis_have_colours_apart(adaptive_run):
    """Each estimate has a colour of its own, far in hue or lightness from every other
    (theta4 and theta6 were two near reds): no two closer than 0.25 in RGB or of the
    same lightness and hue."""
    from matplotlib.colors import rgb_to_hsv, to_rgb
    ax = plot_theta_hat(adaptive_run)
    colours = [l.get_color() for l in ax.get_lines() if l.get_label().startswith("$")]
    plt.close(ax.figure)
    assert len(colours) >= 4 and len(set(colours)) == len(colours)
    for i, a in enumerate(colours):
        for b in colours[i + 1:]:
            dist = np.linalg.norm(np.subtract(to_rgb(a), to_rgb(b)))
            hue = abs(rgb_to_hsv(to_rgb(a))[0] - rgb_to_hsv(to_rgb(b))[0])
            hue = min(hue, 1 - hue)
            assert dist > 0.25 and (hue > 0.08 or _luminance_contrast(a, b) > 1.5), (a, b)


def test_a_time_axis_is_labelled_where_its_numbers_are(adaptive_run):
    """Panels stacked on a shared time axis: the label goes with the tick numbers, on
    the bottom panel only."""
    fig, (top, bottom) = plt.subplots(2, 1, sharex=True)
    plot_error(adaptive_run, ax=top)
    plot_theta_hat(adaptive_run, ax=bottom)
    fig.canvas.draw()
    assert top.get_xlabel() == "" and not any(t.get_text() for t in top.get_xticklabels())
    assert bottom.get_xlabel() == "t (s)"
    assert any(t.get_text() for t in bottom.get_xticklabels())
    plt.close(fig)
    ax = plot_error(adaptive_run)  # on its own: labelled
    assert ax.get_xlabel() == "t (s)"
    plt.close(ax.figure)
