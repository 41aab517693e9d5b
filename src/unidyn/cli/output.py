"""Where a subcommand writes and how it says so: ``--out`` checked before any work,
the folder the results went to as the user named it, names shortened for a line."""

from __future__ import annotations

from pathlib import Path

from ..results.folders import output_folder


def out_folder(text: str) -> Path:
    """--out as given, once it is known to name a folder (or nothing yet)."""
    output_folder(text)  # one line for an empty --out or a file
    return Path(text)


def shown(out: Path, final) -> Path:
    """Where results went, as the user named it: ``out`` when they went there (its
    link's target, for a symbolic link), else the folder's full path."""
    return out if Path(final) == output_folder(out) else Path(final)


def short_name(name: str, limit: int = 80) -> str:
    """A scenario's or sweep's name for one line: at most ``limit`` characters."""
    return name if len(name) <= limit else name[:limit - 3] + "..."
