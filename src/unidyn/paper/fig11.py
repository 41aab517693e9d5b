"""The paper's Fig. 11: IAE against the kinematic controller's gain kx = ky for four
cases, and what the paper says of it.

:func:`paper_fig11` is the sweep (the four cases :data:`FIG11_CASES`);
:func:`fig11_claims` judges its metrics against the paper's claims, each claim one entry
of :data:`FIG11_CLAIMS` whose words and criterion are made from the paper's numbers
(:data:`FIG11_PAPER`); :func:`format_fig11_claims` makes a Markdown table of them and
:func:`plot_fig11` draws the figure.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass

import numpy as np

from .._validate import BATCH_ATOL, BATCH_RTOL, ValidationError
from ..model.noise import PAPER_NOISE
from ..results import figstyle
from ..sweeps.statistics import mean_std_sem
from ..sweeps.sweep import Sweep
from ..sweeps.sweep_files import read_metrics
from .claims import BARS

__all__ = ["paper_fig11", "fig11_claims", "format_fig11_claims", "fig11_table", "Fig11Claim",
           "Fig11Point", "FIG11_CASES", "FIG11_CLAIMS", "FIG11_PAPER", "FIG11_ESTIMATE",
           "plot_fig11", "BARS"]

#: The estimates of cases (b) and (c), times theta: "wrong parameter estimates (10 %)".
FIG11_ESTIMATE = 0.9
#: The four cases of Fig. 11 (Section 5's list (a)-(d)), by variant label: what each is,
#: and the Scenario fields (and sweep keys) that make it.
_VARIANTS = {
    "a": ("kinematic controller only", {"case": "uncompensated"}),
    "b": (f"compensation, θ̂ = {FIG11_ESTIMATE:g} θ, no update",
          {"case": "compensated", "theta_hat_scale": FIG11_ESTIMATE}),
    "c": (f"adaptive from t = 0, θ̂(0) = {FIG11_ESTIMATE:g} θ",
          {"case": "adaptive", "adapt_from": 0.0, "theta_hat_scale": FIG11_ESTIMATE}),
    "d": ("exact θ̂, no update", {"case": "compensated", "theta_hat_scale": 1.0}),
}
#: The four cases of Fig. 11, by variant label.
FIG11_CASES = {lab: f"({lab}) {text}" for lab, (text, _) in _VARIANTS.items()}


def paper_fig11(T: float = 250.0, gains=None, noise=PAPER_NOISE, *, base=None, seeds=None,
                rtol: float = BATCH_RTOL, atol: float = BATCH_ATOL) -> Sweep:
    """The sweep of the paper's Fig. 11: IAE over ``T`` for kx = ky in ``gains``
    (default 0.5, 1.0, ..., 35: 70 values), four variants:

    - ``a``: kinematic controller only on the dynamic robot (case ``uncompensated``)
    - ``b``: compensation with theta_hat0 = 0.9 theta, no update (``compensated``)
    - ``c``: the same, updating from t = 0 (``adaptive``, ``adapt_from = 0``)
    - ``d``: exact theta_hat, no update (``compensated``, scale 1.0)

    Everything else is the paper's Section 5 setting.

    :param noise: a NoiseSpec (default: the paper's stated noise), its dict, or
        ``None`` for noise-free runs
    :param base: further Scenario fields for every point (e.g. ``{"vd_dot": "filter"}``)
    :param seeds: a number N (seeds 1..N) or a list of noise seeds: every point run once
        per seed (a ``seed`` axis; the claims and the figure then use the mean and its
        standard error over the seeds). ``None``: the noise's own seed, once
    """
    if gains is None:
        gains = np.arange(0.5, 35.0 + 1e-9, 0.5)
    gains = [float(g) for g in np.atleast_1d(np.asarray(gains, dtype=float))]
    b = {"T": T, "noise": noise}  # Sweep turns a NoiseSpec into plain data
    if base:
        b.update(base)
    if b["noise"] is None:
        b["noise"] = "off"
    variants = tuple({"label": lab, **fields} for lab, (_, fields) in _VARIANTS.items())
    grid = {"kxy": gains}
    if seeds is not None:
        if b["noise"] == "off":
            raise ValidationError("seeds: the noise is off, so every seed gives the same run")
        if isinstance(seeds, (int, np.integer)) and not isinstance(seeds, bool):
            if seeds < 1:
                raise ValidationError(f"seeds must be at least 1, got {seeds}")
            seeds = list(range(1, int(seeds) + 1))
        grid["seed"] = list(seeds)
    return Sweep(base=b, grid=grid, variants=variants,
                 name="Fig. 11 (IAE against kx = ky)", rtol=rtol, atol=atol)


@dataclass(frozen=True)
class Fig11Claim:
    """One thing the paper says of Fig. 11, the criterion used, the measured numbers
    (each IAE as mean ± error bar), and whether it holds beyond the error bars
    (``verdict``: "holds", "does not hold", "cannot be told apart within the error
    bars", or "not covered" by the sweep; ``holds``: True, False, or None for the
    last two)."""

    claim: str
    criterion: str
    measured: str
    holds: bool | None
    verdict: str = ""

    def __post_init__(self):
        if not self.verdict:
            verdict = {True: "holds", False: "does not hold"}.get(self.holds, "not covered")
            object.__setattr__(self, "verdict", verdict)


@dataclass(frozen=True)
class Fig11Point:
    """One case at one gain: the IAE's mean over the seeds whose run completed, its
    error bar (the standard error over the seeds; with one seed, the run's largest
    numerical error estimate, which for a sensitive run is how far a 1e-12 m
    perturbation moved it), and how many seeds."""

    iae: float
    error: float
    n: int


def _fig11_rows(metrics) -> tuple[list, dict, list]:
    """(ks, table, skipped): the gains every case has a complete point for (perhaps
    none), :class:`Fig11Point` by case and gain, and the (case, gain) of every point
    none of whose runs completed (left out)."""
    rows = read_metrics(metrics) if isinstance(metrics, (str, os.PathLike)) else list(metrics)
    runs = {lab: {} for lab in FIG11_CASES}
    for r in rows:
        if "variant" not in r or "kxy" not in r:
            raise ValidationError("fig11_claims needs rows with 'variant' and 'kxy' "
                                  "(the metrics of paper_fig11())")
        if r["variant"] in runs:
            runs[r["variant"]].setdefault(float(r["kxy"]), []).append(r)
    table = {lab: {} for lab in FIG11_CASES}
    skipped = []
    for lab, by_k in runs.items():
        for k, members in by_k.items():
            done = [r for r in members if r.get("complete", True) and r.get("iae") is not None]
            if not done:
                skipped.append((lab, k))
                continue
            mean, _, error = mean_std_sem(r["iae"] for r in done)
            if error is None:  # one seed: the run's largest estimate, relative
                error = float(done[0].get("numerical_error") or 0.0) * abs(mean)
            # else the spread over the seeds (a sensitive run's among it)
            table[lab][k] = Fig11Point(mean, error, len(done))
    missing = [lab for lab, v in table.items() if not v]
    if missing:
        raise ValidationError(f"fig11_claims: no complete rows for case(s) {', '.join(missing)}"
                              + (f" ({len(skipped)} incomplete point(s) left out)"
                                 if skipped else ""))
    ks = sorted(set.intersection(*(set(v) for v in table.values())))
    return ks, table, sorted(skipped)


def fig11_table(metrics) -> tuple[list, dict]:
    """``(ks, table)``: the gains kx = ky every case has a complete point for, and the
    IAE (mean over the seeds) by case label (:data:`FIG11_CASES`) and gain; points none
    of whose runs completed are left out. ``metrics``: rows of
    :func:`~unidyn.sweeps.sweep_files.read_metrics` or a metrics.csv path."""
    ks, table, _ = _fig11_rows(metrics)
    return ks, {lab: {k: p.iae for k, p in v.items()} for lab, v in table.items()}


def _below(x: Fig11Point, y: Fig11Point) -> int:
    """1 where x is below y beyond :data:`BARS` error bars of the difference, -1 where
    above beyond them, 0 where the two cannot be told apart."""
    d, s = y.iae - x.iae, BARS * math.hypot(x.error, y.error)
    return 1 if d > s else (-1 if d < -s else 0)


def _verdict(signs) -> bool | None:
    """True where every comparison holds beyond the error bars, False where one fails
    beyond them, None where some cannot be told apart (and none fails)."""
    signs = list(signs)
    if any(s < 0 for s in signs):
        return False
    return True if all(s > 0 for s in signs) else None


def _kl(ks, limit=6) -> str:
    s = ", ".join(f"{k:g}" for k in ks[:limit])
    return s + (f", ... ({len(ks)} in all)" if len(ks) > limit else "")


def _point_text(p: Fig11Point) -> str:
    return f"{p.iae:.3f} ± {p.error:.2g}"


#: What the paper says of Fig. 11 in numbers: (a)'s IAE is "higher than 8 for kx = ky =
#: 1", and reaches "its minimum value of 1.24" at kx = ky = 23.
FIG11_PAPER = {"low gain": 1.0, "iae above at low gain": 8.0, "best gain": 23.0,
               "best iae": 1.24}
#: How near the paper's minimum of (a) the measured one must be. Near its minimum the
#: IAE changes slowly with the gain, so where it falls is judged to +-5 1/s (half the
#: spacing of Fig. 11's ticks, 10) and its value to +-25 % (beyond the error bars: the
#: paper's noise draw and integration are not ours).
GAIN_READ, IAE_READ = 5.0, 0.25
_APART = "cannot be told apart within the error bars"


@dataclass(frozen=True)
class _Sweep:
    """What the claims are judged on: the gains every case has a complete point for,
    :class:`Fig11Point` by case and gain, and the (case, gain) of incomplete points."""

    ks: list
    tab: dict
    skipped: list

    def left_out(self, labels, at=None) -> str:
        """What the claim leaves out: the incomplete points of cases ``labels``."""
        pts = [(lab, k) for lab, k in self.skipped
               if lab in labels and (at is None or k == at)]
        if not pts:
            return ""
        where = ", ".join(f"{lab} at k = {k:g}" for lab, k in pts[:6])
        more = f", ... ({len(pts)} in all)" if len(pts) > 6 else ""
        return f"; {len(pts)} incomplete point(s) left out ({where}{more})"


def _judged(holds, covered: bool = True) -> str:
    """The verdict of a comparison made with the error bars."""
    return {True: "holds", False: "does not hold"}.get(holds, _APART if covered
                                                        else "not covered")


def _above_at_low_gain(sw: _Sweep):
    """(a) above the paper's IAE at its low gain, beyond the error bars."""
    k, floor = FIG11_PAPER["low gain"], FIG11_PAPER["iae above at low gain"]
    a = sw.tab["a"]
    if k in a:
        p = a[k]
        sign = 1 if p.iae - BARS * p.error > floor else (-1 if p.iae + BARS * p.error < floor
                                                          else 0)
        holds = _verdict([sign])
        return f"IAE_a({k:g}) = {_point_text(p)}", holds, _judged(holds)
    if ("a", k) in sw.skipped:
        return (f"the run at k = {k:g} did not complete" + sw.left_out("a", k), None,
                "not covered")
    return f"k = {k:g} not in the sweep", None, "not covered"


def _smallest_at(sw: _Sweep):
    """(a)'s minimum: every gain within its error bars inside the paper's gain +-
    :data:`GAIN_READ`, its value within the paper's +- :data:`IAE_READ`."""
    best_k, best = FIG11_PAPER["best gain"], FIG11_PAPER["best iae"]
    a = sw.tab["a"]
    ka = min(a, key=lambda k: (a[k].iae, k))
    # the gains whose IAE cannot be told apart from the minimum's
    flat = [k for k in sorted(a) if _below(a[ka], a[k]) == 0]
    at_best = f"; IAE_a({best_k:g}) = {_point_text(a[best_k])}" if best_k in a else ""
    covers = min(a) <= best_k <= max(a)
    holds = None
    if covers:
        inside = [abs(k - best_k) <= GAIN_READ for k in flat]
        value = abs(a[ka].iae - best) <= IAE_READ * best + BARS * a[ka].error
        holds = (all(inside) and value) if (all(inside) or not any(inside)) else None
        holds = False if not value else holds
    measured = (f"minimum {_point_text(a[ka])} at k = {ka:g}{_end_of_sweep(ka, a)}"
                + (f"; within the error bars of it: k = {_kl(flat)}" if len(flat) > 1 else "")
                + at_best + ("" if covers else _not_reached(sw, best_k)) + sw.left_out("a"))
    return measured, holds, _judged(holds, covers)


def _end_of_sweep(k, series) -> str:
    """Where the minimum at gain k is an end of the sweep, which end."""
    if k == max(series):
        return " (the largest k swept: still falling, no interior minimum)"
    return " (the smallest k swept)" if k == min(series) else ""


def _not_reached(sw: _Sweep, k) -> str:
    """Why (a) has no complete point around gain k: outside the sweep, or incomplete."""
    swept = set(sw.tab["a"]) | {g for lab, g in sw.skipped if lab == "a"}
    return (f" (k = {k:g} is outside the sweep)" if not min(swept) <= k <= max(swept)
            else f" (no complete point of (a) reaches k = {k:g})")


def _below_a(lab: str):
    """Case ``lab`` below (a) at every gain both have a complete point for."""
    def judge(sw: _Sweep):
        a, series = sw.tab["a"], sw.tab[lab]
        both = sorted(set(a) & set(series))
        if not both:
            return ("no gain with complete points of both" + sw.left_out(("a", lab)), None,
                    "not covered")
        signs = {k: _below(series[k], a[k]) for k in both}
        bad = [k for k in both if signs[k] < 0]
        even = [k for k in both if signs[k] == 0]
        ratio = max(series[k].iae / a[k].iae for k in both)
        holds = _verdict(signs.values())
        return (f"below at {len(both) - len(bad) - len(even)} of {len(both)} k"
                + (f"; above at k = {_kl(bad)}" if bad else "")
                + (f"; {_APART} at k = {_kl(even)}" if even else "")
                + f"; largest IAE_{lab}/IAE_a = {ratio:.3f}" + sw.left_out(("a", lab)),
                holds, _judged(holds))
    return judge


def _lowest(sw: _Sweep):
    """(d) below the best of (a), (b), (c) at every gain all four have a point for."""
    ks, (a, b, c, d) = sw.ks, (sw.tab[x] for x in "abcd")
    if not ks:
        return ("no gain with complete points of all four" + sw.left_out("abcd"), None,
                "not covered")
    best = {k: min((a[k], b[k], c[k]), key=lambda p: p.iae) for k in ks}
    signs = {k: _below(d[k], best[k]) for k in ks}
    bad = [k for k in ks if signs[k] < 0]
    even = [k for k in ks if signs[k] == 0]
    worst = max(ks, key=lambda k: d[k].iae - best[k].iae)
    holds = _verdict(signs.values())
    return (f"lowest at {len(ks) - len(bad) - len(even)} of {len(ks)} k"
            + (f"; not at k = {_kl(bad)} (at k = {worst:g}: d {_point_text(d[worst])}, "
               f"best other {_point_text(best[worst])})" if bad else "")
            + (f"; {_APART} at k = {_kl(even)}" if even else "")
            + sw.left_out("abcd"), holds, _judged(holds))


_P = FIG11_PAPER
#: What the paper says of Fig. 11, each claim once: (its words, the criterion, the
#: judge that measures it on the sweep and gives (measured, holds, verdict)).
FIG11_CLAIMS = (
    (f"(a) IAE above {_P['iae above at low gain']:g} at k = {_P['low gain']:g}",
     f"IAE_a(k = {_P['low gain']:g}) > {_P['iae above at low gain']:g}", _above_at_low_gain),
    (f"(a) smallest IAE, {_P['best iae']:g}, at k = {_P['best gain']:g}",
     f"minimum of (a) at {_P['best gain'] - GAIN_READ:g} <= k <= "
     f"{_P['best gain'] + GAIN_READ:g}, value within {_P['best iae']:g} ± "
     f"{100 * IAE_READ:g} %", _smallest_at),
    *((f"({lab}) below (a) for every k", f"IAE_{lab}(k) < IAE_a(k) at every k swept",
       _below_a(lab)) for lab in "bc"),
    ("(d) lowest for every k", "IAE_d(k) < IAE of (a), (b) and (c) at every k swept",
     _lowest),
)
del _P


def fig11_claims(metrics) -> list:
    """Compare Fig. 11 metrics (rows of :func:`read_metrics`, or the path of a
    metrics.csv) with what the paper says of its Fig. 11 (:data:`FIG11_CLAIMS`), judged
    with the error bars of :class:`Fig11Point`: a comparison holds, does not hold, or
    cannot be told apart where the difference is within :data:`BARS` error bars.

    Points none of whose runs completed are left out, and every claim they would have
    entered says how many were left out and where. Claims about one k (k = 1, 23)
    need that k in the sweep; otherwise they are reported as not covered.
    :return: list of :class:`Fig11Claim`
    """
    sw = _Sweep(*_fig11_rows(metrics))
    return [Fig11Claim(claim, criterion, *judge(sw)) for claim, criterion, judge in FIG11_CLAIMS]


def format_fig11_claims(claims, title: str | None = None) -> str:
    """A Markdown table of :func:`fig11_claims`."""
    rows = [] if title is None else [title, ""]
    rows += ["| the paper says | criterion | measured (mean ± error bar) | verdict |",
             "|---|---|---|---|"]
    for c in claims:
        rows.append(f"| {c.claim} | {c.criterion} | {c.measured} | {c.verdict} |")
    return "\n".join(rows)


def plot_fig11(metrics, path, title: str | None = None):
    """IAE against k = kx = ky for the four cases, log y with plain tick labels (1, 2,
    5, 10, 20), as the paper's Fig. 11, each point the mean over the seeds ± its error
    bar (:class:`Fig11Point`). In unidyn's figure style (:mod:`unidyn.results.figstyle`).
    Each case is drawn over its complete points; a note names the points left out
    (their runs' messages in ``metrics.csv`` say why)."""
    import matplotlib.pyplot as plt  # here: matplotlib is optional and slow to import

    _, tab, skipped = _fig11_rows(metrics)
    with figstyle.style():
        fig, ax = plt.subplots(figsize=figstyle.size(1, 0.95))
        for (lab, desc), mk in zip(FIG11_CASES.items(), ("o", "s", "^", "D")):
            ks = sorted(tab[lab])  # each case over its complete points
            ys = np.array([tab[lab][k].iae for k in ks])
            es = np.array([tab[lab][k].error for k in ks])
            ys[~np.isfinite(ys)] = np.nan
            line, = ax.plot(ks, ys, "-", marker=mk, ms=2.5, markevery=max(1, len(ks) // 12),
                            label=desc)
            ax.fill_between(ks, ys - es, ys + es, color=line.get_color(), alpha=0.25, lw=0)
        if skipped:  # where a curve ends early, say why
            gone = {lab: [k for c, k in skipped if c == lab] for lab in FIG11_CASES}
            cases = ", ".join(f"({lab}) {len(ks)} at k ≥ {min(ks):g}"
                              for lab, ks in gone.items() if ks)
            ax.plot([], [], " ", label=f"points not drawn (incomplete runs):\n{cases}")
        figstyle.plain_log_axis(ax, "y")
        ax.set_xlabel("$k_x = k_y$ (1/s)")
        n = max(p.n for v in tab.values() for p in v.values())
        ax.set_ylabel("IAE (m·s)")
        ax.set_title((title or "IAE against the kinematic controller's gain (Fig. 11)")
                     + (f"\nmean ± standard error over {n} seeds" if n > 1 else ""))
        ax.grid(True, which="major")
        ax.grid(True, which="minor", axis="y", alpha=0.2)
        figstyle.legend(ax, outside="below")
        return figstyle.save(fig, path)
