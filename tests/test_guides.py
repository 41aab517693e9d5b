"""The guides (docs/guides/*.md) work for a reader who installed unidyn and starts in a
folder of their own: every ``python`` and ``sh`` block of a guide runs as written, in
the order of the page, in one empty temporary folder (no checkout, no copy of
``examples/``: a block that needs a file gets it from :mod:`unidyn.datasets` or writes
it), with ``MPLBACKEND=Agg``. ``python`` blocks run in a fresh interpreter each; ``sh``
blocks run in bash, where ``unidyn`` and ``python`` are this interpreter's and the
programs of its environment (``bdrun``) are found.

A block that cannot run here is preceded by ``<!-- not-run: reason -->``: it needs a
robot or ROS, opens a window, installs packages, or is too long for the test suite
(the full Fig. 11 sweep; the guide runs a small one beside it).

The numbers a guide states about a run (counts of runs and rows, agreement of the
engines) are checked against what the block prints or writes (:data:`NUMBERS`).
"""

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

import test_readme as readme

ROOT = Path(__file__).resolve().parents[1]
GUIDES = sorted((ROOT / "docs" / "guides").glob("*.md"))
TIMEOUT = 300


def _marker(block, kind):
    m = re.match(rf"<!--\s*{kind}:\s*(.*?)\s*-->", block.marker)
    return m.group(1) if m else None


def _runnable(guide):
    return [b for b in readme.markdown_blocks(guide)
            if b.lang in ("python", "sh") and _marker(b, "not-run") is None]


def _bin(tmp):
    """A folder for PATH in which ``unidyn``, ``python`` and ``python3`` are this
    interpreter's, as in a virtual environment that is active."""
    bin_ = tmp / "bin"
    bin_.mkdir()
    # scripts, not links: a link to a venv's python outside the venv's folder starts
    # Python without the venv (its pyvenv.cfg is looked for beside the link)
    for name, run in (("python", ""), ("python3", ""), ("unidyn", " -m unidyn")):
        script = bin_ / name
        script.write_text(f'#!/bin/sh\nexec "{sys.executable}"{run} "$@"\n')
        script.chmod(0o755)
    return bin_


def _env(bin_):
    env = dict(os.environ)
    env["MPLBACKEND"] = "Agg"
    # the environment's own programs (bdrun, bdedit) after these
    env["PATH"] = os.pathsep.join([str(bin_), str(Path(sys.executable).parent), env.get("PATH", "")])
    return env


def run_guide(guide, tmp):
    """Run the guide's blocks in order in an empty folder; returns the folder and
    {block line: its stdout}."""
    ws = tmp / "ws"
    ws.mkdir()
    env = _env(_bin(tmp))
    outputs = {}
    for b in _runnable(guide):
        code = b.code
        if b.lang == "python":
            script = tmp / f"{guide.stem}-L{b.line}.py"
            script.write_text(code, encoding="utf-8")
            argv = [sys.executable, str(script)]
        else:
            argv = ["bash", "-e", "-o", "pipefail", "-c", code]
        r = subprocess.run(argv, cwd=ws, env=env, capture_output=True, text=True, timeout=TIMEOUT)
        assert r.returncode == 0 and "Traceback" not in r.stderr, (
            f"{b.where} ({b.section}) failed:\n{code}\n--- stdout\n{r.stdout[-3000:]}"
            f"\n--- stderr\n{r.stderr[-3000:]}")
        outputs[b.line] = r.stdout
    return ws, outputs


def _stated(guide, pattern):
    """The number a guide states, found by ``pattern`` (one group) in its text."""
    m = re.search(pattern, guide.read_text(encoding="utf-8"))
    assert m, f"{guide.name} no longer says {pattern!r}: update the check"
    return m.group(1)


def _rows(path):
    lines = path.read_text(encoding="utf-8").splitlines()
    return len([ln for ln in lines[1:] if ln.strip()])


def _check_command_line(guide, ws, outputs):
    # "8 runs of 40 s": the sample sweep writes one row per run
    n = int(_stated(guide, r"sweep\.toml`[^.]*?(\d+) runs of 40 s"))
    assert _rows(ws / "out" / "sweep" / "metrics.csv") == n
    # "over 4 seeds": runs.csv holds one row per seed
    seeds = int(_stated(guide, r"--seeds (\d+) --out out/case3-seeds"))
    assert _rows(ws / "out" / "case3-seeds" / "runs.csv") == seeds


def _output_of(guide, outputs, text):
    """The stdout of the block of ``guide`` that holds ``text``."""
    [b] = [b for b in _runnable(guide) if text in b.code]
    return outputs[b.line]


def _text_after(guide, words):
    """The ``text`` block or the table that follows the paragraph ending in ``words``."""
    text = guide.read_text(encoding="utf-8")
    i = text.index(words) + len(words)
    m = re.match(r"\s*(?:```text\n(.*?)```|((?:\|[^\n]*\n)+))", text[i:], re.S)
    assert m, f"{guide.name}: nothing shown after {words!r}"
    return (m.group(1) or m.group(2)).strip()


def _check_paper(guide, ws, outputs):
    # the Section 5 table is what the block prints
    table = _text_after(guide, "It prints (noise seed 0):")
    assert table in _output_of(guide, outputs, "section5_claims"), table
    # the experiment's printed table and verdicts
    shown = _text_after(guide, "It prints:")
    printed = _output_of(guide, outputs, "--paper experiment")
    assert shown in printed, printed
    # the full Fig. 11 sweep: 70 gains, four cases, five seeds
    from unidyn.paper import paper_fig11
    sweep = paper_fig11(seeds=5)
    gains = int(_stated(guide, r"runs the (\d+) gains from 0\.5 to 35"))
    runs = int(_stated(guide, r"noise\s+seeds 1 to 5 \(([\d,]+) runs\)").replace(",", ""))
    assert len(sweep.points()) == runs == gains * 4 * 5
    assert f"{runs:,} runs" in guide.read_text(encoding="utf-8")


def _check_payload(guide, ws, outputs):
    try:
        import tomllib
    except ModuleNotFoundError:  # Python 3.10
        import tomli as tomllib
    [toml] = [b for b in readme.markdown_blocks(guide) if b.lang == "toml"]
    runs = len(tomllib.loads(toml.code)["grid"]["payload"])
    assert int(_stated(guide, r"a sweep of (\d+) runs")) == runs
    # the table of the three controllers holds the numbers the block prints, row by row
    after = 'plot_pickup(results, "out/pickup.png", at=100.0)\n```'
    shown = re.findall(r"(\d+\.\d{3}) m·s", _text_after(guide, after))
    printed = re.findall(r"(\d+\.\d{3}) m·s", _output_of(guide, outputs, "pickup_iae"))
    assert len(shown) == 6 and shown == printed, (shown, printed)


def _check_toolbox_dropin(guide, ws, outputs):
    lag = _stated(guide, r"angular velocity takes ([\d.]+) s to reach 90 %")
    assert f"command {lag} s after it" in _output_of(guide, outputs, "PIECEWISE")


def _check_ros(guide, ws, outputs):
    # the lines shown of the sample recording's identification are the ones it prints
    shown = _text_after(guide, "It prints, among its lines,")
    printed = _output_of(guide, outputs, "unidyn identify courier.mcap").splitlines()
    for line in shown.splitlines():
        assert line == "..." or line.rstrip() in [p.rstrip() for p in printed], line


def _check_model_limits(guide, ws, outputs):
    # the presets named, five of Table 1 and four more: nine sets, unidyn.robots' names
    import unidyn
    text = guide.read_text(encoding="utf-8")
    table1 = re.search(r"The five robots of the paper's Table 1 \(([^)]*)\)", text).group(1)
    others = re.search(r"The\s+other four \(([^)]*)\)", text).group(1)
    named = [re.findall(r"`(\w+)`", part) for part in (table1, others)]
    assert [len(n) for n in named] == [5, 4] and "all nine sets" in text
    assert sorted(named[0] + named[1]) == sorted(unidyn.robots.names())


def _check_identification(guide, ws, outputs):
    # the presets' gains and lengths the unit checks are explained with
    import numpy as np

    import unidyn
    theta = {n: np.asarray(unidyn.robots.get(n).theta) for n in unidyn.robots.names()}
    table1 = ("p3dx", "p3dx_laser", "wheelchair_55kg", "wheelchair_125kg", "khepera3")
    gains = np.concatenate([theta[n][[3, 5]] for n in table1])
    text = guide.read_text(encoding="utf-8")
    lo, hi = re.search(r"θ4 and θ6 are near 1 \(([\d.]+) to ([\d.]+) for", text).groups()
    assert (float(lo), float(hi)) == (round(gains.min(), 2), round(gains.max(), 2))
    robulab = float(_stated(guide, r"([\d.]+) for\s+the RobuLAB-10"))
    assert robulab == round(theta["robulab10"][3], 1)
    lengths = [np.sqrt(abs(t[2] * t[1] / (t[0] * t[4]))) for t in theta.values()]
    lo, hi = re.search(r"radius of\s+gyration \(([\d.]+) to ([\d.]+) m for the presets",
                       text).groups()
    assert (float(lo), float(hi)) == (round(min(lengths), 2), round(max(lengths), 2))


def _check_teaching(guide, ws, outputs):
    import unidyn
    from unidyn.results import figstyle
    text = " ".join(guide.read_text(encoding="utf-8").split())
    assert float(_stated(guide, r"draws figures ([\d.]+) times larger")) == figstyle.SLIDES_SCALE
    words = {7: "seven", 9: "nine"}
    assert f"The {words[len(list((ROOT / 'examples').glob('*.ipynb')))]} notebooks" in text
    assert f"the {words[len(unidyn.robots.names())]} robots" in text


#: per guide, a check of the numbers it states against what its blocks printed and wrote
NUMBERS = {
    "command-line": _check_command_line,
    "payload": _check_payload,
    "paper": _check_paper,
    "toolbox-dropin": _check_toolbox_dropin,
    "ros": _check_ros,
    "model-limits": _check_model_limits,
    "identification": _check_identification,
    "teaching": _check_teaching,
}


def test_guides_exist_and_their_blocks_have_known_languages():
    assert len(GUIDES) >= 8, GUIDES
    for g in GUIDES:
        blocks = readme.markdown_blocks(g)
        assert [b for b in blocks if b.lang in ("python", "sh", "toml")], \
            f"{g.name}: a guide shows code that runs"
        readme.check_languages(blocks)
        readme.check_includes(blocks)


def test_guides_read_as_plain_markdown():
    """The guides read the same on the repository's web page as in the built site: links
    are Markdown links, names are code, notes are quotations; no MyST role (``{doc}``,
    ``{func}``, ...) or directive, which the web page would show as raw markup."""
    for g in GUIDES:
        for n, line in enumerate(g.read_text(encoding="utf-8").splitlines(), 1):
            assert not re.search(r"\{[a-z:]+\}`|^\s*(```|:::)\{", line), \
                f"{g.name}:{n}: MyST markup: {line.strip()}"


def test_guides_use_the_public_api_only():
    """Blocks import ``unidyn`` and its documented subpackages, never a module the
    reference does not list, and name no file of the checkout (``examples/``,
    ``src/``): a reader who installed the package has neither."""
    documented = set(re.findall(r"automodule:: (unidyn[\w.]*)", "".join(
        p.read_text(encoding="utf-8") for p in (ROOT / "docs" / "reference").rglob("*.rst"))))
    for g in GUIDES:
        for b in _runnable(g):
            for mod in re.findall(r"(?:from|import) (unidyn[\w.]*)", b.code):
                assert mod in documented, f"{b.where}: {mod} is not a documented module"
            # the batch engine, the model and the sweeps are used through unidyn's names
            assert not re.search(r"unidyn\.(engine|model|sweeps)\b", b.code), \
                f"{b.where}: use the names of the unidyn namespace"
            assert not re.search(r"(?<![\w/])(examples|src)/", b.code), \
                f"{b.where}: names a file of the checkout"


def test_shipped_example_files_are_the_examples():
    """The scenario and sweep files of unidyn.datasets are the ones examples/ holds and
    the reference shows."""
    import unidyn.datasets
    for name in ("scenario.toml", "sweep.toml"):
        assert unidyn.datasets.path(name).read_bytes() == (ROOT / "examples" / name).read_bytes()


@pytest.mark.slow
@pytest.mark.parametrize("guide", GUIDES, ids=lambda g: g.stem)
def test_guide_blocks_run_from_an_empty_folder(guide, tmp_path):
    ws, outputs = run_guide(guide, tmp_path)
    check = NUMBERS.get(guide.stem)
    if check is not None:
        check(guide, ws, outputs)
