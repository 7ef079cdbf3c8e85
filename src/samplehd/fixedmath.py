"""Arithmetic with the same bits on every machine, for everything that feeds physics or recorded data.

Two parts of numpy give different bits on different machines:

- **BLAS and LAPACK.** numpy hands matrix products (``@``, ``np.dot``, ``np.linalg.norm`` of a vector)
  to BLAS and solves/eigen-decompositions to LAPACK. OpenBLAS picks its kernel by the CPU (or by
  ``OPENBLAS_CORETYPE``) and kernels round differently: one fuses a multiply into an add, another sums
  in another order. :func:`matmul`, :func:`dot`, :func:`norm`, :func:`inv_rigid` and
  :func:`half_turn_axis` spell the arithmetic out instead: a product of matrices sums the terms
  ``a[i, k] * b[k, j]`` in index order k = 0, 1, ..., each product and each sum rounded on its own
  (never a fused multiply-add): Python's floats for one small product, numpy's elementwise multiply
  and add for a few, a compiled loop (:mod:`samplehd.fixedkernels`) for more, all with the same bits.
- **CPU-dispatched elementary functions.** numpy's float64 ``arctan2``, ``arccos``, ``arcsin``,
  ``tan``, ``exp``, ``log``, ``power`` ... run SIMD code chosen by the CPU (AVX-512 or not) whose last
  bit differs from the C library's. :func:`arctan2`, :func:`arccos` and :func:`arcsin` of arrays are
  fdlibm's algorithm in plain IEEE arithmetic (compiled, no math library called); for a scalar, call
  :mod:`math` (the C library, the same on every CPU with FMA).

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
from pathlib import Path
from types import ModuleType

import numpy as np

__all__ = ["arccos", "arcsin", "arctan2", "dot", "half_turn_axis", "inv_rigid", "machine", "matmul", "matmul_reference",
           "norm"]


def matmul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``a @ b`` (numpy's matmul semantics: batch dimensions broadcast, 1-D operands are vectors).

    Each entry is ``((a0 b0 + a1 b1) + a2 b2) + ...`` over the shared index, in order, every product and
    sum rounded on its own (a compiled loop, :func:`samplehd.fixedkernels.matmul_batch`).
    """
    a = np.asarray(a, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    if a.ndim == 0 or b.ndim == 0:
        raise ValueError("matmul: scalar operands are not matrices")
    vec_a, vec_b = a.ndim == 1, b.ndim == 1
    if vec_a:
        a = a[None, :]
    if vec_b:
        b = b[:, None]
    n, k, m = a.shape[-2], a.shape[-1], b.shape[-1]
    if b.shape[-2] != k:
        raise ValueError(f"matmul: shapes {a.shape} and {b.shape} do not align")
    if a.ndim == 2 and b.ndim == 2 and 0 < k and n * m <= 16:  # one small product: Python's float arithmetic
        columns = list(zip(*b.tolist(), strict=True))
        rows = []
        for row in a.tolist():
            out_row = []
            for col in columns:
                acc = row[0] * col[0]
                for q in range(1, k):
                    acc += row[q] * col[q]
                out_row.append(acc)
            rows.append(out_row)
        return _unvector(np.array(rows), vec_a, vec_b)
    batch = np.broadcast_shapes(a.shape[:-2], b.shape[:-2])
    if not k:
        return _unvector(np.zeros(batch + (n, m)), vec_a, vec_b)
    if math.prod(batch) <= _SMALL_BATCH:
        return _unvector(_products(a, b), vec_a, vec_b)
    a3 = np.ascontiguousarray(a if a.shape[:-2] == batch else np.broadcast_to(a, batch + (n, k))).reshape(-1, n, k)
    b3 = np.ascontiguousarray(b if b.shape[:-2] == batch else np.broadcast_to(b, batch + (k, m))).reshape(-1, k, m)
    out = np.empty((a3.shape[0], n, m))
    _kernels().matmul_batch(a3, b3, out)
    return _unvector(out.reshape(batch + (n, m)), vec_a, vec_b)


def _products(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``a @ b`` of (..., n, k) and (..., k, m), k >= 1, in numpy's elementwise multiply and add."""
    out = a[..., :, 0, None] * b[..., None, 0, :]
    for q in range(1, a.shape[-1]):
        out += a[..., :, q, None] * b[..., None, q, :]
    return out


def _unvector(out: np.ndarray, vec_a: bool, vec_b: bool) -> np.ndarray:
    if vec_b:
        out = out[..., 0]
    if vec_a:
        out = out[..., 0, :] if not vec_b else out[..., 0]
    return out


def matmul_reference(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """:func:`matmul` in numpy's elementwise multiply and add, whatever the batch (the same bits; tests)."""
    a = np.asarray(a, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    vec_a, vec_b = a.ndim == 1, b.ndim == 1
    return _unvector(_products(a[None, :] if vec_a else a, b[:, None] if vec_b else b), vec_a, vec_b)


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


_KERNELS: list[ModuleType] = []
# at most this many products in a batch are taken by numpy's elementwise operations (the same bits as
# the compiled loop, cheaper to start for one or a few small matrices)
_SMALL_BATCH = 8


def _kernels() -> ModuleType:
    """The compiled loops, loaded on first use (importing numba takes a moment)."""
    if not _KERNELS:
        import samplehd.fixedkernels

        _KERNELS.append(samplehd.fixedkernels)
    return _KERNELS[0]


def _flat(f: str, *args: np.ndarray | float) -> np.ndarray:
    arrays = [np.asarray(a, dtype=np.float64) for a in args]
    if any(a.shape != arrays[0].shape for a in arrays[1:]):  # broadcasting only where the shapes differ
        arrays = np.broadcast_arrays(*arrays)
    flat = [np.ascontiguousarray(a).reshape(-1) for a in arrays]
    out = np.empty(flat[0].shape[0])
    getattr(_KERNELS[0] if _KERNELS else _kernels(), f)(*flat, out)
    return out.reshape(arrays[0].shape)


def arctan2(y: np.ndarray | float, x: np.ndarray | float) -> np.ndarray:
    """``np.arctan2`` [rad] by fdlibm's algorithm in plain IEEE operations (within 1 ulp of the C
    library's ``atan2``; signed zeros, infinities and NaN as C's ``atan2``)."""
    return _flat("atan2_flat", y, x)


def arccos(x: np.ndarray | float) -> np.ndarray:
    """``np.arccos`` [rad] as ``arctan2(sqrt((1 - x)(1 + x)), x)`` (within 2 ulp; NaN outside [-1, 1])."""
    return _flat("acos_flat", x)


def arcsin(x: np.ndarray | float) -> np.ndarray:
    """``np.arcsin`` [rad] as ``arctan2(x, sqrt((1 - x)(1 + x)))`` (within 2 ulp; NaN outside [-1, 1])."""
    return _flat("asin_flat", x)


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
