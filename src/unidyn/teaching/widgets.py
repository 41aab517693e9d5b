r"""Live sliders over the paper's Section 5 loop (Fig. 2), driving the batch engine.

:class:`LoopExplorer` runs the paper's 200 s figure-eight simulation through
:func:`unidyn.simulate_batch` and draws the path of h and the distance error. Its
:meth:`~LoopExplorer.update` is a plain function of the settings (kinematic gain
kx = ky of Eq. 10, payload and the time it is picked up, noise on or off, case
1-4), so scripts, tests and
headless notebooks call it directly; :meth:`~LoopExplorer.widget` wires the same
function to ``ipywidgets`` controls (the optional dependency ``ipywidgets``,
``pip install unidyn[teach]``; this module imports it only there).

The payload scales the robot's mass from the time it is picked up (the scenario's
``payload`` schedule, :func:`unidyn.model.equations.payload_theta`): theta1, theta2,
theta3 and theta5 grow in proportion (Section 2: each is proportional to the mass m,
or to I_z + m b^2, when the rotors' inertia I_e and the servos' derivative gains are
small against the body's), while theta4 and theta6 (motor and friction terms) do not
depend on the mass. The compensator keeps the empty robot's estimate (case 3: the
preset's theta; case 4: the paper's theta/1.5 of the preset), so a payload is
something it does not know about, as on a real robot; case 4's update (Eq. 20)
follows it.
"""

from __future__ import annotations

import time

import numpy as np

from .._validate import ValidationError, positive, real
from ..engine.batch import simulate_batch
from ..model import robots
from ..model.noise import PAPER_NOISE
from ..model.parameters import MASS_PARAMETERS, RobotParameters
from ..model.scenario import Scenario
from ..results import figstyle

__all__ = ["LoopExplorer", "with_payload", "MASS_PARAMETERS"]

def with_payload(robot, payload: float) -> RobotParameters:
    """The robot carrying a payload: theta1, theta2, theta3, theta5 multiplied by
    ``payload`` (the mass relative to the empty robot, > 0), theta4 and theta6 kept.

    :param robot: a preset name, RobotParameters or six numbers
    :param payload: mass scale, > 0 (1: the robot as identified)
    """
    return robots.resolve(robot, "robot").with_mass(payload)


class LoopExplorer:
    """The paper's Section 5 loop under four settings, drawn as the path of h and
    the distance error |h_d - h| (the paper's Figs. 3-10, a and b).

    :param k: kinematic gain kx = ky of Eq. (10), 1/s, > 0 (the paper: 0.1)
    :param payload: mass scale of the robot with its load, > 0 (see :func:`with_payload`)
    :param load_time: when the load is picked up, s, >= 0 (0: carried from the start)
    :param noise: the paper's measurement noise on (True) or off (False)
    :param case: the paper's simulation 1-4 (kinematic, uncompensated, exact
        compensation, adaptive)
    :param robot: the robot as identified (default: the paper's Pioneer 3-DX with laser)
    :param T: duration, s (the paper: 200)
    :param figure: draw (a matplotlib Figure with two axes is made); False for
        numbers only
    """

    K_RANGE = (0.05, 40.0)
    PAYLOAD_RANGE = (0.5, 3.0)

    def __init__(self, k: float = 0.1, payload: float = 1.0, noise: bool = True, case: int = 4,
                 robot="p3dx_laser", T: float = 200.0, figure: bool = True,
                 load_time: float = 0.0):
        self.robot = robots.resolve(robot, "robot")
        self.T = positive("T", T)
        self.settings = {}
        self.result = None
        self.seconds = {"simulate": float("nan"), "draw": float("nan")}
        self.fig = None
        if figure:
            self._make_figure()
        self.update(k=k, payload=payload, noise=noise, case=case, load_time=load_time)

    # ------------------------------------------------------------------ #
    def scenario(self, k: float, payload: float, noise: bool, case: int,
                 load_time: float = 0.0):
        """The :class:`~unidyn.Scenario` of one setting: ``Scenario.paper(case)`` with
        kx = ky = k, the empty robot carrying ``payload`` times its mass from
        ``load_time`` on (the scenario's ``payload`` schedule), and the empty robot's
        estimate."""
        if isinstance(case, bool) or case not in (1, 2, 3, 4):
            raise ValidationError(f"case must be 1, 2, 3 or 4, got {case!r}")
        if not isinstance(noise, (bool, np.bool_)):
            raise ValidationError(f"noise must be True or False, got {noise!r}")
        k = positive("k", k)
        payload = positive("payload", payload)
        load_time = real("load_time", load_time, low=0.0, high=self.T)
        theta_hat0 = None
        if case == 3:
            theta_hat0 = self.robot
        elif case == 4:
            theta_hat0 = self.robot.scaled(1 / 1.5)
        return Scenario.paper(int(case), robot=self.robot, payload=[[load_time, payload]],
                              theta_hat0=theta_hat0, kx=k, ky=k,
                              noise=PAPER_NOISE if noise else None, T=self.T,
                              name=f"case {case}, k = {k:g}, payload x{payload:g} from "
                                   f"{load_time:g} s")

    def update(self, k=None, payload=None, noise=None, case=None, load_time=None):
        """Run the loop with the given settings (those left ``None`` keep their
        current value) on the batch engine and redraw; returns the
        :class:`~unidyn.Result`. ``seconds`` holds the time it took to simulate and to
        draw."""
        new = dict(self.settings)
        for name, value in (("k", k), ("payload", payload), ("noise", noise), ("case", case),
                            ("load_time", load_time)):
            if value is not None:
                new[name] = value
        sc = self.scenario(**new)
        t0 = time.perf_counter()
        (res,) = simulate_batch([sc], progress=False)
        t1 = time.perf_counter()
        self.settings, self.result = new, res
        if self.fig is not None:
            self._draw()
        self.seconds = {"simulate": t1 - t0, "draw": time.perf_counter() - t1}
        return res

    @property
    def drawn(self) -> dict:
        """The data on the axes: ``path`` (x, y of h), ``reference`` (x_d, y_d) and
        ``error`` (t, |h_d - h|), each an (N, 2) array."""
        if self.fig is None:
            raise ValidationError("this LoopExplorer draws nothing (figure=False)")
        return {k: np.asarray(line.get_xydata(), dtype=float) for k, line in self._lines.items()}

    # ------------------------------------------------------------------ #
    @figstyle.styled
    def _make_figure(self):
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure
        fig = Figure(figsize=figstyle.size(2, 0.38), layout="constrained")
        FigureCanvasAgg(fig)
        ax_path, ax_err = fig.subplots(1, 2, width_ratios=(1, 1.6))
        ref, = ax_path.plot([], [], **figstyle.REFERENCE, label="reference $h_d$")
        path, = ax_path.plot([], [], color="C0", label="path of h")
        ax_path.set(xlabel=figstyle.label("x", "m"), ylabel=figstyle.label("y", "m"))
        ax_path.set_aspect("equal", adjustable="box")
        ax_path.legend(loc="lower right")
        err, = ax_err.plot([], [], color="C0")
        self._load_line = ax_err.axvline(0.0, color="C3", lw=0.8, ls=":", visible=False)
        ax_err.set(xlabel=figstyle.label("t", "s"), ylabel=figstyle.label("distance error", "m"))
        self.fig, self._axes = fig, (ax_path, ax_err)
        self._lines = {"path": path, "reference": ref, "error": err}

    @figstyle.styled
    def _draw(self):
        r, s = self.result, self.settings
        ax_path, ax_err = self._axes
        self._lines["path"].set_data(r.pose[:, 0], r.pose[:, 1])
        self._lines["reference"].set_data(r.reference[:, 0], r.reference[:, 1])
        self._lines["error"].set_data(r.t, r.error)
        xy = np.vstack([r.pose[:, :2], r.reference])
        xy = xy[np.all(np.isfinite(xy), axis=1)]
        lo, hi = xy.min(axis=0), xy.max(axis=0)
        pad = 0.06 * max(float(np.max(hi - lo)), 1e-3)
        ax_path.set_xlim(lo[0] - pad, hi[0] + pad)
        ax_path.set_ylim(lo[1] - pad, hi[1] + pad)
        ax_err.set_xlim(0, self.T)
        self._load_line.set_xdata([s["load_time"], s["load_time"]])
        self._load_line.set_visible(s["payload"] != 1.0 and s["load_time"] > 0)
        emax = float(np.nanmax(r.error)) if len(r.error) else 1.0
        ax_err.set_ylim(0, 1.05 * emax if emax > 0 else 1.0)
        iae = r.metrics["iae"]
        names = {1: "kinematic", 2: "uncompensated", 3: "exact compensation", 4: "adaptive"}
        ax_path.set_title(f"case {s['case']}: {names[s['case']]}", fontsize="medium")
        ax_err.set_title(
            f"k = {s['k']:g} 1/s, payload x{s['payload']:g}"
            + (f" from {s['load_time']:g} s" if s["load_time"] > 0 else "")
            + f", noise {'on' if s['noise'] else 'off'}"
            + (f": IAE = {iae:.2f} m·s" if iae is not None else ": did not complete"),
            fontsize="medium")
        self.fig.canvas.draw()

    # ------------------------------------------------------------------ #
    def widget(self):
        """``ipywidgets`` controls wired to :meth:`update`, with the figure below them
        (needs ``ipywidgets``: ``pip install unidyn[teach]``)."""
        try:
            import ipywidgets as w
        except ImportError:
            raise ImportError("LoopExplorer.widget needs ipywidgets: pip install unidyn[teach]") from None
        from IPython.display import display
        s = self.settings
        k = w.FloatLogSlider(value=s["k"], base=10, min=np.log10(self.K_RANGE[0]),
                             max=np.log10(self.K_RANGE[1]), step=0.05, description="k = kx = ky",
                             continuous_update=False, readout_format=".3g")
        payload = w.FloatSlider(value=s["payload"], min=self.PAYLOAD_RANGE[0],
                                max=self.PAYLOAD_RANGE[1], step=0.1, description="payload x",
                                continuous_update=False)
        load_time = w.FloatSlider(value=s["load_time"], min=0.0, max=self.T, step=5.0,
                                  description="load at t =", continuous_update=False)
        noise = w.Checkbox(value=bool(s["noise"]), description="measurement noise")
        case = w.ToggleButtons(options=[("1 kinematic", 1), ("2 uncompensated", 2),
                                        ("3 compensated", 3), ("4 adaptive", 4)],
                               value=s["case"], description="case")
        out = w.Output()

        def show():
            with out:
                out.clear_output(wait=True)
                display(self.fig)

        def changed(_):
            self.update(k=k.value, payload=payload.value, noise=noise.value, case=case.value,
                        load_time=load_time.value)
            show()

        for c in (k, payload, load_time, noise, case):
            c.observe(changed, names="value")
        show()
        return w.VBox([w.HBox([k, payload, load_time, noise]), case, out])
