"""What unidyn's blocks do with their constructor arguments: keep them as given
(:func:`records_arguments`, which the ``.bd`` writer reads), and check the keywords,
limits and clocks they are given."""

from __future__ import annotations

import difflib
import functools
import inspect

import numpy as np

from unidyn._validate import ValidationError
from unidyn.model.unicycle import Limits


def records_arguments(init):
    """Decorate a block's ``__init__`` so that the block keeps the arguments it was
    built with, as given, in ``block.arguments``: parameter name -> value, every
    parameter of the signature in its order, defaults filled in; bdsim's block options
    (``name``, ``bd``, ``inputs``, ...) are not among them. When a block's
    ``__init__`` calls its parent's (the fixed-port classes do), the block keeps the
    arguments of the outermost call, the ones that rebuild it.

    :func:`unidyn.diagrams.bdfile.save_bd` writes a block as its class and these
    arguments, so a new parameter of a block is written without further code."""
    signature = inspect.signature(init)
    own = [name for name, p in signature.parameters.items()
           if p.kind not in (p.VAR_KEYWORD, p.VAR_POSITIONAL)][1:]  # not self

    @functools.wraps(init)
    def recording_init(self, *args, **kwargs):
        if "arguments" not in vars(self):
            try:
                bound = signature.bind(self, *args, **kwargs)
            except TypeError:
                return init(self, *args, **kwargs)  # raises Python's own message
            bound.apply_defaults()
            self.arguments = {name: bound.arguments[name] for name in own}
        return init(self, *args, **kwargs)

    return recording_init


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
