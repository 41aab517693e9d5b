"""``unidyn identify``: theta1..theta6 of Eq. (2) from logs of one robot (CSV files
or ROS bags), written into --out as theta.json, with its validation on a held-out
log or in-sample (validation.json, validation.png); the library's messages in the
command's words."""

from __future__ import annotations

import json
import re
import sys
import time
import warnings
from pathlib import Path

from .. import identification as ident
from .._errors import ValidationError
from ..identification.bags import is_bag
from ..identification.checks import fit_refused
from ..identification.estimator import read_delay
from ..identification.logs import COLUMNS, POSE, SCALED
from ..identification.results import IDENTIFY_FILES
from ..progress import Progress
from ..results.figstyle import save
from ..results.folders import list_files, staged_output, write_atomic
from .errors import UsageError
from .output import out_folder

#: The steps of ``unidyn identify`` as its progress counts them.
STEPS = ("the fit", "the validation", "its figure")


def unidyn_identify(args) -> int:
    """``unidyn identify``: theta1..theta6 from the logs, written into --out with its
    validation. Its steps, the fit and the validation's simulation, can take minutes on
    long logs: they are shown as they pass (:class:`unidyn.progress.Progress`), and the
    summary ends with what was written and how long it took."""
    t0 = time.perf_counter()
    logs, vlog, kwargs = _inputs(args)
    out = out_folder(args.out)
    staging = staged_output(out, kind="identify", names=IDENTIFY_FILES,
                            overwrite=args.overwrite, what="identification results")
    steps = len(STEPS) - (2 if args.no_validate else 0)
    with staging as stage, Progress(None, steps, desc="unidyn identify", unit="step") as bar:
        replaced = list_files(stage.held)
        if replaced:
            print(f"unidyn: replacing {out}/ ({replaced}) once the new identification is "
                  f"written; kept as they are if it fails or is interrupted", file=sys.stderr,
                  flush=True)
        res = _fit(logs, kwargs)
        bar.advance(1)
        path = res.save(stage)
        _record_topics(path, logs)
        _print_bags(logs)
        print(_cli_words(res.summary()))
        if not args.no_validate:
            _validation(res, logs, vlog, kwargs, stage.path, bar)
    final = out  # an identification is never partial: it is where it was asked for
    print(f"wall time  {time.perf_counter() - t0:.1f} s")
    print(f"written    {final / path.name}")
    if not args.no_validate:
        print(f"written    {final / 'validation.json'}, {final / 'validation.png'}")
    if replaced:  # an identification is swapped in whole or not at all
        print(f"replaced   the previous {replaced}")
    return 0


def _inputs(args):
    """The command's logs (bags read), validation log and identify() options, each
    checked before anything is fitted: (logs, validation log or None, kwargs)."""
    logs = [Path(p) for p in args.log]
    for p in logs:
        if not p.exists():
            raise FileNotFoundError(f"log {p} does not exist")
    bags = _read_bags(ident, logs, args)   # ROS recordings read as logs; CSV paths kept
    if args.validate and args.no_validate:
        raise UsageError("--validate and --no-validate exclude each other")
    vlog = Path(args.validate) if args.validate else None
    if vlog is not None and not vlog.exists():
        raise FileNotFoundError(f"validation log {vlog} does not exist")
    columns = _parse_columns(args.columns) if args.columns is not None else None
    scale = _parse_scale(args.scale) if getattr(args, "scale", None) is not None else None
    if columns is not None and bags:
        raise UsageError("--columns applies to CSV logs, not to bags (--cmd and --odom "
                         "choose their topics)")
    if args.time_unit is not None and bags:
        raise UsageError("--time-unit applies to CSV logs, not to bags (a bag's stamps are "
                         "read in seconds)")
    if vlog is not None and is_bag(vlog):
        vlog = _read_bags(ident, [vlog], args)[0]
    kwargs = {"columns": columns, "commands": args.commands, "delay": _delay(args),
              "method": args.method, "validate": False, "scale": scale}
    for k in ("smoothing", "window", "name", "gap", "time_unit"):
        if getattr(args, k) is not None:
            kwargs[k] = getattr(args, k)
    logs = [bags.pop(0) if is_bag(p) else p for p in logs]
    return logs, vlog, kwargs


def _delay(args):
    """--delay as identify() takes it, checked before the logs are read."""
    if args.delay is None:
        return 0.0
    try:
        kind, value = read_delay(args.delay)
    except ValidationError as err:
        raise ValidationError(_cli_words(str(err))) from None
    return value if kind == "s" else args.delay


def _fit(logs, kwargs):
    """identify() on the logs, its messages in the command's words."""
    try:
        with warnings.catch_warnings():   # the summary prints them
            warnings.simplefilter("ignore", ident.IdentificationWarning)
            return ident.identify(*(p if isinstance(p, dict) else str(p) for p in logs),
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


def _print_bags(logs) -> None:
    """Which topics of each bag were read, and why."""
    for b in logs:
        if isinstance(b, dict):
            print(f"bag        {b['source']}: commands {b['cmd_topic']} ({b['cmd_type']}: "
                  f"{b['cmd_why']}), measured velocities {b['odom_topic']} "
                  f"({b['odom_why']})")


def _validation(res, logs, vlog, kwargs, folder, bar) -> None:
    """Validate ``res`` on the held-out log (or in-sample), print its fit and write
    validation.json and validation.png into ``folder``."""
    columns, scale, time_unit = kwargs["columns"], kwargs["scale"], kwargs.get("time_unit")
    with warnings.catch_warnings(record=True) as seen, fit_refused(  # rows the
            "the validation's simulation"):  # held-out log skipped: warnings
        warnings.simplefilter("always", ident.IdentificationWarning)
        if vlog:
            report = ident.validate(res, vlog if isinstance(vlog, dict) else str(vlog),
                                    columns=columns, time_unit=time_unit, scale=scale)
        else:
            D, segs = _joined(ident, logs, columns, kwargs.get("gap"), time_unit, scale)
            report = ident.validation_report(res.theta, D, segs, res.commands, res.delay)
    bar.advance(1)
    for w in seen:
        if issubclass(w.category, ident.IdentificationWarning):
            print(f"warning: {_cli_words(str(w.message))}")
        else:
            warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
    what = "held-out log" if vlog else "the same log(s) (in-sample)"
    print(f"validation on {what}: NRMSE fit "
          + ", ".join(f"{k} {v:.1f} %" for k, v in report.fit.items()))
    write_atomic(folder / "validation.json", json.dumps(
        {**report.as_dict(), "log": [_source(vlog)] if vlog else
         [_source(p) for p in logs], "in_sample": vlog is None},
        indent=2, allow_nan=False) + "\n")
    axes = ident.plot_validation(report)
    save(axes[0].figure, folder / "validation.png")
    bar.advance(1)


def _parse_columns(text: str) -> dict:
    """--columns NAME=COLUMN,... as a mapping; names are t, u_ref, w_ref, u, w."""
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
        if k not in COLUMNS + POSE:
            raise ValidationError(f"--columns: unknown name {k[:40]!r} in {part[:60]!r}; the "
                                  f"names are {', '.join(COLUMNS + POSE)} (e.g. --columns "
                                  f"t=time,u=v_meas)")
        if k in out:
            raise ValidationError(f"--columns names {k!r} twice")
        out[k] = v
    if not out:
        raise ValidationError("--columns is empty; expected NAME=COLUMN pairs, e.g. "
                              "--columns t=time,u=v_meas")
    return out


def _parse_scale(text: str) -> dict:
    """--scale NAME=FACTOR,... as a mapping; names are u_ref, w_ref, u, w."""
    out = {}
    for part in filter(None, (p.strip() for p in text.split(","))):
        k, sep, v = (x.strip() for x in part.partition("="))
        if not sep or k not in SCALED:
            raise ValidationError(f"--scale expects NAME=FACTOR pairs with names "
                                  f"{', '.join(SCALED)} (e.g. --scale u_ref=0.01 for commands "
                                  f"in cm/s), got {part[:60]!r}")
        try:
            out[k] = float(v)
        except ValueError:
            raise ValidationError(f"--scale {k}: {v[:40]!r} is not a number") from None
    if not out:
        raise ValidationError("--scale is empty; expected NAME=FACTOR pairs, e.g. "
                              "--scale u_ref=0.01")
    return out


def _as_flags(option: str, mapping: str) -> str:
    """A mapping as the library writes it ({'u_ref': 0.01}) as the option's pairs."""
    pairs = re.findall(r"'(\w+)': '?([^',}]+)'?", mapping)
    return f"{option} " + ",".join(f"{k}={v}" for k, v in pairs)


def _cli_words(text: str) -> str:
    """The library's argument names in a message, as this command's options."""
    text = re.sub(r"\b(scale|columns)=(\{[^}]*\})",
                  lambda m: _as_flags(f"--{m.group(1)}", m.group(2)), text)
    for lib, cli in (("delay must be", "--delay must be"),
                     ("commands='linear'", "--commands linear"),
                     ("commands='held'", "--commands held"),
                     ("delay='auto'", "--delay auto"),
                     ("method='output-error'", "--method output-error"),
                     ("use a longer log or a shorter window", "use a longer log or a "
                                                             "smaller --window"),
                     *((f"time_unit='{u}'", f"--time-unit {u}") for u in ("s", "ms", "us", "ns"))):
        text = text.replace(lib, cli)
    return text


def _joined(ident, logs, columns, gap=None, time_unit=None, scale=None):
    """The logs read and joined as identify() joins them: (arrays, pieces)."""
    D, segs, _, _ = ident.join_logs([p if isinstance(p, dict) else str(p) for p in logs],
                                    columns, gap, time_unit=time_unit, scale=scale)
    return D, segs


def _read_bags(ident, paths, args) -> list:
    """The ROS recordings among ``paths`` read as logs (read_bag), in order; with
    --cmd, --odom or --cmd-timeout every path must be one."""
    flags = [f for f, v in (("--cmd", args.cmd), ("--odom", args.odom),
                            ("--cmd-timeout", args.cmd_timeout),
                            ("--wheel-radius", args.wheel_radius),
                            ("--wheel-separation", args.wheel_separation),
                            ("--wheel-joints", args.wheel_joints)) if v is not None]
    csv = [p for p in paths if not is_bag(p)]
    if flags and csv:
        raise UsageError(f"{flags[0]} applies to ROS bags; {csv[0]} is a CSV log")
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
        write_atomic(theta_json, json.dumps(d, indent=2, allow_nan=False) + "\n")
