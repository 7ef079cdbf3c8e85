"""Options of the tabletop environment, declared with :mod:`samplehd.schema`: validated on construction,
unknown keys are errors, ``to_dict``/``from_dict`` from the declaration."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from samplehd.errors import ConfigError
from samplehd.render.image_spec import PRESET_NAMES, ImageSpec
from samplehd.render.renderer import MODALITIES
from samplehd.scene.config import SceneConfig
from samplehd.scene.world import CAMERA_NAMES, SCENE_CAMERA
from samplehd.schema import Config, bounded
from samplehd.tasks.checker import CheckerConfig
from samplehd.tasks.task import family_names

__all__ = ["CAMERAS", "CONTROL_MODES", "EnvConfig", "OBS_MODES", "RENDER_MODES"]

# Observation modes → image modalities rendered per camera.
OBS_MODES: dict[str, tuple[str, ...]] = {
    "state": (),
    "rgb": ("rgb",),
    "rgbd": ("rgb", "depth"),
    "rgbd_seg": MODALITIES,
}
# Environment control modes → robot controller modes (samplehd.robot.controller.ACTION_MODES).
CONTROL_MODES: dict[str, str] = {
    "joint_pos": "joint_position",
    "joint_delta": "joint_delta",
    "ee_delta": "cartesian_delta",
    "steering": "steering",
}
CAMERAS = CAMERA_NAMES  # the world's cameras (samplehd.scene.world)
RENDER_MODES = ("rgb_array",)


@dataclass(frozen=True)
class EnvConfig(Config, section="Tabletop-v0"):
    """Everything that defines a ``samplehd/Tabletop-v0`` environment.

    Attributes:
        obs_mode: ``state`` (robot and object state only), ``rgb``, ``rgbd`` or ``rgbd_seg``.
        cameras: cameras rendered for image observations (``scene``, ``operator``, ``wrist``).
        width: image width [px].
        height: image height [px].
        render_preset: renderer quality preset (``fast``, ``hd`` or the path-traced ``photo``).
        render_mode: ``rgb_array`` or None; :meth:`render` shows ``render_camera``.
        render_camera: camera of :meth:`render`.
        control_mode: ``joint_pos``, ``joint_delta``, ``ee_delta`` (TCP delta through IK) or
            ``steering`` (SAMPLE-HD 7-D velocity command).
        control_hz: decision rate [Hz].
        physics_hz: physics rate, an integer multiple of control_hz [Hz].
        families: task families to draw instructions from (empty: all).
        scene: scene sampler options (a SceneConfig or its dict).
        num_scenes: 0 draws a fresh scene every episode; N > 0 draws scenes from a fixed pool of N
            scenes made from ``scene_seed`` (build-time randomness kept apart from episodes).
        scene_seed: base seed of the scene pool.
        max_episode_steps: control steps after which an episode is truncated (None: no limit of the
            environment's own; ``gymnasium.make`` uses this, its TimeLimit wrapper truncates).
        max_instruction_tokens: length of the padded token-id observation.
        max_instruction_chars: longest instruction text the Text space admits.
        dense_reward: add a shaping term (see :mod:`samplehd.envs.reward`).
        success_check_every: run the success checker every this many steps (1: every step).
        terminate_on_safety: end the episode when the safety monitor stops the arm.
        grasp_assist: weld an object to the gripper while the fingers close on it and both pads
            touch it, until the gripper opens again (``samplehd.motion.assist``; the dataset's paths
            use it too), for every policy alike.
        oracle_subtask: plan the oracle's path at every reset (about a second) and report in
            ``info["oracle_plan_subtask"]`` the planned subtask nearest the current state, whatever
            policy drives (``samplehd.envs.plan_tracker``).
        scene_cache_size: compiled scenes kept in memory.
        checker: success checker tolerances (a CheckerConfig or its dict).
    """

    obs_mode: str = bounded("state", choices=tuple(OBS_MODES))
    cameras: tuple[str, ...] = bounded((SCENE_CAMERA,), choices=CAMERAS, unique=True)
    width: int = bounded(128, lo=8, hi=4096, unit="px")
    height: int = bounded(128, lo=8, hi=4096, unit="px")
    render_preset: str = bounded("fast", choices=PRESET_NAMES)
    render_mode: str | None = bounded(None, choices=RENDER_MODES)
    render_camera: str = bounded(SCENE_CAMERA, choices=CAMERAS)
    control_mode: str = bounded("steering", choices=tuple(CONTROL_MODES))
    control_hz: float = bounded(20.0, lo=0.0, lo_open=True, unit="Hz")
    physics_hz: float = bounded(500.0, lo=0.0, lo_open=True, unit="Hz")
    families: tuple[str, ...] = bounded((), choices=family_names)
    scene: SceneConfig = field(default_factory=SceneConfig)
    num_scenes: int = bounded(0, lo=0)
    scene_seed: int = bounded(0, lo=0)
    max_episode_steps: int | None = bounded(1500, lo=1)
    max_instruction_tokens: int = bounded(48, lo=4)
    max_instruction_chars: int = bounded(256, lo=16)
    dense_reward: bool = False
    success_check_every: int = bounded(1, lo=1)
    terminate_on_safety: bool = True
    grasp_assist: bool = True
    oracle_subtask: bool = False
    scene_cache_size: int = bounded(8, lo=1)
    checker: CheckerConfig = field(default_factory=CheckerConfig)

    def __post_init__(self) -> None:
        super().__post_init__()
        if self.obs_mode != "state" and not self.cameras:
            raise ConfigError(f"Tabletop-v0.cameras=[]: obs_mode {self.obs_mode!r} needs at least one camera "
                              f"from {', '.join(CAMERAS)}")
        ratio = self.physics_hz / self.control_hz
        if ratio < 1 or abs(ratio - round(ratio)) > 1e-9:
            raise ConfigError(f"Tabletop-v0.physics_hz={self.physics_hz!r}: must be an integer multiple of "
                              f"control_hz ({self.control_hz}), e.g. 500 and 20")

    @property
    def modalities(self) -> tuple[str, ...]:
        """Image modalities rendered per camera."""
        return OBS_MODES[self.obs_mode]

    @property
    def image(self) -> ImageSpec:
        """The image request of the observations: ``cameras`` in the modalities of ``obs_mode``, at
        ``width`` × ``height`` in ``render_preset`` (:meth:`TabletopEnv.render` shows ``render_camera``'s
        rgb at the same size and preset)."""
        return ImageSpec(self.width, self.height, self.render_preset, self.cameras, self.modalities)

    @property
    def task_families(self) -> tuple[str, ...]:
        """Families episodes are drawn from."""
        return self.families or family_names()

    @classmethod
    def from_kwargs(cls, **kwargs: Any) -> EnvConfig:
        """Build from keyword options; an unknown key is an error naming the valid ones."""
        return cls.from_dict(kwargs)
