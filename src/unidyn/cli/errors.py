"""The ``unidyn`` command's own errors, and how every error is told: one line on
stderr, ``unidyn: error: ...``, in the command's words (its flags, not the library's
keyword arguments)."""

from __future__ import annotations

import re
import sys


class UsageError(Exception):
    """A command-line usage error (reported on one line, exit status 2)."""


class RunFailed(Exception):
    """A run that produced nothing to write (one line, exit status 1)."""


#: An error message's words longer than this are shortened (a 1 MB value named in a
#: message would bury what the message says).
LONGEST_WORD = 120


def _shorten(word: str) -> str:
    if len(word) <= LONGEST_WORD:
        return word
    return f"{word[:60]}...[{len(word)} characters]...{word[-20:]}"


def flag_words(message: str) -> str:
    """The library's keyword arguments in a message about output folders, as flags."""
    for lib, cli in (("overwrite=True", "--overwrite"), ("resume=False", "--no-resume"),
                     ("yes=True", "--yes"), ("dask_address=", "--dask ")):
        message = message.replace(lib, cli)
    return re.sub(r"\bout_dir\b", "--out", message)


def report(message) -> None:
    """``message`` on stderr as one readable line, ``unidyn: error: ...``."""
    message = " ".join(_shorten(w) for w in str(message).split())
    print(f"unidyn: error: {message}", file=sys.stderr)


def show_warning(message, category, filename, lineno, file=None, line=None):
    """A warning as the command's other messages: one line on stderr (the
    ``warnings.showwarning`` hook)."""
    print(f"unidyn: warning: {' '.join(str(message).split())}", file=sys.stderr)
