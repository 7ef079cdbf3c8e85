"""Tabletop-v0 under Gymnasium's vector environments, and a long random-action soak."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

from samplehd.envs import ENV_ID
from samplehd.envs.tabletop import TabletopEnv


@pytest.mark.parametrize("vector", ["sync", "async"])
def test_two_envs_step_under_vector_env(vector: str, fast_options: dict) -> None:
    def make() -> gym.Env:
        import samplehd.envs

        samplehd.envs.register_envs()
        return gym.make(ENV_ID, obs_mode="rgb", width=24, height=24, **fast_options)

    if vector == "sync":
        envs = gym.vector.SyncVectorEnv([make, make])
    else:
        # spawn, not fork: a GL context made earlier in this process does not survive a fork.
        envs = gym.vector.AsyncVectorEnv([make, make], context="spawn")
    try:
        obs, info = envs.reset(seed=[1, 2])
        assert obs["scene_rgb"].shape == (2, 24, 24, 3)
        assert len(obs["instruction"]) == 2 and all(isinstance(t, str) for t in obs["instruction"])
        envs.action_space.seed(0)
        for _ in range(4):
            obs, reward, term, trunc, info = envs.step(envs.action_space.sample())
        assert reward.shape == (2,) and obs["joint_pos"].shape == (2, 6)
        assert np.all(np.isfinite(obs["joint_pos"]))
    finally:
        envs.close()


@pytest.mark.slow
def test_random_action_soak_10000_steps(fast_options: dict) -> None:
    """10 000 random steps across control modes: no NaN, no crash, safety stops reported."""
    stops, resets, steps = 0, 0, 0
    for mode in ("steering", "ee_delta", "joint_delta", "joint_pos"):
        env = TabletopEnv(control_mode=mode, **fast_options)
        env.action_space.seed(1)
        env.reset(seed=resets)
        for _ in range(2500):
            obs, reward, term, trunc, info = env.step(env.action_space.sample())
            steps += 1
            assert np.all(np.isfinite(obs["joint_pos"])) and np.all(np.isfinite(obs["object_pos"]))
            assert np.all(np.isfinite(env.data.qpos)) and np.isfinite(reward)
            if info["safety_event"] is not None:
                stops += 1
                assert term and info["safety_stop"]
            if term or trunc:
                resets += 1
                env.reset(seed=resets)
        env.close()
    print(f"soak: {steps} steps, {resets} episodes, {stops} safety stops")
    assert steps == 10_000 and stops > 0
