"""Configuration of the scene sampler, declared with :mod:`samplehd.schema`: validated on construction,
unknown keys are errors, ``to_dict``/``from_dict`` from the declaration."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from samplehd.catalogue.loader import CATALOGUES, DEFAULT_CATALOGUE
from samplehd.errors import ConfigError
from samplehd.schema import Config, bounded

__all__ = ["SceneConfig"]

# The properties an asset menu randomises, which ``menu_overrides`` may narrow.
_OVERRIDE_PROPERTIES = ("colour", "material", "size")


@dataclass(frozen=True)
class SceneConfig(Config, section="scene"):
    """How scenes are sampled.

    Attributes:
        min_objects: fewest objects per scene.
        max_objects: most objects per scene.
        catalogue: built-in catalogue the shapes come from: ``procedural`` (shapes made from a few
            numbers) or ``shop-vrb`` (SAMPLE-HD's SHOP-VRB shapes); a config without the field is
            procedural.
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

    min_objects: int = bounded(3, lo=1, hi=30)
    max_objects: int = bounded(5, lo=1, hi=30)
    catalogue: str = bounded(DEFAULT_CATALOGUE, choices=tuple(CATALOGUES))
    classes: tuple[str, ...] = bounded((), unique=True)
    menu_overrides: dict[str, dict[str, list[str]]] | None = None
    placement_margin: float = bounded(0.025, lo=0.0, hi=0.2, unit="m")
    placement_tries: int = bounded(60, lo=1)
    object_tries: int = bounded(20, lo=1)
    scene_attempts: int = bounded(30, lo=1)
    camera_yaw_deg: float = bounded(12.0, lo=0.0, hi=60.0, unit="degrees")
    camera_pitch_deg: float = bounded(5.0, lo=0.0, hi=30.0, unit="degrees")
    camera_distance_jitter: float = bounded(0.08, lo=0.0, hi=0.5, hi_open=True)
    camera_target_jitter: float = bounded(0.04, lo=0.0, hi=0.2, unit="m")
    min_visible_pixels: int = bounded(120, lo=0)
    min_visible_fraction: float = bounded(0.3, lo=0.0, hi=1.0)
    occlusion_resolution: tuple[int, int] = bounded((320, 180), lo=16, hi=4096, unit="px")
    settle_time: float = bounded(0.6, lo=0.0, hi=10.0, lo_open=True, unit="s")
    max_settle_shift: float = bounded(0.01, lo=0.0, lo_open=True, unit="m")
    max_settle_tilt_deg: float = bounded(8.0, lo=0.0, hi=90.0, lo_open=True, unit="degrees")
    max_rest_speed: float = bounded(0.02, lo=0.0, lo_open=True, unit="m/s")

    def __post_init__(self) -> None:
        super().__post_init__()
        if self.max_objects < self.min_objects:
            raise ConfigError(f"scene.max_objects={self.max_objects!r}: must be ≥ min_objects ({self.min_objects})")
        if self.menu_overrides is not None:
            object.__setattr__(self, "menu_overrides", _check_overrides(self.menu_overrides))

    @property
    def named_classes(self) -> tuple[str, ...]:
        """Every class this config names (``classes`` and the ``menu_overrides`` keys): the imported
        classes among them are the only ones that join the built-in catalogue."""
        return (*self.classes, *(self.menu_overrides or {}))


def _check_overrides(overrides: Any) -> dict[str, dict[str, list[str]]]:
    """The shape of ``menu_overrides``: class → {colour|material|size: [names]}. The names are checked
    against the catalogue by :func:`samplehd.scene.sampler.check_scene_config`."""
    if not isinstance(overrides, Mapping):
        raise ConfigError(f"scene.menu_overrides={overrides!r}: must be a JSON object class → "
                          "{\"colour\": [...], \"material\": [...], \"size\": [...]}")
    out: dict[str, dict[str, list[str]]] = {}
    for cls_name, menu in overrides.items():
        where = f"scene.menu_overrides.{cls_name}"
        if not isinstance(menu, Mapping) or not menu:
            raise ConfigError(f"{where}={menu!r}: must be a non-empty JSON object with any of "
                              f"{', '.join(_OVERRIDE_PROPERTIES)}")
        unknown = sorted(set(menu) - set(_OVERRIDE_PROPERTIES))
        if unknown:
            raise ConfigError(f"{where}: unknown properties {unknown}; valid: {', '.join(_OVERRIDE_PROPERTIES)}")
        for prop, values in menu.items():
            if isinstance(values, str) or not isinstance(values, list | tuple) or not values \
                    or not all(isinstance(v, str) for v in values):
                raise ConfigError(f"{where}.{prop}={values!r}: must be a non-empty list of names, "
                                  f"e.g. [\"red\"]")
        out[str(cls_name)] = {p: list(v) for p, v in menu.items()}
    return out
