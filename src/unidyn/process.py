"""How the ``unidyn`` command's process meets Ctrl-C and ``kill``, and how it ends.

Everything about signals and exit status of the command line is here; the rest of
the package only raises (:class:`unidyn._errors.Interrupted` says what an interrupted
job kept) and returns.

- :func:`command_signals`: while a command runs, SIGTERM (``kill``) stops it as
  Ctrl-C (SIGINT) does, with a KeyboardInterrupt, so that it cleans up the same way;
  an interrupt lost in a finaliser is sent again.
- :func:`interrupt_status`: the one line said on Ctrl-C or ``kill`` (with what was
  kept) and the status, 130 or 143.
- :func:`prepare_end` and :func:`end`: a process stopped by SIGINT or SIGTERM ends
  BY that signal, after Python's exit handlers ran and its output was flushed. A
  shell then sees status 130 or 143 and, unlike for a plain ``exit(130)``, stops the
  loop or script that ran the command (bash takes a plain exit as "the command
  handled Ctrl-C" and goes on). Not on Windows, which has no death by signal to
  report: the status says it there.

This module imports only the standard library, so that the command has its Ctrl-C
handling in place before numpy, numba or bdsim load.
"""

from __future__ import annotations

import atexit
import contextlib
import os
import signal
import sys
import threading

from ._errors import Interrupted

__all__ = ["INTERRUPTED", "TERMINATED", "command_signals", "interrupt_status",
           "prepare_end", "end", "run_command", "finishes_on_sigterm"]

#: Exit status of a command stopped by Ctrl-C (128 + SIGINT).
INTERRUPTED = 128 + 2
#: Exit status of a command stopped by ``kill`` (128 + SIGTERM).
TERMINATED = 128 + 15

# which signals arrived while command_signals was in force
_received: set = set()
# the signal the process is to end by (set by end, read by the exit handler)
_ending: list = []
_prepared: list = []


def _on_signal(signum, frame):
    _received.add(signum)
    raise KeyboardInterrupt


def finishes_on_sigterm(handler) -> bool:
    """Whether ``handler`` is the command's SIGTERM handler, which reports a command
    whose results are in place as finished: a SIGTERM held back while results were
    moved into place is then dropped rather than delivered (see
    :func:`unidyn.results.folders.staged_output`)."""
    return handler is _on_signal


def _unraisable(hook):
    """A Ctrl-C (or SIGTERM) that lands in a finaliser or a weak reference's callback
    cannot be raised there (Python prints "Exception ignored in ..." and goes on, the
    interrupt lost): send it again, so that it stops the command where it can."""
    if isinstance(hook.exc_value, KeyboardInterrupt):
        # from another thread, a moment later: raised here, it would land in this hook again
        sig = signal.SIGTERM if signal.SIGTERM in _received else signal.SIGINT
        timer = threading.Timer(0.01, os.kill, (os.getpid(), sig))
        timer.daemon = True
        timer.start()
    else:
        sys.__unraisablehook__(hook)


@contextlib.contextmanager
def command_signals():
    """Run a command with the command line's signal handling: SIGTERM, and Ctrl-C
    unless it is ignored, raise KeyboardInterrupt; an interrupt lost in a finaliser is
    sent again. The handlers and the unraisable hook found are restored after, so
    that a script or a notebook can run a command in its own process. Outside the main
    thread (where Python cannot set signal handlers) nothing changes."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    _received.clear()
    found = {sig: signal.getsignal(sig) for sig in (signal.SIGINT, signal.SIGTERM)}
    hook = sys.unraisablehook
    signal.signal(signal.SIGTERM, _on_signal)
    if found[signal.SIGINT] is signal.default_int_handler:  # not if ignored
        signal.signal(signal.SIGINT, _on_signal)
    sys.unraisablehook = _unraisable
    try:
        yield
    finally:
        for sig, handler in found.items():  # None: set outside Python; the default then
            signal.signal(sig, signal.SIG_DFL if handler is None else handler)
        sys.unraisablehook = hook


def _caused_by_interrupt(err: BaseException) -> bool:
    seen = set()
    while err is not None and id(err) not in seen:
        if isinstance(err, KeyboardInterrupt):
            return True
        seen.add(id(err))
        err = err.__cause__ or err.__context__
    return False


def interrupt_status(err: BaseException, prog: str = "unidyn"):
    """If ``err`` is Ctrl-C or ``kill`` stopping a command, say so on stderr in one
    line, with what the command kept (:attr:`unidyn._errors.Interrupted.kept`), and
    return the exit status (130, or 143 for SIGTERM); otherwise return None.

    Ctrl-C inside an import or a library's C code may come out as that library's own
    error (numba's "Error calling __set_name__", matplotlib's "Invalid bounding box"),
    with the interrupt as its cause or context, or none at all if a signal arrived:
    an interrupt all the same, reported without detail."""
    if not (isinstance(err, KeyboardInterrupt) or _received or _caused_by_interrupt(err)):
        return None
    kept = err.kept if isinstance(err, Interrupted) else ""
    word = "terminated" if signal.SIGTERM in _received else "interrupted"
    print(f"{prog}: {word}" + (f": {kept}" if kept else ""), file=sys.stderr)
    return TERMINATED if signal.SIGTERM in _received else INTERRUPTED


def _flush() -> None:
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (AttributeError, OSError, ValueError):  # None, or closed
            pass


def _end_by_signal() -> None:
    """The exit handler registered first, hence run last (atexit runs its handlers in
    the reverse order of registration): after every other one, end the process by the
    signal that stopped it."""
    if not _ending or os.name == "nt":
        return
    _flush()
    signal.signal(_ending[0], signal.SIG_DFL)
    os.kill(os.getpid(), _ending[0])


def prepare_end() -> None:
    """Make :func:`end` able to end the process by a signal. Call it first thing, before
    anything that registers exit handlers (multiprocessing, logging, numba, matplotlib
    and bdsim do as they load): it registers with :mod:`atexit` the step that sends the
    signal, which runs after the handlers registered after it and before those
    registered before it, which it would skip. The ``unidyn`` command calls it before
    it loads any of them."""
    if not _prepared:
        atexit.register(_end_by_signal)
        _prepared.append(True)


def end(code: int):
    """End the process with a command's exit status ``code``: status 130 ends it by
    SIGINT and 143 by SIGTERM, once Python's exit handlers have run and output is
    flushed (see :func:`prepare_end`); any other status is a plain exit.

    From here on Ctrl-C and SIGTERM are ignored: the command's work is done and its
    status stands (a Ctrl-C in the second or so that the interpreter takes to tear
    down numba, matplotlib and friends would print a traceback from whatever
    finaliser it lands in)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_IGN)
    if code in (INTERRUPTED, TERMINATED):
        # objects the command left half built may fail in their finalisers: nothing to say
        sys.unraisablehook = lambda hook: None
        prepare_end()
        _ending.append(signal.SIGTERM if code == TERMINATED else signal.SIGINT)
    sys.exit(code)


def run_command(entry, argv=None):
    """The ``unidyn`` console script: :func:`prepare_end`, ``entry(argv)`` (the command
    with :func:`command_signals`), then :func:`end` with its status.

    Ending by the signal also makes the outcome the same however Python was started:
    under ``python -m``, CPython ends the process by SIGINT, whatever status was asked
    for, once a KeyboardInterrupt has passed through any ``exec``/``eval`` of a string
    (dataclasses and named tuples make their methods so), even if it was then caught."""
    prepare_end()
    try:
        code = entry(argv)
    except KeyboardInterrupt:  # in the moment between the command's end and the next line
        code = TERMINATED if signal.SIGTERM in _received else INTERRUPTED
    end(code)
