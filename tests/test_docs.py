"""The documentation site: its guides' code runs, its reference lists everything
public, and ``python -m sphinx -W`` builds it.

- The guides' code is run by tests/test_guides.py, from an empty folder.
- The reference's sources name every name of ``unidyn.__all__`` (and every name
  ``import unidyn`` makes available), every block class of unidyn.blocks and every
  notebook of examples/ (fast: no build).
- The site builds with warnings as errors, from the command the README and .ci/run
  name, into a temporary folder, from a regular install (a wheel of this checkout in a
  fresh venv) and a folder outside the checkout that holds only the site's sources; the
  built pages hold every public name, every block under its bdsim name, every
  subcommand of ``unidyn`` and every notebook, run by the build, with its figures and
  printed output, no error box, and MathJax served with the site (slow tier; needs
  the ``docs`` extra). The build's kernels start with ggplot set, and no notebook
  figure may show it; the build is then the session's run of the notebooks
  (tests/test_notebooks.py).
"""

import html
import inspect
import os
import re
import shutil
import subprocess
from pathlib import Path

import pytest

import test_install as install
import test_readme as readme

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
GUIDES = sorted((DOCS / "guides").glob("*.md"))
NOTEBOOKS = sorted((ROOT / "examples").glob("*.ipynb"))


def _public_names():
    import unidyn
    names = set(unidyn.__all__) | {n for n in unidyn._LAZY if not n.startswith("_")}
    return sorted(names)


def _block_classes():
    """Every bdsim block class defined in unidyn.blocks (robots, controllers, sources)."""
    from bdsim.components import Block

    from unidyn.blocks import controllers, sources
    from unidyn.blocks import unicycles as robots
    found = {}
    for mod in (robots, controllers, sources):
        for name, obj in vars(mod).items():
            if (inspect.isclass(obj) and issubclass(obj, Block) and obj.__module__ == mod.__name__
                    and not name.startswith("_")):
                found[name] = obj
    return found


def _subcommands():
    from unidyn.cli import parser
    for action in parser()._actions:
        if isinstance(getattr(action, "choices", None), dict):   # the subcommands
            return sorted(action.choices)
    return []


# --------------------------------------------------------- the reference, unbuilt

def _sources():
    return "\n".join(p.read_text(encoding="utf-8")
                     for p in sorted(DOCS.rglob("*")) if p.suffix in (".rst", ".md")
                     and "_build" not in p.parts)


def test_reference_sources_name_every_public_name():
    text = (DOCS / "reference" / "api.rst").read_text(encoding="utf-8")
    for name in _public_names():
        # api.rst documents inside the unidyn module: a name there is unidyn.NAME
        assert re.search(rf"(::|:mod:`) *(unidyn\.)?{re.escape(name)}\b", text) or \
            re.search(rf"automodule:: unidyn\.{re.escape(name)}\b", _sources()), \
            f"unidyn.{name} is not in the reference"


def test_reference_sources_name_every_block():
    text = (DOCS / "reference" / "blocks.rst").read_text(encoding="utf-8")
    for name, cls in _block_classes().items():
        assert re.search(rf"autoclass:: unidyn\.blocks\.(\w+\.)?{name}\n", text), \
            f"block {name} ({name.upper()}) is not in docs/reference/blocks.rst"
        assert f":blockname:`{name.upper()}`" in (cls.__doc__ or ""), \
            f"{name}'s docstring does not name the block as bdsim does (:blockname:)"


def test_cli_reference_is_generated_from_the_parser():
    text = (DOCS / "reference" / "cli.rst").read_text(encoding="utf-8")
    assert ".. argparse::" in text and ":func: cli_parser" in text


# ------------------------------------------------------------------------ the build

#: what the site is built from besides the installed package: its sources, the examples
#: it shows and the notebooks it runs, and the changelog it includes
SITE_SOURCES = ("docs", "examples", "CHANGELOG.md")


def _copy_site_sources(dest: Path) -> None:
    for pattern in SITE_SOURCES:
        for src in ROOT.glob(pattern):
            target = dest / src.relative_to(ROOT)
            if src.is_dir():
                # what a build made (docs/notebooks/*.ipynb: copies of the examples') left out
                built = ("_build", "_generated", "*.ipynb") if src == DOCS else ()
                shutil.copytree(src, target, ignore=shutil.ignore_patterns(
                    *built, "__pycache__", ".ipynb_checkpoints"))
            else:
                target.parent.mkdir(parents=True, exist_ok=True)
                shutil.copyfile(src, target)


@pytest.fixture(scope="module")
def built(once, distributions):
    """The README's docs build, run as a reader of a release would: unidyn installed from
    a wheel built from this checkout into a fresh venv (as tests/test_install.py installs
    it, offline), the build started in a folder outside the checkout that holds only the
    site's sources. The notebooks it runs see the installed package and nothing of the
    checkout, so a page that reads a checkout's file fails the build. Built once a
    session (the tests below may run in different workers)."""
    pytest.importorskip("sphinx", reason="the docs extra: pip install -e '.[docs]'")
    pytest.importorskip("myst_nb", reason="the docs extra: pip install -e '.[docs]'")
    pytest.importorskip("sphinxarg", reason="the docs extra: pip install -e '.[docs]'")
    return once("docs-build", lambda tmp: _build_site(tmp, distributions[1])) / "html"


def _build_site(tmp: Path, wheel: Path) -> None:
    """The site built into ``tmp / "html"`` from ``wheel`` installed in a fresh venv."""
    python = install._fresh_venv(tmp / "venv")
    install._pip(python, wheel)
    site = Path(install._in_venv(python, "import sysconfig; print(sysconfig.get_paths()['purelib'])")
                .stdout.strip())
    r = install._in_venv(python, "import unidyn; print(unidyn.__file__)")
    assert Path(r.stdout.strip()).is_relative_to(site), r.stdout + r.stderr
    sources = tmp / "sources"
    _copy_site_sources(sources)
    args = readme.DOCS_BUILD[:-1] + [str(tmp / "html")]   # the README's command, into a temporary folder
    # numba's cache is keyed on the compiled functions' files, which this install has
    # anew: the batch engine compiles once for the build, into a folder of the build's own
    env = {k: v for k, v in os.environ.items() if k not in ("BDSIMPATH", "PYTHONPATH")}
    from test_notebooks import ggplot_first
    env.update(MPLBACKEND="Agg", NUMBA_CACHE_DIR=str(tmp / "numba"), IPYTHONDIR=str(ggplot_first(tmp)))
    r = subprocess.run([str(python), *args], cwd=sources, capture_output=True, text=True,
                       env=env, timeout=900)
    assert r.returncode == 0, (r.stdout[-3000:] + "\n" + r.stderr[-5000:])


def _text(path):
    return html.unescape(path.read_text(encoding="utf-8"))


@pytest.mark.slow
def test_built_reference_holds_every_public_name(built):
    pages = _text(built / "reference" / "api.html") + "".join(
        _text(p) for p in (built / "reference" / "modules").glob("*.html"))
    for name in _public_names():
        assert (f'id="unidyn.{name}"' in pages or f'id="module-unidyn.{name}"' in pages), \
            f"unidyn.{name} has no entry in the built reference"


@pytest.mark.slow
def test_built_reference_holds_every_block(built):
    page = _text(built / "reference" / "blocks.html")
    for name, cls in _block_classes().items():
        assert re.search(rf'id="{re.escape(cls.__module__)}\.{name}"|id="unidyn\.blocks\.{name}"',
                         page), f"block class {name} is not in the built blocks page"
        assert f'id="block-{name.lower()}"' in page and name.upper() in page
        assert "Port type" in page


@pytest.mark.slow
def test_built_cli_reference_holds_every_subcommand(built):
    page = _text(built / "reference" / "cli.html")
    subs = _subcommands()
    assert {"run", "sweep", "robots", "properties", "identify"} <= set(subs)
    for sub in subs:
        assert re.search(rf"<h\d[^>]*>\s*{sub}\b", page), f"unidyn {sub} is not in the built CLI page"


@pytest.mark.slow
def test_no_built_page_shows_an_error_box(built):
    """docutils reports some problems inside the page (a red "system message" box)
    instead of as a warning that -W turns into a failure: no page may hold one."""
    for page in built.rglob("*.html"):
        text = _text(page)
        assert "system-message" not in text, f"{page.relative_to(built)} shows an error box"


@pytest.mark.slow
def test_built_site_holds_every_notebook_and_guide(built):
    assert NOTEBOOKS
    index = _text(built / "notebooks" / "index.html")
    for nb in NOTEBOOKS:
        assert (built / "notebooks" / f"{nb.stem}.html").is_file(), f"{nb.name} is not in the site"
        assert f"{nb.stem}.html" in index
    # the build runs every notebook: each page shows the figures it draws (myst-nb
    # writes them to _images/ under the hash of their content) and the text it prints
    for nb in NOTEBOOKS:
        page = _text(built / "notebooks" / f"{nb.stem}.html")
        figures = re.findall(r'<img [^>]*src="\.\./(_images/[0-9a-f]{64}\.(?:png|gif|svg))"', page)
        assert figures, f"{nb.name}: its page shows no figure (was it executed?)"
        for f in figures:
            assert (built / f).stat().st_size > 5000, f"{nb.name}: {f} is empty"
        assert 'class="output stream' in page, f"{nb.name}: its page shows nothing printed"
        assert page.count('class="cell_output') >= 2, f"{nb.name}: its page shows almost no output"
    for g in GUIDES:
        assert (built / "guides" / f"{g.stem}.html").is_file()
    assert (built / "_generated" / "step_responses.png").is_file() or \
        (built / "_images" / "step_responses.png").is_file()


@pytest.mark.slow
def test_notebook_figures_keep_unidyn_style(built):
    """The build's kernels start with ggplot set (test_notebooks.ggplot_first): no figure
    a notebook draws shows ggplot's grey axes."""
    from test_notebooks import assert_no_ggplot_grey
    for nb in NOTEBOOKS:
        page = _text(built / "notebooks" / f"{nb.stem}.html")
        pngs = sorted(set(re.findall(r'src="\.\./(_images/[0-9a-f]{64}\.png)"', page)))
        assert_no_ggplot_grey([(built / f).read_bytes() for f in pngs], nb.name)


@pytest.mark.slow
def test_the_site_serves_its_own_mathjax(built):
    """The equations render offline: every page with mathematics loads MathJax from the
    site's own files, none from the network."""
    with_math = 0
    for page in built.rglob("*.html"):
        text = page.read_text(encoding="utf-8")
        scripts = [s for s in re.findall(r'<script[^>]*src="([^"]*)"', text) if "mathjax" in s.lower()]
        for src in scripts:
            assert "://" not in src and not src.startswith("//"), \
                f"{page.relative_to(built)} loads MathJax from the network: {src}"
            assert (page.parent / src.split("?")[0]).is_file(), (page.relative_to(built), src)
        with_math += bool(scripts)
    assert with_math >= 5, "the pages with equations load no MathJax"
