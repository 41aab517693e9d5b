"""The README's 15-line diagram runs as written and does what it says."""

import re
from pathlib import Path

import numpy as np

README = Path(__file__).resolve().parents[1] / "README.md"


def _snippet():
    text = README.read_text()
    section = text.split("## A diagram in 15 lines", 1)[1]
    return re.search(r"```python\n(.*?)```", section, re.S).group(1)


def test_the_fifteen_line_diagram_runs_and_tracks():
    code = _snippet()
    assert len([l for l in code.splitlines() if l.strip()]) <= 16
    ns = {}
    exec(compile(code, "README.md", "exec"), ns)  # the README's own code, as a user runs it
    out = ns["out"]
    q = np.asarray(out[".ywatch"][0])
    t = np.asarray(out.t)
    h_d = np.stack([np.sin(0.5 * t), np.cos(0.25 * t) - 1], -1)
    err = np.linalg.norm(h_d - q[:, :2], axis=1)
    assert abs(err[0] - 0.2) < 1e-9
    assert np.mean(err[t > 40]) < 0.02     # exact compensation: tracks like the kinematic case
