"""Configuration of the scene sampler, validated on construction; unknown keys are errors."""

from __future__ import annotations

from dataclasses import asdict, dataclass, fields
from typing import Any

from samplehd.errors import ConfigError

__all__ = ["SceneConfig"]


@dataclass(frozen=True)
class SceneConfig:
    """How scenes are sampled.

    Attributes:
        min_objects: fewest objects per scene.
        max_objects: most objects per scene.
        classes: classes to draw from (empty: every catalogue class).
        menu_overrides: per class, allowed values replacing the catalogue menu, e.g.
            ``{"mug": {"colour": ["red", "blue"]}}``.
        placement_margin: clearance kept between object footprints [m].
        placement_tries: placement attempts per object before it is redrawn.
        object_tries: objects redrawn before the scene is restarted.
        scene_attempts: scene restarts before giving up.
        camera_yaw_deg: half-angle of the camera cone around the operator viewpoint, about z [deg].
        camera_pitch_deg: half-range of the camera elevation change [deg].
        camera_distance_jitter: relative change of the camera distance to its target [-].
        camera_target_jitter: displacement of the look-at point [m].
        min_visible_pixels: fewest segmentation pixels each object must show at 640×360 (scaled with
            the occlusion-check resolution) [px].
        min_visible_fraction: fewest visible pixels relative to the object rendered alone [-].
        occlusion_resolution: (width, height) of the segmentation renders of the occlusion check [px].
        settle_time: physics time the scene settles for [s].
        max_settle_shift: largest horizontal drift of an object while settling [m].
        max_settle_tilt_deg: largest tilt while settling [deg].
        max_rest_speed: largest object speed at the end of settling [m/s].
    """

    min_objects: int = 3
    max_objects: int = 5
    classes: tuple[str, ...] = ()
    menu_overrides: dict[str, dict[str, list[str]]] | None = None
    placement_margin: float = 0.025
    placement_tries: int = 60
    object_tries: int = 20
    scene_attempts: int = 30
    camera_yaw_deg: float = 12.0
    camera_pitch_deg: float = 5.0
    camera_distance_jitter: float = 0.08
    camera_target_jitter: float = 0.04
    min_visible_pixels: int = 120
    min_visible_fraction: float = 0.3
    occlusion_resolution: tuple[int, int] = (320, 180)
    settle_time: float = 0.6
    max_settle_shift: float = 0.01
    max_settle_tilt_deg: float = 8.0
    max_rest_speed: float = 0.02

    def __post_init__(self) -> None:
        for f in fields(self):
            value, default = getattr(self, f.name), f.default
            if isinstance(default, bool) or default is None:
                continue
            if isinstance(default, int) and (not isinstance(value, int) or isinstance(value, bool)):
                raise ConfigError(f"scene.{f.name}={value!r}: must be an integer")
            if isinstance(default, float) and (not isinstance(value, (int, float)) or isinstance(value, bool)):
                raise ConfigError(f"scene.{f.name}={value!r}: must be a number")
            if isinstance(default, tuple) and not (
                isinstance(value, tuple) and all(isinstance(v, type(default[0]) if default else str) for v in value)
            ):
                raise ConfigError(f"scene.{f.name}={value!r}: must be a list of "
                                  f"{type(default[0]).__name__ if default else 'str'}")
        if self.menu_overrides is not None and not isinstance(self.menu_overrides, dict):
            raise ConfigError(f"scene.menu_overrides={self.menu_overrides!r}: must be a mapping class → menu")

        def need(ok: bool, field_name: str, what: str) -> None:
            if not ok:
                raise ConfigError(f"scene.{field_name}={getattr(self, field_name)!r}: {what}")

        need(1 <= self.min_objects <= 30, "min_objects", "must be an integer in 1..30")
        need(self.min_objects <= self.max_objects <= 30, "max_objects", "must be in min_objects..30")
        need(0.0 <= self.placement_margin <= 0.2, "placement_margin", "must be in [0, 0.2] m")
        for name in ("placement_tries", "object_tries", "scene_attempts"):
            need(isinstance(getattr(self, name), int) and getattr(self, name) >= 1, name, "must be an integer ≥ 1")
        need(0.0 <= self.camera_yaw_deg <= 60.0, "camera_yaw_deg", "must be in [0, 60] degrees")
        need(0.0 <= self.camera_pitch_deg <= 30.0, "camera_pitch_deg", "must be in [0, 30] degrees")
        need(0.0 <= self.camera_distance_jitter < 0.5, "camera_distance_jitter", "must be in [0, 0.5)")
        need(0.0 <= self.camera_target_jitter <= 0.2, "camera_target_jitter", "must be in [0, 0.2] m")
        need(self.min_visible_pixels >= 0, "min_visible_pixels", "must be ≥ 0")
        need(0.0 <= self.min_visible_fraction <= 1.0, "min_visible_fraction", "must be in [0, 1]")
        w, h = self.occlusion_resolution
        need(16 <= w <= 4096 and 16 <= h <= 4096, "occlusion_resolution", "must be two sizes in 16..4096 px")
        need(0.0 < self.settle_time <= 10.0, "settle_time", "must be in (0, 10] s")

    @classmethod
    def from_dict(cls, d: dict[str, Any], where: str = "scene") -> SceneConfig:
        """Build from a config-file section; unknown keys are errors naming the valid ones."""
        if not isinstance(d, dict):
            raise ConfigError(f"{where}: expected a mapping of scene options, got {type(d).__name__}")
        valid = {f.name for f in fields(cls)}
        unknown = sorted(set(d) - valid)
        if unknown:
            raise ConfigError(f"{where}: unknown option(s) {unknown}; valid: {', '.join(sorted(valid))}")
        kw = dict(d)
        if "classes" in kw:
            kw["classes"] = tuple(kw["classes"])
        if "occlusion_resolution" in kw:
            kw["occlusion_resolution"] = tuple(kw["occlusion_resolution"])
        try:
            return cls(**kw)
        except TypeError as exc:
            raise ConfigError(f"{where}: {exc}") from exc

    @property
    def named_classes(self) -> tuple[str, ...]:
        """Every class this config names (``classes`` and the ``menu_overrides`` keys): the imported
        classes among them are the only ones that join the built-in catalogue."""
        return (*self.classes, *(self.menu_overrides or {}))

    def to_dict(self) -> dict[str, Any]:
        d = asdict(self)
        d["classes"] = list(self.classes)
        d["occlusion_resolution"] = list(self.occlusion_resolution)
        return d
