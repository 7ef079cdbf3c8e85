"""Choose the OpenGL backend MuJoCo renders with, before ``mujoco`` is imported.

MuJoCo reads ``MUJOCO_GL`` once, when its rendering module is first imported, so this must run first.
``samplehd/__init__.py`` calls :func:`configure_gl_backend`, which makes any ``import samplehd`` safe.
"""

from __future__ import annotations

import os
import sys
from collections.abc import MutableMapping

from samplehd.errors import RenderError

__all__ = ["VALID_GL_BACKENDS", "choose_gl_backend", "configure_gl_backend"]

VALID_GL_BACKENDS = ("egl", "osmesa", "glfw", "cgl", "disable", "disabled")


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


def configure_gl_backend(environ: MutableMapping[str, str] | None = None) -> str:
    """Set ``MUJOCO_GL`` (and PyOpenGL's platform to match) in ``environ`` and return the backend."""
    env = os.environ if environ is None else environ
    backend = choose_gl_backend(env)
    env["MUJOCO_GL"] = backend
    if backend in ("egl", "osmesa") and "PYOPENGL_PLATFORM" not in env:
        env["PYOPENGL_PLATFORM"] = backend
    return backend
