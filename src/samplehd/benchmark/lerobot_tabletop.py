"""``samplehd/Tabletop-v0`` as LeRobot's ``lerobot-eval`` runs a benchmark, without importing lerobot.

The plugin package ``lerobot_env_samplehd`` (``plugins/lerobot_env_samplehd``) registers the env
config ``samplehd`` with LeRobot and calls :func:`make_lerobot_envs`; everything else lives here, so
the contract is tested in samplehd's own suite (Python 3.11, no lerobot).

Observations are named so that LeRobot's ``preprocess_observation`` turns them into the features of
``samplehd export lerobot``, with the same shapes and units (the table lives in
:mod:`samplehd.dataset.lerobot_contract`, the conversion in :mod:`samplehd.envs.lerobot_contract`,
shared with ``samplehd evaluate --policy lerobot:CKPT``).

The action is the export's ``action``: SAMPLE-HD's 7-D steering vector. ``info["is_success"]`` is the
shared success checker's verdict. ``task_description`` is the instruction text, ``task`` its family.

Seeds: ``reset(seed=j)`` starts episode ``j`` of this family in ``samplehd evaluate``'s split (seed
``split_seed``, ``families`` in rotation: episode ``j`` of family ``i`` is split episode
``j * len(families) + i``), at ``level`` when one is given. So ``lerobot-eval --seed=0
--eval.n_episodes=N`` meets the episodes that ``samplehd evaluate --seed 0 --episodes N`` (times the
number of families) meets. A reset without a seed (Gymnasium's autoreset) starts the next episode.
With a ``suite`` (a shipped suite's name or a suite file) ``reset(seed=j)`` starts instead the suite's
``j``-th episode of this family, as ``samplehd evaluate --suite`` does: nothing is drawn.
"""

from __future__ import annotations

import functools
from collections.abc import Sequence
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from samplehd.benchmark.evaluation import split_episode
from samplehd.benchmark.levels import LEVELS, reset_at_level
from samplehd.dataset.lerobot_contract import lerobot_features
from samplehd.envs.config import EnvConfig
from samplehd.envs.lerobot_contract import LeRobotObservation, lerobot_observation
from samplehd.envs.suite_file import read_suite
from samplehd.envs.tabletop import TabletopEnv, action_bounds
from samplehd.errors import ConfigError
from samplehd.robot.controller import ControlConfig

__all__ = ["DEFAULT_MAX_STEPS", "LeRobotTabletop", "make_lerobot_envs"]

DEFAULT_MAX_STEPS = 1500  # Tabletop-v0's own limit, as `samplehd evaluate` runs it


class LeRobotTabletop(gym.Env):
    """One family of ``samplehd evaluate``'s split, observed as LeRobot names the export's features.

    Args:
        family: the task family of every episode.
        env: Tabletop-v0 options (``obs_mode`` must render RGB; ``control_mode`` is the policy's).
        families: the split's families in rotation (default: ``(family,)``).
        split_seed: ``samplehd evaluate --seed``.
        level: generalisation level L1–L4, or None (the plain split).
        max_episode_steps: LeRobot's rollout stops after this many steps.
        suite: a benchmark suite (name or file): episode ``j`` is its ``j``-th of ``family`` (the
            split's seed and level are then not used).
    """

    metadata = {"render_modes": ["rgb_array"], "render_fps": 20}

    def __init__(self, family: str, env: dict[str, Any], families: Sequence[str] | None = None,
                 split_seed: int = 0, level: str | None = None, max_episode_steps: int = DEFAULT_MAX_STEPS,
                 suite: str | None = None) -> None:
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
        self.suite = suite
        self._suite_episodes: tuple[int, ...] = ()
        if suite is not None:
            if level is not None:
                raise ConfigError(f"level={level!r}: a suite fixes each episode's level; leave level out with suite")
            episodes = [e for e in read_suite(suite).episodes if e.family == family]
            self._suite_episodes = tuple(e.id for e in episodes)
            if not self._suite_episodes:
                raise ConfigError(f"task={family!r}: suite {suite!r} has no episode of this family")
            # an observation slot for every object of the family's fullest scene (core's stack_three
            # scenes hold up to 7 objects, a distractors variant up to 10), as `evaluate --suite` makes
            need = max(len(e.scene.get("objects", ())) for e in episodes)
            if need > config.scene.max_objects:
                options["scene"] = {**dict(options.get("scene") or {}), "max_objects": need}
        self.family, self.families, self.split_seed, self.level = family, families, int(split_seed), level
        self._index = families.index(family)
        self._inner: TabletopEnv | None = None
        self._options = options
        self._next = 0
        self._last: LeRobotObservation | None = None
        self.task = family
        self.task_description = ""
        self._max_episode_steps = max_episode_steps
        self.metadata = {**self.metadata, "render_fps": int(round(config.control_hz))}  # PyAV needs an int
        feats = lerobot_features(config.image)
        self.observation_space = spaces.Dict({
            "pixels": spaces.Dict({cam: spaces.Box(0, 255, feats[f"pixels/{cam}"].shape, np.uint8)
                                   for cam in self.cameras}),
            "agent_pos": spaces.Box(-np.inf, np.inf, feats["agent_pos"].shape, np.float32),
            "tcp_pose": spaces.Box(-np.inf, np.inf, feats["tcp_pose"].shape, np.float32),
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
              ) -> tuple[LeRobotObservation, dict[str, Any]]:
        episode = self._next if seed is None else int(seed)
        if episode < 0:
            raise ConfigError(f"seed={episode}: must be >= 0 (the episode's index in the split)")
        super().reset(seed=episode)
        if self.suite is not None:
            if episode >= len(self._suite_episodes):
                raise ConfigError(f"seed={episode}: suite {self.suite!r} has {len(self._suite_episodes)} "
                                  f"{self.family} episodes (0..{len(self._suite_episodes) - 1})")
            entry = read_suite(self.suite).episodes[self._suite_episodes[episode]]
            obs, info = self.inner.reset(seed=entry.reset_seed, options={"suite": self.suite, "episode": entry.id})
            where = {"suite_episode": entry.id, "reset_seed": entry.reset_seed}
        else:
            reset_seed, _ = split_episode(self.split_index(episode), self.families, self.split_seed)
            obs, info, used = reset_at_level(self.inner, reset_seed, self.family, self.level)
            where = {"split_episode": self.split_index(episode), "reset_seed": used}
        self._next = episode + 1
        self.task_description = str(info["instruction"])
        self._last = lerobot_observation(obs, self.cameras)
        info = {**info, "is_success": False, **where}
        return self._last, info

    def step(self, action: Any) -> tuple[LeRobotObservation, float, bool, bool, dict[str, Any]]:
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
              max_episode_steps: int, suite: str | None = None) -> LeRobotTabletop:
    return LeRobotTabletop(family, env, families, split_seed, level, max_episode_steps, suite)


def make_lerobot_envs(families: Sequence[str], env: dict[str, Any], n_envs: int = 1, use_async: bool = False,
                      split_seed: int = 0, level: str | None = None, max_episode_steps: int = DEFAULT_MAX_STEPS,
                      suite: str | None = None) -> dict[str, dict[int, gym.vector.VectorEnv]]:
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
    for family in families:  # errors here, in one line
        LeRobotTabletop(family, env, families, split_seed, level, max_episode_steps, suite)
    out: dict[str, dict[int, gym.vector.VectorEnv]] = {}
    for family in families:
        make = functools.partial(_make_one, family, dict(env), families, split_seed, level, max_episode_steps, suite)
        if use_async and n_envs > 1:
            vec: gym.vector.VectorEnv = gym.vector.AsyncVectorEnv([make] * n_envs, context="spawn")
        else:
            vec = gym.vector.SyncVectorEnv([make] * n_envs)
        out[family] = {0: vec}
    return out
