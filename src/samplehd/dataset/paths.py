"""Ground-truth paths for the instructions of existing scene and instruction files (``samplehd
paths``), planned, executed and written by the same work unit as ``samplehd generate``, so the
episode files are the same HDF5 files (docs/FORMAT.md) with the same seed rule.

Outputs in OUT::

    episodes/s<scene>_<slot>.h5   one episode per succeeded instruction
    results.jsonl                 one line per instruction (instruction_index, scene_index, slot,
                                  family, seed, success, attempts, reason, message, frames, file, seconds)
    summary.json                  {attempted, succeeded, first_try, by_family: {family: {attempted,
                                  succeeded, first_try}}, rejections: {reason: count}, frames, seconds}
    config.json                   the resolved options

Instruction slot ``k`` of scene ``i`` draws from ``episode_seed(seed, i, k)``; the slot is the entry's
``slot`` (instruction files of ``generate``) or else its position among its scene's entries.
"""

from __future__ import annotations

import json
from collections import Counter
from collections.abc import Callable
from pathlib import Path
from typing import Any, TypedDict

from samplehd.dataset.layout import EPISODE_DIR, episode_name
from samplehd.dataset.render import RenderConfig, check_cameras
from samplehd.dataset.work import EpisodeUnit, run_episode_unit
from samplehd.errors import ConfigError, DatasetError, SamplehdError
from samplehd.fileio import read_json, write_json_atomic
from samplehd.language.executor import execute
from samplehd.language.instruction_file import read_instructions
from samplehd.language.scene import parse_scene
from samplehd.record.paths import PathConfig
from samplehd.scene.annotate import SceneAnnotation
from samplehd.scene.spec import SceneSpec
from samplehd.tasks.task import family_names, parse_task
from samplehd.workers import Backend
from samplehd.world.seeding import episode_seed

__all__ = ["FamilyCounts", "PathResult", "PathSummary", "check_instructions_fit", "format_summary", "generate_paths",
           "load_scenes", "summarise"]


class PathResult(TypedDict, total=False):
    """One line of ``results.jsonl``: an instruction's path, written (``file``) or rejected (``reason``,
    ``message``); ``frames`` [frames], ``seconds`` [s] of wall time."""

    instruction_index: int
    scene_index: int
    slot: int
    family: str
    seed: int
    success: bool
    attempts: int
    frames: int
    seconds: float
    file: str
    reason: str
    message: str


class FamilyCounts(TypedDict):
    """Paths of one family in ``summary.json``: attempted, succeeded, and succeeded at the first attempt."""

    attempted: int
    succeeded: int
    first_try: int


class PathSummary(TypedDict):
    """``summary.json`` of ``samplehd paths``: the counts over every instruction and by family, the
    rejection reasons with their counts (most common first), the frames written and the wall time [s]."""

    attempted: int
    succeeded: int
    first_try: int
    by_family: dict[str, FamilyCounts]
    rejections: dict[str, int]
    frames: int
    seconds: float


def load_scenes(path: Path) -> dict[int, SceneAnnotation]:
    """Scenes of a scenes.json (or a directory holding one), by image_index.

    Raises:
        DatasetError: unreadable file, or a scene without its ``spec``.
    """
    file = path / "scenes.json" if path.is_dir() else path
    data = read_json(file, DatasetError)
    scenes = data.get("scenes") if isinstance(data, dict) else None
    if not isinstance(scenes, list):
        raise DatasetError(f"{file}: expected {{info, scenes: [...]}}")
    out = {}
    for k, s in enumerate(scenes):
        if not isinstance(s, dict) or "spec" not in s:
            raise DatasetError(f"{file}: scenes[{k}]: spec: missing (write scenes with `samplehd scenes`)")
        out[int(s.get("image_index", k))] = s
    return out


def check_instructions_fit(entries: list[Any], scenes: dict[int, SceneAnnotation], instructions_path: Path,
                           scenes_path: Path) -> None:
    """Refuse instructions that were not made for these scenes, before any path is planned: each
    names a known family and a scene of the scenes file, and its program, run again on that scene,
    gives the task it records (instructions for other scenes name other or missing objects).

    Raises:
        ConfigError: one line naming the instruction, what contradicts and how to get matching files.
    """
    families = family_names()
    remake = f"make instructions for these scenes: samplehd instructions --scenes {scenes_path}"
    for k, e in enumerate(entries):
        where = f"{instructions_path} instructions[{k}]"
        if not isinstance(e, dict):
            raise ConfigError(f"{where}: expected an instruction object, got {type(e).__name__}")
        family = e.get("family")
        if family not in families:
            raise ConfigError(f"{where}: family {family!r} is unknown; valid: {', '.join(families)}")
        scene = scenes.get(e.get("image_index")) if isinstance(e.get("image_index"), int) else None
        if scene is None:
            raise ConfigError(f"{where}: image_index {e.get('image_index')!r} is not a scene of {scenes_path}; "
                              f"{remake}")
        try:
            # A scene given by its spec alone (no CLEVR annotation) is checked by its object count.
            parsed = (parse_scene(scene, where=f"{scenes_path} scene {e['image_index']}")
                      if "objects" in scene else None)
            count = len(parsed) if parsed is not None else len(scene["spec"]["objects"])
            task = parse_task(dict(e["task"]), family)
            named = [*task.objects] + ([task.reference] if task.reference != -1 else [])
            if any(not 0 <= i < count for i in named):
                raise ConfigError(f"{where}: names object(s) {named}, but scene {e['image_index']} of "
                                  f"{scenes_path} has objects 0..{count - 1}; {remake}")
            if parsed is not None and e.get("program") is not None:
                again = json.loads(json.dumps(execute(e["program"], parsed).to_program_dict()))
                if again != json.loads(json.dumps(e["task"])):
                    raise ConfigError(f"{where}: {str(e.get('instruction', ''))[:60]!r} means {again} on scene "
                                      f"{e['image_index']} of {scenes_path}, not the recorded {e['task']} "
                                      f"(made for other scenes?); {remake}")
        except ConfigError:
            raise
        except (SamplehdError, KeyError, TypeError, ValueError) as exc:
            raise ConfigError(f"{where}: does not fit scene {e['image_index']} of {scenes_path} "
                              f"({str(exc).splitlines()[0] if str(exc) else type(exc).__name__}); {remake}") from None


def generate_paths(
    scenes_path: Path,
    instructions_path: Path,
    out: Path,
    *,
    seed: int = 0,
    limit: int = 0,
    paths: PathConfig | None = None,
    render: RenderConfig | None = None,
    backend: Backend | None = None,
    on_result: Callable[[PathResult, int], None] | None = None,
) -> PathSummary:
    """Plan, execute and record every instruction; returns the summary (also written to OUT).

    Args:
        scenes_path: scenes directory (with scenes.json) or file.
        instructions_path: instructions.json.
        out: output directory.
        seed: base seed (see the module docstring).
        limit: only the first ``limit`` instructions (0: all).
        paths: planner and physics options.
        render: images per episode (default: none, states only).
        backend: where units run (default: in this process).
        on_result: called with each instruction's result and the number of instructions.

    Raises:
        DatasetError: unreadable inputs; ConfigError: inconsistent options (before anything is written).
    """
    paths = paths or PathConfig()
    render = render or RenderConfig(mode="none")
    backend = backend or Backend()
    if limit < 0:
        raise ConfigError(f"limit={limit}: must be ≥ 0 (0: all)", field="limit")
    check_cameras(render)
    scenes = load_scenes(scenes_path)
    entries = read_instructions(instructions_path)["instructions"]
    if limit:
        entries = entries[:limit]
    check_instructions_fit(entries, scenes, instructions_path, scenes_path)
    units, meta = [], {}
    slots: Counter[int] = Counter()
    for k, e in enumerate(entries):
        scene_index = int(e["image_index"])
        slot = int(e.get("slot", slots[scene_index]))
        slots[scene_index] += 1
        s = scenes[scene_index]
        unit = EpisodeUnit(out=str(out), file=episode_name(scene_index, slot), scene_index=scene_index, slot=slot,
                           seed=episode_seed(seed, scene_index, slot), family=str(e["family"]),
                           task=parse_task(e["task"], family=str(e["family"])),
                           instruction=str(e["instruction"]), split=str(e.get("split", s.get("split", "train"))),
                           scene=SceneSpec.from_dict(s["spec"]), directions=s.get("directions"), paths=paths,
                           render=render)
        units.append(unit)
        meta[(scene_index, slot)] = int(e.get("instruction_index", k))
    try:
        (out / EPISODE_DIR).mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise DatasetError(f"out={out}: not writable ({exc.strerror}); choose a writable directory",
                           field="out") from None
    write_json_atomic(out / "config.json", {"scenes": str(scenes_path), "instructions": str(instructions_path),
                                            "seed": seed, "limit": limit, "paths": paths.to_dict(),
                                            "render": render.to_dict(), "backend": backend.describe()}, indent=2)
    results: list[PathResult] = []
    with (out / "results.jsonl").open("w", encoding="utf-8") as log:
        for unit, res in backend.map(run_episode_unit, units):
            r: PathResult = {"instruction_index": meta[(unit.scene_index, unit.slot)], "scene_index": unit.scene_index,
                 "slot": unit.slot, "family": unit.family, "seed": unit.seed, "success": res.ok,
                 "attempts": 1 if res.attempts is None else res.attempts, "frames": res.num_frames or 0,
                 "seconds": res.seconds}
            if res.ok:
                r["file"] = f"{EPISODE_DIR}/{unit.file}"
            else:
                r.update(reason=res.reason, message=res.message or "")
            results.append(r)
            log.write(json.dumps(r) + "\n")
            log.flush()
            if on_result is not None:
                on_result(r, len(units))
    summary = summarise(sorted(results, key=lambda r: r["instruction_index"]))
    write_json_atomic(out / "summary.json", summary, indent=2)
    return summary


def summarise(results: list[PathResult]) -> PathSummary:
    """The summary.json content from per-instruction results."""
    by: dict[str, FamilyCounts] = {}
    rej: Counter[str] = Counter()
    for r in results:
        f = by.setdefault(r["family"], {"attempted": 0, "succeeded": 0, "first_try": 0})
        f["attempted"] += 1
        if r["success"]:
            f["succeeded"] += 1
            f["first_try"] += int(r.get("attempts", 1) == 1)
        else:
            rej[r["reason"]] += 1
    return {
        "attempted": len(results),
        "succeeded": sum(int(r["success"]) for r in results),
        "first_try": sum(f["first_try"] for f in by.values()),
        "by_family": dict(sorted(by.items())),
        "rejections": dict(rej.most_common()),
        "frames": int(sum(r.get("frames", 0) for r in results)),
        "seconds": float(sum(r.get("seconds", 0.0) for r in results)),
    }


def format_summary(summary: PathSummary) -> str:
    """The summary as a plain-text table."""
    lines = [f"{'family':16s} {'attempted':>9s} {'first try':>9s} {'succeeded':>9s} {'rate':>7s}"]
    for fam, f in summary["by_family"].items():
        rate = f["succeeded"] / f["attempted"] if f["attempted"] else 0.0
        lines.append(f"{fam:16s} {f['attempted']:9d} {f['first_try']:9d} {f['succeeded']:9d} {rate:7.1%}")
    a, s = summary["attempted"], summary["succeeded"]
    lines.append(f"{'all':16s} {a:9d} {summary['first_try']:9d} {s:9d} {(s / a if a else 0):7.1%}")
    if summary["rejections"]:
        lines.append("rejections: " + ", ".join(f"{k} {v}" for k, v in summary["rejections"].items()))
    return "\n".join(lines)
