"""Shared fixtures.

Importing unidyn first registers its blocks with bdsim (for a checkout used without
installing it). pyproject.toml turns every warning into an error; the expected ones
are asserted with ``pytest.warns``."""

import os

os.environ.setdefault("MPLBACKEND", "Agg")

import pytest  # noqa: E402

import unidyn  # noqa: E402,F401

@pytest.fixture
def sim():
    """A headless, quiet bdsim simulator that ignores pytest's command line."""
    from unidyn.diagrams import new_simulator
    return new_simulator()
