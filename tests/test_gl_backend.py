import os
import subprocess
import sys

import pytest

from samplehd.errors import RenderError
from samplehd.render.backend import choose_gl_backend, configure_gl_backend


def test_user_choice_is_respected():
    assert choose_gl_backend({"MUJOCO_GL": "osmesa"}) == "osmesa"
    assert choose_gl_backend({"MUJOCO_GL": "EGL"}) == "egl"


def test_defaults_per_platform():
    assert choose_gl_backend({}, platform="linux") == "egl"
    assert choose_gl_backend({}, platform="darwin") == "cgl"
    assert choose_gl_backend({}, platform="win32") == "glfw"


def test_invalid_value_lists_valid_ones():
    with pytest.raises(RenderError, match=r"MUJOCO_GL='vulkan' is not a valid backend; use one of egl, osmesa"):
        choose_gl_backend({"MUJOCO_GL": "vulkan"})


def test_configure_sets_pyopengl_platform_to_match():
    env: dict[str, str] = {}
    assert configure_gl_backend(env) in ("egl", "cgl", "glfw")
    env = {"MUJOCO_GL": "osmesa"}
    configure_gl_backend(env)
    assert env["PYOPENGL_PLATFORM"] == "osmesa"


_IMPORT_MUJOCO_FIRST = """
import mujoco  # before samplehd: MuJoCo picks its GL backend with MUJOCO_GL unset
import samplehd

import numpy as np

from samplehd.render.renderer import SceneRenderer
from samplehd.scene.world import compile_world

model, data = compile_world()
with SceneRenderer(model, 64, 48, "fast") as renderer:
    rgb = renderer.render(data, "operator", ("rgb",))["rgb"]
assert rgb.shape == (48, 64, 3), rgb.shape
print("colours", len(np.unique(rgb.reshape(-1, 3), axis=0)))
"""


@pytest.mark.render
def test_renders_headless_when_mujoco_is_imported_before_samplehd() -> None:
    env = {k: v for k, v in os.environ.items() if k not in ("MUJOCO_GL", "PYOPENGL_PLATFORM")}
    proc = subprocess.run(
        [sys.executable, "-c", _IMPORT_MUJOCO_FIRST], env=env, capture_output=True, text=True, timeout=180
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    colours = int(proc.stdout.split("colours", 1)[1].split()[0])
    assert colours > 1, "the image is all one colour"
