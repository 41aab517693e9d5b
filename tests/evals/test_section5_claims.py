"""Section 5's claims (unidyn.paper.section5) judged on distance errors made to hold or
to miss each one, and their words made from the paper's numbers."""

from types import SimpleNamespace

import numpy as np
import pytest

from unidyn.paper import format_claims, section5_claims
from unidyn.paper.section5 import SECTION5_CLAIMS, SECTION5_PAPER

T, TS = 200.0, 0.1


def _run(error):
    t = np.arange(round(T / TS) + 1) * TS
    return SimpleNamespace(t=t, error=np.asarray(error(t), dtype=float))


#: Errors shaped as the paper describes its four simulations: 0.2 m decaying (1);
#: oscillating around 0.1 m (2); small (3); 0.2 m until updating starts at 100 s,
#: then decaying (4).
GOOD = {
    1: lambda t: 0.2 * np.exp(-t / 10),
    2: lambda t: 0.1 + 0.05 * np.sin(t),
    3: lambda t: np.full_like(t, 0.005),
    4: lambda t: np.where(t < 100, 0.2, 0.2 * np.exp(-(t - 100) / 10)),
}


def _claims(**changes):
    errors = {**GOOD, **{int(k[1:]): v for k, v in changes.items()}}
    return section5_claims(*(_run(errors[n]) for n in (1, 2, 3, 4)))


def test_every_claim_holds_on_errors_shaped_as_the_paper_says():
    claims = _claims()
    assert [c.holds for c in claims] == [True] * 5, format_claims(claims)
    assert [c.case for c in claims] == ["1 kinematic", "2 uncompensated", "3 compensated",
                                        "4 adaptive", "4 adaptive"]


@pytest.mark.parametrize("change, fails", [
    # the error starts 0.1 m off the paper's 0.2 m
    ({"e1": lambda t: 0.3 * np.exp(-t / 10)}, 0),
    # case 2 oscillates around 0.17 m, beyond "around 0.1 m"
    ({"e2": lambda t: 0.17 + 0.05 * np.sin(t)}, 1),
    # case 3 below twice the noise (0.02 m) but above a fifth of case 2's mean (0.1 m)
    ({"e3": lambda t: np.full_like(t, 0.0199), "e2": lambda t: 0.09 + 0.04 * np.sin(t)}, 2),
    # case 4 still 0.06 m at the end
    ({"e4": lambda t: np.where(t < 100, 0.2, 0.06)}, 4),
])
def test_a_claim_missed_fails_alone(change, fails):
    holds = [c.holds for c in _claims(**change)]
    assert holds == [i != fails for i in range(5)]


def test_case_3_is_judged_against_a_fifth_of_case_2():
    """0.015 m holds against case 2's 0.1 m (a fifth: 0.02 m), fails against 0.07 m
    (0.014 m)."""
    small = {"e3": lambda t: np.full_like(t, 0.015)}
    assert _claims(**small)[2].holds
    assert not _claims(**small, e2=lambda t: np.full_like(t, 0.07))[2].holds


def test_the_words_carry_the_papers_numbers():
    """Each number of SECTION5_PAPER is in the claim that speaks of it and in its
    criterion: the prose and the test come from one entry."""
    claims = _claims()
    for c, key in zip(claims, ("start", "uncompensated", None, "adaptive before",
                               "adaptive end")):
        if key is not None:
            v = f"{SECTION5_PAPER[key]:g}"
            assert v in c.paper, (v, c.paper)
    assert "= 0.2 m" in claims[0].criterion and "< 0.05 m" in claims[4].criterion
    assert "within 0.05-0.15 m" in claims[1].criterion
    assert "within 0.15-0.25 m" in claims[3].criterion
    assert len(SECTION5_CLAIMS) == len(claims)
