"""samplehd.fixedmath: numpy's results to rounding, in one fixed order of IEEE operations, whatever the
BLAS kernel, BLAS threads or numpy's SIMD targets."""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys

import numpy as np
import pytest

from samplehd.fixedmath import (
    arccos,
    arcsin,
    arctan2,
    dot,
    half_turn_axis,
    inv_rigid,
    machine,
    matmul,
    matmul_reference,
    norm,
)
from samplehd.world.transforms import quat_to_mat, rotvec

SHAPES = [((3, 3), (3, 3)), ((4, 4), (4, 4)), ((3, 3), (3,)), ((3,), (3, 3)), ((3,), (3,)), ((7, 3, 3), (3, 3)),
          ((5, 1, 4, 4), (2, 4, 4)), ((2, 3), (3, 5)), ((6, 2), (2,)), ((8, 2, 2, 2), (8, 2, 2, 2)),
          ((300, 2, 2, 4, 4), (300, 1, 1, 4, 4)), ((40, 3, 3), (3,)), ((50, 2), (2, 2)), ((3, 0), (0, 2))]


@pytest.mark.parametrize(("sa", "sb"), SHAPES)
def test_matmul_is_numpy_matmul_to_rounding(sa, sb) -> None:
    rng = np.random.default_rng(0)
    a, b = rng.normal(size=sa), rng.normal(size=sb)
    want = a @ b
    got = matmul(a, b)
    assert np.shape(got) == np.shape(want)
    np.testing.assert_allclose(got, want, rtol=1e-13, atol=1e-14)
    # the compiled loop (large batches) and numpy's elementwise operations (small ones): the same bits
    np.testing.assert_array_equal(got, matmul_reference(a, b) if a.size and b.size else want)


def test_matmul_sums_in_index_order_without_fused_multiply_add() -> None:
    """Each entry is ((a0 b0 + a1 b1) + a2 b2) + ..., every product and sum rounded on its own: what
    Python's float arithmetic gives term by term."""
    rng = np.random.default_rng(1)
    a, b = rng.normal(size=(50, 4, 6)), rng.normal(size=(50, 6, 3))
    got = matmul(a, b)
    np.testing.assert_array_equal(matmul(a[:5], b[:5]), got[:5])  # numpy's path equals the compiled one
    for n in range(50):
        for i in range(4):
            for j in range(3):
                s = a[n, i, 0].item() * b[n, 0, j].item()
                for k in range(1, 6):
                    s += a[n, i, k].item() * b[n, k, j].item()
                assert got[n, i, j] == s
    v = rng.normal(size=9).tolist()
    w = rng.normal(size=9).tolist()
    s = 0.0
    for x, y in zip(v, w, strict=True):
        s += x * y
    assert dot(v, w) == s
    s2 = 0.0
    for x in v:
        s2 += x * x
    assert norm(v) == math.sqrt(s2)
    np.testing.assert_array_equal(norm(np.array([v, w]), axis=1), [norm(v), norm(w)])


def test_matmul_refuses_what_does_not_align() -> None:
    with pytest.raises(ValueError, match="do not align"):
        matmul(np.ones((3, 2)), np.ones((3, 3)))
    with pytest.raises(ValueError, match="scalar"):
        matmul(np.float64(2.0), np.ones(3))


def test_rigid_inverse_and_half_turns() -> None:
    rng = np.random.default_rng(2)
    for _ in range(50):
        q = rng.normal(size=4)
        t = np.eye(4)
        t[:3, :3] = quat_to_mat(q / np.linalg.norm(q))
        t[:3, 3] = rng.normal(size=3)
        np.testing.assert_allclose(matmul(t, inv_rigid(t)), np.eye(4), atol=1e-14)
        axis = rng.normal(size=3)
        axis /= np.linalg.norm(axis)
        half_turn = quat_to_mat(np.array([0.0, *axis]))  # rotation by π about axis
        got = half_turn_axis(half_turn)
        assert abs(abs(float(got @ axis)) - 1.0) < 1e-12
        assert got[int(np.argmax(np.abs(got)))] > 0
        rv = rotvec(half_turn)
        assert abs(np.linalg.norm(rv) - math.pi) < 1e-7  # acos near -1 keeps about half the digits


def _ulps(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.abs(np.asarray(a, dtype=float).view(np.int64) - np.asarray(b, dtype=float).view(np.int64))


def test_elementary_functions_are_within_ulps_of_the_c_librarys() -> None:
    rng = np.random.default_rng(3)
    for scale in (1e-12, 1e-3, 1.0, 1e3, 1e20):
        y, x = rng.normal(size=(2, 5000))
        y *= scale
        assert _ulps(arctan2(y, x), [math.atan2(a, b) for a, b in zip(y, x, strict=True)]).max() <= 1
    u = np.concatenate([rng.uniform(-1, 1, 5000), 1 - rng.uniform(0, 1e-6, 200), -1 + rng.uniform(0, 1e-6, 200),
                        [1.0, -1.0, 0.0, -0.0]])
    assert _ulps(arccos(u), [math.acos(v) for v in u]).max() <= 2
    assert _ulps(arcsin(u), [math.asin(v) for v in u]).max() <= 2
    assert np.isnan(arccos([1.5, -2.0, np.nan])).all() and np.isnan(arcsin(np.array([-1.0000001, 3.0]))).all()
    assert arctan2(np.ones((2, 1)), np.ones(3)).shape == (2, 3) and np.shape(arccos(0.5)) == ()


def test_atan2_special_values_are_c99s() -> None:
    """Signed zeros, infinities, NaN, subnormals and huge ratios, every pair: C's atan2 (1 ulp where a
    ratio over 2**60 meets a negative x)."""
    special = [0.0, -0.0, 1.0, -1.0, np.inf, -np.inf, np.nan, 1e-310, -1e-310, 1e300, -1e300]
    ys, xs = (a.ravel() for a in np.meshgrid(special, special))
    got = arctan2(ys, xs)
    for y, x, g in zip(ys, xs, got, strict=True):
        w = math.atan2(y, x)
        if math.isnan(w):
            assert math.isnan(g), (y, x)
        else:
            assert math.copysign(1.0, g) == math.copysign(1.0, w) and _ulps(g, w) <= 1, (y, x, g, w)


_PROBE = """
import hashlib, numpy as np
from samplehd.fixedmath import arccos, arctan2, matmul, norm
rng = np.random.default_rng(4)
a, b = rng.normal(size=(64, 4, 4)), rng.normal(size=(64, 4, 4))
parts = [matmul(a, b), matmul(a[:, :3, :3], b[:, :3, :1]), norm(a[:, 0, :3], axis=1),
         np.array([norm(r) for r in a[:, 0]]), arctan2(a[:, 0, 0], b[:, 0, 0]), arccos(np.clip(a[:, 1, 1] / 3, -1, 1))]
print(hashlib.sha256(b"".join(np.ascontiguousarray(p).tobytes() for p in parts)).hexdigest())
"""


def test_same_bits_under_every_blas_kernel_and_simd_target() -> None:
    """The products, norms and angles above, in processes with other BLAS kernels, thread counts and with
    numpy's SIMD dispatch off: one result (numpy's own ``@`` differs between some of them)."""
    from numpy._core._multiarray_umath import __cpu_dispatch__, __cpu_features__

    simd = " ".join(f for f in __cpu_dispatch__ if __cpu_features__.get(f))
    settings = [{}, {"OPENBLAS_CORETYPE": "Prescott", "OPENBLAS_NUM_THREADS": "1"},
                {"OPENBLAS_CORETYPE": "SkylakeX" if "avx512f" in _cpu_flags() else "Haswell"}]
    if simd:
        settings.append({"NPY_DISABLE_CPU_FEATURES": simd})
    hashes = set()
    for extra in settings:
        env = {k: v for k, v in os.environ.items() if not k.startswith(("OPENBLAS", "NPY_", "OMP_"))}
        env.update(extra)
        proc = subprocess.run([sys.executable, "-c", _PROBE], capture_output=True, text=True, env=env, timeout=120)
        assert proc.returncode == 0, proc.stderr
        hashes.add(proc.stdout.strip())
    assert len(hashes) == 1, hashes


def _cpu_flags() -> str:
    try:
        with open("/proc/cpuinfo") as f:
            return f.read()
    except OSError:
        return ""


def test_machine_names_the_blas_kernel_and_cpu() -> None:
    m = machine()
    assert m["cpu"] and m["arch"]
    assert isinstance(m["numpy_simd"], list)
    assert "library" in m["blas"]
    env = {k: v for k, v in os.environ.items() if not k.startswith("OPENBLAS")}
    env.update({"OPENBLAS_CORETYPE": "Prescott", "OPENBLAS_NUM_THREADS": "1"})
    code = "import json; from samplehd.fixedmath import machine; print(json.dumps(machine()['blas']))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=60).stdout
    if "kernel" in m["blas"]:  # OpenBLAS: the kernel and the threads in use are reported
        forced = json.loads(out)
        assert forced["threads"] == 1 and forced["kernel"] and forced["library"] == m["blas"]["library"]
