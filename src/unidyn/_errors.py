"""The exception types that the command line catches, in a module that imports
nothing heavy: the ``unidyn`` command loads it before numpy, so that its Ctrl-C
handling is in place from the start (see :func:`unidyn.cli.entry`)."""


class ValidationError(ValueError):
    """A parameter is missing, of the wrong kind or outside its allowed range."""


class NonFiniteSignalError(FloatingPointError):
    """A block received or produced NaN or infinity; the message says where and when."""


class MissingDependency(ImportError):
    """An optional dependency needed for the requested feature is not installed."""
