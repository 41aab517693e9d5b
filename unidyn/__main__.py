"""``python -m unidyn``: the unidyn command line."""

import sys

from .cli import main

sys.exit(main())
