"""The ``unidyn`` command: run scenarios and sweeps, list robots, check properties,
identify parameters from a log.

    unidyn run --paper 4 --out out/case4
    unidyn run scenario.toml --set kx=0.5 --set noise=off --out out/run1
    unidyn run --from out/run1/summary.json --out out/run1-again
    unidyn sweep sweep.toml --out out/sweep
    unidyn sweep --paper-fig11 --no-noise --out out/fig11
    unidyn robots
    unidyn properties p3dx --u-max 1.2
    unidyn identify log.csv --columns t=time,u=v_meas,w=omega_meas --out out/ident
    unidyn identify rosbag2_2026_11_25/ --cmd /cmd_vel --out out/ident-ros

Errors in the input (a bad value, malformed TOML, a missing file) print one line
``unidyn: error: ...`` on stderr and exit with status 2. Ctrl-C (SIGINT) and ``kill``
(SIGTERM) stop a command cleanly (it says what it kept), after which the process
ends by that signal, as a shell expects of a command it can stop: the shell's status
is 130 or 143, and a script or loop that ran the command stops with it.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
import warnings
from pathlib import Path

from . import process
from ._errors import (Interrupted, MissingDependency, SimulationError, SimulationInterrupted,
                      ValidationError)

__all__ = ["main"]



class _UsageError(Exception):
    """A command-line usage error (reported on one line, exit status 2)."""


class _RunFailed(Exception):
    """A run that produced nothing to write (one line, exit status 1)."""


class _Formatter(argparse.HelpFormatter):
    """Wraps descriptions as usual; keeps an epilog of examples line by line."""

    def _fill_text(self, text, width, indent):
        if text.startswith("examples:"):
            return "".join(indent + line for line in text.splitlines(keepends=True))
        return super()._fill_text(text, width, indent)


def _examples(*lines: str) -> str:
    return "examples:\n" + "\n".join(f"  {line}" for line in lines)


class _Parser(argparse.ArgumentParser):
    def error(self, message):
        raise _UsageError(f"{message} (see '{self.prog} --help')")


# ------------------------------------------------------------------------ helpers

#: An error message's words longer than this are shortened (a 1 MB value named in a
#: message would bury what the message says).
_LONGEST_WORD = 120


def _shorten(word: str) -> str:
    if len(word) <= _LONGEST_WORD:
        return word
    return f"{word[:60]}...[{len(word)} characters]...{word[-20:]}"


def _flag_words(message: str) -> str:
    """The library's keyword arguments in a message about output folders, as flags."""
    for lib, cli in (("overwrite=True", "--overwrite"), ("resume=False", "--no-resume"),
                     ("out_dir ", "--out ")):
        message = message.replace(lib, cli)
    return message


def _err(message: str) -> None:
    message = " ".join(_shorten(w) for w in str(message).split())  # one line, readable
    print(f"unidyn: error: {message}", file=sys.stderr)


def _split_set(item: str):
    key, sep, value = item.partition("=")
    key = key.strip()
    if not sep or not key:
        raise ValidationError(f"--set expects KEY=VALUE, got {item!r}")
    from .sweeps.sweep_files import parse_toml_value
    return key, parse_toml_value(value.strip())


def _apply_set(d: dict, key: str, value, item: str) -> dict:
    d = dict(d)
    head, dot, rest = key.partition(".")
    if not dot:
        d[key] = value
        return d
    if head not in d:
        raise ValidationError(f"--set {item}: unknown scenario field {head!r}")
    sub = d[head]
    if sub is None:
        raise ValidationError(f"--set {item}: {head} is off; set the whole table, e.g. "
                              f"--set '{head}={{...}}'")
    if not isinstance(sub, dict):
        raise ValidationError(f"--set {item}: {head} is not a table")
    d[head] = _apply_set(sub, rest, value, item)
    return d


def _build_scenario(args):
    """The Scenario from --from / --paper / the file, then flags, then --set."""
    from .model.scenario import Scenario
    if args.from_ and (args.scenario or args.paper):
        raise _UsageError("--from cannot be combined with a scenario file or --paper")
    engine = None
    if args.from_:
        path = Path(args.from_)
        if path.is_dir():
            path = path / "summary.json"
        from .results.folders import check_manifest
        from .results.result import RUN_FILES
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
        raw, where = summary["scenario"], str(path)
        engine = summary.get("engine")
    else:
        raw, where = {}, "defaults"
        if args.paper is not None:
            raw = Scenario.paper(args.paper).to_dict()
            where = f"--paper {args.paper}"
        if args.scenario:
            from .sweeps.sweep_files import read_scenario_table
            raw = {**raw, **read_scenario_table(Path(args.scenario))}
            where = str(args.scenario)
    try:
        sc = Scenario.from_dict(raw)
    except ValidationError as err:
        raise ValidationError(f"{where}: {err}") from None
    d = sc_d = sc.to_dict()
    paper_name = d.get("name") if args.paper is not None else None
    # the flags, then every --set, in order; the scenario must be valid once all are
    # applied (--T 400000 --set log_every=100 is fine although T alone is not)
    steps = [(f"{flag} {value}", lambda d, k=key, v=value: {**d, k: v})
             for flag, key, value in (("--case", "case", args.case),
                                      ("--robot", "robot", args.robot), ("--T", "T", args.T))
             if value is not None]
    for item in args.set or []:
        key, value = _split_set(item)
        steps.append((f"--set {item}", lambda d, k=key, v=value, i=item: _apply_set(d, k, v, i)))
    for what, step in steps:
        try:
            d = step(d)
        except ValidationError as err:
            raise ValidationError(f"{what}: {err}") from None
    try:
        sc = Scenario.from_dict(d)
    except ValidationError as err:
        # name the flag after which the scenario never became valid again
        culprit, trial = (steps[0][0] if steps else where), sc_d
        for k, (what, step) in enumerate(steps[:-1]):
            trial = step(trial)
            try:
                Scenario.from_dict(trial)
                culprit = steps[k + 1][0]
            except ValidationError:
                pass
        raise ValidationError(f"{culprit}: {err}") from None
    from ._validate import MAX_NAME  # numpy loads with it, after the command's signals
    if len(sc.name) > MAX_NAME:
        raise ValidationError(f"name is {len(sc.name)} characters long; at most {MAX_NAME} "
                              f"are allowed (it titles the figures)")
    if paper_name and sc.name == paper_name and sc.case != Scenario.paper(args.paper).case:
        sc = sc.replace(name="")  # the paper's name no longer describes the run
    return sc, engine


def _out(text: str) -> Path:
    """--out as given, once it is known to name a folder (or nothing yet)."""
    from .results.folders import output_folder
    output_folder(text)  # one line for an empty --out or a file
    return Path(text)


def _shown(out: Path, final) -> Path:
    """Where results went, as the user named it: ``out`` when they went there (its
    link's target, for a symbolic link), else the folder's full path."""
    from .results.folders import output_folder
    return out if Path(final) == output_folder(out) else Path(final)


def _import_animation():
    import importlib
    try:
        animation = importlib.import_module(".teaching.animation", __package__)
    except ModuleNotFoundError as err:
        if err.name == f"{__package__}.teaching.animation":
            raise MissingDependency("--animate is not available: this installation has no "
                                    "unidyn.teaching.animation module") from None
        raise MissingDependency(f"--animate needs {err.name}, which is not installed") from None
    if not hasattr(animation, "animate"):
        raise MissingDependency("--animate is not available: unidyn.teaching.animation has no animate()")
    return animation


# ------------------------------------------------------------------------ commands

def _cmd_run(args) -> int:
    from .results.folders import staged_output
    from .results.result import RUN_FILES
    sc, engine_from = _build_scenario(args)
    from .engine.choice import choose
    engine = choose(sc, args.engine or engine_from or "auto")  # as unidyn.run chooses
    out = _out(args.out)
    animation = _import_animation() if args.animate else None
    bag = _bag_target(args)
    # the new results are written into a private folder inside `out` and moved into
    # place only once complete; an error or an interrupt leaves `out` as it was
    # (staged_output also holds the folder's lock: one writer at a time)
    staging = staged_output(out, kind="run", names=RUN_FILES, overwrite=args.overwrite,
                            what="run results")
    try:
        stage, result, wall, replaced = _run_staged(staging, sc, engine, out, animation,
                                                    **_tolerances(args))
    except Interrupted:  # interrupted, the computed part written: it says where
        raise
    except KeyboardInterrupt:
        raise Interrupted(f"{out} is as it was before this run") from None
    status = _run_summary(sc, out, stage, result, wall, replaced, animation)
    if bag is not None:
        _write_bag(result, bag)
    return status


def _bag_target(args):
    """--bag FILE.mcap checked before the run (None without --bag)."""
    if args.bag is None:
        return None
    from .results.rosbag import check_bag_target
    return check_bag_target(args.bag, args.overwrite)


def _write_bag(result, bag) -> None:
    from .results.rosbag import write_run_bag
    write_run_bag(result, bag)
    print(f"written    {bag} (/cmd_vel, /odom, /reference)")


def _tolerances(args) -> dict:
    """--rtol and --atol, where given: the same tolerances for either engine."""
    return {k: getattr(args, k) for k in ("rtol", "atol") if getattr(args, k) is not None}


def _tolerance_arguments(p) -> None:
    p.add_argument("--rtol", type=float, help="relative tolerance of the integration, as "
                   "solve_ivp's (default 1e-8, either engine)")
    p.add_argument("--atol", type=float, help="absolute tolerance of the integration "
                   "(default 1e-10, either engine)")


def _run_staged(staging, sc, engine, out, animation, **options):
    with staging as stage:
        replaced = ", ".join(stage.held)
        if replaced:
            print(f"unidyn: replacing {out}/ ({replaced}) once the new run is written; "
                  f"kept as they are if it fails or is interrupted", file=sys.stderr, flush=True)
        t0 = time.perf_counter()
        from .engine.choice import run
        interrupted = False
        try:
            result = run(sc, engine, **options)
        except SimulationError as err:
            if err.result is None:
                raise _RunFailed(f"the run failed before its first sample: {err}; "
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
        result.save(stage.path)
        if not interrupted:  # after Ctrl-C the data only, at once: no figures
            from .results.plots import save_figures
            save_figures(result, stage.path)
        if animation is not None and not interrupted:
            animation.animate(result, stage.path / "animation.gif")
    if interrupted:
        kept = (f"; {out} keeps its previous results" if stage.held else "")
        raise Interrupted(f"interrupted at t = {float(result.t[-1]):g} s of {sc.T:g} s; the "
                           f"part computed is in {_shown(out, stage.final)} (timeseries.csv "
                           f"and summary.json, complete: "
                           f"false; no figures){kept}")
    return stage, result, wall, replaced


def _run_summary(sc, out, stage, result, wall, replaced, animation) -> int:
    final = _shown(out, stage.final)
    print(f"case       {sc.case}" + (f"  ({_short_name(sc.name)})" if sc.name else ""))
    print(f"robot      {sc.robot.name}")
    backend = getattr(result, "backend", "")
    print(f"engine     {result.engine}" + (f" ({backend})" if backend else "")
          + f", T = {sc.T:g} s, noise "
          + ("off" if sc.noise is None else f"seed {sc.noise.seed}"))
    if result.complete:
        m = result.metrics
        print(f"IAE        {m['iae']:.6g} m·s")
        print(f"error(T)   {m['error_final']:.6g} m")
    else:
        t_end = float(result.t[-1]) if len(result.t) else 0.0
        print(f"result     INCOMPLETE: stopped at t = {t_end:g} s of {sc.T:g} s: "
              f"{' '.join(str(result.message).split())}")
        print("metrics    none (an incomplete run has no IAE; summary.json holds the partial "
              "ones under partial_metrics)")
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


def _short_name(name: str, limit: int = 80) -> str:
    return name if len(name) <= limit else name[:limit - 3] + "..."


def _parse_gains(text: str):
    """'0.5:35:0.5' (start:stop:step, stop included) or a TOML list '[1, 5, 23]'."""
    from .sweeps.sweep_files import expand_range, parse_toml_value
    if ":" in text:
        parts = text.split(":")
        if len(parts) != 3:
            raise ValidationError(f"--gains expects START:STOP:STEP or a list, got {text!r}")
        try:
            start, stop, step = (float(p) for p in parts)
        except ValueError:
            raise ValidationError(f"--gains expects numbers in START:STOP:STEP, "
                                  f"got {text!r}") from None
        return expand_range("--gains", {"start": start, "stop": stop, "step": step})
    v = parse_toml_value(text)
    if not isinstance(v, list):
        v = [v]
    for g in v:
        if isinstance(g, bool) or not isinstance(g, (int, float)) or not g > 0:
            raise ValidationError(f"--gains: every gain must be a number > 0, got {g!r}")
    return [float(g) for g in v]


def _cmd_sweep(args) -> int:
    from .sweeps import sweep as sw
    from .model.noise import PAPER_NOISE
    from .paper import fig11_claims, format_fig11_claims, paper_fig11
    if bool(args.sweep) == bool(args.paper_fig11):
        raise _UsageError("give either a sweep file or --paper-fig11")
    if args.gains is not None and not args.paper_fig11:
        raise _UsageError("--gains applies to --paper-fig11 only (a sweep file has its grid)")
    if args.paper_fig11:
        gains = _parse_gains(args.gains) if args.gains is not None else None
        spec = paper_fig11(T=250.0 if args.T is None else args.T, gains=gains,
                           noise=None if args.no_noise else PAPER_NOISE,
                           **_tolerances(args))
    else:
        spec = sw.Sweep.from_toml(args.sweep)
        changes = {}
        if args.T is not None:
            changes["T"] = args.T
        if args.no_noise:
            changes["noise"] = "off"
        try:
            if changes:
                spec = spec.with_base(**changes)
            if _tolerances(args):
                import dataclasses
                spec = dataclasses.replace(spec, **_tolerances(args))
        except ValidationError as err:
            raise ValidationError(f"{args.sweep}: {err}") from None
    from .results.folders import output_folder
    out = _out(args.out)
    n = len(spec)
    if args.dask is None:
        client, close = None, None
    else:
        from .sweeps.cluster import connect_dask
        client, close = connect_dask(args.dask, "--dask")
    try:
        print(f"sweep: {_short_name(spec.name or str(args.sweep))}: {n} points, engine "
              f"{args.engine}" + (f", Dask at {args.dask}" if args.dask else ""), flush=True)
        run = sw.run_sweep(spec, out, engine=args.engine, chunk_size=args.chunk_size,
                           resume=not args.no_resume, progress=not args.no_progress,
                           dask_address=client, overwrite=args.overwrite)
    finally:
        if close is not None:
            close()
    print(f"ran {run.ran} points" + (f", {run.skipped} already done (resumed)"
                                     if run.skipped else "")
          + f" in {run.seconds:.1f} s; written {out}/ (metrics.csv, sweep.json, metrics.png)")
    if run.replaced:
        print(f"replaced   the previous sweep in {out}/ ({sw._rows_named(run.replaced)})")
    if run.failed:
        print(f"incomplete {len(run.failed)} of {len(run.rows)} point(s) did not complete "
              f"(complete = false, empty metrics; left out of summaries): points "
              f"{', '.join(map(str, run.failed[:10]))}" + (", ..." if len(run.failed) > 10
                                                           else ""))
        print(f"unidyn: warning: {len(run.failed)} point(s) did not complete: "
              f"{', '.join(map(str, run.failed[:10]))}", file=sys.stderr)
    if args.paper_fig11:
        base = spec.points()[0].scenario
        noise = ("off" if base.noise is None else
                 f"position std {base.noise.position_std:g} m, velocity std "
                 f"{base.noise.velocity_std:g}, seed {base.noise.seed}")
        title = (f"Fig. 11 claims: T = {base.T:g} s, {len(spec.grid['kxy'])} gains "
                 f"{min(spec.grid['kxy']):g}..{max(spec.grid['kxy']):g}, noise {noise}, "
                 f"engine {args.engine}")
        claims = fig11_claims(run.rows)
        table = format_fig11_claims(claims, title=f"**{title}**")
        from .paper import plot_fig11
        from .results.folders import FolderLock, Ledger
        with FolderLock(out):  # recorded as the sweep's files, by their content
            ledger = Ledger(output_folder(out), "sweep", sw.SWEEP_FILES)
            ledger.write("claims.md", table + "\n")
            ledger.write_with("fig11.png", lambda path: plot_fig11(
                run.rows, path, title=f"IAE, T = {base.T:g} s, noise "
                + ("off" if base.noise is None else "on")))
        print()
        print(table)
        print(f"\nwritten {out}/claims.md and {out}/fig11.png")
    return 1 if run.failed else 0


def _cmd_robots(args) -> int:
    from .model import robots
    names = robots.names()
    w = max(len(n) for n in names)
    head = f"{'name':{w}s} " + " ".join(f"{f'theta{i}':>10s}" for i in range(1, 7)) + "  source"
    print(head)
    for n in names:
        r = robots.get(n)
        print(f"{n:{w}s} " + " ".join(f"{v:10.6g}" for v in r.theta) + f"  {r.source}")
    return 0


def _cmd_properties(args) -> int:
    from .model import robots
    from .model.properties import check_properties
    robot = robots.resolve(args.robot, "robot")
    print(check_properties(robot, args.u_max))
    return 0


def _parse_columns(text: str) -> dict:
    """--columns NAME=COLUMN,... as a mapping; names are t, u_ref, w_ref, u, w."""
    from .identification import COLUMNS
    out = {}
    for part in text.split(","):
        part = part.strip()
        if not part:
            continue
        k, sep, v = part.partition("=")
        k, v = k.strip(), v.strip()
        if not sep or not k or not v:
            raise ValidationError(f"--columns expects NAME=COLUMN pairs separated by commas "
                                  f"(e.g. t=time,u=v_meas), got {part[:60]!r}")
        if k not in COLUMNS:
            raise ValidationError(f"--columns: unknown name {k[:40]!r} in {part[:60]!r}; the "
                                  f"names are {', '.join(COLUMNS)} (e.g. --columns t=time,u=v_meas)")
        if k in out:
            raise ValidationError(f"--columns names {k!r} twice")
        out[k] = v
    if not out:
        raise ValidationError("--columns is empty; expected NAME=COLUMN pairs, e.g. "
                              "--columns t=time,u=v_meas")
    return out


def _cli_words(text: str) -> str:
    """The library's argument names in a message, as this command's options."""
    for lib, cli in (("commands='linear'", "--commands linear"),
                     ("commands='held'", "--commands held"),
                     ("delay='auto'", "--delay auto"),
                     ("delay must be <= a third", "--delay must be <= a third"),
                     ("method='output-error'", "--method output-error"),
                     ("use a longer log or a shorter window", "use a longer log or a "
                                                             "smaller --window"),
                     *((f"time_unit='{u}'", f"--time-unit {u}") for u in ("s", "ms", "us", "ns"))):
        text = text.replace(lib, cli)
    return text


def _cmd_identify(args) -> int:
    from . import identification as ident
    from .results.folders import staged_output
    logs = [Path(p) for p in args.log]
    for p in logs:
        if not p.exists():
            raise FileNotFoundError(f"log {p} does not exist")
    bags = _read_bags(ident, logs, args)   # ROS recordings read as logs; CSV paths kept
    if args.validate and args.no_validate:
        raise _UsageError("--validate and --no-validate exclude each other")
    vlog = Path(args.validate) if args.validate else None
    if vlog is not None and not vlog.exists():
        raise FileNotFoundError(f"validation log {vlog} does not exist")
    columns = _parse_columns(args.columns) if args.columns is not None else None
    if columns is not None and bags:
        raise _UsageError("--columns applies to CSV logs, not to bags (--cmd and --odom "
                          "choose their topics)")
    if args.time_unit is not None and bags:
        raise _UsageError("--time-unit applies to CSV logs, not to bags (a bag's stamps are "
                          "read in seconds)")
    from .identification.bags import is_bag
    if vlog is not None and is_bag(vlog):
        vlog = _read_bags(ident, [vlog], args)[0]
    delay = 0.0
    if args.delay is not None:
        text = args.delay.strip()
        try:
            delay = float(text)
        except ValueError:
            delay = text if text.lower() == "auto" or text.lower().endswith(
                ("sample", "samples")) else None
        if delay is None or (isinstance(delay, float) and not delay >= 0):
            raise ValidationError(f"--delay expects seconds >= 0 (0.1), samples ('1 samples') "
                                  f"or auto, got {text[:40]!r}")
    kwargs = {"columns": columns, "commands": args.commands, "delay": delay,
              "method": args.method, "validate": False}
    for k in ("smoothing", "window", "name", "gap", "time_unit"):
        if getattr(args, k) is not None:
            kwargs[k] = getattr(args, k)
    logs = [bags.pop(0) if is_bag(p) else p for p in logs]
    out = _out(args.out)
    from .identification.results import IDENTIFY_FILES
    staging = staged_output(out, kind="identify", names=IDENTIFY_FILES,
                            overwrite=args.overwrite, what="identification results")
    with staging as stage:
        replaced = ", ".join(stage.held)
        if replaced:
            print(f"unidyn: replacing {out}/ ({replaced}) once the new identification is "
                  f"written; kept as they are if it fails or is interrupted", file=sys.stderr,
                  flush=True)
        try:
            with warnings.catch_warnings():   # the summary prints them
                warnings.simplefilter("ignore", ident.IdentificationWarning)
                res = ident.identify(*(p if isinstance(p, dict) else str(p) for p in logs),
                                     **kwargs)
        except ident.MissingColumnsError as err:
            have = ", ".join(repr(a[:40]) for a in err.available[:12]) or "no columns"
            want = ",".join(f"{k}=..." for k in err.missing)
            raise ValidationError(f"log {err.source} is missing column(s) "
                                  f"{', '.join(repr(err.mapped[k][:40]) for k in err.missing)}"
                                  f"; it has {have}. Pass --columns {want} to map the "
                                  f"log's names") from None
        except ValidationError as err:
            raise ValidationError(_cli_words(str(err))) from None
        path = res.save(stage.path)
        _record_topics(path, logs)
        for b in logs:
            if isinstance(b, dict):
                print(f"bag        {b['source']}: commands {b['cmd_topic']} ({b['cmd_type']}: "
                      f"{b['cmd_why']}), measured velocities {b['odom_topic']} "
                      f"({b['odom_why']})")
        print(_cli_words(res.summary()))
        if not args.no_validate:
            with warnings.catch_warnings(record=True) as seen:  # rows the held-out log
                warnings.simplefilter("always", ident.IdentificationWarning)  # skipped
                report = ident.validate(res, vlog if isinstance(vlog, dict) else str(vlog),
                                        columns=columns, time_unit=args.time_unit) if vlog else \
                    ident.validation_report(res.theta, *_joined(ident, logs, columns,
                                                                kwargs.get("gap"), args.time_unit),
                                            res.commands, res.delay)
            for w in seen:
                if issubclass(w.category, ident.IdentificationWarning):
                    print(f"warning: {_cli_words(str(w.message))}")
                else:
                    warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
            what = "held-out log" if vlog else "the same log(s) (in-sample)"
            print(f"validation on {what}: NRMSE fit "
                  + ", ".join(f"{k} {v:.1f} %" for k, v in report.fit.items()))
            (stage.path / "validation.json").write_text(
                json.dumps({**report.as_dict(), "log": [_source(vlog)] if vlog else
                            [_source(p) for p in logs], "in_sample": vlog is None},
                           indent=2, allow_nan=False) + "\n")
            from .results.figstyle import save
            axes = ident.plot_validation(report)
            save(axes[0].figure, stage.path / "validation.png")
    final = out  # an identification is never partial: it is where it was asked for
    print(f"written    {final / path.name}")
    if not args.no_validate:
        print(f"written    {final / 'validation.json'}, {final / 'validation.png'}")
    if replaced:  # an identification is swapped in whole or not at all
        print(f"replaced   the previous {replaced}")
    return 0


def _joined(ident, logs, columns, gap=None, time_unit=None):
    """The logs read and joined as identify() joins them: (arrays, pieces)."""
    D, segs, _, _ = ident.join_logs([p if isinstance(p, dict) else str(p) for p in logs],
                                    columns, gap, time_unit=time_unit)
    return D, segs


def _read_bags(ident, paths, args) -> list:
    """The ROS recordings among ``paths`` read as logs (read_bag), in order; with
    --cmd, --odom or --cmd-timeout every path must be one."""
    from .identification.bags import is_bag
    flags = [f for f, v in (("--cmd", args.cmd), ("--odom", args.odom),
                            ("--cmd-timeout", args.cmd_timeout),
                            ("--wheel-radius", args.wheel_radius),
                            ("--wheel-separation", args.wheel_separation),
                            ("--wheel-joints", args.wheel_joints)) if v is not None]
    csv = [p for p in paths if not is_bag(p)]
    if flags and csv:
        raise _UsageError(f"{flags[0]} applies to ROS bags; {csv[0]} is a CSV log")
    if args.cmd_timeout is not None and not args.cmd_timeout > 0:
        raise ValidationError(f"--cmd-timeout must be > 0 seconds, got {args.cmd_timeout:g}")
    with warnings.catch_warnings(record=True) as caught:   # told as one line each
        warnings.simplefilter("always", ident.IdentificationWarning)
        joints = args.wheel_joints.split(",") if args.wheel_joints is not None else None
        logs = [ident.read_bag(p, cmd=args.cmd, odom=args.odom, cmd_timeout=args.cmd_timeout,
                               wheel_radius=args.wheel_radius,
                               wheel_separation=args.wheel_separation, wheel_joints=joints)
                for p in paths if is_bag(p)]
    for w in caught:
        print(f"unidyn: warning: {w.message}", file=sys.stderr)
    return logs


def _source(log) -> str:
    return log["source"] if isinstance(log, dict) else str(log)


def _record_topics(theta_json: Path, logs) -> None:
    """Add the bags' chosen topics to theta.json (a "bags" list), when there are bags."""
    bags = [{"path": b["source"], "cmd_topic": b["cmd_topic"], "cmd_type": b["cmd_type"],
             "odom_topic": b["odom_topic"], "cmd_timeout": b["cmd_timeout"]}
            for b in logs if isinstance(b, dict)]
    if bags:
        d = json.loads(theta_json.read_text())
        d["bags"] = bags
        theta_json.write_text(json.dumps(d, indent=2, allow_nan=False) + "\n")


# ------------------------------------------------------------------------ parser

def _cmd_edit(args) -> int:
    from .editor import edit
    return edit(args.file)


def _parser() -> argparse.ArgumentParser:
    p = _Parser(prog="unidyn", description="Differential-drive robots with the velocity-based "
                "dynamic model of Martins et al. (2017): simulations, sweeps, parameters.")
    from . import __version__
    p.add_argument("--version", action="version", version=f"unidyn {__version__}")
    sub = p.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    sub.required = True

    r = sub.add_parser("run", help="simulate one scenario and write its results",
                       description="Simulate one scenario (the paper's defaults, a TOML file, "
                       "then flags, then --set) and write timeseries.csv, summary.json and "
                       "figures into --out.",
                       formatter_class=_Formatter, epilog=_examples(
                           "unidyn run --paper 4 --T 20 --out out/p4     # the paper's 4th, 20 s",
                           "unidyn run examples/scenario.toml --out out/circle",
                           "unidyn run --case compensated --robot p3dx --set kx=1 --set ky=1 "
                           "--set noise=off --T 15 --out out/c",
                           "unidyn run --paper 2 --T 10 --engine bdsim --out out/p2-diagram"))
    r.add_argument("scenario", nargs="?", metavar="SCENARIO.toml",
                   help="scenario fields (top level or a [scenario] table)")
    r.add_argument("--paper", type=int, choices=(1, 2, 3, 4),
                   help="start from the paper's simulation N (Section 5)")
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
    _tolerance_arguments(r)
    r.add_argument("--overwrite", action="store_true", help="replace results already in DIR")
    r.add_argument("--animate", action="store_true", help="also write DIR/animation.gif")
    r.add_argument("--bag", metavar="FILE.mcap",
                   help="also write the run as a ROS 2 bag (MCAP): Twist commands on /cmd_vel, "
                        "nav_msgs/Odometry on /odom, the reference on /reference; needs "
                        "pip install \"unidyn[ros]\"")
    r.set_defaults(func=_cmd_run)

    s = sub.add_parser("sweep", help="run a parameter sweep (resumable)",
                       description="Run every point of a sweep file, or the paper's Fig. 11, "
                       "writing metrics.csv (one row per point), sweep.json and metrics.png "
                       "into --out. An interrupted sweep resumes where it stopped.",
                       formatter_class=_Formatter, epilog=_examples(
                           "unidyn sweep examples/sweep.toml --out out/sweep",
                           "unidyn sweep --paper-fig11 --gains '[1, 5, 23]' --T 50 --no-noise "
                           "--out out/fig11-three-gains     # all 70 gains: leave out --gains"))
    s.add_argument("sweep", nargs="?", metavar="SWEEP.toml", help="the sweep file")
    s.add_argument("--paper-fig11", action="store_true",
                   help="the paper's Fig. 11: IAE against kx = ky, four cases; also writes "
                        "fig11.png and claims.md")
    s.add_argument("--gains", help="with --paper-fig11: START:STOP:STEP or a list '[1, 5, 23]' "
                                   "(default 0.5:35:0.5)")
    s.add_argument("--no-noise", action="store_true", help="noise-free runs")
    s.add_argument("--T", type=float, help="duration of every run, s")
    s.add_argument("--out", required=True, metavar="DIR", help="output folder")
    s.add_argument("--engine", choices=("batch", "bdsim"), default="batch")
    s.add_argument("--chunk-size", type=int, metavar="N", help="points per chunk")
    _tolerance_arguments(s)
    s.add_argument("--dask", metavar="ADDRESS",
                   help="run the chunks on Dask: 'local' (worker processes on this machine) "
                        "or a scheduler address (tcp://host:8786)")
    s.add_argument("--no-resume", action="store_true",
                   help="start over instead of skipping the points already in DIR (with "
                        "finished rows there, needs --overwrite)")
    s.add_argument("--overwrite", action="store_true",
                   help="allow the finished rows in DIR to be replaced (by a different sweep, "
                        "or with --no-resume); they are kept until the new sweep has finished")
    s.add_argument("--no-progress", action="store_true", help="no progress bar")
    s.set_defaults(func=_cmd_sweep)

    rb = sub.add_parser("robots", help="list the preset robots",
                        description="The preset robots: theta1..theta6 and their source.",
                        formatter_class=_Formatter, epilog=_examples("unidyn robots"))
    rb.set_defaults(func=_cmd_robots)

    pr = sub.add_parser("properties", help="check the model's properties for a robot",
                        description="Check properties 1-7 of Section 3 for a robot.",
                        formatter_class=_Formatter, epilog=_examples(
                            "unidyn properties p3dx",
                            "unidyn properties wheelchair_125kg --u-max 1.0"))
    pr.add_argument("robot", metavar="ROBOT", help="preset name or a theta.json file")
    pr.add_argument("--u-max", type=float, help="speed range |u| <= U_MAX, m/s "
                                                "(default: the paper's for the robot)")
    pr.set_defaults(func=_cmd_properties)

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
                       formatter_class=_Formatter, epilog=_examples(
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
    i.set_defaults(func=_cmd_identify)

    e = sub.add_parser("edit", help="open a .bd file in bdsim's editor, bdedit",
                       description="Open a block-diagram file in bdedit with unidyn's blocks "
                       "in its palette and the file's simulation time in the toolbar; says "
                       "which system libraries Qt lacks, if any (needs unidyn[teach]).",
                       formatter_class=_Formatter, epilog=_examples(
                           "unidyn edit examples/bd/fig2_case3_compensated.bd"))
    e.add_argument("file", metavar="FILE.bd", help="the block-diagram file")
    e.set_defaults(func=_cmd_edit)
    return p


def _show_warning(message, category, filename, lineno, file=None, line=None):
    """A warning as the command's other messages: one line on stderr."""
    print(f"unidyn: warning: {' '.join(str(message).split())}", file=sys.stderr)


def main(argv=None) -> int:
    """Run the ``unidyn`` command line; returns the exit status."""
    try:
        with warnings.catch_warnings():
            warnings.showwarning = _show_warning  # the hook the warnings module offers
            args = _parser().parse_args(argv)
            return int(args.func(args) or 0)
    except SystemExit as exc:  # --help, --version
        return exc.code if isinstance(exc.code, int) else (0 if exc.code is None else 2)
    except _RunFailed as err:
        _err(err)
        return 1
    except (ValidationError, _UsageError, MissingDependency) as err:
        _err(_flag_words(str(err)))
        return 2
    except BrokenPipeError:  # e.g. piped into head: stop quietly
        import os
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        return 141
    except FileNotFoundError as err:
        _err(err.args[0] if len(err.args) == 1 else f"no such file: {err.filename}")
        return 2
    except OSError as err:
        _err(f"{err.strerror or err}" + (f": {err.filename}" if err.filename else ""))
        return 2
    except RecursionError:  # input nested deeper than Python can walk
        _err("input nested too deeply to process")
        return 2
    except Exception as err:
        # Ctrl-C inside an import or a library's C code, reported as that library's error
        status = process.interrupt_status(err)
        if status is None:
            raise
        return status
    except KeyboardInterrupt as err:  # Ctrl-C or kill: one line, with what was kept
        return process.interrupt_status(err)


def entry(argv=None) -> int:
    """Run the command line in this process as the ``unidyn`` command does, and return
    its exit status: :func:`main` with the command's signal handling
    (:func:`unidyn.process.command_signals`): SIGTERM (``kill``) stops the command as
    Ctrl-C does, so it removes its staging folder and temporary files (status 143).
    The signal handlers found are restored on return, so that a script or a notebook
    can call it; only the ``unidyn`` command itself (:func:`script`) ends the process."""
    with process.command_signals():
        return main(argv)


def script(argv=None) -> None:
    """The ``unidyn`` console script and ``python -m unidyn``: :func:`entry`, then the
    process ends with the command's status; stopped by Ctrl-C or ``kill``, it ends by
    that signal (:func:`unidyn.process.end`), so that a shell loop running it stops."""
    process.run_command(entry, argv)


if __name__ == "__main__":  # pragma: no cover
    script()
