"""What unidyn's blocks check on the values they read and compute, and how they
name their states."""

from __future__ import annotations

import math

import numpy as np

from unidyn._validate import NonFiniteSignalError, ValidationError


def as_vector(value, n: int, block, port: str, t: float) -> np.ndarray:
    """An input port's value as a finite float vector of length n, or a clear error."""
    arr = np.asarray(value, dtype=float).reshape(-1)
    if arr.shape[0] != n:
        raise ValidationError(
            f"block {block.name!r}: input {port!r} must have {n} elements, got {arr.shape[0]}")
    if not all(map(math.isfinite, arr.tolist())):
        raise NonFiniteSignalError(
            f"block {block.name!r}: input {port!r} is not finite at t = {t:.6g} s: {arr.tolist()}")
    return arr


def check_finite(arr, block, what: str, t: float) -> np.ndarray:
    if not all(map(math.isfinite, np.asarray(arr).reshape(-1).tolist())):
        raise NonFiniteSignalError(
            f"block {block.name!r}: {what} is not finite at t = {t:.6g} s: {np.asarray(arr).tolist()}")
    return arr


def qualified_state_names(block, names) -> None:
    """Name ``block``'s states ``<block name>:<state>`` (bdsim's own form for
    unnamed states, ``vehicle:x_0``), so that the states of several blocks of one
    kind stay apart in ``out.xnames``; called when the diagram is compiled, once
    bdsim has named every block."""
    block.state_names([f"{block.name}:{n}" for n in names])
