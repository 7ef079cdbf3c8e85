"""Compiled loops of :mod:`samplehd.fixedmath`: batched small matrix products and fdlibm's arctangent.

Each loop does the IEEE operations its docstring names, one after the other: no fused multiply-add
(numba compiles without fast-math, so LLVM may neither contract a product into a sum nor reorder a
sum), no call into a math library (so no vector math library can stand in for one). Their results are
therefore the same bits on every machine, and equal to :mod:`samplehd.fixedmath`'s array expressions;
``tests/test_fixedmath.py`` checks both. The functions compile on their first call (a few seconds)
and numba caches the machine code on disk (it can change how fast, never what comes out).

fdlibm's ``s_atan.c`` and ``e_atan2.c`` (Copyright (C) 1993 by Sun Microsystems, Inc.: "Permission to
use, copy, modify, and distribute this software is freely granted, provided that this notice is
preserved.") give the arctangent's reduction, coefficients and special cases.
"""

from __future__ import annotations

import math

import numba
import numpy as np

__all__ = ["acos_flat", "asin_flat", "atan2_flat", "matmul_batch"]

_ATAN_HI = (4.63647609000806093515e-01, 7.85398163397448278999e-01, 9.82793723247329054082e-01,
            1.57079632679489655800e+00)
_ATAN_LO = (2.26987774529616870924e-17, 3.06161699786838301793e-17, 1.39033110312309984516e-17,
            6.12323399573676603587e-17)
_A0, _A1, _A2, _A3 = 3.33333333333329318027e-01, -1.99999999998764832476e-01, 1.42857142725034663711e-01, \
    -1.11111104054623557880e-01
_A4, _A5, _A6, _A7 = 9.09088713343650656196e-02, -7.69187620504482999495e-02, 6.66107313738753120669e-02, \
    -5.83357013379057348645e-02
_A8, _A9, _A10 = 4.97687799461593236017e-02, -3.65315727442169155270e-02, 1.62858201153657823623e-02
_PI, _PI_LO, _PI_2, _PI_4 = 3.1415926535897931160e+00, 1.2246467991473531772e-16, 1.5707963267948965580e+00, \
    7.8539816339744827900e-01


@numba.njit(cache=True, nogil=True)
def matmul_batch(a: np.ndarray, b: np.ndarray, out: np.ndarray) -> None:
    """``out[p] = a[p] @ b[p]`` for (B, n, k) and (B, k, m): each entry ``((a0 b0 + a1 b1) + a2 b2) + ...``."""
    n, k, m = a.shape[1], a.shape[2], b.shape[2]
    for p in range(a.shape[0]):
        for i in range(n):
            for j in range(m):
                s = a[p, i, 0] * b[p, 0, j]
                for q in range(1, k):
                    s += a[p, i, q] * b[p, q, j]
                out[p, i, j] = s


@numba.njit(cache=True, nogil=True, error_model="numpy")
def _atan_abs(ax: float) -> float:
    """atan of a non-negative ``ax`` (fdlibm's s_atan.c)."""
    if ax >= 2.0**66:
        return _ATAN_HI[3] + _ATAN_LO[3]
    if ax < 0.4375:
        if ax < 2.0**-27:
            return ax
        idx, x = -1, ax
    elif ax < 0.6875:
        idx, x = 0, (2.0 * ax - 1.0) / (2.0 + ax)
    elif ax < 1.1875:
        idx, x = 1, (ax - 1.0) / (ax + 1.0)
    elif ax < 2.4375:
        idx, x = 2, (ax - 1.5) / (1.0 + 1.5 * ax)
    else:
        idx, x = 3, -1.0 / ax
    z = x * x
    w = z * z
    s1 = z * (_A0 + w * (_A2 + w * (_A4 + w * (_A6 + w * (_A8 + w * _A10)))))
    s2 = w * (_A1 + w * (_A3 + w * (_A5 + w * (_A7 + w * _A9))))
    if idx < 0:
        return x - x * (s1 + s2)
    return _ATAN_HI[idx] - ((x * (s1 + s2) - _ATAN_LO[idx]) - x)


@numba.njit(cache=True, nogil=True, error_model="numpy")
def _atan2(y: float, x: float) -> float:
    """atan2(y, x) (fdlibm's e_atan2.c): signed zeros, infinities and NaN as C's ``atan2``."""
    if x != x or y != y:
        return x + y
    neg_y = math.copysign(1.0, y) < 0.0
    neg_x = math.copysign(1.0, x) < 0.0
    if y == 0.0:
        if not neg_x:
            return y
        return -_PI if neg_y else _PI
    if x == 0.0:
        return -_PI_2 if neg_y else _PI_2
    ax, ay = abs(x), abs(y)
    if ax == math.inf:
        if ay == math.inf:
            z = 3.0 * _PI_4 if neg_x else _PI_4
        else:
            z = _PI if neg_x else 0.0
        return -z if neg_y else z
    if ay == math.inf:
        return -_PI_2 if neg_y else _PI_2
    k = math.frexp(ay)[1] - math.frexp(ax)[1]
    if k > 60:
        z = _PI_2 + 0.5 * _PI_LO
    elif neg_x and k < -60:
        z = 0.0
    else:
        z = _atan_abs(ay / ax)
    if not neg_x:
        return -z if neg_y else z
    return (z - _PI_LO) - _PI if neg_y else _PI - (z - _PI_LO)


@numba.njit(cache=True, nogil=True, error_model="numpy")
def atan2_flat(y: np.ndarray, x: np.ndarray, out: np.ndarray) -> None:
    """``out[i] = atan2(y[i], x[i])`` over 1-D arrays."""
    for i in range(out.shape[0]):
        out[i] = _atan2(y[i], x[i])


@numba.njit(cache=True, nogil=True, error_model="numpy")
def acos_flat(x: np.ndarray, out: np.ndarray) -> None:
    """``out[i] = atan2(sqrt((1 - x)(1 + x)), x)``; NaN outside [-1, 1] (a square root is correctly
    rounded in IEEE arithmetic: the compiled ``sqrt`` is the processor's instruction)."""
    for i in range(out.shape[0]):
        v = x[i]
        out[i] = _atan2(math.sqrt((1.0 - v) * (1.0 + v)), v) if -1.0 <= v <= 1.0 else math.nan


@numba.njit(cache=True, nogil=True, error_model="numpy")
def asin_flat(x: np.ndarray, out: np.ndarray) -> None:
    """``out[i] = atan2(x, sqrt((1 - x)(1 + x)))``; NaN outside [-1, 1]."""
    for i in range(out.shape[0]):
        v = x[i]
        out[i] = _atan2(v, math.sqrt((1.0 - v) * (1.0 + v))) if -1.0 <= v <= 1.0 else math.nan
