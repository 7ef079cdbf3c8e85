"""Choose the OpenGL backend MuJoCo renders with, before ``mujoco`` is imported.

MuJoCo reads ``MUJOCO_GL`` once, when its rendering module is first imported, so this must run first.
``samplehd/__init__.py`` calls :func:`configure_gl_backend`, which makes any ``import samplehd`` safe.

On Linux the backend is EGL, which renders on an NVIDIA GPU where there is one and on Mesa's llvmpipe
(the CPU) otherwise, with no flag: glvnd's libEGL loads every vendor's driver named by the JSON files of
its vendor folders, and MuJoCo's EGL context takes the devices that CUDA numbers first (NVIDIA's; then
``CUDA_VISIBLE_DEVICES`` and ``MUJOCO_EGL_DEVICE_ID`` pick among them), falling back to the next device
(Mesa's) when one cannot be initialised. Some container hosts mount NVIDIA's driver outside the standard
folders (``/usr/local/nvidia``); :func:`egl_vendor_dirs` then adds its folder ahead of the standard ones,
so the GPU is found and Mesa stays the fallback.
"""

from __future__ import annotations

import os
import sys
from collections.abc import Mapping, MutableMapping, Sequence

from samplehd.errors import RenderError

__all__ = ["VALID_GL_BACKENDS", "choose_gl_backend", "configure_gl_backend", "egl_vendor_dirs"]

VALID_GL_BACKENDS = ("egl", "osmesa", "glfw", "cgl", "disable", "disabled")

# glvnd's EGL vendor folders when __EGL_VENDOR_LIBRARY_DIRS is unset, and where container hosts put NVIDIA's.
STANDARD_EGL_VENDOR_DIRS = ("/etc/glvnd/egl_vendor.d", "/usr/share/glvnd/egl_vendor.d")
EXTRA_EGL_VENDOR_DIRS = ("/usr/local/nvidia/share/glvnd/egl_vendor.d",)


def choose_gl_backend(environ: MutableMapping[str, str], platform: str = sys.platform) -> str:
    """Return the GL backend to use, respecting a user-set ``MUJOCO_GL``.

    Args:
        environ: the environment to read (injected so tests need not touch ``os.environ``).
        platform: ``sys.platform`` of the machine.

    Returns:
        ``MUJOCO_GL`` when the user set it; otherwise ``egl`` on Linux (headless or not, since EGL
        needs no display), ``cgl`` on macOS and ``glfw`` elsewhere.

    Raises:
        RenderError: the user's ``MUJOCO_GL`` is not a backend MuJoCo knows.
    """
    user = environ.get("MUJOCO_GL", "").strip().lower()
    if user:
        if user not in VALID_GL_BACKENDS:
            raise RenderError(
                f"MUJOCO_GL={environ['MUJOCO_GL']!r} is not a valid backend; "
                f"use one of {', '.join(VALID_GL_BACKENDS[:-1])}"
            )
        return user
    if platform.startswith("linux"):
        return "egl"
    if platform == "darwin":
        return "cgl"
    return "glfw"


def _has_vendor_file(folder: str, vendor: str) -> bool:
    try:
        return any(f.endswith(".json") and vendor in f.lower() for f in os.listdir(folder))
    except OSError:
        return False


def egl_vendor_dirs(environ: Mapping[str, str], standard: Sequence[str] | None = None,
                    extra: Sequence[str] | None = None) -> str | None:
    """The ``__EGL_VENDOR_LIBRARY_DIRS`` that lets glvnd find NVIDIA's EGL driver, or None to leave it unset.

    Returns the folders of ``extra`` holding an NVIDIA vendor file, then the ``standard`` ones (so Mesa stays
    the fallback), when no ``standard`` folder holds NVIDIA's file already; None when there is nothing to add
    or the user set glvnd's ``__EGL_VENDOR_LIBRARY_DIRS`` or ``__EGL_VENDOR_LIBRARY_FILENAMES``.
    """
    standard = STANDARD_EGL_VENDOR_DIRS if standard is None else standard
    extra = EXTRA_EGL_VENDOR_DIRS if extra is None else extra
    if environ.get("__EGL_VENDOR_LIBRARY_DIRS") or environ.get("__EGL_VENDOR_LIBRARY_FILENAMES"):
        return None
    if any(_has_vendor_file(d, "nvidia") for d in standard):
        return None
    found = [d for d in extra if _has_vendor_file(d, "nvidia")]
    return ":".join([*found, *standard]) if found else None


def configure_gl_backend(environ: MutableMapping[str, str] | None = None) -> str:
    """Set ``MUJOCO_GL`` (and PyOpenGL's platform to match; for EGL, glvnd's vendor folders where NVIDIA's
    driver is mounted outside the standard ones) in ``environ`` and return the backend."""
    env = os.environ if environ is None else environ
    backend = choose_gl_backend(env)
    env["MUJOCO_GL"] = backend
    if backend in ("egl", "osmesa") and "PYOPENGL_PLATFORM" not in env:
        env["PYOPENGL_PLATFORM"] = backend
    if backend == "egl":
        dirs = egl_vendor_dirs(env)
        if dirs:
            env["__EGL_VENDOR_LIBRARY_DIRS"] = dirs
    return backend
