"""Reading identification logs: CSV files in their encodings, column mapping,
checks, gaps and the pieces between them, and several logs joined into one.

A log holds the commands (u_ref, w_ref) a robot received and the velocities
(u, w) it measured, with their time stamps, the quantities of Eq. (11).
"""

from __future__ import annotations

import contextlib
import csv
import math
import os
import re
import warnings
from collections.abc import Mapping
from pathlib import Path

import numpy as np

from .._validate import ValidationError, real, short_repr

#: The canonical column names of a log.
COLUMNS = ("t", "u_ref", "w_ref", "u", "w")
#: The optional columns of the robot's pose (m, m, rad): with them, a log whose u and
#: w are exchanged is told apart (see :func:`check_layout`)
POSE = ("x", "y", "psi")
# a time step longer than this many median steps is a gap (the robot was not logged)
_GAP_FACTOR = 5.0
# a time step longer than this many median steps (but not a gap) means missing rows:
# the commands held while they were missing are unknown, so the log is split there
# too (sampling jitter of +-10 % only reaches 1.2)
_MISSING_FACTOR = 1.4
# pieces between gaps or missing rows with fewer samples are not used
MIN_SEGMENT = 3
#: The units the time column may be in, and their length in seconds.
TIME_UNITS = {"s": 1.0, "ms": 1e-3, "us": 1e-6, "ns": 1e-9}
# a median time step longer than this (s) is not a wheeled robot's log: its
# velocity time constants are tenths of a second (Section 5), so a log this
# sparse cannot show them; it is almost always t in ms, us or ns read as seconds
MAX_STEP = 1.0


class IdentificationWarning(UserWarning):
    """A reason not to trust an identified parameter as much as its interval
    says, or something in a log that was read other than as written."""


class MissingColumnsError(ValidationError):
    """A log lacks columns that identification needs.

    :ivar missing: the canonical names that are missing (t, u_ref, ...)
    :ivar mapped: for each missing name, the log's name it was looked up as
    :ivar available: the log's column names
    :ivar source: what the log is (a file path, "mapping", ...)
    """

    def __init__(self, message, missing, mapped, available, source):
        super().__init__(message)
        self.missing, self.mapped = tuple(missing), dict(mapped)
        self.available, self.source = tuple(available), source


def _column_map(columns) -> dict:
    if columns is None:
        return {k: k for k in COLUMNS + POSE}
    if not isinstance(columns, Mapping):
        raise ValidationError(f"columns must be a mapping from {', '.join(COLUMNS)} to the "
                              f"log's column names, got {short_repr(columns)}")
    unknown = [k for k in columns if k not in COLUMNS + POSE]
    if unknown:
        raise ValidationError(f"columns: unknown key(s) {', '.join(short_repr(k) for k in unknown)}; "
                              f"allowed keys are {', '.join(COLUMNS + POSE)}")
    out = {k: k for k in COLUMNS + POSE}
    for k, v in columns.items():
        if not isinstance(v, str) or not v.strip():
            raise ValidationError(f"columns[{k!r}] must be a column name (a non-empty string), "
                                  f"got {short_repr(v)}")
        out[k] = v.strip()
    return out


def _decode(path: Path, raw: bytes) -> str:
    """The text of a log file: UTF-8 (with or without a byte-order mark), UTF-16
    with a byte-order mark, or, failing UTF-8, Windows-1252 / Latin-1."""
    if raw.startswith((b"\xff\xfe", b"\xfe\xff")):
        try:
            return raw.decode("utf-16")
        except UnicodeDecodeError as err:
            line = raw[:err.start].count("\n".encode("utf-16-le")) + 1
            raise ValidationError(f"log: {path} line {line}: the file starts with a UTF-16 "
                                  f"byte-order mark but is not valid UTF-16") from None
    if b"\x00" in raw:
        line = raw[:raw.index(b"\x00")].count(b"\n") + 1
        raise ValidationError(f"log: {path} line {line}: a NUL byte: "
                              f"the file is not text (binary, or UTF-16 without a byte-order "
                              f"mark); save the log as UTF-8 CSV")
    try:
        return raw.decode("utf-8-sig")
    except UnicodeDecodeError as err:
        first = err
    try:
        return raw.decode("cp1252")
    except UnicodeDecodeError:
        pass
    if not any(0x80 <= b <= 0x9f for b in raw):
        return raw.decode("latin-1")
    pos = first.start
    line = raw[:pos].count(b"\n") + 1
    bad = raw[pos:pos + 4]
    raise ValidationError(f"log: {path} line {line}: bytes {bad!r} are not text (neither "
                          f"UTF-8 nor Latin-1); save the log as UTF-8 CSV")


def _sniff_delimiter(header: str) -> str:
    for d in (",", ";", "\t"):
        if d in header:
            return d
    return ","


# a number written with a decimal comma: 0,25  -1,5e-3
_DECIMAL_COMMA = re.compile(r"^[+-]?\d*,\d+(?:[eE][+-]?\d+)?$|^[+-]?\d+,(?:[eE][+-]?\d+)?$")


def _number(cell: str):
    """The float a CSV cell holds, accepting a decimal comma; None if it holds none."""
    try:
        return float(cell)
    except ValueError:
        pass
    if _DECIMAL_COMMA.match(cell):
        return float(cell.replace(",", "."))
    return None


def _header(path, lines) -> tuple[int, str, str]:
    """(line number, text, separator) of the header row among ``lines``: the first
    line that is neither blank nor a comment, after an optional ``sep=`` line."""
    delim = None
    for lineno, line in enumerate(lines, start=1):
        s = line.strip()
        if s and not s.startswith("#"):
            m = re.fullmatch(r"""["']?sep=(.)["']?,*;*""", s.lstrip("\ufeff"))
            if m and delim is None:
                delim = "\t" if m.group(1) == "\t" else m.group(1)
                continue
            return lineno, line, delim or _sniff_delimiter(line)
    raise ValidationError(f"log: {path} has no header row; expected a first row naming "
                          f"the columns ({', '.join(COLUMNS)})")


def _header_columns(header_line, delim, wanted) -> tuple[list, list]:
    """(every header name, [(name, field index)] of the columns wanted and present)."""
    header = [h.strip().strip('"').strip("'").strip().lstrip("\ufeff")
              for h in next(csv.reader([header_line], delimiter=delim))]
    want = list(header) if wanted is None else [w for w in dict.fromkeys(wanted) if w in header]
    index = {h: i for i, h in reversed(list(enumerate(header)))}   # first occurrence
    return header, [(h, index[h]) for h in want]


# bytes of a CSV file examined at a time when counting its fields
_BLOCK = 1 << 24


def _read_plain(path: Path, wanted):
    """The columns of a plain CSV log read by numpy's reader, or None when the file
    is anything but plain: UTF-8 or Latin-1 text, no quotes, no comment lines or
    non-numbers among the data rows, and every data row with exactly the header's
    number of fields (so that no decimal comma can split a number unnoticed).
    Such files, by far the commonest, are read in C, a block at a time, holding
    little more than the columns wanted; any other goes through
    :func:`_read_csv`'s reader, which explains what it skips or refuses."""
    try:
        with open(path, "rb") as fh:
            head = fh.read(1 << 16)
            if head.startswith((b"\xff\xfe", b"\xfe\xff")):
                return None
            head = head[:head.rfind(b"\n") + 1]
            try:
                lineno, header_line, delim = _header(path, _decode(path, head).split("\n")[:-1])
            except ValidationError:
                return None
            if len(delim) != 1 or not delim.isascii():
                return None
            start = sum(len(x) + 1 for x in head.split(b"\n", lineno)[:lineno])
            header, cols = _header_columns(header_line, delim, wanted)
            fh.seek(start)
            filled = _plain_rows(fh, ord(delim), len(header) - 1)
    except OSError:
        return None
    if filled is None:
        return None
    try:
        with _warnings_as_errors():
            arr = np.loadtxt(path, delimiter=delim, skiprows=lineno, usecols=[i for _, i in cols]
                             or [0], ndmin=2, comments=None, quotechar=None,
                             encoding="latin-1", dtype=float)
    except (ValueError, Warning, OSError):
        return None
    rowlines = np.flatnonzero(filled) + lineno + 1
    if arr.shape[0] != rowlines.size:
        return None
    data = {h: np.ascontiguousarray(arr[:, j]) for j, (h, _) in enumerate(cols)}
    return data, header, rowlines, []


def _plain_rows(fh, code, separators):
    """Which lines from the file position on hold data (are not blank), or None
    when a line holds other than ``separators`` separators (byte ``code``), a
    quote, a '#' or a NUL byte: read a block at a time."""
    filled, carry, pending, prev = [], 0, 0, 10
    while True:
        raw = fh.read(_BLOCK)
        if not raw:
            break
        if any(c in raw for c in (b'"', b"'", b"#", b"\x00")):
            return None
        blk = np.frombuffer(raw, np.uint8)
        nl = np.flatnonzero(blk == 10)
        sep = np.flatnonzero(blk == code)
        per = np.diff(np.searchsorted(sep, nl), prepend=0)
        length = np.diff(nl, prepend=-1)             # with the newline
        if nl.size:
            per[0] += carry
            length[0] += pending
            carry, pending = sep.size - int(np.searchsorted(sep, nl[-1])), blk.size - nl[-1] - 1
        else:
            carry, pending = carry + sep.size, pending + blk.size
        cr = np.zeros(nl.size, bool)
        cr[nl > 0] = blk[nl[nl > 0] - 1] == 13
        if nl.size and nl[0] == 0:
            cr[0] = prev == 13
        full = length - 1 - cr > 0
        if not np.all(per[full] == separators):
            return None
        filled.append(full)
        prev = int(blk[-1])
    if pending:                                      # a last line without a newline
        if carry != separators and pending - (prev == 13) > 0:
            return None
        filled.append(np.array([pending - (prev == 13) > 0]))
    return np.concatenate(filled) if filled else np.zeros(0, bool)


def _read_csv(path: Path, wanted=None) -> tuple[dict, list, list]:
    """Read the columns ``wanted`` (all if None) of a CSV log as float arrays.

    Lines starting with '#' and blank lines are skipped; the first other line
    names the columns (after an optional ``sep=;`` line, as spreadsheets write
    it). Numbers may use a decimal comma (with ';' or tab separators, or
    quoted). A data row may end in one empty field the header lacks (a
    trailing separator). One row of non-numbers right after the header (units
    such as ``s,m/s,rad/s``) is skipped, and so are comment lines among the
    data rows; both are reported in the notes. Columns not wanted are never
    parsed.
    Returns (columns found, every header name, the file line of each row,
    notes: one line per kind of row skipped).
    """
    if path.is_file():
        plain = _read_plain(path, wanted)
        if plain is not None:
            return plain
    try:
        raw = path.read_bytes()
    except IsADirectoryError:
        raise ValidationError(f"log: {path} is a folder, not a CSV file") from None
    except OSError as err:
        raise ValidationError(f"log: cannot read {path}: {err.strerror or err}") from None
    text = _decode(path, raw)
    del raw
    lines = text.splitlines()
    lineno, header_line, delim = _header(path, lines)
    header, cols = _header_columns(header_line, delim, wanted)
    want = [h for h, _ in cols]
    need = max((i for _, i in cols), default=-1) + 1
    data = {h: [] for h in want}
    rowlines, notes = [], []
    body = [(n, line) for n, line in enumerate(lines[lineno:], start=lineno + 1)
            if line.strip() and not line.lstrip().startswith("#")]
    # comment lines after the first data row: a logger's remarks, or rows commented out
    first = body[0][0] if body else len(lines) + 1
    inner = [n for n, line in enumerate(lines[first:], start=first + 1)
             if line.lstrip().startswith("#")]
    if inner:
        notes.append(f"log: {path}: skipped {len(inner)} comment line(s) among the data rows "
                     f"(first at line {inner[0]}: {short_repr(lines[inner[0] - 1].strip())})")
    rows = csv.reader((line for _, line in body), delimiter=delim)
    for j, ((n, _), row) in enumerate(zip(body, rows)):
        if len(row) == len(header) + 1 and not row[-1].strip():
            row = row[:-1]                       # a trailing separator
        if len(row) > len(header):
            raise ValidationError(f"log: {path} line {n} has {len(row)} fields, the header "
                                  f"{len(header)} (a decimal comma, or an unquoted separator "
                                  f"in a field?)")
        if len(row) < need:
            raise ValidationError(f"log: {path} line {n} has {len(row)} field(s); column "
                                  f"{header[need - 1]!r} is field {need} of the header's "
                                  f"{len(header)}")
        vals = [_number(row[i].strip()) for _, i in cols]
        if j == 0 and vals and all(v is None for v in vals) and \
                all(_number(c.strip()) is None for c in row):
            notes.append(f"log: {path} line {n}: skipped a row of non-numbers right after "
                         f"the header (units?): {short_repr(delim.join(row))}")
            continue
        for (h, i), v in zip(cols, vals):
            if v is None:
                cell = row[i].strip()
                hint = ""
                if j == 0:
                    hint = (" (a row of units under the header? remove it, or every cell of "
                            "it must be a non-number)")
                elif "," in cell:
                    hint = " (a decimal comma? use ';' or tab as the separator, or quote it)"
                raise ValidationError(f"log: {path} line {n}, column {h!r}: {short_repr(cell)} is "
                                      f"not a number{hint}")
            data[h].append(v)
        rowlines.append(n)
    return data, header, rowlines, notes


@contextlib.contextmanager
def _warnings_as_errors():
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        yield


def _get_columns(log, wanted) -> tuple:
    """(mapping or None, object, description, available names, file line of each
    row or None, notes on rows skipped) of a log's raw columns."""
    if isinstance(log, (str, os.PathLike)):
        path = Path(log)
        data, header, rowlines, notes = _read_csv(path, wanted)
        return data, None, str(path), header, rowlines, notes
    if isinstance(log, np.ndarray):
        if log.dtype.names is None:
            raise ValidationError("log: a numpy array must be a structured array with named "
                                  f"fields ({', '.join(COLUMNS)}), got dtype {log.dtype}")
        return {n: log[n] for n in log.dtype.names}, None, "structured array", \
            list(log.dtype.names), None, []
    if isinstance(log, Mapping) or (hasattr(log, "keys") and hasattr(log, "__getitem__")):
        keys = list(log.keys())
        return {k: log[k] for k in keys}, None, "mapping", keys, None, []
    return None, log, type(log).__name__, [k for k in dir(log) if not k.startswith("_")], \
        None, []


#: The columns that ``scale`` may multiply: the commands and the measured velocities.
SCALED = ("u_ref", "w_ref", "u", "w")


def _scale_map(scale) -> dict:
    """``scale`` checked: a mapping from some of :data:`SCALED` to positive factors."""
    if scale is None:
        return {}
    if not isinstance(scale, Mapping):
        raise ValidationError(f"scale must be a mapping from {', '.join(SCALED)} to factors, "
                              f"e.g. {{'u_ref': 0.01}} for commands in cm/s, got "
                              f"{short_repr(scale)}")
    out = {}
    for k, v in scale.items():
        if k not in SCALED:
            raise ValidationError(f"scale: unknown key {short_repr(k)}; allowed keys are "
                                  f"{', '.join(SCALED)}")
        f = real(f"scale[{k!r}]", v)
        if not (math.isfinite(f) and f > 0):
            raise ValidationError(f"scale[{k!r}] must be a finite factor > 0 (0.01 turns cm/s "
                                  f"into m/s, pi/180 deg/s into rad/s), got {v!r}")
        out[k] = f
    return out


def load_log(log, columns=None, time_unit: str | None = None, scale=None) -> dict:
    """Read and check a log; return a dict of 1-D float arrays t, u_ref, w_ref, u, w.

    Rows read other than as written (exact duplicates dropped, a units row or
    comment lines among the data skipped) are reported as one
    :class:`IdentificationWarning` each; :func:`identify` puts the same lines
    in its result's ``warnings``.

    :param log: a mapping (dict, pandas DataFrame, npz file) or an object with
        attributes, holding arrays t (s), u_ref (m/s), w_ref (rad/s), u (m/s) and
        w (rad/s); a numpy structured array with those fields; or the path of a
        CSV file whose first row names the columns. CSV files may be UTF-8 (with
        or without a byte-order mark), UTF-16 with a byte-order mark, or Latin-1 /
        Windows-1252; separated by commas, semicolons or tabs; lines starting
        with '#' are comments. Columns other than the five are ignored (never
        parsed).
    :param columns: optional mapping from the names above to the log's own
        column names, e.g. ``{"u": "v_meas", "w": "omega_meas"}``
    :param time_unit: the unit of the time column: ``"s"``, ``"ms"``, ``"us"``
        or ``"ns"``; the returned t is in seconds. Default (None) seconds, and a
        median time step over 1 s is refused as almost surely another unit
        (the message names the likely one); pass ``"s"`` to accept it
    :raises ValidationError: for a missing column (all are named;
        :class:`MissingColumnsError`), undecodable bytes or a cell that is not a
        number (file, line and column named), columns of different lengths, NaN
        or inf, time that is not strictly increasing (repeated or going back),
        fewer than 20 samples, or (``time_unit=None``) a median time step over 1 s
    :param scale: factors that bring columns to m/s and rad/s, e.g. ``{"u_ref": 0.01}``
        for linear-speed commands logged in cm/s, ``{"w": math.pi / 180}`` for
        measured angular velocities in deg/s (the columns are multiplied by them)
    """
    out, notes = _load(log, columns, time_unit, scale)
    for note in notes:
        warnings.warn(note, IdentificationWarning, stacklevel=2)
    return out


def _time_unit(time_unit):
    if time_unit is not None and time_unit not in TIME_UNITS:
        raise ValidationError(f"time_unit must be one of {', '.join(TIME_UNITS)} (the unit of "
                              f"the log's time column), got {short_repr(time_unit)}")
    return time_unit


def _load(log, columns, time_unit=None, scale=None) -> tuple[dict, list]:
    """:func:`load_log` returning (arrays, notes: one line per kind of row read
    other than as written) instead of warning."""
    cmap = _column_map(columns)
    factors = _scale_map(scale)
    time_unit = _time_unit(time_unit)
    data, obj, what, available, rowlines, notes = _get_columns(
        log, [cmap[k] for k in COLUMNS + POSE])

    def has(name):
        return name in data if data is not None else hasattr(obj, name)

    _require_columns(cmap, has, what, available)
    posed = all(has(cmap[k]) for k in POSE)
    out = {}
    for k in COLUMNS + (POSE if posed else ()):
        raw = data[cmap[k]] if data is not None else getattr(obj, cmap[k])
        arr = _column(raw, k, what, rowlines)
        if out and arr.size != out["t"].size:
            raise ValidationError(f"log columns must have equal lengths: {k!r} has {arr.size} "
                                  f"samples, 't' has {out['t'].size}")
        # arrays read from a file are the log's own; a caller's are never changed
        out[k] = arr if rowlines is not None else arr.copy()
    out, rowlines = _without_repeated_rows(out, what, rowlines, notes)
    n, dt = out["t"].size, np.diff(out["t"])
    if n < 20:
        raise ValidationError(
            f"log {what} has {n} rows; fitting six parameters and the initial velocities "
            f"needs at least 20, and an accurate estimate many more: log a minute or more of "
            f"varied commands (see excitation())")
    if np.any(dt <= 0):
        k = int(np.flatnonzero(dt <= 0)[0])
        raise ValidationError(f"log {what}: time 't' must be strictly increasing; it is going "
                              f"back at {_where(k + 1, rowlines)}: t = {float(out['t'][k])!r} "
                              f"then {float(out['t'][k + 1])!r}")
    out["t"] = out["t"] * TIME_UNITS[time_unit or "s"]
    for k, f in factors.items():
        out[k] = out[k] * f
    step = float(np.median(dt)) * TIME_UNITS[time_unit or "s"]
    if time_unit is None and step > MAX_STEP:
        raise ValidationError(f"log {what}: the median time step is {step:.4g} s, too long for "
                              f"a wheeled robot's log (at most {MAX_STEP:g} s); "
                              f"{_unit_hint(step)}")
    return out, notes


def _where(k: int, rowlines) -> str:
    """Sample k of the log, with its file line when it came from a file."""
    return f"sample {k}" + (f" (line {rowlines[k]})" if rowlines is not None else "")


def _require_columns(cmap, has, what, available) -> None:
    """A :class:`MissingColumnsError` naming the columns of t, u_ref, w_ref, u, w that
    the log lacks (as mapped) and those it has."""
    missing = [k for k in COLUMNS if not has(cmap[k])]
    if not missing:
        return
    desc = [f"{k!r}" + (f" (as {cmap[k]!r})" if cmap[k] != k else "") for k in missing]
    shown = ", ".join(short_repr(a, 40) for a in available[:20])
    if len(available) > 20:
        shown += f" and {len(available) - 20} more"
    raise MissingColumnsError(
        f"log {what} is missing column(s) {', '.join(desc)}; it has {shown or 'no columns'}"
        f". Map the log's own names to t, u_ref, w_ref, u, w (the columns mapping)",
        missing, {k: cmap[k] for k in missing}, available, what)


def _column(raw, k, what, rowlines) -> np.ndarray:
    """Column ``k`` as a one-dimensional array of finite floats."""
    try:
        arr = np.asarray(raw, dtype=float)
    except (TypeError, ValueError):
        raise ValidationError(f"log {what}: column {k!r} must hold numbers") from None
    if arr.ndim != 1:
        arr = arr.reshape(-1) if arr.size == max(arr.shape, default=0) else arr
    if arr.ndim != 1:
        raise ValidationError(f"log column {k!r} must be one-dimensional, got shape "
                              f"{arr.shape}")
    bad = np.flatnonzero(~np.isfinite(arr))
    if bad.size:
        raise ValidationError(f"log {what}: column {k!r} has {bad.size} NaN/inf value(s), "
                              f"first at {_where(int(bad[0]), rowlines)} "
                              f"({float(arr[bad[0]])!r}); all values must be finite")
    return arr


def _without_repeated_rows(out, what, rowlines, notes):
    """The log without rows that repeat the one before exactly (a note says how many);
    a time stamp repeated with other values refused. Returns (arrays, file lines)."""
    same = np.flatnonzero(np.diff(out["t"]) == 0)
    if not same.size:
        return out, rowlines
    exact = np.all([out[k][same] == out[k][same + 1] for k in out], axis=0)
    if not np.all(exact):
        k = int(same[~exact][0])
        raise ValidationError(
            f"log {what}: time 't' is repeated with different values at "
            f"{_where(k, rowlines)} and {_where(k + 1, rowlines)} "
            f"(t = {float(out['t'][k])!r}); two different rows cannot "
            f"share a time stamp: fix or remove one")
    keep = np.ones(out["t"].size, bool)
    keep[same + 1] = False
    out = {k: v[keep] for k, v in out.items()}
    notes.append(f"log {what}: {same.size} exact duplicate row(s) dropped (first at "
                 f"{_where(int(same[0]) + 1, rowlines)}, t = {float(out['t'][same[0]])!r})")
    return out, (np.asarray(rowlines)[keep] if rowlines is not None else None)


def _unit_hint(step: float) -> str:
    """What a median time step of ``step`` (read as seconds) most likely is."""
    names = {"ms": "milliseconds", "us": "microseconds", "ns": "nanoseconds"}
    for unit in ("ms", "us", "ns"):
        if step * TIME_UNITS[unit] <= MAX_STEP:
            return (f"is t in {names[unit]}? pass time_unit='{unit}' (a step of "
                    f"{step * TIME_UNITS[unit]:.3g} s), or time_unit='s' if it really is "
                    f"seconds")
    return "pass time_unit= with the unit of the time column"


def segments(t, gap: float = None) -> list:
    """Split sample times at gaps: the (start, stop) index ranges of the pieces.

    A time step longer than ``gap`` is a gap: the robot was not logged in
    between (or rows are missing, and with them the commands held meanwhile),
    so nothing is filtered, integrated or compared across it. By default a
    step longer than 1.4 times the median step splits the log: one of 1.4 to 5
    median steps means missing rows, a longer one a gap (see
    :func:`missing_rows`).
    """
    t = np.asarray(t, dtype=float)
    dt = np.diff(t)
    limit = _MISSING_FACTOR * float(np.median(dt)) if gap is None else float(gap)
    cuts = np.flatnonzero(dt > limit) + 1
    bounds = np.concatenate([[0], cuts, [t.size]])
    return [(int(a), int(b)) for a, b in zip(bounds[:-1], bounds[1:])]


def missing_rows(t, gap: float = None) -> tuple[int, int]:
    """(number of rows missing, number of gaps) in sample times ``t``, as
    :func:`segments` splits them: a step of 1.4 to 5 median steps (and at most
    ``gap`` when given) counts as round(step / median) - 1 missing rows, a
    longer split step as a gap."""
    t = np.asarray(t, dtype=float)
    dt = np.diff(t)
    med = float(np.median(dt))
    limit = _MISSING_FACTOR * med if gap is None else float(gap)
    split = dt > limit
    short = split & (dt <= _GAP_FACTOR * med)
    return int(np.sum(np.round(dt[short] / med) - 1)), int(np.sum(split & ~short))


def check_measured(u_ref, w_ref, u, w, what="the log"):
    """Refuse velocities that are the commands themselves: odometry computed from
    the commands (a controller's open-loop odometry) carries no dynamics, and
    Eq. (2) fitted to it gives time constants of zero as if identified."""
    tu = 1e-6 * max(float(np.max(np.abs(u_ref))), 1e-9)
    tw = 1e-6 * max(float(np.max(np.abs(w_ref))), 1e-9)
    same = np.zeros(u.size, bool)
    for lag in (0, 1):     # the command held over the row, or over the row before
        same[lag:] |= (np.abs(u[lag:] - u_ref[:u.size - lag]) <= tu) & \
            (np.abs(w[lag:] - w_ref[:u.size - lag]) <= tw)
    # a robot at rest measures exactly the zero it is commanded: only motion tells
    moving = (np.abs(u_ref) > tu) | (np.abs(w_ref) > tw)
    share = float(np.mean(same[moving])) if moving.sum() >= 20 else 0.0
    if share > 0.5:
        raise ValidationError(
            f"{what}: the measured velocities equal the commands in "
            f"{100 * share:.0f} % of the rows in motion: they are computed from the commands "
            f"(open-loop odometry, as a diff_drive_controller with open_loop: true "
            f"publishes), not measured, and carry no dynamics to identify; log odometry "
            f"from the wheel encoders (open_loop: false), or the wheel speeds on "
            f"/joint_states (read_bag's wheel_radius and wheel_separation)")


def _corr(a, b) -> float:
    """Pearson's correlation of two series (0 where either is constant): the same in
    any unit of either."""
    a, b = a - np.mean(a), b - np.mean(b)
    den = float(np.sqrt(np.sum(a * a) * np.sum(b * b)))
    return float(np.sum(a * b)) / den if den > 0 else 0.0


def _one_sided(x) -> float:
    """How one-signed a velocity is, |mean| / rms, in any unit: near 1 for a robot's
    forward speed, near 0 for its turning rate, which goes both ways."""
    rms = float(np.sqrt(np.mean(np.square(x))))
    return abs(float(np.mean(x))) / rms if rms > 0 else 0.0


def _by_shape(lin, ang):
    """Which of two velocities is the linear one by shape alone: False (as named),
    True (exchanged) or None (the log cannot tell)."""
    f_lin, f_ang = _one_sided(lin), _one_sided(ang)
    if max(f_lin, f_ang) >= 0.5 and min(f_lin, f_ang) <= 0.5 * max(f_lin, f_ang):
        return f_ang > f_lin
    return None


#: correlations this far apart tell two columns apart
_CLEAR = 0.2


def _pose_rates(D, segs) -> tuple:
    """The pieces of at least 3 rows (slices), and where the log has the pose, the
    heading's rate psi' and the path's speed |(x', y')| in each, in the pose's units."""
    rate, speed, parts = [], [], []
    for a, b in segs:
        if b - a < 3:
            continue
        t = D["t"][a:b]
        parts.append(slice(a, b))
        if "x" in D:
            psi = D["psi"][a:b]  # radians or degrees: unwrapped in its own period
            period = 360.0 if np.ptp(psi) > 2.1 * np.pi else 2 * np.pi
            rate.append(np.gradient(np.unwrap(psi, period=period), t))
            speed.append(np.hypot(np.gradient(D["x"][a:b], t), np.gradient(D["y"][a:b], t)))
    return parts, rate, speed


def pose_factors(D, segs):
    """How many times the path's speed from the pose |u| is, and the heading's rate w
    (least squares over the log), or None without a pose: near 1 when the velocities
    are in the pose's units (m and rad, as odometry reports them)."""
    parts, rate, speed = _pose_rates(D, segs)
    if not rate:
        return None
    rate, speed = np.concatenate(rate), np.concatenate(speed)
    u, w = (np.concatenate([D[k][s] for s in parts]) for k in ("u", "w"))
    k_u = float(np.sum(np.abs(u) * speed) / np.sum(speed * speed)) if np.any(speed) else math.nan
    k_w = float(np.sum(w * rate) / np.sum(rate * rate)) if np.any(rate) else math.nan
    return k_u, k_w


def layout(D, segs) -> tuple:
    """Whether the log's measured velocities and its commands are named the wrong way
    round, each True, False or None (the log cannot tell), and the evidence, in words.
    Only shapes, signs and correlations are compared, never magnitudes, so the answer
    is the same in any unit of the velocities or of the pose: the heading's rate psi'
    follows w and the path's speed |(x', y')| follows |u| (with the pose, :data:`POSE`);
    a robot's forward speed keeps its sign while its turning rate changes sign (without
    it); each command follows its own velocity, not the other one."""
    parts, rate, speed = _pose_rates(D, segs)
    if not parts:
        return None, None, ""
    u_ref, w_ref, u, w = (np.concatenate([D[k][s] for s in parts])
                          for k in ("u_ref", "w_ref", "u", "w"))
    said = []
    measured = None
    if rate:
        rate, speed = np.concatenate(rate), np.concatenate(speed)
        r_w, r_u = abs(_corr(rate, w)), abs(_corr(rate, u))
        s_u, s_w = _corr(speed, np.abs(u)), _corr(speed, np.abs(w))
        if r_u > r_w + _CLEAR and s_w > s_u:
            measured = True
        elif r_w > r_u + _CLEAR and s_u > s_w:
            measured = False
        said.append(f"the heading's rate psi' correlates {r_u:.2f} with u and {r_w:.2f} "
                    f"with w, the path's speed {s_u:.2f} with |u| and {s_w:.2f} with |w|")
    if measured is None:
        measured = _by_shape(u, w)
        said.append(f"|mean|/rms is {_one_sided(u):.2f} for u and {_one_sided(w):.2f} for w")
    lin, ang = (w, u) if measured else (u, w)
    straight = _corr(u_ref, lin) + _corr(w_ref, ang)
    cross = _corr(u_ref, ang) + _corr(w_ref, lin)
    crossed = cross > straight + 2 * _CLEAR
    said.append(f"the commands correlate {straight / 2:.2f} with their own velocities and "
                f"{cross / 2:.2f} with the other ones")
    if measured is not None:  # crossed: the commands are exchanged
        return measured, crossed, "; ".join(said)
    by_cmd = _by_shape(u_ref, w_ref)  # the commands' shapes may tell
    said.append(f"|mean|/rms is {_one_sided(u_ref):.2f} for u_ref and "
                f"{_one_sided(w_ref):.2f} for w_ref")
    if by_cmd is None:
        return None, (True if crossed else None), "; ".join(said)
    return by_cmd != crossed, by_cmd, "; ".join(said)


def check_layout(D, segs, columns=None) -> list:
    """Refuse a log whose u and w, or u_ref and w_ref, or both, are exchanged (see
    :func:`layout`), naming the ``columns=`` that maps them right; the warnings (a
    list) when the log cannot tell (its parameters fit either way, theta1 with theta2
    and theta4 with theta6 exchanged)."""
    measured, commands, said = layout(D, segs)
    cmap = _column_map(columns)

    def fix(*pairs):
        new = dict(cmap)
        for a, b in pairs:
            new[a], new[b] = cmap[b], cmap[a]
        return "columns={" + ", ".join(f"{k!r}: {v!r}" for k, v in new.items()
                                        if v != k) + "}"
    if measured is None and commands:
        raise ValidationError(
            f"the log's commands follow the other velocities ({said}): either u_ref and "
            f"w_ref or u and w are exchanged, and this log cannot tell which (it has no "
            f"pose x, y, psi, and its velocities change sign alike). If the measured "
            f"velocities are named right, map the commands: {fix(('u_ref', 'w_ref'))}; if "
            f"the commands are, map the velocities: {fix(('u', 'w'))}")
    if measured or commands:
        pairs = [p for p, bad in ((("u_ref", "w_ref"), commands), (("u", "w"), measured))
                 if bad]
        which = ", and ".join(f"{cmap[a]!r} and {cmap[b]!r}" for a, b in pairs)
        raise ValidationError(f"the log's {which} look exchanged ({said}); if the header "
                              f"names them the wrong way round, map them: {fix(*pairs)}")
    if measured is None:
        return [f"this log cannot tell u from w ({said}; no pose x, y, psi): if they are "
                f"exchanged in its header, theta1 and theta2, theta4 and theta6 come out "
                f"exchanged; check the columns"]
    return []


def split_log(log, t_split: float, columns=None,
              time_unit: str | None = None) -> tuple[dict, dict]:
    """Split a log at time ``t_split``: (samples with t < t_split, samples with t >= t_split).

    Use the first part to identify and the second, held out, to :func:`validate`.
    ``t_split`` is in seconds; the parts' t too (see ``time_unit`` of :func:`load_log`).
    """
    d = load_log(log, columns, time_unit)
    t_split = real("t_split", t_split, low=d["t"][0], high=d["t"][-1], low_open=True,
                   high_open=True)
    m = d["t"] < t_split
    extra = {k: np.asarray(v) for k, v in (log.items() if isinstance(log, Mapping) else [])
             if k not in COLUMNS and np.ndim(v) >= 1 and len(v) == m.size}
    first = {k: v[m] for k, v in {**d, **extra}.items()}
    second = {k: v[~m] for k, v in {**d, **extra}.items()}
    return first, second


def _first_short(t, gap):
    return next(float(t[a]) for a, b in segments(t, gap) if b - a < MIN_SEGMENT)


def recorded_gap(logs):
    """The recording-gap threshold (s) the logs carry, where every one of them does
    (logs read from ROS bags, whose ``"gap"`` entry :func:`read_bag` sets); else None."""
    said = [float(lg["gap"]) for lg in logs if isinstance(lg, dict) and "gap" in lg]
    return max(said) if said and len(said) == len(logs) else None


def join_logs(logs, columns=None, gap=None, time_unit=None, scale=None):
    """Read several logs of one robot and join them as :func:`identify` does.

    Each log is read by :func:`load_log` and split at gaps by :func:`segments`;
    pieces of fewer than ``MIN_SEGMENT`` samples are dropped. The logs are
    concatenated one after the other (their time stamps are not shifted), and
    the pieces index the concatenation, so nothing is ever integrated, filtered
    or compared across the end of one log and the start of the next.

    :param logs: a sequence of logs (paths, mappings, ... as for :func:`load_log`)
    :param columns: mapping from t, u_ref, w_ref, u, w to the logs' own names
    :param gap: a time step longer than this (s) splits a log; default 1.4
        times its median step (see :func:`segments`), or, where every log was read
        from a ROS bag (:func:`~unidyn.identification.read_bag`), the largest of
        their recording-gap thresholds (their ``"gap"`` entries)
    :param time_unit: the unit of the logs' time column (see :func:`load_log`)
    :param scale: factors that bring columns to m/s and rad/s (see :func:`load_log`)
    :raises ValidationError: for a bad log (prefixed "log N:" when several logs
        are given and the log is not a file) or when no piece is long enough
    :return: (dict of the joined arrays t, u_ref, w_ref, u, w; list of
        (start, stop) pieces; number of pieces dropped as too short; a
        description of each log). The numbers of missing rows and of gaps
        found are in the dict's ``"missing"`` entry (a pair), and the rows the
        logs held that were dropped or skipped, one line per kind and log, in
        its ``"notes"`` entry (see :func:`load_log`; not issued as warnings).
    """
    parts, segs, dropped, offset, sources, notes = [], [], 0, 0, [], []
    n_missing, n_gaps = 0, 0
    gap = recorded_gap(logs) if gap is None else gap
    for i, lg in enumerate(logs):
        try:
            d, more = _load(lg, columns, time_unit, scale)
            notes += more
        except ValidationError as err:
            if len(logs) == 1 or isinstance(lg, (str, os.PathLike)):
                raise
            raise type(err)(f"log {i + 1}: {err}") if type(err) is ValidationError else err  # noqa: B904 (err, or it named by its log)
        parts.append(d)
        sources.append(str(lg) if isinstance(lg, (str, os.PathLike)) else type(lg).__name__)
        m_, g_ = missing_rows(d["t"], gap)
        n_missing, n_gaps = n_missing + m_, n_gaps + g_
        short = []
        for a, b in segments(d["t"], gap):
            if b - a >= MIN_SEGMENT:
                segs.append((a + offset, b + offset))
            else:
                short.append(b - a)
        if short:
            dropped += len(short)
            notes.append(f"log {sources[-1]}: {sum(short)} row(s) not used: {len(short)} "
                         f"piece(s) between gaps or missing rows held fewer than "
                         f"{MIN_SEGMENT} samples (first at t = {_first_short(d['t'], gap):g} s)")
        offset += d["t"].size
    if not segs:
        raise ValidationError(f"every piece of the log(s) between gaps holds fewer than "
                              f"{MIN_SEGMENT} samples: nothing to identify from")
    keys = COLUMNS + (POSE if all("x" in p for p in parts) else ())
    D = {k: np.concatenate([p[k] for p in parts]) if len(parts) > 1 else parts[0][k]
         for k in keys}
    D["missing"] = (n_missing, n_gaps)
    D["notes"] = notes
    return D, segs, dropped, sources
