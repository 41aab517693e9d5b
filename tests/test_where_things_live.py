"""docs/reference/where-things-live.md against the package: every module of src/unidyn is
on the page, every module the page names exists, and the README links the page."""

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "src" / "unidyn"
PAGE = ROOT / "docs" / "reference" / "where-things-live.md"


def package_modules() -> set[str]:
    """Every module of the package by its path in src/unidyn: ``model/laws.py``, and a
    package as its folder, ``model/`` (the top-level package as ``__init__.py``)."""
    out = set()
    for path in PACKAGE.rglob("*.py"):
        rel = path.relative_to(PACKAGE).as_posix()
        if path.name == "__init__.py" and path.parent != PACKAGE:
            rel = rel[: -len("__init__.py")]
        out.add(rel)
    return out


def page_modules() -> set[str]:
    """The modules the page's tables name: the first cell of each row, in backquotes."""
    out = set()
    for line in PAGE.read_text(encoding="utf-8").splitlines():
        m = re.match(r"\| `([^`]+)` \|", line)
        if m:
            out.add(m.group(1))
    return out


def test_page_names_every_module_of_the_package():
    missing = sorted(package_modules() - page_modules())
    assert not missing, f"add these modules to {PAGE.relative_to(ROOT)}: {missing}"


def test_every_module_the_page_names_exists():
    stale = sorted(page_modules() - package_modules())
    assert not stale, f"{PAGE.relative_to(ROOT)} names modules that do not exist: {stale}"


def test_the_docs_and_the_readme_link_the_page():
    assert "where-things-live" in (ROOT / "docs" / "reference" / "index.rst").read_text(encoding="utf-8")
    assert "(docs/reference/where-things-live.md)" in (ROOT / "README.md").read_text(encoding="utf-8")
