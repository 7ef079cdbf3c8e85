"""LeRobot env config ``samplehd``: ``lerobot-eval --env.type=samplehd --env.task=pick_up``.

LeRobot (>= 0.6) imports this package at start because its distribution name begins with
``lerobot_env_``; importing it registers :class:`SamplehdEnv` under the name ``samplehd``. The
environment itself, its observation names and its seeding live in samplehd
(:mod:`samplehd.benchmark.lerobot_tabletop`), where samplehd's tests check them without lerobot.

Options (``--env.<name>``):
    task: the task family, or several separated by commas (one LeRobot suite each; e.g. ``pick_up``);
        default: the families of ``dataset``, else ``pick_up``.
    dataset: a ``samplehd export lerobot`` folder; the environment is built from the settings it
        recorded (cameras, image size, render preset, control mode and rates, scene, checker).
    level: generalisation level L1–L4 (``samplehd evaluate --level``), or none.
    split_seed: ``samplehd evaluate --seed``; LeRobot's ``--seed`` is the first episode's index.
    suite: a benchmark suite (a shipped suite's name or a suite file, ``samplehd evaluate --suite``):
        each task's episodes are the suite's episodes of that family, in order; nothing is drawn.
    episode_length: steps before a rollout stops (``samplehd evaluate``'s limit is 1500).
    observation_width, observation_height, cameras: the images when no ``dataset`` is given.
    catalogue: the objects' built-in catalogue when no ``dataset`` is given: samplehd's default
        (``shop-vrb``, SAMPLE-HD's shapes) when left out, or ``procedural``.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from lerobot.configs import FeatureType, PolicyFeature
from lerobot.envs.configs import EnvConfig

import samplehd  # noqa: F401  (picks the GL backend before mujoco is imported)
from samplehd.benchmark.lerobot_tabletop import DEFAULT_MAX_STEPS, make_lerobot_envs
from samplehd.dataset.lerobot_contract import lerobot_features
from samplehd.envs.config import EnvConfig as TabletopConfig
from samplehd.envs.lerobot_contract import env_options_from_export

__all__ = ["SamplehdEnv"]


@EnvConfig.register_subclass("samplehd")
@dataclass
class SamplehdEnv(EnvConfig):
    """samplehd's tabletop, one LeRobot suite per task family (see the module docstring)."""

    task: str | None = None
    fps: int = 20
    dataset: str | None = None
    level: str | None = None
    split_seed: int = 0
    suite: str | None = None
    episode_length: int = DEFAULT_MAX_STEPS
    observation_width: int = 128
    observation_height: int = 128
    cameras: str = "scene"
    catalogue: str | None = None
    features: dict[str, PolicyFeature] = field(default_factory=dict)
    features_map: dict[str, str] = field(default_factory=dict)

    def __post_init__(self) -> None:
        options = TabletopConfig.from_kwargs(**self.env_options)  # defaults filled in, one-line errors
        self.fps = int(round(options.control_hz))
        feats = lerobot_features(options.image)
        self.features = {k: PolicyFeature(type=FeatureType[f.kind], shape=f.shape) for k, f in feats.items()}
        self.features_map = {k: f.name for k, f in feats.items()}

    @property
    def families(self) -> list[str]:
        named = [f.strip() for f in (self.task or "").split(",") if f.strip()]
        return named or list(self.env_options.get("families") or ["pick_up"])

    @property
    def env_options(self) -> dict[str, Any]:
        """Tabletop-v0 options: the export's record, else RGB images of ``cameras`` at the given size."""
        if self.dataset:
            return env_options_from_export(self.dataset)
        options: dict[str, Any] = {
            "obs_mode": "rgb", "cameras": [c.strip() for c in self.cameras.split(",") if c.strip()],
            "width": self.observation_width, "height": self.observation_height, "control_mode": "steering",
            "control_hz": 20.0}
        if self.catalogue is not None:
            options["scene"] = {"catalogue": self.catalogue}
        return options

    @property
    def gym_kwargs(self) -> dict[str, Any]:
        return {"env": self.env_options, "split_seed": self.split_seed, "level": self.level,
                "max_episode_steps": self.episode_length, "suite": self.suite}

    def create_envs(self, n_envs: int, use_async_envs: bool = False) -> dict[str, dict[int, Any]]:
        """``{family: {0: VectorEnv}}``, each of ``n_envs`` environments."""
        return make_lerobot_envs(self.families, n_envs=n_envs, use_async=use_async_envs, **self.gym_kwargs)
