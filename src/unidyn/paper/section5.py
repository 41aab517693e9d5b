"""Section 5's four simulations and what the paper says of them.

Each claim is one entry of :data:`SECTION5_CLAIMS`: the case it speaks of, the paper's
words (made from the paper's numbers, :data:`SECTION5_PAPER`) and the conditions it is
judged by (:class:`Bound`), from which both the criterion's text and its test are made.
:func:`section5_claims` judges the four results of ``Scenario.paper(1..4)``;
:func:`format_claims` makes a Markdown table of them.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from ..model.cases import CASES
from ..model.noise import PAPER_NOISE
from ..model.scenario import Scenario
from .claims import Claim

__all__ = ["section5_claims", "format_claims", "SECTION5_CLAIMS", "SECTION5_PAPER", "Stat",
           "Bound", "Section5Claim"]

#: The paper's simulation 4: its duration and when updating starts (Section 5).
_PAPER = Scenario.paper(4)

#: What the paper says of its simulations in numbers, m: the distance error starts at
#: 0.2 m (h starts 0.2 m from the reference); without compensation it oscillates around
#: 0.1 m; with adaptive compensation it is about 0.2 m before updating starts and below
#: 0.05 m at the end.
SECTION5_PAPER = {"start": 0.2, "uncompensated": 0.1, "adaptive before": 0.2,
                  "adaptive end": 0.05}

#: The noise of the position, m (Section 5: standard deviation 0.01 m): an error whose
#: mean is below it "decays to zero"; below twice it, an error is "small, from the
#: noise"; above twice it, the error "never vanishes" (more than noise explains).
NOISE_LEVEL = PAPER_NOISE.position_std
#: How near "about" and "around" put a value the paper reads off its error plots, m.
ABOUT = 0.05
#: "Close to case 1" with compensation: its error is at most this fraction of case 2's
#: (the compensation removes four fifths of what the dynamics add, at least).
CLOSE_FRACTION = 1 / 5
#: The transient from the start, s: "never vanishes" and "close to" speak of the error
#: after it, and "decays to zero" of the error over as long a time at the end.
SETTLED = 50.0
#: "At t = T" with noise on every sample: the mean over the last seconds, s.
END_WINDOW = 5.0


@dataclass(frozen=True)
class Stat:
    """A number of one run's distance error: its ``"mean"`` or ``"min"`` over
    [t0, t1] s, or its value ``"at"`` t0 s; ``scale`` multiplies it."""

    run: int
    kind: str
    t0: float
    t1: float | None = None
    scale: float = 1.0

    def text(self, run: int, short: bool = False, beside: Stat | None = None) -> str:
        """In words, in a claim about case ``run`` (another case's is named); ``short``:
        as a measured number is labelled; ``beside``: the statistic it bounds (the same
        statistic of another case is named by its case alone)."""
        if self.kind == "at":
            what = f"error({self.t0:g})"
        else:
            what = f"{self.kind}{'' if short else ' error over'} {self.t0:g}-{self.t1:g} s"
        if self.run != run:
            same = beside is not None and (beside.kind, beside.t0, beside.t1) == (
                self.kind, self.t0, self.t1)
            what = f"case {self.run}'s" + ("" if same else f" {what}")
        return what if self.scale == 1.0 else f"{_fraction(self.scale)} of {what}"

    def value(self, results) -> float:
        r = results[self.run - 1]
        if self.kind == "at":
            return self.scale * float(r.error[np.argmin(np.abs(r.t - self.t0))])
        m = (r.t >= self.t0) & (r.t <= self.t1)
        return self.scale * float({"mean": np.mean, "min": np.min}[self.kind](r.error[m]))


@dataclass(frozen=True)
class Bound:
    """A condition on a :class:`Stat`: ``low < stat < high`` (each a number in m, a
    :class:`Stat`, or None for no bound), or ``stat = equal`` to 1e-9 m."""

    stat: Stat
    low: float | Stat | None = None
    high: float | Stat | None = None
    equal: float | None = None

    def text(self, run: int, stat: bool = True) -> str:
        """In words, in a claim about case ``run``; ``stat=False``: without the
        statistic's name (a second bound on the one just named)."""
        s = self.stat.text(run) + " " if stat else ""
        if self.equal is not None:
            return f"{s}= {self.equal:g} m"
        if self.low is not None and self.high is not None:  # numbers, m
            return f"{s}within {self.low:g}-{self.high:g} m"
        b = self.low if self.low is not None else self.high
        b = b.text(run, beside=self.stat) if isinstance(b, Stat) else f"{b:g} m"
        return f"{s}{'>' if self.low is not None else '<'} {b}"

    def holds(self, results) -> bool:
        v = self.stat.value(results)
        if self.equal is not None:
            return abs(v - self.equal) < 1e-9
        lo, hi = (b.value(results) if isinstance(b, Stat) else b
                  for b in (self.low, self.high))
        if lo is not None and hi is not None:  # a range includes its ends
            return lo <= v <= hi
        return v > lo if lo is not None else v < hi

    def stats(self):
        return [self.stat] + [b for b in (self.low, self.high) if isinstance(b, Stat)]


def _fraction(x: float) -> str:
    return f"1/{1 / x:g}" if x < 1 and float(1 / x).is_integer() else f"{x:g} times"


def _near(stat: Stat, value: float) -> Bound:
    """"About" or "around" ``value`` (:data:`ABOUT`)."""
    return Bound(stat, low=value - ABOUT, high=value + ABOUT)


@dataclass(frozen=True)
class Section5Claim:
    """One claim of Section 5: the run (case 1-4) it speaks of, the paper's words, the
    conditions it holds by (all of them), and further numbers shown beside them."""

    run: int
    paper: str
    bounds: tuple
    shown: tuple = ()

    def judge(self, results) -> Claim:
        stats = dict.fromkeys([replace(s, scale=1.0) for b in self.bounds for s in b.stats()]
                              + list(self.shown))
        measured = ", ".join(f"{s.text(self.run, short=True)} = {_metres(s.value(results))} m"
                             for s in stats)
        criterion = " and ".join(
            b.text(self.run, stat=i == 0 or b.stat != self.bounds[i - 1].stat)
            for i, b in enumerate(self.bounds))
        return Claim(f"{self.run} {CASES[self.run - 1]}", self.paper, criterion, measured,
                     all(b.holds(results) for b in self.bounds))


def _metres(v: float) -> str:
    """3 decimals, 4 below 1 cm."""
    return f"{v:.3f}" if abs(v) >= 0.01 else f"{v:.4f}"


_T, _UPDATE, P = _PAPER.T, _PAPER.adapt_from, SECTION5_PAPER
_AFTER = {run: Stat(run, "mean", SETTLED, _T) for run in (1, 2, 3)}

#: What Section 5 says of its four simulations, each claim once (:class:`Section5Claim`).
SECTION5_CLAIMS = (
    Section5Claim(1, f"error starts at {P['start']:g} m and decays to zero", (
        Bound(Stat(1, "at", 0.0), equal=P["start"]),
        Bound(Stat(1, "mean", _T - SETTLED, _T), high=NOISE_LEVEL))),
    Section5Claim(2, f"error never vanishes, oscillates around {P['uncompensated']:g} m", (
        Bound(Stat(2, "min", SETTLED, _T), low=2 * NOISE_LEVEL),
        _near(_AFTER[2], P["uncompensated"]))),
    Section5Claim(3, "close to case 1, small error from the noise", (
        Bound(_AFTER[3], high=2 * NOISE_LEVEL),
        Bound(_AFTER[3], high=Stat(2, "mean", SETTLED, _T, scale=CLOSE_FRACTION))),
        shown=(_AFTER[1],)),
    Section5Claim(4, f"about {P['adaptive before']:g} m before updating starts at "
                     f"t = {_UPDATE:g} s", (
        _near(Stat(4, "mean", SETTLED, _UPDATE), P["adaptive before"]),)),
    Section5Claim(4, f"below {P['adaptive end']:g} m at t = {_T:g} s", (
        Bound(Stat(4, "mean", _T - END_WINDOW, _T), high=P["adaptive end"]),),
        shown=(Stat(4, "at", _T),)),
)
del P


def section5_claims(r1, r2, r3, r4) -> list[Claim]:
    """Compare the four Section 5 runs (the results of ``Scenario.paper(1..4)``) with
    what the paper says of them (:data:`SECTION5_CLAIMS`)."""
    results = (r1, r2, r3, r4)
    return [c.judge(results) for c in SECTION5_CLAIMS]


def format_claims(claims) -> str:
    """A Markdown table of the claims."""
    rows = ["| case | the paper says | criterion | measured | holds |",
            "|---|---|---|---|---|"]
    for c in claims:
        rows.append(f"| {c.case} | {c.paper} | {c.criterion} | {c.measured} | "
                    f"{'yes' if c.holds else 'NO'} |")
    return "\n".join(rows)
