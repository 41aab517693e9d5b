"""For teaching and exploring: animations (:mod:`~unidyn.teaching.animation`),
notebook sliders (:mod:`~unidyn.teaching.widgets`) and the bridge to python-control
(:mod:`~unidyn.teaching.iosys`), the loop as linear systems for Bode plots and root
loci. bdedit's ``.bd`` files are written by :mod:`unidyn.diagrams.bdfile`."""
