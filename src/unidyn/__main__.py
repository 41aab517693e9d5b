"""``python -m unidyn``: the unidyn command line."""

import sys

try:
    from .cli import entry
except KeyboardInterrupt:  # Ctrl-C while the package loads: nothing was started
    print("unidyn: interrupted", file=sys.stderr)
    sys.exit(130)

sys.exit(entry())
