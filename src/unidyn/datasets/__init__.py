"""Sample data shipped with unidyn, for the guides, the notebooks and first tries, from
any install (as ``scipy.datasets`` and ``skimage.data`` ship theirs)::

    import unidyn.datasets
    from unidyn import identification as ident
    res = ident.identify(unidyn.datasets.path("log.csv"))

- ``log.csv``: a robot's log at 10 Hz, simulated (its header says how: a robot that is
  not a preset, commands held between rows, a 5 s gap), with the columns ``t, u_ref,
  w_ref, u, w`` that :func:`unidyn.identification.identify` reads;
- ``courier.mcap``: a ROS 2 recording (MCAP) of a simulated robot, as
  ``ros2 bag record -s mcap /cmd_vel /odom`` stores it (``tools/make_sample_bag.py``
  writes it, and says how it was simulated);
- ``scenario.toml``: a scenario file to start from (one adaptive run on a circle, 30 s),
  for ``unidyn run`` and :func:`unidyn.read_scenario`;
- ``sweep.toml``: a sweep file to start from (two labelled variants crossed with four
  gains: 8 runs of 40 s), for ``unidyn sweep``.

Copy a file to edit it: ``shutil.copy(unidyn.datasets.path("scenario.toml"), ".")``.
"""

from __future__ import annotations

from pathlib import Path

from .._validate import choice

__all__ = ["path", "NAMES"]

#: The files shipped.
NAMES = ("log.csv", "courier.mcap", "scenario.toml", "sweep.toml")


def path(name: str) -> Path:
    """The path of the sample file ``name`` (one of :data:`NAMES`) in the installed
    package; a :class:`unidyn.ValidationError` names the files there are."""
    return Path(__file__).with_name(choice("name", name, NAMES))
