#!/usr/bin/env python3
"""Train Stable-Baselines3's PPO, unchanged, on samplehd/Tabletop-v0 through samplehd's wrappers.

Usage: python scripts/sb3_ppo.py [--policy mlp|multi|cnn] [--steps N] [--seed S]

Prints the mean return of the first and the last 20 finished episodes (dense reward: a pull of the
TCP towards the object the task moves, ≤ 0.1 per step; success adds 1). Needs ``samplehd[sb3]``.
"""

from __future__ import annotations

import argparse
import time

import gymnasium as gym
import numpy as np

import samplehd  # noqa: F401  (registers samplehd/Tabletop-v0)
from samplehd.envs.wrappers import FlatState, SingleImage, TokenInstruction


def make_env(policy: str) -> gym.Env:
    common = {"max_episode_steps": 100, "dense_reward": True, "num_scenes": 1, "scene_seed": 0}
    if policy == "cnn":
        return SingleImage(gym.make("samplehd/Tabletop-v0", obs_mode="rgb", width=64, height=64, **common))
    env = gym.make("samplehd/Tabletop-v0", **common)
    return FlatState(env) if policy == "mlp" else TokenInstruction(env)


def main() -> None:
    from stable_baselines3 import PPO
    from stable_baselines3.common.env_checker import check_env
    from stable_baselines3.common.monitor import Monitor

    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--policy", choices=["mlp", "multi", "cnn"], default="mlp")
    p.add_argument("--steps", type=int, default=20_000)
    p.add_argument("--seed", type=int, default=0)
    a = p.parse_args()
    env = make_env(a.policy)
    check_env(env)
    env = Monitor(env)
    name = {"mlp": "MlpPolicy", "multi": "MultiInputPolicy", "cnn": "CnnPolicy"}[a.policy]
    model = PPO(name, env, seed=a.seed, verbose=0)
    t = time.time()
    model.learn(a.steps)
    returns = np.array(env.get_episode_rewards())
    print(f"PPO {name}: {a.steps} steps in {time.time() - t:.0f} s, {len(returns)} episodes; mean return "
          f"first 20 {returns[:20].mean():.3f}, last 20 {returns[-20:].mean():.3f}")


if __name__ == "__main__":
    main()
