"""The figure style: periods of the references, plain log tick labels, legends that hide
no data, y-limits from the data, per-component theta_hat panels, file modes."""

import math
import os
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402

import unidyn  # noqa: E402
from unidyn import figstyle  # noqa: E402
from unidyn.plots import (plot_error, plot_theta_hat, reference_once,  # noqa: E402
                          reference_period, save_figures)
from unidyn.trajectories import Circle, FigureEight, Line  # noqa: E402

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


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
    inside = (pts[:, 0] >= box.x0) & (pts[:, 0] <= box.x1) & (pts[:, 1] >= box.y0) & (
        pts[:, 1] <= box.y1)
    assert not inside.any()


def test_error_panel_limits_come_from_the_data(adaptive_run):
    ax = plot_error(adaptive_run)
    lo, hi = ax.get_ylim()
    plt.close(ax.figure)
    e = adaptive_run.error
    assert lo == 0 and e.max() < hi <= 1.1 * e.max()


def test_theta_hat_panels_show_each_estimate_and_its_true_value(adaptive_run):
    axes = plot_theta_hat(adaptive_run, panels=True)
    theta = adaptive_run.scenario.robot.theta
    for i, ax in enumerate(axes):
        lo, hi = ax.get_ylim()
        est = adaptive_run.theta_hat[:, i]
        assert lo < min(est.min(), theta[i]) and max(est.max(), theta[i]) < hi
        # readable: the component's own range fills at least half of its panel
        span = max(est.max(), theta[i]) - min(est.min(), theta[i])
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
    from unidyn.animation import animate
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
    assert paper_section5.main(["--out", str(out), "--T", "1"]) == 2
    err = capsys.readouterr().err
    assert "--overwrite" in err and "section5.png" in err
    assert (out / "section5.png").read_bytes() == b"earlier results"
