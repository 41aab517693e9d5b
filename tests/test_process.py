"""How the ``unidyn`` command's process ends (unidyn.process), in real processes."""

import os
import signal
import subprocess
import sys

import pytest

pytestmark = pytest.mark.skipif(os.name == "nt", reason="no death by signal on Windows")


def _no_sigint_ignore():  # a shell's background job may inherit SIGINT ignored
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def _child(code: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-c", code], text=True, capture_output=True,
                          timeout=120, preexec_fn=_no_sigint_ignore)


def test_nothing_registers_an_exit_handler_before_the_command_does():
    """The step that ends the process by the signal is an exit handler registered
    first, so that it runs after every other; one registered before it would be
    skipped. Loading the command line (all that runs before ``script``, under ``python
    -m unidyn`` too) registers none."""
    p = _child("import atexit\n"
               "seen = []\n"
               "register = atexit.register\n"
               "def recording(f, *a, **k):\n"
               "    seen.append(getattr(f, '__qualname__', repr(f)))\n"
               "    return register(f, *a, **k)\n"
               "atexit.register = recording\n"
               "import unidyn, unidyn.cli, unidyn.process\n"
               "print(seen)\n")
    assert p.returncode == 0, p.stderr
    assert p.stdout.strip() == "[]"


@pytest.mark.parametrize("sig, word", [(signal.SIGINT, "interrupted"),
                                       (signal.SIGTERM, "terminated")])
def test_a_stopped_command_dies_by_its_signal_after_the_exit_handlers_and_output(sig, word):
    """Ctrl-C or kill during a command: it says so, exit handlers registered while it ran
    (as numba's, matplotlib's, multiprocessing's are) run, output still buffered comes
    out, and then the process dies by that very signal (what a shell needs to stop its
    loop)."""
    p = _child("import atexit, os, signal, threading\n"
               "import unidyn.cli as c, unidyn.cli.robots\n"
               "def cmd(args):\n"
               "    atexit.register(print, 'handler ran')\n"
               "    print('buffered output')  # stdout is a pipe: not flushed yet\n"
               f"    os.kill(os.getpid(), {int(sig)})\n"
               "    threading.Event().wait(30)\n"
               "unidyn.cli.robots.unidyn_robots = cmd\n"
               "c.script(['robots'])\n")
    assert p.returncode == -sig, (p.returncode, p.stdout, p.stderr)
    assert p.stdout.split("\n")[:2] == ["buffered output", "handler ran"], p.stdout
    assert p.stderr.strip() == f"unidyn: {word}", p.stderr


def test_a_command_that_finished_exits_with_its_status():
    p = _child("import unidyn.cli as c\n"
               "c.script(['properties', 'no-such-robot'])\n")
    assert p.returncode == 2, (p.returncode, p.stderr)
    assert p.stderr.startswith("unidyn: error:") and "Traceback" not in p.stderr
