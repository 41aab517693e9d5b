"""Every fenced block of README.md, and every example in the command line's ``--help``
texts, runs as written, so the README cannot drift from the code; the README keeps the
promises of a front page (a diagram of at most 15 lines, one statement a line; the
test command, which .ci/run runs as written; the docs build command). The guides of the
documentation (docs/guides/*.md) are run by tests/test_guides.py.

- ``python`` and ``sh`` blocks run in the order a reader meets them, in one empty
  temporary working folder holding a copy of ``examples/`` and of the sample data, and
  then all again in the same folder (a reader going through the page a second time):
  both rounds succeed and nothing outside ``out/`` is written (:func:`run_twice`).
  ``python`` blocks run in a fresh interpreter each; ``sh`` blocks line by line:
  ``unidyn ...`` as ``python -m unidyn ...``, ``python``/``.venv/bin/python`` as this
  interpreter. The set-up commands (``python3 -m venv .venv``, ``.venv/bin/pip install
  -e ...``, the test-suite run) are checked for their shape here and really run by
  ``tests/test_fresh_clone.py``; ``[...]`` marks an optional part of a command and is
  left out;
- ``toml`` blocks, here and in the guides, are parsed and run (a sweep if they have
  ``[grid]``, else a scenario).

A block preceded by ``<!-- include: PATH -->`` must equal the file PATH (relative to
the checkout) character for character, and the file is what runs. A block that is not
meant to run (e.g. output shown) must be preceded by ``<!-- not-run: reason -->``;
``text`` blocks show output and are not run. The docs build command
(``python -m sphinx ...``) is checked for its shape here and run by tests/test_docs.py.
Running blocks is in the slow tier; the Section 5 script is run once a session by
tests/evals/test_section5.py.
"""

import os
import re
import shlex
import shutil
import subprocess
import sys
import textwrap
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10
    import tomli as tomllib

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
LANGS = ("python", "sh", "toml")
#: languages of blocks that show text (output, a file's lines) and are not run
SHOWN = ("text",)
#: the docs build, as the README and .ci/run name it
DOCS_BUILD = ["-m", "sphinx", "-W", "-b", "html", "docs", "docs/_build/html"]
#: substrings of commands that take more than a few seconds
#: commands whose run is tested once a session elsewhere, not by running a page's blocks
SLOW_ONCE = ("paper_section5.py",)
TIMEOUT = 600


@dataclass
class Block:
    lang: str
    code: str
    line: int        # line of the opening fence
    section: str     # the heading it sits under
    marker: str      # the HTML comment just before it, if any
    path: Path = README

    @property
    def where(self):
        return f"{self.path.relative_to(ROOT)}:{self.line}"

    @property
    def id(self):
        words = re.sub(r"[^a-z0-9]+", "-", self.section.lower()).strip("-")
        stem = "" if self.path == README else self.path.stem + "-"
        return f"{stem}L{self.line}-{self.lang}-{words[:30]}"


def markdown_blocks(path=README):
    """The fenced blocks of a Markdown file (MyST directives, ```{name}, are not code)."""
    blocks, section = [], ""
    lines = path.read_text(encoding="utf-8").splitlines()
    i = 0
    while i < len(lines):
        line = lines[i]
        if line.startswith("#"):
            section = line.lstrip("#").strip()
        m = re.match(r"^(\s*)```(\S*)(?:\s.*)?$", line)   # a MyST directive has arguments
        if m:
            start, lang, indent = i, m.group(2), len(m.group(1))
            body = []
            i += 1
            while not re.match(r"^\s*```\s*$", lines[i]):
                body.append(lines[i][indent:])
                i += 1
            prev = next((lines[j].strip() for j in range(start - 1, -1, -1) if lines[j].strip()), "")
            if not lang.startswith("{"):
                blocks.append(Block(lang, "\n".join(body) + "\n", start + 1, section,
                                    prev if prev.startswith("<!--") else "", path))
        i += 1
    return blocks


BLOCKS = markdown_blocks(README)


def _marker(block, kind):
    m = re.match(rf"<!--\s*{kind}:\s*(.*?)\s*-->", block.marker)
    return m.group(1) if m else None


def check_languages(blocks):
    assert blocks, "no fenced blocks found"
    for b in blocks:
        reason = _marker(b, "not-run")
        if reason is not None:
            assert len(reason) > 5, f"{b.where}: say why the block is not run"
        else:
            assert b.lang in LANGS + SHOWN, (f"{b.where}: a ```{b.lang} block is neither run "
                                             f"nor marked <!-- not-run: reason -->")
    not_run = [b for b in blocks if _marker(b, "not-run") is not None]
    assert len(not_run) <= 3, "keep blocks that are not run rare"


def check_includes(blocks):
    for b in blocks:
        path = _marker(b, "include")
        if path is not None:
            assert (ROOT / path).read_text(encoding="utf-8") == b.code, \
                f"{b.where} differs from {path}"


def test_every_block_has_a_known_language_or_a_not_run_reason():
    check_languages(BLOCKS)


def test_included_blocks_equal_their_files():
    check_includes(BLOCKS)


# ------------------------------------------------------------------------ workspace

def _workspace(tmp):
    """An empty folder outside the checkout with a copy of examples/ and of the sample
    data (src/unidyn/datasets/), the files the commands read."""
    shutil.copytree(ROOT / "examples", tmp / "examples",
                    ignore=shutil.ignore_patterns("*.ipynb", ".ipynb_checkpoints", "__pycache__"))
    data = ROOT / "src" / "unidyn" / "datasets"
    shutil.copytree(data, tmp / data.relative_to(ROOT), ignore=shutil.ignore_patterns("*.py*"))
    return tmp


def _env(extra=None):
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH",)}
    env["MPLBACKEND"] = "Agg"
    env.update(extra or {})
    return env


def _run(argv, cwd, env=None):
    r = subprocess.run(argv, cwd=cwd, capture_output=True, text=True, env=_env(env),
                       timeout=TIMEOUT)
    return r


def runnable(kind, blocks=BLOCKS, marks=()):
    chosen = [b for b in blocks if b.lang == kind and _marker(b, "not-run") is None]
    return [pytest.param(b, id=b.id, marks=list(marks)) for b in chosen]




# -------------------------------------------------------------------------- python

#: Checks appended to a python block (after the README's code, which runs unchanged).
PY_CHECKS = {
    "A diagram in 15 lines": """
import numpy as _np, pathlib as _pl
_t = _np.asarray(out.t); _q = _np.asarray(out.y)
_np.savez(_pl.Path(__file__).with_name("readme_check.npz"), t=_t, q=_q)
""",
}


def run_python_block(block, ws, scripts):
    """Run a python block with ``ws`` as its working folder, from a script written into
    ``scripts`` (a folder outside ``ws``)."""
    code = block.code
    path = _marker(block, "include")
    if path is not None:
        code = (ROOT / path).read_text(encoding="utf-8")
    if block.path == README:
        code += PY_CHECKS.get(block.section, "")
    scripts.mkdir(parents=True, exist_ok=True)
    script = scripts / f"L{block.line}.py"
    script.write_text(code, encoding="utf-8")
    r = _run([sys.executable, str(script)], ws)
    assert r.returncode == 0, f"{block.where} ({block.section}):\n{r.stdout}\n{r.stderr}"
    return r


def _files(folder):
    """{relative path: bytes} of every file under ``folder`` but its ``__pycache__``
    folders (which Python writes beside imported modules, and git ignores)."""
    return {p.relative_to(folder).as_posix(): p.read_bytes() for p in folder.rglob("*")
            if p.is_file() and "__pycache__" not in p.parts}


def run_twice(path, tmp, skip=SLOW_ONCE):
    """Every runnable python and sh block of the Markdown file ``path``, in the order a
    reader meets them, in one working folder (:func:`_workspace`), and then all of them
    again in the same folder, as a reader who goes through a guide a second time. Each
    must succeed both times, and nothing outside ``out/`` may be written or changed.
    Commands holding a string of ``skip`` are not run (the set-up commands are checked
    for their shape). Returns the working folder, where the script of each python block
    sits (``<scripts>/L<line>.py``), and {block line: its second round's result}."""
    ws, scripts = _workspace(tmp / "ws"), tmp / "scripts"
    before = _files(ws)
    blocks = [b for b in markdown_blocks(path)
              if b.lang in ("python", "sh") and _marker(b, "not-run") is None]
    results = {}
    for round_ in ("first", "second"):
        for b in blocks:
            if b.lang == "python":
                try:
                    results[b.line] = run_python_block(b, ws, scripts)
                except AssertionError as e:
                    raise AssertionError(f"{round_} run: {e}") from None
                continue
            for text, words in _commands(b):
                kind, argv, env = _translate(words)
                if kind != "run":
                    _check_shape(kind, argv)
                elif not any(s in " ".join(words) for s in skip):
                    r = _run(argv, ws, env)
                    assert r.returncode == 0 and "Traceback" not in r.stderr, (
                        f"{round_} run of {b.where}: {text}\n{r.stdout[-2000:]}\n{r.stderr[-3000:]}")
    after = _files(ws)
    stray = sorted(f for f in after if before.get(f) != after[f] and not f.startswith("out/"))
    assert not stray, f"{path.name}'s blocks write outside out/: {stray}"
    return ws, scripts, results


@pytest.mark.slow
def test_readme_blocks_run_twice_and_write_only_under_out(tmp_path):
    """The README's diagram and command-line blocks, as a reader runs them from the
    checkout, twice (the Section 5 script, run once a session by tests/evals, refuses
    to replace its results without --overwrite, as the README says)."""
    ws, scripts, results = run_twice(README, tmp_path)
    [block] = [b for b in BLOCKS if b.section == "A diagram in 15 lines" and b.lang == "python"]
    _check_fifteen_lines(block, scripts, results[block.line])


def test_the_diagram_is_at_most_15_lines_of_one_statement_each():
    import ast
    [block] = [b for b in BLOCKS if b.section == "A diagram in 15 lines" and b.lang == "python"]
    lines = [l for l in block.code.splitlines() if l.strip() and not l.lstrip().startswith("#")]
    assert len(lines) <= 15, f"{len(lines)} lines"
    tree = ast.parse(block.code)
    assert len(tree.body) == len(lines), "one statement a line: no ';', no statement over two lines"
    assert all(isinstance(node, (ast.Import, ast.Assign, ast.Expr)) for node in tree.body)


def _check_fifteen_lines(block, scripts, r):
    # the output is the printed pose alone: bdsim's notices and reports are silenced
    assert r.stderr.strip() == "", r.stderr
    assert re.fullmatch(r"t = 60 s: h = \(-?\d+\.\d{3}, -?\d+\.\d{3}\) m, psi = -?\d+\.\d{2} rad\n",
                        r.stdout), r.stdout
    data = np.load(scripts / "readme_check.npz")
    t, q = data["t"], data["q"]
    # the printed pose is the last sample, and the path tracks the figure eight
    x, y = (float(v) for v in re.findall(r"-?\d+\.\d{3}", r.stdout)[:2])
    assert abs(x - q[-1, 0]) < 1e-3 and abs(y - q[-1, 1]) < 1e-3
    h_d = np.stack([np.sin(0.5 * t), np.cos(0.25 * t) - 1], -1)
    err = np.linalg.norm(h_d - q[:, :2], axis=1)
    assert abs(err[0] - 0.2) < 1e-9
    assert np.mean(err[t > 40]) < 0.02     # exact compensation: tracks like the kinematic case


# ------------------------------------------------------------------------------ sh

def _commands(block):
    """The commands of a sh block: (text, argv, env) with comments and [...] removed."""
    out = []
    for raw in block.code.splitlines():
        text = re.sub(r"\s+\[[^\]]*\]", "", raw)   # optional parts, [--flag value]
        words = shlex.split(text, comments=True)
        if not words:
            continue
        for part in _split_and(words):
            out.append((raw.strip(), part))
    return out


def _split_and(words):
    parts, cur = [], []
    for w in words:
        if w == "&&":
            parts.append(cur)
            cur = []
        else:
            cur.append(w)
    parts.append(cur)
    return parts


def _translate(words):
    """(kind, argv, env): kind is 'run', 'venv', 'pip', 'pytest' or 'sphinx'."""
    env = {}
    while words and re.fullmatch(r"[A-Z_][A-Z0-9_]*=.*", words[0]):
        k, v = words[0].split("=", 1)
        env[k] = v
        words = words[1:]
    cmd, args = words[0], words[1:]
    if cmd == "unidyn":
        return "run", [sys.executable, "-m", "unidyn", *args], env
    if cmd == "mkdir":
        return "run", ["mkdir", *args], env
    if cmd == "bdrun":  # bdsim's runner of .bd files, installed beside this interpreter
        return "run", [str(Path(sys.executable).with_name("bdrun")), *args], env
    if cmd in ("python3", "python") and args[:2] == ["-m", "venv"]:
        return "venv", args, env
    if cmd in (".venv/bin/pip", "pip"):
        return "pip", args, env
    if cmd in ("python", "python3", ".venv/bin/python"):
        if args[:2] == ["-m", "pytest"]:
            return "pytest", args, env
        if args[:2] == ["-m", "sphinx"]:
            return "sphinx", args, env
        return "run", [sys.executable, *args], env
    raise AssertionError(f"README command {' '.join(words)!r}: unknown program {cmd!r}")


def _check_shape(kind, args):
    if kind == "venv":
        assert args == ["-m", "venv", ".venv"], args
    elif kind == "pip":
        assert args[0] == "install" and args[1] == "-e", args
        spec = args[2]
        m = re.fullmatch(r"\.(?:\[([a-z,]+)\])?", spec)
        assert m, spec
        extras = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"][
            "optional-dependencies"]
        for e in (m.group(1) or "").split(","):
            assert not e or e in extras, f"README installs unknown extra {e!r}"
    elif kind == "pytest":
        assert args[:2] == ["-m", "pytest"], args
    elif kind == "sphinx":  # built by tests/test_docs.py
        assert args == DOCS_BUILD, args


def _readme_commands(lang="sh"):
    return [(b, words) for b in BLOCKS if b.lang == lang and _marker(b, "not-run") is None
            for _text, words in _commands(b)]


def test_ci_runs_the_readme_test_command_as_written():
    """.ci/run removes any old .venv and runs the README's second command, the same line;
    that command makes a venv, installs the test extra and runs pytest -q. The test
    extra brings every extra whose code the tests run, the docs among them (the docs
    build is a test), so the suite CI runs is the one a reader runs."""
    sh = [b for b in BLOCKS if b.lang == "sh" and _marker(b, "not-run") is None]
    command = sh[1].code.strip()
    lines = [ln.strip() for ln in (ROOT / ".ci" / "run").read_text(encoding="utf-8").splitlines()
             if ln.strip() and not ln.lstrip().startswith("#")]
    assert lines[-1] == command, (lines[-1], command)
    assert [ln.split()[0] for ln in lines[:-1]] == ["set", "cd", "rm"], lines
    assert [_translate(w)[:2] for _t, w in _commands(sh[1])] == [
        ("venv", ["-m", "venv", ".venv"]), ("pip", ["install", "-e", ".[test]"]),
        ("pytest", ["-m", "pytest", "-q"])]
    extras = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["optional-dependencies"]
    [own] = [r for r in extras["test"] if r.startswith("unidyn[")]
    # every extra but Jupyter itself (the tests run notebooks with nbclient and ipykernel)
    assert set(own[len("unidyn["):-1].split(",")) == set(extras) - {"test", "notebooks"}
    assert ("sphinx", DOCS_BUILD) in [_translate(w)[:2] for _b, w in _readme_commands()], \
        "the README does not show the docs build"
    # the main job: install, then the paper's Section 5 script
    readme = [_translate(w)[:2] for _b, w in _readme_commands()]
    assert ("pip", ["install", "-e", "."]) in readme
    assert any(k == "run" and "examples/paper_section5.py" in a for k, a in readme)


def test_the_test_extra_brings_every_package_a_test_would_skip_without():
    """Where the test extra is installed (README command 2, .ci/run), no test is skipped
    for a missing package: every module a test asks for with ``pytest.importorskip``
    can be imported."""
    import ast
    import importlib.util
    wanted = set()
    for path in (ROOT / "tests").rglob("*.py"):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if (isinstance(node, ast.Call) and getattr(node.func, "attr", "") == "importorskip"
                    and node.args and isinstance(node.args[0], ast.Constant)):
                wanted.add(node.args[0].value)
    assert {"sphinx", "nbclient", "rosbags"} <= wanted  # the scan finds them
    missing = sorted(m for m in wanted if importlib.util.find_spec(m) is None)
    assert not missing, f"not installed: {missing}; pip install -e '.[test]'"


def test_readme_is_a_front_page():
    text = README.read_text(encoding="utf-8")
    assert len(text.splitlines()) <= 200
    assert len(re.findall(r"!\[[^\]]*\]\(", text)) == 1, "one figure"
    for guide in sorted((ROOT / "docs" / "guides").glob("*.md")):
        assert f"docs/guides/{guide.name}" in text, f"the README does not link {guide.name}"
    for link in re.findall(r"\]\(((?!https?:)[^)#]+)\)", text):
        assert (ROOT / link).exists(), f"the README links {link}, which does not exist"


# ---------------------------------------------------------------------------- toml

PAGE_BLOCKS = BLOCKS + [b for g in sorted((ROOT / "docs" / "guides").glob("*.md"))
                        for b in markdown_blocks(g)]


@pytest.mark.slow
@pytest.mark.parametrize("block", runnable("toml", PAGE_BLOCKS))
def test_toml_block_parses_and_runs(block, tmp_path):
    ws = _workspace(tmp_path)
    data = tomllib.loads(block.code)
    path = ws / "readme_block.toml"
    path.write_text(block.code, encoding="utf-8")
    what = "sweep" if ("grid" in data or "base" in data) else "run"
    r = _run([sys.executable, "-m", "unidyn", what, str(path), "--out", str(ws / "out")], ws)
    assert r.returncode == 0, f"{block.where}:\n{r.stdout}\n{r.stderr}"
    assert (ws / "out" / ("metrics.csv" if what == "sweep" else "summary.json")).is_file()


# -------------------------------------------------------------------- --help texts

def _epilog_commands():
    from unidyn.cli import parser as cli_parser
    parser = cli_parser()
    subs = [a for a in parser._actions if hasattr(a, "choices") and isinstance(a.choices, dict)]
    found = []
    for name, sub in (subs[0].choices.items() if subs else []):
        for line in textwrap.dedent(sub.epilog or "").splitlines():
            line = line.strip().removeprefix("$ ")
            # `unidyn edit` opens a window (tests/teaching/test_bdedit.py starts the editor)
            if line.startswith("unidyn ") and name != "edit":
                found.append(pytest.param(name, line, id=f"{name}-{len(found)}",
                                          marks=[pytest.mark.slow]))
    return found


EPILOG_COMMANDS = _epilog_commands()


@pytest.mark.skipif(not EPILOG_COMMANDS, reason="the --help texts show no example commands")
@pytest.mark.parametrize("name,line", EPILOG_COMMANDS or [("-", "-")])
def test_help_example_runs(name, line, tmp_path):
    ws = _workspace(tmp_path)
    words = shlex.split(re.sub(r"\s+\[[^\]]*\]", "", line), comments=True)
    kind, argv, env = _translate(words)
    r = _run(argv, ws, env)
    assert r.returncode == 0, f"unidyn {name} --help: {line}\n{r.stdout}\n{r.stderr}"
