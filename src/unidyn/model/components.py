"""Between the equations' two forms: the public one takes and returns arrays whose last
axis holds a vector's components (:mod:`unidyn.model.unicycle`, :mod:`unidyn.model.laws`);
the one in :mod:`unidyn.model.equations` takes and returns the components themselves.
These split an array into its components and stack components into an array."""

from __future__ import annotations

import numpy as np

__all__ = ["parts", "scalar", "join", "pair"]


def parts(a, n=None):
    """The components of ``a`` along its last axis: Python floats for a single vector
    (the blocks call it at every solver stage, and arithmetic on floats has none of
    numpy's per-call overhead), else arrays. A scalar stands for ``n`` equal components
    where n is given."""
    a = np.asarray(a, dtype=float)
    if a.ndim == 0 and n is not None:
        return [float(a)] * n
    if a.ndim == 1:
        return a.tolist()
    return [a[..., i] for i in range(a.shape[-1])]


def scalar(x):
    """A float for a scalar (including a 0-d array), else an array."""
    if isinstance(x, float):
        return x
    x = np.asarray(x, dtype=float)
    return float(x) if x.ndim == 0 else x


def join(*values):
    """Components stacked along a new last axis, broadcasting them."""
    if all(isinstance(p, float) for p in values):
        return np.array(values)
    arrays = np.broadcast_arrays(*values)
    out = np.empty(arrays[0].shape + (len(values),))
    for i, p in enumerate(arrays):
        out[..., i] = p
    return out


def pair(x, y):
    """Two components stacked into shape + (2,)."""
    return join(x, y)
