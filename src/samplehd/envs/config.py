"""Options of the tabletop environment, validated on construction; unknown keys are errors."""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field, fields
from typing import Any

from samplehd.errors import ConfigError
from samplehd.render.renderer import MODALITIES, PRESETS
from samplehd.scene.config import SceneConfig
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
CAMERAS = ("scene", "operator", "wrist")
RENDER_MODES = ("rgb_array",)


@dataclass(frozen=True)
class EnvConfig:
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

    obs_mode: str = "state"
    cameras: tuple[str, ...] = ("scene",)
    width: int = 128
    height: int = 128
    render_preset: str = "fast"
    render_mode: str | None = None
    render_camera: str = "scene"
    control_mode: str = "steering"
    control_hz: float = 20.0
    physics_hz: float = 500.0
    families: tuple[str, ...] = ()
    scene: SceneConfig = field(default_factory=SceneConfig)
    num_scenes: int = 0
    scene_seed: int = 0
    max_episode_steps: int | None = 1500
    max_instruction_tokens: int = 48
    max_instruction_chars: int = 256
    dense_reward: bool = False
    success_check_every: int = 1
    terminate_on_safety: bool = True
    grasp_assist: bool = True
    oracle_subtask: bool = False
    scene_cache_size: int = 8
    checker: CheckerConfig = field(default_factory=CheckerConfig)

    def __post_init__(self) -> None:
        def fail(name: str, what: str) -> None:
            raise ConfigError(f"Tabletop-v0 option {name}={getattr(self, name)!r}: {what}")

        def named(value: object, valid: Any) -> bool:  # a list or dict is no name (and is unhashable)
            return isinstance(value, str) and value in valid

        if not named(self.obs_mode, OBS_MODES):
            fail("obs_mode", f"valid: {', '.join(OBS_MODES)}")
        if not named(self.control_mode, CONTROL_MODES):
            fail("control_mode", f"valid: {', '.join(CONTROL_MODES)}")
        if isinstance(self.cameras, str) or not isinstance(self.cameras, tuple | list):
            fail("cameras", f"must be a list of camera names from {', '.join(CAMERAS)}")
        object.__setattr__(self, "cameras", tuple(self.cameras))
        bad = [c for c in self.cameras if not named(c, CAMERAS)]
        if bad or len(set(self.cameras)) != len(self.cameras):
            fail("cameras", f"must be distinct names from {', '.join(CAMERAS)}")
        if self.obs_mode != "state" and not self.cameras:
            fail("cameras", f"obs_mode {self.obs_mode!r} needs at least one camera")
        if not named(self.render_camera, CAMERAS):
            fail("render_camera", f"valid: {', '.join(CAMERAS)}")
        for name in ("width", "height"):
            v = getattr(self, name)
            if not (isinstance(v, int) and not isinstance(v, bool) and 8 <= v <= 4096):
                fail(name, "must be an integer in 8..4096 px")
        if not named(self.render_preset, PRESETS):
            fail("render_preset", f"valid: {', '.join(PRESETS)}")
        if self.render_mode is not None and not named(self.render_mode, RENDER_MODES):
            fail("render_mode", f"valid: {', '.join(RENDER_MODES)} or None")
        for name in ("control_hz", "physics_hz"):
            v = getattr(self, name)
            if not (isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v) and v > 0):
                fail(name, "must be a positive number of Hz")
        ratio = self.physics_hz / self.control_hz
        if ratio < 1 or abs(ratio - round(ratio)) > 1e-9:
            fail("physics_hz", f"must be an integer multiple of control_hz ({self.control_hz})")
        if isinstance(self.families, str) or not isinstance(self.families, tuple | list):
            fail("families", f"must be a list from {', '.join(family_names())}")
        object.__setattr__(self, "families", tuple(self.families))
        bad = [f for f in self.families if not named(f, family_names())]
        if bad:
            fail("families", f"unknown {bad}; valid: {', '.join(family_names())}")
        if isinstance(self.scene, dict):
            object.__setattr__(self, "scene", SceneConfig.from_dict(self.scene, where="Tabletop-v0 option scene"))
        if not isinstance(self.scene, SceneConfig):
            fail("scene", "must be a SceneConfig or a dict of its options")
        if isinstance(self.checker, dict):
            object.__setattr__(self, "checker", CheckerConfig.from_dict(self.checker))
        if not isinstance(self.checker, CheckerConfig):
            fail("checker", "must be a CheckerConfig or a dict of its options")
        steps = self.max_episode_steps
        if steps is not None and not (isinstance(steps, int) and not isinstance(steps, bool) and steps >= 1):
            fail("max_episode_steps", "must be an integer >= 1 (or None: no limit)")
        for name, lo in (("num_scenes", 0), ("scene_seed", 0), ("max_instruction_tokens", 4),
                         ("max_instruction_chars", 16), ("success_check_every", 1), ("scene_cache_size", 1)):
            v = getattr(self, name)
            if not (isinstance(v, int) and not isinstance(v, bool) and v >= lo):
                fail(name, f"must be an integer >= {lo}")
        for name in ("dense_reward", "terminate_on_safety", "grasp_assist", "oracle_subtask"):
            if not isinstance(getattr(self, name), bool):
                fail(name, "must be true or false")

    @property
    def modalities(self) -> tuple[str, ...]:
        """Image modalities rendered per camera."""
        return OBS_MODES[self.obs_mode]

    @property
    def task_families(self) -> tuple[str, ...]:
        """Families episodes are drawn from."""
        return self.families or family_names()

    @classmethod
    def from_kwargs(cls, **kwargs: Any) -> EnvConfig:
        """Build from keyword options; an unknown key is an error naming the valid ones."""
        valid = [f.name for f in fields(cls)]
        unknown = sorted(set(kwargs) - set(valid))
        if unknown:
            raise ConfigError(f"Tabletop-v0: unknown option(s) {unknown}; valid: {', '.join(valid)}")
        return cls(**kwargs)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready options (nested configs as dicts)."""
        d = asdict(self)
        d["scene"] = self.scene.to_dict()
        d["checker"] = self.checker.to_dict()
        d["cameras"] = list(self.cameras)
        d["families"] = list(self.families)
        return d
