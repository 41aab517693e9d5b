"""The paper's Section 5 claims, measured on simulation results.

:func:`section5_claims` takes the four results of ``Scenario.paper(1..4)`` and
returns, for each claim the paper makes about them, the measured number and
whether it holds by the stated criterion.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["Claim", "section5_claims", "format_claims"]


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
