"""What the paper says, and the checks of it: its Section 5 simulations and its Fig. 11.

- Section 5: :func:`section5_claims` takes the four results of
  ``Scenario.paper(1..4)`` and returns, for each claim the paper makes about them,
  the measured number and whether it holds by the stated criterion
  (:func:`format_claims` makes a Markdown table of them).
- Fig. 11: :func:`paper_fig11` is the sweep of the paper's Fig. 11 (IAE against the
  kinematic controller's gain kx = ky, four cases :data:`FIG11_CASES`), and
  :func:`fig11_claims` compares its metrics with what the paper says of them
  (:func:`format_fig11_claims`), and :func:`plot_fig11` draws the figure.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass

import numpy as np

from .results import figstyle
from ._validate import ValidationError
from ._validate import BATCH_ATOL, BATCH_RTOL
from .sweeps.sweep_files import read_metrics
from .model.noise import PAPER_NOISE
from .sweeps.sweep import Sweep

__all__ = ["Claim", "section5_claims", "format_claims", "paper_fig11", "fig11_claims",
           "format_fig11_claims", "fig11_table", "Fig11Claim", "Fig11Point", "FIG11_CASES",
           "plot_fig11", "BARS"]


@dataclass(frozen=True)
class Claim:
    case: str
    paper: str
    criterion: str
    measured: str
    holds: bool


def _mean(r, t0, t1):
    m = (r.t >= t0) & (r.t <= t1)
    return float(np.mean(r.error[m]))


def _minmax(r, t0, t1):
    m = (r.t >= t0) & (r.t <= t1)
    return float(np.min(r.error[m])), float(np.max(r.error[m]))


def section5_claims(r1, r2, r3, r4) -> list[Claim]:
    """Compare the four Section 5 runs with what the paper says of them."""
    claims = []
    e0 = float(r1.error[0])
    late1 = _mean(r1, 150, 200)
    claims.append(Claim("1 kinematic", "error starts at 0.2 m and decays to zero",
                        "error(0) = 0.2 m and mean error over 150-200 s < 0.01 m",
                        f"error(0) = {e0:.3f} m, mean 150-200 s = {late1:.4f} m",
                        abs(e0 - 0.2) < 1e-9 and late1 < 0.01))
    m2 = _mean(r2, 50, 200)
    lo2, hi2 = _minmax(r2, 50, 200)
    claims.append(Claim("2 uncompensated", "error never vanishes, oscillates around 0.1 m",
                        "min error over 50-200 s > 0.02 m; mean within 0.05-0.15 m",
                        f"mean 50-200 s = {m2:.3f} m, range {lo2:.3f}-{hi2:.3f} m",
                        lo2 > 0.02 and 0.05 <= m2 <= 0.15))
    m3, m1 = _mean(r3, 50, 200), _mean(r1, 50, 200)
    claims.append(Claim("3 compensated", "close to case 1, small error from the noise",
                        "mean error over 50-200 s < 0.02 m and < 1/5 of case 2's",
                        f"mean 50-200 s = {m3:.4f} m (case 1: {m1:.4f} m)",
                        m3 < 0.02 and m3 < m2 / 5))
    before = _mean(r4, 50, 100)
    end = _mean(r4, 195, 200)
    claims.append(Claim("4 adaptive", "about 0.2 m before updating starts at t = 100 s",
                        "mean error over 50-100 s within 0.15-0.25 m",
                        f"mean 50-100 s = {before:.3f} m", 0.15 <= before <= 0.25))
    claims.append(Claim("4 adaptive", "below 0.05 m at t = 200 s",
                        "mean error over 195-200 s < 0.05 m",
                        f"mean 195-200 s = {end:.4f} m, error(200) = {r4.error[-1]:.4f} m",
                        end < 0.05))
    return claims


def format_claims(claims) -> str:
    """A Markdown table of the claims."""
    rows = ["| case | the paper says | criterion | measured | holds |",
            "|---|---|---|---|---|"]
    for c in claims:
        rows.append(f"| {c.case} | {c.paper} | {c.criterion} | {c.measured} | "
                    f"{'yes' if c.holds else 'NO'} |")
    return "\n".join(rows)


# ------------------------------------------------------------------ the paper's Fig. 11

#: The four cases of Fig. 11, by variant label.
FIG11_CASES = {
    "a": "(a) kinematic controller only",
    "b": "(b) compensation, θ̂ = 0.9 θ, no update",
    "c": "(c) adaptive from t = 0, θ̂(0) = 0.9 θ",
    "d": "(d) exact θ̂, no update",
}


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
    variants = (
        {"label": "a", "case": "uncompensated"},
        {"label": "b", "case": "compensated", "theta_hat_scale": 0.9},
        {"label": "c", "case": "adaptive", "adapt_from": 0.0, "theta_hat_scale": 0.9},
        {"label": "d", "case": "compensated", "theta_hat_scale": 1.0},
    )
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
            iae = np.array([float(r["iae"]) for r in done])
            mean = float(np.mean(iae))
            if len(iae) > 1:  # the spread over the seeds (a sensitive run's among it)
                error = float(np.std(iae, ddof=1) / np.sqrt(len(iae)))
            else:  # one seed: the run's largest estimate, relative
                error = float(done[0].get("numerical_error") or 0.0) * abs(mean)
            table[lab][k] = Fig11Point(mean, error, len(iae))
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


#: Error bars a difference must exceed to be told apart: 2 (about 95 %).
BARS = 2.0


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


def _pm(p: Fig11Point) -> str:
    return f"{p.iae:.3f} ± {p.error:.2g}"


def fig11_claims(metrics) -> list:
    """Compare Fig. 11 metrics (rows of :func:`read_metrics`, or the path of a
    metrics.csv) with what the paper says of its Fig. 11, judged with the error bars
    of :class:`Fig11Point`: a comparison holds, does not hold, or cannot be told apart
    where the difference is within :data:`BARS` error bars.

    Points none of whose runs completed are left out, and every claim they would have
    entered says how many were left out and where. Claims about one k (k = 1, 23)
    need that k in the sweep; otherwise they are reported as not covered.
    :return: list of :class:`Fig11Claim`
    """
    ks, tab, skipped = _fig11_rows(metrics)
    a, b, c, d = (tab[x] for x in "abcd")
    apart = "cannot be told apart within the error bars"

    def left_out(labels, at=None) -> str:
        pts = [(lab, k) for lab, k in skipped if lab in labels and (at is None or k == at)]
        if not pts:
            return ""
        where = ", ".join(f"{lab} at k = {k:g}" for lab, k in pts[:6])
        more = f", ... ({len(pts)} in all)" if len(pts) > 6 else ""
        return f"; {len(pts)} incomplete point(s) left out ({where}{more})"

    def claim(text, criterion, measured, holds):
        return Fig11Claim(text, criterion, measured, holds,
                          {True: "holds", False: "does not hold"}.get(holds, apart))

    out = []
    if 1.0 in a:
        p = a[1.0]
        above = 1 if p.iae - BARS * p.error > 8 else (-1 if p.iae + BARS * p.error < 8 else 0)
        out.append(claim("(a) IAE above 8 at k = 1", "IAE_a(k = 1) > 8",
                         f"IAE_a(1) = {_pm(p)}", _verdict([above])))
    elif ("a", 1.0) in skipped:
        out.append(Fig11Claim("(a) IAE above 8 at k = 1", "IAE_a(k = 1) > 8",
                              "the run at k = 1 did not complete" + left_out("a", 1.0), None))
    else:
        out.append(Fig11Claim("(a) IAE above 8 at k = 1", "IAE_a(k = 1) > 8",
                              "k = 1 not in the sweep", None))
    ka = min(a, key=lambda k: (a[k].iae, k))
    where = ""
    if ka == max(a):
        where = " (the largest k swept: still falling, no interior minimum)"
    elif ka == min(a):
        where = " (the smallest k swept)"
    # the gains whose IAE cannot be told apart from the minimum's
    flat = [k for k in sorted(a) if _below(a[ka], a[k]) == 0]
    at23 = f"; IAE_a(23) = {_pm(a[23.0])}" if 23.0 in a else ""
    covers = min(a) <= 23 <= max(a)
    swept = set(a) | {k for lab, k in skipped if lab == "a"}
    gap = (" (k = 23 is outside the sweep)" if not min(swept) <= 23 <= max(swept)
           else " (no complete point of (a) reaches k = 23)")
    if covers:
        inside = [18 <= k <= 28 for k in flat]
        value = abs(a[ka].iae - 1.24) <= 0.25 * 1.24 + BARS * a[ka].error
        holds = (all(inside) and value) if (all(inside) or not any(inside)) else None
        holds = False if not value else holds
    else:
        holds = None
    out.append(Fig11Claim(
        "(a) smallest IAE, 1.24, at k = 23",
        "minimum of (a) at 18 <= k <= 28, value within 1.24 ± 25 %",
        f"minimum {_pm(a[ka])} at k = {ka:g}{where}"
        + (f"; within the error bars of it: k = {_kl(flat)}" if len(flat) > 1 else "")
        + at23 + ("" if covers else gap) + left_out("a"),
        holds, {True: "holds", False: "does not hold"}.get(holds, apart if covers else "not covered")))
    for lab, series in (("b", b), ("c", c)):
        both = sorted(set(a) & set(series))  # the gains both cases have a complete point for
        if not both:
            out.append(Fig11Claim(f"({lab}) below (a) for every k",
                                  f"IAE_{lab}(k) < IAE_a(k) at every k swept",
                                  "no gain with complete points of both" + left_out(("a", lab)),
                                  None))
            continue
        signs = {k: _below(series[k], a[k]) for k in both}
        bad = [k for k in both if signs[k] < 0]
        even = [k for k in both if signs[k] == 0]
        ratio = max(series[k].iae / a[k].iae for k in both)
        out.append(claim(
            f"({lab}) below (a) for every k", f"IAE_{lab}(k) < IAE_a(k) at every k swept",
            f"below at {len(both) - len(bad) - len(even)} of {len(both)} k"
            + (f"; above at k = {_kl(bad)}" if bad else "")
            + (f"; {apart} at k = {_kl(even)}" if even else "")
            + f"; largest IAE_{lab}/IAE_a = {ratio:.3f}" + left_out(("a", lab)),
            _verdict(signs.values())))
    if not ks:
        out.append(Fig11Claim("(d) lowest for every k",
                              "IAE_d(k) < IAE of (a), (b) and (c) at every k swept",
                              "no gain with complete points of all four" + left_out("abcd"),
                              None))
        return out
    best = {k: min((a[k], b[k], c[k]), key=lambda p: p.iae) for k in ks}
    signs = {k: _below(d[k], best[k]) for k in ks}
    bad = [k for k in ks if signs[k] < 0]
    even = [k for k in ks if signs[k] == 0]
    worst = max(ks, key=lambda k: d[k].iae - best[k].iae)
    out.append(claim(
        "(d) lowest for every k", "IAE_d(k) < IAE of (a), (b) and (c) at every k swept",
        f"lowest at {len(ks) - len(bad) - len(even)} of {len(ks)} k"
        + (f"; not at k = {_kl(bad)} (at k = {worst:g}: d {_pm(d[worst])}, "
           f"best other {_pm(best[worst])})" if bad else "")
        + (f"; {apart} at k = {_kl(even)}" if even else "")
        + left_out("abcd"),
        _verdict(signs.values())))
    return out


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
