"""The sensor axis: the documented noise amounts, drawn from the episode's seed, and the wrapper that
gives a Gymnasium user the same corrupted images `samplehd evaluate` gives a policy."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from samplehd.benchmark.axes import perturb
from samplehd.benchmark.sensor import SuiteSensor, corrupt_observation, sensor_rng
from samplehd.envs.suite_file import content_hash
from samplehd.envs.tabletop import TabletopEnv

# Twelve oracle-proven episodes of an earlier build of smoke
TWINS = Path(__file__).parent / "data" / "twins.json"


def test_strength_5_corrupts_images_by_the_documented_amounts_and_leaves_state_alone() -> None:
    twin = json.loads(TWINS.read_text())["episodes"][0]
    sensor = perturb(twin, "sensor", 5, seed=0)["sensor"]
    obs = {"scene_rgb": np.full((96, 96, 3), 128, np.uint8), "scene_depth": np.full((96, 96), 1.0, np.float32),
           "joint_pos": np.arange(6.0)}
    out = corrupt_observation(obs, sensor, sensor_rng(7))
    again = corrupt_observation(obs, sensor, sensor_rng(7))
    assert all(np.array_equal(out[k], again[k]) for k in obs)  # the episode's seed fixes the pixels
    assert np.array_equal(out["joint_pos"], obs["joint_pos"])
    assert out["scene_rgb"].dtype == np.uint8
    assert np.std(out["scene_rgb"].astype(float) - 128) == pytest.approx(20, rel=0.1)
    holes = out["scene_depth"] == 0
    assert holes.mean() == pytest.approx(0.20, abs=0.03)
    assert np.std(out["scene_depth"][~holes] - 1.0) == pytest.approx(0.01, rel=0.1)
    assert corrupt_observation(obs, None, sensor_rng(7))["scene_rgb"] is obs["scene_rgb"]


def test_the_wrapper_corrupts_a_sensor_episode_and_not_its_clean_twin(tmp_path: Path) -> None:
    raw = json.loads(TWINS.read_text())
    twin = raw["episodes"][0]
    raw["episodes"] = [twin, {"id": 1, **perturb(twin, "sensor", 5, seed=0)}]
    raw["content_hash"] = content_hash(raw["episodes"])
    path = tmp_path / "s.json"
    path.write_text(json.dumps(raw))
    env = SuiteSensor(TabletopEnv(obs_mode="rgbd", width=32, height=32))
    try:
        clean, _ = env.reset(options={"suite": str(path), "episode": 0})
        noisy, _ = env.reset(options={"suite": str(path), "episode": 1})
        seen = env.unwrapped.observer.observe(env.unwrapped.physics)  # what the env itself renders
        assert np.array_equal(seen["scene_rgb"], clean["scene_rgb"])
        assert not np.array_equal(noisy["scene_rgb"], clean["scene_rgb"])
        assert (noisy["scene_depth"] == 0).mean() > 0.1 and np.array_equal(noisy["joint_pos"], clean["joint_pos"])
    finally:
        env.close()
