"""Make unidyn's blocks discoverable by bdsim's block loader.

bdsim 1.4 builds its block library once per process, the first time
``bdsim.BDSim()`` is created, by scanning ``<entry>/<package>/blocks/`` for each
entry of ``sys.path`` and each package named in the ``BDSIMPATH`` environment
variable. A regular install ships ``unidyn-bdsim.pth``, which adds ``unidyn`` to
``BDSIMPATH`` at interpreter start-up. An editable install puts the checkout's
``src/`` folder on ``sys.path``, where ``unidyn/blocks`` is found, but ships no
``.pth`` hook; :func:`register`, run on ``import unidyn``, then does what the hook
does. It changes this process only:

- ``os.environ["BDSIMPATH"]`` gets ``unidyn`` appended (child processes inherit it);
- if no ``sys.path`` entry holds ``unidyn/blocks`` (an unusual install), the folder
  holding the imported package is appended to ``sys.path``;
- a block library that bdsim built before ``import unidyn`` without unidyn's
  blocks is dropped, so that the next ``bdsim.BDSim()`` builds it again.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

PACKAGE = "unidyn"


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
        home = str(Path(__file__).resolve().parents[1])
        if home not in sys.path:
            sys.path.append(home)
    # bdsim caches its library per process: drop a cache built without us.
    bdsim_run = sys.modules.get("bdsim.run_sim")
    if bdsim_run is not None:
        lib = getattr(bdsim_run.BDSim, "_blocklibrary", None)
        if lib is not None and "DYNAMICUNICYCLE" not in lib:
            bdsim_run.BDSim._blocklibrary = None
