"""Sphinx configuration of unidyn's documentation.

Build it with

    python -m sphinx -W -b html docs docs/_build/html

At the start of a build, :mod:`unidyn_docs` (docs/_ext) copies the notebooks of
examples/ into docs/notebooks/ (they are rendered, not executed: see
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
# The notebooks of examples/ are stored without outputs, and the test suite executes
# them all (tests/test_notebooks.py). The build executes only the two that take
# seconds, in a temporary folder; the others take minutes and are rendered as stored
# (code and text, no outputs).
EXECUTED_NOTEBOOKS = ("01_model", "04_toolbox_dropin")
nb_execution_mode = "force"
nb_execution_in_temp = True
nb_execution_timeout = 120
nb_execution_raise_on_error = True
nb_execution_excludepatterns = [f"notebooks/{p.stem}.ipynb"
                                for p in sorted((ROOT / "examples").glob("*.ipynb"))
                                if p.stem not in EXECUTED_NOTEBOOKS]

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
