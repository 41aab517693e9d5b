"""Make unidyn's blocks discoverable by bdsim's block loader.

bdsim 1.4 builds its block library once per process, the first time
``bdsim.BDSim()`` is created, by scanning ``<entry>/<package>/blocks/`` for each
entry of ``sys.path`` and each package named in the ``BDSIMPATH`` environment
variable. Every install of unidyn, regular or editable (``pip install .`` or
``pip install -e .``), ships ``unidyn-bdsim.pth``, which adds ``unidyn`` to
``BDSIMPATH`` when Python starts: the blocks are then found whether or not
``unidyn`` was imported, in any import order, by ``bdrun`` and ``bdedit`` too.

:func:`register`, run on ``import unidyn``, does the same for a checkout used
without installing it (its ``src/`` folder on ``PYTHONPATH``); there, ``import
unidyn`` has to come before the first ``bdsim.BDSim()``. It changes this process's
``BDSIMPATH`` only (child processes inherit it).
"""

from __future__ import annotations

import os

PACKAGE = "unidyn"


def register() -> None:
    """Add ``unidyn`` to ``BDSIMPATH`` if it is not there; idempotent and cheap."""
    paths = [p for p in os.environ.get("BDSIMPATH", "").split(":") if p]
    if PACKAGE not in paths:
        os.environ["BDSIMPATH"] = ":".join(paths + [PACKAGE])
