"""Every notebook in examples/ runs top to bottom in a fresh kernel without an error,
and uses only unidyn's public names.

The kernel is this test's own Python (``sys.executable``), whatever kernelspecs the
user has installed elsewhere: the test writes a kernelspec for it into a temporary
folder and hands nbclient a kernel manager that only looks there. Each notebook
runs with a temporary working folder (files it writes land there) and a 120 s
limit per cell. ``test_kernel_runs_this_python`` checks the kernel choice itself.

The runs are marked ``slow`` (about two minutes for all notebooks, a minute more
where the batch engine is not compiled yet): deselect with ``-m "not slow"``. The
public-name check reads the notebooks without running them (fast).

Each notebook runs once a session: where the docs build runs too (the ``docs`` extra
installed and tests/test_docs.py's build selected), the build runs every notebook,
from a regular install and with the same ggplot style set first, and checks the same
things of it; the runs here are then deselected (tests/conftest.py).
"""

import ast
import base64
import json
import os
import sys
import time
from pathlib import Path

import pytest

nbformat = pytest.importorskip("nbformat")
nbclient = pytest.importorskip("nbclient")
pytest.importorskip("ipykernel")

EXAMPLES = Path(__file__).resolve().parent.parent / "examples"
NOTEBOOKS = sorted(EXAMPLES.glob("*.ipynb"))
CELL_TIMEOUT = 120  # s
EXPECTED = ("01_model.ipynb", "02_fig2_diagram.ipynb", "03_adaptive.ipynb",
            "04_toolbox_dropin.ipynb", "05_identification.ipynb", "06_long_runs.ipynb",
            "07_linear_loop.ipynb")


@pytest.fixture(scope="module")
def kernel_spec_dir(tmp_path_factory):
    """A kernelspec named python3 that starts ipykernel with this interpreter."""
    root = tmp_path_factory.mktemp("kernels")
    spec = root / "python3"
    spec.mkdir()
    (spec / "kernel.json").write_text(json.dumps({
        "argv": [sys.executable, "-m", "ipykernel_launcher", "-f", "{connection_file}"],
        "display_name": "Python 3 (unidyn tests)",
        "language": "python",
    }))
    return root


def execute(nb, kernel_spec_dir, cwd, ipython_dir=None):
    """``nb`` run in a fresh kernel of ``kernel_spec_dir`` in the folder ``cwd``; with
    ``ipython_dir``, the kernel's IPython folder (its start-up files run first)."""
    from jupyter_client.kernelspec import KernelSpecManager
    from jupyter_client.manager import AsyncKernelManager
    from jupyter_core.utils import run_sync

    ksm = KernelSpecManager(kernel_dirs=[str(kernel_spec_dir)], ensure_native_kernel=False)
    km = AsyncKernelManager(kernel_name="python3", kernel_spec_manager=ksm)
    env = {"MPLBACKEND": "Agg", **({"IPYTHONDIR": str(ipython_dir)} if ipython_dir else {})}
    client = nbclient.NotebookClient(nb, km=km, kernel_name="python3", timeout=CELL_TIMEOUT,
                                     resources={"metadata": {"path": str(cwd)}})
    old = {k: os.environ.get(k) for k in env}
    os.environ.update(env)  # inherited by the kernel process
    try:
        return client.execute()
    finally:
        if km.has_kernel:  # nbclient shuts down only the kernels of managers it created
            run_sync(km.shutdown_kernel)(now=True)
        for k, v in old.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v


def test_examples_are_present():
    assert tuple(p.name for p in NOTEBOOKS) == EXPECTED


#: the parts a notebook may import from, by their public names (``__all__``) and their
#: public modules
SUBPACKAGES = ("model", "results", "blocks", "diagrams", "engine", "identification",
               "sweeps", "teaching", "datasets")


def _public_names():
    """unidyn's public names, and each subpackage's (its ``__all__`` and modules)."""
    import importlib
    import pkgutil

    import unidyn
    top = {n for n in dir(unidyn) if not n.startswith("_")} | {"__file__", "__version__"}
    exported = {}
    for s in SUBPACKAGES:
        mod = importlib.import_module(f"unidyn.{s}")
        exported[s] = set(getattr(mod, "__all__", ())) | {
            m.name for m in pkgutil.iter_modules(mod.__path__) if not m.name.startswith("_")}
    return top, exported


def _import_uses(node, top, exported, aliases):
    """What an import statement takes from unidyn that is not public; the subpackages
    it names are added to ``aliases`` (local name -> subpackage)."""
    bad = []
    if isinstance(node, ast.Import):
        for a in node.names:
            if a.name.startswith("unidyn."):
                sub = a.name.removeprefix("unidyn.")
                if sub not in SUBPACKAGES:
                    bad.append(f"import {a.name}")
                elif a.asname:
                    aliases[a.asname] = sub
        return bad
    if not (isinstance(node, ast.ImportFrom) and (node.module or "").startswith("unidyn")):
        return bad
    sub = node.module.removeprefix("unidyn").removeprefix(".")
    for a in node.names:
        if sub == "":
            if a.name not in top:
                bad.append(f"from unidyn import {a.name}")
            elif a.name in SUBPACKAGES:
                aliases[a.asname or a.name] = a.name
        elif sub not in SUBPACKAGES:
            bad.append(f"from {node.module} import {a.name}")
        elif a.name not in exported[sub]:
            bad.append(f"from {node.module} import {a.name} (not in its __all__)")
    return bad


def _attribute_uses(node, top, exported, aliases):
    """What an attribute (``unidyn.x``, ``sub.x``, ``..._private``) reaches that is not
    public."""
    bad = []
    if not isinstance(node, ast.Attribute):
        return bad
    if isinstance(node.value, ast.Name) and node.value.id in aliases:
        sub = aliases[node.value.id]
        if (sub is None and node.attr not in top) or \
                (sub is not None and node.attr not in exported[sub]):
            bad.append(f"{node.value.id}.{node.attr}")
    if node.attr.startswith("_") and not node.attr.startswith("__") \
            and "unidyn" in ast.unparse(node.value):
        bad.append(ast.unparse(node))
    return bad


def _public_uses(path):
    """Every way the notebook at ``path`` reaches into unidyn that is not a public
    name: ``[(cell index, description)]``."""
    top, exported = _public_names()
    bad = []
    aliases = {"unidyn": None}          # local name -> subpackage (None: unidyn itself)
    for i, cell in enumerate(nbformat.read(path, as_version=4).cells):
        if cell.cell_type != "code":
            continue
        # IPython's magics and shell escapes are not Python
        src = "\n".join("" if ln.lstrip().startswith(("%", "!")) else ln
                        for ln in cell.source.splitlines())
        tree = ast.parse(src)
        for node in ast.walk(tree):
            bad += [(i, what) for what in _import_uses(node, top, exported, aliases)]
        for node in ast.walk(tree):
            bad += [(i, what) for what in _attribute_uses(node, top, exported, aliases)]
    return bad


@pytest.mark.parametrize("path", NOTEBOOKS, ids=[p.stem for p in NOTEBOOKS])
def test_notebook_uses_only_public_names(path):
    """A notebook reaches unidyn through ``unidyn.NAME`` (the names ``dir(unidyn)``
    lists) and the public names and modules of its parts (``unidyn.results.figstyle``),
    never a private name."""
    assert _public_uses(path) == []


def test_public_name_check_catches_private_uses(tmp_path):
    nb = nbformat.v4.new_notebook(cells=[nbformat.v4.new_code_cell(src) for src in (
        "%matplotlib inline\nimport unidyn\nfrom unidyn import simulate_batch\n"
        "from unidyn.results import figstyle\nfrom unidyn.teaching import animation\n"
        "from unidyn import identification as ident\nident.identify\nunidyn.laws.PAPER_GAMMA",
        "from unidyn.batch import simulate_batch",
        "import unidyn.runner",
        "from unidyn import _jit",
        "unidyn.sweep.run_sweep",
        "from unidyn import identification as ident\nident.fit_output_error",
        "unidyn.model._helper",
        "from unidyn.diagrams import build_fig2, _private",
    )])
    path = tmp_path / "x.ipynb"
    nbformat.write(nb, path)
    assert sorted({i for i, _ in _public_uses(path)}) == [1, 2, 3, 4, 5, 6, 7]


@pytest.mark.slow
def test_kernel_runs_this_python(kernel_spec_dir, tmp_path):
    nb = nbformat.v4.new_notebook(cells=[nbformat.v4.new_code_cell(
        "import os, sys, unidyn\nprint(sys.executable)\nprint(os.getcwd())")])
    nb = execute(nb, kernel_spec_dir, tmp_path)
    text = "".join(o.get("text", "") for o in nb.cells[0].outputs).split("\n")
    assert os.path.realpath(text[0]) == os.path.realpath(sys.executable)
    assert os.path.realpath(text[1]) == os.path.realpath(tmp_path)


#: ggplot's grey axes background (229, 229, 229), which must not appear in a figure
GGPLOT_GREY = 229


def ggplot_first(folder: Path) -> Path:
    """An IPython folder in ``folder`` whose kernels start with matplotlib's ggplot style
    set, as roboticstoolbox's plotting module sets it for a whole process when loaded:
    the notebooks' figures must keep unidyn's style all the same (here and in the docs
    build, tests/test_docs.py)."""
    startup = folder / "ipython" / "profile_default" / "startup"
    startup.mkdir(parents=True)
    (startup / "00-ggplot.py").write_text("import matplotlib.pyplot as plt\nplt.style.use('ggplot')\n")
    return folder / "ipython"


def assert_no_ggplot_grey(pngs, what):
    """No PNG of ``pngs`` (bytes) has more than 5 % of its pixels in ggplot's axes grey."""
    import io

    import matplotlib.image as mpimg
    import numpy as np
    assert pngs, f"{what}: no figure shown"
    grey = []
    for png in pngs:
        rgb = np.round(mpimg.imread(io.BytesIO(png))[..., :3] * 255)
        grey.append(round(float(np.all(np.abs(rgb - GGPLOT_GREY) <= 1, axis=-1).mean()), 3))
    assert max(grey) < 0.05, (what, grey)


@pytest.mark.slow
@pytest.mark.parametrize("path", NOTEBOOKS, ids=[p.stem for p in NOTEBOOKS])
def test_notebook_runs(path, kernel_spec_dir, tmp_path):
    """Each notebook runs; its figures are drawn in unidyn's style even with another
    style set for the whole kernel first (as roboticstoolbox's plotting module does
    when loaded): no ggplot-grey axes in any figure."""
    nb = nbformat.read(path, as_version=4)
    start = time.perf_counter()
    # a failing cell raises nbclient's CellExecutionError with the cell and its traceback
    nb = execute(nb, kernel_spec_dir, tmp_path, ipython_dir=ggplot_first(tmp_path / "kernel"))
    elapsed = time.perf_counter() - start
    errors = [o for cell in nb.cells if cell.cell_type == "code"
              for o in cell.get("outputs", []) if o.get("output_type") == "error"]
    assert not errors, errors
    pngs = [base64.b64decode(o["data"]["image/png"]) for cell in nb.cells if cell.cell_type == "code"
            for o in cell.get("outputs", []) if "image/png" in o.get("data", {})]
    assert_no_ggplot_grey(pngs, path.name)
    print(f"{path.name}: {elapsed:.1f} s")
