"""``unidyn run --paper experiment``: the experiment that ends the paper's Section 5
(:func:`unidyn.paper.experiment`), its own module so that ``unidyn run`` loads the
paper's reproductions (and bdsim with them) only when it is asked for."""

from __future__ import annotations

import time

from .._errors import Interrupted
from ..paper import EXPERIMENT_FILES, EXPERIMENT_PAPER, experiment, write_experiment
from ..results.folders import list_files, staged_output
from .arguments import tolerance_options
from .errors import UsageError
from .output import out_folder, refuse_other_results, shown

__all__ = ["run_experiment"]


def run_experiment(args) -> int:
    """``unidyn run --paper experiment``: Section 5's experiment
    (:func:`unidyn.paper.experiment`) in both engines (or the one --engine names) over
    --seeds noise seeds; writes claims.md, experiment.png, runs.csv and experiment.json
    into --out, staged as a run's files are."""
    given = [flag for flag, value in (
        ("a scenario file", args.scenario), ("--from", args.from_), ("--case", args.case),
        ("--T", args.T), ("--set", args.set), ("--animate", args.animate),
        ("--bag", args.bag), ("--rtol/--atol", tolerance_options(args) or None)) if value]
    if given:
        raise UsageError(f"--paper experiment runs the paper's settings; it takes --robot, "
                         f"--seeds, --engine, --out and --overwrite, not {given[0]}")
    seeds = 8 if args.seeds is None else args.seeds
    if seeds < 1:
        raise UsageError(f"--seeds must be at least 1, got {seeds}")
    engines = {"auto": ("batch", "bdsim"), None: ("batch", "bdsim")}.get(
        args.engine, (args.engine,))
    robot = args.robot or "p3dx_laser"
    out = out_folder(args.out)
    refuse_other_results(out, "experiment")
    staging = staged_output(out, kind="experiment", names=EXPERIMENT_FILES,
                            overwrite=args.overwrite, what="experiment results")
    print(f"experiment: Section 5, robot {robot}, {seeds} noise seeds and one run without "
          f"noise, two controllers, engines {' and '.join(engines)}", flush=True)
    t0 = time.perf_counter()
    try:
        with staging as stage:
            exp = experiment(seeds=seeds, engines=engines, robot=robot, progress=None)
            write_experiment(exp, stage.path)
    except KeyboardInterrupt:
        raise Interrupted(f"{out} is as it was before this run") from None
    st = exp.stats
    mean = lambda k: st[k][0]  # noqa: E731
    err = lambda k: st[k][1]  # noqa: E731
    print(f"{'IAE':<34}{'paper':>8}   {'measured (mean ± SE over seeds)':>34}")
    for label, paper, key in (("15-30 s, before updating", "before", "adaptive before"),
                              ("45-60 s, after updating", "after", "adaptive after"),
                              ("45-60 s, kinematic controller", "kinematic", "kinematic after")):
        print(f"{label:<34}{EXPERIMENT_PAPER[paper]:>8.2f}   "
              f"{mean(key):>25.3f} ± {err(key):.3f} m·s")
    P = EXPERIMENT_PAPER
    print(f"ratio after/before                {P['after'] / P['before']:>8.3f}   "
          f"{mean('after/before'):>25.3f} ± {err('after/before'):.3f}")
    print(f"ratio kinematic/before            {P['kinematic'] / P['before']:>8.3f}   "
          f"{mean('kinematic/before'):>25.3f} ± {err('kinematic/before'):.3f}")
    verdict = {True: "holds", False: "does not hold", None: "not compared"}
    for c in exp.claims:
        print(f"  {verdict[c.holds]:<14} {c.case}")
    print(f"wall time  {time.perf_counter() - t0:.1f} s")
    print(f"written    {shown(out, stage.final)}/ ({list_files(EXPERIMENT_FILES)})")
    return 0
