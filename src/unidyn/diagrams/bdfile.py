r"""Write a built bdsim block diagram as a ``.bd`` file, the JSON that bdsim's
``bdload``/``bdrun`` read and its graphical editor bdedit opens and saves.

bdsim 1.4 reads ``.bd`` files but has no writer. :func:`save_bd` writes a diagram
built in Python (e.g. the result of :func:`unidyn.diagrams.build_fig2`, the paper's
Fig. 2) so that ``bdrun FILE.bd`` runs the same diagram and bdedit draws it::

    from unidyn import Scenario
    from unidyn.diagrams import bdfile, build_fig2, new_simulator
    bdfile.save_bd(build_fig2(new_simulator(), Scenario.paper(4)), "fig2_case4.bd")

A unidyn block is written as its class and the arguments it was built with, which
every unidyn block keeps (``block.arguments``); bdsim's ``DEMUX``, ``MUX``,
``NULL``, ``CONSTANT`` and ``GAIN`` are read back from the block. Arguments that
are objects of the model are written as the plain values the blocks also take: a
robot by its preset name or its six numbers, a trajectory by its spec, ``limits``
as the block's own ``speed_max``, ... keywords. A block whose ports depend on an
option (``DynamicUnicycle(velocity_output=True)``) is written as it is, and bdrun
runs it; bdedit draws the ports such a file gives it, labelled where the class's
defaults have them, so :func:`~unidyn.diagrams.build_fig2` builds the classes with
those ports fixed (``DYNAMICUNICYCLEWITHVELOCITY``, ...). Anything a file cannot hold
(a bdsim clock: sampled control; a callable trajectory; another package's block)
raises :class:`BdFileError` naming the block and the parameter.

Parameter values are written in the form ``bdload`` reads back: numbers, lists of
numbers, booleans and null as JSON; a string as itself when ``bdload``'s evaluation
leaves it a string (``"p3dx_laser"``), and as the expression ``"='...'"`` when it
would not (``"input"`` and ``"filter"`` are Python builtins); infinity as
``"=math.inf"``; a seed sequence as ``"=np.random.SeedSequence(...)"``. Files are
deterministic: the same diagram gives the same bytes.
"""

from __future__ import annotations

import ast
import builtins
import itertools
import json
import math
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from .._validate import ValidationError
from ..model import robots
from ..model import trajectories as traj
from ..model.parameters import RobotParameters
from ..model.scenario import Scenario
from ..model.unicycle import Limits
from ..results.ownership import write_atomic
from .fig2 import build_fig2, new_simulator

__all__ = ["save_bd", "to_bd_dict", "block_parameters", "paper_fig2", "write_paper_fig2",
           "BdFileError", "FIG2_LAYOUT", "BDSIM_TYPES", "PAPER_FILES"]

# bdedit's socket sides and kinds (bdedit.block_socket)
_LEFT, _RIGHT = 1, 3
_INPUT, _OUTPUT = 1, 2
_STEP_WIRE = 3

#: Positions (x, y) of the Fig. 2 blocks by name, left to right trajectory -> K -> D ->
#: R, the measurements fed back below (drawn flipped: signals flow right to left), on
#: bdedit's 20 px grid; y grows downwards in bdedit. The gaps leave the editor's wires
#: lanes apart: bdedit turns a feedback wire 20 px x (input index + 1) left of the
#: input it enters and a forward wire halfway between its blocks, so K starts 310 px
#: right of the trajectory's end (the measured q and v turn 60 and 100 px left of K, the
#: trajectory's h_d_ddot 155 px) and D 190 px right of K's (v turns 40 px left of D,
#: K's v_d_dot 95 px).
FIG2_LAYOUT: dict[str, tuple[float, float]] = {
    "trajectory": (-1400.0, 0.0),
    "controller": (-840.0, 0.0),
    "compensator": (-400.0, 0.0),
    "demux": (-40.0, 0.0),
    "robot": (160.0, 0.0),
    "position_noise": (0.0, 260.0),
    "velocity_noise": (0.0, 420.0),
}
_FLIPPED = {"position_noise", "velocity_noise"}


class BdFileError(ValidationError):
    """A block or parameter that a ``.bd`` file cannot hold (the message names them)."""


# --------------------------------------------------------------------------- #
# values


_BDLOAD_NAMES = {"np", "math", "pi", "SE3", "SE2"}


def _bdload_keeps(s: str) -> bool:
    """True when bdload, which evaluates every string parameter and keeps the string
    only if that raises NameError or SyntaxError, leaves ``s`` as this string."""
    if not s or s[0] == "=":
        return False
    try:
        tree = ast.parse(s, mode="eval")
    except SyntaxError:
        return True
    node = tree.body
    return (isinstance(node, ast.Name) and node.id not in _BDLOAD_NAMES
            and not hasattr(builtins, node.id))


def _expr(v, where: str) -> str:
    """A Python expression for a plain value, as bdload's eval reads it."""
    if v is None or isinstance(v, (bool, np.bool_)):
        return repr(None if v is None else bool(v))
    if isinstance(v, (int, np.integer)):
        return repr(int(v))
    if isinstance(v, (float, np.floating)):
        v = float(v)
        if math.isnan(v):
            raise BdFileError(f"{where} is NaN, which a .bd file cannot hold")
        if math.isinf(v):
            return "math.inf" if v > 0 else "-math.inf"
        return repr(v)
    if isinstance(v, str):
        return repr(v)
    if isinstance(v, (list, tuple, np.ndarray)):
        return "[" + ", ".join(_expr(x, where) for x in np.asarray(v, dtype=object).tolist()) + "]"
    raise BdFileError(f"{where}: a value of type {type(v).__name__} cannot be written")


def _json_native(v) -> bool:
    if v is None or isinstance(v, (bool, int, str)):
        return True
    if isinstance(v, float):
        return math.isfinite(v)
    if isinstance(v, list):
        return all(_json_native(x) and not isinstance(x, str) for x in v)
    return False


def _plain(v):
    """numpy scalars and arrays, tuples -> Python scalars and lists."""
    if isinstance(v, np.ndarray):
        return [_plain(x) for x in v.tolist()]
    if isinstance(v, (tuple, list)):
        return [_plain(x) for x in v]
    if isinstance(v, (np.bool_,)):
        return bool(v)
    if isinstance(v, np.integer):
        return int(v)
    if isinstance(v, np.floating):
        return float(v)
    return v


def _write_value(v, where: str):
    """The JSON form of a parameter value that bdload turns back into ``v``."""
    if isinstance(v, _Expr):
        return "=" + v.text
    if isinstance(v, dict):  # e.g. a trajectory spec: bdload passes dicts through as they are
        out = {}
        for k, x in v.items():
            x = _plain(x)
            if not (_json_native(x) or isinstance(x, list) and all(_json_native(e) for e in x)):
                raise BdFileError(f"{where}[{k!r}]: {x!r} cannot be written in a dict")
            out[str(k)] = x
        return out
    v = _plain(v)
    if isinstance(v, str):
        return v if _bdload_keeps(v) else "=" + repr(v)
    if _json_native(v):
        return v
    return "=" + _expr(v, where)


@dataclass(frozen=True)
class _Expr:
    """A parameter written as a bdload expression (``"=..."``)."""

    text: str


def _seed_expr(seed: np.random.SeedSequence, where: str) -> _Expr:
    ent, key = seed.entropy, tuple(seed.spawn_key)
    if isinstance(ent, (int, np.integer)) and all(isinstance(k, (int, np.integer)) for k in key):
        return _Expr(f"np.random.SeedSequence({int(ent)}, spawn_key={tuple(int(k) for k in key)!r}, "
                     f"pool_size={seed.pool_size})")
    raise BdFileError(f"{where}: seed {seed!r} cannot be written (use an int or an int-seeded SeedSequence)")


# --------------------------------------------------------------------------- #
# blocks -> (block type, parameters)


def _robot_value(params: RobotParameters):
    """A preset robot by name, any other as six numbers."""
    try:
        if params.name in robots.names() and robots.get(params.name) == params:
            return params.name
    except ValidationError:
        pass
    return [float(x) for x in params.theta]


def _argument(value, where: str):
    """A block argument as a value a .bd file holds: the model's objects as the plain
    values the blocks also take (a robot by name or theta, a trajectory by its spec),
    a seed sequence as the expression that rebuilds it; a clock or code refused."""
    if isinstance(value, RobotParameters):
        return _robot_value(value)
    if isinstance(value, traj.Trajectory):
        value = value.to_spec()
        if value["type"] not in traj.KINDS:
            raise BdFileError(f"{where} is a {value['type']} trajectory, which a .bd file cannot "
                              f"hold (a file holds no code); use one of {', '.join(traj.KINDS)}")
        return value
    if isinstance(value, np.random.SeedSequence):
        return _seed_expr(value, where)
    if callable(value) and not isinstance(value, type):
        raise BdFileError(f"{where} is code ({value!r}), which a .bd file cannot hold")
    if type(value).__module__.startswith("bdsim."):
        raise BdFileError(f"{where} is a bdsim {type(value).__name__}, which a .bd file cannot "
                          f"hold; write continuous control, or name the clock (SENSORNOISE)")
    return value


def _unidyn_block(b) -> tuple[str, dict]:
    """A unidyn block as its class and the arguments it was built with."""
    where = f"block {b.name!r} ({type(b).__name__}): parameter"
    args = dict(b.arguments)
    limits = args.get("limits")
    if isinstance(limits, Limits):  # the limits as the block's own keywords
        args.update({k: v for k, v in asdict(limits).items() if k in args}, limits=None)
    return type(b).__name__.upper(), {k: _plain(_argument(v, f"{where} {k!r}"))
                                      for k, v in args.items()}


def _bdsim_block(b):
    t = b.type.upper() if isinstance(b.type, str) else ""
    if t == "DEMUX":
        return "DEMUX", {"nout": int(b.nout)}
    if t == "MUX":
        return "MUX", {"nin": int(b.nin)}
    if t == "NULL":
        return "NULL", {"nin": int(b.nin)}
    if t == "CONSTANT":
        return "CONSTANT", {"value": _plain(b.value)}
    if t == "GAIN":
        return "GAIN", {"K": _plain(b.K), "premul": bool(getattr(b, "premul", False))}
    raise BdFileError(f"block {b.name!r} ({type(b).__name__}): the .bd writer cannot read back "
                      f"its parameters (it knows unidyn's blocks and {', '.join(BDSIM_TYPES)})")


#: bdsim's own blocks the writer knows (they do not record their arguments).
BDSIM_TYPES = ("DEMUX", "MUX", "NULL", "CONSTANT", "GAIN")


def block_parameters(block) -> tuple[str, dict]:
    """The block type and constructor parameters under which bdload rebuilds ``block``:
    for unidyn's blocks, the class and the arguments it was built with (its
    ``arguments``), for bdsim's those of :data:`BDSIM_TYPES`."""
    if isinstance(vars(block).get("arguments"), dict):
        return _unidyn_block(block)
    if type(block).__module__.startswith("bdsim."):
        return _bdsim_block(block)
    raise BdFileError(f"block {block.name!r} ({type(block).__name__}): the .bd writer cannot "
                      f"read back its parameters")


# --------------------------------------------------------------------------- #
# the file


def _auto_layout(blocks, wires) -> dict:
    """Columns by the longest chain of wires from a source, ignoring wires that leave a
    block with state (the feedback paths); blocks in a column stacked downwards."""
    stateful = {id(b) for b in blocks if (b.nstates or 0) + (b.ndstates or 0) > 0}
    col = {id(b): 0 for b in blocks}
    for _ in range(len(blocks)):
        changed = False
        for w in wires:
            s, e = w.start.block, w.end.block
            if id(s) in stateful:
                continue
            if col[id(e)] < col[id(s)] + 1:
                col[id(e)] = col[id(s)] + 1
                changed = True
        if not changed:
            break
    rows: dict[int, int] = {}
    out = {}
    for b in blocks:
        c = col[id(b)]
        r = rows.get(c, 0)
        rows[c] = r + 1
        out[b.name] = (250.0 * c, 180.0 * r)
    return out


#: What bdedit draws a port label and a block's icon with, px (its default font).
_CHAR_PX, _ICON_PX, _PAD_PX = 10, 50, 10


def _width(b) -> int:
    """Wide enough that the port labels, on either side of the icon in the middle,
    touch neither the icon nor each other."""
    ins = max((len(str(n)) for n in (b._inport_names or [])), default=0)
    outs = max((len(str(n)) for n in (b._outport_names or [])), default=0)
    side = _CHAR_PX * max(ins, outs) + _PAD_PX
    return max(100, int(math.ceil((2 * side + _ICON_PX + 2 * _PAD_PX) / 10.0)) * 10)


def _on_grid(x: float) -> float:
    """``x`` on bdedit's 20 px grid."""
    return 20.0 * round(x / 20.0)


def _sink_position(b, wires, pos, flipped) -> tuple[float, float] | None:
    """A NULL sink not in the layout goes above and right of what feeds it (left of
    it when that block is drawn flipped), on bdedit's grid."""
    for w in wires:
        if w.end.block is b and w.start.block.name in pos:
            x, y = pos[w.start.block.name]
            if w.start.block.name in flipped:
                return (_on_grid(x - 170.0), _on_grid(y))
            return (_on_grid(x + _width(w.start.block) + 80.0), _on_grid(y - 160.0))
    return None


def to_bd_dict(diagram, *, layout: dict | str | None = "fig2",
               simulation_time: float | None = None) -> dict:
    """The ``.bd`` JSON (as a dict) of a built diagram.

    :param diagram: a :class:`unidyn.diagrams.Fig2` or a bdsim ``BlockDiagram``,
        wired and not yet compiled (or compiled: the same)
    :param layout: block name -> (x, y) position in bdedit's scene (y downwards), or
        ``"fig2"`` (:data:`FIG2_LAYOUT`, the paper's drawing; blocks it does not name
        are placed automatically), or None for an automatic left-to-right layout
    :param simulation_time: the editor's simulation time, s (a Fig2's scenario T by default)
    :return: dict with ``blocks``, ``wires`` and bdedit's scene fields
    :raises BdFileError: for a block or parameter that a .bd file cannot hold
    """
    bd = getattr(diagram, "bd", diagram)
    scenario = getattr(diagram, "scenario", None)
    if simulation_time is None:
        simulation_time = float(scenario.T) if scenario is not None else 10.0
    blocks = list(bd.blocklist)
    wires = list(bd.wirelist)
    for w in wires:
        if getattr(w.start, "isslice", False) or getattr(w.end, "isslice", False):
            raise BdFileError(f"wire {w.start} -> {w.end}: sliced ports cannot be written")
    names = [b.name for b in blocks]
    dup = sorted({n for n in names if names.count(n) > 1})
    if dup:
        raise BdFileError(f"block name {dup[0]!r} is used twice; a .bd file names blocks uniquely")
    pos, flipped = _positions(blocks, wires, layout)
    ids = itertools.count(1)
    jblocks, out_socket, in_socket = [], {}, {}
    for b in blocks:
        jblocks.append(_json_block(b, pos[b.name], b.name in flipped, ids, out_socket,
                                   in_socket))
    jwires = [{"id": next(ids), "start_socket": out_socket[(id(w.start.block), w.start.port)],
               "end_socket": in_socket[(id(w.end.block), w.end.port)],
               "wire_type": _STEP_WIRE, "custom_routing": False, "wire_coordinates": []}
              for w in wires]
    connected = {(id(w.end.block), w.end.port) for w in wires}
    for b in blocks:
        for i in range(int(b.nin or 0)):
            if (id(b), i) not in connected:
                raise BdFileError(f"block {b.name!r}: input {i} is not connected; bdload "
                                  f"refuses a diagram with an open input")
    return {"id": 0, "created_by": "unidyn.diagrams.bdfile", "creation_time": 0,
            "simulation_time": simulation_time, "scene_width": 6400, "scene_height": 6400,
            "blocks": jblocks, "wires": jwires, "labels": [], "grouping_boxes": []}


def _positions(blocks, wires, layout) -> tuple[dict, set]:
    """Every block's position by name, and the names of the blocks drawn flipped, for
    ``layout`` (see :func:`to_bd_dict`); NULL sinks go beside what feeds them."""
    names = [b.name for b in blocks]
    if layout == "fig2":
        pos = {k: v for k, v in FIG2_LAYOUT.items() if k in names}
        auto = _auto_layout(blocks, wires)
        for b in blocks:
            if b.name not in pos and b.type != "null":
                x, y = auto[b.name]
                pos[b.name] = (x - 650.0, y + 550.0)
        flipped = _FLIPPED
    elif layout is None:
        pos, flipped = _auto_layout(blocks, wires), set()
    elif isinstance(layout, dict):
        pos, flipped = {k: tuple(map(float, v)) for k, v in layout.items()}, set()
    else:
        raise BdFileError(f"layout must be 'fig2', None or a dict of positions, got {layout!r}")
    for b in blocks:  # NULL sinks beside their source, then anything still unplaced
        if b.name not in pos:
            p = _sink_position(b, wires, pos, flipped)
            pos[b.name] = p if p is not None else _auto_layout(blocks, wires)[b.name]
    return pos, flipped


def _json_block(b, position, flip, ids, out_socket, in_socket) -> dict:
    """Block ``b`` as the file holds it, its sockets numbered from ``ids`` and recorded
    in ``out_socket`` and ``in_socket`` ((block, port) -> socket id) for the wires."""
    btype, params = block_parameters(b)
    nin, nout = int(b.nin or 0), int(b.nout or 0)
    bid = next(ids)
    ins, outs = [], []
    for i in range(nin):
        sid = next(ids)
        in_socket[(id(b), i)] = sid
        ins.append({"id": sid, "index": i, "multi_wire": True,
                    "position": _RIGHT if flip else _LEFT, "socket_type": _INPUT})
    for i in range(nout):
        sid = next(ids)
        out_socket[(id(b), i)] = sid
        outs.append({"id": sid, "index": i, "multi_wire": True,
                     "position": _LEFT if flip else _RIGHT, "socket_type": _OUTPUT})
    jparams = [[k, _write_value(v, f"block {b.name!r} ({type(b).__name__}): parameter {k!r}")]
               for k, v in params.items()]
    x, y = position
    return {"id": bid, "block_type": btype, "title": b.name,
            "pos_x": float(x), "pos_y": float(y), "width": _width(b), "height": 100,
            "flipped": flip, "inputsNum": nin, "outputsNum": nout,
            "inputs": ins, "outputs": outs, "parameters": jparams}


def save_bd(diagram, path, *, layout: dict | str | None = "fig2",
            simulation_time: float | None = None) -> Path:
    """Write a built diagram as a ``.bd`` file that ``bdload``/``bdrun`` run and bdedit opens.

    :param diagram: a :class:`unidyn.diagrams.Fig2` (e.g. ``build_fig2(...)``) or a bdsim
        ``BlockDiagram``
    :param path: the file to write (replaced if it exists)
    :param layout: see :func:`to_bd_dict`
    :param simulation_time: see :func:`to_bd_dict`
    :return: the path written
    :raises BdFileError: naming the block and parameter a .bd file cannot hold; nothing
        is written then
    """
    data = to_bd_dict(diagram, layout=layout, simulation_time=simulation_time)
    text = json.dumps(data, indent=4, allow_nan=False) + "\n"
    path = Path(path)
    write_atomic(path, text)  # a temporary file beside it, then a rename
    return path


# --------------------------------------------------------------------------- #
# the paper's four simulations as .bd files

#: File names of the paper's four Section 5 simulations, by number.
PAPER_FILES = {1: "fig2_case1_kinematic.bd", 2: "fig2_case2_uncompensated.bd",
               3: "fig2_case3_compensated.bd", 4: "fig2_case4_adaptive.bd"}


def paper_fig2(sim, n: int):
    """The Fig. 2 diagram of the paper's simulation ``n`` as drawn for the editor.

    Cases 1, 3 and 4 are :func:`unidyn.diagrams.build_fig2` of ``Scenario.paper(n)``.
    Case 2 is case 1 with the kinematic robot replaced by the dynamic one
    (``DYNAMICUNICYCLE``, the drop-in with the same ports), as the paper builds it
    ("we include the dynamic model into the same system"); ``build_fig2`` also
    feeds the robot's velocities through a noise block that nothing reads, which
    leaves the motion the same (the run tests compare both with
    ``unidyn.simulate(Scenario.paper(2))``). So in the editor case 1 -> 2 replaces
    the robot block, 2 -> 3 inserts the compensator D (and the controller with its
    rate output, with the velocities fed back), 3 -> 4 sets D's estimate, ``adaptive``
    and ``adapt_from``.

    :return: a :class:`unidyn.diagrams.Fig2` whose scenario is ``Scenario.paper(n)``
    """
    from ..blocks import DynamicUnicycle  # bdsim: loaded when a diagram is built
    if n == 2:
        sc = Scenario.paper(2)

        def robot(bd, _):
            return DynamicUnicycle(robot=sc.robot, a=sc.a, x0=sc.x0, limits=sc.limits, bd=bd,
                                   name="robot")
        fig = build_fig2(sim, Scenario.paper(1), robot=robot)
        fig.scenario = sc
        return fig
    return build_fig2(sim, Scenario.paper(n))


def write_paper_fig2(folder) -> list[Path]:
    """Write the four ``.bd`` files of :data:`PAPER_FILES` into ``folder``."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    return [save_bd(paper_fig2(new_simulator(), n), folder / name) for n, name in PAPER_FILES.items()]
