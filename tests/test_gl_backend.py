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
