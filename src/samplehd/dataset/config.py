"""Configuration of dataset generation, its presets, and the seeds of every work unit.

A config file is JSON with any of the sections below; unknown keys are errors naming the file and
field::

    {"num_scenes": 2000, "seed": 0, "target_episodes": 8360, "test_every": 20,
     "scene": {...SceneConfig...}, "instructions": {"per_scene": 8, "balance": "templates",
     "families": null}, "paths": {...PathConfig...}, "render": {"mode": "fast", "width": 640,
     "height": 360, "cameras": ["scene"], "modalities": ["rgb", "depth", "segmentation"]}}

Presets give every field; a config file overrides a preset, command-line flags override both.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

from samplehd.dataset.render import RenderConfig, check_cameras, check_render_applies
from samplehd.errors import ConfigError
from samplehd.fileio import read_json
from samplehd.record.disturbances import DisturbanceConfig
from samplehd.record.paths import PathConfig
from samplehd.scene.config import SceneConfig
from samplehd.scene.sampler import check_scene_config
from samplehd.schema import Config, bounded
from samplehd.tasks.task import family_names

__all__ = [
    "PRESETS",
    "GenerateConfig",
    "check_names",
    "InstructionConfig",
    "load_config",
    "preset_config",
]

_BALANCE = ("templates", "families")


@dataclass(frozen=True)
class InstructionConfig(Config, section="instructions"):
    """How instruction candidates are generated.

    Attributes:
        per_scene: instruction candidates per scene (fewer where a scene allows fewer); each gets a
            ground-truth path attempt, and the failed ones are left out of the dataset.
        balance: what comes out uniform: ``templates`` or ``families``.
        families: only these task families (None: all of SAMPLE-HD's and samplehd's).
    """

    per_scene: int = bounded(5, lo=1, hi=99)
    balance: str = bounded("templates", choices=_BALANCE)
    families: tuple[str, ...] | None = bounded(None, choices=family_names, nonempty=True, unique=True)


@dataclass(frozen=True)
class GenerateConfig(Config, section="config"):
    """Everything that decides a dataset's content (not how fast it is made).

    Attributes:
        num_scenes: scenes to sample.
        seed: base seed; scene ``i`` and instruction slot ``k`` of it draw from seeds derived from
            ``(seed, i)`` and ``(seed, i, k)`` alone, so the result does not depend on workers or backend.
        target_episodes: stop once this many episodes succeeded, counting candidates in slot-major order
            (every scene's first instruction, then every scene's second, ...); 0: keep every success.
        test_every: every ``test_every``-th scene (and its instructions) is in the test split.
        scene: scene sampler options.
        instructions: instruction candidate options.
        paths: ground-truth path options (``samplehd.record.paths.PathConfig``).
        render: images stored with each episode.
        disturbances: failures applied to episodes for the oracle to recover from
            (``samplehd.record.disturbances``); off (probability 0) by default, and then left out of
            :meth:`to_dict`, so a dataset without the section records the config it always did.
    """

    num_scenes: int = bounded(4, lo=1, hi=1_000_000)
    seed: int = bounded(0, lo=0)
    target_episodes: int = bounded(0, lo=0)
    test_every: int = bounded(20, lo=0)
    scene: SceneConfig = field(default_factory=SceneConfig)
    instructions: InstructionConfig = field(default_factory=InstructionConfig)
    paths: PathConfig = field(default_factory=PathConfig)
    render: RenderConfig = field(default_factory=RenderConfig)
    disturbances: DisturbanceConfig = field(default_factory=DisturbanceConfig)

    def to_dict(self) -> dict[str, object]:
        """JSON-ready options; ``disturbances`` only when it is on."""
        d = super().to_dict()
        if not self.disturbances.enabled:
            del d["disturbances"]
        return d

    @classmethod
    def from_dict(cls, d: Mapping[str, Any], where: str | None = None, base: GenerateConfig | None = None
                  ) -> GenerateConfig:
        """Build from a mapping; missing keys come from ``base`` (default: the defaults).

        Raises:
            ConfigError: an unknown key or a bad value, naming ``where`` (default ``config``) and the field.
        """
        where = cls._section if where is None else where
        if not isinstance(d, Mapping):
            raise ConfigError(f"{where}: expected a JSON object")
        base = base or cls()
        valid = {"num_scenes", "seed", "target_episodes", "test_every", "scene", "instructions", "paths", "render",
                 "disturbances"}
        unknown = sorted(set(d) - valid)
        if unknown:
            raise ConfigError(f"{where}: unknown option(s) {unknown}; valid: {', '.join(sorted(valid))}")
        kw: dict[str, Any] = {}
        for k in ("num_scenes", "seed", "target_episodes", "test_every"):
            if k in d:
                kw[k] = d[k]
        sections = {
            "scene": lambda s: SceneConfig.from_dict({**base.scene.to_dict(), **s}, where=f"{where}: scene"),
            "instructions": lambda s: InstructionConfig.from_dict({**base.instructions.to_dict(), **s},
                                                                  where=f"{where}: instructions"),
            "paths": lambda s: PathConfig.from_dict(_merge_paths(base.paths.to_dict(), s), where=f"{where}: paths"),
            "render": lambda s: RenderConfig.from_dict({**base.render.to_dict(), **s}, where=f"{where}: render"),
            "disturbances": lambda s: DisturbanceConfig.from_dict({**base.disturbances.to_dict(), **s},
                                                                  where=f"{where}: disturbances"),
        }
        for k, make in sections.items():
            if k in d:
                if not isinstance(d[k], Mapping):
                    raise ConfigError(f"{where}: {k}: expected a JSON object")
                try:
                    kw[k] = make(d[k])
                except ConfigError as exc:
                    msg = str(exc)
                    raise ConfigError(msg if msg.startswith(where) else f"{where}: {msg}") from None
        try:
            return replace(base, **kw)
        except ConfigError as exc:
            raise ConfigError(f"{where}: {exc}") from None


def _merge_paths(base: dict[str, Any], override: Mapping[str, Any]) -> dict[str, Any]:
    """``paths`` of ``base`` with ``override`` applied, ``planner`` and ``checker`` key by key (a config
    that sets one planner field keeps the rest of its base's, e.g. the sample-hd preset's order)."""
    merged = {**base, **override}
    for sub in ("planner", "checker"):
        if isinstance(override.get(sub), Mapping) and isinstance(base.get(sub), Mapping):
            merged[sub] = {**base[sub], **override[sub]}
    return merged


PRESETS: dict[str, dict[str, Any]] = {
    # A minute on two cores: 4 small scenes, 2 candidates each, small images.
    "tiny": {
        "num_scenes": 4,
        "scene": {"min_objects": 3, "max_objects": 3},
        "instructions": {"per_scene": 2},
        "render": {"mode": "fast", "width": 128, "height": 72},
        "test_every": 4,
    },
    "small": {
        "num_scenes": 40,
        "instructions": {"per_scene": 4},
        "render": {"mode": "fast", "width": 320, "height": 180},
    },
    # SAMPLE-HD's shape: 2000 scenes of 3-5 objects of its own SHOP-VRB shapes, >= 8360 successful
    # instructions, 16:9 images; several moved objects are picked in SAMPLE-HD's order (nearest the
    # effector first), the order its preprocessing assumes.
    "sample-hd": {
        "num_scenes": 2000,
        "target_episodes": 8360,
        "scene": {"min_objects": 3, "max_objects": 5},
        "instructions": {"per_scene": 10},
        "paths": {"planner": {"order": "nearest"}},
        "render": {"mode": "fast", "width": 640, "height": 360},
    },
}


def preset_config(name: str) -> GenerateConfig:
    """The config of a preset; raises ConfigError listing the valid names."""
    if name not in PRESETS:
        raise ConfigError(f"unknown preset {name!r}; valid: {', '.join(PRESETS)}")
    return GenerateConfig.from_dict(PRESETS[name], where=f"preset {name}")


def load_config(path: Path | None, base: GenerateConfig) -> GenerateConfig:
    """Apply a JSON config file to ``base``; errors name the file and field."""
    if path is None:
        return base
    doc = read_json(path, ConfigError, f"config={path}", field="config")
    config = GenerateConfig.from_dict(doc, where=str(path), base=base)
    check_names(config, where=str(path))
    render = doc.get("render")
    check_render_applies(config.render, {k: f"{path}: render.{k}" for k in render} if isinstance(render, dict) else {})
    return config


def check_names(config: GenerateConfig, where: str = "config") -> None:
    """Check the names a config uses against the catalogue and the world (object classes, menu
    colours/materials/sizes, cameras): the part of validation that needs them.

    Raises:
        ConfigError: one line starting with ``where``.
    """
    try:
        check_scene_config(config.scene)
        check_cameras(config.render)
    except ConfigError as exc:
        raise ConfigError(f"{where}: {exc}") from None


def candidate_order(keys: Sequence[tuple[int, int]]) -> list[tuple[int, int]]:
    """Candidates (scene, slot) in slot-major order: the order ``target_episodes`` counts in."""
    return sorted(keys, key=lambda k: (k[1], k[0]))


def dispatch_order(keys: Sequence[tuple[int, int]], target_episodes: int) -> list[tuple[int, int]]:
    """The order episode units are handed to the workers in.

    Where ``target_episodes`` could stop the run before its last candidate, slot-major (the order the
    target counts in, so that no unit past the stop runs); otherwise scene by scene, so that a worker
    meets a scene's units one after another and compiles its world once for them
    (:func:`samplehd.dataset.work.unit_world`). Either way every unit's bytes are its own seed's.
    """
    if 0 < target_episodes < len(keys):
        return candidate_order(keys)
    return sorted(keys)
