"""Input validation shared by the core, the blocks and the scenario layer.

Every check raises :class:`ValidationError` (a ``ValueError``) whose message
names the offending parameter and the allowed range, so that a misspelt or
out-of-range value fails loudly at construction time instead of producing a
silently wrong simulation.
"""

from __future__ import annotations

import math
from numbers import Real

import numpy as np

from ._errors import NonFiniteSignalError, ValidationError  # noqa: F401  (defined there)

#: The longest name a scenario, a sweep or a sweep's variant may have (it titles the
#: figures and names the rows of metrics.csv).
MAX_NAME = 200


def real(name: str, value, *, low: float | None = None, high: float | None = None,
         low_open: bool = False, high_open: bool = False, allow_inf: bool = False) -> float:
    """Return ``value`` as a float after checking it is a finite real in range.

    :param name: parameter name used in the error message
    :param low, high: bounds (``None`` for unbounded)
    :param low_open, high_open: exclude the bound itself
    :param allow_inf: accept +/-inf (e.g. "no limit")
    """
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (Real, np.floating, np.integer)):
        raise ValidationError(f"{name} must be a real number, got {short_repr(value)}")
    try:
        v = float(value)
    except OverflowError:  # an integer too large for a float (TOML allows them)
        raise ValidationError(f"{name} is too large: {short_repr(value)}") from None
    if math.isnan(v) or (math.isinf(v) and not allow_inf):
        raise ValidationError(f"{name} must be finite, got {v!r}")
    if low is not None and (v < low or (low_open and v == low)):
        op = ">" if low_open else ">="
        raise ValidationError(f"{name} must be {op} {low:g}, got {v!r}")
    if high is not None and (v > high or (high_open and v == high)):
        op = "<" if high_open else "<="
        raise ValidationError(f"{name} must be {op} {high:g}, got {v!r}")
    return v


def integer(name: str, value, low: int | None = None, high: int | None = None) -> int:
    """An integer (Python or numpy, not a bool) in [low, high]; the error names the
    parameter and the range."""
    rng = ("" if low is None and high is None else f" >= {low}" if high is None
           else f" <= {high}" if low is None else f" in {low}..{high}")
    if (isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer))
            or (low is not None and value < low) or (high is not None and value > high)):
        raise ValidationError(f"{name} must be an integer{rng}, got {short_repr(value)}")
    return int(value)


def positive(name: str, value, *, allow_inf: bool = False) -> float:
    """A finite (or, with ``allow_inf``, infinite) real number > 0."""
    return real(name, value, low=0.0, low_open=True, allow_inf=allow_inf)


#: The diagram's default tolerances, as ``solve_ivp``'s rtol and atol.
DEFAULT_RTOL = 1e-8
DEFAULT_ATOL = 1e-10
#: The batch engine's: its runs start at these and are tightened where their estimated
#: numerical error misses its promise (:func:`unidyn.simulate_batch`).
BATCH_RTOL = 1e-6
BATCH_ATOL = 1e-8


def tolerances(rtol, atol) -> tuple:
    """(rtol, atol) as floats, as both engines take them; ValidationError unless rtol
    is in [1e-13, 0.1] and atol > 0."""
    rtol, atol = positive("rtol", rtol), positive("atol", atol)
    if not 1e-13 <= rtol <= 0.1:
        raise ValidationError(f"rtol must lie in [1e-13, 0.1] (float64 resolves no finer); "
                              f"got {rtol:g}")
    return float(rtol), float(atol)


def nonnegative(name: str, value) -> float:
    """A finite real number >= 0."""
    return real(name, value, low=0.0)


def vector(name: str, value, length: int | tuple[int, ...], *, finite: bool = True) -> np.ndarray:
    """Return ``value`` as a 1-D float array of the given length(s).

    :param length: the required length, or a tuple of accepted lengths
    """
    lengths = (length,) if isinstance(length, int) else tuple(length)
    what = f"{name} must be a vector of {_or(lengths)} real numbers"
    if isinstance(value, (str, bytes, dict)) or value is None:
        raise ValidationError(f"{what}, got {short_repr(value)}")
    try:
        raw = np.asarray(value)
    except (TypeError, ValueError, OverflowError, RecursionError):
        raise ValidationError(f"{what}, got {short_repr(value)}") from None
    # only numbers: no strings ("1"), booleans, complex values or objects
    if raw.dtype.kind not in "iuf":
        if raw.dtype.kind == "O" and raw.ndim == 1:
            for v in raw.tolist():
                real(f"each element of {name}", v, allow_inf=not finite)
        else:
            raise ValidationError(f"{what}, got {short_repr(value)}")
    try:
        arr = np.asarray(raw, dtype=float)
    except (TypeError, ValueError, OverflowError):
        raise ValidationError(f"{what}, got {short_repr(value)}") from None
    if arr.ndim == 0:
        arr = arr.reshape(1)
    if arr.ndim != 1 or arr.shape[0] not in lengths:
        raise ValidationError(
            f"{name} must be a vector of length {_or(lengths)}, got shape {arr.shape}")
    if finite and not np.all(np.isfinite(arr)):
        raise ValidationError(f"{name} must contain only finite values, got {arr.tolist()}")
    return arr


def positive_vector(name: str, value, length: int) -> np.ndarray:
    """A vector of ``length`` finite values, each > 0."""
    arr = vector(name, value, length)
    if np.any(arr <= 0):
        raise ValidationError(f"every element of {name} must be > 0, got {arr.tolist()}")
    return arr


def flag(name: str, value) -> bool:
    """True or False (a Python or numpy boolean)."""
    if not isinstance(value, (bool, np.bool_)):
        raise ValidationError(f"{name} must be True or False, got {short_repr(value)}")
    return bool(value)


def choice(name: str, value, allowed) -> str:
    """One of a fixed set of strings."""
    if not isinstance(value, str) or value not in allowed:
        raise ValidationError(
            f"{name} must be one of {', '.join(repr(a) for a in allowed)}; got {short_repr(value)}")
    return value


def did_you_mean(given, known) -> str:
    """`` (did you mean 'radius'?)``, naming the entry of ``known`` closest to the
    misspelled ``given`` (a key of a table, a name), or ``""`` when none is close: the
    hint every "unknown key" message of a scenario, a sweep file or a call carries."""
    import difflib
    close = difflib.get_close_matches(str(given), [str(k) for k in known], n=1, cutoff=0.5)
    return f" (did you mean {close[0]!r}?)" if close else ""


def string_keys(name: str, table) -> dict:
    """A mapping whose keys are all strings (as TOML and JSON tables are)."""
    if not isinstance(table, dict):
        raise ValidationError(f"{name} must be a table, got {short_repr(table)}")
    bad = [k for k in table if not isinstance(k, str)]
    if bad:
        raise ValidationError(f"{name}: keys must be strings, got {short_repr(bad[0])}")
    return table


def short_repr(value, limit: int = 300) -> str:
    """repr of a value, cut to ``limit`` characters (a string keeps its closing quote;
    safe for deep nesting), for naming a bad value in a message."""
    try:
        text = repr(value)
    except RecursionError:
        text = f"<deeply nested {type(value).__name__}>"
    if len(text) <= limit:
        return text
    if text[:1] in "'\"":
        return text[: limit - 4] + "..." + text[0]
    return text[: limit - 3] + "..."


def _or(lengths: tuple[int, ...]) -> str:
    return " or ".join(str(n) for n in lengths)
