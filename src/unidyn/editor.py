"""Open a block-diagram file in bdsim's graphical editor, bdedit (``unidyn edit FILE.bd``).

What this adds to typing ``bdedit FILE.bd``:

- before Qt starts, a check that the system libraries Qt's X11 platform plugin
  (xcb) needs are there; Qt itself aborts naming only the first one missing, this
  names every one (:data:`QT_XCB_PACKAGES`, Debian's package names);
- the simulation-time box shows the file's simulation time. ``bdedit FILE`` loads
  the file through ``InterfaceWindow.loadFromFilePath``, which leaves the box at its
  default of 10 s (bdedit 1.4), while bdedit's File > Open menu sets it from the
  file; here the box is set as that menu does;
- the window opens on most of the screen with the whole diagram in view, its blocks
  drawn at the widths the file gives them (:func:`show_whole_diagram`);
- bdsim's notice "package ... not loaded" for each of its toolboxes that is not
  installed, printed each time bdedit starts a simulator, is not shown
  (:func:`quiet_toolboxes`).

unidyn's blocks are in the palette as they are for ``bdedit`` itself: every install
ships the start-up hook that names ``unidyn`` in ``BDSIMPATH`` (see
:mod:`unidyn._bdsim_path`), and importing unidyn adds it for a checkout used
without installing.
"""

from __future__ import annotations

import ctypes.util
import importlib.util
import os
import signal
import sys
from pathlib import Path

from ._errors import MissingDependency, ValidationError

#: Debian/Ubuntu packages of the system libraries that Qt 6's xcb platform plugin
#: (the one that opens windows on X11) loads, with the library names ``ctypes``
#: looks for. The first three are the ones a desktop usually lacks.
QT_XCB_PACKAGES = {
    "libxcb-cursor0": "xcb-cursor",
    "libxcb-icccm4": "xcb-icccm",
    "libxcb-keysyms1": "xcb-keysyms",
    "libxcb-image0": "xcb-image",
    "libxcb-render-util0": "xcb-render-util",
    "libxcb-shape0": "xcb-shape",
    "libxcb-randr0": "xcb-randr",
    "libxcb-xkb1": "xcb-xkb",
    "libxkbcommon-x11-0": "xkbcommon-x11",
    "libegl1": "EGL",
    "libfontconfig1": "fontconfig",
}


#: The toolboxes whose blocks bdsim looks for when it starts (``BDSim(toolboxes=True)``,
#: bdsim 1.2's default, as bdedit creates it).
TOOLBOXES = ("roboticstoolbox", "machinevisiontoolbox")


def quiet_toolboxes(environ=os.environ) -> None:
    """bdsim's own switch, ``BDSIM_NO_TOOLBOXES=1`` (its ``--help`` documents it), set in
    ``environ`` (this process's environment) unless the user set it: bdsim then looks
    for no toolbox, and prints no "package ... not loaded: not found" for each one that
    is not installed. The installed toolboxes are named in ``BDSIMPATH`` instead, so that
    their blocks stay in the palette."""
    if "BDSIM_NO_TOOLBOXES" in environ:
        return
    installed = [p for p in TOOLBOXES if importlib.util.find_spec(p) is not None]
    environ["BDSIM_NO_TOOLBOXES"] = "1"
    if installed:
        environ["BDSIMPATH"] = ":".join(filter(None, [environ.get("BDSIMPATH"), *installed]))


def missing_qt_packages(find_library=ctypes.util.find_library) -> list[str]:
    """The packages of :data:`QT_XCB_PACKAGES` whose library is not found, when Qt is
    going to use its xcb plugin (Linux, ``QT_QPA_PLATFORM`` unset or ``xcb``)."""
    platform = os.environ.get("QT_QPA_PLATFORM", "")
    if not sys.platform.startswith("linux") or platform.split(":")[0] not in ("", "xcb"):
        return []
    return [pkg for pkg, lib in QT_XCB_PACKAGES.items() if find_library(lib) is None]


def check_qt(find_library=ctypes.util.find_library) -> None:
    """Raise :class:`MissingDependency` with one line naming what Qt lacks."""
    try:
        import bdedit  # noqa: F401
        import PySide6  # noqa: F401
    except ImportError as err:
        raise MissingDependency(f"the editor needs {err.name}, which is not installed: "
                                "pip install 'unidyn[teach]'") from None
    missing = missing_qt_packages(find_library)
    if missing:
        raise MissingDependency(
            f"Qt cannot open a window: system libraries missing ({' '.join(missing)}); Qt "
            f"needs all of: {' '.join(QT_XCB_PACKAGES)} (Debian/Ubuntu: sudo apt-get "
            f"install {' '.join(QT_XCB_PACKAGES)})")


def open_window(path: str | os.PathLike):
    """bdedit's main window with ``path`` loaded, as ``bdedit FILE`` builds it, and
    the simulation-time box showing the file's time. Needs a running QApplication."""
    from bdedit.interface_manager import InterfaceWindow
    from PySide6.QtWidgets import QApplication

    app = QApplication.instance()
    window = InterfaceWindow(app.primaryScreen().availableGeometry())
    scene = window.centralWidget().scene
    # what bdedit's start-up does with its default options (bdedit.bdedit.main)
    scene.block_name_fontsize = 12
    scene.grScene.updateBackgroundMode("grey", True)
    window.loadFromFilePath(str(path))
    # what bdedit's File > Open does after loading, and its command line does not
    window.runButtonParameters["SimTime"] = scene.sim_time
    window.simTimeBox.setText(str(scene.sim_time))
    _draw_saved_widths(scene)
    # bdedit reserves the width of a block's parameter panel (column 10 of the window's
    # grid) for every block it loads, and keeps it while no panel is shown: the canvas
    # is then squeezed to a strip. No panel is open after loading.
    window.centralWidget().layout.setColumnMinimumWidth(10, 0)
    return window


def _draw_saved_widths(scene) -> None:
    """Draw every block at the width its file gives it: bdedit 1.4 reads the width but
    its graphics item keeps the default of 100 px it was created with, where port
    labels on both sides overlap (tests/teaching/test_bdedit.py fails if that changes)."""
    for block in scene.blocks:
        gr = block.grBlock
        if getattr(gr, "width", block.width) != block.width:
            gr.prepareGeometryChange()
            gr.width = block.width
            for socket in block.inputs + block.outputs:
                socket.grSocket.setPos(*map(float, block.getSocketPosition(socket.index,
                                                                           socket.position)))
            block.updateConnectedEdges()


def show_whole_diagram(window, size=None) -> None:
    """Size ``window`` (``size`` = (width, height) in px; by default 85 % of the
    screen) and zoom its canvas so the whole diagram is in view, with a margin (Qt's
    ``QGraphicsView.fitInView``)."""
    from PySide6.QtCore import Qt
    from PySide6.QtWidgets import QApplication

    app = QApplication.instance()
    if size is None:
        screen = app.primaryScreen().availableGeometry()
        size = (int(0.85 * screen.width()), int(0.85 * screen.height()))
    window.resize(*size)
    app.processEvents()  # the canvas takes its size before it is zoomed to it
    interface = window.centralWidget()
    items = interface.scene.grScene.itemsBoundingRect()
    margin = 0.05 * max(items.width(), items.height())
    interface.canvasView.fitInView(items.adjusted(-margin, -margin, margin, margin),
                                   Qt.AspectRatioMode.KeepAspectRatio)


def edit(path: str | os.PathLike) -> int:
    """Open ``path`` (a .bd file) in bdedit and run the editor until it is closed."""
    path = Path(path)
    if path.suffix != ".bd":
        raise ValidationError(f"FILE must be a .bd block-diagram file, got {str(path)!r}")
    if not path.is_file():
        raise FileNotFoundError(f"no such .bd file: {path}")
    check_qt()
    quiet_toolboxes()  # before bdedit starts a simulator to fill its palette
    from PySide6.QtWidgets import QApplication

    app = QApplication.instance() or QApplication(["bdedit"])
    app.setApplicationName("bdedit")
    window = open_window(path)
    window.show()
    show_whole_diagram(window)
    # Python runs its signal handlers only between bytecodes, never while Qt's event
    # loop runs: with the default actions, Ctrl-C and SIGTERM end the editor as they
    # end any program
    signal.signal(signal.SIGINT, signal.SIG_DFL)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    event_loop = app.exec  # Qt's event loop (QApplication.exec), runs until the window closes
    return event_loop()
