"""Statistics over noise seeds: a sweep whose grid varies ``seed`` gets one row per
point of the other axes in ``statistics.csv`` (:func:`seed_statistics`), each metric
as its mean, standard deviation and standard error over the seeds, beside the largest
numerical error estimate among the point's runs."""

from __future__ import annotations

import math

from .sweep_files import METRICS

__all__ = ["seed_statistics", "statistics_columns", "mean_std_sem", "STATISTICS"]

#: The statistics of each metric, as column suffixes.
STATISTICS = ("mean", "std", "sem")


def mean_std_sem(values) -> tuple:
    """(mean, sample standard deviation (n - 1), standard error std / sqrt(n)) of
    ``values``; None where there are too few of them (no mean for none, no spread for
    one)."""
    values = [float(v) for v in values]
    n = len(values)
    mean = math.fsum(values) / n if n else None
    std = math.sqrt(math.fsum((v - mean) ** 2 for v in values) / (n - 1)) if n > 1 else None
    return mean, std, None if std is None else std / math.sqrt(n)


def statistics_columns(axes) -> list:
    """The columns of statistics.csv for a sweep with these axes (``seed`` among them)."""
    return ([a for a in axes if a != "seed"] + ["case", "n"]
            + [f"{m}_{s}" for m in METRICS for s in STATISTICS]
            + ["numerical_error", "sensitive", "incomplete"])


def seed_statistics(rows, axes) -> list:
    """One row per point of the axes other than ``seed``, in the order of ``rows``:
    ``n`` (the seeds whose run completed), ``<metric>_mean``, ``<metric>_std`` (sample
    standard deviation, n - 1; empty for n < 2) and ``<metric>_sem`` (std / sqrt(n))
    over them, ``numerical_error`` (the largest estimate among the point's runs),
    ``sensitive`` (how many of its runs are) and ``incomplete`` (runs that stopped,
    left out of the statistics).

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
        row["sensitive"] = sum(bool(r.get("sensitive")) for r in members)
        row["incomplete"] = len(members) - len(done)
        out.append(row)
    return out


def _key(v):
    """A hashable stand-in for a cell's value (lists and tables as text)."""
    return repr(v) if isinstance(v, (list, dict)) else v
