"""What unidyn.simulate relies on in bdsim 1.4 to guard a run (pinned below 1.5 in
pyproject.toml): a block's ``output`` runs at every right-hand-side evaluation of
the solver, a block's ``start`` receives the run state, and that state logs the
watched signals in ``tlist``/``plist`` as the run goes. If a bdsim release changes
any of these, these tests fail here rather than the guard going silently blind."""

import inspect

import numpy as np
import pytest

from unidyn.diagrams import RunMonitor, new_simulator


def _integrator_diagram(monitor):
    """x' = -x, x(0) = 1, with a RunMonitor on x."""
    sim = new_simulator()
    bd = sim.blockdiagram(name="decay")
    integ = bd.INTEGRATOR(x0=1.0, name="x")
    gain = bd.GAIN(-1.0, name="minus")
    bd.connect(integ, gain)
    bd.connect(gain, integ)
    mon = RunMonitor(monitor, nin=1, bd=bd, name="monitor")
    bd.connect(integ[0], mon[0])
    bd.compile()
    return sim, bd, integ, mon


def test_bdsim_hands_blocks_the_run_state_and_calls_them_at_every_solver_evaluation():
    seen = []
    sim, bd, integ, mon = _integrator_diagram(lambda t, x: seen.append((t, float(np.ravel(x)[0]))))
    assert "simstate" in inspect.signature(type(mon).start).parameters
    out = sim.run(bd, T=1.0, dt=0.1, watch=[integ[0]], solver="RK45",
                  solver_args=dict(rtol=1e-10, atol=1e-12))
    simstate = mon.simstate
    assert simstate is not None
    # every right-hand-side evaluation the solver made passed through the monitor
    assert simstate.count > 0 and len(seen) >= simstate.count
    # what the monitor saw is the state at the solver's trial points: x = exp(-t)
    # (analytic solution) to within the error of one trial step
    t, x = np.array(seen).T
    np.testing.assert_allclose(x, np.exp(-t), atol=1e-3)
    # the run state logs the watched signal, sample by sample, as the run result does
    assert len(simstate.tlist) == len(out.t) and len(simstate.plist) == 1
    np.testing.assert_allclose(np.ravel(simstate.plist[0]), np.exp(-np.asarray(simstate.tlist)),
                               rtol=1e-8)


@pytest.mark.parametrize("error", [ArithmeticError("stop here"), KeyboardInterrupt()])
def test_a_monitor_that_raises_stops_the_run_and_the_run_state_keeps_the_log(error):
    calls = []

    def monitor(t, x):
        calls.append(t)
        if len(calls) == 50:
            raise error
    sim, bd, integ, mon = _integrator_diagram(monitor)
    with pytest.raises((RuntimeError, KeyboardInterrupt)) as info:
        sim.run(bd, T=1.0, dt=0.1, watch=[integ[0]])
    if isinstance(error, KeyboardInterrupt):
        assert info.type is KeyboardInterrupt
    else:  # bdsim reports the block and raises from the cause
        chain, e = [], info.value
        while e is not None and e not in chain:
            chain.append(e)
            e = e.__cause__ or e.__context__
        assert error in chain
    assert len(calls) == 50  # stopped at once
    simstate = mon.simstate
    assert simstate.t == calls[-1]
    assert len(simstate.tlist) >= 1 and len(simstate.plist[0]) == len(simstate.tlist)
