"""The LeRobot env contract (samplehd.envs.lerobot_tabletop): names and shapes of the export, is_success,
seeds of `samplehd evaluate`'s split; and, where lerobot is importable (its Python 3.12 venv), the
plugin's env factory and one LeRobot-style rollout step with a dummy policy."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from samplehd.envs.evaluation import benchmark_split
from samplehd.envs.lerobot_tabletop import (
    EXPORT_RECORD,
    LeRobotTabletop,
    env_options_from_export,
    make_lerobot_envs,
)
from samplehd.envs.levels import reset_at_level
from samplehd.envs.tabletop import TabletopEnv
from samplehd.errors import ConfigError
from samplehd.export.lerobot import _VECTOR_FEATURES, SAMPLEHD_RECORD, _env_record

SIZE = 32


@pytest.fixture()
def options(fast_options: dict) -> dict:
    return {**fast_options, "obs_mode": "rgb", "cameras": ["scene"], "width": SIZE, "height": SIZE}


def lerobot_keys(obs: dict[str, Any]) -> dict[str, tuple[int, ...]]:
    """Feature names and per-env shapes as LeRobot's preprocess_observation renames a raw observation:
    ``pixels`` dict → ``observation.images.<cam>`` (HWC → CHW), ``agent_pos`` → ``observation.state``,
    any other array ``k`` → ``observation.<k>``."""
    out = {f"observation.images.{cam}": (img.shape[2], *img.shape[:2]) for cam, img in obs["pixels"].items()}
    out["observation.state"] = obs["agent_pos"].shape
    out.update({f"observation.{k}": v.shape for k, v in obs.items() if k not in ("pixels", "agent_pos")})
    return out


def test_observations_are_named_and_shaped_as_the_export(options: dict) -> None:
    env = LeRobotTabletop("pick_up", options)
    obs, info = env.reset(seed=0)
    exported = {k: (n,) for k, (n, _) in _VECTOR_FEATURES.items() if k.startswith("observation")}
    exported["observation.images.scene"] = (3, SIZE, SIZE)  # (H, W, 3) in info.json, CHW once loaded
    assert lerobot_keys(obs) == exported
    assert env.observation_space.contains(obs)
    assert obs["pixels"]["scene"].dtype == np.uint8
    raw = env.inner._observation()
    assert np.allclose(obs["agent_pos"][:6], raw["joint_pos"]) and obs["agent_pos"][6] == pytest.approx(
        raw["gripper"][:2].sum())  # gripper opening [m], as the recorder's
    assert np.allclose(obs["tcp_pose"], np.concatenate([raw["tcp_pos"], raw["tcp_quat"]]))
    assert info["is_success"] is False and env.task == "pick_up" and env.task_description == info["instruction"]
    assert env._max_episode_steps == 1500 and env.action_space.shape == (7,) and env.metadata["render_fps"] == 20
    assert isinstance(env.metadata["render_fps"], int)  # lerobot-eval writes its videos with PyAV
    obs, reward, _, _, info = env.step(np.zeros(7, np.float32))
    assert info["is_success"] == info["success"] == env.inner.check_success()["success"]
    assert env.render() is obs["pixels"]["scene"]
    env.close()


def test_seeds_reproduce_the_evaluate_split_and_levels(options: dict) -> None:
    families = ("place", "pick_up")
    env = LeRobotTabletop("pick_up", options, families=families, split_seed=5)
    _, info = env.reset(seed=3)
    seed, family = benchmark_split(8, families, 5)[7]  # episode 3 of family 1 of 2
    assert info["split_episode"] == 7 and family == "pick_up" and info["reset_seed"] == seed
    plain = TabletopEnv(**{**options, "families": ["pick_up"]})
    _, ref = plain.reset(seed=seed, options={"family": "pick_up"})
    assert info["instruction"] == ref["instruction"] and info["scene_seed"] == ref["scene_seed"]
    _, info = env.reset()  # Gymnasium's autoreset: the next episode
    assert info["split_episode"] == 9
    leveled = LeRobotTabletop("pick_up", options, families=families, split_seed=5, level="L1")
    _, info = leveled.reset(seed=0)
    _, ref, used = reset_at_level(plain, benchmark_split(2, families, 5)[1][0], "pick_up", "L1")
    assert info["reset_seed"] == used and info["instruction"] == ref["instruction"]
    for e in (env, leveled, plain):
        e.close()


def test_vector_envs_are_lerobots_nesting(options: dict) -> None:
    envs = make_lerobot_envs(["pick_up"], options, n_envs=2, max_episode_steps=7)
    assert list(envs) == ["pick_up"] and list(envs["pick_up"]) == [0]
    vec = envs["pick_up"][0]
    obs, info = vec.reset(seed=[0, 1])
    assert obs["pixels"]["scene"].shape == (2, SIZE, SIZE, 3) and obs["agent_pos"].shape == (2, 7)
    assert list(info["split_episode"]) == [0, 1] and vec.call("_max_episode_steps") == (7, 7)
    assert all(vec.call("task_description"))
    _, _, _, _, info = vec.step(np.zeros((2, 7), np.float32))
    assert info["is_success"].dtype == bool and info["is_success"].shape == (2,)
    vec.close()


def test_bad_options_are_one_line(options: dict, tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match=r"level='L9': valid: L1, L2, L3, L4"):
        LeRobotTabletop("pick_up", options, level="L9")
    with pytest.raises(ConfigError, match=r"obs_mode='state'"):
        LeRobotTabletop("pick_up", {**options, "obs_mode": "state"})
    with pytest.raises(ConfigError, match=r"task='stack': not among"):
        LeRobotTabletop("stack", options, families=("pick_up",))
    with pytest.raises(ConfigError, match=r"cannot read meta/samplehd.json .*samplehd export lerobot"):
        env_options_from_export(tmp_path)


def test_the_export_record_builds_the_env(tmp_path: Path) -> None:
    from samplehd.dataset.config import GenerateConfig

    assert SAMPLEHD_RECORD == EXPORT_RECORD
    settings = {"scene": {"mode": "fast", "width": 64, "height": 48, "modalities": ["rgb"]}}
    record = _env_record(GenerateConfig().to_dict(), settings, ["scene"], ["pick_up"])
    (tmp_path / "meta").mkdir()
    (tmp_path / EXPORT_RECORD).write_text(json.dumps(record))
    env = LeRobotTabletop("pick_up", env_options_from_export(tmp_path))
    assert env.observation_space["pixels"]["scene"].shape == (48, 64, 3)
    uneven = {**settings, "wrist": {**settings["scene"], "width": 32}}
    assert "env_note" in _env_record(GenerateConfig().to_dict(), uneven, ["scene", "wrist"], ["pick_up"])
    (tmp_path / EXPORT_RECORD).write_text(json.dumps(_env_record({}, uneven, ["scene", "wrist"], [])))
    with pytest.raises(ConfigError, match="no environment settings: cameras"):
        env_options_from_export(tmp_path)


def test_lerobot_factory_and_one_rollout_step(options: dict, tmp_path: Path) -> None:
    """Where lerobot is installed (its Python 3.12 venv with this plugin): LeRobot's make_env, its
    preprocess_observation and a dummy policy's step, as lerobot-eval's rollout does them."""
    pytest.importorskip("lerobot")
    torch = pytest.importorskip("torch")
    plugin = pytest.importorskip("lerobot_env_samplehd")
    from lerobot.envs.factory import make_env
    from lerobot.envs.utils import env_to_policy_features, preprocess_observation

    (tmp_path / "meta").mkdir()
    (tmp_path / EXPORT_RECORD).write_text(json.dumps({"env": {**options, "families": ["pick_up"]}}))
    cfg = plugin.SamplehdEnv(dataset=str(tmp_path), episode_length=5)  # task: the export's families
    features = env_to_policy_features(cfg)
    envs = make_env(cfg, n_envs=1)
    vec = envs["pick_up"][0]
    obs, _ = vec.reset(seed=[0])
    batch = preprocess_observation(obs)
    inputs = {k: tuple(f.shape) for k, f in features.items() if k != "action"}
    assert {k: tuple(v.shape[1:]) for k, v in batch.items()} == inputs
    image = batch["observation.images.scene"]
    assert image.dtype == torch.float32 and float(image.max()) <= 1
    action = torch.zeros((1, *features["action"].shape))  # a dummy policy's select_action
    _, _, _, _, info = vec.step(action.numpy())
    assert "is_success" in info
    vec.close()
