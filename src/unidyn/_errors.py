"""The exception types that the command line catches, in a module that imports
nothing heavy: the ``unidyn`` command loads it before numpy, so that its Ctrl-C
handling is in place from the start (see :mod:`unidyn.process`)."""


class ValidationError(ValueError):
    """A parameter is missing, of the wrong kind or outside its allowed range."""


class NonFiniteSignalError(FloatingPointError):
    """A block received or produced NaN or infinity; the message says where and when."""


class MissingDependency(ImportError):
    """An optional dependency needed for the requested feature is not installed."""


class Interrupted(KeyboardInterrupt):
    """Ctrl-C (or ``kill``, which the ``unidyn`` command turns into Ctrl-C) stopped a
    job that says what it left behind.

    Attributes:
        kept: one sentence on what is in the output folder now, e.g. "3 of 8 points
            are in out/metrics.csv; run the same command again to resume" (the
            command line prints it after "interrupted: ").
    """

    def __init__(self, kept: str):
        super().__init__(kept)
        self.kept = kept
