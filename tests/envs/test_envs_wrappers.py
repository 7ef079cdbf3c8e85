"""Stable-Baselines3, unchanged, on samplehd/Tabletop-v0 through the wrappers of samplehd.envs.wrappers."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from stable_baselines3 import PPO
from stable_baselines3.common.env_checker import check_env

import samplehd  # noqa: F401
from samplehd.envs.tokens import encode_instruction
from samplehd.envs.wrappers import FlatState, SingleImage, TokenInstruction
from samplehd.errors import ConfigError

COMMON = {"max_episode_steps": 40, "num_scenes": 1, "scene_seed": 0, "dense_reward": True}


@pytest.fixture(scope="module")
def state_env() -> gym.Env:
    env = gym.make("samplehd/Tabletop-v0", **COMMON)
    yield env
    env.close()


def test_the_raw_env_is_what_sb3_rejects(state_env: gym.Env) -> None:
    # Why the wrappers exist: SB3 refuses the Text instruction space.
    with pytest.raises((AssertionError, TypeError, ValueError, NotImplementedError)):
        PPO("MultiInputPolicy", state_env, n_steps=16, batch_size=16)


def test_token_instruction_passes_check_env_and_trains(state_env: gym.Env) -> None:
    env = TokenInstruction(state_env)
    check_env(env)
    obs, info = env.reset(seed=4)
    assert "instruction" not in obs
    want = encode_instruction(info["instruction"], len(obs["instruction_tokens"]))
    assert np.array_equal(obs["instruction_tokens"], want)
    model = PPO("MultiInputPolicy", env, n_steps=32, batch_size=16, n_epochs=1, seed=0)
    model.learn(32)
    action, _ = model.predict(env.reset(seed=5)[0], deterministic=True)
    assert env.action_space.contains(action)


def test_flat_state_layout_and_mlp_policy(state_env: gym.Env) -> None:
    env = FlatState(state_env)
    check_env(env)
    obs, _ = env.reset(seed=6)
    raw = state_env.unwrapped._observation()
    n = state_env.unwrapped.max_objects
    assert obs.shape == (6 + 6 + 3 + 3 + 4 + 3 * n + 4 * n + n + len(raw["instruction_tokens"]),)
    assert np.allclose(obs[:6], raw["joint_pos"]) and np.allclose(obs[-len(raw["instruction_tokens"]):],
                                                                 raw["instruction_tokens"])
    assert FlatState(state_env, instruction=False).observation_space.shape[0] == obs.shape[0] - 48
    PPO("MlpPolicy", env, n_steps=32, batch_size=16, n_epochs=1, seed=0).learn(32)


@pytest.mark.render
def test_single_image_with_cnn_policy() -> None:
    env = SingleImage(gym.make("samplehd/Tabletop-v0", obs_mode="rgb", width=64, height=64, **COMMON))
    check_env(env)
    obs, _ = env.reset(seed=1)
    assert obs.shape == (64, 64, 3) and obs.dtype == np.uint8 and obs.std() > 5  # a real picture
    PPO("CnnPolicy", env, n_steps=16, batch_size=16, n_epochs=1, seed=0).learn(16)
    env.close()


def test_wrapper_errors_name_what_is_valid(state_env: gym.Env) -> None:
    with pytest.raises(ConfigError, match="obs_mode='rgb'"):
        SingleImage(state_env)
    with pytest.raises(ConfigError, match="expected the Dict"):
        TokenInstruction(FlatState(state_env))
