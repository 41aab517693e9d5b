"""A block that watches a run from inside the diagram, through bdsim's block interface."""

from __future__ import annotations

from typing import Callable

from bdsim.components import FunctionBlock

__all__ = ["RunMonitor"]


class RunMonitor(FunctionBlock):
    """Calls ``monitor(t, *inputs)`` each time bdsim evaluates the diagram, and keeps
    the run's state.

    bdsim evaluates every block of a diagram at each right-hand-side evaluation
    the solver makes and at every clock tick, so ``monitor`` sees the signals on its
    inputs (e.g. the robot's pose and velocities) as the integration proceeds; it
    may stop the run by raising. The block has no outputs and changes nothing in
    the loop.

    :param monitor: ``monitor(t, *inputs)``, t in s
    :type monitor: callable
    :param nin: number of inputs
    :type nin: int
    :ivar simstate: bdsim's state of the current run (``None`` before it starts):
        ``t`` the time reached, ``tlist`` and ``plist`` the samples logged so far
        of the signals passed to ``BDSim.run(..., watch=)``
    """

    nout = 0

    def __init__(self, monitor: Callable, nin: int = 1, **blockargs):
        """``blockargs`` are bdsim's block options (``name``, ``inputs``, ...)."""
        super().__init__(nin=nin, nout=0, **blockargs)
        self.monitor = monitor
        self.simstate = None

    def start(self, simstate=None):
        super().start(simstate)
        self.simstate = simstate

    def output(self, t, inports, x):
        self.monitor(t, *inports)
        return []
