"""``samplehd/Tabletop-v0`` as LeRobot's ``lerobot-eval`` runs a benchmark, without importing lerobot.

The plugin package ``lerobot_env_samplehd`` (``plugins/lerobot_env_samplehd``) registers the env
config ``samplehd`` with LeRobot and calls :func:`make_lerobot_envs`; everything else lives here, so
the contract is tested in samplehd's own suite (Python 3.11, no lerobot).

Observations are named so that LeRobot's ``preprocess_observation`` turns them into the features of
``samplehd export lerobot``, with the same shapes and units:

==================  ==========================  ===============================================
env key             LeRobot feature             value
==================  ==========================  ===============================================
``pixels/<cam>``    ``observation.images.<cam>``  RGB (H, W, 3) uint8 (LeRobot makes it CHW float)
``agent_pos``       ``observation.state``         6 joint angles [rad] + gripper opening [m]
``tcp_pose``        ``observation.tcp_pose``      TCP position [m] + quaternion (w, x, y, z)
==================  ==========================  ===============================================

The action is the export's ``action``: SAMPLE-HD's 7-D steering vector. ``info["is_success"]`` is the
shared success checker's verdict. ``task_description`` is the instruction text, ``task`` its family.

Seeds: ``reset(seed=j)`` starts episode ``j`` of this family in ``samplehd evaluate``'s split (seed
``split_seed``, ``families`` in rotation: episode ``j`` of family ``i`` is split episode
``j * len(families) + i``), at ``level`` when one is given. So ``lerobot-eval --seed=0
--eval.n_episodes=N`` meets the episodes that ``samplehd evaluate --seed 0 --episodes N`` (times the
number of families) meets. A reset without a seed (Gymnasium's autoreset) starts the next episode.
"""

from __future__ import annotations

import functools
import json
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from samplehd.envs.config import EnvConfig
from samplehd.envs.evaluation import split_episode
from samplehd.envs.levels import LEVELS, reset_at_level
from samplehd.envs.tabletop import TabletopEnv, action_bounds
from samplehd.errors import ConfigError
from samplehd.robot.controller import ControlConfig

__all__ = ["EXPORT_RECORD", "LeRobotTabletop", "env_options_from_export", "lerobot_observation",
           "make_lerobot_envs"]

EXPORT_RECORD = "meta/samplehd.json"  # written by samplehd.export.lerobot (its SAMPLEHD_RECORD)
DEFAULT_MAX_STEPS = 1500  # Tabletop-v0's own limit, as `samplehd evaluate` runs it


def env_options_from_export(root: str | Path) -> dict[str, Any]:
    """The ``samplehd/Tabletop-v0`` options recorded by ``samplehd export lerobot`` in ``root``.

    Raises:
        ConfigError: no record (not a samplehd export, or one made before the record existed), or the
            export has no environment that matches it (the record's note says why).
    """
    path = Path(root) / EXPORT_RECORD
    try:
        record = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError) as exc:
        raise ConfigError(f"dataset={str(root)!r}: cannot read {EXPORT_RECORD} ({type(exc).__name__}); expected "
                          "a folder written by `samplehd export lerobot`") from None
    if "env" not in record:
        why = record.get("env_note", "it was exported before samplehd recorded environment settings; export again")
        raise ConfigError(f"dataset={str(root)!r}: {EXPORT_RECORD} has no environment settings: {why}")
    EnvConfig.from_kwargs(**record["env"])  # one-line errors now, not in a worker process
    return dict(record["env"])


def lerobot_observation(obs: dict[str, Any], cameras: Sequence[str]) -> dict[str, Any]:
    """A Tabletop-v0 observation as LeRobot's names and layouts (see the module docstring)."""
    g = np.asarray(obs["gripper"], np.float32)
    return {
        "pixels": {cam: obs[f"{cam}_rgb"] for cam in cameras},
        "agent_pos": np.concatenate([obs["joint_pos"], g[:2].sum(keepdims=True)]).astype(np.float32),
        "tcp_pose": np.concatenate([obs["tcp_pos"], obs["tcp_quat"]]).astype(np.float32),
    }


class LeRobotTabletop(gym.Env):
    """One family of ``samplehd evaluate``'s split, observed as LeRobot names the export's features.

    Args:
        family: the task family of every episode.
        env: Tabletop-v0 options (``obs_mode`` must render RGB; ``control_mode`` is the policy's).
        families: the split's families in rotation (default: ``(family,)``).
        split_seed: ``samplehd evaluate --seed``.
        level: generalisation level L1–L4, or None (the plain split).
        max_episode_steps: LeRobot's rollout stops after this many steps.
    """

    metadata = {"render_modes": ["rgb_array"], "render_fps": 20}

    def __init__(self, family: str, env: dict[str, Any], families: Sequence[str] | None = None,
                 split_seed: int = 0, level: str | None = None, max_episode_steps: int = DEFAULT_MAX_STEPS) -> None:
        super().__init__()
        families = tuple(families) if families else (family,)
        if family not in families:
            raise ConfigError(f"task={family!r}: not among the split's families {list(families)}")
        if level is not None and level not in LEVELS:
            raise ConfigError(f"level={level!r}: valid: {', '.join(LEVELS)} or none")
        if not (isinstance(max_episode_steps, int) and max_episode_steps >= 1):
            raise ConfigError(f"episode_length={max_episode_steps!r}: must be an integer >= 1")
        options = {**env, "families": [family], "max_episode_steps": None}
        config = EnvConfig.from_kwargs(**options)
        if "rgb" not in config.modalities:
            raise ConfigError(f"obs_mode={config.obs_mode!r}: LeRobot's policies need images; valid: rgb, rgbd, "
                              "rgbd_seg")
        self.cameras = config.cameras
        self.family, self.families, self.split_seed, self.level = family, families, int(split_seed), level
        self._index = families.index(family)
        self._inner: TabletopEnv | None = None
        self._options = options
        self._next = 0
        self._last: dict[str, Any] | None = None
        self.task = family
        self.task_description = ""
        self._max_episode_steps = max_episode_steps
        self.metadata = {**self.metadata, "render_fps": int(round(config.control_hz))}  # PyAV needs an int
        h, w = config.height, config.width
        self.observation_space = spaces.Dict({
            "pixels": spaces.Dict({cam: spaces.Box(0, 255, (h, w, 3), np.uint8) for cam in self.cameras}),
            "agent_pos": spaces.Box(-np.inf, np.inf, (7,), np.float32),
            "tcp_pose": spaces.Box(-np.inf, np.inf, (7,), np.float32),
        })
        low, high = action_bounds(config.control_mode, ControlConfig(physics_hz=config.physics_hz,
                                                                    control_hz=config.control_hz))
        self.action_space = spaces.Box(low, high, dtype=np.float32)

    @property
    def inner(self) -> TabletopEnv:
        """The Tabletop-v0 environment, made at first use (in the worker process under AsyncVectorEnv)."""
        if self._inner is None:
            self._inner = TabletopEnv(**self._options)
        return self._inner

    def split_index(self, episode: int) -> int:
        """Index in ``samplehd evaluate``'s split of this family's episode ``episode``."""
        return episode * len(self.families) + self._index

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None
              ) -> tuple[dict[str, Any], dict[str, Any]]:
        episode = self._next if seed is None else int(seed)
        if episode < 0:
            raise ConfigError(f"seed={episode}: must be >= 0 (the episode's index in the split)")
        super().reset(seed=episode)
        reset_seed, _ = split_episode(self.split_index(episode), self.families, self.split_seed)
        obs, info, used = reset_at_level(self.inner, reset_seed, self.family, self.level)
        self._next = episode + 1
        self.task_description = str(info["instruction"])
        self._last = lerobot_observation(obs, self.cameras)
        info = {**info, "is_success": False, "split_episode": self.split_index(episode), "reset_seed": used}
        return self._last, info

    def step(self, action: Any) -> tuple[dict[str, Any], float, bool, bool, dict[str, Any]]:
        obs, reward, terminated, truncated, info = self.inner.step(np.asarray(action, np.float32))
        self._last = lerobot_observation(obs, self.cameras)
        return self._last, float(reward), bool(terminated), bool(truncated), info

    def render(self) -> np.ndarray | None:
        """The first camera's latest RGB observation (no extra rendering)."""
        return None if self._last is None else self._last["pixels"][self.cameras[0]]

    def close(self) -> None:
        if self._inner is not None:
            self._inner.close()
            self._inner = None


def _make_one(family: str, env: dict[str, Any], families: tuple[str, ...], split_seed: int, level: str | None,
              max_episode_steps: int) -> LeRobotTabletop:
    return LeRobotTabletop(family, env, families, split_seed, level, max_episode_steps)


def make_lerobot_envs(families: Sequence[str], env: dict[str, Any], n_envs: int = 1, use_async: bool = False,
                      split_seed: int = 0, level: str | None = None, max_episode_steps: int = DEFAULT_MAX_STEPS
                      ) -> dict[str, dict[int, gym.vector.VectorEnv]]:
    """``{family: {0: VectorEnv}}`` as LeRobot's ``make_env`` returns (one suite per family, so
    ``lerobot-eval`` reports success per family).

    AsyncVectorEnv (``use_async`` and ``n_envs`` > 1) starts its workers with ``spawn``: an EGL
    context made in the parent does not survive ``fork``.
    """
    families = tuple(families)
    if not families:
        raise ConfigError("task='': name at least one family (e.g. pick_up)")
    if not (isinstance(n_envs, int) and n_envs >= 1):
        raise ConfigError(f"n_envs={n_envs!r}: must be an integer >= 1")
    LeRobotTabletop(families[0], env, families, split_seed, level, max_episode_steps)  # errors here, in one line
    out: dict[str, dict[int, gym.vector.VectorEnv]] = {}
    for family in families:
        make = functools.partial(_make_one, family, dict(env), families, split_seed, level, max_episode_steps)
        if use_async and n_envs > 1:
            vec: gym.vector.VectorEnv = gym.vector.AsyncVectorEnv([make] * n_envs, context="spawn")
        else:
            vec = gym.vector.SyncVectorEnv([make] * n_envs)
        out[family] = {0: vec}
    return out
