"""The batch engine: many runs of the Fig. 2 loop integrated at once
(:func:`~unidyn.simulate_batch`, :mod:`~unidyn.engine.batch`).

:mod:`~unidyn.engine.batch` runs a call and reads the results; :mod:`~unidyn.engine.kernels`
holds the step rule, an error-controlled Dormand-Prince method, compiled by numba where
installed and also run as plain Python (:mod:`~unidyn.compiled`);
:mod:`~unidyn.model.closed_loop` the loop's right-hand side on arrays of runs, which the converged
references integrate with scipy's ``solve_ivp``.

Which of the two engines, this one or the bdsim diagram of :mod:`unidyn.diagrams`, runs
a scenario is chosen above both, in :mod:`unidyn.engines` (:func:`unidyn.run`)."""
