"""Helpers shared by unidyn's blocks (not blocks themselves)."""

from __future__ import annotations

import difflib
import inspect
import math

import numpy as np

from unidyn._validate import NonFiniteSignalError, ValidationError
from unidyn.model.unicycle import Limits


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


#: Keywords of roboticstoolbox's vehicle blocks (UNICYCLE, BICYCLE) that unidyn's
#: blocks spell differently: the keyword, the unidyn keyword it maps to, and why.
TOOLBOX_KEYWORDS = {
    "vlim": ("speed_max", "roboticstoolbox's old name for speed_max"),
    "slim": ("steer_max", "roboticstoolbox's old name for steer_max"),
    "L": ("robot", "the wheelbase of roboticstoolbox's BICYCLE: a unicycle has none, "
                   "robot= gives its dynamics"),
}


def keyword_hint(keyword: str, known) -> str:
    """`` (...)`` naming the keyword meant by an unknown ``keyword``: the toolbox's
    spelling of it (:data:`TOOLBOX_KEYWORDS`) or the closest of ``known``; else ``""``."""
    meant = TOOLBOX_KEYWORDS.get(keyword)
    if meant is not None and meant[0] in known:
        return f" ({meant[1]})"
    close = difflib.get_close_matches(keyword, sorted(known), n=1)
    return f" (did you mean {close[0]!r}?)" if close else ""


def qualified_state_names(block, names) -> None:
    """Name ``block``'s states ``<block name>:<state>`` (bdsim's own form for
    unnamed states, ``vehicle:x_0``), so that the states of several blocks of one
    kind stay apart in ``out.xnames``; called when the diagram is compiled, once
    bdsim has named every block."""
    block.state_names([f"{block.name}:{n}" for n in names])


def check_blockargs(block, blockargs: dict) -> None:
    """Raise a ValidationError naming the block type and the keyword when
    ``blockargs`` holds a keyword that neither the block nor bdsim's common block
    options accept (bdsim's own message names no block: "in block None")."""
    cls = type(block)
    common, own = set(), set()
    for k in cls.__mro__:
        init = k.__dict__.get("__init__")
        if init is None:
            continue
        names = {n for n, p in inspect.signature(init).parameters.items()
                 if n != "self" and p.kind not in (p.VAR_KEYWORD, p.VAR_POSITIONAL)}
        (common if k.__module__.startswith("bdsim") else own).update(names)
    unknown = sorted(set(blockargs) - common)
    if unknown:
        known = sorted(own | common)
        hint = keyword_hint(unknown[0], known)
        raise ValidationError(
            f"{cls.__name__}: unknown keyword {unknown[0]!r}{hint}; it accepts "
            f"{', '.join(sorted(own))} and bdsim's block options "
            f"{', '.join(sorted(common - own))}")


def limits_from_args(limits, speed_max, steer_max, accel_max, angular_accel_max):
    if limits is not None:
        if not isinstance(limits, Limits):
            raise ValidationError(f"limits must be a unidyn.Limits or None, got {limits!r}")
        return limits
    return Limits(speed_max=speed_max, steer_max=steer_max, accel_max=accel_max,
                  angular_accel_max=angular_accel_max)


def check_clock(clock, block_name: str):
    """A bdsim clock, or a clear error naming the parameter."""
    from bdsim.components import Clock
    if not isinstance(clock, Clock):
        raise ValidationError(f"{block_name}: clock must be a bdsim Clock (e.g. "
                              f"bd.clock(0.1, name='controller')), got {clock!r}")
    return clock


def check_fixed_blockargs(block, blockargs: dict) -> None:
    """For a fixed-port block: raise a ValidationError naming the block type and the
    keyword when ``blockargs`` holds anything but bdsim's naming and wiring options
    (``name``, ``inputs``, ``inames``, ``onames``, ...). The port-changing options of
    the parent class, and bdsim's ``nin``/``nout``, are refused: they would change
    the ports that the class declares."""
    cls = type(block)
    common = set()
    for k in cls.__mro__:
        init = k.__dict__.get("__init__")
        if init is not None and k.__module__.startswith("bdsim"):
            common.update(n for n, p in inspect.signature(init).parameters.items()
                          if n != "self" and p.kind not in (p.VAR_KEYWORD, p.VAR_POSITIONAL))
    # options that set ports, states or the block's class are the class's own business
    common &= {"name", "inputs", "bd", "pos", "inames", "onames"}
    own = {n for n, p in inspect.signature(cls.__init__).parameters.items()
           if n != "self" and p.kind not in (p.VAR_KEYWORD, p.VAR_POSITIONAL)}
    unknown = sorted(set(blockargs) - common)
    if unknown:
        hint = keyword_hint(unknown[0], sorted(own | common))
        raise ValidationError(
            f"{cls.__name__}: unknown keyword {unknown[0]!r}{hint}; it accepts "
            f"{', '.join(sorted(own))} and bdsim's block options "
            f"{', '.join(sorted(common - own))}")


def optional_limit(name: str, value):
    """A limit given as None (no limit) or a number: inf for None, else the number."""
    return np.inf if value is None else value
