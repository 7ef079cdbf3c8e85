"""Observation wrappers that make ``samplehd/Tabletop-v0`` fit the usual RL libraries' policies.

Stable-Baselines3 (and most other libraries) accept ``Box``, ``Discrete``, ``MultiDiscrete`` and
``MultiBinary`` observations, and ``Dict`` of those; they reject the environment's ``Text``
instruction. Each wrapper keeps the instruction as its token ids only
(:mod:`samplehd.envs.tokens`; ``tokens.decode_instruction`` turns them back into words):

=======================  ===================================  =====================================
wrapper                  observation                          Stable-Baselines3 policy
=======================  ===================================  =====================================
:class:`TokenInstruction`  the ``Dict`` without ``instruction``  ``MultiInputPolicy``
:class:`SingleImage`     one camera's RGB image (H×W×3 uint8)  ``CnnPolicy`` (no instruction)
:class:`FlatState`       one float32 vector of the state        ``MlpPolicy``
                         (and the token ids, as numbers)
=======================  ===================================  =====================================

Example (``pip install 'samplehd[sb3]'``)::

    import gymnasium as gym
    import samplehd
    from samplehd.envs.wrappers import FlatState
    from stable_baselines3 import PPO

    env = FlatState(gym.make("samplehd/Tabletop-v0", dense_reward=True, max_episode_steps=100))
    PPO("MlpPolicy", env).learn(10_000)

A state-only environment (``obs_mode="state"``) makes no GL context in this process (its scene
sampling renders its occlusion check in a child process), so it can be created before or after
``import torch``.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from samplehd.errors import ConfigError

if TYPE_CHECKING:
    from samplehd.envs.observation import Observation

__all__ = ["STATE_KEYS", "FlatState", "SingleImage", "TokenInstruction"]

# State entries of the observation, in the order FlatState concatenates them.
STATE_KEYS = ("joint_pos", "joint_vel", "gripper", "tcp_pos", "tcp_quat", "object_pos", "object_quat", "object_mask")


def _dict_space(env: gym.Env) -> spaces.Dict:
    space = env.observation_space
    if not isinstance(space, spaces.Dict):
        raise ConfigError(f"{type(env).__name__}: expected the Dict observations of samplehd/Tabletop-v0, "
                          f"got {type(space).__name__}; apply this wrapper first")
    return space


class TokenInstruction(gym.ObservationWrapper):
    """The environment's ``Dict`` observation without the ``Text`` instruction; ``instruction_tokens``
    (fixed-length int64 ids, 0-padded) carry it."""

    def __init__(self, env: gym.Env) -> None:
        super().__init__(env)
        space = _dict_space(env)
        self.observation_space = spaces.Dict({k: v for k, v in space.spaces.items() if k != "instruction"})

    def observation(self, observation: Observation) -> Observation:
        return {k: v for k, v in observation.items() if k != "instruction"}


class SingleImage(gym.ObservationWrapper):
    """One camera's RGB image (H×W×3 uint8) as the whole observation, for image-only policies.

    Args:
        env: an environment made with ``obs_mode`` rgb, rgbd or rgbd_seg.
        camera: which camera (default: the first of ``cameras``).
    """

    def __init__(self, env: gym.Env, camera: str | None = None) -> None:
        super().__init__(env)
        space = _dict_space(env)
        images = [k[: -len("_rgb")] for k in space.spaces if k.endswith("_rgb")]
        if not images:
            raise ConfigError("SingleImage: the environment renders no RGB camera; make it with obs_mode='rgb'")
        self.camera = camera or images[0]
        if self.camera not in images:
            raise ConfigError(f"SingleImage: camera {self.camera!r} is not rendered; rendered: {', '.join(images)}")
        self._key = f"{self.camera}_rgb"
        self.observation_space = space.spaces[self._key]

    def observation(self, observation: Observation) -> np.ndarray:
        return observation[self._key]


class FlatState(gym.ObservationWrapper):
    """The robot and object state as one float32 vector (:data:`STATE_KEYS` flattened, in that order),
    followed by the instruction token ids as numbers when ``instruction=True``.

    Unbounded entries keep infinite bounds; libraries that normalise observations should use running
    statistics (e.g. Stable-Baselines3's ``VecNormalize``).
    """

    def __init__(self, env: gym.Env, instruction: bool = True) -> None:
        super().__init__(env)
        space = _dict_space(env)
        self._keys = [k for k in STATE_KEYS if k in space.spaces]
        if instruction:
            self._keys.append("instruction_tokens")
        lows, highs = [], []
        for k in self._keys:
            sub = space.spaces[k]
            if isinstance(sub, spaces.MultiBinary):
                lows.append(np.zeros(int(np.prod(sub.shape))))
                highs.append(np.ones(int(np.prod(sub.shape))))
            else:
                lows.append(np.broadcast_to(sub.low, sub.shape).ravel().astype(np.float64))
                highs.append(np.broadcast_to(sub.high, sub.shape).ravel().astype(np.float64))
        self.observation_space = spaces.Box(np.concatenate(lows).astype(np.float32),
                                            np.concatenate(highs).astype(np.float32), dtype=np.float32)

    def observation(self, observation: Observation) -> np.ndarray:
        return np.concatenate([np.asarray(observation[k], dtype=np.float32).ravel() for k in self._keys])
