"""Where a subcommand writes and how it says so: ``--out`` checked before any work
(a folder, holding no other kind of results), the folder the results went to as the
user named it, names shortened for a line."""

from __future__ import annotations

import importlib
from pathlib import Path

from ..results.folders import Ledger, list_files, output_folder
from .errors import UsageError

#: The kinds of results the command writes into an --out folder, by the name of their
#: manifest (``.unidyn-<kind>.json``): how they are called, and where their file names
#: are (loaded only for a folder that has that manifest).
RESULT_KINDS = {
    "run": ("a run", "unidyn.results.result", "RUN_FILES"),
    "seeds": ("seed runs", "unidyn.sweeps.seeds", "SEED_FILES"),
    "experiment": ("the paper's experiment", "unidyn.paper", "EXPERIMENT_FILES"),
    "sweep": ("a sweep", "unidyn.sweeps.sweep", "SWEEP_FILES"),
}


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


def refuse_other_results(out: Path, kind: str) -> None:
    """One line, before any work, when ``out`` holds results of a kind other than
    ``kind`` (a key of :data:`RESULT_KINDS`): a sweep is not written into a run's
    folder, nor a run into a sweep's. A folder holds a kind when that kind's manifest
    vouches, by content, for a file in it (:class:`~unidyn.results.folders.Ledger`)."""
    folder = output_folder(out)
    if not folder.is_dir():
        return
    for other, (what, module, attribute) in RESULT_KINDS.items():
        if other == kind or not (folder / f".unidyn-{other}.json").exists():
            continue
        held, _ = Ledger(folder, other, getattr(importlib.import_module(module),
                                                attribute)).sort()
        if held:
            raise UsageError(f"{out} holds {what} ({list_files(held)}); choose "
                             f"another --out for {RESULT_KINDS[kind][0]}")
