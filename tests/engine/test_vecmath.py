"""The compiled engine's sin, cos and tanh (unidyn.engine.vecmath): numpy's values to a
few units in the last place over the whole range the engine meets, the identities
they must keep, numpy's special values, and no call into the maths library left in
the engine's right-hand side."""

import re

import numpy as np
import pytest

numba = pytest.importorskip("numba")

from unidyn.engine import kernels as _kernels, vecmath as _vecmath
from unidyn.model import equations  # noqa: E402
from unidyn.engine.rhs import ClosedLoop  # noqa: E402
from unidyn.model.scenario import Scenario  # noqa: E402


@numba.njit
def _apply(x, s, c, t):
    for i in range(x.size):
        s[i] = _vecmath.sin(x[i])
        c[i] = _vecmath.cos(x[i])
        t[i] = _vecmath.tanh(x[i])


def _vec(x):
    x = np.ascontiguousarray(x, dtype=float)
    s, c, t = np.empty_like(x), np.empty_like(x), np.empty_like(x)
    _apply(x, s, c, t)
    return s, c, t


def _ulps(a, b):
    """|a - b| in units of the last place of b (of the smallest normal near 0)."""
    return np.abs(a - b) / np.spacing(np.maximum(np.abs(b), np.finfo(float).tiny))


def _inputs():
    rng = np.random.default_rng(20261124)
    magnitude = 10.0 ** rng.uniform(-300, np.log10(_vecmath.SINCOS_LIMIT), 200_000)
    # multiples of pi/2 and points just beside them: where sin or cos is near 0 and
    # the argument reduction is hardest
    n = rng.integers(-2**26 + 1, 2**26, 20_000).astype(float) * (np.pi / 2)
    near = np.concatenate([n, np.nextafter(n, np.inf), n * (1 + 1e-15)])
    return np.concatenate([magnitude * rng.choice([-1.0, 1.0], magnitude.size), near,
                           rng.uniform(-40, 40, 100_000)])


def test_sin_cos_tanh_are_numpys_to_a_few_ulps():
    x = _inputs()
    x = x[np.abs(x) <= _vecmath.SINCOS_LIMIT]
    s, c, t = _vec(x)
    with np.errstate(all="ignore"):
        ns, nc, nt = np.sin(x), np.cos(x), np.tanh(x)
    # sin, cos: within 2 ulp where the value is not tiny; near a zero of sin or cos
    # the error is the argument reduction's, absolute: |x| 2^-100 at most
    for mine, ref in ((s, ns), (c, nc)):
        err = np.abs(mine - ref)
        assert np.all((_ulps(mine, ref) <= 2) | (err <= 1e-30 * np.maximum(1.0, np.abs(x))))
    assert _ulps(t, nt).max() <= 3


def test_identities_hold_to_rounding():
    x = _inputs()
    x = x[np.abs(x) <= _vecmath.SINCOS_LIMIT]
    s, c, t = _vec(x)
    assert np.abs(s * s + c * c - 1.0).max() <= 4 * np.finfo(float).eps
    s2, c2, t2 = _vec(-x)
    np.testing.assert_array_equal(s2, -s)  # odd
    np.testing.assert_array_equal(c2, c)   # even
    np.testing.assert_array_equal(t2, -t)  # odd
    assert np.all(np.abs(t) <= 1.0)
    # tanh is increasing, up to its rounding (3 ulp)
    tg = _vec(np.linspace(-25, 25, 100_001))[2]
    assert np.all(np.diff(tg) >= -3 * np.spacing(np.abs(tg[1:])))


def test_special_values_are_numpys():
    x = np.array([0.0, -0.0, np.nan, np.inf, -np.inf, 5e-324, -5e-324, 20.0, 700.0, -1e300])
    s, c, t = _vec(x)
    with np.errstate(invalid="ignore"):
        for mine, ref in ((s[:8], np.sin(x[:8])), (c[:8], np.cos(x[:8]))):
            np.testing.assert_array_equal(mine, ref)
            number = ~np.isnan(ref)  # (a NaN's sign means nothing)
            assert np.array_equal(np.signbit(mine[number]), np.signbit(ref[number]))
        np.testing.assert_array_equal(t, np.tanh(x))
    assert np.array_equal(np.signbit(t), np.signbit(np.tanh(x)))


def test_beyond_the_exact_reduction_sin_and_cos_are_nan_not_wrong():
    x = np.array([_vecmath.SINCOS_LIMIT * 1.0000001, -1e9, 1e15, 1e300])
    s, c, t = _vec(x)
    assert np.isnan(s).all() and np.isnan(c).all()
    np.testing.assert_array_equal(t, np.sign(x))


def test_the_engine_uses_them_and_its_right_hand_side_calls_no_maths_library():
    """The loop's right-hand side as the engine compiles it (the equations inlined):
    no call to sin, cos or tanh of the C library is left in it. (Compiled here without
    numba's cache, which keeps machine code but not the compiler's intermediate form.)"""
    rates = numba.njit(error_model="numpy")(_kernels.loop_rates.py_func)
    p = ClosedLoop(Scenario.paper(4)).P[0]
    rates(0.5, np.zeros(13), (p, (0.0, 0.0, 0.0, 0.0)), np.zeros(14))
    ir = rates.inspect_llvm(rates.signatures[0])
    called = set(re.findall(r"call [^@]*@([\w.$]+)", ir))
    assert not {"sin", "cos", "tanh", "llvm.sin.f64", "llvm.cos.f64"} & called, called
    assert "llvm.floor.f64" in called  # the argument reduction of vecmath's sin and cos


def test_the_equations_give_the_same_numbers_compiled_and_in_numpy():
    """Eq. (10) and its rate, compiled with these functions, against numpy's on the
    same seeded random states: equal to a few ulps of the result's size."""
    rng = np.random.default_rng(7)
    args = [rng.uniform(-3, 3, 2000) for _ in range(11)] + [
        rng.uniform(0.1, 0.3, 2000), rng.uniform(0.1, 10, 2000), rng.uniform(0.1, 10, 2000),
        rng.uniform(0.1, 1, 2000), rng.uniform(0.1, 1, 2000)]
    ref = np.array(equations.kinematic_law_rate(*args))

    @numba.njit
    def compiled(a):
        out = np.empty((4, a.shape[1]))
        for i in range(a.shape[1]):
            r = equations.kinematic_law_rate(a[0, i], a[1, i], a[2, i], a[3, i], a[4, i], a[5, i],
                                             a[6, i], a[7, i], a[8, i], a[9, i], a[10, i], a[11, i],
                                             a[12, i], a[13, i], a[14, i], a[15, i])
            out[0, i], out[1, i], out[2, i], out[3, i] = r
        return out

    got = compiled(np.array(args))
    scale = np.abs(ref).max(axis=1, keepdims=True)
    assert np.all(np.abs(got - ref) <= 1e-14 * scale)
