r"""Reading and writing scenario and sweep files: one module for ``unidyn run``,
``unidyn sweep`` and :meth:`unidyn.sweeps.sweep.Sweep.from_toml`.

- TOML: :func:`read_toml` (a scenario or sweep file), :func:`parse_toml_value` (one
  value given on the command line, ``--set kx=0.5``), :func:`read_scenario_table` (a
  scenario file, its fields at the top level or under ``[scenario]``) and
  :func:`read_scenario` (the Scenario of that file, ``unidyn.read_scenario``).
- Sweep definitions: :func:`expand_range` (a range table ``{start, stop, step}`` or
  ``{start, stop, num, log}``), :func:`check_keys` (a table of Scenario fields and the
  special keys :data:`SPECIAL_KEYS`), :func:`scenario_from_layers` (the Scenario of
  stacked tables: base, variant, grid point), :func:`plain` (plain data for a value).
- A sweep's folder: its record ``sweep.json`` (:func:`sweep_record_text`,
  :func:`read_sweep_record`: the definition, its id, engine and library version) and
  ``.sweep-id`` (:func:`sweep_id_text`, :func:`read_sweep_id`); its ``metrics.csv``
  (:func:`read_metrics`, and the cell format of :func:`cell`, :func:`rows_text` and
  :func:`write_rows` that makes every row read back as written).
"""

from __future__ import annotations

import csv
import dataclasses
import io
import json
import math
from collections.abc import Mapping
from numbers import Real
from pathlib import Path

import numpy as np

from .._errors import MissingDependency
from .._validate import ValidationError, did_you_mean, integer, positive, real
from ..model.metrics import METRIC_NAMES
from ..model.scenario import Scenario, plain_value
from ..results.folders import json_ready

__all__ = ["read_toml", "parse_toml_value", "read_scenario_table", "read_scenario", "expand_range",
           "check_keys", "scenario_from_layers", "plain", "read_metrics", "sweep_record_text",
           "read_sweep_record", "sweep_id_text", "read_sweep_id", "MissingDependency",
           "SPECIAL_KEYS", "METRICS", "MAX_POINTS", "RECORD_NAME", "ID_NAME"]

#: Keys that are not Scenario fields but set one or more of them.
SPECIAL_KEYS = ("kxy", "theta_hat_scale", "seed")
#: The per-point metrics written to metrics.csv (:data:`unidyn.model.metrics.METRICS`).
METRICS = METRIC_NAMES
#: A sweep with more points than this is refused (almost surely a typo in a range).
MAX_POINTS = 1_000_000

_CONFLICTS = {"kxy": ("kx", "ky"), "theta_hat_scale": ("theta_hat0",)}


# --------------------------------------------------------------------------- TOML

def _toml():
    try:
        import tomllib
    except ModuleNotFoundError:  # Python < 3.11
        try:
            import tomli as tomllib
        except ModuleNotFoundError:
            raise MissingDependency("reading TOML on Python < 3.11 needs tomli "
                                    "(pip install tomli)") from None
    return tomllib


def read_toml(path, what: str = "file") -> dict:
    """Read a TOML file; a missing file raises ``FileNotFoundError``, malformed TOML a
    :class:`ValidationError` naming the file, line and column."""
    path = Path(path)
    tomllib = _toml()
    try:
        with open(path, "rb") as fh:
            return tomllib.load(fh)
    except FileNotFoundError:
        raise FileNotFoundError(f"{what} {path} does not exist") from None
    except IsADirectoryError:
        raise ValidationError(f"{what} {path} is a folder, not a TOML file") from None
    except tomllib.TOMLDecodeError as err:
        raise ValidationError(f"{path}: malformed TOML: {err}{_quote_hint(path, err)}") from None
    except UnicodeDecodeError as err:
        raise ValidationError(f"{path}: not a UTF-8 text file: {err}") from None
    except RecursionError:
        raise ValidationError(f"{path}: TOML nested too deeply to read") from None


def _quote_hint(path, err) -> str:
    """A hint when the line at fault gives a bare word as a value (robot = p3dx_laser):
    TOML needs text in quotes."""
    import re
    at = re.search(r"at line (\d+)", str(err))
    try:
        line = Path(path).read_text(encoding="utf-8").splitlines()[int(at.group(1)) - 1]
    except (AttributeError, OSError, UnicodeDecodeError, IndexError, ValueError):
        return ""
    key, eq_, value = line.partition("=")
    value = value.split("#")[0].strip()
    if eq_ and re.fullmatch(r"[A-Za-z_][\w.-]*", value) and value not in (
            "true", "false", "inf", "nan"):
        return f' (text needs quotes: {key.strip()} = "{value}")'
    return ""


def parse_toml_value(text: str):
    """A TOML value (``0.5``, ``[0, 0, 0]``, ``{seed = 3}``, ``"p3dx"``); text that is
    not a TOML value is returned as the string itself (so ``p3dx`` needs no quotes)."""
    tomllib = _toml()
    try:
        return tomllib.loads(f"v = {text}")["v"]
    except tomllib.TOMLDecodeError:
        return text
    except RecursionError:
        raise ValidationError("value nested too deeply to read") from None


def read_scenario_table(path) -> dict:
    """The fields of a scenario file: its top-level table, or its ``[scenario]`` table
    when that is all it holds (plain data for :meth:`unidyn.Scenario.from_dict`)."""
    data = read_toml(path, "scenario file")
    if set(data) == {"scenario"} and isinstance(data["scenario"], dict):
        data = data["scenario"]
    return data


def read_scenario(path) -> Scenario:
    """The :class:`~unidyn.Scenario` of a scenario file, as ``unidyn run FILE`` reads it
    (``unidyn.read_scenario``): a TOML file of Scenario fields, at the top level or under
    ``[scenario]``, with the sweeps' keys ``kxy``, ``theta_hat_scale`` and ``seed``
    allowed. A missing file raises ``FileNotFoundError``, a bad one a
    :class:`~unidyn.ValidationError` of one line naming the file and the field."""
    return scenario_from_layers([(str(path), read_scenario_table(path))])


# ------------------------------------------------------ values and scenario tables

def plain(v):
    """Plain data for Scenario-typed values (:func:`unidyn.model.scenario.plain_value`)."""
    return plain_value(v)


def is_number(v) -> bool:
    """A real number that is not a bool."""
    return isinstance(v, Real) and not isinstance(v, bool)


def expand_range(where: str, spec: Mapping) -> list:
    """The values of a range table: ``start`` to ``stop`` (included) by ``step``, or
    ``num`` values (geometric with ``log = true``); ``where`` names it in errors."""
    allowed = {"start", "stop", "step", "num", "log"}
    unknown = sorted(set(spec) - allowed)
    if unknown:
        raise ValidationError(f"{where}: unknown range key {unknown[0]!r}"
                              f"{did_you_mean(unknown[0], allowed)}; a range has start, "
                              f"stop and step (or num, with log = true for a geometric range)")
    for k in ("start", "stop"):
        if k not in spec:
            raise ValidationError(f"{where}: a range needs {k!r} (and step or num)")
    start = real(f"{where}.start", spec["start"])
    stop = real(f"{where}.stop", spec["stop"])
    if ("step" in spec) == ("num" in spec):
        raise ValidationError(f"{where}: a range needs exactly one of 'step' and 'num'")
    log = spec.get("log", False)
    if not isinstance(log, bool):
        raise ValidationError(f"{where}.log must be true or false, got {log!r}")
    if stop < start:
        raise ValidationError(f"{where}: stop ({stop:g}) must be >= start ({start:g})")
    if "step" in spec:
        step = spec["step"]
        if log:
            raise ValidationError(f"{where}: log = true needs num, not step")
        step = real(f"{where}.step", step, low=0.0, low_open=True)
        n = int(math.floor((stop - start) / step + 1e-9)) + 1
        if n > MAX_POINTS:
            raise ValidationError(f"{where}: {n} values; at most {MAX_POINTS} are allowed")
        # 12 significant digits: 0.1 + 2 * 0.1 is 0.3, not 0.30000000000000004
        return [float(f"{start + i * float(step):.12g}") for i in range(n)]
    num = spec["num"]
    if isinstance(num, bool) or not isinstance(num, int) or not 1 <= num <= MAX_POINTS:
        raise ValidationError(f"{where}.num must be an integer in 1..{MAX_POINTS}, got {num!r}")
    if log:
        if start <= 0:
            raise ValidationError(f"{where}: a geometric range needs start > 0, got {start:g}")
        vals = np.geomspace(start, stop, num)
    else:
        vals = np.linspace(start, stop, num)
    return [float(f"{v:.12g}") for v in vals]


def check_keys(where: str, d, allow_label: bool = False) -> dict:
    """``d`` as plain data, after checking that every key is a Scenario field or one of
    :data:`SPECIAL_KEYS` (or ``label``, for a variant); an unknown key raises, naming
    the closest known one."""
    if not isinstance(d, Mapping):
        raise ValidationError(f"{where} must be a table of scenario fields, got {d!r}")
    known = {f.name for f in dataclasses.fields(Scenario)} | set(SPECIAL_KEYS)
    if allow_label:
        known.add("label")
    for k in d:
        if k not in known:
            raise ValidationError(f"{where}: unknown key {k!r}{did_you_mean(k, known)}; "
                                  f"allowed: scenario fields "
                                  f"and {', '.join(SPECIAL_KEYS)}")
    return {str(k): plain(v) for k, v in d.items()}


def _special(where: str, key: str, value):
    if key == "seed":
        return integer(f"{where}.seed", value, 0)
    return positive(f"{where}.{key}", value)


def scenario_from_layers(layers, name: str = ""):
    """The Scenario of a stack of layers [(where, table)], each overriding the earlier
    ones: a sweep's base, variant and grid point; ``unidyn run``'s scenario, then its
    flags and ``--set`` options in order. A dotted key (``noise.seed``) sets one field
    of a table that an earlier layer gave. The special keys are applied last; one that
    sets a field some layer also sets (``kxy`` and ``kx``) is refused as ambiguous.

    The scenario need only be valid once every layer is applied (``T = 400000`` with
    ``log_every = 100`` is fine although the T alone is not); when it is not, the error
    names the layer after which it never became valid again (``where``), and an error in
    a layer's own keys names that layer.
    """
    fields, fields_from, special = _stacked(layers)
    for key, (where, _) in special.items():
        for f in _CONFLICTS.get(key, ()):
            if f in fields:
                raise ValidationError(f"{where}.{key} and {fields_from[f]}.{f} both set "
                                      f"{f}; use one of them")
    if name and "name" not in fields:
        fields["name"] = name
    try:
        sc = Scenario.from_dict(fields)
    except ValidationError as err:
        raise ValidationError(f"{_culprit(layers)}: {err}") from None
    if "kxy" in special:
        k = special["kxy"][1]
        sc = sc.replace(kx=k, ky=k)
    if "theta_hat_scale" in special:
        sc = sc.replace(theta_hat0=sc.robot.scaled(special["theta_hat_scale"][1]))
    if "seed" in special:
        where, seed = special["seed"]
        if sc.noise is None:
            raise ValidationError(f"{where}.seed is set but noise is off; give noise "
                                  f"(e.g. noise = {{position_std = 0.01, velocity_std = 0.0141}})")
        sc = sc.replace(noise=dataclasses.replace(sc.noise, seed=seed))
    return sc


def _stacked(layers):
    """The fields of stacked layers (with the layer that set each last) and the
    special keys (with the layer that gave each)."""
    fields, fields_from, special = {}, {}, {}
    for where, d in layers:
        for k, v in d.items():
            if k in SPECIAL_KEYS:
                special[k] = (where, _special(where, k, v))
                continue
            head, dot, rest = k.partition(".")
            fields[head] = _set_field(fields, head, rest, v, where) if dot else v
            fields_from[head] = where
    return fields, fields_from, special


def _set_field(fields, head, rest, value, where):
    """The table ``fields[head]`` with its field ``rest`` (dotted for a table in it) set."""
    if head not in fields:
        raise ValidationError(f"{where}: unknown scenario field {head!r}"
                              f"{did_you_mean(head, fields)}")
    table = fields[head]
    if table is None:
        raise ValidationError(f"{where}: {head} is off; set the whole table, e.g. "
                              f"{head}={{...}}")
    if not isinstance(table, dict):
        raise ValidationError(f"{where}: {head} is not a table")
    table = dict(table)
    key, dot, deeper = rest.partition(".")
    table[key] = _set_field(table, key, deeper, value, where) if dot else value
    return table


def _culprit(layers) -> str:
    """The layer after which the stacked scenario never became valid again."""
    culprit = layers[0][0] if layers else "scenario"
    for k in range(1, len(layers)):
        try:
            Scenario.from_dict(_stacked(layers[:k])[0])
            culprit = layers[k][0]
        except ValidationError:
            pass
    return culprit


#: Columns of metrics.csv that hold text as written (a variant's label, the case):
#: never read as a number or JSON, so a label "007" or "null" stays itself.
TEXT_COLUMNS = ("variant", "case", "message")


def text(v) -> str:
    """A value as people read it: a string as it is, anything else as :func:`cell`
    writes it (the names of points, the legends of figures)."""
    return v if isinstance(v, str) else cell(v)


def cell(v) -> str:
    """A CSV cell: round-trip text for numbers, JSON for lists and tables; a string as
    written, or JSON-quoted where it would read back as something else ("1.5", "null")."""
    if v is None:
        return ""
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, float):
        return repr(v)
    if isinstance(v, int):
        return str(v)
    if isinstance(v, str):
        return v if _parse_cell(v) == v else json.dumps(v)
    return json.dumps(v, sort_keys=True, separators=(",", ":"))


# -------------------------------------------------------- a sweep folder's records

#: The record of the sweep whose rows a folder holds (definition, id, engine, version).
RECORD_NAME = "sweep.json"
#: The file beside metrics.csv that records which sweep its rows belong to.
ID_NAME = ".sweep-id"


def sweep_record_text(record: dict, **state) -> str:
    """The text of ``sweep.json``: the record and the state of the run (``finished``,
    ``failed``)."""
    return json.dumps(json_ready({**record, **state}), indent=2, allow_nan=False) + "\n"


def read_sweep_record(folder) -> dict:
    """The table in ``folder``'s ``sweep.json``; ``ValueError`` when it is not a JSON table."""
    record = json.loads((Path(folder) / RECORD_NAME).read_text())
    if not isinstance(record, dict):
        raise ValueError("not a table")
    return record


def sweep_id_text(record: dict) -> str:
    """The text of ``.sweep-id``: the sweep's id and engine."""
    return f"{record['id']} {record['engine']}\n"


def read_sweep_id(folder) -> list:
    """``[id, engine]`` from ``folder``'s ``.sweep-id``; ``[]`` when it cannot be read."""
    try:
        return (Path(folder) / ID_NAME).read_text().split()
    except (OSError, UnicodeDecodeError):
        return []


# ----------------------------------------------------------- metrics.csv

def read_rows(path: Path, columns: list):
    """(rows, clean): the complete rows of metrics.csv, and whether every line parsed."""
    text = path.read_text()
    if not text.strip():
        return [], False
    clean = text.endswith("\n")
    if not clean:
        text = text[:text.rfind("\n") + 1]  # a line cut short by an interruption
    reader = csv.reader(io.StringIO(text, newline=""))
    header = next(reader, None)
    if header != columns:
        raise ValidationError(f"{path} has columns {header}, this sweep writes {columns}; "
                              f"use another output folder or resume=False")
    rows = []
    for rec in reader:
        if len(rec) != len(columns):
            clean = False
            continue
        try:
            rows.append(_parse_row(dict(zip(columns, rec))))
        except ValueError:
            clean = False
    return rows, clean


#: What a spreadsheet takes a cell starting with for a formula (OWASP's CSV-injection
#: list), and the quote that makes such a cell text.
_FORMULA_START = ("=", "+", "-", "@", "\t", "\r")
_QUOTE = "'"


def _as_text(text: str) -> str:
    """A text cell that spreadsheets show as text: one starting with a formula
    character (or with the quote itself, so that reading back is exact) gets a
    leading quote."""
    return _QUOTE + text if text.startswith(_FORMULA_START + (_QUOTE,)) else text


def _from_text(text: str) -> str:
    """The text :func:`_as_text` wrote."""
    return text[1:] if text.startswith(_QUOTE) else text


def _parse_cell(text: str):
    if text.startswith(_QUOTE):
        return _from_text(text)
    if text == "":
        return None
    try:
        return json.loads(text)
    except ValueError:
        try:
            return float(text)  # nan, inf
        except ValueError:
            return text


def _parse_row(rec: dict) -> dict:
    out = {}
    for k, v in rec.items():
        if k == "index":
            out[k] = int(v)
        elif k in METRICS:
            out[k] = None if v == "" else float(v)  # empty: the point did not complete
        elif k == "complete":
            if v not in ("true", "false"):
                raise ValueError(v)
            out[k] = v == "true"
        elif k in TEXT_COLUMNS:
            out[k] = _from_text(v)
        else:
            out[k] = _parse_cell(v)
    return out


def read_metrics(path) -> list:
    """The rows of a sweep's metrics.csv (a file or the sweep's folder), sorted by index:
    dicts with ``index`` (int), the axes, ``case``, the metrics (float; ``None`` for a
    point that did not complete) and ``complete`` (bool)."""
    path = Path(path)
    if path.is_dir():
        path = path / "metrics.csv"
    if not path.exists():
        raise FileNotFoundError(f"{path} does not exist")
    with open(path, newline="") as fh:
        header = next(csv.reader(fh), None)
    if not header or "index" not in header or "iae" not in header:
        raise ValidationError(f"{path} is not a sweep's metrics.csv (no index/iae columns)")
    rows, _ = read_rows(path, header)
    return sorted(rows, key=lambda r: r["index"])


def write_rows(fh, columns, rows):
    """Write ``rows`` as CSV lines; text cells are written so that spreadsheets show
    them as text (:func:`_as_text`), and read back as written."""
    w = csv.writer(fh, lineterminator="\n")
    for r in rows:
        w.writerow([_as_text(r[c] if c in TEXT_COLUMNS else cell(r[c]))
                    if isinstance(r[c], str) else cell(r[c]) for c in columns])


def rows_text(columns, rows, header: bool = True) -> str:
    """The lines of metrics.csv for ``rows``, after the header line of ``columns``
    (``header=False``: the rows alone, to append)."""
    buf = io.StringIO()
    if header:
        csv.writer(buf, lineterminator="\n").writerow(columns)
    write_rows(buf, columns, rows)
    return buf.getvalue()


def finished_rows(csv_path: Path) -> list:
    """The indices of the rows in a metrics.csv, whatever its columns."""
    try:
        with open(csv_path, newline="") as fh:
            reader = csv.reader(fh)
            header = next(reader, None) or []
            at = header.index("index") if "index" in header else 0
            out = []
            for rec in reader:
                try:
                    out.append(int(rec[at]))
                except (ValueError, IndexError):
                    pass
            return out
    except (OSError, UnicodeDecodeError, csv.Error):
        return []

