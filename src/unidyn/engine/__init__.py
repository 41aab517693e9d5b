"""The batch engine: many runs of the Fig. 2 loop integrated at once
(:func:`~unidyn.simulate_batch`, :mod:`~unidyn.engine.batch`).

:mod:`~unidyn.engine.batch` sets the steps, groups the runs and reads the results,
and holds the numpy backend's step rule; :mod:`~unidyn.engine.kernels` the compiled
one (numba), :mod:`~unidyn.engine.jit` numba's cache and compile notice,
:mod:`~unidyn.engine.vecmath` the compiled sin, cos and tanh;
:mod:`~unidyn.engine.rhs` the loop's right-hand side on arrays of runs (the numpy
backend's, and the one the references integrate with scipy's ``solve_ivp``)."""
