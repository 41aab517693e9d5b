"""``python -m unidyn``: the unidyn command line."""

import sys

try:
    from .cli import script
except KeyboardInterrupt:  # Ctrl-C while the package loads: nothing was started
    print("unidyn: interrupted", file=sys.stderr, flush=True)
    import os
    import signal
    if os.name != "nt":  # end by the signal, as the command does (unidyn.cli.script)
        signal.signal(signal.SIGINT, signal.SIG_DFL)
        signal.raise_signal(signal.SIGINT)
    sys.exit(130)

script()
