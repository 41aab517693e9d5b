"""The table of trajectory kinds (unidyn.model.trajectories.KINDS): every kind, built with
its defaults, is evaluated by the batch engine from its parameter table exactly as by its
own object (plain Python and compiled), runs compiled, reads back from its spec and
leaves no kind unnamed in a refusal. Nothing here lists the kinds: a new one is
checked by being in the table."""

import numpy as np
import pytest

from unidyn import Scenario, ValidationError
from unidyn.engine import kernels
from unidyn.engine.batch import backend_for
from unidyn.model import equations as eq
from unidyn.model.closed_loop import ClosedLoop
from unidyn.model.trajectories import KINDS, FunctionTrajectory, Line, from_spec

# the batch engine's reference from its parameter table: plain Python, and compiled
REFERENCE = [pytest.param(kernels.reference.py_func if kernels.AVAILABLE else kernels.reference,
                          id="python")] + (
    [pytest.param(kernels.reference, id="compiled")] if kernels.AVAILABLE else [])
#: Times over a few periods of each kind's defaults and past a segment's arrival, with
#: the arrival itself and the instants around it
TIMES = np.concatenate([np.linspace(0.0, 40.0, 401), [4.999999, 5.0, 5.000001]])


@pytest.mark.parametrize("reference", REFERENCE)
@pytest.mark.parametrize("kind", list(KINDS))
def test_the_engine_s_table_gives_the_kind_s_own_reference(kind, reference):
    tr = KINDS[kind]()
    table = ClosedLoop(Scenario(trajectory=tr, T=1.0)).P[0]
    assert table[eq.P.trajectory] == tr.code != eq.PYTHON
    for t in TIMES:
        np.testing.assert_allclose(reference(t, t, table, ()), np.concatenate(tr.evaluate(t)),
                                   rtol=1e-15, atol=1e-15)


def test_codes_name_one_function_each():
    """Kinds share a code only where one is the other's special case (a point is a line)."""
    for a in KINDS.values():
        for b in KINDS.values():
            if a is not b and a.code == b.code:
                assert issubclass(a, b) or issubclass(b, a), (a.kind, b.kind)
    assert Line.code in {k.code for k in KINDS.values() if k.kind == "point"}


def test_an_unknown_code_gives_nan_not_another_kind():
    table = ClosedLoop(Scenario(trajectory=Line(), T=1.0)).P[0].copy()
    table[eq.P.trajectory] = max(k.code for k in KINDS.values()) + 1
    assert np.isnan(eq.reference_components(1.0, 1.0, table)).all()


@pytest.mark.parametrize("kind", list(KINDS))
def test_every_kind_runs_compiled_and_reads_back_from_its_spec(kind):
    tr = KINDS[kind]()
    assert from_spec(tr.to_spec()) == tr and from_spec(kind) == tr
    sc = Scenario(trajectory=tr, T=1.0)
    assert backend_for([sc]) == ("compiled" if kernels.AVAILABLE else "plain")
    assert Scenario.from_dict(sc.to_dict()).trajectory == tr


def test_a_python_function_runs_plain():
    f8 = KINDS["figure_eight"]()
    sc = Scenario(trajectory=FunctionTrajectory(f8, acceleration=f8.acceleration), T=1.0)
    assert ClosedLoop(sc).P[0, eq.P.trajectory] == eq.PYTHON
    assert backend_for([sc]) == "plain"


def test_a_refusal_names_every_kind():
    with pytest.raises(ValidationError) as err:
        from_spec({"type": "spiral"})
    assert all(k in str(err.value) for k in KINDS)


def test_a_kind_named_twice_or_a_code_taken_is_refused_where_the_table_is_built():
    from unidyn.model.trajectories import Trajectory, _table_of_kinds
    with pytest.raises(TypeError, match="two trajectory kinds are named 'line'"):
        _table_of_kinds(Line, Line)
    spiral = type("Spiral", (Trajectory,), {"kind": "spiral", "code": eq.LINE})
    with pytest.raises(TypeError, match="'line' and 'spiral' share the code 2"):
        _table_of_kinds(Line, spiral)
