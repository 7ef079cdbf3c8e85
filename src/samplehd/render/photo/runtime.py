"""Load Mitsuba 3 and Open Image Denoise for the photo preset, choosing the backend.

* An NVIDIA GPU (CUDA driver present) → Mitsuba's ``cuda_ad_rgb`` variant; otherwise ``llvm_ad_rgb``
  on the CPU. ``SAMPLEHD_PHOTO_VARIANT`` overrides the choice.
* The CPU variant compiles kernels with LLVM. Debian 12's default LLVM 15 crashes Mitsuba's backend
  ("Cannot select: fminimum"), so samplehd looks for LLVM ≥ 16 itself (Debian's ``libllvm19``) and
  points ``DRJIT_LIBLLVM_PATH`` at it, unless the user set that variable.
* Anything missing gives one line saying what to install.
"""

from __future__ import annotations

import ctypes.util
import glob
import os
import re
import threading
from typing import Any

from samplehd.errors import RenderError

__all__ = ["INSTALL_HINT", "find_llvm", "load_drjit", "load_mitsuba", "load_oidn", "photo_backend"]

INSTALL_HINT = "pip install 'samplehd[photo]' (mitsuba, pyoidn)"
LLVM_HINT = "apt-get install libllvm19 (Debian 12; LLVM 15 crashes Mitsuba), or set DRJIT_LIBLLVM_PATH"
_MIN_LLVM = 16
_LOCK = threading.Lock()
_STATE: dict[str, Any] = {}


_VERSION = re.compile(r"(?:libLLVM-|libLLVM\.so\.|llvm-|libLLVM\.)(\d+)")


def _llvm_version(path: str) -> int:
    m = _VERSION.search(path)
    return int(m.group(1)) if m else 0


def find_llvm(search: tuple[str, ...] = ("/usr/lib/x86_64-linux-gnu", "/usr/lib/aarch64-linux-gnu", "/usr/lib64",
                                          "/usr/lib", "/usr/local/lib", "/opt/homebrew/opt/llvm/lib",
                                          "/usr/local/opt/llvm/lib")) -> str | None:
    """Path of the newest shared libLLVM >= 16 on this machine, or None."""
    found: list[tuple[int, str]] = []
    for d in search:
        for pattern in ("libLLVM-[0-9]*.so*", "libLLVM.so.[0-9]*", "llvm-[0-9]*/lib/libLLVM*.so*", "libLLVM*.dylib"):
            for path in sorted(glob.glob(os.path.join(d, pattern))):
                v = _llvm_version(path)
                if v >= _MIN_LLVM and os.path.isfile(path):
                    found.append((v, path))
    return max(found)[1] if found else None


def _has_cuda() -> bool:
    return ctypes.util.find_library("cuda") is not None and any(
        os.path.exists(p) for p in ("/dev/nvidiactl", "/dev/nvidia0"))


def photo_backend() -> str:
    """The Mitsuba variant the photo preset uses here (without loading anything)."""
    want = os.environ.get("SAMPLEHD_PHOTO_VARIANT", "").strip()
    if want:
        if want not in ("llvm_ad_rgb", "cuda_ad_rgb"):
            raise RenderError(f"SAMPLEHD_PHOTO_VARIANT={want!r} is invalid; valid: llvm_ad_rgb, cuda_ad_rgb")
        return want
    return "cuda_ad_rgb" if _has_cuda() else "llvm_ad_rgb"


def load_mitsuba() -> Any:
    """Import Mitsuba, set its variant once per process, and return the module.

    Raises:
        RenderError: Mitsuba/pyoidn or a suitable LLVM is missing (one line: what to install).
    """
    with _LOCK:
        if "mi" in _STATE:
            return _STATE["mi"]
        variant = photo_backend()
        if variant == "llvm_ad_rgb" and not os.environ.get("DRJIT_LIBLLVM_PATH"):
            llvm = find_llvm()
            if llvm is None:
                raise RenderError(f"the photo preset needs LLVM >= {_MIN_LLVM} for Mitsuba's CPU backend: {LLVM_HINT}")
            os.environ["DRJIT_LIBLLVM_PATH"] = llvm
        try:
            import drjit
            import mitsuba as mi
            import pyoidn
        except ImportError as exc:
            raise RenderError(f"the photo preset needs {exc.name}: {INSTALL_HINT}") from None
        try:
            mi.set_variant(variant)
        except (ImportError, AttributeError, RuntimeError) as exc:
            hint = LLVM_HINT if variant.startswith("llvm") else "an NVIDIA driver with CUDA"
            raise RenderError(f"cannot start Mitsuba's {variant} backend ({exc}); needs {hint}") from None
        _STATE["mi"] = mi
        _STATE["dr"] = drjit
        _STATE["oidn"] = pyoidn
        _STATE["variant"] = variant
        return mi


def load_drjit() -> Any:
    """Dr.Jit, Mitsuba's array library, once :func:`load_mitsuba` has set the variant."""
    load_mitsuba()
    return _STATE["dr"]


def load_oidn() -> Any:
    """Open Image Denoise's Python module (``pyoidn``), loaded with Mitsuba."""
    load_mitsuba()
    return _STATE["oidn"]
