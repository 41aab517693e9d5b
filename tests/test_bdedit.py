"""bdsim's graphical editor, bdedit, for real: started on Qt's offscreen platform (no
display) in a subprocess, it opens each Fig. 2 .bd file and holds every block and
wire; a block dragged from its palette with bdedit's defaults builds; the README's
screenshot script renders the loop."""

from __future__ import annotations

import inspect
import json
import math
import os
import struct
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

import unidyn  # noqa: F401  (BDSIMPATH for the subprocesses)
from unidyn.bdfile import PAPER_FILES

ROOT = Path(__file__).resolve().parents[1]
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


def test_screenshot_script_renders_the_loop(qt, tmp_path):
    png = tmp_path / "fig2.png"
    proc = subprocess.run([sys.executable, str(ROOT / "tools" / "bdedit_screenshot.py"),
                           str(BD_DIR / PAPER_FILES[4]), str(png)],
                          capture_output=True, text=True, timeout=240, env=ENV, cwd=ROOT)
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert "Traceback" not in proc.stderr, proc.stderr[-3000:]
    w, h = _png_size(png)
    assert w > 2000 and h > 1000       # the whole loop, at bdedit's 3x export resolution
    # not blank: decode with matplotlib and count ink
    import matplotlib.image as mpimg
    img = mpimg.imread(png)
    dark = (img[..., :3].mean(axis=2) < 0.3).mean()
    assert 0.01 < dark < 0.5, dark
