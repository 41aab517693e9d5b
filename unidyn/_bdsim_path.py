"""Make unidyn's blocks discoverable by bdsim's block loader.

bdsim 1.4 builds its block library once per process, the first time
``bdsim.BDSim()`` is created, by scanning ``<entry>/<package>/blocks/`` for each
entry of ``sys.path`` and each package named in the ``BDSIMPATH`` environment
variable. A regular install ships ``unidyn-bdsim.pth``, which adds ``unidyn`` to
``BDSIMPATH`` at interpreter start-up. An editable install maps the top-level
``blocks/`` folder onto ``unidyn.blocks`` with an import hook, so there is no
``unidyn/blocks`` folder to scan; :func:`register` then adds a small folder
holding a ``unidyn/blocks`` link to the real one. It runs on ``import unidyn``.
"""

from __future__ import annotations

import hashlib
import os
import sys
import tempfile
from pathlib import Path

PACKAGE = "unidyn"


def blocks_dir() -> Path:
    """The folder holding unidyn's block modules."""
    import importlib.util
    spec = importlib.util.find_spec(f"{PACKAGE}.blocks")
    return Path(list(spec.submodule_search_locations)[0]).resolve()


def _discoverable() -> bool:
    for entry in sys.path:
        if entry and (Path(entry) / PACKAGE / "blocks" / "__init__.py").is_file():
            return True
    return False


def register() -> None:
    """Ensure bdsim's loader finds ``unidyn.blocks``; idempotent and cheap."""
    paths = [p for p in os.environ.get("BDSIMPATH", "").split(":") if p]
    if PACKAGE not in paths:
        os.environ["BDSIMPATH"] = ":".join(paths + [PACKAGE])
    if not _discoverable():
        target = blocks_dir()
        tag = hashlib.sha1(str(target).encode()).hexdigest()[:12]
        shim = Path(tempfile.gettempdir()) / f"unidyn-bdsim-{tag}"
        link = shim / PACKAGE / "blocks"
        try:
            link.parent.mkdir(parents=True, exist_ok=True)
            if not link.exists():
                try:
                    os.symlink(target, link, target_is_directory=True)
                except FileExistsError:
                    pass
        except OSError as err:  # pragma: no cover - exotic file systems
            import warnings
            warnings.warn(f"unidyn: cannot make blocks visible to bdsim ({err}); "
                          f"set BDSIMPATH and install unidyn without -e", RuntimeWarning)
            return
        sys.path.append(str(shim))
    # bdsim caches its library per process: drop a cache built without us.
    bdsim_run = sys.modules.get("bdsim.run_sim")
    if bdsim_run is not None:
        lib = getattr(bdsim_run.BDSim, "_blocklibrary", None)
        if lib is not None and "DYNAMICUNICYCLE" not in lib:
            bdsim_run.BDSim._blocklibrary = None
