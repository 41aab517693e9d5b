"""One scenario over noise seeds: its runs, and each metric's mean, standard deviation
and standard error over them (``unidyn.run(scenario, seeds=N)``, ``unidyn run
--seeds N``).

A run with measurement noise is one sample of it: another seed moves its metrics by
far more than they are integrated wrong. Their spread over seeds is the uncertainty to
quote, computed here as for sweeps over seeds and for the paper's experiment
(:func:`unidyn.sweeps.statistics.mean_std_sem`). A folder of seed runs
(:meth:`SeedRuns.save`) holds:

- ``runs.csv``: one row per seed, its metrics, numerical error, whether it is
  sensitive and complete;
- ``statistics.csv``: one row, the columns of a sweep's
  (:func:`unidyn.sweeps.statistics.seed_statistics`);
- ``timeseries.csv``: every run's series, a ``seed`` column first;
- ``summary.json``: the scenario, the seeds, the statistics and what to quote;
- ``error.png``: the mean distance error over the seeds with its standard-error band
  (:func:`unidyn.sweeps.plots.plot_seed_error`).
"""

from __future__ import annotations

import itertools
import json
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .. import __version__
from .._validate import ValidationError, integer
from ..model.metrics import BY_NAME, MEAN_ERROR, METRIC_UNITS
from ..model.scenario import Scenario
from ..results.folders import json_ready, staged_output, write_atomic
from ..results.result import has_noise
from .statistics import numerical_error_small, seed_statistics, statistics_columns
from .sweep_files import METRICS, rows_text

__all__ = ["SeedRuns", "seed_scenarios", "seed_list", "plus_minus", "SEED_FILES", "RUN_COLUMNS"]

#: Every file a folder of seed runs may hold.
SEED_FILES = ("runs.csv", "statistics.csv", "timeseries.csv", "summary.json", "error.png")
#: The columns of runs.csv.
RUN_COLUMNS = (["seed", "case"] + list(METRICS)
               + ["numerical_error", "estimate", "sensitive", "complete", "message"])
#: The most seeds one call runs.
MAX_SEEDS = 10_000


def seed_list(scenario: Scenario, seeds) -> list:
    """The noise seeds ``seeds`` names for ``scenario``: a number N gives the N seeds
    from the scenario's own, ``noise.seed``, on; a list gives itself (distinct integers
    >= 0).

    :raises ValidationError: the scenario has no noise, or ``seeds`` is not one of these
    """
    if not has_noise(scenario):
        raise ValidationError("seeds: the scenario has no measurement noise, so every seed "
                              "gives the same run (set its noise, e.g. noise = "
                              "unidyn.model.noise.PAPER_NOISE)")
    if isinstance(seeds, (list, tuple, np.ndarray)):
        out = [integer("seeds[]", s, 0) for s in seeds]
        if not out:
            raise ValidationError("seeds is an empty list; give at least one seed")
        if len(set(out)) < len(out):
            raise ValidationError(f"seeds has a seed twice: {list(out)}")
    else:
        n = integer("seeds", seeds, 1)
        out = list(range(scenario.noise.seed, scenario.noise.seed + n))
    if len(out) > MAX_SEEDS:
        raise ValidationError(f"seeds: {len(out)} seeds; at most {MAX_SEEDS} are allowed")
    return out


def seed_scenarios(scenario: Scenario, seeds) -> tuple:
    """``(seeds, scenarios)``: the seeds of :func:`seed_list` and ``scenario`` with each
    as its ``noise.seed``, what :func:`unidyn.run` runs for ``seeds``."""
    seeds = seed_list(scenario, seeds)
    return seeds, [scenario.replace(noise={**scenario.noise.as_dict(), "seed": s})
                   for s in seeds]


def _row(seed, result) -> dict:
    """One row of runs.csv: the run's metrics (of the part computed, for a run that
    stopped), the largest of their numerical errors, how it was estimated (where the
    engine says), whether it is sensitive and complete."""
    error = result.numerical_error
    return {"seed": seed, "case": result.scenario.case,
            **{m: None if result.metrics[m] is None else float(result.metrics[m])
               for m in METRICS},
            "numerical_error": max(float(error[m]) for m in METRICS) if error else None,
            "estimate": getattr(result, "estimate", None), "sensitive": bool(result.sensitive),
            "complete": bool(result.complete), "message": result.message}


def plus_minus(mean, sem, unit: str = "") -> str:
    """``mean ± sem`` rounded to the standard error's second significant digit
    (``2.7412 ± 0.0036``); the mean alone where there is no standard error."""
    u = f" {unit}" if unit else ""
    if mean is None:
        return "-"
    if sem is None or not math.isfinite(sem) or sem <= 0 or not math.isfinite(mean):
        return f"{mean:.6g}{u}"
    decimals = 1 - math.floor(math.log10(sem))
    if 0 <= decimals <= 12 and abs(mean) < 1e9:
        return f"{mean:.{decimals}f} ± {sem:.{decimals}f}{u}"
    digits = max(1, math.floor(math.log10(abs(mean))) - math.floor(math.log10(sem)) + 2) \
        if mean else 2
    return f"{mean:.{digits - 1}e} ± {sem:.1e}{u}"


@dataclass
class SeedRuns:
    """One scenario run over noise seeds (:func:`unidyn.run` with ``seeds``).

    :ivar scenario: the scenario (its own seed is one of the runs' where ``seeds`` was N)
    :ivar seeds: the noise seeds, in the order of ``results``
    :ivar results: one :class:`~unidyn.Result` per seed (``runs[i]`` is ``results[i]``)
    :ivar rows: one dict per run, the rows of ``runs.csv``
    :ivar statistics: each metric's ``<metric>_mean``, ``_std`` and ``_sem`` over the
        seeds whose run completed, ``n``, and the rest of a row of ``statistics.csv``
        (:func:`unidyn.sweeps.statistics.seed_statistics`)
    """

    scenario: Scenario
    seeds: tuple
    results: list

    def __post_init__(self):
        self.rows = [_row(s, r) for s, r in zip(self.seeds, self.results)]
        self.statistics = seed_statistics(self.rows, ["seed"])[0]

    def __len__(self):
        return len(self.results)

    def __iter__(self):
        return iter(self.results)

    def __getitem__(self, i):
        return self.results[i]

    @property
    def complete(self) -> bool:
        """True when every run computed every sample."""
        return all(r.complete for r in self.results)

    def numerical_error(self, metric: str):
        """The largest numerical error of ``metric`` among the runs that completed
        (relative, as :attr:`unidyn.Result.numerical_error`), or None where one of them
        has none."""
        done = [r for r in self.results if r.complete]
        errors = [r.numerical_error[metric] for r in done
                  if r.numerical_error and metric in r.numerical_error]
        return max(errors) if errors and len(errors) == len(done) else None

    def numerical_error_small(self, metric: str):
        """Whether the runs' numerical error of ``metric`` is small (below a tenth)
        against its standard error over the seeds: True, False, or None where unknown
        (one seed, no estimate). A final error's is relative to the run's mean error
        IAE / T, the other metrics' to their own size
        (:data:`unidyn.model.metrics.Metric`'s ``own_scale``)."""
        st = self.statistics
        mean_error = st[f"{MEAN_ERROR}_mean"]
        scale = (mean_error / self.scenario.T if not BY_NAME[metric].own_scale
                 and mean_error is not None else st[f"{metric}_mean"])
        return numerical_error_small(self.numerical_error(metric), scale, st[f"{metric}_sem"])

    def __repr__(self) -> str:
        """Each metric as mean ± standard error (n) over the seeds, the numerical error
        beside it only where it is not small against the standard error."""
        sc, st, n = self.scenario, self.statistics, self.statistics["n"]
        robot = getattr(sc.robot, "name", "") or "custom robot"
        first = self.results[0] if self.results else None
        shown = ", ".join(map(str, self.seeds[:8])) + (", ..." if len(self.seeds) > 8 else "")
        lines = [f"unidyn.SeedRuns: {sc.case} loop" + (f" {sc.name!r}" if sc.name else "")
                 + f" over {len(self.seeds)} noise seeds ({shown})",
                 f"  robot {robot}, reference {type(sc.trajectory).__name__}, T = {sc.T:g} s"
                 + (f", engine {first.engine}" + (f" ({first.backend})" if first.backend else "")
                    if first else "")
                 + f"; {n} of {len(self.results)} runs complete",
                 f"  mean ± standard error over the {n} seeds (n = {n}): the uncertainty to quote"]
        for m in METRICS:
            text = plus_minus(st[f"{m}_mean"], st[f"{m}_sem"], METRIC_UNITS.get(m, ""))
            line = f"  {m:12s} {text} (n = {n})"
            if self.numerical_error_small(m) is False:
                line += (f"  numerical error {self.numerical_error(m):.1e} relative, not "
                         f"small against it")
            lines.append(line)
        if n < 2:
            lines.append("  one seed: no spread; run more seeds for a standard error")
        small = [self.numerical_error_small(m) for m in METRICS]
        if all(s is True for s in small):
            lines.append("  numerical error below a tenth of each standard error: the "
                         "standard error alone counts")
        elif any(self.numerical_error(m) is None for m in METRICS) and n:
            lines.append("  numerical error: not estimated for every run"
                         + (" (the diagram integrates once)"
                            if first and first.engine == "bdsim" else ""))
        lines.append(f"  sensitive    {st['sensitive']} of {len(self.results)} runs"
                     + ("" if st["sensitive"] else " (False for every run)"))
        if st["incomplete"]:
            lines.append(f"  incomplete   {st['incomplete']} runs stopped, left out of the "
                         f"statistics: " + next(r.message for r in self.results if not r.complete))
        lines.append("  runs: runs[i] (a unidyn.Result per seed), rows, statistics; "
                     "plot_error(); save(folder)")
        return "\n".join(lines)

    # ------------------------------------------------------------------ #
    def summary(self) -> dict:
        """What ``summary.json`` holds: the scenario, the seeds, the statistics, what
        to quote, and each run's metrics."""
        return {
            "unidyn_version": __version__,
            "engine": self.results[0].engine if self.results else None,
            "backend": self.results[0].backend if self.results else None,
            "scenario": json_ready(self.scenario.to_dict()),
            "seeds": list(self.seeds),
            "uncertainty": (f"each metric's mean over the {self.statistics['n']} seeds whose "
                            f"run completed, with its standard error (std / sqrt(n)): the "
                            f"uncertainty of the mean over the measurement noise; the "
                            f"numerical error is the integration's alone"),
            "statistics": json_ready(_finite(self.statistics)),
            "numerical_error_small": {m: self.numerical_error_small(m) for m in METRICS},
            "runs": json_ready([_finite(r) for r in self.rows]),
        }

    def save(self, folder, overwrite: bool = False) -> Path:
        """Write runs.csv, statistics.csv, timeseries.csv, summary.json and error.png
        (:data:`SEED_FILES`) into ``folder``, as :meth:`unidyn.Result.save` writes a
        run's: nothing replaced without ``overwrite``, nothing of the user's touched,
        the files moved into place only once all are written."""
        with staged_output(folder, kind="seeds", names=SEED_FILES, overwrite=overwrite,
                           what="seed runs", option="folder", flag="overwrite=True") as stage:
            self.write(stage.path)
        return Path(folder)

    def write(self, folder) -> None:
        """Write the files into ``folder`` (a stage: see :meth:`save`)."""
        folder = Path(folder)
        write_atomic(folder / "runs.csv", rows_text(RUN_COLUMNS, self.rows))
        write_atomic(folder / "statistics.csv",
                     rows_text(statistics_columns(["seed"]), [self.statistics]))
        if self.results:
            header = "seed," + ",".join(self.results[0].series_columns()) + "\n"
            write_atomic(folder / "timeseries.csv", header, more=itertools.chain.from_iterable(
                r.series_text(lead=f"{s},") for s, r in zip(self.seeds, self.results)))
        write_atomic(folder / "summary.json", json.dumps(self.summary(), indent=2,
                                                         allow_nan=False) + "\n")
        try:
            from ..results import figstyle
            from .plots import plot_seed_error
            with figstyle.style():
                figstyle.save(plot_seed_error(self).figure, folder / "error.png")
        except ImportError:  # no matplotlib: the data is what matters
            pass

    def plot_error(self, ax=None):
        """The mean distance error over the seeds with its standard-error band
        (:func:`unidyn.sweeps.plots.plot_seed_error`)."""
        from .plots import plot_seed_error
        return plot_seed_error(self, ax=ax)


def _finite(row: dict) -> dict:
    """``row`` with its non-finite numbers as None (null in JSON)."""
    return {k: (None if isinstance(v, float) and not math.isfinite(v) else v)
            for k, v in row.items()}
