"""Schedules of values that step at given times, as scenario fields hold them: rows
``[t, value]``, from time t (s, >= 0, strictly increasing) on the value holds (> 0): a
circle's radius (:class:`unidyn.model.trajectories.Circle`) and a robot's payload
(:func:`unidyn.model.parameters.payload_schedule`)."""

from __future__ import annotations

import numpy as np

from .._validate import ValidationError, positive, real

__all__ = ["step_rows"]


def step_rows(name: str, value, what: str, value_label: str) -> tuple:
    """The rows of a schedule, ``((t, v), ...)``, validated: each a pair, t >= 0 and
    increasing strictly, v > 0 and finite.

    :param name: the field, for messages (``payload``)
    :param value: a list or tuple of rows (the caller has taken other forms)
    :param what: the sentence saying what the field may be, for a value of another shape
    :param value_label: how messages name a row's value (``"R"``, ``"mass scale"``)
    :raises ValidationError: one line naming ``name`` and the row
    """
    rows = list(value)
    if not all(isinstance(r, (list, tuple, np.ndarray)) and len(r) == 2 for r in rows):
        raise ValidationError(f"{what}, got {value!r:.120}")
    out = []
    for k, (t, v) in enumerate(rows):
        t = real(f"{name}[{k}] t", t, low=0.0)
        v = positive(f"{name}[{k}] {value_label}", v)
        if out and t <= out[-1][0]:
            raise ValidationError(f"{name}: a schedule's times increase; row {k} has "
                                  f"t = {t:g} after t = {out[-1][0]:g}")
        out.append((t, v))
    return tuple(out)
