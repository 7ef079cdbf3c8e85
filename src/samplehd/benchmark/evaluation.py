"""Policy evaluation on a fixed, seeded benchmark split of ``samplehd/Tabletop-v0``.

The split is a pure function of (number of episodes, families, seed): episode ``k`` asks for family
``families[k % len(families)]`` and resets the environment with the seed
``SeedSequence([seed, k])``, so every policy meets exactly the same scenes and instructions.

A policy is any callable ``obs -> action``; if it has a ``reset(seed=...)`` method it is called at
the start of every episode. Built in: ``oracle`` (:class:`samplehd.envs.oracle.OraclePolicy`) and
``random`` (uniform samples of the action space), and the learned baselines of :mod:`samplehd.learn`
(``neurosymbolic``, ``bc``; they read trained models from ``models``). ``lerobot:CKPT`` runs a
LeRobot checkpoint as ``lerobot-eval`` would (:mod:`samplehd.benchmark.lerobot_policy`). ``MODULE:CALLABLE`` imports
user code (that is the point of the API); the callable may also be a factory taking the environment
and returning the policy (it is called with the environment when it accepts a keyword ``env``).

With a ``level`` (L1–L4, :mod:`samplehd.benchmark.levels`) episode ``k`` is the first episode of its
family in that generalisation level among reset seeds derived from the split's seed for ``k``.

With a ``suite`` (a shipped suite's name or a suite file, :mod:`samplehd.envs.suite_file`) nothing is
drawn: episode ``k`` is the suite's episode ``k``, reset through the environment option
``{"suite": ..., "episode": k}`` that any Gymnasium user has, and the report names the suite and its
content hash.
"""

from __future__ import annotations

import importlib
import inspect
import json
import re
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from samplehd.benchmark.lerobot_policy import LeRobotPolicy, is_lerobot_policy
from samplehd.benchmark.levels import LEVELS, reset_at_level
from samplehd.benchmark.report_files import with_statistics, write_report_with_statistics
from samplehd.benchmark.sensor import corrupt_observation, sensor_rng
from samplehd.catalogue.loader import catalogue_for
from samplehd.envs.config import EnvConfig
from samplehd.envs.oracle import OraclePolicy
from samplehd.envs.suite_file import Suite, SuiteEpisode, read_suite
from samplehd.envs.tabletop import TabletopEnv
from samplehd.errors import ConfigError, PlanningError, require_extra
from samplehd.record.paths import PathConfig, plan_and_execute
from samplehd.render.video import write_mp4
from samplehd.scene.spec import compile_scene
from samplehd.schema import Config, bounded
from samplehd.tasks.task import Task, family_names, parse_task
from samplehd.workers import Backend

__all__ = ["DrawnSplit", "EpisodeRecord", "EpisodeRunner", "EvalConfig", "EvalReport", "GroupSummary", "RandomPolicy",
           "SuiteSplit", "benchmark_split", "check_policy_action", "evaluate", "load_policy", "load_policy_module",
           "split_episode"]

# SAMPLE-HD's families plus the two simple new ones: the default benchmark. stack_three needs scenes
# with three stackable objects (see the env's ``scene`` option) and is opt-in.
DEFAULT_FAMILIES = ("place", "remove", "stack", "put", "pick_up", "place_relative")
# Learned baselines: name -> "module:factory(env, EvalConfig)".
LEARNED = {"neurosymbolic": "samplehd.learn.neurosymbolic:policy_for_evaluation",
           "bc": "samplehd.learn.policy.inference:policy_for_evaluation"}
BUILT_IN = ("oracle", "random", *LEARNED)
_POLICY_SPEC = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*(\.[A-Za-z_][A-Za-z0-9_]*)*:[A-Za-z_][A-Za-z0-9_]*$")


@dataclass(frozen=True)
class EvalConfig(Config, section="EvalConfig"):
    """What an evaluation run does.

    Attributes:
        policy: ``oracle``, ``random``, ``neurosymbolic``, ``bc``, ``lerobot:CKPT`` or ``MODULE:CALLABLE``.
        episodes: number of episodes of the split.
        families: families of the split, in rotation.
        seed: seed of the split.
        env: the environment's options (an EnvConfig, or a dict of its fields).
        video_dir: write one MP4 per episode here (None: no videos).
        workers: processes running episodes in parallel.
        compare_offline: also run the offline ground-truth path generator (one attempt) on every
            episode and record whether it succeeds (the oracle's reference).
        models: folder of trained models (``neurosymbolic``: parser/ and perception/; ``bc``: the
            policy's folder).
        programs: ``neurosymbolic``: ``predicted`` or ``gt`` programs.
        perception: ``neurosymbolic``: ``predicted`` or ``gt`` scene annotations.
        level: generalisation level L1–L4, or None (the plain split).
        suite: a shipped suite's name or a suite file: run every episode of it instead of a drawn
            split (``episodes``, ``families``, ``seed`` and ``level`` are then not used).
    """

    policy: str = "oracle"
    episodes: int = bounded(10, lo=1)
    families: tuple[str, ...] = bounded(DEFAULT_FAMILIES, choices=family_names, nonempty=True)
    seed: int = bounded(0, lo=0)
    env: EnvConfig = field(default_factory=EnvConfig)
    video_dir: str | None = None
    workers: int = bounded(1, lo=1)
    compare_offline: bool = False
    models: str | None = None
    programs: str = bounded("predicted", choices=("gt", "predicted"))
    perception: str = bounded("predicted", choices=("gt", "predicted"))
    level: str | None = bounded(None, choices=LEVELS)
    suite: str | None = None

    def __post_init__(self) -> None:
        super().__post_init__()
        if self.suite is not None and self.level is not None:
            raise ConfigError(f"EvalConfig.level={self.level!r}: a suite fixes each episode's level; leave level out "
                              "with suite")
        check_policy_spec(self.policy, where="EvalConfig.")
        if self.policy == "bc" and not self.models:
            raise ConfigError("EvalConfig.policy='bc': needs `models` (the folder of `samplehd train policy`)")


@dataclass(frozen=True)
class EpisodeRecord:
    """What one benchmark episode did: the result of its work unit, an item of the report's ``records``
    (:meth:`to_dict`; the optional entries only where they apply).

    Attributes:
        index: the episode's index in the split.
        seed: the reset seed used (with a level: the first seed of that level).
        family: the family of the instruction the episode got.
        requested_family: the family the split asked for.
        instruction: the instruction's text.
        task: the task the instruction asks for (``info["task"]``; written as the executor's
            ``{type, objects, subject, relation}``).
        success: the shared checker's verdict at the end.
        steps: control steps taken.
        episode_return: sum of the rewards (``return`` in the report).
        terminated: the episode ended (success, failure or a safety stop).
        truncated: the step limit ended it.
        safety_events: kinds of the safety events of the last step's info.
        check_reason: the checker's reason.
        wall_s: wall time of the episode [s].
        gave_up: why the policy gave up (oracle: a planning error), or None.
        level: the generalisation level of the split, or None.
        diagnosis: a learned policy's diagnosis of its stages, or None.
        failure_stage: the stage a failed episode is charged to (with a diagnosis), or None.
        replans: the oracle's replans, or None.
        offline_success: whether the offline path generator solved the episode (``compare_offline``).
        video: the episode's MP4, or None.
        disturbed: the scene objects the task does not name that the episode moved or turned beyond the
            checker's tolerances (``disturb_distance``, ``disturb_angle``), at its end.
        axis: a suite episode's robustness axis (``none``: clean), or None outside a suite.
        strength: a suite episode's axis strength 0–5, or None.
        twin: a suite episode's clean twin (its index), or None.
    """

    index: int
    seed: int
    family: str
    requested_family: str
    instruction: str
    task: Task
    success: bool
    steps: int
    episode_return: float
    terminated: bool
    truncated: bool
    safety_events: tuple[str, ...]
    check_reason: str
    wall_s: float
    gave_up: str | None = None
    level: str | None = None
    diagnosis: dict[str, Any] | None = None
    failure_stage: str | None = None
    replans: int | None = None
    offline_success: bool | None = None
    video: str | None = None
    disturbed: tuple[int, ...] = ()
    axis: str | None = None
    strength: int | None = None
    twin: int | None = None

    def to_dict(self) -> dict[str, object]:
        """The report's record: keys in this order, ``return`` for :attr:`episode_return`, optional
        entries only where set."""
        d: dict[str, Any] = {
            "index": self.index, "seed": self.seed, "family": self.family, "requested_family": self.requested_family,
            "instruction": self.instruction, "task": self.task.to_program_dict(), "success": self.success,
            "steps": self.steps, "return": self.episode_return, "terminated": self.terminated,
            "truncated": self.truncated, "safety_events": list(self.safety_events),
            "check_reason": self.check_reason, "wall_s": self.wall_s, "disturbed": list(self.disturbed)}
        for name in ("gave_up", "level", "diagnosis", "failure_stage", "replans", "offline_success", "video", "axis",
                     "strength", "twin"):
            if getattr(self, name) is not None:
                d[name] = getattr(self, name)
        return d


def check_policy_spec(spec: str, where: str = "") -> None:
    """Raise ConfigError unless ``spec`` is a built-in policy, ``lerobot:CKPT`` or ``MODULE:CALLABLE``.
    ``where``: what the message's subject ``policy`` is prefixed with (``EvalConfig.``; nothing: a
    ``policy`` parameter)."""
    if isinstance(spec, str) and (spec in BUILT_IN or is_lerobot_policy(spec) or _POLICY_SPEC.match(spec)):
        return
    raise ConfigError(f"{where}policy={spec!r}: expected {', '.join(BUILT_IN)}, lerobot:CKPT or MODULE:CALLABLE "
                      "(e.g. mypkg.agents:act)", field=None if where else "policy")


def split_episode(k: int, families: Sequence[str], seed: int) -> tuple[int, str]:
    """(reset seed, family) of episode ``k`` of the split made from ``seed``."""
    return int(np.random.SeedSequence([int(seed), int(k)]).generate_state(1, np.uint32)[0]), families[k % len(families)]


def benchmark_split(episodes: int, families: Sequence[str], seed: int) -> list[tuple[int, str]]:
    """(reset seed, family) of each episode of the split."""
    return [split_episode(k, families, seed) for k in range(episodes)]


class RandomPolicy:
    """Uniform samples of an action space (the success floor)."""
    def __init__(self, action_space: Any, seed: int = 0) -> None:
        self.action_space = action_space
        self.action_space.seed(seed)

    def reset(self, seed: int | None = None) -> None:
        if seed is not None:
            self.action_space.seed(seed)

    def __call__(self, obs: Any) -> np.ndarray:
        return self.action_space.sample()


def load_policy_module(spec: str) -> Any:
    """Import a ``MODULE:CALLABLE`` policy's callable (None for built-in policies), so a bad policy is
    refused before anything runs.

    Raises:
        ConfigError: the spec is malformed, the module cannot be imported or has no such callable.
    """
    check_policy_spec(spec)
    if spec in BUILT_IN or is_lerobot_policy(spec):
        return None
    module_name, attr = spec.split(":")
    try:
        module = importlib.import_module(module_name)
    except ImportError as exc:
        raise ConfigError(f"policy={spec!r}: cannot import module {module_name!r} ({exc})", field="policy") from None
    obj = getattr(module, attr, None)
    if obj is None or not callable(obj):
        raise ConfigError(f"policy={spec!r}: module {module_name!r} has no callable {attr!r}", field="policy")
    return obj


def load_policy(spec: str, env: Any, config: EvalConfig | None = None) -> Callable[[Any], Any]:
    """Build the policy named by ``spec`` for ``env``; see the module docstring."""
    check_policy_spec(spec)
    if spec in LEARNED:

        require_extra("torch", "learn", f"the {spec} policy")
        # The learned baselines live on a floor above the environments: named by module path, as
        # user policies are, and imported only when asked for.
        module_name, attr = LEARNED[spec].split(":")
        factory = getattr(importlib.import_module(module_name), attr)
        return factory(env, config or EvalConfig(policy=spec))
    if spec == "oracle":
        return OraclePolicy(env)
    if spec == "random":
        return RandomPolicy(env.action_space)
    if is_lerobot_policy(spec):
        return LeRobotPolicy.load(spec, env)
    obj = load_policy_module(spec)
    try:
        params = inspect.signature(obj).parameters
    except (TypeError, ValueError):
        params = {}
    if "env" in params:
        obj = obj(env=env)
        if not callable(obj):
            raise ConfigError(f"policy={spec!r}: the factory did not return a callable policy", field="policy")
    return obj


def check_policy_action(spec: str, action: Any, space: Any) -> np.ndarray:
    """The policy's action as an array, or a one-line error saying what it returned and what is expected.

    Raises:
        ConfigError: ``policy returned …; expected …`` (not a real array of the action shape, or NaN).
    """
    expected = f"expected {space.shape[0]} finite numbers (a sequence or numpy array) for this control mode"
    try:
        a = np.asarray(action)
    except Exception:  # noqa: BLE001 - any object can be returned
        a = np.asarray(None)
    if a.dtype.kind not in "biuf" or a.shape != space.shape or not np.all(np.isfinite(a)):
        text = repr(action)
        text = text if len(text) <= 60 else text[:57] + "..."
        raise ConfigError(f"policy={spec!r}: policy returned {text} ({type(action).__name__}); {expected}",
                          field="policy")
    return a.astype(float)


def _offline_success(env: Any, seed: int) -> bool:
    ep = env.unwrapped.episode
    try:
        plan_and_execute(ep.scene, ep.instruction["task"], np.random.default_rng(seed), PathConfig(max_attempts=1),
                         family=ep.family, directions=ep.annotation.get("directions"),
                         compiled=compile_scene(ep.scene))
    except PlanningError:
        return False
    return True


def _with_slots_for(config: EvalConfig, suite: Suite) -> EvalConfig:
    """``config`` with an observation slot for every object of the suite's fullest scene (a
    ``distractors`` variant holds up to five objects more than the scenes the env samples); a config
    with room enough is returned as it is."""
    scene = config.env.scene
    need = max((len(e.scene.get("objects", ())) for e in suite.episodes), default=0)
    if need <= scene.max_objects:
        return config
    return replace(config, env=replace(config.env, scene=replace(scene, max_objects=need)))


class EpisodeRunner:
    """One environment and policy that run benchmark episodes one at a time (the suite builder's oracle
    runs through it too)."""
    def __init__(self, config: EvalConfig) -> None:
        # A worker imports this module through the samplehd package, which sets the GL backend first.

        self.config = config
        env = replace(config.env, render_mode="rgb_array") if config.video_dir else config.env
        self.env = TabletopEnv(**env.to_dict())
        self.policy = load_policy(config.policy, self.env, config)

    def close(self) -> None:
        if hasattr(self.policy, "close"):
            self.policy.close()
        self.env.close()

    def run(self, item: tuple[int, int, str], options: dict[str, Any] | None = None) -> EpisodeRecord:
        """Run episode ``(index, seed, family)`` and return its record; with ``options``, reset with these
        instead (``scene`` + ``instruction``: a given episode)."""
        index, seed, family = item
        config, env, policy = self.config, self.env, self.policy
        t0 = time.perf_counter()
        suite_episode: SuiteEpisode | None = None
        if options is not None:
            obs, info = env.reset(seed=seed, options=options)
        elif config.suite is not None:
            suite_episode = read_suite(config.suite).episode(index)
            obs, info = env.reset(seed=seed, options={"suite": config.suite, "episode": index})
        else:
            obs, info, seed = reset_at_level(env, seed, family, config.level)
        sensor = suite_episode.sensor if suite_episode is not None else None
        noise = sensor_rng(seed)
        obs = corrupt_observation(obs, sensor, noise) if sensor else obs
        if hasattr(policy, "reset"):
            policy.reset(seed=seed)
        frames = [env.render()] if config.video_dir else []
        steps, ret, term, trunc = 0, 0.0, False, False
        gave_up = ""
        while not (term or trunc):
            try:
                action = policy(obs)
            except PlanningError as exc:  # the oracle could not go on: a failed episode, not a failed run
                gave_up = f"{type(exc).__name__}: {exc}"
                break
            obs, reward, term, trunc, info = env.step(check_policy_action(config.policy, action, env.action_space))
            if sensor:
                obs = corrupt_observation(obs, sensor, noise)
            steps += 1
            ret += reward
            if config.video_dir:
                frames.append(env.render())
            if getattr(policy, "gave_up", False):
                gave_up = str(getattr(policy, "failure", "gave up"))
                break
        success = bool(info["success"])
        disturbed = tuple(int(i) for i in env.unwrapped.check_success()["disturbed"])
        diagnosis = dict(policy.diagnosis) if getattr(policy, "diagnosis", None) else None
        record = EpisodeRecord(
            index=index, seed=seed, family=info["family"], requested_family=family,
            instruction=info["instruction"], task=parse_task(info["task"], info["family"]), success=success,
            steps=steps, episode_return=ret,
            terminated=term, truncated=trunc, safety_events=tuple(e["kind"] for e in info["safety_events"]),
            check_reason=info["check_reason"], wall_s=round(time.perf_counter() - t0, 3),
            gave_up=gave_up or None, level=suite_episode.level if suite_episode else config.level, diagnosis=diagnosis,
            failure_stage=diagnosis.get("stage", "motion") if diagnosis is not None and not success else None,
            replans=int(policy.replans) if hasattr(policy, "replans") else None,
            offline_success=_offline_success(env, seed) if config.compare_offline else None, disturbed=disturbed,
            axis=suite_episode.axis if suite_episode else None,
            strength=suite_episode.strength if suite_episode else None,
            twin=suite_episode.twin if suite_episode else None)
        if config.video_dir and frames and frames[0] is not None:
            out = Path(config.video_dir)
            out.mkdir(parents=True, exist_ok=True)
            name = f"episode_{index:04d}_{record.family}_{'ok' if success else 'fail'}.mp4"
            write_mp4(out / name, np.stack(frames), env.metadata["render_fps"])
            record = replace(record, video=str(out / name))
        return record


_WORKER: dict[str, tuple[EvalConfig, EpisodeRunner]] = {}


def _run_in_worker(item: tuple[EvalConfig, int, int, str]) -> EpisodeRecord:
    """One episode in a worker process; the worker keeps its runner (and environment) between units."""
    config, *episode = item
    held = _WORKER.get("runner")
    if held is None or held[0] != config:
        if held is not None:
            held[1].close()
        _WORKER["runner"] = held = (config, EpisodeRunner(config))
    return held[1].run(tuple(episode))  # type: ignore[arg-type]


@dataclass(frozen=True)
class GroupSummary:
    """The figures of a group of records (the whole run, a family, a level, an axis strength).

    Attributes:
        episodes: records in the group.
        successes: successful ones.
        success_rate: ``successes / episodes`` (0 for an empty group).
        successes_undisturbed: successes that moved no object the task does not name.
        successes_after_retry: successes a learned policy reached after retrying (its diagnosis counts
            ``retries``).
        safety_stops: records with a safety event.
        mean_steps: mean control steps per episode.
        failures_by_stage: failed episodes per stage they are charged to (learned policies; empty: none).
        offline_success_rate: share the offline path generator solved, or None (no ``compare_offline``).
        success_rate_where_offline_succeeds: the success rate among those, or None (none solved, or no
            ``compare_offline``).
    """

    episodes: int
    successes: int
    success_rate: float
    successes_undisturbed: int
    successes_after_retry: int
    safety_stops: int
    mean_steps: float
    failures_by_stage: dict[str, int] = field(default_factory=dict)
    offline_success_rate: float | None = None
    success_rate_where_offline_succeeds: float | None = None

    @classmethod
    def of(cls, records: Sequence[EpisodeRecord]) -> GroupSummary:
        """The summary of ``records``: the one place a group's figures are made, so an interval on each
        success rate belongs here."""
        n = len(records)
        ok = sum(r.success for r in records)
        offline = where_offline = None
        if records and records[0].offline_success is not None:
            feasible = [r for r in records if r.offline_success]
            offline = len(feasible) / n
            where_offline = sum(r.success for r in feasible) / len(feasible) if feasible else None
        stages = [r.failure_stage for r in records if r.failure_stage is not None]
        return cls(episodes=n, successes=ok, success_rate=ok / n if n else 0.0,
                   successes_undisturbed=sum(r.success and not r.disturbed for r in records),
                   successes_after_retry=sum(r.success and bool((r.diagnosis or {}).get("retries"))
                                             for r in records),
                   safety_stops=sum(bool(r.safety_events) for r in records),
                   mean_steps=float(np.mean([r.steps for r in records])) if records else 0.0,
                   failures_by_stage={s: stages.count(s) for s in sorted(set(stages))},
                   offline_success_rate=offline, success_rate_where_offline_succeeds=where_offline)

    def to_dict(self) -> dict[str, object]:
        """The report's entry: the offline rates only with ``compare_offline``, the stages only when any."""
        d: dict[str, object] = {"episodes": self.episodes, "successes": self.successes,
                                "success_rate": self.success_rate}
        if self.offline_success_rate is not None:
            d["offline_success_rate"] = self.offline_success_rate
            d["success_rate_where_offline_succeeds"] = self.success_rate_where_offline_succeeds
        d["successes_undisturbed"] = self.successes_undisturbed
        d["successes_after_retry"] = self.successes_after_retry
        d["safety_stops"] = self.safety_stops
        if self.failures_by_stage:
            d["failures_by_stage"] = dict(self.failures_by_stage)
        d["mean_steps"] = self.mean_steps
        return d


@dataclass(frozen=True)
class DrawnSplit:
    """A split drawn from a seed (no suite).

    Attributes:
        episodes: its episodes.
        families: its families, in rotation.
        seed: its seed.
        level: its generalisation level, or None.
    """

    episodes: int
    families: tuple[str, ...]
    seed: int
    level: str | None

    def to_dict(self) -> dict[str, object]:
        return {"episodes": self.episodes, "families": list(self.families), "seed": self.seed, "level": self.level}


@dataclass(frozen=True)
class SuiteSplit:
    """A suite's episodes.

    Attributes:
        suite: the suite's name.
        content_hash: its content hash.
        episodes: its episodes.
        package_version: the samplehd version that built it.
    """

    suite: str
    content_hash: str
    episodes: int
    package_version: str

    def to_dict(self) -> dict[str, object]:
        return {"suite": self.suite, "content_hash": self.content_hash, "episodes": self.episodes,
                "package_version": self.package_version}


@dataclass(frozen=True)
class EvalReport:
    """What an evaluation run did: the JSON report (:meth:`to_dict`, keys in this order).

    Attributes:
        policy: the policy spec.
        partial: written while the run goes on (an interrupted run keeps what it finished).
        split: the split run.
        models: the models folder, or None.
        programs: ``neurosymbolic``'s programs setting, else None.
        perception: ``neurosymbolic``'s perception setting, else None.
        env: the environment's options.
        catalogue: content hashes of the catalogue in use (:meth:`samplehd.catalogue.model.Catalogue.record`).
        overall: the whole run's figures (written at the top level of the report).
        by_family: figures per family, in the order families first occur.
        by_level: a suite's figures per level (None outside a suite).
        by_axis: a suite's figures per axis and strength (None outside a suite).
        wall_s: wall time of the run so far [s].
        records: one per episode, by index.
        statistics: every rate with its 95 % interval (:func:`samplehd.benchmark.statistics.summarize`),
            once the run is complete; None before.
    """

    policy: str
    partial: bool
    split: DrawnSplit | SuiteSplit
    models: str | None
    programs: str | None
    perception: str | None
    env: EnvConfig
    catalogue: dict[str, object]
    overall: GroupSummary
    by_family: dict[str, GroupSummary]
    by_level: dict[str, GroupSummary] | None
    by_axis: dict[str, dict[str, GroupSummary]] | None
    wall_s: float
    records: tuple[EpisodeRecord, ...]
    statistics: dict[str, Any] | None = None

    @property
    def success_rate(self) -> float:
        """The whole run's success rate."""
        return self.overall.success_rate

    def to_dict(self) -> dict[str, object]:
        """The report as written to its JSON file."""
        d: dict[str, Any] = {
            "policy": self.policy, "partial": self.partial, "split": self.split.to_dict(), "models": self.models,
            "programs": self.programs, "perception": self.perception, "env": self.env.to_dict(),
            "catalogue": self.catalogue, **self.overall.to_dict(),
            "by_family": {k: v.to_dict() for k, v in self.by_family.items()}}
        if self.by_level is not None:
            d["by_level"] = {k: v.to_dict() for k, v in self.by_level.items()}
        if self.by_axis is not None:
            d["by_axis"] = {ax: {st: v.to_dict() for st, v in by.items()} for ax, by in self.by_axis.items()}
        d["wall_s"] = self.wall_s
        if self.statistics is not None:
            d["statistics"] = self.statistics
        d["records"] = [r.to_dict() for r in self.records]
        return d


def evaluate(config: EvalConfig, out: str | Path | None = None,
             progress: Callable[[EpisodeRecord], None] | None = None) -> EvalReport:
    """Run a policy on the benchmark split and return (and optionally write, with its tables beside it) the
    report.

    The JSON report (:meth:`EvalReport.to_dict`) holds ``policy``, ``split`` (episodes, families, seed),
    ``env`` (options), ``success_rate`` and the run's other figures, ``by_family`` (per family:
    episodes, successes, success_rate, ...), ``catalogue`` (content hashes of the catalogue in use),
    ``wall_s``, ``statistics`` (every rate with its 95 % interval:
    :func:`samplehd.benchmark.statistics.summarize`) and ``records`` (one per episode: index, seed,
    family, instruction, task, success, steps, return, terminated, truncated, safety_events,
    check_reason, wall_s, and for the oracle replans / gave_up / offline_success).
    """
    if config.suite is not None:
        suite: Suite | None = read_suite(config.suite)
        items = [(e.id, e.reset_seed, e.family) for e in suite.episodes]
        config = _with_slots_for(config, suite)
    else:
        suite = None
        items = [(k, s, f) for k, (s, f) in enumerate(benchmark_split(config.episodes, config.families, config.seed))]
    t0 = time.perf_counter()
    records: list[EpisodeRecord] = []

    def done(record: EpisodeRecord) -> None:
        records.append(record)
        if progress is not None:
            progress(record)
        if out is not None:  # partial report, so an interrupted run keeps what it finished
            _write_report(out, _report(config, records, t0, suite, partial=True))

    if config.workers == 1:
        runner = EpisodeRunner(config)
        try:
            for item in items:
                done(runner.run(item))
        finally:
            runner.close()
    else:
        one = replace(config, workers=1)
        for _, record in Backend(workers=config.workers).map(_run_in_worker, ((one, *item) for item in items)):
            done(record)
    report = _report(config, records, t0, suite)
    full = write_report_with_statistics(report.to_dict(), out) if out is not None else with_statistics(
        report.to_dict())
    return replace(report, statistics=full["statistics"])


def _write_report(out: str | Path, report: EvalReport) -> None:
    path = Path(out)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(path.suffix + ".tmp")
    tmp.write_text(json.dumps(report.to_dict(), indent=1) + "\n", encoding="utf-8")
    tmp.replace(path)


def _report(config: EvalConfig, records: list[EpisodeRecord], t0: float, suite: Suite | None = None,
            partial: bool = False) -> EvalReport:
    records = sorted(records, key=lambda r: r.index)
    by_family = {fam: GroupSummary.of([r for r in records if r.family == fam])
                 for fam in dict.fromkeys(r.family for r in records)}
    env = config.env
    split: DrawnSplit | SuiteSplit
    if suite is not None:
        split = SuiteSplit(suite=suite.name, content_hash=suite.content_hash, episodes=len(suite.episodes),
                           package_version=suite.package_version)
        by_level: dict[str, GroupSummary] | None = {
            lv: GroupSummary.of([r for r in records if r.level == lv])
            for lv in sorted({r.level for r in records if r.level})}
        by_axis: dict[str, dict[str, GroupSummary]] | None = {
            ax: {str(st): GroupSummary.of([r for r in records if r.axis == ax and r.strength == st])
                 for st in sorted({r.strength for r in records if r.axis == ax})}  # type: ignore[type-var]
            for ax in sorted({r.axis for r in records if r.axis})}  # type: ignore[type-var]
    else:
        split = DrawnSplit(episodes=config.episodes, families=tuple(config.families), seed=config.seed,
                           level=config.level)
        by_level = by_axis = None
    neurosymbolic = config.policy == "neurosymbolic"
    return EvalReport(
        policy=config.policy, partial=partial, split=split, models=config.models,
        programs=config.programs if neurosymbolic else None, perception=config.perception if neurosymbolic else None,
        env=env,
        # The split's scenes draw from the built-in catalogue plus imported classes the env options name.
        catalogue=catalogue_for(env.scene.named_classes, env.scene.catalogue).record(),
        overall=GroupSummary.of(records), by_family=by_family, by_level=by_level, by_axis=by_axis,
        wall_s=round(time.perf_counter() - t0, 2), records=tuple(records))
