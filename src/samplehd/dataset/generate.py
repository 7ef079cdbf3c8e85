"""Generate a dataset: scenes → instruction candidates → ground-truth paths (+ images) → metadata.

The writer of the layout in docs/FORMAT.md::

    DIR/info.json  scenes.json  instructions.json  candidates.json  journal.jsonl  runs.jsonl
    DIR/scenes/SHD_<split>_<index:06d>.json   (+ images/ depth/ segmentation/ of each scene)
    DIR/episodes/s<scene:06d>_<slot:02d>.h5    one HDF5 container per successful episode

Stages and their units:

1. scenes: one unit per scene (``scene_seed(seed, i)``); done when its ``scenes/<stem>.json`` exists.
2. instructions: one deterministic pass over all scenes in index order (template use counts are shared
   across scenes), written to ``candidates.json``; slot ``k`` of scene ``i`` gets
   ``episode_seed(seed, i, k)``.
3. paths: one unit per candidate, fed in slot-major order; done when its episode file exists or the
   journal records its rejection. With ``target_episodes`` the run stops at the candidate whose success
   reaches the target (counted in that order), whatever finished first.
4. finalize: ``instructions.json`` (successful candidates, numbered 0..M-1 by scene then slot),
   ``scenes.json`` and ``info.json`` (status ``complete``).

Every file is written atomically, so a run killed at any moment resumes (``resume=True``) to the same
dataset an uninterrupted run makes.
"""

from __future__ import annotations

import json
import os
import platform
import sys
import time
from collections import Counter
from collections.abc import Iterator
from contextlib import ExitStack
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import h5py
import mujoco
import numpy

from samplehd.catalogue.loader import LEGACY_CATALOGUE, catalogue_for
from samplehd.catalogue.model import CatalogueRecord
from samplehd.dataset.config import GenerateConfig, candidate_order, dispatch_order
from samplehd.dataset.container import read_meta, write_error
from samplehd.dataset.journal import JournalRecord, append_journal, read_journal, repair_journal
from samplehd.dataset.layout import (
    CANDIDATES_FILE,
    EPISODE_DIR,
    FORMAT_VERSION,
    INFO_FILE,
    INSTRUCTIONS_FILE,
    RESUME_HINT,
    RUNS_FILE,
    SCENE_DIR,
    SCENES_FILE,
    DatasetInfo,
    episode_name,
    is_temporary,
    parse_episode_name,
)
from samplehd.dataset.lock import dataset_lock
from samplehd.dataset.progress import Progress
from samplehd.dataset.reader import DatasetReader
from samplehd.dataset.render import check_cameras
from samplehd.dataset.work import EpisodeUnit, run_episode_unit, run_scene_unit
from samplehd.errors import ConfigError, DatasetError
from samplehd.fileio import file_sha256, write_json_atomic
from samplehd.fixedmath import machine
from samplehd.language.instruction_file import InstructionEntry, generate_instruction_file
from samplehd.render.image_spec import ImageSpec
from samplehd.render.renderer import MODALITIES
from samplehd.scene.annotate import SceneAnnotation, image_stem
from samplehd.scene.generate import SceneJob, scene_split
from samplehd.scene.sampler import check_scene_config
from samplehd.scene.spec import SceneSpec
from samplehd.tasks.task import parse_task
from samplehd.version import __version__
from samplehd.workers import Backend
from samplehd.world.seeding import episode_seed, scene_seed

__all__ = ["GenerateSummary", "generate_dataset", "versions"]


@dataclass
class GenerateSummary:
    """What a run made.

    Attributes:
        scenes: scenes in the dataset.
        candidates: instruction candidates generated.
        attempted: candidates whose path was attempted (up to the target cutoff).
        episodes: successful episodes in the dataset.
        frames: frames over all episodes.
        rejections: path rejections by reason (up to the cutoff).
        scene_rejections: scene-sampling rejections by reason.
        families: episodes per family.
        target_reached: whether ``target_episodes`` was reached (True when there is no target).
        seconds: wall time of this run [s].
        work_seconds: summed unit times of the units this run executed [s].
        units_run: path units executed in this run (not resumed from disk).
        stage_seconds: wall time per stage of this run [s].
        cpu_seconds: summed CPU time of the path units this run executed [s] (independent of contention).
        scene_cpu_seconds: summed CPU time of the scene units this run executed [s].
    """

    scenes: int = 0
    candidates: int = 0
    attempted: int = 0
    episodes: int = 0
    frames: int = 0
    rejections: dict[str, int] = field(default_factory=dict)
    scene_rejections: dict[str, int] = field(default_factory=dict)
    families: dict[str, int] = field(default_factory=dict)
    target_reached: bool = True
    seconds: float = 0.0
    work_seconds: float = 0.0
    units_run: int = 0
    stage_seconds: dict[str, float] = field(default_factory=dict)
    cpu_seconds: float = 0.0
    scene_cpu_seconds: float = 0.0


def versions() -> dict[str, str]:
    """Versions of what decides the content: samplehd, MuJoCo, numpy, h5py, Python."""
    return {"samplehd": __version__, "mujoco": mujoco.__version__, "numpy": numpy.__version__,
            "h5py": h5py.__version__, "python": platform.python_version()}



def _write_json(path: Path, obj: Any, indent: int | None = None) -> None:
    try:
        write_json_atomic(path, obj, indent)
    except OSError as exc:
        raise write_error(path, exc, RESUME_HINT) from None


def _first_difference(a: Any, b: Any, where: str = "") -> str | None:
    if isinstance(a, dict) and isinstance(b, dict):
        for k in sorted(set(a) | set(b)):
            d = _first_difference(a.get(k), b.get(k), f"{where}.{k}" if where else k)
            if d:
                return d
        return None
    return None if a == b else f"{where}: {a!r} in the dataset, {b!r} now"


def _prepare(out: Path, config: GenerateConfig, resume: bool) -> None:
    info_path = out / INFO_FILE
    if out.exists() and not out.is_dir():
        raise DatasetError(f"out={out}: exists and is not a directory", field="out")
    if resume and not info_path.exists():
        what = "does not exist" if not out.exists() else "holds no dataset (no info.json)"
        raise DatasetError(f"resume: {out} {what}; leave out `resume` to start a new dataset there", field="resume")
    if info_path.exists():
        if not resume:
            raise DatasetError(f"out={out}: already holds a dataset; pass `resume` to continue it or choose "
                               f"another `out`", field="out")
        try:
            stored_info = json.loads(info_path.read_text())
            stored = stored_info["config"]
        except (OSError, ValueError, KeyError, TypeError) as exc:
            raise DatasetError(f"{info_path}: unreadable ({exc}); cannot resume") from None
        _check_resumable(out, stored_info)
        diff = _first_difference(stored, json.loads(json.dumps(config.to_dict())))
        if diff:
            raise ConfigError(f"resume: the config differs from {info_path} at {diff}; resume with the same "
                              f"preset/config/flags", field="resume")
        if isinstance(stored_info.get("catalogue"), dict):
            changed = _catalogue_difference(stored_info["catalogue"], catalogue_in_use(config))
            if changed:
                raise ConfigError(f"resume: {info_path} catalogue.sha256 does not match the catalogue now "
                                  f"({changed} changed since the dataset was started); resume with the "
                                  "catalogue it was made with, or start a new `out`", field="resume")
    elif out.is_dir() and _holds_files(out):
        raise DatasetError(f"out={out}: is not empty and holds no dataset; choose an empty or new directory",
                           field="out")
    try:
        for sub in _LAYOUT_DIRS:
            (out / sub).mkdir(parents=True, exist_ok=True)
        probe = out / f".write-test{os.getpid()}"
        probe.write_text("")
        probe.unlink()
    except OSError as exc:
        raise DatasetError(f"out={out}: not writable ({exc.strerror}); choose a writable directory",
                           field="out") from None
    for folder in (out, out / SCENE_DIR, out / EPISODE_DIR):
        for p in folder.iterdir():
            if is_temporary(p.name) and p.is_file():
                p.unlink()
    repair_journal(out)


# The folders a new dataset starts with (made before info.json is written).
_LAYOUT_DIRS = (SCENE_DIR, EPISODE_DIR, "images", "depth", "segmentation")


def _holds_files(out: Path) -> bool:
    """Whether ``out`` holds anything but temporary files and the empty folders a start that failed
    before writing info.json leaves (such a stub must not block the next run)."""
    for p in out.iterdir():
        if is_temporary(p.name):
            continue
        if not (p.name in _LAYOUT_DIRS and p.is_dir() and not any(p.iterdir())):
            return True
    return False


def _check_resumable(out: Path, info: DatasetInfo) -> None:
    """Refuse to resume a dataset of another format, or one whose finished episodes are missing or
    damaged (resuming would build on them); nothing is changed."""
    reader = DatasetReader(out)  # checks format_version
    reader.check_intact(verify=True)
    for record in read_journal(out):
        if record.get("status") != "ok":
            continue
        path = out / EPISODE_DIR / episode_name(int(record["scene_index"]), int(record["slot"]))
        size = path.stat().st_size if path.is_file() else -1
        if size != record.get("size", size):
            state = "missing" if size < 0 else f"{size} bytes, the journal records {record['size']}"
            raise DatasetError(f"{path}: {state} (damaged); nothing was changed; `samplehd validate {out}` lists "
                               "every problem")


def catalogue_in_use(config: GenerateConfig) -> CatalogueRecord:
    """The content hashes of the catalogue a dataset's scenes draw from (built-in data files plus
    every imported class the config names); recorded in info.json and checked on ``--resume``."""
    return catalogue_for(config.scene.named_classes, config.scene.catalogue).record()


def _catalogue_difference(stored: CatalogueRecord, now: CatalogueRecord) -> str | None:
    if stored.get("sha256") == now["sha256"]:
        return None
    then = stored.get("name", LEGACY_CATALOGUE)  # a record older than catalogue names
    if then != now["name"]:
        return f"the catalogue ({then} then, {now['name']} now)"
    if stored.get("built_in") != now["built_in"]:
        return "the built-in catalogue data files"
    old, new = stored.get("imported", {}), now["imported"]
    changed = sorted(n for n in set(old) | set(new) if old.get(n) != new.get(n))
    return "imported class(es) " + ", ".join(changed)


def _base_info(config: GenerateConfig) -> DatasetInfo:
    return {"format_version": FORMAT_VERSION, "status": "in_progress", "versions": versions(),
            "machine": machine(),  # to trace a difference between machines
            "config": config.to_dict(), "catalogue": catalogue_in_use(config)}


def _scene_stage(out: Path, config: GenerateConfig, backend: Backend, progress: Progress,
                 summary: GenerateSummary) -> Iterator[SceneAnnotation]:
    """Sample the missing scenes; yield every scene's annotation in index order as soon as it and all
    before it exist, so that the instruction stage runs while later scenes are sampled."""
    r = config.render
    preset = r.mode if r.enabled else "fast"

    def path(i: int) -> Path:
        return out / SCENE_DIR / f"{image_stem(scene_split(i, config.test_every), i)}.json"

    image = ImageSpec(r.width, r.height, preset, modalities=MODALITIES)
    jobs = [SceneJob(i, scene_seed(config.seed, i), str(out), config.scene, image, config.test_every)
            for i in range(config.num_scenes) if not path(i).exists()]
    progress.stage("scenes", config.num_scenes, config.num_scenes - len(jobs))
    done = [True] * config.num_scenes
    for job in jobs:
        done[job.index] = False
    following = 0  # next scene to yield

    def ready() -> Iterator[SceneAnnotation]:
        nonlocal following
        while following < config.num_scenes and done[following]:
            try:
                scene = json.loads(path(following).read_text())
            except (OSError, ValueError) as exc:
                raise DatasetError(f"{path(following)}: unreadable scene file ({exc}); delete it and run with "
                                   "`resume`") from None
            following += 1
            yield scene

    yield from ready()
    for job, res in backend.map(run_scene_unit, iter(jobs)):
        summary.scene_cpu_seconds += res.cpu_seconds
        progress.advance("scenes")
        done[job.index] = True
        yield from ready()


def _instruction_stage(out: Path, config: GenerateConfig, scenes: Iterator[SceneAnnotation],
                       progress: Progress) -> tuple[list[SceneAnnotation], list[InstructionEntry]]:
    """Instruction candidates of every scene, made as the scenes arrive (or read back when resuming);
    returns (scenes, candidates)."""
    path = out / CANDIDATES_FILE
    progress.stage("instructions", config.num_scenes)
    if path.exists():
        seen = list(scenes)
        try:
            doc = json.loads(path.read_text())
        except (OSError, ValueError) as exc:
            raise DatasetError(f"{path}: unreadable ({exc}); delete it and run with `resume`") from None
        progress.advance("instructions", len(seen))
        return seen, list(doc["instructions"])
    seen = []

    def arriving() -> Iterator[SceneAnnotation]:
        for scene in scenes:
            seen.append(scene)
            yield scene

    ic = config.instructions
    doc = generate_instruction_file(arriving(), config.seed, per_scene=ic.per_scene, balance=ic.balance,
                                    families=list(ic.families) if ic.families is not None else None,
                                    scenes_info={"num_scenes": config.num_scenes, "seed": config.seed},
                                    progress=lambda done, total: progress.advance("instructions"),
                                    source=str(out / SCENE_DIR), total=config.num_scenes)
    slots: Counter[int] = Counter()
    for entry in doc["instructions"]:
        scene = int(entry["image_index"])
        slot = slots[scene]
        slots[scene] += 1
        entry["candidate_index"] = entry.pop("instruction_index")
        entry["slot"] = slot
        entry["seed"] = episode_seed(config.seed, scene, slot)
        entry["file"] = f"{EPISODE_DIR}/{episode_name(scene, slot)}"
    _write_json(path, doc)
    return seen, list(doc["instructions"])


class _Cutoff:
    """Tracks results in slot-major order to find where ``target_episodes`` is reached."""

    def __init__(self, order: list[tuple[int, int]], target: int) -> None:
        self.order = order
        self.target = target
        self.status: dict[tuple[int, int], bool] = {}
        self.next = 0  # first position whose status is unknown
        self.successes = 0  # among positions < next
        self.end: int | None = None  # positions < end are in the dataset

    def record(self, key: tuple[int, int], ok: bool) -> None:
        self.status[key] = ok
        while self.end is None and self.next < len(self.order) and self.order[self.next] in self.status:
            self.successes += self.status[self.order[self.next]]
            self.next += 1
            if self.target and self.successes >= self.target:
                self.end = self.next

    def needed(self, position: int) -> bool:
        return self.end is None or position < self.end


def _path_stage(out: Path, config: GenerateConfig, scenes: list[SceneAnnotation], candidates: list[InstructionEntry],
                backend: Backend, progress: Progress, summary: GenerateSummary) -> _Cutoff:

    by_key = {(int(c["image_index"]), int(c["slot"])): c for c in candidates}
    order = candidate_order(list(by_key))
    cutoff = _Cutoff(order, config.target_episodes)
    known: dict[tuple[int, int], JournalRecord] = {}
    for rec in read_journal(out):
        key = (int(rec["scene_index"]), int(rec["slot"]))
        if key in by_key and (rec["status"] == "rejected" or (out / by_key[key]["file"]).exists()):
            known[key] = rec
    # An episode file renamed into place just before a kill, without its journal line.
    late = []
    for p in (out / EPISODE_DIR).iterdir():
        key = parse_episode_name(p.name)
        if key is not None and key in by_key and key not in known:
            try:
                meta = read_meta(p)
            except DatasetError:
                p.unlink()
                continue

            rec = {"scene_index": key[0], "slot": key[1], "status": "ok", "num_frames": int(meta["num_frames"]),
                   "size": p.stat().st_size, "sha256": file_sha256(p), "seconds": 0.0}
            label = meta["info"].get("disturbance") if isinstance(meta.get("info"), dict) else None
            if label is not None:
                rec.update({"success": bool(meta["success"]), "disturbance": label["kind"],
                            "outcome": label["outcome"]})
            known[key] = rec
            late.append(rec)
    append_journal(out, late)
    for key in order:
        if key in known:
            cutoff.record(key, _succeeded(known[key]))
    scene_by_index = {int(s["image_index"]): s for s in scenes}
    total = len(order) if cutoff.end is None else cutoff.end
    progress.stage("paths", total, sum(1 for k in order[:total] if k in known))
    frames_done = sum(int(r.get("num_frames", 0)) for k, r in known.items())
    if frames_done:
        progress.advance("paths", 0, frames_done)

    position = {k: i for i, k in enumerate(order)}
    dispatch = dispatch_order(order, config.target_episodes)

    def units() -> Iterator[EpisodeUnit]:
        for key in dispatch:
            if key in known:
                continue
            if not cutoff.needed(position[key]):
                return
            c = by_key[key]
            s = scene_by_index[key[0]]
            yield EpisodeUnit(out=str(out), file=Path(c["file"]).name, scene_index=key[0], slot=key[1],
                              seed=int(c["seed"]), family=str(c["family"]),
                              task=parse_task(c["task"], family=str(c["family"])),
                              instruction=str(c["instruction"]), split=str(c["split"]),
                              scene=SceneSpec.from_dict(s["spec"]), directions=s["directions"], paths=config.paths,
                              render=config.render,
                              disturbances=config.disturbances if config.disturbances.enabled else None)

    for unit, res in backend.map(run_episode_unit, units()):
        key = (unit.scene_index, unit.slot)
        record = res.to_dict()
        append_journal(out, [record])
        known[key] = record
        cutoff.record(key, _succeeded(record))
        summary.units_run += 1
        summary.work_seconds += res.seconds
        summary.cpu_seconds += res.cpu_seconds
        if cutoff.end is not None and position[key] >= cutoff.end:
            continue
        progress.advance("paths", 1, res.num_frames or 0)
        if not res.ok:
            progress.note(f"scene {key[0]} slot {key[1]}: rejected ({res.reason})")
    if cutoff.end is not None:
        progress.stage("paths", cutoff.end, cutoff.end)
    cutoff.known = known  # type: ignore[attr-defined]
    return cutoff


def _succeeded(record: JournalRecord) -> bool:
    """Whether a journal record is a success: an episode written, and not a failed recovery (kept, but
    not counted towards ``target_episodes``)."""
    return record.get("status") == "ok" and record.get("success", True) is not False


def _finalize(out: Path, config: GenerateConfig, scenes: list[SceneAnnotation], candidates: list[InstructionEntry],
              cutoff: _Cutoff, summary: GenerateSummary) -> None:
    known: dict[tuple[int, int], JournalRecord] = cutoff.known  # type: ignore[attr-defined]
    end = len(cutoff.order) if cutoff.end is None else cutoff.end
    included = set(cutoff.order[:end])
    by_key = {(int(c["image_index"]), int(c["slot"])): c for c in candidates}
    ok_keys = sorted(k for k in included if known.get(k, {}).get("status") == "ok")
    instructions, episodes = [], []
    families: Counter[str] = Counter()
    splits: Counter[str] = Counter()
    outcomes: dict[str, Counter[str]] = {k: Counter() for k in config.disturbances.kinds}
    for i, key in enumerate(ok_keys):
        c = dict(by_key[key])
        rec = known[key]
        c["instruction_index"] = i
        c["num_frames"] = int(rec["num_frames"])
        instructions.append(c)
        episodes.append({"instruction_index": i, "scene_index": key[0], "slot": key[1], "file": c["file"],
                         "seed": int(c["seed"]), "family": c["family"], "split": c["split"],
                         "num_frames": int(rec["num_frames"]), "size": int(rec["size"]), "sha256": rec["sha256"]})
        if "disturbance" in rec:
            episodes[-1].update({k: rec[k] for k in ("disturbance", "outcome", "success")})
            outcomes[rec["disturbance"]][rec["outcome"]] += 1
        families[c["family"]] += 1
        splits[c["split"]] += 1
    # Episodes past the target cutoff (finished by other workers meanwhile) are not part of the dataset.
    keep = {Path(e["file"]).name for e in episodes}
    for p in (out / EPISODE_DIR).iterdir():
        if parse_episode_name(p.name) is not None and p.name not in keep:
            p.unlink()
    rejections = Counter(known[k]["reason"] for k in included if known.get(k, {}).get("status") == "rejected")
    scene_rej: Counter[str] = Counter()
    for s in scenes:
        scene_rej.update(s.get("sampling", {}).get("rejections", {}))
    cand_doc = json.loads((out / CANDIDATES_FILE).read_text())
    summary.scenes = len(scenes)
    summary.candidates = len(candidates)
    summary.attempted = len(included)
    summary.episodes = len(episodes)
    summary.frames = sum(e["num_frames"] for e in episodes)
    summary.rejections = dict(sorted(rejections.items()))
    summary.scene_rejections = dict(sorted(scene_rej.items()))
    summary.families = dict(sorted(families.items()))
    successes = sum(1 for e in episodes if e.get("success", True))  # failed recoveries are kept, not counted
    summary.target_reached = not config.target_episodes or successes >= config.target_episodes
    lang_info = dict(cand_doc["info"])
    lang_info["counts"] = {"families": dict(sorted(families.items())), "splits": dict(sorted(splits.items())),
                           "candidates": len(candidates)}
    _write_json(out / SCENES_FILE, {"info": {"version": __version__, "seed": config.seed,
                                             "num_scenes": len(scenes), "license": "CC BY 4.0",
                                             "split_rule": f"every {config.test_every}th scene is test"},
                                    "scenes": scenes})
    _write_json(out / INSTRUCTIONS_FILE, {"info": lang_info, "instructions": instructions})
    info = _base_info(config)
    info.update({
        "status": "complete",
        "counts": {"scenes": len(scenes), "candidates": len(candidates), "attempted": len(included),
                   "episodes": len(episodes), "frames": summary.frames, "families": summary.families,
                   "splits": dict(sorted(splits.items()))},
        "target_reached": summary.target_reached,
        "rejections": {"scenes": summary.scene_rejections, "paths": summary.rejections,
                       "instructions": dict(cand_doc["info"].get("rejections", {}))},
        "seeds": {"base": config.seed, "scenes": [int(s["seed"]) for s in scenes]},
        "render": config.render.to_dict(),
        "episodes": episodes,
    })
    if config.disturbances.enabled:
        # Disturbed episodes by kind and outcome; failed recoveries are in the dataset, counted apart.
        info["counts"]["disturbances"] = {k: dict(sorted(v.items())) for k, v in outcomes.items()}
        info["counts"]["failed_recoveries"] = sum(v["failed"] for v in outcomes.values())
    _write_json(out / INFO_FILE, info, indent=1)


def _marking_end(items: Iterator[Any], marks: list[float]) -> Iterator[Any]:
    """Pass items through; append the time when the last one has been produced."""
    yield from items
    marks.append(time.perf_counter())


def generate_dataset(out: str | Path, config: GenerateConfig, backend: Backend | None = None, resume: bool = False,
                     progress: Progress | None = None) -> GenerateSummary:
    """Generate (or, with ``resume``, finish) a dataset in ``out``.

    Args:
        out: the dataset directory (created; must be new or empty unless resuming).
        config: what to generate.
        backend: where units run (default: in this process).
        resume: continue the dataset in ``out``; its config must equal ``config``.
        progress: progress receiver.

    Returns:
        The summary of the finished dataset.

    Raises:
        DatasetError: ``out`` is not usable, or a file cannot be written (disk full, permissions).
        ConfigError: resuming with a different config.
    """
    out = Path(out)
    # Everything is checked before the first file is written.
    check_cameras(config.render)
    check_scene_config(config.scene)
    with ExitStack() as held:
        existed = out.is_dir()
        if existed:  # an existing folder (a dataset to resume) is locked before it is looked at
            held.enter_context(dataset_lock(out))
        _prepare(out, config, resume)
        if not existed:  # made by _prepare just now
            held.enter_context(dataset_lock(out))
        return _generate(out, config, backend or Backend(), resume, progress or Progress())


def _generate(out: Path, config: GenerateConfig, backend: Backend, resume: bool,
              progress: Progress) -> GenerateSummary:
    summary = GenerateSummary()
    t0 = time.perf_counter()
    if not (out / INFO_FILE).exists():
        _write_json(out / INFO_FILE, _base_info(config), indent=1)
    marks = [time.perf_counter()]
    # Instructions are made in this process while the workers sample the later scenes.
    scene_iter = _scene_stage(out, config, backend, progress, summary)
    scenes, candidates = _instruction_stage(out, config, _marking_end(scene_iter, marks), progress)
    marks.append(time.perf_counter())
    cutoff = _path_stage(out, config, scenes, candidates, backend, progress, summary)
    marks.append(time.perf_counter())
    _finalize(out, config, scenes, candidates, cutoff, summary)
    marks.append(time.perf_counter())
    summary.stage_seconds = {k: round(b - a, 3) for k, a, b in zip(("scenes", "instructions", "paths", "finalize"),
                                                                    marks, marks[1:], strict=False)}
    summary.seconds = time.perf_counter() - t0
    run = {"command": "generate", "argv": sys.argv[1:], "backend": backend.describe(), "resume": resume,
           "seconds": round(summary.seconds, 3), "units_run": summary.units_run,
           "work_seconds": round(summary.work_seconds, 3), "stage_seconds": summary.stage_seconds,
           "cpu_seconds": round(summary.cpu_seconds, 3), "scene_cpu_seconds": round(summary.scene_cpu_seconds, 3),
           "workers": backend.workers, "time": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime())}
    try:
        with open(out / RUNS_FILE, "a", encoding="utf-8") as f:
            f.write(json.dumps(run) + "\n")
    except OSError as exc:
        raise write_error(out / RUNS_FILE, exc, RESUME_HINT) from None
    return summary
