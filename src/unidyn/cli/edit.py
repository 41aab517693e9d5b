"""``unidyn edit``: open a .bd file in bdsim's editor, bdedit, with unidyn's blocks."""

from __future__ import annotations

from ..editor import edit


def unidyn_edit(args) -> int:
    """``unidyn edit FILE.bd``: the editor's exit status."""
    return edit(args.file)
