"""What the tests that run real processes read of them: CPU time from Linux's /proc, so
that a check waits for work done, not for a wall-clock time a busy machine stretches."""

import os
from pathlib import Path

#: Whether this system has /proc (a test that reads CPU time is skipped without it).
HAS_PROC = Path("/proc/self/stat").is_file()


def cpu_seconds(pid: int) -> float:
    """The CPU time a running process has used, all its threads; 0 once it has gone."""
    try:
        fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    except OSError:
        return 0.0
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")
