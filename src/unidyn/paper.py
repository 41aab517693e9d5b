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
from ._validate import DEFAULT_ATOL, DEFAULT_RTOL
from .sweeps.sweep_files import read_metrics
from .model.noise import PAPER_NOISE
from .sweeps.sweep import Sweep

__all__ = ["Claim", "section5_claims", "format_claims", "paper_fig11", "fig11_claims",
           "format_fig11_claims", "fig11_table", "Fig11Claim", "FIG11_CASES", "plot_fig11"]


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


def paper_fig11(T: float = 250.0, gains=None, noise=PAPER_NOISE, *, base=None,
                rtol: float = DEFAULT_RTOL, atol: float = DEFAULT_ATOL) -> Sweep:
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
    return Sweep(base=b, grid={"kxy": gains}, variants=variants,
                 name="Fig. 11 (IAE against kx = ky)", rtol=rtol, atol=atol)


@dataclass(frozen=True)
class Fig11Claim:
    """One thing the paper says of Fig. 11, the criterion used, the measured numbers,
    and whether it holds (``None``: the sweep does not cover it)."""

    claim: str
    criterion: str
    measured: str
    holds: bool | None


def _fig11_rows(metrics) -> tuple[list, dict, list]:
    """(ks, table, skipped): the gains every case has a complete point for (perhaps
    none), IAE by case and gain, and the (case, gain) of every point that did not
    complete (left out)."""
    rows = read_metrics(metrics) if isinstance(metrics, (str, os.PathLike)) else list(metrics)
    table = {lab: {} for lab in FIG11_CASES}
    skipped = []
    for r in rows:
        if "variant" not in r or "kxy" not in r:
            raise ValidationError("fig11_claims needs rows with 'variant' and 'kxy' "
                                  "(the metrics of paper_fig11())")
        if r["variant"] in table:
            if not r.get("complete", True) or r.get("iae") is None:
                skipped.append((r["variant"], float(r["kxy"])))
                continue
            table[r["variant"]][float(r["kxy"])] = float(r["iae"])
    missing = [lab for lab, v in table.items() if not v]
    if missing:
        raise ValidationError(f"fig11_claims: no complete rows for case(s) {', '.join(missing)}"
                              + (f" ({len(skipped)} incomplete point(s) left out)"
                                 if skipped else ""))
    ks = sorted(set.intersection(*(set(v) for v in table.values())))
    return ks, table, sorted(skipped)


def fig11_table(metrics) -> tuple[list, dict]:
    """``(ks, table)``: the gains kx = ky every case has a complete point for, and the IAE
    by case label (:data:`FIG11_CASES`) and gain; points that did not complete are left
    out. ``metrics``: rows of :func:`~unidyn.sweeps.sweep_files.read_metrics` or a metrics.csv path."""
    ks, table, _ = _fig11_rows(metrics)
    return ks, table


def _kl(ks, limit=6) -> str:
    s = ", ".join(f"{k:g}" for k in ks[:limit])
    return s + (f", ... ({len(ks)} in all)" if len(ks) > limit else "")


def fig11_claims(metrics) -> list:
    """Compare Fig. 11 metrics (rows of :func:`read_metrics`, or the path of a
    metrics.csv) with what the paper says of its Fig. 11.

    Points that did not complete have no IAE: they are left out, and every claim
    they would have entered says how many were left out and where. Claims about one
    k (k = 1, 23) need that k in the sweep; otherwise they are reported with
    ``holds = None``.
    :return: list of :class:`Fig11Claim`
    """
    ks, tab, skipped = _fig11_rows(metrics)
    a, b, c, d = (tab[x] for x in "abcd")

    def left_out(labels, at=None) -> str:
        pts = [(lab, k) for lab, k in skipped if lab in labels and (at is None or k == at)]
        if not pts:
            return ""
        where = ", ".join(f"{lab} at k = {k:g}" for lab, k in pts[:6])
        more = f", ... ({len(pts)} in all)" if len(pts) > 6 else ""
        return f"; {len(pts)} incomplete point(s) left out ({where}{more})"

    out = []
    if 1.0 in a:
        out.append(Fig11Claim("(a) IAE above 8 at k = 1", "IAE_a(k = 1) > 8",
                              f"IAE_a(1) = {a[1.0]:.3f}", a[1.0] > 8))
    elif ("a", 1.0) in skipped:
        out.append(Fig11Claim("(a) IAE above 8 at k = 1", "IAE_a(k = 1) > 8",
                              "the run at k = 1 did not complete" + left_out("a", 1.0), None))
    else:
        out.append(Fig11Claim("(a) IAE above 8 at k = 1", "IAE_a(k = 1) > 8",
                              "k = 1 not in the sweep", None))
    ka = min(a, key=lambda k: (a[k], k))
    where = ""
    if ka == max(a):
        where = " (the largest k swept: still falling, no interior minimum)"
    elif ka == min(a):
        where = " (the smallest k swept)"
    at23 = f"; IAE_a(23) = {a[23.0]:.3f}" if 23.0 in a else ""
    covers = min(a) <= 23 <= max(a)
    swept = set(a) | {k for lab, k in skipped if lab == "a"}
    gap = (" (k = 23 is outside the sweep)" if not min(swept) <= 23 <= max(swept)
           else " (no complete point of (a) reaches k = 23)")
    out.append(Fig11Claim(
        "(a) smallest IAE, 1.24, at k = 23",
        "minimum of (a) at 18 <= k <= 28, value within 1.24 ± 25 %",
        f"minimum {a[ka]:.3f} at k = {ka:g}{where}{at23}"
        + ("" if covers else gap) + left_out("a"),
        (18 <= ka <= 28 and abs(a[ka] - 1.24) <= 0.25 * 1.24) if covers else None))
    for lab, series in (("b", b), ("c", c)):
        both = sorted(set(a) & set(series))  # the gains both cases have a complete point for
        if not both:
            out.append(Fig11Claim(f"({lab}) below (a) for every k",
                                  f"IAE_{lab}(k) < IAE_a(k) at every k swept",
                                  "no gain with complete points of both" + left_out(("a", lab)),
                                  None))
            continue
        bad = [k for k in both if not series[k] < a[k]]
        ratio = max(series[k] / a[k] for k in both)
        out.append(Fig11Claim(
            f"({lab}) below (a) for every k", f"IAE_{lab}(k) < IAE_a(k) at every k swept",
            f"below at {len(both) - len(bad)} of {len(both)} k"
            + (f"; not at k = {_kl(bad)}" if bad else "")
            + f"; largest IAE_{lab}/IAE_a = {ratio:.3f}" + left_out(("a", lab)),
            not bad))
    if not ks:
        out.append(Fig11Claim("(d) lowest for every k",
                              "IAE_d(k) < IAE of (a), (b) and (c) at every k swept",
                              "no gain with complete points of all four" + left_out("abcd"),
                              None))
        return out
    bad = [k for k in ks if not d[k] < min(a[k], b[k], c[k])]
    worst = max(ks, key=lambda k: d[k] - min(a[k], b[k], c[k]))
    out.append(Fig11Claim(
        "(d) lowest for every k", "IAE_d(k) < IAE of (a), (b) and (c) at every k swept",
        f"lowest at {len(ks) - len(bad)} of {len(ks)} k"
        + (f"; not at k = {_kl(bad)} (at k = {worst:g}: d {d[worst]:.3f}, "
           f"best other {min(a[worst], b[worst], c[worst]):.3f})" if bad else "")
        + left_out("abcd"),
        not bad))
    return out


def format_fig11_claims(claims, title: str | None = None) -> str:
    """A Markdown table of :func:`fig11_claims`."""
    rows = [] if title is None else [title, ""]
    rows += ["| the paper says | criterion | measured | holds |", "|---|---|---|---|"]
    for c in claims:
        holds = "n/a" if c.holds is None else ("yes" if c.holds else "NO")
        rows.append(f"| {c.claim} | {c.criterion} | {c.measured} | {holds} |")
    return "\n".join(rows)


def plot_fig11(metrics, path, title: str | None = None):
    """IAE against k = kx = ky for the four cases, log y with plain tick labels (1, 2,
    5, 10, 20), as the paper's Fig. 11. In unidyn's figure style (:mod:`unidyn.results.figstyle`).
    Each case is drawn over its complete points; a note names the points left out
    (their runs' messages in ``metrics.csv`` say why)."""
    import matplotlib.pyplot as plt  # here: matplotlib is optional and slow to import

    _, tab, skipped = _fig11_rows(metrics)
    with figstyle.style():
        fig, ax = plt.subplots(figsize=figstyle.size(1, 0.95))
        for (lab, desc), mk in zip(FIG11_CASES.items(), ("o", "s", "^", "D")):
            ks = sorted(tab[lab])  # each case over its complete points
            ys = [tab[lab][k] if math.isfinite(tab[lab][k]) else math.nan for k in ks]
            ax.plot(ks, ys, "-", marker=mk, ms=2.5, markevery=max(1, len(ks) // 12),
                    label=desc)
        if skipped:  # where a curve ends early, say why
            gone = {lab: [k for c, k in skipped if c == lab] for lab in FIG11_CASES}
            cases = ", ".join(f"({lab}) {len(ks)} at k ≥ {min(ks):g}"
                              for lab, ks in gone.items() if ks)
            ax.plot([], [], " ", label=f"points not drawn (incomplete runs):\n{cases}")
        figstyle.plain_log_axis(ax, "y")
        ax.set_xlabel("$k_x = k_y$ (1/s)")
        ax.set_ylabel("IAE (m·s)")
        ax.set_title(title or "IAE against the kinematic controller's gain (Fig. 11)")
        ax.grid(True, which="major")
        ax.grid(True, which="minor", axis="y", alpha=0.2)
        figstyle.legend(ax, outside="below")
        return figstyle.save(fig, path)
