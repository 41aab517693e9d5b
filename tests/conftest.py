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
def once(tmp_path_factory):
    """``once(name, make)``: ``make(folder)`` run once a test session into a folder of
    that name, shared by the pytest-xdist workers; returns the folder. The first worker
    to ask makes it under a file lock, the others wait for it and read it; where it
    failed, they fail with its error instead of making it again."""
    import shutil

    from filelock import FileLock
    base = tmp_path_factory.getbasetemp()
    # under xdist each worker's folder lies in the session's; without, it is the session's
    root = base.parent if os.environ.get("PYTEST_XDIST_WORKER") else base

    def get(name: str, make):
        folder = root / f"once-{name}"
        failed = root / f"once-{name}.failed"
        with FileLock(str(folder) + ".lock"):
            if failed.is_file():
                pytest.fail(f"{name} failed earlier in this session:\n{failed.read_text()}")
            if not (folder / ".done").is_file():
                shutil.rmtree(folder, ignore_errors=True)
                folder.mkdir()
                try:
                    make(folder)
                except Exception as e:  # not a skip (the next to ask skips too)
                    failed.write_text(f"{type(e).__name__}: {e}"[-5000:])
                    raise
                (folder / ".done").touch()
        return folder
    return get


@pytest.fixture(scope="session")
def section5(once):
    """The README's first command's job, ``examples/paper_section5.py --out FOLDER``,
    run once a test session as a process of its own (:func:`once`): the paper's four
    200 s runs through the bdsim diagram. Returns the folder it wrote (``claims.md``,
    the figures, ``case<n>_<case>/`` with each run's ``timeseries.csv`` and
    ``summary.json``), beside which ``stdout.txt`` holds what it printed. The Section 5
    claims (tests/evals/test_section5.py) and the ``.bd`` files' 200 s reference
    (tests/diagrams/test_bdfiles.py) read it."""
    import subprocess
    import sys
    from pathlib import Path
    script = Path(__file__).resolve().parents[1] / "examples" / "paper_section5.py"

    def make(folder):
        r = subprocess.run([sys.executable, str(script), "--out", str(folder / "section5")],
                           cwd=folder, capture_output=True, text=True, timeout=3600,
                           env={**os.environ, "MPLBACKEND": "Agg"})
        assert r.returncode == 0, r.stdout[-3000:] + r.stderr[-3000:]
        (folder / "stdout.txt").write_text(r.stdout)
    return once("section5", make) / "section5"


@pytest.fixture(scope="session")
def section5_runs(section5):
    """{n: (columns, summary)}: the four runs :func:`section5` wrote, each run's
    ``timeseries.csv`` as {column: array} and its ``summary.json``."""
    import json

    import numpy as np
    runs = {}
    for n in (1, 2, 3, 4):
        [folder] = section5.glob(f"case{n}_*")
        data = np.genfromtxt(folder / "timeseries.csv", delimiter=",", names=True)
        runs[n] = ({k: data[k] for k in data.dtype.names},
                   json.loads((folder / "summary.json").read_text()))
    return runs


@pytest.fixture(scope="session")
def distributions(once):
    """``(sdist, wheel)`` of this checkout, built once a test session (two builds at
    once would share the checkout's build folders)."""
    from test_install import build_distributions
    folder = once("distributions", lambda f: build_distributions(f / "dist"))
    return next(folder.glob("dist/unidyn-*.tar.gz")), next(folder.glob("dist/unidyn-*.whl"))


@pytest.hookimpl(trylast=True)  # after -m and -k have chosen the session's tests
def pytest_collection_modifyitems(config, items):
    """The docs build, the session's longest task (minutes, on one worker), starts first:
    begun last, it would keep one worker busy while the others, done, wait for it (or
    for its result). And each notebook runs once a session: where the docs build is
    among the session's tests and can run (the docs extra installed), it runs every
    notebook as a reader's install does, with ggplot set first, and checks what
    tests/test_notebooks.py checks of a run; that module's runs are then deselected."""
    import importlib.util
    docs = [item for item in items  # tests/test_docs.py's build
            if "built" in item.fixturenames and item.nodeid.split("::")[0].endswith("test_docs.py")]
    if not docs:
        return
    items[:] = docs + [item for item in items if item not in docs]
    if any(importlib.util.find_spec(m) is None for m in ("sphinx", "myst_nb", "sphinxarg")):
        return
    runs = [item for item in items if item.nodeid.split("::")[0].endswith("test_notebooks.py")
            and getattr(item, "originalname", "") == "test_notebook_runs"]
    if runs:
        items[:] = [item for item in items if item not in runs]
        config.hook.pytest_deselected(items=runs)
