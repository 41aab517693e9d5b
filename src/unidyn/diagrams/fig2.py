r"""The closed loop of Fig. 2 of Martins et al. (2017) as a bdsim block diagram.

::

    trajectory --h_d, h_d_dot--> K --v_d--> D --v_r--> R --q, v--+
                                 ^           ^                    |
                                 +--q_meas---+------v_meas--------+

:func:`build_fig2` wires the blocks for one :class:`unidyn.Scenario` and returns
a :class:`Fig2` holding the diagram and every block by role, so a user can add
scopes or watches, or pass their own factory for any role (a different
controller, roboticstoolbox's ``UNICYCLE`` as the robot) without editing
library code.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Callable

from unidyn.model.scenario import Scenario

__all__ = ["Fig2", "TOOLBOX_CRASH", "ToolboxWarning", "build_fig2", "new_simulator"]


#: Why a ``bdsim.BDSim()`` that loads the toolboxes' blocks fails beside
#: roboticstoolbox-python 1.5.0, and the two ways out.
TOOLBOX_CRASH = ("bdsim 1.4's block loader cannot read roboticstoolbox-python 1.5's block "
                 "docstrings (KeyError: 'type'): pip install 'roboticstoolbox-python<1.5' for "
                 "the toolbox's blocks, or use unidyn's blocks with bdsim.BDSim(..., toolboxes=False)")


class ToolboxWarning(UserWarning):
    """The toolboxes' bdsim blocks could not be loaded; the message says why and what to do."""


def new_simulator(toolboxes: bool | None = None, **options):
    """A headless, quiet ``bdsim.BDSim`` that ignores ``sys.argv`` (for scripts, tests, notebooks).

    bdsim 1.4 loads its block library once per process, for the first simulator
    made, and every later one shares it; ``toolboxes`` says whether it holds the
    Robotics Toolbox's blocks (``UNICYCLE``, ``VEHICLEPLOT``, ...) beside bdsim's and
    unidyn's:

    - ``None`` (default): the toolbox's blocks where they load, else without them
      and a :class:`ToolboxWarning` (roboticstoolbox-python 1.5.0, see
      :data:`TOOLBOX_CRASH`). unidyn's own diagrams need no toolbox block, so
      ``unidyn.simulate`` and ``unidyn run --engine bdsim`` work either way.
    - ``True``: with the toolbox's blocks, or a ``RuntimeError`` saying why not.
    - ``False``: bdsim's and unidyn's blocks only.

    bdsim's own notice about toolboxes that are not installed (machinevisiontoolbox)
    is suppressed; keyword arguments are bdsim's options and override the defaults."""
    import contextlib
    import io
    import warnings

    import bdsim
    opts = dict(graphics=False, progress=False, banner=False, sysargs=False, quiet=True)
    opts.update(options)
    with contextlib.redirect_stdout(io.StringIO()):
        if toolboxes is False:
            return bdsim.BDSim(toolboxes=False, **opts)
        try:
            return bdsim.BDSim(toolboxes=True, **opts)
        except KeyError as err:  # bdsim left its block library unloaded: a retry loads it
            if err.args != ("type",):
                raise
            if toolboxes:
                raise RuntimeError(TOOLBOX_CRASH) from err
        warnings.warn(f"{TOOLBOX_CRASH}; this process's bdsim simulators now have bdsim's "
                      f"and unidyn's blocks only", ToolboxWarning, stacklevel=2)
        return bdsim.BDSim(toolboxes=False, **opts)


@dataclass
class Fig2:
    """A wired Fig. 2 diagram and its blocks by role.

    :ivar bd: the bdsim block diagram (not yet compiled)
    :ivar scenario: the scenario it was built from
    :ivar blocks: role -> block: ``trajectory``, ``controller``, ``compensator`` (absent
        in the kinematic and uncompensated cases), ``robot``, ``demux``,
        ``position_noise``, ``velocity_noise`` (present with noise)
    :ivar clocks: name -> bdsim clock: ``"sensor"`` (with noise) and ``"controller"`` (sampled control)
    :ivar watch: role -> plug logged by :func:`unidyn.simulate`
    """

    bd: Any
    scenario: Scenario
    blocks: dict = field(default_factory=dict)
    clocks: dict = field(default_factory=dict)
    watch: dict = field(default_factory=dict)

    def __getattr__(self, name):
        blocks = self.__dict__.get("blocks", {})
        if name in blocks:
            return blocks[name]
        raise AttributeError(name)


def build_fig2(sim, scenario: Scenario, *, robot: Callable | None = None,
               controller: Callable | None = None, compensator: Callable | None = None,
               trajectory: Callable | None = None) -> Fig2:
    """Wire Fig. 2 for ``scenario`` in a new block diagram of ``sim``.

    The four cases of Section 5 differ only in the blocks:

    =================  ==================================  ======================
    case               robot                               compensator
    =================  ==================================  ======================
    ``kinematic``      ``KINEMATICUNICYCLE`` (v = v_d)      none
    ``uncompensated``  ``DYNAMICUNICYCLE``                  none (v_ref = v_d)
    ``compensated``    ``DYNAMICUNICYCLE``                  ``DYNAMICCOMPENSATOR``, fixed theta_hat
    ``adaptive``       ``DYNAMICUNICYCLE``                  ``DYNAMICCOMPENSATOR``, adaptive
    =================  ==================================  ======================

    Where an option fixes a block's ports, the block is the class with those ports
    (the robot with its velocity output is a ``DYNAMICUNICYCLEWITHVELOCITY``, K with
    its rate output a ``KINEMATICCONTROLLERWITHRATE``, D taking that rate a
    ``DYNAMICCOMPENSATORWITHRATEINPUT``, the noise a ``SENSORNOISE``), and the reference
    is a ``FIGUREEIGHT``, ``CIRCLE``, ``LINE`` or ``POINT``: the diagram is then what its
    ``.bd`` file holds (:mod:`unidyn.diagrams.bdfile`).

    :param sim: a ``bdsim.BDSim`` (see :func:`new_simulator`)
    :param scenario: the run to wire
    :param robot: optional factory ``f(bd, scenario) -> block`` replacing the robot; the
        block needs inputs v (0) and ω (1) and the pose on output 0 (and the
        velocities on output 1 when a compensator is used)
    :param controller: optional factory ``f(bd, scenario) -> block`` replacing K
        (inputs h_d, h_d_dot, q; output v_d)
    :param compensator: optional factory ``f(bd, scenario) -> block`` replacing D
        (inputs v_d, v; output v_r)
    :param trajectory: optional factory ``f(bd, scenario) -> block`` replacing the
        reference source (outputs h_d, h_d_dot, h_d_ddot)
    :return: the wired :class:`Fig2`
    """
    # bdsim loads with the blocks: when a diagram is built, not on import
    from unidyn.blocks import trajectory_block

    sc = scenario
    bd = sim.blockdiagram(name=sc.name or f"fig2_{sc.case}")
    fig = Fig2(bd=bd, scenario=sc)
    if sc.noise is not None:
        fig.clocks["sensor"] = bd.clock(sc.Ts, name="sensor")
    if sc.control == "sampled":
        fig.clocks["controller"] = bd.clock(sc.Ts, name="controller")
    # the exact v_d' needs the rate output of our continuous K; with a user's own
    # controller the compensator falls back to its derivative filter
    analytic = (sc.case_spec.compensated and sc.derivative == "analytic"
                and controller is None)

    # Where a port-changing option is on, the blocks are the classes with those ports
    # fixed (DynamicUnicycleWithVelocity for velocity_output=True, ...): the same
    # equations, and the blocks a .bd file holds and bdedit draws.
    src = (trajectory(bd, sc) if trajectory
           else trajectory_block(sc.trajectory, bd=bd, name="trajectory"))
    fig.blocks["trajectory"] = src
    R = robot(bd, sc) if robot is not None else _robot(bd, sc)
    fig.blocks["robot"] = R
    q_meas, v_meas = _measurements(fig, R)

    K = controller(bd, sc) if controller is not None else _controller(fig, analytic)
    fig.blocks["controller"] = K
    bd.connect(src[0], K[0])
    bd.connect(src[1], K[1])
    bd.connect(q_meas, K[2])
    if analytic and sc.control != "sampled":
        bd.connect(src[2], K[3])
        bd.connect(v_meas, K[4])

    command = K[0]
    if sc.case_spec.compensated:
        D = compensator(bd, sc) if compensator is not None else _compensator(fig, analytic)
        fig.blocks["compensator"] = D
        bd.connect(K[0], D[0])
        bd.connect(v_meas, D[1])
        if analytic:
            bd.connect(K[1], D[2])
        command = D[0]
        fig.watch["theta_hat"] = D[1]

    demux = bd.DEMUX(2, name="demux")
    fig.blocks["demux"] = demux
    bd.connect(command, demux)
    bd.connect(demux[0], R[0])
    bd.connect(demux[1], R[1])

    fig.watch.update({"pose": R[0], "reference": src[0], "v_d": K[0], "v_ref": command})
    if sc.case_spec.dynamic:
        fig.watch["velocity"] = R[1]
    _terminate_unused_outputs(bd)
    return fig


def _robot(bd, sc):
    """The robot R: the dynamic one with its velocity output, or the kinematic one."""
    from unidyn.blocks import DynamicUnicycleWithVelocity, KinematicUnicycle

    lim = sc.limits
    if sc.case_spec.dynamic:
        return DynamicUnicycleWithVelocity(
            robot=sc.robot, a=sc.a, x0=sc.x0, speed_max=_limit(lim.speed_max),
            accel_max=_limit(lim.accel_max), steer_max=_limit(lim.steer_max),
            angular_accel_max=_limit(lim.angular_accel_max),
            payload=[list(row) for row in sc.payload] or None, bd=bd, name="robot")
    return KinematicUnicycle(a=sc.a, x0=sc.x0, speed_max=lim.speed_max,
                             steer_max=lim.steer_max, bd=bd, name="robot")


def _measurements(fig, R):
    """The pose and (dynamic robot) velocities as fed back: through noise blocks held
    over Ts when the scenario has noise (psi is fed back clean). Returns the two plugs
    (the velocities' None for a kinematic robot)."""
    from unidyn.blocks import SensorNoise

    sc, bd = fig.scenario, fig.bd
    dynamic = sc.case_spec.dynamic
    q_meas, v_meas = R[0], (R[1] if dynamic else None)
    if sc.noise is None:
        return q_meas, v_meas
    clock = fig.clocks["sensor"].name

    def noisy(plug, std, stream, name):
        # stream 0 (position) or 1 (velocity) of the run's seed (unidyn.model.noise.noise_seeds)
        block = SensorNoise(Ts=sc.Ts, clock_name=clock, std=std, seed=sc.noise.seed,
                            stream=stream, indices=(0, 1), bd=bd, name=name)
        bd.connect(plug, block)
        fig.blocks[name] = block
        return block[0]

    q_meas = noisy(R[0], sc.noise.position_std, 0, "position_noise")
    if dynamic:
        v_meas = noisy(R[1], sc.noise.velocity_std, 1, "velocity_noise")
    return q_meas, v_meas


def _controller(fig, analytic):
    """The kinematic controller K: sampled, with its rate output (for the analytic
    v_d'), or continuous."""
    from unidyn.blocks import KinematicController, KinematicControllerWithRate
    from unidyn.blocks.controllers import SampledKinematicController

    sc, bd = fig.scenario, fig.bd
    gains = dict(a=sc.a, kx=sc.kx, ky=sc.ky, lx=sc.lx, ly=sc.ly)
    if sc.control == "sampled":
        return SampledKinematicController(fig.clocks["controller"], **gains, bd=bd,
                                          name="controller")
    if analytic:
        return KinematicControllerWithRate(**gains, bd=bd, name="controller")
    return KinematicController(**gains, bd=bd, name="controller")


def _compensator(fig, analytic):
    """The dynamic compensator D, fixed or adaptive: sampled (v_d' by differences),
    taking K's rate (analytic v_d'), or continuous with a derivative filter."""
    from unidyn.blocks import DynamicCompensator, DynamicCompensatorWithRateInput
    from unidyn.blocks.controllers import SampledDynamicCompensator

    sc, bd = fig.scenario, fig.bd
    adaptive = sc.case_spec.adaptive
    dargs = dict(theta_hat0=sc.theta_hat_initial, ku=sc.ku, kw=sc.kw, lu=sc.lu, lw=sc.lw,
                 adaptive=adaptive, gamma=sc.gamma, sigma=sc.sigma,
                 adapt_from=sc.adapt_from if adaptive else 0.0, leakage=sc.leakage)
    if sc.control == "sampled":
        return SampledDynamicCompensator(fig.clocks["controller"], **dargs,
                                         vd_dot="difference", bd=bd, name="compensator")
    if analytic:
        return DynamicCompensatorWithRateInput(**dargs, bd=bd, name="compensator")
    return DynamicCompensator(**dargs, vd_dot="filter", tau=sc.tau, bd=bd, name="compensator")


def _limit(value: float) -> float | None:
    """A limit as the fixed-port robot takes it: None for no limit."""
    return None if value == float("inf") else value


def _terminate_unused_outputs(bd):
    """End every output nothing reads (e.g. theta_hat, which is only logged) in a NULL
    sink, so compiling the diagram prints no "output ... is not connected" notice. Each
    sink is named for the signal it ends, ``theta_hat_unused``, as the editor shows it."""
    used = {(id(w.start.block), w.start.port) for w in bd.wirelist}
    unused = [(b, port) for b in list(bd.blocklist) for port in range(b.nout or 0)
              if (id(b), port) not in used]
    taken = {b.name for b in bd.blocklist}
    for b, port in unused:
        names = getattr(b, "_outport_names", None) or []
        signal = str(names[port]) if port < len(names) else f"{b.name}_out{port}"
        name = f"{signal}_unused"
        if name in taken:  # two blocks' outputs of one name: the block's name too
            name = f"{b.name}_{signal}_unused"
        taken.add(name)
        bd.connect(b[port], bd.NULL(1, name=name))
