"""For teaching and exploring: animations (:mod:`~unidyn.teaching.animation`),
notebook sliders (:mod:`~unidyn.teaching.widgets`), bdedit's ``.bd`` files
(:mod:`~unidyn.teaching.bdfile`) and the bridge to python-control
(:mod:`~unidyn.teaching.iosys`)."""
