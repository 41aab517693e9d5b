"""Seeded measurement noise, white and held over each sample interval (the paper's Section 5).

The paper adds noise to the x and y fed to the kinematic controller and to the
u and w fed to the dynamic compensator and to the update law; psi is fed back
clean. Each noise value is held for one sample time Ts. The n-th held value is
the n-th draw of ``numpy.random.default_rng`` seeded from the run's seed, so the
bdsim blocks and any other engine see the same numbers for the same seed.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._validate import integer, nonnegative

__all__ = ["NoiseSpec", "noise_seeds", "held_sequence", "HeldNoise", "PAPER_NOISE"]


@dataclass(frozen=True)
class NoiseSpec:
    """Noise of the paper's simulations.

    :param position_std: std of the noise on x and y fed to the kinematic controller, m, >= 0
    :param velocity_std: std of the noise on u and w fed to the compensator, >= 0
    :param seed: integer seed, >= 0
    """

    position_std: float = 0.01
    velocity_std: float = 0.0141
    seed: int = 0

    def __post_init__(self):
        object.__setattr__(self, "position_std", nonnegative("noise.position_std", self.position_std))
        object.__setattr__(self, "velocity_std", nonnegative("noise.velocity_std", self.velocity_std))
        object.__setattr__(self, "seed", integer("noise.seed", self.seed, 0))

    def as_dict(self) -> dict:
        return {"position_std": self.position_std, "velocity_std": self.velocity_std,
                "seed": self.seed}


#: The paper's noise: 0.01 m on position, 0.0141 on velocity, seed 0.
PAPER_NOISE = NoiseSpec()


def noise_seeds(seed: int):
    """The (position, velocity) seed sequences derived from one run seed: the
    noise blocks of the diagram and every other engine draw from these."""
    pos, vel = np.random.SeedSequence(int(seed)).spawn(2)
    return pos, vel


def held_sequence(seed, std: float, n: int, dim: int = 2, out=None) -> np.ndarray:
    """``n`` held values, one row per sample interval: the k-th row is the k-th draw
    ``std * rng.standard_normal(dim)`` of ``numpy.random.default_rng(seed)``, drawn one
    row at a time exactly as :class:`unidyn.blocks.MeasurementNoise` draws them tick by tick.

    numpy's ``Generator`` keeps no state between calls beyond its bit generator, so one
    draw of shape (n, dim) is the same numbers as n draws of dim, in order
    (``tests/model/test_unicycle_and_laws.py`` checks it), in one call instead of n. ``out``: an array to
    draw into, in place of a new one."""
    return HeldNoise(seed, std).draw(np.empty((n, dim)) if out is None else out)


class HeldNoise:
    """The values of :func:`held_sequence` drawn a window at a time: successive calls
    of :meth:`draw` continue the same sequence, so a long run needs only the window
    in memory.

    :param seed: the seed (or seed sequence) of the generator
    :param std: the noise's standard deviation
    """

    def __init__(self, seed, std: float):
        self.rng = np.random.default_rng(seed)
        self.std = float(std)

    def draw(self, out: np.ndarray) -> np.ndarray:
        """Fill out (float64, C-contiguous, (rows, dim)) with the next rows of the
        sequence, in place (no temporary), and return it."""
        self.rng.standard_normal(out=out)
        out *= self.std
        return out
