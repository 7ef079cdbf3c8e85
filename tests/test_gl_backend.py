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


def test_nvidia_egl_driver_outside_the_standard_folders_is_found_ahead_of_mesa(tmp_path):
    from samplehd.render.backend import egl_vendor_dirs

    standard = [tmp_path / "etc", tmp_path / "share"]
    nvidia = tmp_path / "usr_local_nvidia"
    for d in (*standard, nvidia):
        d.mkdir()
    (standard[1] / "50_mesa.json").write_text("{}")
    std, extra = [str(d) for d in standard], [str(nvidia)]
    assert egl_vendor_dirs({}, std, extra) is None  # no NVIDIA driver: Mesa alone, nothing to set
    (nvidia / "10_nvidia.json").write_text("{}")
    assert egl_vendor_dirs({}, std, extra) == ":".join([str(nvidia), *std])
    # a user's glvnd settings win; a driver in a standard folder needs nothing
    assert egl_vendor_dirs({"__EGL_VENDOR_LIBRARY_FILENAMES": "/x/10_nvidia.json"}, std, extra) is None
    assert egl_vendor_dirs({"__EGL_VENDOR_LIBRARY_DIRS": "/x"}, std, extra) is None
    (standard[0] / "10_nvidia.json").write_text("{}")
    assert egl_vendor_dirs({}, std, extra) is None


def test_configure_adds_the_nvidia_folder_for_egl_only(tmp_path, monkeypatch):
    import samplehd.render.backend as backend

    (tmp_path / "nvidia").mkdir()
    (tmp_path / "nvidia" / "10_nvidia.json").write_text("{}")
    monkeypatch.setattr(backend, "STANDARD_EGL_VENDOR_DIRS", (str(tmp_path / "share"),))
    monkeypatch.setattr(backend, "EXTRA_EGL_VENDOR_DIRS", (str(tmp_path / "nvidia"),))
    env: dict[str, str] = {"MUJOCO_GL": "egl"}
    configure_gl_backend(env)
    assert env["__EGL_VENDOR_LIBRARY_DIRS"] == f"{tmp_path / 'nvidia'}:{tmp_path / 'share'}"
    env = {"MUJOCO_GL": "osmesa"}
    configure_gl_backend(env)
    assert "__EGL_VENDOR_LIBRARY_DIRS" not in env
