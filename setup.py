"""Build hook: ship ``unidyn-bdsim.pth`` so that bdsim finds unidyn's blocks.

bdsim 1.4 discovers block libraries only in the packages named by the
``BDSIMPATH`` environment variable (plus its own toolboxes). The ``.pth`` file,
run by Python at start-up, appends ``unidyn`` to ``BDSIMPATH``, so that
``bd.DYNAMICUNICYCLE(...)``, ``bdrun`` and ``bdedit`` find the blocks with no
extra step, whether or not ``unidyn`` was imported, after ``pip install .`` and
``pip install -e .`` alike.

A wheel's files come from ``build_lib``. An editable wheel (setuptools >= 64) is
assembled from the folder that its ``install`` command names as ``install_lib``
(its ``build_lib`` holds only what the editable finder maps), so in editable mode
the hook goes there. tests/test_install.py checks both installs in a fresh venv.
"""

from pathlib import Path

from setuptools import setup
from setuptools.command.build_py import build_py

PTH = "unidyn-bdsim.pth"


class BuildPyWithPth(build_py):
    def run(self):
        super().run()
        if getattr(self, "editable_mode", False):
            target = self.get_finalized_command("install").install_lib
        else:
            target = self.build_lib
        self.copy_file(str(Path(__file__).parent / PTH), str(Path(target) / PTH))


setup(cmdclass={"build_py": BuildPyWithPth})
