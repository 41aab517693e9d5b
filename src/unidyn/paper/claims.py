"""What every check of the paper shares: a claim and its verdict, and how far apart two
measured numbers must be to be told apart."""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["Claim", "BARS", "VERDICTS"]

#: Error bars a difference must exceed to be told apart: 2 (about 95 %): a mean's
#: standard error over seeds, or a run's numerical error estimate where there is one seed.
BARS = 2.0

#: The words of a verdict: the claim holds, does not hold, or was not compared.
VERDICTS = {True: "holds", False: "does not hold", None: "not compared"}


@dataclass(frozen=True)
class Claim:
    """One thing the paper says, checked: where it is said (``case``: a simulation of
    Section 5, or what the experiment measured), what the paper says (``paper``), the
    criterion it is judged by, the measured numbers, and whether it holds (``None``:
    not compared)."""

    case: str
    paper: str
    criterion: str
    measured: str
    holds: bool | None
