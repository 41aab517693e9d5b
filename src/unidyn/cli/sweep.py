"""``unidyn sweep``: every point of a sweep file, or the paper's Fig. 11 (with its
claims table and figure), run into --out; an interrupted sweep resumes where it
stopped."""

from __future__ import annotations

import dataclasses
import sys

from .._errors import ValidationError
from ..engines import warn_if_plain
from ..model.noise import PAPER_NOISE
from ..paper import fig11_claims, format_fig11_claims, paper_fig11, plot_fig11
from ..results.folders import FolderLock, Ledger, output_folder
from ..sweeps.cluster import connect_dask
from ..sweeps.sweep import SWEEP_FILES, Sweep, rows_named, run_sweep
from ..sweeps.sweep_files import expand_range, finished_rows, parse_toml_value
from .arguments import tolerance_options
from .errors import UsageError
from .output import out_folder, refuse_other_results, short_name

#: Sweeps of at most this many points say at their start whether the batch engine would
#: run them as plain Python, and how long that would take (each point's scenario is
#: built for it); a larger sweep's time is measured on its first points instead.
PLAIN_CHECKED = 10_000


def unidyn_sweep(args) -> int:
    """``unidyn sweep``: run a sweep file or the paper's Fig. 11 into --out."""
    spec = _sweep(args)
    out = out_folder(args.out)
    refuse_other_results(out, "sweep")
    run = _run(spec, out, args)
    print(f"ran {run.ran} points" + (f", {run.skipped} already done (resumed)"
                                     if run.skipped else "")
          + f" in {run.seconds:.1f} s; written {out}/ (metrics.csv, sweep.json, metrics.png"
          + (", statistics.csv" if "seed" in spec.axes else "") + ")")
    if run.replaced:
        print(f"replaced   the previous sweep in {out}/ ({rows_named(run.replaced)})")
    if run.failed:
        print(f"incomplete {len(run.failed)} of {len(run.rows)} point(s) did not complete "
              f"(complete = false, the metrics of the part computed; left out of "
              f"summaries): points "
              f"{', '.join(map(str, run.failed[:10]))}" + (", ..." if len(run.failed) > 10
                                                           else ""))
        print(f"unidyn: warning: {len(run.failed)} point(s) did not complete: "
              f"{', '.join(map(str, run.failed[:10]))}", file=sys.stderr)
    if args.paper_fig11:
        _fig11_claims(spec, run, out, args.engine)
    return 1 if run.failed else 0


def _sweep(args) -> Sweep:
    """The sweep the options ask for: the paper's Fig. 11, or the sweep file with
    --T, --no-noise and the tolerances applied; options that do not go together
    refused."""
    if bool(args.sweep) == bool(args.paper_fig11):
        raise UsageError("give either a sweep file or --paper-fig11")
    for option, value in (("--gains", args.gains), ("--seeds", args.seeds)):
        if value is not None and not args.paper_fig11:
            raise UsageError(f"{option} applies to --paper-fig11 only (a sweep file has its grid)")
    if args.seeds is not None and args.seeds < 1:
        raise UsageError(f"--seeds must be at least 1, got {args.seeds}")
    if args.seeds is not None and args.no_noise:
        raise UsageError("--seeds with --no-noise: without noise every seed gives the same run")
    if args.paper_fig11:
        gains = _parse_gains(args.gains) if args.gains is not None else None
        return paper_fig11(T=250.0 if args.T is None else args.T, gains=gains,
                           noise=None if args.no_noise else PAPER_NOISE, seeds=args.seeds,
                           **tolerance_options(args))
    spec = Sweep.from_toml(args.sweep)
    changes = {}
    if args.T is not None:
        changes["T"] = args.T
    if args.no_noise:
        changes["noise"] = "off"
    try:
        if changes:
            spec = spec.with_base(**changes)
        if tolerance_options(args):
            spec = dataclasses.replace(spec, **tolerance_options(args))
    except ValidationError as err:
        raise ValidationError(f"{args.sweep}: {err}") from None
    return spec


def _run(spec, out, args):
    """Run the sweep's points into ``out`` (on Dask with --dask)."""
    if args.dask is None:
        client, close = None, None
    else:
        client, close = connect_dask(args.dask, "--dask")
    try:
        n = len(spec)
        print(f"sweep: {short_name(spec.name or str(args.sweep))}: {n:,} points, engine "
              f"{args.engine}" + (f", Dask at {args.dask}" if args.dask else ""), flush=True)
        if args.engine == "batch" and args.dask is None and n <= PLAIN_CHECKED:
            # its time as plain Python, if so (a larger sweep's time is measured)
            done = set(finished_rows(out / "metrics.csv")) if not args.no_resume else set()
            warn_if_plain([p.scenario for p in spec.points()
                           if p.index not in done and p.scenario.control == "continuous"])
        return run_sweep(spec, out, engine=args.engine, chunk_size=args.chunk_size,
                         resume=not args.no_resume, progress=not args.no_progress,
                         dask_address=client, overwrite=args.overwrite, yes=args.yes)
    finally:
        if close is not None:
            close()


def _fig11_claims(spec, run, out, engine) -> None:
    """The paper's Fig. 11 claims judged on the sweep's rows: printed, and written with
    the figure into ``out`` as files of the sweep."""
    base = spec.points()[0].scenario
    noise = ("off" if base.noise is None else
             f"position std {base.noise.position_std:g} m, velocity std "
             f"{base.noise.velocity_std:g}, "
             + (f"{len(spec.grid['seed'])} seeds" if "seed" in spec.grid
                else f"seed {base.noise.seed}"))
    title = (f"Fig. 11 claims: T = {base.T:g} s, {len(spec.grid['kxy'])} gains "
             f"{min(spec.grid['kxy']):g}..{max(spec.grid['kxy']):g}, noise {noise}, "
             f"engine {engine}")
    claims = fig11_claims(run.rows)
    table = format_fig11_claims(claims, title=f"**{title}**")
    with FolderLock(out) as lock:  # recorded as the sweep's files, by their content
        ledger = Ledger(output_folder(out), "sweep", SWEEP_FILES, lock)
        ledger.write("claims.md", table + "\n")
        ledger.write_with("fig11.png", lambda path: plot_fig11(
            run.rows, path, title=f"IAE, T = {base.T:g} s, noise "
            + ("off" if base.noise is None else "on")))
    print()
    print(table)
    print(f"\nwritten {out}/claims.md and {out}/fig11.png"
          + (f" and {out}/statistics.csv" if "seed" in spec.grid else ""))


def _parse_gains(text: str):
    """'0.5:35:0.5' (start:stop:step, stop included) or a TOML list '[1, 5, 23]'."""
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
