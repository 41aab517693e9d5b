"""``python -m unidyn``: the unidyn command line."""

import sys

from . import process

process.prepare_end()  # before anything registers exit handlers (see its docstring)
try:
    from .cli import entry
except KeyboardInterrupt:  # Ctrl-C while the command line loads: nothing was started
    print("unidyn: interrupted", file=sys.stderr, flush=True)
    process.end(process.INTERRUPTED)

process.run_command(entry)
