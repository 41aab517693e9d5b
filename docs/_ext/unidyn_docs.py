"""Sphinx helpers of unidyn's documentation.

- ``:blockname:`NAME``` — the name a block has in a bdsim diagram (``bd.NAME(...)``),
  as bdsim's own documentation writes it, with an index entry;
- ``.. unidyn-scenario-fields::`` — a table of every field of :class:`unidyn.Scenario`
  with its default and its description, read from the dataclass and its docstring, so
  the scenario-file reference cannot miss a field;
- at the start of a build: the notebooks of ``examples/`` are copied into
  ``docs/notebooks/`` and the figures of ``docs/_generated/`` are drawn by
  ``docs/figures/make_docs_figures.py``.
"""

from __future__ import annotations

import dataclasses
import importlib.util
import re
import shutil
from pathlib import Path

from docutils import nodes
from docutils.statemachine import StringList
from sphinx import addnodes
from sphinx.util.docutils import SphinxDirective

DOCS = Path(__file__).resolve().parents[1]
ROOT = DOCS.parent


def blockname_role(name, rawtext, text, lineno, inliner, options=None, content=()):
    node = nodes.literal(text, text, classes=["blockname"])
    entry = addnodes.index(entries=[("single", f"{text} (block)", f"block-{text.lower()}", "", None)])
    target = nodes.target("", "", ids=[f"block-{text.lower()}"])
    inliner.document.note_explicit_target(target)
    return [entry, target, nodes.strong("", "", node)], []


def _param_docs(doc: str) -> dict[str, str]:
    """``:param name: text`` entries of a docstring (continuation lines joined)."""
    out, current = {}, None
    for line in doc.splitlines():
        m = re.match(r"\s*:param ([\w, ]+):\s*(.*)", line)
        if m:
            current = [n.strip() for n in m.group(1).split(",")]
            for n in current:
                out[n] = m.group(2).strip()
        elif current and line.strip() and not line.strip().startswith(":"):
            for n in current:
                out[n] += " " + line.strip()
        else:
            current = None
    return out


def _default_text(f: dataclasses.Field) -> str:
    from unidyn.model.scenario import plain_value
    if f.default is not dataclasses.MISSING:
        value = f.default
    elif f.default_factory is not dataclasses.MISSING:
        value = f.default_factory()
    else:
        return "(required)"
    try:
        value = plain_value(value)
    except Exception:  # noqa: BLE001 - a default with no plain form is shown as Python writes it
        pass
    text = repr(value)
    return text if len(text) <= 80 else text[:77] + "..."


class ScenarioFields(SphinxDirective):
    """Every field of unidyn.Scenario: name, default, description."""

    def run(self):
        from unidyn import Scenario
        docs = _param_docs(Scenario.__doc__ or "")
        rows = []
        for f in dataclasses.fields(Scenario):
            if not f.init:
                continue
            desc = docs.get(f.name, "")
            rows += [f"   * - ``{f.name}``", f"     - ``{_default_text(f)}``", f"     - {desc}"]
        text = [".. list-table::", "   :header-rows: 1", "   :widths: 15 25 60", "",
                "   * - field", "     - default (the paper's setting)", "     - meaning"] + rows
        node = nodes.container()
        self.state.nested_parse(StringList(text, source="unidyn.Scenario"), self.content_offset, node)
        return node.children


#: Modules whose docstrings are being rewritten elsewhere and still hold plain-text
#: habits that reST reads otherwise: ``|x|`` (a substitution to reST) and a field list
#: that starts or ends without a blank line. Their docstrings are repaired in memory
#: for the build, here only; a module that is clean needs no entry.
REPAIRED_MODULES = ("unidyn.engine", "unidyn.results", "unidyn.teaching", "unidyn.sweeps",
                    "unidyn.identification", "unidyn.process")
_FIELD = re.compile(r"^\s*:(param|type|ivar|vartype|raises|returns?|rtype|seealso)\b")


def repair_docstring(app, what, name, obj, options, lines):
    module = (getattr(obj, "__module__", None) or getattr(getattr(obj, "fget", None), "__module__", None)
              or (name if what == "module" else ""))
    if not str(module).startswith(REPAIRED_MODULES):
        return
    out, field_indent = [], None
    for line in lines:
        line = re.sub(r"(?<![\\`])\|(?!`)", r"\\|", line)   # |x| is an absolute value
        indent = len(line) - len(line.lstrip())
        if _FIELD.match(line):
            if out and out[-1].strip() and field_indent is None:
                out.append("")            # a field list starts after a blank line
            field_indent = indent
        elif field_indent is not None and line.strip() and indent <= field_indent:
            out.append("")                # ... and ends before one
            field_indent = None
        elif not line.strip():
            field_indent = None
        out.append(line)
    lines[:] = out


def cli_parser():
    """The ``unidyn`` command's parser (:func:`unidyn.cli.parser`), with its help texts
    escaped for reST (sphinx-argparse reads them as reST; they are written as plain
    text for the terminal, where ``|u|`` is an absolute value)."""
    import argparse

    from unidyn.cli import parser

    def escape(parser):
        for action in parser._actions:
            if action.help and action.help is not argparse.SUPPRESS:
                action.help = action.help.replace("|", "\\|")
            if isinstance(getattr(action, "choices", None), dict):   # the subcommands
                for sub in action.choices.values():
                    escape(sub)
        return parser
    return escape(parser())


def _copy_if_changed(src: Path, dst: Path) -> None:
    if not dst.exists() or dst.read_bytes() != src.read_bytes():
        dst.parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(src, dst)


def prepare_sources(app):
    """Copy the notebooks in; draw the build-time figures (skipped when up to date)."""
    nb_dir = DOCS / "notebooks"
    wanted = {p.name for p in (ROOT / "examples").glob("*.ipynb")}
    for p in sorted((ROOT / "examples").glob("*.ipynb")):
        _copy_if_changed(p, nb_dir / p.name)
    for stale in nb_dir.glob("*.ipynb"):
        if stale.name not in wanted:
            stale.unlink()
    spec = importlib.util.spec_from_file_location("make_docs_figures",
                                                  DOCS / "figures" / "make_docs_figures.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    mod.main(DOCS / "_generated")


def setup(app):
    app.add_role("blockname", blockname_role)
    app.add_directive("unidyn-scenario-fields", ScenarioFields)
    app.connect("builder-inited", prepare_sources)
    app.connect("autodoc-process-docstring", repair_docstring)
    return {"version": "1", "parallel_read_safe": True, "parallel_write_safe": True}
