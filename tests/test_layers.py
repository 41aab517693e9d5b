"""The package's layers: each module imports only its own layer or lower, and no
import cycle joins two of its modules.

Every import statement of src/unidyn counts, at module level or inside a function,
absolute or relative (``from . import x`` included): a function-local import of one
of the package's own modules cycles just as well when it runs.
"""

import ast
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[1] / "src"
PACKAGE = "unidyn"

#: Lowest first. A module may import its own layer or a lower one. A package's
#: submodules sit in the package's layer unless listed themselves.
LAYERS = {
    # what every part shares: the package's namespace, its exceptions and validators,
    # progress bars, how bdsim finds the blocks, signals and exit status, the sample
    # data (standard library only)
    "base": ("unidyn", "unidyn._errors", "unidyn._validate", "unidyn._bdsim_path",
             "unidyn.process", "unidyn.progress", "unidyn.datasets"),
    # the paper's science, free of bdsim and of files
    "science": ("unidyn.model",),
    # what a run gives back: the result, its folders, files and figures
    "results": ("unidyn.results",),
    # bdsim's blocks and diagrams, the batch engine and what it compiles with numba
    "simulation": ("unidyn.blocks", "unidyn.diagrams", "unidyn.engine", "unidyn.compiled"),
    # the choice between the two engines, above both; identification, sweeps,
    # teaching tools and bridges
    "tools": ("unidyn.engines", "unidyn.identification", "unidyn.sweeps", "unidyn.teaching"),
    # the paper's reproductions
    "paper": ("unidyn.paper",),
    # the command line and the editor it starts
    "commands": ("unidyn.cli", "unidyn.__main__", "unidyn.editor"),
}


def module_names(src=SRC):
    """{dotted module name: path} of every module of the package."""
    out = {}
    for path in sorted((src / PACKAGE).rglob("*.py")):
        parts = list(path.relative_to(src).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts.pop()
        out[".".join(parts)] = path
    return out


def imports(name, path, modules):
    """The package's modules that module ``name`` imports anywhere in its body."""
    is_package = path.name == "__init__.py"
    found = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"), str(path))):
        if isinstance(node, ast.Import):
            targets = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = name.split(".")
                base = base[:len(base) - node.level + (1 if is_package else 0)]
                base = ".".join(base + ([node.module] if node.module else []))
            else:
                base = node.module
            # ``from a import b`` imports the module a.b when there is one, else a
            targets = [f"{base}.{a.name}" if f"{base}.{a.name}" in modules else base
                       for a in node.names]
        else:
            continue
        for t in targets:
            while t and t not in modules:  # ``import a.b.c`` of a name inside a module
                t = t.rpartition(".")[0]
            if t and t != name:
                found.add(t)
    return found


def graph(src=SRC):
    modules = module_names(src)
    return {m: imports(m, p, modules) for m, p in modules.items()}


def layer_of(module):
    rank = {m: i for i, ms in enumerate(LAYERS.values()) for m in ms}
    m = module
    while m not in rank:
        if "." not in m:
            raise KeyError(f"{module} is in no layer of LAYERS")
        m = m.rpartition(".")[0]
    return rank[m]


def cycles(g):
    """The strongly connected components of more than one module (Tarjan)."""
    index, low, stack, on, out = {}, {}, [], set(), []

    def visit(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in sorted(g.get(v, ())):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(sorted(comp))

    for v in sorted(g):
        if v not in index:
            visit(v)
    return out


def upward(g):
    """(importer, imported) pairs where a lower layer imports a higher one."""
    return sorted((a, b) for a, bs in g.items() for b in bs if layer_of(b) > layer_of(a))


def test_no_import_cycles():
    assert cycles(graph()) == []


def test_every_module_has_a_layer():
    assert [m for m in module_names() if not _has_layer(m)] == []


def _has_layer(module):
    try:
        layer_of(module)
    except KeyError:
        return False
    return True


def test_no_import_from_a_higher_layer():
    assert upward(graph()) == []


def test_the_walk_sees_every_kind_of_import(tmp_path):
    """A cycle through a function-local relative import, and an upward ``from . import``,
    are found: the checks above can fail."""
    pkg = tmp_path / PACKAGE
    (pkg / "sub").mkdir(parents=True)
    (pkg / "__init__.py").write_text("")
    (pkg / "model.py").write_text("def f():\n    from .paper import g\n    return g\n")
    (pkg / "paper.py").write_text("import unidyn.model\n")
    (pkg / "robots.py").write_text("from . import cli\n")
    (pkg / "cli").mkdir()
    (pkg / "cli" / "__init__.py").write_text("")
    (pkg / "sub" / "__init__.py").write_text("from .. import model\nfrom .x import y\n")
    (pkg / "sub" / "x.py").write_text("y = 1\n")
    g = graph(tmp_path)
    assert g["unidyn.sub"] == {"unidyn.model", "unidyn.sub.x"}
    assert cycles(g) == [["unidyn.model", "unidyn.paper"]]
    assert ("unidyn.robots", "unidyn.cli") in upward(g)
    assert ("unidyn.model", "unidyn.paper") in upward(g)


@pytest.mark.parametrize("layer", list(LAYERS))
def test_layers_name_existing_modules(layer):
    modules = module_names()
    assert [m for m in LAYERS[layer] if m not in modules] == []


def test_package_lists_its_names_only():
    """``import unidyn`` loads its names lazily (see src/unidyn/__init__.py); what
    ``dir(unidyn)`` lists is its API, not the flag its lazy imports read."""
    import unidyn
    assert "TYPE_CHECKING" not in dir(unidyn)
    assert [n for n in unidyn.__all__ if getattr(unidyn, n, None) is None] == []
