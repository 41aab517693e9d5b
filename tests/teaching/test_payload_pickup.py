"""Picking up a load (unidyn.teaching.payload): which controller ends closer to the
reference once the robot is heavier."""

import numpy as np

from unidyn.engine.batch import simulate_batch
from unidyn.teaching.payload import pickup_iae, pickup_scenarios, pickup_sweep, plot_pickup


def test_adaptive_compensation_ends_closer_than_exact_for_the_empty_robot(tmp_path):
    """Twice the mass at 30 s, no noise, kx = ky = 0.5 (the start's offset gone by
    15 s): before the load exact compensation tracks
    (the analytic v_d', Section 5's case 3), after it the error it leaves is larger
    than adaptive compensation's, and both are far below the kinematic controller's."""
    scs = pickup_scenarios(mass=2.0, at=30.0, T=60.0, kx=0.5, ky=0.5)
    assert scs["compensated"].payload == ((30.0, 2.0),)
    np.testing.assert_array_equal(scs["adaptive"].theta_hat_initial,
                                  scs["adaptive"].robot.theta)
    results = dict(zip(scs, simulate_batch(list(scs.values()), progress=False)))
    iae = pickup_iae(results, at=30.0, window=15.0)
    assert iae["compensated"][0] < 1e-2
    assert iae["adaptive"][1] < 0.5 * iae["compensated"][1]
    assert iae["compensated"][1] < 0.5 * iae["uncompensated"][1]
    path = plot_pickup(results, tmp_path / "pickup.png", at=30.0)
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_sweep_exact_compensation_loses_more_the_heavier_the_load():
    """Without a load exact compensation tracks exactly; its IAE after the load grows
    with the mass."""
    iae = pickup_sweep([1.0, 1.5, 2.5], at=20.0, T=40.0, window=10.0, kx=0.5, ky=0.5)
    comp = iae["compensated"]
    assert comp[0] < 1e-3 and comp[0] < comp[1] < comp[2]
    assert np.all(iae["uncompensated"] > comp)
