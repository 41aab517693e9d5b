"""Statistics over noise seeds: a sweep whose grid varies ``seed``, and one scenario
run over seeds (``unidyn.run(scenario, seeds=N)``), get one row per point of the other
axes in ``statistics.csv`` (:func:`seed_statistics`), each metric as its mean, standard
deviation and standard error over the seeds (:func:`mean_std_sem`), beside the largest
numerical error estimate among the point's runs and whether it is small against the
standard error (:func:`numerical_error_small`)."""

from __future__ import annotations

import math

import numpy as np

from ..model.metrics import BY_NAME
from .sweep_files import METRICS

__all__ = ["seed_statistics", "statistics_columns", "mean_std_sem", "numerical_error_small",
           "STATISTICS", "SMALL"]

#: The statistics of each metric, as column suffixes.
STATISTICS = ("mean", "std", "sem")


def mean_std_sem(values) -> tuple:
    """(mean, sample standard deviation (n - 1), standard error std / sqrt(n)) of
    ``values``; None where there are too few of them (no mean for none, no spread for
    one). ``values`` may be an array of n rows (n runs' series sampled alike): then each
    is an array, the statistics of each column over the rows."""
    if isinstance(values, np.ndarray) and values.ndim > 1:
        n = len(values)
        if n == 0:
            return None, None, None
        mean = values.mean(axis=0)
        if n == 1:
            return mean, None, None
        std = values.std(axis=0, ddof=1)
        return mean, std, std / math.sqrt(n)
    values = [float(v) for v in values]
    n = len(values)
    mean = math.fsum(values) / n if n else None
    std = math.sqrt(math.fsum((v - mean) ** 2 for v in values) / (n - 1)) if n > 1 else None
    return mean, std, None if std is None else std / math.sqrt(n)


#: A numerical error is small against a standard error below this fraction of it: then
#: the standard error alone is the uncertainty to quote.
SMALL = 0.1
#: The metrics whose numerical error is relative to their own size (a final error's is
#: relative to the run's mean error, :attr:`unidyn.Result.numerical_error`).
_OWN_SCALE = tuple(m for m in METRICS if BY_NAME[m].own_scale)


def numerical_error_small(relative, mean, sem):
    """Whether a numerical error ``relative`` (relative to the metric's size, as
    :attr:`unidyn.Result.numerical_error`) of a metric whose mean over seeds is ``mean``
    is below :data:`SMALL` times its standard error ``sem``: True, False, or None where
    either is unknown (one seed, no estimate)."""
    if relative is None or mean is None or sem is None:
        return None
    return float(relative) * abs(float(mean)) <= SMALL * float(sem)  # both 0: exact alike


def statistics_columns(axes) -> list:
    """The columns of statistics.csv for a sweep with these axes (``seed`` among them)."""
    return ([a for a in axes if a != "seed"] + ["case", "n"]
            + [f"{m}_{s}" for m in METRICS for s in STATISTICS]
            + ["numerical_error", "numerical_error_small", "estimate", "sensitive",
               "incomplete"])


def seed_statistics(rows, axes) -> list:
    """One row per point of the axes other than ``seed``, in the order of ``rows``:
    ``n`` (the seeds whose run completed), ``<metric>_mean``, ``<metric>_std`` (sample
    standard deviation, n - 1; empty for n < 2) and ``<metric>_sem`` (std / sqrt(n))
    over them, ``numerical_error`` (the largest estimate among the point's runs),
    ``numerical_error_small`` (whether that estimate is below :data:`SMALL` times the
    standard error for every metric whose numerical error is relative to its own size,
    so that the standard error alone is the uncertainty to quote; None where one of
    them is unknown), ``estimate`` (how the runs' numerical errors were obtained: the
    distinct values of the rows' ``estimate`` column, joined by "; ", None where the
    rows have none), ``sensitive`` (how many of its runs are) and ``incomplete`` (runs
    that stopped, left out of the statistics).

    :param rows: metrics.csv rows (:func:`unidyn.sweeps.sweep_files.read_metrics`)
    :param axes: the sweep's axes (:attr:`unidyn.sweeps.sweep.Sweep.axes`)
    """
    keys = [a for a in axes if a != "seed"]
    groups = {}
    for r in rows:
        groups.setdefault(tuple(_key(r.get(a)) for a in keys), []).append(r)
    out = []
    for members in groups.values():
        done = [r for r in members if r.get("complete")]
        row = {a: members[0].get(a) for a in keys}
        row["case"] = members[0].get("case")
        row["n"] = len(done)
        for m in METRICS:
            stats = mean_std_sem(r[m] for r in done if r.get(m) is not None)
            row[f"{m}_mean"], row[f"{m}_std"], row[f"{m}_sem"] = stats
        errors = [float(r["numerical_error"]) for r in members
                  if r.get("numerical_error") is not None]
        row["numerical_error"] = max(errors) if errors else None
        small = [numerical_error_small(row["numerical_error"], row[f"{m}_mean"], row[f"{m}_sem"])
                 for m in _OWN_SCALE]
        row["numerical_error_small"] = None if None in small else all(small)
        how = list(dict.fromkeys(str(r["estimate"]) for r in members
                                 if r.get("estimate") not in (None, "")))
        row["estimate"] = "; ".join(how) or None
        row["sensitive"] = sum(bool(r.get("sensitive")) for r in members)
        row["incomplete"] = len(members) - len(done)
        out.append(row)
    return out


def _key(v):
    """A hashable stand-in for a cell's value (lists and tables as text)."""
    return repr(v) if isinstance(v, (list, dict)) else v
