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


class ValidationError(ValueError):
    """A parameter is missing, of the wrong kind or outside its allowed range."""


def real(name: str, value, *, low: float | None = None, high: float | None = None,
         low_open: bool = False, high_open: bool = False, allow_inf: bool = False) -> float:
    """Return ``value`` as a float after checking it is a finite real in range.

    :param name: parameter name used in the error message
    :param low, high: bounds (``None`` for unbounded)
    :param low_open, high_open: exclude the bound itself
    :param allow_inf: accept +/-inf (e.g. "no limit")
    """
    if isinstance(value, bool) or not isinstance(value, (Real, np.floating, np.integer)):
        raise ValidationError(f"{name} must be a real number, got {value!r}")
    v = float(value)
    if math.isnan(v) or (math.isinf(v) and not allow_inf):
        raise ValidationError(f"{name} must be finite, got {v!r}")
    if low is not None and (v < low or (low_open and v == low)):
        op = ">" if low_open else ">="
        raise ValidationError(f"{name} must be {op} {low:g}, got {v!r}")
    if high is not None and (v > high or (high_open and v == high)):
        op = "<" if high_open else "<="
        raise ValidationError(f"{name} must be {op} {high:g}, got {v!r}")
    return v


def positive(name: str, value, *, allow_inf: bool = False) -> float:
    """A finite (or, with ``allow_inf``, infinite) real number > 0."""
    return real(name, value, low=0.0, low_open=True, allow_inf=allow_inf)


def nonnegative(name: str, value) -> float:
    """A finite real number >= 0."""
    return real(name, value, low=0.0)


def vector(name: str, value, length: int | tuple[int, ...], *, finite: bool = True) -> np.ndarray:
    """Return ``value`` as a 1-D float array of the given length(s).

    :param length: the required length, or a tuple of accepted lengths
    """
    lengths = (length,) if isinstance(length, int) else tuple(length)
    if isinstance(value, (str, bytes)) or value is None:
        raise ValidationError(f"{name} must be a vector of length {_or(lengths)}, got {value!r}")
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise ValidationError(f"{name} must be a vector of length {_or(lengths)}, got {value!r}") from None
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


def choice(name: str, value, allowed) -> str:
    """One of a fixed set of strings."""
    if value not in allowed:
        raise ValidationError(
            f"{name} must be one of {', '.join(repr(a) for a in allowed)}; got {value!r}")
    return value


def _or(lengths: tuple[int, ...]) -> str:
    return " or ".join(str(n) for n in lengths)
