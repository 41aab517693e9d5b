"""The ``unidyn`` command: run scenarios and sweeps, list robots, check properties,
identify parameters from a log.

    unidyn run --paper 4 --out out/case4
    unidyn run scenario.toml --set kx=0.5 --set noise=off --out out/run1
    unidyn run --from out/run1/summary.json --out out/run1-again
    unidyn sweep sweep.toml --out out/sweep
    unidyn sweep --paper-fig11 --no-noise --out out/fig11
    unidyn robots
    unidyn properties p3dx --u-max 1.2
    unidyn identify log.csv --columns t=time,u=v_meas,w=omega_meas --out out/ident
    unidyn identify rosbag2_2026_11_25/ --cmd /cmd_vel --out out/ident-ros

Errors in the input (a bad value, malformed TOML, a missing file) print one line
``unidyn: error: ...`` on stderr and exit with status 2. Ctrl-C (SIGINT) and ``kill``
(SIGTERM) stop a command cleanly (it says what it kept), after which the process
ends by that signal, as a shell expects of a command it can stop: the shell's status
is 130 or 143, and a script or loop that ran the command stops with it.

The package holds a module per subcommand (:mod:`~unidyn.cli.run`,
:mod:`~unidyn.cli.sweep`, :mod:`~unidyn.cli.robots`, :mod:`~unidyn.cli.properties`,
:mod:`~unidyn.cli.identify`, :mod:`~unidyn.cli.edit`), each running its subcommand
as ``unidyn_<name>(args)`` and loaded only when that subcommand runs;
:mod:`~unidyn.cli.arguments` builds the parser, :mod:`~unidyn.cli.errors` tells
errors in one line, and :mod:`~unidyn.cli.output` names the output folder.
"""

from __future__ import annotations

import importlib
import os
import sys
import warnings

from .. import process
from .._errors import MissingDependency, ValidationError
from .arguments import parser
from .errors import RunFailed, UsageError, flag_words, report, show_warning

__all__ = ["main", "entry", "script", "parser"]


def main(argv=None) -> int:
    """Run the ``unidyn`` command line; returns the exit status."""
    try:
        with warnings.catch_warnings():
            warnings.showwarning = show_warning  # the hook the warnings module offers
            args = parser().parse_args(argv)
            # the subcommand's module, loaded only now (after the command's signal
            # handling is in place, and only for the subcommand that runs)
            module = importlib.import_module(f"{__name__}.{args.command}")
            return int(getattr(module, f"unidyn_{args.command}")(args) or 0)
    except SystemExit as exc:  # --help, --version
        return exc.code if isinstance(exc.code, int) else (0 if exc.code is None else 2)
    except RunFailed as err:
        report(err)
        return 1
    except (ValidationError, UsageError, MissingDependency) as err:
        report(flag_words(str(err)))
        return 2
    except BrokenPipeError:  # e.g. piped into head: stop quietly
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        return 141
    except FileNotFoundError as err:
        report(err.args[0] if len(err.args) == 1 else f"no such file: {err.filename}")
        return 2
    except OSError as err:
        report(f"{err.strerror or err}" + (f": {err.filename}" if err.filename else ""))
        return 2
    except RecursionError:  # input nested deeper than Python can walk
        report("input nested too deeply to process")
        return 2
    except Exception as err:
        # Ctrl-C inside an import or a library's C code, reported as that library's error
        status = process.interrupt_status(err)
        if status is None:
            raise
        return status
    except KeyboardInterrupt as err:  # Ctrl-C or kill: one line, with what was kept
        return process.interrupt_status(err)


def entry(argv=None) -> int:
    """Run the command line in this process as the ``unidyn`` command does, and return
    its exit status: :func:`main` with the command's signal handling
    (:func:`unidyn.process.command_signals`): SIGTERM (``kill``) stops the command as
    Ctrl-C does, so it removes its staging folder and temporary files (status 143).
    The signal handlers found are restored on return, so that a script or a notebook
    can call it; only the ``unidyn`` command itself (:func:`script`) ends the process."""
    with process.command_signals():
        return main(argv)


def script(argv=None) -> None:
    """The ``unidyn`` console script and ``python -m unidyn``: :func:`entry`, then the
    process ends with the command's status; stopped by Ctrl-C or ``kill``, it ends by
    that signal (:func:`unidyn.process.end`), so that a shell loop running it stops."""
    process.run_command(entry, argv)

