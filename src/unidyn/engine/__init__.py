"""The batch engine: many runs of the Fig. 2 loop integrated at once
(:func:`~unidyn.simulate_batch`, :mod:`~unidyn.engine.batch`).

:mod:`~unidyn.engine.batch` chooses the steps and reads the results;
:mod:`~unidyn.engine.kernels` holds the step rule, RK4, once, compiled by numba where it
is installed and also run as plain Python (:mod:`~unidyn.engine.jit`: numba's cache, the
compile notice and the plain copy); :mod:`~unidyn.engine.vecmath` the compiled sin, cos
and tanh; :mod:`~unidyn.engine.rhs` the loop's right-hand side on arrays of runs, which
the references integrate with scipy's ``solve_ivp``."""
