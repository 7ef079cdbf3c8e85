"""The goldens: the same config and seed give the same data on any machine.

Each golden dataset (see golden.py) is generated in subprocesses under different BLAS kernels
(``OPENBLAS_CORETYPE`` unset, Haswell, Zen, Prescott), BLAS thread counts (1 and 2), worker counts
(1 and 2), and once with numpy's CPU-dispatched SIMD loops switched off (as on a CPU without AVX2 or
AVX-512); every run must equal the one fixture bit for bit. A pure refactoring keeps the fixtures; a
change that is meant to change the data regenerates them (see golden.py) and says why in its commit.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import pytest

from golden import GOLDENS, differences, fixture, summarise

_BLAS_ENV = ("OPENBLAS_CORETYPE", "OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS",
             "NPY_DISABLE_CPU_FEATURES", "NPY_ENABLE_CPU_FEATURES")


def _dispatched_simd() -> str:
    """numpy's SIMD targets above its baseline that this CPU runs (switched off by one variant)."""
    try:
        from numpy._core._multiarray_umath import __cpu_dispatch__, __cpu_features__
    except ImportError:
        return ""
    return " ".join(f for f in __cpu_dispatch__ if __cpu_features__.get(f))


def _has_avx2() -> bool:
    try:
        return " avx2" in Path("/proc/cpuinfo").read_text()
    except OSError:
        return False


# name -> (environment for the BLAS and numpy, --workers)
VARIANTS: dict[str, tuple[dict[str, str], int]] = {
    "native": ({}, 2),
    "Haswell, 1 thread": ({"OPENBLAS_CORETYPE": "Haswell", "OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1"}, 1),
    "Zen, 2 threads": ({"OPENBLAS_CORETYPE": "Zen", "OPENBLAS_NUM_THREADS": "2", "OMP_NUM_THREADS": "2"}, 2),
    "Prescott, 1 thread": ({"OPENBLAS_CORETYPE": "Prescott", "OPENBLAS_NUM_THREADS": "1"}, 2),
    "numpy without SIMD dispatch, 2 threads": ({"NPY_DISABLE_CPU_FEATURES": _dispatched_simd(),
                                                "OPENBLAS_NUM_THREADS": "2"}, 1),
}


def _skip_reason(variant: str) -> str | None:
    env, _ = VARIANTS[variant]
    if env.get("OPENBLAS_CORETYPE") in ("Haswell", "Zen") and not _has_avx2():
        return "this CPU has no AVX2 for that kernel"
    if "NPY_DISABLE_CPU_FEATURES" in env and not env["NPY_DISABLE_CPU_FEATURES"]:
        return "numpy dispatches no SIMD targets on this CPU"
    return None


def _generate(golden: str, variant: str, root: Path) -> tuple[Path, str]:
    env_over, workers = VARIANTS[variant]
    env = {k: v for k, v in os.environ.items() if k not in _BLAS_ENV}
    env.update(env_over)
    out = root / golden / variant.replace(" ", "_").replace(",", "")
    proc = subprocess.run([sys.executable, "-m", "samplehd", *GOLDENS[golden], "--workers", str(workers),
                           "--out", str(out), "--quiet"], capture_output=True, text=True, timeout=900, env=env)
    return out, proc.stderr[-2000:] if proc.returncode else ""


@pytest.fixture(scope="module")
def generated(tmp_path_factory) -> dict[tuple[str, str], tuple[Path, str]]:
    """Every golden under every variant that this machine can run: (golden, variant) -> (out, error)."""
    root = tmp_path_factory.mktemp("goldens")
    runs = [(g, v) for g in GOLDENS for v in VARIANTS if _skip_reason(v) is None]
    results = {runs[0]: _generate(*runs[0], root)}  # first alone: it compiles the free-spot loops once
    with ThreadPoolExecutor(2) as pool:
        futures = {run: pool.submit(_generate, *run, root) for run in runs[1:]}
        results.update({run: f.result() for run, f in futures.items()})
    return results


@pytest.mark.parametrize("variant", list(VARIANTS))
@pytest.mark.parametrize("golden", list(GOLDENS))
def test_golden_matches_on_every_kernel(generated, golden: str, variant: str) -> None:
    reason = _skip_reason(variant)
    if reason:
        pytest.skip(reason)
    out, error = generated[golden, variant]
    assert not error, error
    expected = json.loads(fixture(golden).read_text())
    diff = differences(expected, summarise(out))
    assert not diff, f"{golden} under {variant} differs from the golden fixture:\n" + "\n".join(diff)


def test_variants_ran_what_they_say(generated) -> None:
    """info.json records the machine: the runs really used other BLAS kernels and thread counts, and the
    SIMD variant really ran without numpy's dispatched targets (else the goldens above prove nothing)."""
    machines = {}
    for (_golden, variant), (out, error) in generated.items():
        assert not error, error
        machines[variant] = json.loads((out / "info.json").read_text())["machine"]
    for variant, m in machines.items():
        assert m["cpu"] and m["libc"] is not None
        env, _ = VARIANTS[variant]
        if "kernel" in m["blas"] and "OPENBLAS_NUM_THREADS" in env:
            assert m["blas"]["threads"] == int(env["OPENBLAS_NUM_THREADS"]), (variant, m["blas"])
        if "NPY_DISABLE_CPU_FEATURES" in env:
            assert m["numpy_simd"] == [], (variant, m["numpy_simd"])
    kernels = {m["blas"].get("kernel") for m in machines.values()}
    if None not in kernels:  # OpenBLAS (numpy's wheels): at least two kernels took part
        assert len(kernels) >= 2, kernels


@pytest.mark.parametrize("golden", list(GOLDENS))
def test_golden_replays_in_the_env(generated, golden: str) -> None:
    """The recorded actions of every golden episode, sent to the env from its start, reach the recorded
    outcome (six-object scenes included: the env's observation is sized by the dataset's scene options)."""
    out, error = generated[golden, "native"]
    assert not error, error
    proc = subprocess.run([sys.executable, "-m", "samplehd", "validate", str(out), "--replay"], capture_output=True,
                          text=True, timeout=900)
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-2000:]
    assert "replay to the recorded outcome" in proc.stdout
