"""``unidyn robots``: list the preset robots."""

from __future__ import annotations

from ..model import robots


def unidyn_robots(args) -> int:
    """``unidyn robots``: the preset robots, theta1..theta6 and their source."""
    names = robots.names()
    w = max(len(n) for n in names)
    head = f"{'name':{w}s} " + " ".join(f"{f'theta{i}':>10s}" for i in range(1, 7)) + "  source"
    print(head)
    for n in names:
        r = robots.get(n)
        print(f"{n:{w}s} " + " ".join(f"{v:10.6g}" for v in r.theta) + f"  {r.source}")
    return 0
