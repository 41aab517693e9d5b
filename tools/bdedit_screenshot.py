"""Screenshots of ``unidyn edit`` on each of the paper's Fig. 2 files, as a user sees it.

    xvfb-run -s "-screen 0 1920x1080x24" python tools/bdedit_screenshot.py [BD_FILE ...]

Opens each ``.bd`` file (default: every file in ``examples/bd/``) in bdedit's main
window as ``unidyn edit`` does (:func:`unidyn.editor.open_window`, then
:func:`unidyn.editor.show_whole_diagram` at 1600 x 900 px), and saves the window as it
is drawn on the screen to ``docs/figures/bdedit_<name>.png``. Under Xvfb (above) Qt
draws with its X11 platform, as on a desktop; without a display it falls back to Qt's
offscreen platform, which draws the same window without the desktop's fonts.
"""

import os
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SIZE = (1600, 900)


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    out_dir = ROOT / "docs" / "figures"
    if argv[:1] == ["--out"]:
        out_dir, argv = Path(argv[1]), argv[2:]
    files = [Path(a) for a in argv] or sorted((ROOT / "examples" / "bd").glob("*.bd"))
    if not os.environ.get("DISPLAY") and not os.environ.get("QT_QPA_PLATFORM"):
        os.environ["QT_QPA_PLATFORM"] = "offscreen"
    import unidyn  # noqa: F401  (puts unidyn's blocks on bdsim's BDSIMPATH for the palette)
    from PySide6.QtWidgets import QApplication

    from unidyn.editor import open_window, show_whole_diagram

    app = QApplication.instance() or QApplication(["bdedit"])
    out_dir.mkdir(parents=True, exist_ok=True)
    for bd_file in files:
        window = open_window(bd_file)
        if not window.centralWidget().scene.blocks:
            raise SystemExit(f"bdedit loaded no blocks from {bd_file}")
        window.show()
        show_whole_diagram(window, SIZE)
        for _ in range(10):
            app.processEvents()
        png = out_dir / f"bdedit_{bd_file.stem}.png"
        if not window.grab().save(str(png)):
            raise SystemExit(f"could not write {png}")
        window.centralWidget().scene.has_been_modified = False  # closes without asking
        window.close()
        print(png)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
