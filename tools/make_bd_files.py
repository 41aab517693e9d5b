"""Write the paper's Fig. 2, its four Section 5 simulations, as .bd files for bdedit and bdrun.

    python tools/make_bd_files.py            # into examples/bd/
    python tools/make_bd_files.py OUT_DIR

Each file is the diagram of :func:`unidyn.diagrams.bdfile.paper_fig2` written by
:func:`unidyn.diagrams.bdfile.save_bd`; tests/diagrams/test_bdfiles.py checks that the shipped files
are what this script writes and that bdrun runs them to the numbers of
``unidyn.simulate(Scenario.paper(n))``.
"""

import sys
from pathlib import Path

import unidyn  # noqa: F401  (puts unidyn's blocks on bdsim's BDSIMPATH)
from unidyn.diagrams.bdfile import write_paper_fig2


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    folder = Path(argv[0]) if argv else Path(__file__).resolve().parents[1] / "examples" / "bd"
    for path in write_paper_fig2(folder):
        print(path)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
