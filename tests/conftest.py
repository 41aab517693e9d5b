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


@pytest.fixture(scope="session")
def paper_run(tmp_path_factory):
    """``paper_run(n)`` = ``unidyn.simulate(Scenario.paper(n))``: one of the paper's four
    200 s runs (Section 5), simulated once per test session and shared by the pytest-xdist
    workers: the first worker to ask runs it under a lock and writes it next to the
    session's temporary folders; the others read it. The Section 5 claims and the .bd files'
    200 s reference both use it."""
    import pickle

    from filelock import FileLock
    root = tmp_path_factory.getbasetemp().parent  # shared by the workers of one session
    done = {}

    def get(n: int):
        if n not in done:
            path = root / f"paper_run_{n}.pickle"
            with FileLock(str(path) + ".lock"):
                if path.is_file():
                    done[n] = pickle.loads(path.read_bytes())
                else:
                    done[n] = unidyn.simulate(unidyn.Scenario.paper(n), progress=False)
                    path.write_bytes(pickle.dumps(done[n]))
        return done[n]
    return get
