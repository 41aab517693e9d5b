"""The exception types that the command line catches, in a module that imports
nothing heavy: the ``unidyn`` command loads it before numpy, so that its Ctrl-C
handling is in place from the start (see :mod:`unidyn.process`).

Each is public as ``unidyn.<Name>`` (``unidyn.ValidationError``), and says so: its
``__module__`` is ``unidyn``, so that a traceback and ``repr`` name it where a user
imports it from (:data:`PUBLIC`, set at the end of this module)."""


class ValidationError(ValueError):
    """A parameter is missing, of the wrong kind or outside its allowed range."""


class NonFiniteSignalError(FloatingPointError):
    """A block received or produced NaN or infinity; the message says where and when."""


class AccuracyWarning(UserWarning):
    """A run finished, but the engine that ran it cannot vouch for its accuracy;
    the message names the cause and what to change."""


class MissingDependency(ImportError):
    """An optional dependency needed for the requested feature is not installed."""


class SimulationError(RuntimeError):
    """A run stopped early (e.g. a non-finite signal). ``result`` holds what was
    computed up to the failure, marked ``complete=False``; the message says when,
    where and for which scenario."""

    def __init__(self, message, result=None):
        super().__init__(message)
        self.result = result


class SimulationInterrupted(KeyboardInterrupt):
    """A run (or batch of runs) stopped by Ctrl-C. ``result`` is the computed part
    of the (first) run, ``results`` that of every run (``None`` for a run not yet
    started), each marked ``complete=False``."""

    def __init__(self, message, result=None, results=None):
        super().__init__(message)
        self.results = list(results) if results is not None else [result]
        self.result = result if result is not None else next(
            (r for r in self.results if r is not None), None)


class Interrupted(KeyboardInterrupt):
    """Ctrl-C (or ``kill``, which the ``unidyn`` command turns into Ctrl-C) stopped a
    job that says what it left behind: ``kept`` is one sentence on what is in the
    output folder now, e.g. "3 of 8 points are in out/metrics.csv; run the same
    command again to resume" (the command line prints it after "interrupted: ")."""

    def __init__(self, kept: str):
        super().__init__(kept)
        self.kept = kept


#: The exception and warning types above, each shown and importable as ``unidyn.<Name>``.
PUBLIC = (ValidationError, NonFiniteSignalError, AccuracyWarning, MissingDependency,
          SimulationError, SimulationInterrupted, Interrupted)
for _cls in PUBLIC:
    _cls.__module__ = "unidyn"
del _cls
