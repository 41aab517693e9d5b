"""Render the paper's Fig. 2 loop (simulation 4, adaptive compensation) as bdedit draws it.

    QT_QPA_PLATFORM=offscreen python tools/bdedit_screenshot.py [BD_FILE] [PNG_FILE]

Opens ``examples/bd/fig2_case4_adaptive.bd`` in bdedit's main window (Qt's
offscreen platform needs no display) and saves the scene, as bdedit's own
"export PNG" renders it, to ``docs/figures/bdedit_fig2.png``.

bdedit 1.4 reads each block's saved width but keeps drawing it 100 px wide, where
the port labels of blocks with labels on both sides overlap; the script applies
the saved widths (written by ``unidyn.teaching.bdfile``) before rendering.
"""

import os
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def _apply_saved_widths(scene):
    """Draw every block at the width the file gives it (bdedit keeps its default)."""
    for block in scene.blocks:
        gr = block.grBlock
        if getattr(gr, "width", block.width) != block.width:
            gr.prepareGeometryChange()
            gr.width = block.width
            for socket in block.inputs + block.outputs:
                socket.grSocket.setPos(*map(float, block.getSocketPosition(socket.index,
                                                                           socket.position)))
            block.updateConnectedEdges()


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    bd_file = Path(argv[0]) if argv else ROOT / "examples" / "bd" / "fig2_case4_adaptive.bd"
    png = Path(argv[1]) if len(argv) > 1 else ROOT / "docs" / "figures" / "bdedit_fig2.png"
    os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")
    import unidyn  # noqa: F401  (puts unidyn's blocks on bdsim's BDSIMPATH for bdedit's palette)
    from PySide6.QtWidgets import QApplication

    from bdedit.interface_manager import InterfaceWindow

    app = QApplication.instance() or QApplication(["bdedit"])
    window = InterfaceWindow(app.primaryScreen().availableGeometry())
    interface = window.centralWidget()
    # what bdedit's own start-up does (bdedit.bdedit.main) before loading a file
    interface.scene.block_name_fontsize = 12
    interface.scene.grScene.updateBackgroundMode("white", False)
    window.loadFromFilePath(str(bd_file))
    scene = interface.scene
    if not scene.blocks:
        raise SystemExit(f"bdedit loaded no blocks from {bd_file}")
    _apply_saved_widths(scene)
    app.processEvents()
    png.parent.mkdir(parents=True, exist_ok=True)
    interface.save_image(str(png), picture_name="")
    window.close()
    print(png)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
