"""Benchmark suite files: a frozen, hashed list of episodes that evaluation reads and never draws.

A suite file (JSON, written by ``samplehd suite build``, :mod:`samplehd.benchmark.suite`) holds:

==================  ================================================================================
key                 meaning
==================  ================================================================================
``format``          ``"samplehd-suite"`` (anything else is a foreign file)
``format_version``  :data:`SUITE_FORMAT_VERSION`
``name``            the suite's name
``package_version`` the samplehd version that built it
``build``           the resolved build configuration (seed, families, levels, catalogues, env options)
``manifest``        counts by family, level, catalogue, axis and strength; candidates tried and the
                    reasons the oracle failed the rejected ones; the oracle's success on the suite
``content_hash``    ``sha256:`` of the canonical JSON of ``episodes`` (sorted keys, no spaces)
``episodes``        one :class:`SuiteEpisode` dict each, in order
==================  ================================================================================

Each episode carries its full scene specification (objects, settled poses, camera), so resetting to it
needs no sampling and depends on no sampler version: the environment reset option
``{"suite": NAME_OR_FILE, "episode": i}`` rebuilds it exactly as ``scene`` + ``instruction`` do.
Shipped suites live beside this module (``suites/NAME.json``); a name is looked up there, anything
with a ``/`` or a ``.json`` suffix is a path.
"""

from __future__ import annotations

import copy
import functools
import hashlib
import json
from collections.abc import Mapping
from dataclasses import MISSING, asdict, dataclass
from pathlib import Path
from typing import Any, TypedDict

import numpy as np

from samplehd.errors import ConfigError
from samplehd.fileio import read_json, write_json_atomic

__all__ = ["CLEAN_AXIS", "SUITE_DIR", "SUITE_FORMAT", "SUITE_FORMAT_VERSION", "SUITE_SPEC_DIR", "Suite",
           "SuiteEpisode", "content_hash", "read_suite", "shipped_suites", "suite_path", "suite_reset_options"]

SUITE_FORMAT = "samplehd-suite"
SUITE_FORMAT_VERSION = 1
SUITE_DIR = Path(__file__).resolve().parent / "suites"
# The build options of the shipped suites (``samplehd suite build NAME`` reads NAME.json here).
SUITE_SPEC_DIR = SUITE_DIR / "specs"
# The clean axis: an episode as drawn, the twin every perturbed episode is compared with.
CLEAN_AXIS = "none"


class EpisodeRecord(TypedDict, total=False):
    """A suite episode as the file's ``episodes`` hold it (:meth:`SuiteEpisode.to_dict`; the keys are
    :class:`SuiteEpisode`'s fields). A robustness variant being built (:func:`samplehd.benchmark.axes.perturb`)
    lacks ``id`` until the suite numbers it."""

    id: int
    catalogue: str
    scene_seed: int
    reset_seed: int
    scene: dict[str, Any]
    instruction: str
    family: str
    task: dict[str, Any]
    program: list[Any]
    program_sequence: str
    targets: list[int]
    level: str
    axis: str
    strength: int
    twin: int | None
    oracle_steps: int
    start_state: dict[str, list[float]] | None
    sensor: dict[str, float] | None


class SceneResetOptions(TypedDict, total=False):
    """The environment's ``scene`` + ``instruction`` reset options of a suite episode: the scene
    specification, the instruction entry, and (robot start axis) the ``{qpos, qvel, act}`` start state."""

    scene: dict[str, Any]
    instruction: dict[str, Any]
    episode: dict[str, list[float]]


@dataclass(frozen=True)
class SuiteEpisode:
    """One episode of a suite.

    Attributes:
        id: its index in the suite.
        catalogue: the built-in catalogue its objects come from (``procedural``, ``shop-vrb``).
        scene_seed: the seed the scene was sampled from (the scene itself is in ``scene``).
        reset_seed: the environment's reset seed that drew the episode: evaluation resets with it and
            gives it to the policy's ``reset(seed=...)``, as the oracle got it when it proved the episode.
        scene: the scene specification (``SceneSpec.to_dict()``).
        instruction: the instruction text.
        family: the task family.
        task: the executor's task dict.
        program: the CLEVR program nodes.
        program_sequence: the program as flat tokens.
        targets: the objects the task names.
        level: the generalisation level L1–L4 of the episode.
        axis: the robustness axis (``none``: clean).
        strength: the axis' strength 0–5 (0: the clean twin).
        twin: the id of the clean twin (None for a clean episode).
        oracle_steps: control steps the closed-loop oracle took to succeed when the suite was built.
        start_state: ``{qpos, qvel, act}`` lists the episode starts from instead of the scene's own
            state (the robot start axis), or None.
        sensor: the sensor axis' image corruption (:mod:`samplehd.benchmark.sensor`: ``rgb_noise``,
            ``rgb_blur``, ``depth_noise``, ``depth_holes``), or None.
    """

    id: int
    catalogue: str
    scene_seed: int
    reset_seed: int
    scene: dict[str, Any]
    instruction: str
    family: str
    task: dict[str, Any]
    program: list[Any]
    program_sequence: str
    targets: list[int]
    level: str
    axis: str = CLEAN_AXIS
    strength: int = 0
    twin: int | None = None
    oracle_steps: int = 0
    start_state: dict[str, list[float]] | None = None
    sensor: dict[str, float] | None = None

    def to_dict(self) -> EpisodeRecord:
        return EpisodeRecord(**asdict(self))

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> SuiteEpisode:
        # Fields with a default may be left out; the others must be there.
        required = [k for k, f in cls.__dataclass_fields__.items() if f.default is MISSING]
        return cls(**{k: d[k] for k in required}, **{k: d[k] for k in cls.__dataclass_fields__
                                                      if k not in required and k in d})

    def reset_options(self) -> SceneResetOptions:
        """The environment's ``scene`` + ``instruction`` reset options of this episode (a private copy)."""
        options: SceneResetOptions = {
            "scene": self.scene,
            "instruction": {"instruction": self.instruction, "family": self.family, "task": self.task,
                            "program": self.program, "program_sequence": self.program_sequence,
                            "targets": self.targets}}
        if self.start_state is not None:
            options["episode"] = self.start_state
        return copy.deepcopy(options)


def content_hash(episodes: list[EpisodeRecord]) -> str:
    """``sha256:<hex>`` of the canonical JSON (sorted keys, no spaces) of the episode dicts."""
    text = json.dumps(episodes, sort_keys=True, separators=(",", ":"), ensure_ascii=True)
    return "sha256:" + hashlib.sha256(text.encode("ascii")).hexdigest()


@dataclass(frozen=True)
class Suite:
    """A suite as read from its file (see the module docstring).

    Attributes:
        name: the suite's name.
        path: the file it was read from (None: not yet written).
        content_hash: the hash over the episodes.
        build: the resolved build configuration.
        manifest: counts and rejection reasons.
        package_version: the samplehd version that built it.
        episodes: the episodes, in order.
    """

    name: str
    path: str | None
    content_hash: str
    build: dict[str, Any]
    manifest: dict[str, Any]
    package_version: str
    episodes: tuple[SuiteEpisode, ...]

    def episode(self, index: Any) -> SuiteEpisode:
        """Episode ``index``; a ConfigError naming the valid range otherwise."""
        if (not isinstance(index, (int, np.integer)) or isinstance(index, bool)
                or not 0 <= int(index) < len(self.episodes)):
            raise ConfigError(f"reset: option 'episode' {index!r}: suite {self.name!r} has episodes "
                              f"0..{len(self.episodes) - 1}")
        return self.episodes[int(index)]

    def to_dict(self) -> dict[str, object]:
        return {"format": SUITE_FORMAT, "format_version": SUITE_FORMAT_VERSION, "name": self.name,
                "package_version": self.package_version, "build": self.build, "manifest": self.manifest,
                "content_hash": self.content_hash, "episodes": [e.to_dict() for e in self.episodes]}

    def write(self, path: str | Path) -> None:
        """Write the suite file (atomically)."""
        write_json_atomic(Path(path), self.to_dict(), indent=None)


def shipped_suites() -> list[str]:
    """Names of the suites shipped in the package."""
    return sorted(p.stem for p in SUITE_DIR.glob("*.json"))


def suite_path(name_or_file: str | Path) -> Path:
    """The file of a suite name (shipped) or a path.

    Raises:
        ConfigError: a name that is not shipped (the message lists those that are).
    """
    text = str(name_or_file)
    if "/" in text or text.endswith(".json") or Path(text).is_file():
        return Path(text)
    path = SUITE_DIR / f"{text}.json"
    if not path.exists():
        raise ConfigError(f"suite={text!r}: no such shipped suite; shipped: {', '.join(shipped_suites()) or 'none'}"
                          " (or give a suite file's path)", field="suite")
    return path


def read_suite(name_or_file: str | Path) -> Suite:
    """Read and check a suite file or shipped suite (cached per file and modification time).

    Raises:
        ConfigError: one line naming the file and what is wrong: unreadable, not JSON, not a suite
            file, another format version, a missing field, or episodes that do not match the hash.
    """
    path = suite_path(name_or_file)
    try:
        stamp = path.stat().st_mtime_ns
    except OSError:
        stamp = -1
    return _read(str(path), stamp)


@functools.lru_cache(maxsize=8)
def _read(path: str, stamp: int) -> Suite:
    label = f"suite {path}"
    raw = read_json(path, ConfigError, label, field="suite")
    if not isinstance(raw, dict) or raw.get("format") != SUITE_FORMAT:
        raise ConfigError(f"{label}: not a samplehd suite file (its 'format' is not {SUITE_FORMAT!r}); build one "
                          "with `samplehd suite build`", field="suite")
    if raw.get("format_version") != SUITE_FORMAT_VERSION:
        raise ConfigError(f"{label}: format_version {raw.get('format_version')!r}: this samplehd reads version "
                          f"{SUITE_FORMAT_VERSION}; rebuild the suite", field="suite")
    for key, kind in (("name", str), ("content_hash", str), ("episodes", list), ("manifest", dict), ("build", dict)):
        if not isinstance(raw.get(key), kind):
            raise ConfigError(f"{label}: field {key!r} is missing or not a {kind.__name__}; the file is damaged",
                              field="suite")
    if content_hash(raw["episodes"]) != raw["content_hash"]:
        raise ConfigError(f"{label}: the episodes do not match content_hash {raw['content_hash']!r}; the file is "
                          "damaged or was edited (rebuild it)", field="suite")
    episodes = []
    for i, d in enumerate(raw["episodes"]):
        try:
            ep = SuiteEpisode.from_dict(d)
        except (KeyError, TypeError) as exc:
            raise ConfigError(f"{label}: episode {i} lacks field {exc}; the file is damaged", field="suite") from None
        if ep.id != i:
            raise ConfigError(f"{label}: episode {i} has id {ep.id}; the file is damaged", field="suite")
        episodes.append(ep)
    return Suite(name=raw["name"], path=path, content_hash=raw["content_hash"], build=raw["build"],
                 manifest=raw["manifest"], package_version=str(raw.get("package_version", "")),
                 episodes=tuple(episodes))


def suite_reset_options(options: Mapping[str, Any]) -> SceneResetOptions:
    """The ``scene`` + ``instruction`` reset options of the environment option ``{"suite": NAME_OR_FILE,
    "episode": i}``.

    Raises:
        ConfigError: another option beside the two, a suite that is not a name or path, a damaged
            or foreign file, or an episode index outside the suite.
    """
    extra = sorted(set(options) - {"suite", "episode"})
    if extra:
        raise ConfigError(f"reset: option 'suite' goes with 'episode' (an index) only; leave out {extra}")
    name = options["suite"]
    if not isinstance(name, (str, Path)) or not str(name):
        raise ConfigError(f"reset: option 'suite' must be a suite name or file path, got {name!r}")
    suite = read_suite(name)
    if "episode" not in options:
        raise ConfigError(f"reset: option 'suite' needs 'episode' (an index 0..{len(suite.episodes) - 1})")
    return suite.episode(options["episode"]).reset_options()
