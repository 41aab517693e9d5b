"""sin, cos and tanh of a float64 for compiled code, as straight-line arithmetic
(numba; imported by :mod:`unidyn.engine.jit` only).

numba compiles ``np.sin``, ``np.cos`` and ``np.tanh`` of a scalar to calls into the
C maths library, which the optimiser can neither inline nor share between the
equations. The functions here are numba intrinsics: each call site receives LLVM
instructions without a call or a branch (argument reduction, a polynomial, selects),
which the optimiser schedules with the rest of the right-hand side, merges where two
equations take the sine of the same angle, and vectorises where a loop allows
(``python benchmarks/engines.py`` prints their cost beside the library's).

The methods are the classical ones of fdlibm (the C maths library of Sun, on which
most others build):

- **sin, cos:** x = n pi/2 + r with |r| <= pi/4, n = round(2x/pi), r by a
  four-part Cody-Waite subtraction (exact products for |x| < 2^26 pi/2); sin r
  and cos r by fdlibm's minimax polynomials (``__kernel_sin``, ``__kernel_cos``);
  the quadrant n mod 4 picks and signs them. For |x| > :data:`SINCOS_LIMIT` = 1e8
  (a heading after 16 million turns) the result is NaN rather than an inaccurate
  number, so the compiled engine stops such a run with a non-finite state.
- **tanh:** tanh|x| = e / (e + 2) with e = expm1(2|x|) = 2^k (1 + p) - 1, where
  2|x| = k ln 2 + r, |r| <= ln(2)/2, and p = expm1(r) by its Taylor polynomial to
  r^13; 2|x| is capped at 40, where tanh is 1 in float64; the sign is copied
  from x.

Within 2 units in the last place (ulp) of numpy for sin and cos, 3 for tanh
(numpy's are within 1 of the exact value). NaN gives NaN, +-inf gives NaN for sin
and cos and +-1 for tanh, as in numpy.
``tests/engine/test_vecmath.py`` compares them with numpy on seeded random inputs from
1e-300 to 1e8 (and beside multiples of pi/2) and on the special values.
"""

from __future__ import annotations

import math

from llvmlite import ir
from numba.core import cgutils, types
from numba.extending import intrinsic

__all__ = ["sin", "cos", "tanh", "SINCOS_LIMIT"]

#: |x| beyond which sin and cos return NaN (the reduction is exact below 2^26 pi/2).
SINCOS_LIMIT = 1e8

_F64 = ir.DoubleType()
_I64 = ir.IntType(64)

# pi/2 in four parts, truncated to 27, 25, 25 and 50 significant bits: n times each
# of the first three is exact for |n| < 2^26; the four add up to pi/2 within 1e-43.
_PIO2 = (1.570796325802803, 9.920935739593517e-10, 5.721188709663575e-18,
         1.6446256936324258e-26)
_TWO_OVER_PI = 6.36619772367581382433e-01

# fdlibm __kernel_sin and __kernel_cos, |r| <= pi/4.
_S = (-1.66666666666666324348e-01, 8.33333333332248946124e-03, -1.98412698298579493134e-04,
      2.75573137070700676789e-06, -2.50507602534068634195e-08, 1.58969099521155010221e-10)
_C = (4.16666666666666019037e-02, -1.38888888888741095749e-03, 2.48015872894767294178e-05,
      -2.75573143513906633035e-07, 2.08757232129817482790e-09, -1.13596475577881948265e-11)

# ln 2 in two parts (fdlibm's ln2_hi, 32 bits, and ln2_lo).
_LN2_HI = 6.93147180369123816490e-01
_LN2_LO = 1.90821492927058770002e-10
_TANH_CAP = 40.0  # 2|x| beyond which tanh x is +-1 in float64
_ROUND = 6755399441055744.0  # 1.5 * 2^52: x + _ROUND holds round(x) in its low bits


def _c(value):
    return ir.Constant(_F64, value)


def _poly(b, z, coefficients):
    """c0 + z (c1 + z (c2 + ...)) by Horner's rule."""
    acc = _c(coefficients[-1])
    for c in reversed(coefficients[:-1]):
        acc = b.fadd(_c(c), b.fmul(z, acc))
    return acc


def _floor(b, x):
    fn = cgutils.get_or_insert_function(b.module, ir.FunctionType(_F64, [_F64]), "llvm.floor.f64")
    return b.call(fn, [x])


def _sincos(b, x):
    """(sin x, cos x) as LLVM values."""
    n = _floor(b, b.fadd(b.fmul(x, _c(_TWO_OVER_PI)), _c(0.5)))
    r = x
    for part in _PIO2:
        r = b.fsub(r, b.fmul(n, _c(part)))
    z = b.fmul(r, r)
    # sin r = r + r^3 (S1 + z S2 + ...)
    s = b.fadd(r, b.fmul(b.fmul(z, r), _poly(b, z, _S)))
    # cos r = w + ((1 - w) - z/2 + z^2 (C1 + z C2 + ...)), w = 1 - z/2 (fdlibm's form)
    hz = b.fmul(z, _c(0.5))
    w = b.fsub(_c(1.0), hz)
    c = b.fadd(w, b.fadd(b.fsub(b.fsub(_c(1.0), w), hz), b.fmul(b.fmul(z, z), _poly(b, z, _C))))
    q = b.fsub(n, b.fmul(_c(4.0), _floor(b, b.fmul(n, _c(0.25)))))  # n mod 4, exact
    odd = b.or_(b.fcmp_ordered("==", q, _c(1.0)), b.fcmp_ordered("==", q, _c(3.0)))
    sin_r = b.select(odd, c, s)
    cos_r = b.select(odd, s, c)
    sin_x = b.select(b.fcmp_ordered(">=", q, _c(2.0)), b.fneg(sin_r), sin_r)
    sin_x = b.select(b.fcmp_ordered("==", x, _c(0.0)), x, sin_x)  # sin(-0) = -0
    cos_neg = b.or_(b.fcmp_ordered("==", q, _c(1.0)), b.fcmp_ordered("==", q, _c(2.0)))
    cos_x = b.select(cos_neg, b.fneg(cos_r), cos_r)
    fabs = cgutils.get_or_insert_function(b.module, ir.FunctionType(_F64, [_F64]), "llvm.fabs.f64")
    far = b.fcmp_unordered(">", b.call(fabs, [x]), _c(SINCOS_LIMIT))  # or NaN
    nan = _c(math.nan)
    return b.select(far, nan, sin_x), b.select(far, nan, cos_x)


def _tanh(b, x):
    fabs = cgutils.get_or_insert_function(b.module, ir.FunctionType(_F64, [_F64]), "llvm.fabs.f64")
    copysign = cgutils.get_or_insert_function(
        b.module, ir.FunctionType(_F64, [_F64, _F64]), "llvm.copysign.f64")
    y = b.fmul(b.call(fabs, [x]), _c(2.0))
    y = b.select(b.fcmp_ordered(">", y, _c(_TANH_CAP)), _c(_TANH_CAP), y)  # NaN stays
    # k = round(y / ln 2), read from the low bits of y / ln 2 + 1.5 * 2^52
    shifted = b.fadd(b.fmul(y, _c(1.0 / math.log(2.0))), _c(_ROUND))
    k = b.fsub(shifted, _c(_ROUND))
    r = b.fsub(b.fsub(y, b.fmul(k, _c(_LN2_HI))), b.fmul(k, _c(_LN2_LO)))
    taylor = tuple(1.0 / math.factorial(j) for j in range(2, 14))
    p = b.fadd(r, b.fmul(b.fmul(r, r), _poly(b, r, taylor)))  # expm1(r)
    k_int = b.sub(b.bitcast(shifted, _I64), b.bitcast(_c(_ROUND), _I64))
    two_k = b.bitcast(b.shl(b.add(k_int, ir.Constant(_I64, 1023)), ir.Constant(_I64, 52)), _F64)
    e = b.fadd(b.fmul(two_k, p), b.fsub(two_k, _c(1.0)))  # expm1(y)
    return b.call(copysign, [b.fdiv(e, b.fadd(e, _c(2.0))), x])


def _unary(emit, name):
    """A numba intrinsic of float64 -> float64 whose body is emit(builder, x)."""
    def typer(typingctx, x):
        if x != types.float64:
            return None
        sig = types.float64(types.float64)

        def codegen(context, builder, signature, args):
            return emit(builder, args[0])
        return sig, codegen
    typer.__name__ = typer.__qualname__ = name
    return intrinsic(typer)


sin = _unary(lambda b, x: _sincos(b, x)[0], "sin")
cos = _unary(lambda b, x: _sincos(b, x)[1], "cos")
tanh = _unary(_tanh, "tanh")
