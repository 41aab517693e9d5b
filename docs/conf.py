"""Sphinx configuration of unidyn's documentation.

Build it with

    python -m sphinx -W -b html docs docs/_build/html

At the start of a build, :mod:`unidyn_docs` (docs/_ext) copies the notebooks of
examples/ into docs/notebooks/ (they are executed when the site is built: see
``nb_execution_mode``) and draws the figures of docs/_generated/ with the code they
document.
"""

import sys
from pathlib import Path

DOCS = Path(__file__).resolve().parent
ROOT = DOCS.parent
sys.path.insert(0, str(DOCS / "_ext"))
# the checkout's package, also when it is not installed (an editable install finds it anyway)
sys.path.insert(0, str(ROOT / "src"))

import unidyn  # noqa: E402

project = "unidyn"
author = "the unidyn authors"
copyright = "the unidyn authors, MIT licence"
release = version = unidyn.__version__

extensions = [
    "sphinx.ext.autodoc",
    "sphinx.ext.mathjax",
    "sphinx-mathjax-offline",   # MathJax copied into the site, so the pages read offline
    "sphinxarg.ext",      # the command line, from its argparse parser
    "myst_nb",            # Markdown pages and the notebooks
    "unidyn_docs",        # the :blockname: role, the scenario-field table, build-time figures
]

source_suffix = {".rst": "restructuredtext", ".md": "myst-nb", ".ipynb": "myst-nb"}
root_doc = "index"
exclude_patterns = ["_build", "README.md", "figures/*.py", "**.ipynb_checkpoints"]
templates_path = []

# -- MyST and notebooks -------------------------------------------------------------
myst_enable_extensions = ["dollarmath", "colon_fence", "deflist"]
myst_heading_anchors = 3
# The notebooks of examples/ are stored without outputs. The build runs every one of
# them, top to bottom in a fresh kernel in a temporary folder, so each page shows what
# its notebook prints and draws with the code of this checkout: an output cannot go
# stale, and a notebook that fails fails the build. All seven take about a minute and a
# half; where the batch engine's numba compilation is not cached yet (a fresh install, or
# its sources changed), the first notebook that needs it compiles it, which adds some
# seconds once. The test suite runs them through this build (tests/test_docs.py), or
# through tests/test_notebooks.py where the docs extra is not installed.
nb_execution_mode = "force"
nb_execution_in_temp = True
nb_execution_timeout = 180   # s per cell: the longest, compiling on a slow machine, stays far below
nb_execution_raise_on_error = True
nb_execution_show_tb = True  # a notebook that fails shows its traceback in the build's log

# -- autodoc ------------------------------------------------------------------------
autodoc_member_order = "bysource"
autodoc_typehints = "none"   # the docstrings give types with units; signatures keep defaults
autodoc_default_options = {"members": True, "show-inheritance": False}
autoclass_content = "both"
# Cross-references are not checked (nitpicky off): type hints name numpy, bdsim and
# python-control types that this site does not document.
nitpicky = False

# -- HTML ---------------------------------------------------------------------------
html_theme = "furo"
html_title = f"unidyn {release}"
html_static_path = []
html_show_sourcelink = False
