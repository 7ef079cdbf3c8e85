"""A state-only environment makes no GL context in its process, and samples the same scenes."""

from __future__ import annotations

import subprocess
import sys

PROBE = """
import sys
import gymnasium as gym
import samplehd
env = gym.make("samplehd/Tabletop-v0", max_episode_steps=5)
env.reset(seed=3)
env.step(env.action_space.sample())
from samplehd.render import renderer
egl = sys.modules.get("mujoco.egl")
osm = sys.modules.get("mujoco.osmesa")
print("display", None if egl is None else egl.EGL_DISPLAY, "osmesa", osm is not None and osm.__dict__.get("_CONTEXT"),
      "context", getattr(renderer._THREAD, "gl", None))
"""


def test_state_env_makes_no_gl_context() -> None:
    out = subprocess.run([sys.executable, "-c", PROBE], capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr[-2000:]
    assert out.stdout.split()[-6:] == ["display", "None", "osmesa", "False", "context", "None"], out.stdout


def test_child_sampling_gives_the_same_scene() -> None:
    from samplehd.envs import episodes
    from samplehd.scene.config import SceneConfig

    config = SceneConfig(min_objects=3, max_objects=3)
    child = episodes.SceneCache(config, gl_free=True).scene(seed=11, index=2)
    episodes._SAMPLED.clear()
    here = episodes.SceneCache(config).scene(seed=11, index=2)
    assert child.to_dict() == here.to_dict()
