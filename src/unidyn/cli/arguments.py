"""The ``unidyn`` command's arguments: the parser of every subcommand and its options
(the help texts ``unidyn --help`` shows and the reference documentation is generated
from). It loads nothing heavy, so that ``--help`` is quick; the subcommands' modules
are loaded only to run them."""

from __future__ import annotations

import argparse

from .. import __version__
from .errors import UsageError


class Formatter(argparse.HelpFormatter):
    """Wraps descriptions as usual; keeps an epilog of examples line by line."""

    def _fill_text(self, text, width, indent):
        if text.startswith("examples:"):
            return "".join(indent + line for line in text.splitlines(keepends=True))
        return super()._fill_text(text, width, indent)


def examples(*lines: str) -> str:
    """An epilog of example command lines (kept line by line by :class:`Formatter`)."""
    return "examples:\n" + "\n".join(f"  {line}" for line in lines)


class Parser(argparse.ArgumentParser):
    """A parser whose usage errors raise :class:`~unidyn.cli.errors.UsageError` (one
    line, exit status 2) instead of printing the usage and exiting."""

    def error(self, message):
        raise UsageError(f"{message} (see '{self.prog} --help')")


def tolerance_arguments(p) -> None:
    """--rtol and --atol on the parser ``p``."""
    p.add_argument("--rtol", type=float, help="relative tolerance of the integration, as "
                   "solve_ivp's (default 1e-8 for the diagram; the batch engine starts at "
                   "1e-6 and tightens each run until its estimated error is within 1e-4)")
    p.add_argument("--atol", type=float, help="absolute tolerance of the integration "
                   "(default 1e-10 for the diagram, 1e-8 for the batch engine)")


def tolerance_options(args) -> dict:
    """--rtol and --atol, where given: the same tolerances for either engine (keyword
    arguments of :func:`unidyn.run` and :func:`~unidyn.sweeps.sweep.run_sweep`)."""
    return {k: getattr(args, k) for k in ("rtol", "atol") if getattr(args, k) is not None}


def parser() -> argparse.ArgumentParser:
    """The ``unidyn`` command's parser: every subcommand and option, with its help texts;
    ``args.command`` names the subcommand (and the module of this package that runs it)."""
    p = Parser(prog="unidyn", description="Differential-drive robots with the velocity-based "
               "dynamic model of Martins et al. (2017): simulations, sweeps, parameters.")
    p.add_argument("--version", action="version", version=f"unidyn {__version__}")
    sub = p.add_subparsers(dest="command", metavar="COMMAND", parser_class=Parser)
    sub.required = True

    r = sub.add_parser("run", help="simulate one scenario and write its results",
                       description="Simulate one scenario (the paper's defaults, a TOML file, "
                       "then flags, then --set) and write timeseries.csv, summary.json and "
                       "figures into --out.",
                       formatter_class=Formatter, epilog=examples(
                           "unidyn run --paper 4 --T 20 --out out/p4     # the paper's 4th, 20 s",
                           "unidyn run --paper 3 --seeds 8 --out out/p3-seeds  # over 8 noise seeds",
                           "unidyn run examples/scenario.toml --out out/circle",
                           "unidyn run --case compensated --robot p3dx --set kx=1 --set ky=1 "
                           "--set noise=off --T 15 --out out/c",
                           "unidyn run --paper 2 --T 10 --engine bdsim --out out/p2-diagram",
                           "unidyn run --paper experiment --out out/experiment"))
    r.add_argument("scenario", nargs="?", metavar="SCENARIO.toml",
                   help="scenario fields (top level or a [scenario] table)")
    r.add_argument("--paper", type=_paper_choice, choices=(1, 2, 3, 4, "experiment"),
                   help="start from the paper's simulation N (Section 5); 'experiment': "
                        "Section 5's experiment, both controllers over several noise seeds, "
                        "with claims.md beside the paper's numbers")
    r.add_argument("--seeds", type=int, metavar="N",
                   help="run the scenario over N noise seeds, from its own (noise.seed) on: "
                        "each metric as mean ± standard error (n); writes runs.csv, "
                        "statistics.csv, timeseries.csv, summary.json and error.png. With "
                        "--paper experiment: noise seeds 0..N-1 (default 8)")
    r.add_argument("--from", dest="from_", metavar="SUMMARY.json",
                   help="rebuild the scenario (and engine) of a previous run's summary.json")
    r.add_argument("--case", help="kinematic, uncompensated, compensated or adaptive")
    r.add_argument("--robot", help="preset name (see 'unidyn robots') or a theta.json file")
    r.add_argument("--T", type=float, help="duration, s")
    r.add_argument("--set", action="append", metavar="KEY=VALUE",
                   help="set a scenario field; VALUE is a TOML value (kx=0.5, noise=off, "
                        "'x0=[0,0,0]', noise.seed=3); repeatable")
    r.add_argument("--out", required=True, metavar="DIR", help="output folder")
    r.add_argument("--engine", choices=("auto", "bdsim", "batch"),
                   help="auto (default): the batch engine for continuous control, the bdsim "
                        "diagram for sampled control; bdsim: always the diagram")
    tolerance_arguments(r)
    r.add_argument("--overwrite", action="store_true", help="replace results already in DIR")
    r.add_argument("--animate", action="store_true", help="also write DIR/animation.gif")
    r.add_argument("--bag", metavar="FILE.mcap",
                   help="also write the run as a ROS 2 bag (MCAP): Twist commands on /cmd_vel, "
                        "nav_msgs/Odometry on /odom, the reference on /reference; needs "
                        "pip install \"unidyn[ros]\"")

    s = sub.add_parser("sweep", help="run a parameter sweep (resumable)",
                       description="Run every point of a sweep file, or the paper's Fig. 11, "
                       "writing metrics.csv (one row per point), sweep.json and metrics.png "
                       "into --out. An interrupted sweep resumes where it stopped.",
                       formatter_class=Formatter, epilog=examples(
                           "unidyn sweep examples/sweep.toml --out out/sweep",
                           "unidyn sweep --paper-fig11 --gains '[1, 5, 23]' --T 50 --no-noise "
                           "--out out/fig11-three-gains     # all 70 gains: leave out --gains",
                           "unidyn sweep --paper-fig11 --gains '[1, 5, 23]' --seeds 5 "
                           "--out out/fig11-5-seeds     # error bars over 5 noise seeds"))
    s.add_argument("sweep", nargs="?", metavar="SWEEP.toml", help="the sweep file")
    s.add_argument("--paper-fig11", action="store_true",
                   help="the paper's Fig. 11: IAE against kx = ky, four cases; also writes "
                        "fig11.png and claims.md")
    s.add_argument("--gains", help="with --paper-fig11: START:STOP:STEP or a list '[1, 5, 23]' "
                                   "(default 0.5:35:0.5)")
    s.add_argument("--seeds", type=int, metavar="N",
                   help="with --paper-fig11: every point over noise seeds 1..N, the figure and "
                        "claims with mean ± standard error; also writes statistics.csv")
    s.add_argument("--no-noise", action="store_true", help="noise-free runs")
    s.add_argument("--T", type=float, help="duration of every run, s")
    s.add_argument("--out", required=True, metavar="DIR", help="output folder")
    s.add_argument("--engine", choices=("batch", "bdsim"), default="batch")
    s.add_argument("--chunk-size", type=int, metavar="N", help="points per chunk")
    tolerance_arguments(s)
    s.add_argument("--dask", metavar="ADDRESS",
                   help="run the chunks on Dask: 'local' (worker processes on this machine) "
                        "or a scheduler address (tcp://host:8786)")
    s.add_argument("--no-resume", action="store_true",
                   help="start over instead of skipping the points already in DIR (with "
                        "finished rows there, needs --overwrite)")
    s.add_argument("--overwrite", action="store_true",
                   help="allow the finished rows in DIR to be replaced (by a different sweep, "
                        "or with --no-resume); they are kept until the new sweep has finished")
    s.add_argument("--yes", action="store_true",
                   help="start a sweep estimated to take more than an hour or more than half "
                        "the free disk (refused otherwise, before anything is written)")
    s.add_argument("--no-progress", action="store_true",
                   help="no progress (bar or lines) and no estimate of the sweep's size")

    sub.add_parser("robots", help="list the preset robots",
                   description="The preset robots: theta1..theta6 and their source.",
                   formatter_class=Formatter, epilog=examples("unidyn robots"))

    pr = sub.add_parser("properties", help="check the model's properties for a robot",
                        description="Check properties 1-7 of Section 3 for a robot.",
                        formatter_class=Formatter, epilog=examples(
                            "unidyn properties p3dx",
                            "unidyn properties wheelchair_125kg --u-max 1.0"))
    pr.add_argument("robot", metavar="ROBOT", help="preset name or a theta.json file")
    pr.add_argument("--u-max", type=float, help="speed range |u| <= U_MAX, m/s "
                                                "(default: the paper's for the robot)")

    i = sub.add_parser("identify", help="identify theta1..theta6 from one or more logs",
                       description="Identify theta1..theta6 of Eq. (2) from logs of one "
                       "robot: CSV files with columns t, u_ref, w_ref, u, w (other columns are "
                       "ignored; --columns maps other names), or ROS recordings (a ROS 2 bag "
                       "folder, an .mcap file or a ROS 1 .bag) with Twist or TwistStamped "
                       "commands and nav_msgs/Odometry; bags need pip install "
                       "\"unidyn[ros]\". Commands are taken as held from their "
                       "time stamp to the next (--commands linear for smooth ones); gaps in "
                       "the time stamps split a log. Writes theta.json, validation.json and "
                       "validation.png into --out.",
                       formatter_class=Formatter, epilog=examples(
                           "unidyn identify src/unidyn/datasets/log.csv --out out/id",
                           "unidyn identify src/unidyn/datasets/courier.mcap --out out/id-ros",
                           "unidyn identify src/unidyn/datasets/courier.mcap --cmd /cmd_vel --odom /odom "
                           "--cmd-timeout 0.5 --out out/id-topics",
                           "unidyn identify src/unidyn/datasets/log.csv --delay auto --no-validate "
                           "--out out/id-delay"))
    i.add_argument("log", nargs="+", metavar="LOG",
                   help="one or more logs of one robot: CSV files or ROS bags")
    i.add_argument("--cmd", metavar="TOPIC",
                   help="bags: the command topic (default: the one Twist or TwistStamped "
                        "topic, or the one named cmd_vel_out among several)")
    i.add_argument("--odom", metavar="TOPIC",
                   help="bags: the odometry topic (default: the one nav_msgs/Odometry topic; "
                        "with --wheel-radius the one sensor_msgs/JointState topic)")
    i.add_argument("--cmd-timeout", type=float, metavar="SECONDS",
                   help="bags: the robot's driver stops it (command zero) this long after "
                        "the last command (default: each command held until the next)")
    i.add_argument("--wheel-radius", type=float, metavar="M",
                   help="bags: read the measured velocities from the wheel speeds of "
                        "/joint_states (sensor_msgs/JointState) with this wheel radius r, "
                        "m; needs --wheel-separation")
    i.add_argument("--wheel-separation", type=float, metavar="M",
                   help="bags: the distance D between the wheels, m (u = r (wL + wR) / 2, "
                        "w = r (wR - wL) / D)")
    i.add_argument("--wheel-joints", metavar="LEFT,RIGHT",
                   help="bags: the wheel joints' names (default: the joints named left "
                        "and right)")
    i.add_argument("--columns", metavar="NAME=COLUMN,...",
                   help="map t, u_ref, w_ref, u, w to the log's column names, "
                        "e.g. t=time,u=v_meas,w=omega_meas")
    i.add_argument("--scale", metavar="NAME=FACTOR,...",
                   help="multiply u_ref, w_ref, u or w by a factor to bring them to m/s and "
                        "rad/s, e.g. u_ref=0.01 for commands in cm/s")
    i.add_argument("--out", required=True, metavar="DIR")
    i.add_argument("--commands", choices=("held", "linear"), default="held",
                   help="held (default): each command acts from its time stamp until the "
                        "next, as robot firmware applies it; linear: commands vary linearly "
                        "between samples")
    i.add_argument("--delay", metavar="SECONDS|auto",
                   help="input delay: seconds (0.1), samples ('1 samples') or auto to "
                        "estimate it (default 0)")
    i.add_argument("--gap", type=float, metavar="SECONDS",
                   help="a time step longer than this splits a log into pieces, each with "
                        "its own initial state (default: 1.4 times the median step)")
    i.add_argument("--time-unit", choices=("s", "ms", "us", "ns"),
                   help="unit of the logs' time column (default s; a median step over 1 s "
                        "is refused unless --time-unit s is given)")
    i.add_argument("--method", choices=("output-error", "equation-error"),
                   default="output-error",
                   help="output-error (default): fit simulated velocities to the measured "
                        "ones; equation-error: least squares on Eq. (11) (smooth commands)")
    i.add_argument("--smoothing", choices=("filter", "savgol"),
                   help="equation-error derivative handling")
    i.add_argument("--window", type=float, help="equation-error filter / fit window, s")
    i.add_argument("--name", help="name of the identified parameter set")
    i.add_argument("--validate", metavar="HELDOUT",
                   help="validate on this log, CSV or bag (default: the identification "
                        "logs, in-sample)")
    i.add_argument("--no-validate", action="store_true",
                   help="skip the validation simulation and figure")
    i.add_argument("--overwrite", action="store_true", help="replace a theta.json in DIR")

    e = sub.add_parser("edit", help="open a .bd file in bdsim's editor, bdedit",
                       description="Open a block-diagram file in bdedit with unidyn's blocks "
                       "in its palette and the file's simulation time in the toolbar; says "
                       "which system libraries Qt lacks, if any (needs unidyn[teach]).",
                       formatter_class=Formatter, epilog=examples(
                           "unidyn edit examples/bd/fig2_case3_compensated.bd"))
    e.add_argument("file", metavar="FILE.bd", help="the block-diagram file")
    return p


def _paper_choice(text: str):
    """--paper: a simulation number 1-4, or "experiment" (argparse checks the choices)."""
    text = text.strip()
    return int(text) if text.isdigit() else text
