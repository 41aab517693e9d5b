"""For teaching and exploring: animations (:mod:`~unidyn.teaching.animation`),
notebook sliders (:mod:`~unidyn.teaching.widgets`) and the bridge to python-control
(:mod:`~unidyn.teaching.iosys`), the loop as linear systems for Bode plots and root
loci. bdedit's ``.bd`` files are written by :mod:`unidyn.diagrams.bdfile`."""

import importlib
import warnings


def __getattr__(name):
    # ``from unidyn.teaching import bdfile``, as earlier versions placed it, keeps working
    if name == "bdfile":
        warnings.warn("unidyn.teaching.bdfile is unidyn.diagrams.bdfile: "
                      "from unidyn.diagrams import bdfile", DeprecationWarning, stacklevel=2)
        return importlib.import_module("unidyn.diagrams.bdfile")
    raise AttributeError(f"module 'unidyn.teaching' has no attribute {name!r}")
