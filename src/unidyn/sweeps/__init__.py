"""Sweeps: many scenarios from one definition (:class:`~unidyn.sweeps.sweep.Sweep`,
``unidyn sweep``), their files (:mod:`~unidyn.sweeps.sweep_files`: scenario and sweep
TOML files, a sweep folder's record and ``metrics.csv``), their figure
(:mod:`~unidyn.sweeps.plots`) and a Dask cluster to run them on
(:mod:`~unidyn.sweeps.cluster`)."""
