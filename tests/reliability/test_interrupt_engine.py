"""Ctrl-C stops a long batch run within a second or two of the process's CPU time and
keeps what was computed (a real process, a real SIGINT). Counted in CPU time, the bound
does not depend on how busy the machine is; the wall-clock time from Ctrl-C to the
prompt is measured by ``python benchmarks/responsiveness.py``."""

import os
import signal
import subprocess
import sys
import textwrap
import time

import pytest

from processes import HAS_PROC, cpu_seconds

pytestmark = pytest.mark.reliability

SCRIPT = textwrap.dedent("""
    import faulthandler, signal, sys, time
    faulthandler.register(signal.SIGUSR1)  # the test asks where it is, if it hangs
    from unidyn import Scenario
    from unidyn.engine.batch import simulate_batch
    from unidyn.diagrams.simulate import SimulationInterrupted

    started = []
    def progress(done, total):
        if not started:
            started.append(1)
            print("started", flush=True)

    # millions of samples (hours), every L-th logged
    T, L = float(sys.argv[2]), int(sys.argv[3])
    sc = Scenario.paper(4, T=T, Ts=0.1, noise=None, name="long", log_every=L)
    try:
        simulate_batch([sc], backend=sys.argv[1], progress=progress)
        print("finished")
    except SimulationInterrupted as err:
        r = err.result
        print("interrupted", r.complete, len(r.t), r.t[-1], r.message, flush=True)
        print("cpu", time.process_time(), flush=True)  # all its threads' CPU time
""")


def _no_sigint_ignore():
    """Ctrl-C as in a terminal: a process started from a shell's background job
    inherits SIGINT ignored, and Python then raises no KeyboardInterrupt."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)


@pytest.mark.slow
@pytest.mark.skipif(not HAS_PROC, reason="reads CPU time from /proc")
@pytest.mark.parametrize("backend, T, L", [("compiled", 1e6, 100), ("plain", 2e5, 5)])
def test_sigint_stops_a_long_batch_run_and_keeps_the_part_computed(backend, T, L):
    env = {**os.environ, "MPLBACKEND": "Agg"}
    p = subprocess.Popen([sys.executable, "-c", SCRIPT, backend, str(T), str(L)],
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env,
                         preexec_fn=_no_sigint_ignore)
    try:
        line = p.stdout.readline()  # after numba's (cached) compilation
        assert line.strip() == "started", (line, p.stderr.read() if p.poll() is not None else "")
        time.sleep(1.5)
        cpu_at_sigint = cpu_seconds(p.pid)
        p.send_signal(signal.SIGINT)
        try:
            out, err = p.communicate(timeout=20)
        except subprocess.TimeoutExpired:
            p.send_signal(signal.SIGUSR1)  # its threads' tracebacks, on its stderr
            time.sleep(1.0)
            p.kill()
            out, err = p.communicate()
            pytest.fail(f"no exit 20 s after SIGINT; stdout: {out!r}; stderr: {err[-6000:]}")
    finally:
        if p.poll() is None:
            p.kill()
    words = out.split()
    assert words[0] == "interrupted", (out, err)
    assert words[1] == "False"  # marked incomplete
    n, t_end = int(words[2]), float(words[3])
    assert n >= 2 and abs(t_end - (n - 1) * 0.1 * L) < 1e-6 * n  # a whole, uniform part
    assert "interrupted at t = " in out and "long" in out
    # stopping and keeping the part computed: at most 2 s of CPU time (clock ticks of
    # 10 ms in /proc); a run that went on to its end would take minutes of it
    cpu_after = float(out.split("cpu")[-1]) - cpu_at_sigint
    assert cpu_after < 2.0, (cpu_after, out)


@pytest.mark.parametrize("backend", ["compiled", "plain"])
def test_ctrl_c_after_the_last_sample_leaves_a_complete_run(backend):
    """A Ctrl-C that comes once every sample is computed still interrupts the call, but
    the run it leaves is complete (it was "interrupted at t = T of T", incomplete); its
    error is not estimated (the estimate's runs were cut short)."""
    from unidyn import Scenario
    from unidyn.diagrams.simulate import SimulationInterrupted
    from unidyn.engine.batch import simulate_batch

    def progress(done, total):
        if done >= total:
            raise KeyboardInterrupt
    sc = Scenario.paper(3, T=1.0)
    with pytest.raises(SimulationInterrupted) as err:
        simulate_batch([sc], backend=backend, progress=progress)
    r, = err.value.results
    whole, = simulate_batch([sc], backend=backend)
    assert r.complete and r.message == "" and r.numerical_error is None
    for k, v in whole.metrics.items():  # the run before the estimate's tighter one
        assert abs(r.metrics[k] - v) <= 2 * whole.numerical_error[k] * abs(v), k
