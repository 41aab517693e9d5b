"""bdsim's graphical editor, bdedit, for real: the ``bdedit`` command a user types
opens every shipped .bd file and stays open, and draws each block where the file
places it; started on Qt's offscreen platform (no display) in a subprocess, its
window holds every block and wire of each Fig. 2 file; a block dragged from its
palette with bdedit's defaults builds; ``unidyn edit`` opens with the whole diagram in
view; the screenshot script renders the loop."""

from __future__ import annotations

import inspect
import json
import math
import os
import re
import struct
import subprocess
import sys
import time
import warnings
from pathlib import Path

import numpy as np
import pytest

import unidyn  # noqa: F401  (BDSIMPATH for the subprocesses)
from processes import HAS_PROC, cpu_seconds
from unidyn.diagrams.bdfile import PAPER_FILES

ROOT = Path(__file__).resolve().parents[2]
BD_DIR = ROOT / "examples" / "bd"
ENV = dict(os.environ, QT_QPA_PLATFORM="offscreen", MPLBACKEND="Agg", BDSIMPATH="unidyn",
           PYTHONWARNINGS="ignore")


def _python(code: str, *args, timeout=240):
    return subprocess.run([sys.executable, "-c", code, *map(str, args)], capture_output=True,
                          text=True, timeout=timeout, env=ENV, cwd=ROOT)


@pytest.fixture(scope="module")
def qt():
    """Skip the module only when Qt cannot start at all."""
    proc = _python("from PySide6.QtWidgets import QApplication; app = QApplication(['t']); "
                   "print(app.platformName())", timeout=60)
    if proc.returncode != 0:
        tail = (proc.stderr or proc.stdout).strip().splitlines()[-1:] or ["?"]
        pytest.skip(f"Qt (PySide6, which bdsim 1.4's bdedit needs) cannot start here: {tail[0]}")
    assert proc.stdout.strip().splitlines()[-1] == "offscreen"


OPEN_FILES = r"""
import json, sys
import unidyn
from PySide6.QtWidgets import QApplication
from bdedit.interface_manager import InterfaceWindow
app = QApplication(["bdedit"])
window = InterfaceWindow(app.primaryScreen().availableGeometry())
scene = window.centralWidget().scene
scene.grScene.updateBackgroundMode("white", False)
result = {}
for path in sys.argv[1:]:
    window.loadFromFilePath(path)
    app.processEvents()
    blocks = [{"type": b.block_type, "title": b.title, "nin": len(b.inputs), "nout": len(b.outputs),
               "icon": b.icon, "params": {p[0]: p[2] for p in b.parameters}} for b in scene.blocks]
    wires = [[w.start_socket.node.title, w.start_socket.index, w.end_socket.node.title,
              w.end_socket.index] for w in scene.wires]
    result[path] = {"blocks": blocks, "wires": wires}
    window.centralWidget().scene.has_been_modified = False
print("RESULT " + json.dumps(result))
window.close()
"""


@pytest.mark.slow
def test_bdedit_opens_every_fig2_file(qt):
    """Each file in bdedit's scene: every block (type, title, ports, icon, parameters) and
    every wire, checked against the file and against bdload's diagram of it."""
    from bdsim.blockdiagram import bdload

    from unidyn.diagrams import new_simulator
    paths = [str(BD_DIR / name) for name in PAPER_FILES.values()]
    proc = _python(OPEN_FILES, *paths)
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert "unknown block types" not in proc.stderr, proc.stderr[-3000:]
    assert "dropping unresolvable wire" not in proc.stderr, proc.stderr[-3000:]
    line = next(s for s in proc.stdout.splitlines() if s.startswith("RESULT "))
    result = json.loads(line[len("RESULT "):])
    for path in paths:
        got = result[path]
        data = json.loads(Path(path).read_text())
        want_blocks = sorted((b["block_type"], b["title"], b["inputsNum"], b["outputsNum"])
                             for b in data["blocks"])
        assert sorted((b["type"], b["title"], b["nin"], b["nout"]) for b in got["blocks"]) == want_blocks
        # every unidyn block is drawn with its icon
        for b in got["blocks"]:
            if b["type"] not in ("DEMUX", "NULL"):
                assert Path(b["icon"]).is_file(), (b["type"], b["icon"])
        # parameters as the file holds them (bdedit drops parameters it does not know)
        for jb in data["blocks"]:
            gb = next(b for b in got["blocks"] if b["title"] == jb["title"])
            shown = {k: v for k, v in gb["params"].items() if k != "blockargs"}
            assert shown == {k: v for k, v in jb["parameters"]}, jb["title"]
        # the wires: the same connections bdload makes from the file
        sim = new_simulator()
        bd = sim.blockdiagram()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            bdload(bd, path)
        want_wires = sorted((w.start.block.name, w.start.port, w.end.block.name, w.end.port)
                            for w in bd.wirelist)
        assert sorted(map(tuple, got["wires"])) == want_wires
        assert len(want_wires) == len(data["wires"]) >= 8


PALETTE = r"""
import json, sys
import unidyn
from PySide6.QtWidgets import QApplication
from bdedit.block_importer import import_blocks
app = QApplication(["bdedit"])
out = {}
for group, blocks in import_blocks(None, None):
    for name, cls in blocks:
        if name in sys.argv[1:]:
            out[name] = {"nin": cls.inputsNum, "nout": cls.outputsNum,
                         "params": [[p[0], p[1].__name__, p[2]] for p in cls.parameters]}
print("RESULT " + json.dumps(out))
"""

FIXED = ["DYNAMICUNICYCLEWITHVELOCITY", "KINEMATICCONTROLLERWITHRATE",
         "DYNAMICCOMPENSATORWITHRATEINPUT", "SENSORNOISE"]


def _as_bdload(value):
    """A parameter value as bdload (bdsim.blockdiagram.bdload) turns it into an argument."""
    if not isinstance(value, str):
        return value
    ns = {"np": np, "math": math, "pi": math.pi}
    if value.startswith("="):
        return eval(value[1:], ns)
    try:
        return eval(value, ns)
    except (NameError, SyntaxError):
        return value


@pytest.mark.slow
def test_palette_blocks_build_with_bdedit_defaults(qt):
    """A fixed-port block dragged from bdedit's palette has the class's ports, and the
    defaults bdedit reads from its docstring build the block as bdload would."""
    from unidyn.diagrams import new_simulator
    proc = _python(PALETTE, *FIXED)
    assert proc.returncode == 0, proc.stderr[-3000:]
    line = next(s for s in proc.stdout.splitlines() if s.startswith("RESULT "))
    palette = json.loads(line[len("RESULT "):])
    assert sorted(palette) == sorted(FIXED)
    sim = new_simulator()
    bd = sim.blockdiagram()
    for name, info in palette.items():
        kwargs = {k: _as_bdload(v) for k, _, v in info["params"] if k != "blockargs"}
        block = getattr(bd, name)(**kwargs)
        assert (block.nin, block.nout) == (info["nin"], info["nout"]), name
        cls = type(block)
        # every default bdedit shows is the constructor's default
        for k, v in kwargs.items():
            default = inspect.signature(cls.__init__).parameters[k].default
            if v is None or default is None:
                assert v is default, (name, k, v, default)
            else:
                np.testing.assert_array_equal(np.asarray(v, dtype=float if not isinstance(v, str) else object),
                                              np.asarray(default, dtype=float if not isinstance(default, str) else object),
                                              err_msg=f"{name}.{k}")


def _png_size(path: Path):
    head = path.read_bytes()[:24]
    assert head[:8] == b"\x89PNG\r\n\x1a\n"
    return struct.unpack(">II", head[16:24])


@pytest.mark.slow
def test_screenshot_script_renders_the_loop(qt, tmp_path):
    proc = subprocess.run([sys.executable, str(ROOT / "tools" / "bdedit_screenshot.py"),
                           "--out", str(tmp_path), str(BD_DIR / PAPER_FILES[4])],
                          capture_output=True, text=True, timeout=240, env=ENV, cwd=ROOT)
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert "Traceback" not in proc.stderr, proc.stderr[-3000:]
    png = tmp_path / f"bdedit_{Path(PAPER_FILES[4]).stem}.png"
    assert _png_size(png) == (1600, 900)  # the window, at the size the script gives it
    # not blank: decode with matplotlib and count ink
    import matplotlib.image as mpimg
    img = mpimg.imread(png)
    dark = (img[..., :3].mean(axis=2) < 0.3).mean()
    assert 0.01 < dark < 0.5, dark


SHOWN = r"""
import json, sys
import unidyn
from PySide6.QtWidgets import QApplication
from unidyn.editor import open_window, show_whole_diagram
app = QApplication(["bdedit"])
out = {}
for path in sys.argv[1:]:
    window = open_window(path)
    window.show()
    show_whole_diagram(window, (1200, 700))
    app.processEvents()
    view = window.centralWidget().canvasView
    seen = view.mapToScene(view.viewport().rect()).boundingRect()
    blocks = [b.grBlock.sceneBoundingRect() for b in window.centralWidget().scene.blocks]
    out[path] = {"window": window.width(), "canvas": view.width(),
                 "inside": all(seen.contains(r) for r in blocks),
                 "widths": [[b.width, b.grBlock.boundingRect().width()]
                            for b in window.centralWidget().scene.blocks]}
    window.centralWidget().scene.has_been_modified = False
    window.close()
print("RESULT " + json.dumps(out))
"""


@pytest.mark.slow
def test_unidyn_edit_opens_with_the_whole_diagram_in_view(qt):
    """Not a strip of canvas beside an empty panel (bdedit keeps room for a parameter
    panel that is not shown), every block inside the visible part of the canvas, and
    each block drawn as wide as its file says (bdedit draws 100 px)."""
    paths = [str(p) for p in SHIPPED]
    proc = _python(SHOWN, *paths)
    assert proc.returncode == 0, proc.stderr[-3000:]
    got = json.loads(next(s for s in proc.stdout.splitlines()
                          if s.startswith("RESULT "))[len("RESULT "):])
    for path in paths:
        g = got[path]
        assert g["canvas"] > 0.6 * g["window"], (path, g)
        assert g["inside"], path
        assert all(w == drawn for w, drawn in g["widths"]), (path, g["widths"])
        assert any(w > 100 for w, _ in g["widths"]), path


BDEDIT = Path(sys.executable).with_name("bdedit")
SHIPPED = sorted(BD_DIR.glob("*.bd"))


@pytest.fixture(scope="module")
def bdedit_command(qt):
    if not BDEDIT.is_file():
        pytest.skip(f"no bdedit command beside {sys.executable}")
    return str(BDEDIT)


def test_void_qt_calls_keep_none_alive(qt):
    """The cause of bdedit's 'Fatal Python error: none_dealloc' under PySide6 6.12.0:
    every Qt method returning void handed Python a None it did not own, and on
    Python 3.11 None's reference count ran down to zero after a few thousand paints.
    Fails (rather than the editor aborting in a classroom) if the PySide6 that the
    pin in pyproject.toml admits does it again."""
    proc = _python("import sys\n"
                   "from PySide6.QtCore import QPointF\n"
                   "from PySide6.QtGui import QPainterPath\n"
                   "path = QPainterPath(QPointF(0, 0))\n"
                   "before = sys.getrefcount(None)\n"
                   "for i in range(500): path.lineTo(float(i), 1.0)\n"
                   "print(sys.getrefcount(None) - before)\n", timeout=60)
    assert proc.returncode == 0, proc.stderr[-2000:]
    # a few references come and go with the loop itself; the bug loses one per call
    assert abs(int(proc.stdout.split()[-1])) < 50, proc.stdout


@pytest.mark.slow
@pytest.mark.skipif(not HAS_PROC, reason="reads CPU time from /proc")
def test_bdedit_command_opens_a_shipped_file_and_stays_open(bdedit_command):
    """``bdedit FILE`` as a user types it, on the largest shipped file and with no file:
    each editor is still running after it has used 8 s of CPU time drawing its window
    (bdedit repaints continuously). Under PySide6 6.12.0 on Python 3.11 each aborted
    after 3.5-4.2 s of CPU time, whatever the file; counted in CPU time, the check does
    not depend on how busy the machine is. (Every shipped file is opened by the tests
    above and below.)"""
    largest = max(SHIPPED, key=lambda p: p.stat().st_size)
    runs = [[bdedit_command, str(largest)], [bdedit_command]]
    procs = [subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                              env=ENV, cwd=ROOT) for cmd in runs]
    try:
        deadline = time.monotonic() + 150
        while (time.monotonic() < deadline and all(p.poll() is None for p in procs)
               and min(cpu_seconds(p.pid) for p in procs) < 8):
            time.sleep(0.5)
        ended = [(cmd[1:], p.returncode) for cmd, p in zip(runs, procs) if p.poll() is not None]
    finally:
        for p in procs:
            if p.poll() is None:
                p.terminate()
        outputs = [p.communicate(timeout=30) for p in procs]
    errors = {" ".join(cmd[1:]) or "(no file)": err[-2000:] for cmd, (_, err) in zip(runs, outputs)
              if "Fatal Python error" in err or "Traceback" in err}
    assert not ended, (ended, [err[-2000:] for _, err in outputs])
    assert not errors, errors


def _svg_titles(svg: str) -> dict[str, tuple[float, float]]:
    """Each text drawn in an SVG export with the translation of the group holding it."""
    found = {}
    for m in re.finditer(r'<g [^>]*transform="matrix\(1,0,0,1,([-\d.e]+),([-\d.e]+)\)"[^>]*>\s*'
                         r'<text [^>]*>([^<]+)</text>', svg):
        found.setdefault(m.group(3).strip(), (float(m.group(1)), float(m.group(2))))
    return found


@pytest.mark.slow
@pytest.mark.parametrize("path", SHIPPED, ids=lambda p: p.name)
def test_bdedit_command_draws_each_block_where_the_file_places_it(bdedit_command, path, tmp_path):
    """``bdedit FILE -p OUT.svg`` (bdedit's own export, through the same start-up and
    painting as the editor window): every block's title is drawn, and the titles
    keep the file's layout (the offset from the file's coordinates is the same for
    every block, within the title's centring)."""
    svg_path = tmp_path / "diagram.svg"
    proc = subprocess.run([bdedit_command, str(path), "-p", str(svg_path)], capture_output=True,
                          text=True, timeout=240, env=ENV, cwd=ROOT)
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert "Fatal Python error" not in proc.stderr and "Traceback" not in proc.stderr, proc.stderr[-3000:]
    titles = _svg_titles(svg_path.read_text())
    blocks = json.loads(path.read_text())["blocks"]
    shown = [b for b in blocks if b["title"] in titles]
    assert len(shown) == len(blocks), sorted(set(b["title"] for b in blocks) - set(titles))
    offsets = np.array([np.subtract(titles[b["title"]], (b["pos_x"], b["pos_y"])) for b in shown])
    spread = np.abs(offsets - np.median(offsets, axis=0)).max(axis=0)
    # Blocks in the files stand at least 150 px apart. A title is centred on the block
    # (its length moves it by up to 50 px) and drawn below it, and bdedit draws a block
    # taller the more ports it has (up to 80 px lower).
    assert (spread < (50, 80)).all(), dict(zip((b["title"] for b in shown), offsets.tolist()))


SIM_TIME = r"""
import json, sys
from PySide6.QtWidgets import QApplication
from unidyn.editor import open_window
app = QApplication(["bdedit"])
out = {}
for path in sys.argv[1:]:
    window = open_window(path)
    app.processEvents()
    scene = window.centralWidget().scene
    out[path] = [window.simTimeBox.text(), sorted(b.title for b in scene.blocks)]
    scene.has_been_modified = False
    window.close()
print("RESULT " + json.dumps(out))
"""


@pytest.mark.slow
def test_unidyn_edit_window_shows_the_files_simulation_time_and_blocks(qt):
    paths = [str(p) for p in SHIPPED]
    proc = _python(SIM_TIME, *paths)
    assert proc.returncode == 0, proc.stderr[-3000:]
    line = next(s for s in proc.stdout.splitlines() if s.startswith("RESULT "))
    got = json.loads(line[len("RESULT "):])
    for path in paths:
        data = json.loads(Path(path).read_text())
        assert float(got[path][0]) == data["simulation_time"] != 10.0, (path, got[path])
        assert got[path][1] == sorted(b["title"] for b in data["blocks"]), path


@pytest.mark.slow
def test_unidyn_edit_runs_until_terminated(qt):
    """The command opens the editor and keeps it open; SIGTERM (and Ctrl-C) end it,
    although Python's own handlers never run inside Qt's event loop."""
    proc = subprocess.Popen([sys.executable, "-m", "unidyn", "edit", str(SHIPPED[0])],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=ENV,
                            cwd=ROOT)
    try:
        deadline = time.monotonic() + 120
        while time.monotonic() < deadline and proc.poll() is None and cpu_seconds(proc.pid) < 5:
            time.sleep(0.5)
        assert proc.poll() is None, proc.communicate()[1][-3000:]
        proc.terminate()
        _, err = proc.communicate(timeout=30)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()
    assert proc.returncode == -15, (proc.returncode, err[-3000:])
    assert "Traceback" not in err, err[-3000:]


@pytest.mark.parametrize("args, message", [
    (["notes.txt"], "FILE must be a .bd block-diagram file, got 'notes.txt'"),
    (["missing.bd"], "no such .bd file: missing.bd"),
])
def test_unidyn_edit_bad_file_is_one_line(args, message):
    proc = subprocess.run([sys.executable, "-m", "unidyn", "edit", *args], capture_output=True,
                          text=True, timeout=120, env=ENV, cwd=ROOT)
    assert proc.returncode == 2 and proc.stderr == f"unidyn: error: {message}\n", proc.stderr


def test_missing_qt_libraries_are_named_all_at_once(monkeypatch):
    """Qt aborts naming the first library it lacks; the editor command names each
    missing one and every package Qt's window system needs, in one line."""
    from unidyn._errors import MissingDependency
    from unidyn.editor import QT_XCB_PACKAGES, check_qt
    pytest.importorskip("PySide6")
    lacking = {"xcb-icccm", "xcb-keysyms"}
    monkeypatch.setattr(sys, "platform", "linux")
    monkeypatch.delenv("QT_QPA_PLATFORM", raising=False)
    with pytest.raises(MissingDependency) as info:
        check_qt(find_library=lambda name: None if name in lacking else f"lib{name}.so")
    text = str(info.value)
    assert "\n" not in text
    assert "missing (libxcb-icccm4 libxcb-keysyms1)" in text
    assert all(pkg in text for pkg in ("libxcb-cursor0", "libxcb-icccm4", "libxcb-keysyms1"))
    assert text.endswith("sudo apt-get install " + " ".join(QT_XCB_PACKAGES) + ")")
    # all there, or not using xcb: nothing to say
    check_qt(find_library=lambda name: f"lib{name}.so")
    monkeypatch.setenv("QT_QPA_PLATFORM", "offscreen")
    check_qt(find_library=lambda name: None)
