"""Arithmetic with the same bits on every machine, for everything that feeds physics or recorded data.

Two parts of numpy give different bits on different machines:

- **BLAS and LAPACK.** numpy hands matrix products (``@``, ``np.dot``, ``np.linalg.norm`` of a vector)
  to BLAS and solves/eigen-decompositions to LAPACK. OpenBLAS picks its kernel by the CPU (or by
  ``OPENBLAS_CORETYPE``) and kernels round differently: one fuses a multiply into an add, another sums
  in another order. :func:`matmul`, :func:`dot`, :func:`norm`, :func:`inv_rigid` and
  :func:`half_turn_axis` spell the arithmetic out instead: a product of matrices sums the terms
  ``a[i, k] * b[k, j]`` in index order k = 0, 1, ..., each product and each sum rounded on its own
  (numpy's elementwise multiply and add, never a fused multiply-add).
- **CPU-dispatched elementary functions.** numpy's float64 ``arctan2``, ``arccos``, ``arcsin``,
  ``tan``, ``exp``, ``log``, ``power`` ... run SIMD code chosen by the CPU (AVX-512 or not) whose last
  bit differs from the C library's. :func:`arctan2`, :func:`arccos` and :func:`arcsin` call the C
  library's functions (Python's :mod:`math`) element by element; for a scalar, call :mod:`math`.

The differences start in the 16th digit and grow through contact until episodes end differently. With
these, a dataset's bits depend on the versions of samplehd, MuJoCo, numpy and the C library only.
The functions take arrays of any batch shape, like the numpy calls they replace; for a single small
matrix they cost a few microseconds more than BLAS, for stacks of them about the same.
"""

from __future__ import annotations

import ctypes
import math
import platform
import re
from collections.abc import Callable
from pathlib import Path

import numpy as np

__all__ = ["arccos", "arcsin", "arctan2", "dot", "half_turn_axis", "inv_rigid", "machine", "matmul", "norm"]


def matmul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``a @ b`` (numpy's matmul semantics: batch dimensions broadcast, 1-D operands are vectors).

    Each entry is ``((a0 b0 + a1 b1) + a2 b2) + ...`` over the shared index, in order.
    """
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    if a.ndim == 0 or b.ndim == 0:
        raise ValueError("matmul: scalar operands are not matrices")
    vec_a, vec_b = a.ndim == 1, b.ndim == 1
    if vec_a:
        a = a[None, :]
    if vec_b:
        b = b[:, None]
    n = a.shape[-1]
    if b.shape[-2] != n:
        raise ValueError(f"matmul: shapes {a.shape} and {b.shape} do not align")
    out = a[..., :, 0, None] * b[..., None, 0, :]
    for k in range(1, n):
        out += a[..., :, k, None] * b[..., None, k, :]
    if vec_b:
        out = out[..., 0]
    if vec_a:
        out = out[..., 0, :] if not vec_b else out[..., 0]
    return out


def dot(a: np.ndarray, b: np.ndarray) -> float:
    """The dot product of two vectors, summed in index order."""
    s = 0.0
    for x, y in zip(np.asarray(a, dtype=float).tolist(), np.asarray(b, dtype=float).tolist(), strict=True):
        s += x * y
    return s


def norm(v: np.ndarray, axis: int | None = None) -> float | np.ndarray:
    """Euclidean length of a vector (``axis=None``, a float) or of each vector along ``axis``.

    The squares are summed in index order; the square root is correctly rounded everywhere.
    """
    v = np.asarray(v, dtype=float)
    if axis is None:
        s = 0.0
        for x in v.ravel().tolist():
            s += x * x
        return math.sqrt(s)
    v = np.moveaxis(v, axis, -1)
    s = v[..., 0] * v[..., 0]
    for k in range(1, v.shape[-1]):
        s += v[..., k] * v[..., k]
    return np.sqrt(s)


def inv_rigid(t: np.ndarray) -> np.ndarray:
    """Inverse of rigid transforms (..., 4, 4): rotation transposed, translation ``-Rᵀ p``."""
    t = np.asarray(t, dtype=float)
    rt = np.swapaxes(t[..., :3, :3], -1, -2)
    out = np.zeros_like(t)
    out[..., :3, :3] = rt
    out[..., :3, 3] = -matmul(rt, t[..., :3, 3:4])[..., 0]
    out[..., 3, 3] = 1.0
    return out


def half_turn_axis(r: np.ndarray) -> np.ndarray:
    """Unit axis of a rotation by (nearly) π, whose antisymmetric part is too small to give it.

    For a rotation by angle θ about u, ``(R + Rᵀ)/2 - cos θ I = (1 - cos θ) u uᵀ``: the column with the
    largest diagonal entry is u scaled by a positive number, so that component of the axis is positive.
    """
    r = np.asarray(r, dtype=float)
    cos = min(1.0, max(-1.0, (float(r[0, 0] + r[1, 1] + r[2, 2]) - 1.0) / 2.0))
    m = (r + r.T) / 2.0 - cos * np.eye(3)
    i = int(np.argmax(np.diag(m)))
    col = m[:, i]
    return col / norm(col)


def _elementwise(f: Callable[..., float], *args: np.ndarray | float) -> np.ndarray:
    arrays = np.broadcast_arrays(*(np.asarray(a, dtype=float) for a in args))
    out = np.fromiter(map(f, *(a.ravel().tolist() for a in arrays)), dtype=float, count=arrays[0].size)
    return out.reshape(arrays[0].shape)


def _acos(x: float) -> float:
    return math.acos(x) if -1.0 <= x <= 1.0 else math.nan


def _asin(x: float) -> float:
    return math.asin(x) if -1.0 <= x <= 1.0 else math.nan


def arctan2(y: np.ndarray | float, x: np.ndarray | float) -> np.ndarray:
    """``np.arctan2`` by the C library's ``atan2``, element by element [rad]."""
    return _elementwise(math.atan2, y, x)


def arccos(x: np.ndarray | float) -> np.ndarray:
    """``np.arccos`` by the C library's ``acos`` (NaN outside [-1, 1], as numpy) [rad]."""
    return _elementwise(_acos, x)


def arcsin(x: np.ndarray | float) -> np.ndarray:
    """``np.arcsin`` by the C library's ``asin`` (NaN outside [-1, 1], as numpy) [rad]."""
    return _elementwise(_asin, x)


def _cpu_model() -> str:
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def _blas() -> dict[str, str | int]:
    """numpy's BLAS as loaded in this process: library, version and kernel (OpenBLAS), threads."""
    try:
        maps = Path("/proc/self/maps").read_text()
    except OSError:
        return {"library": "unknown"}
    paths = sorted({m for m in re.findall(r"(/\S*openblas\S*\.so[.\d]*)", maps)})
    for path in paths:
        name = Path(path).name
        prefix, suffix = ("scipy_", "64_") if "openblas64" in name else ("scipy_", "") if "scipy_openblas" in name \
            else ("", "")
        try:
            lib = ctypes.CDLL(path)
            corename = getattr(lib, f"{prefix}openblas_get_corename{suffix}")
            config = getattr(lib, f"{prefix}openblas_get_config{suffix}")
            threads = getattr(lib, f"{prefix}openblas_get_num_threads{suffix}")
        except (OSError, AttributeError):
            continue
        corename.restype = config.restype = ctypes.c_char_p
        return {"library": name, "config": config().decode(errors="replace").strip(),
                "kernel": corename().decode(errors="replace"), "threads": int(threads())}
    return {"library": ", ".join(Path(p).name for p in paths) or "unknown"}


def machine() -> dict[str, object]:
    """What this machine does differently from another: the CPU, numpy's BLAS (and the kernel it picked),
    the SIMD targets numpy dispatches to and the C library. None of it changes the data made with the
    functions of this module; it is recorded so that a difference can be traced (docs/FORMAT.md)."""
    try:
        from numpy._core._multiarray_umath import __cpu_dispatch__, __cpu_features__
        simd = [f for f in __cpu_dispatch__ if __cpu_features__.get(f)]
    except ImportError:  # numpy moved its private module
        simd = []
    libc, libc_version = platform.libc_ver()
    return {"cpu": _cpu_model(), "arch": platform.machine(), "blas": _blas(), "numpy_simd": simd,
            "libc": f"{libc} {libc_version}".strip()}
