"""Build hook: ship ``unidyn-bdsim.pth`` so that bdsim finds unidyn's blocks.

bdsim 1.4 discovers block libraries only in the packages named by the
``BDSIMPATH`` environment variable (plus its own toolboxes). The ``.pth`` file,
run by Python at start-up, appends ``unidyn`` to ``BDSIMPATH``, so that
``bd.DYNAMICUNICYCLE(...)`` works after a plain ``pip install`` with no extra
step. An editable install gets no hook; there ``import unidyn`` before creating
``bdsim.BDSim()`` does the same (see README).
"""

from pathlib import Path

from setuptools import setup
from setuptools.command.build_py import build_py

PTH = "unidyn-bdsim.pth"


class BuildPyWithPth(build_py):
    def run(self):
        super().run()
        if not getattr(self, "editable_mode", False):
            src = Path(__file__).parent / PTH
            self.copy_file(str(src), str(Path(self.build_lib) / PTH))


setup(cmdclass={"build_py": BuildPyWithPth})
