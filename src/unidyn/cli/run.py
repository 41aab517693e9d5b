"""``unidyn run``: simulate one scenario (the paper's defaults, a TOML file, a
previous run's summary.json, then flags, then --set) and write timeseries.csv,
summary.json and figures into --out; a run that fails or is interrupted leaves --out
as it was, or writes the part computed, marked incomplete. With ``--seeds N``, the
scenario over N noise seeds, each metric as mean ± standard error
(:class:`unidyn.sweeps.seeds.SeedRuns`)."""

from __future__ import annotations

import importlib
import json
import sys
import time
from pathlib import Path

from .._errors import (
    Interrupted,
    MissingDependency,
    SimulationError,
    SimulationInterrupted,
    ValidationError,
)
from .._validate import MAX_NAME
from ..engines import choose, run
from ..model.metrics import METRIC_NAMES, METRICS
from ..model.scenario import Scenario
from ..results.folders import check_manifest, list_files, staged_output
from ..results.plots import save_figures
from ..results.result import RUN_FILES, has_noise
from ..results.rosbag import check_bag_target, write_run_bag
from ..sweeps.seeds import SEED_FILES, plus_minus
from ..sweeps.sweep_files import (
    parse_toml_value,
    read_scenario_table,
    scenario_from_layers,
)
from .arguments import tolerance_options
from .errors import RunFailed, UsageError
from .output import out_folder, refuse_other_results, short_name, shown


def unidyn_run(args) -> int:
    """``unidyn run``: simulate one scenario and write its results into --out."""
    if args.paper == "experiment":  # its module loads the paper's, and so bdsim
        return importlib.import_module(f"{__package__}.experiment").run_experiment(args)
    sc, engine_from = _build_scenario(args)
    engine = choose(sc, args.engine or engine_from or "auto")  # as unidyn.run chooses
    out = out_folder(args.out)
    refuse_other_results(out, "run" if args.seeds is None else "seeds")
    if args.seeds is not None:
        return _run_seeds(args, sc, engine, out)
    animation = _import_animation() if args.animate else None
    bag = _bag_target(args)
    # the new results are written into a private folder inside `out` and moved into
    # place only once complete; an error or an interrupt leaves `out` as it was
    # (staged_output also holds the folder's lock: one writer at a time)
    staging = staged_output(out, kind="run", names=RUN_FILES, overwrite=args.overwrite,
                            what="run results")
    try:
        stage, result, wall, replaced = _run_staged(staging, sc, engine, out, animation,
                                                    args, **tolerance_options(args))
    except Interrupted:  # interrupted, the computed part written: it says where
        raise
    except KeyboardInterrupt:
        raise Interrupted(f"{out} is as it was before this run") from None
    status = _run_summary(sc, out, stage, result, wall, replaced, animation)
    if bag is not None:
        _write_bag(result, bag)
    return status


def _say_defaults(args, sc, engine) -> None:
    """Without a scenario file, --paper or --from, what runs is the defaults (with the
    flags given): said as the run starts, so that it is not a silent 200 s default."""
    if not (args.scenario or args.paper or args.from_):
        print(f"running    the defaults (no scenario file, --paper or --from given): case "
              f"{sc.case}, robot {sc.robot.name}, T = {sc.T:g} s, engine {engine}", flush=True)


def _split_set(item: str):
    key, sep, value = item.partition("=")
    key = key.strip()
    if not sep or not key:
        raise ValidationError(f"--set expects KEY=VALUE, got {item!r}")
    return key, parse_toml_value(value.strip())


def _build_scenario(args):
    """The Scenario from --from, or the defaults, --paper and the file; then the flags,
    then every --set, in order (the layers of
    :func:`~unidyn.sweeps.sweep_files.scenario_from_layers`); and the engine a --from
    summary names (or None)."""
    if args.from_ and (args.scenario or args.paper):
        raise UsageError("--from cannot be combined with a scenario file or --paper")
    engine = None
    if args.from_:
        path = Path(args.from_)
        if path.is_dir():
            path = path / "summary.json"
        problem = check_manifest(path.parent, "run", RUN_FILES, [path.name])  # one run's
        if problem:
            raise ValidationError(f"--from {args.from_}: {problem}")
        try:
            summary = json.loads(path.read_text())
        except FileNotFoundError:
            raise FileNotFoundError(f"{path} does not exist") from None
        except ValueError as err:
            raise ValidationError(f"{path}: not valid JSON: {err}") from None
        if not isinstance(summary, dict) or not isinstance(summary.get("scenario"), dict):
            raise ValidationError(f"{path} has no 'scenario' table; is it a summary.json "
                                  f"written by unidyn run?")
        base = [(str(path), summary["scenario"])]
        engine = summary.get("engine")
    else:
        base = [("defaults", {})]
        if args.paper is not None:
            base.append((f"--paper {args.paper}", Scenario.paper(args.paper).to_dict()))
        if args.scenario:
            base.append((str(args.scenario), read_scenario_table(Path(args.scenario))))
    sc = scenario_from_layers(base)
    paper_name = sc.name if args.paper is not None else None
    # the flags, then every --set, in order, over the scenario they start from (whose
    # tables --set noise.seed=3 sets a field of); valid once all are applied
    layers = [(base[-1][0], sc.to_dict())]
    layers += [(f"{flag} {value}", {key: value})
               for flag, key, value in (("--case", "case", args.case),
                                        ("--robot", "robot", args.robot), ("--T", "T", args.T))
               if value is not None]
    layers += [(f"--set {item}", dict([_split_set(item)])) for item in args.set or []]
    sc = scenario_from_layers(layers)
    if len(sc.name) > MAX_NAME:
        raise ValidationError(f"name is {len(sc.name)} characters long; at most {MAX_NAME} "
                              f"are allowed (it titles the figures)")
    if paper_name and sc.name == paper_name and sc.case != Scenario.paper(args.paper).case:
        sc = sc.replace(name="")  # the paper's name no longer describes the run
    return sc, engine


def _import_animation():
    """unidyn.teaching.animation, loaded for --animate only: it needs optional packages
    (unidyn[teach]), and says which is missing."""
    try:
        animation = importlib.import_module("unidyn.teaching.animation")
    except ModuleNotFoundError as err:
        if err.name == "unidyn.teaching.animation":
            raise MissingDependency("--animate is not available: this installation has no "
                                    "unidyn.teaching.animation module") from None
        raise MissingDependency(f"--animate needs {err.name}, which is not installed") from None
    if not hasattr(animation, "animate"):
        raise MissingDependency("--animate is not available: unidyn.teaching.animation has no animate()")
    return animation


def _bag_target(args):
    """--bag FILE.mcap checked before the run (None without --bag): a recording unidyn
    did not write is never replaced, and one it wrote only with --overwrite."""
    if args.bag is None:
        return None
    return check_bag_target(args.bag, args.overwrite)


def _write_bag(result, bag) -> None:
    if write_run_bag(result, bag):
        print(f"written    {bag.given} (/cmd_vel, /odom, /reference)")
    else:
        print(f"kept       {bag.given} as it was: an incomplete run does not replace a "
              f"recording")


def _run_staged(staging, sc, engine, out, animation, args, **options):
    with staging as stage:
        _say_defaults(args, sc, engine)
        replaced = list_files(stage.held)
        if replaced:
            print(f"unidyn: replacing {out}/ ({replaced}) once the new run is written; "
                  f"kept as they are if it fails or is interrupted", file=sys.stderr, flush=True)
        t0 = time.perf_counter()
        interrupted = False
        try:
            result = run(sc, engine, progress=True, **options)  # lines or a bar once past 1 s
        except SimulationError as err:
            if err.result is None:
                raise RunFailed(f"the run failed before its first sample: {err}; "
                                f"{out} is unchanged") from None
            result = err.result  # written below, marked incomplete
        except SimulationInterrupted as err:  # Ctrl-C: keep what was computed
            if err.result is None or len(err.result.t) < 2:
                raise
            # a Ctrl-C after the last sample: the run is complete, and written as such
            result, interrupted = err.result, not err.result.complete
        wall = time.perf_counter() - t0
        if not result.complete:
            stage.incomplete(result.message or "the run stopped early")
        result.save(stage)
        if not interrupted:  # after Ctrl-C the data only, at once: no figures
            save_figures(result, stage.path)
        if animation is not None and not interrupted:
            animation.animate(result, stage.path / "animation.gif")
    if interrupted:
        kept = (f"; {out} keeps its previous results" if stage.held else "")
        raise Interrupted(f"interrupted at t = {float(result.t[-1]):g} s of {sc.T:g} s; the "
                          f"part computed is in {shown(out, stage.final)} (timeseries.csv "
                          f"and summary.json, complete: false; no figures){kept}")
    return stage, result, wall, replaced


def _run_summary(sc, out, stage, result, wall, replaced, animation) -> int:
    final = shown(out, stage.final)
    print(f"case       {sc.case}" + (f"  ({short_name(sc.name)})" if sc.name else ""))
    print(f"robot      {sc.robot.name}" + (
        "; payload " + ", ".join(f"x{m:g} from {t:g} s" for t, m in sc.payload)
        if sc.payload else ""))
    backend = getattr(result, "backend", "")
    print(f"engine     {result.engine}" + (f" ({backend})" if backend else "")
          + f", T = {sc.T:g} s, noise "
          + ("off" if sc.noise is None else f"seed {sc.noise.seed}"))
    m, err = result.metrics, result.numerical_error or {}
    if not result.complete:
        t_end = float(result.t[-1]) if len(result.t) else 0.0
        print(f"result     INCOMPLETE: stopped at t = {t_end:g} s of {sc.T:g} s: "
              f"{' '.join(str(result.message).split())}")
    part = "" if result.complete else f" (to t = {float(result.t[-1]) if len(result.t) else 0:g} s)"
    noisy = has_noise(sc)
    for metric in METRICS:
        k = metric.name
        beside = f"  (numerical error {err[k]:.1e} relative)" if k in err and not noisy else ""
        print(f"{metric.label:10s} {m[k]:.6g} {metric.unit}{part}{beside}")
    if noisy:  # which uncertainty to quote, and how to get it
        print(f"quote      these are one sample of the noise (seed {sc.noise.seed}); their "
              f"spread over seeds is the uncertainty: --seeds N gives mean ± standard error")
        if err:
            print(f"numerical  error at most {max(err.values()):.1e} relative: the "
                  f"integration's alone, not an error bar")
    else:
        print("quote      no noise: deterministic, each number with its numerical error"
              + ("" if err else " (not estimated: the batch engine estimates it)"))
    if result.sensitive:
        print(f"sensitive  True: {result.message}")
    else:
        print("sensitive  False")
        if result.complete and result.message:
            print(f"note       {result.message}")
    print(f"wall time  {wall:.2f} s")
    print(f"written    {final}/ (timeseries.csv, summary.json, figures"
          + (", animation.gif" if animation is not None else "") + ")")
    if replaced and final == out:
        print(f"replaced   the previous {replaced}")
    elif stage.held and final != out:
        print(f"kept       {out}/ as it was: an incomplete run does not replace complete "
              f"results")
    if not result.complete:
        print(f"unidyn: warning: the run stopped early: {result.message}", file=sys.stderr)
        return 1
    return 0


def _run_seeds(args, sc, engine, out) -> int:
    """``--seeds N``: the scenario over N noise seeds (``unidyn.run(sc, seeds=N)``),
    written into --out as :meth:`unidyn.sweeps.seeds.SeedRuns.save` writes it; each
    metric printed as mean ± standard error (n)."""
    if args.seeds < 1:
        raise UsageError(f"--seeds must be at least 1, got {args.seeds}")
    if not has_noise(sc):
        raise UsageError("--seeds: the scenario has no noise, so every seed gives the same "
                         "run (drop noise=off, or set noise.position_std)")
    for flag, given in (("--animate", args.animate), ("--bag", args.bag)):
        if given:
            raise UsageError(f"{flag} writes one run; it cannot be combined with --seeds")
    staging = staged_output(out, kind="seeds", names=SEED_FILES, overwrite=args.overwrite,
                            what="seed runs")
    try:
        with staging as stage:
            _say_defaults(args, sc, engine)
            if stage.held:
                print(f"unidyn: replacing {out}/ ({list_files(stage.held)}) once the new runs "
                      f"are written; kept as they are if it fails or is interrupted",
                      file=sys.stderr, flush=True)
            t0 = time.perf_counter()
            runs = run(sc, engine, seeds=args.seeds, progress=True, **tolerance_options(args))
            wall = time.perf_counter() - t0
            if not runs.complete:
                stage.incomplete(next(r.message for r in runs if not r.complete))
            runs.write(stage.path)
    except KeyboardInterrupt:
        raise Interrupted(f"{out} is as it was before these runs") from None
    final = shown(out, stage.final)
    st, n, first = runs.statistics, runs.statistics["n"], runs[0]
    print(f"case       {sc.case}" + (f"  ({short_name(sc.name)})" if sc.name else ""))
    print(f"robot      {sc.robot.name}")
    print(f"engine     {first.engine}" + (f" ({first.backend})" if first.backend else "")
          + f", T = {sc.T:g} s, noise seeds {runs.seeds[0]}"
          + (f"-{runs.seeds[-1]}" if len(runs.seeds) > 1 else "") + f" ({len(runs)} runs)")
    for metric in METRICS:
        m = metric.name
        line = (f"{metric.label:10s} {plus_minus(st[f'{m}_mean'], st[f'{m}_sem'], metric.unit)}"
                f" (n = {n})")
        if runs.numerical_error_small(m) is False:
            line += (f"  (numerical error {runs.numerical_error(m):.1e} relative: not small "
                     f"against the standard error)")
        print(line)
    print(f"quote      mean ± standard error (std / sqrt(n)) over the {n} seeds"
          + ("" if n > 1 else "; one seed has no spread: use more seeds"))
    if all(runs.numerical_error_small(m) for m in METRIC_NAMES):
        print("numerical  error below a tenth of each standard error")
    elif n and any(runs.numerical_error(m) is None for m in METRIC_NAMES):
        print("numerical  error not estimated for every run"
              + (" (the diagram integrates once)" if first.engine == "bdsim" else ""))
    print(f"sensitive  {st['sensitive']} of {len(runs)} runs")
    if st["incomplete"]:
        print(f"incomplete {st['incomplete']} of {len(runs)} runs stopped early, left out of "
              f"the statistics (runs.csv says why)")
    print(f"wall time  {wall:.2f} s")
    print(f"written    {final}/ (runs.csv, statistics.csv, timeseries.csv, summary.json, "
          f"error.png)")
    if stage.held and final == out:
        print(f"replaced   the previous {list_files(stage.held)}")
    elif stage.held:
        print(f"kept       {out}/ as it was: incomplete runs do not replace complete results")
    return 0 if runs.complete else 1
