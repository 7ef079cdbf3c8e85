"""Build a benchmark suite: episodes drawn once, each proven solvable by the closed-loop oracle, frozen
into a hashed file (:mod:`samplehd.envs.suite_file`) that evaluation reads instead of drawing.

The suite is a grid of cells (catalogue × family × level), ``episodes_per_cell`` episodes each. Cell
``c``'s candidate ``k`` is the first episode of its family and level on the scenes sampled from the
seeds ``SeedSequence([seed, k, a])``, ``a`` = 0, 1, ... (:func:`samplehd.benchmark.levels.instruction_at_level`:
several instructions of the family are drawn per scene before the next scene is sampled). Candidate
``k`` of every cell of a catalogue draws from the same scenes, so the cells share scenes (each
episode is still one scene and one instruction; a cell's episodes are on different scenes), and one
work unit, a *column*, proves candidate ``k`` of all the catalogue's cells that want one, sampling
each scene once. The oracle (:class:`samplehd.envs.oracle.OraclePolicy`) acts through
``TabletopEnv.step`` from the reset ``samplehd evaluate --suite`` makes (the scene and instruction as
options, the scene seed as the reset seed) until the episode ends
(:class:`~samplehd.benchmark.evaluation.EpisodeRunner`). A candidate the oracle fails is rejected, its
reason counted in the manifest, and the next candidate of the cell is tried.

Each cell tries its candidates in rounds, on one pool of the worker backend (local processes or
Ray): its first round tries two candidates, and a cell neither of which found an episode of its family
and level is given up (``short_cells`` says why); each later round tries as many new candidates as the
cell still lacks episodes, from the third round on that many divided by the share of the cell's
candidates so far that were solved (at most twice as many), so that a cell whose draws often fail
needs fewer rounds. A cell's next round is asked as soon as its own last candidate is in, not when
every cell's is, and the cells whose rounds are asked together share columns; a later round starts
before an earlier one, so the cells that need many rounds are not left to the end. A candidate's
outcome depends only on the configuration, its cell and ``k``, and the cell's episodes are always its
first ``episodes_per_cell`` solved candidates in candidate order (those solved beyond them are counted
as ``spare``), whatever the number of workers and the order candidates finish in: the same
configuration gives the same bytes.

A suite may instead derive from a built *base* suite (``base``, ``base_per_cell``): it takes the first
``base_per_cell`` clean episodes of each of the base's cells (after its first ``base_skip``: a
validation suite disjoint from a test suite of the same base), in suite order, as they are (the base's
oracle proof stands; only their ids are renumbered), and makes their axes' variants as above, the
physical ones proven in the base's env with the base's scene options. Nothing is drawn, so the
drawing options belong to the base's build and may not be given. This is how a large robustness suite
(``plus``) ships as a specification and is built lazily, an axis or a few at a time: a variant depends
only on the seed, its axis and strength, its attempt and its twin (whose id does not depend on the
axes built), so a build of some axes holds the same variants as a build of all, renumbered.
"""

from __future__ import annotations

import json
import re
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass, field, is_dataclass, replace
from typing import Any

import numpy as np

from samplehd.benchmark.axes import AXES, PHYSICAL_AXES, STRENGTHS, perturb
from samplehd.benchmark.evaluation import DEFAULT_FAMILIES, EpisodeRecord, EpisodeRunner, EvalConfig
from samplehd.benchmark.levels import LEVELS, episode_level, instruction_at_level
from samplehd.catalogue.loader import CATALOGUES as BUILT_IN_CATALOGUES
from samplehd.catalogue.loader import DEFAULT_CATALOGUE
from samplehd.envs.config import EnvConfig
from samplehd.envs.suite_file import (
    CLEAN_AXIS,
    Suite,
    SuiteEpisode,
    content_hash,
    read_suite,
    shipped_suites,
    suite_path,
)
from samplehd.errors import ConfigError, SamplehdError, SceneError
from samplehd.scene.config import SceneConfig
from samplehd.schema import Config, bounded, to_mapping
from samplehd.tasks.task import family_names
from samplehd.version import __version__
from samplehd.workers import Backend, Feed

__all__ = ["SELECTION", "Candidate", "SuiteBuildConfig", "build_suite", "read_base", "rejection_reason", "same_episode",
           "scene_seeds"]

CATALOGUES = tuple(BUILT_IN_CATALOGUES)
_NUMBER = re.compile(r"[0-9]+(\.[0-9]+)?")
# The options that draw and prove clean episodes: a suite built from a base has the base's.
_DRAWING = ("families", "levels", "catalogues", "episodes_per_cell", "max_candidates_per_cell",
            "max_scenes_per_candidate", "instruction_rounds", "env", "family_scene", "family_max_scenes")
# Of those, the ones a physical variant is proven with (the env and its scenes' options).
_PROOF = ("env", "family_scene", "family_max_scenes", "max_scenes_per_candidate")
# The options of a suite built from a base (left out of the build record of one that is not).
# Beside a base, the options that select its cells (catalogue, family, level; None: all of them).
SELECTION = ("base_catalogues", "base_families", "base_levels")
_BASE = ("base", "base_per_cell", "base_skip", *SELECTION)


@dataclass(frozen=True)
class SuiteBuildConfig(Config, section="suite"):
    """What ``samplehd suite build`` makes.

    Attributes:
        seed: seed of every candidate's reset.
        families: task families, one cell each (per catalogue and level).
        levels: generalisation levels L1–L4, one cell each.
        catalogues: built-in catalogues (``procedural``, ``shop-vrb``), one cell each.
        episodes_per_cell: episodes each cell gets.
        max_candidates_per_cell: candidates a cell may try before the build gives up on it (the
            manifest lists such cells under ``short_cells``).
        max_scenes_per_candidate: scenes a candidate may sample looking for an episode of its family
            and level before it is rejected (``draw: ...``).
        instruction_rounds: rounds of instruction draws on a scene before the next scene is sampled
            (:func:`samplehd.benchmark.levels.instruction_at_level`).
        env: the environment the oracle proves the episodes in (its ``scene.catalogue`` is set per cell).
        family_scene: per family, scene options (:class:`samplehd.scene.config.SceneConfig` keys) its
            cells' scenes are sampled with instead of ``env.scene``'s, e.g. ``{"stack_three":
            {"min_objects": 5, "max_objects": 7}}``: three objects that stack are rare among 3–5.
        family_max_scenes: per family, scenes a candidate may sample instead of
            ``max_scenes_per_candidate``, e.g. ``{"stack_three": 160}``: a scene holding a stack of
            three is rare even among 5–7 objects.
        axes: robustness axes (:mod:`samplehd.benchmark.axes`); each clean episode gets a variant per
            axis and strength, its clean twin being the episode itself (strength 0).
        strengths: the strengths of each axis (1–5).
        max_attempts_per_variant: directions a physical axis' variant may try before the build leaves
            it out (the manifest lists it under ``short_variants``).
        base: a built suite (a shipped suite's name or a file) whose clean episodes this suite takes as
            they are, instead of drawing and proving its own; the drawing options above (families to
            family_max_scenes) are the base's and may not be given.
        base_per_cell: with ``base``: the first N clean episodes of each of the base's cells (catalogue ×
            family × level), in suite order; None: all of them.
        base_skip: with ``base``: the first N clean episodes of each cell are passed over before
            ``base_per_cell`` are taken (0: none), e.g. the episodes a test suite of the first 10 per
            cell leaves, to tune a policy's rules on without touching them.
        base_catalogues, base_families, base_levels: with ``base``: only the base's cells of these
            catalogues, families and levels (None: all of the base's), e.g. a smaller suite of one
            catalogue's L1 episodes to evaluate a policy on.
    """

    seed: int = bounded(0, lo=0)
    families: tuple[str, ...] = bounded(DEFAULT_FAMILIES, choices=family_names, nonempty=True)
    levels: tuple[str, ...] = bounded(("L1",), choices=LEVELS, nonempty=True)
    catalogues: tuple[str, ...] = bounded((DEFAULT_CATALOGUE,), choices=CATALOGUES, nonempty=True)
    episodes_per_cell: int = bounded(1, lo=1)
    max_candidates_per_cell: int = bounded(20, lo=1)
    max_scenes_per_candidate: int = bounded(40, lo=1)
    instruction_rounds: int = bounded(1, lo=1)
    env: EnvConfig = field(default_factory=EnvConfig)
    family_scene: dict[str, dict[str, Any]] | None = None
    family_max_scenes: dict[str, int] | None = None
    axes: tuple[str, ...] = bounded((), choices=tuple(AXES), unique=True)
    strengths: tuple[int, ...] = bounded(STRENGTHS, lo=min(STRENGTHS), hi=max(STRENGTHS), unique=True, nonempty=True)
    max_attempts_per_variant: int = bounded(4, lo=1)
    base: str | None = None
    base_per_cell: int | None = bounded(None, lo=1)
    base_skip: int = bounded(0, lo=0)
    base_catalogues: tuple[str, ...] | None = bounded(None, choices=CATALOGUES, nonempty=True, unique=True)
    base_families: tuple[str, ...] | None = bounded(None, choices=family_names, nonempty=True, unique=True)
    base_levels: tuple[str, ...] | None = bounded(None, choices=LEVELS, nonempty=True, unique=True)

    def __post_init__(self) -> None:
        super().__post_init__()
        self._check_base()
        for family, options in (self.family_scene or {}).items():
            where = f"suite.family_scene.{family}"
            if family not in family_names():
                raise ConfigError(f"{where}: unknown family {family!r}; valid: {', '.join(family_names())}",
                                  field="family_scene")
            if not isinstance(options, dict) or "catalogue" in options:
                raise ConfigError(f"{where}={options!r}: must be a JSON object of scene options other than "
                                  "'catalogue' (each cell sets its own)", field="family_scene")
            try:
                SceneConfig.from_dict({**self.env.scene.to_dict(), **options}, where=where)
            except ConfigError as exc:  # a rule across fields names the scene section only
                if str(exc).startswith(where):
                    raise
                raise ConfigError(f"{where}: {exc}", field="family_scene") from None

        for family, count in (self.family_max_scenes or {}).items():
            where = f"suite.family_max_scenes.{family}"
            if family not in family_names():
                raise ConfigError(f"{where}: unknown family {family!r}; valid: {', '.join(family_names())}",
                                  field="family_max_scenes")
            if isinstance(count, bool) or not isinstance(count, int) or count < 1:
                raise ConfigError(f"{where}={count!r}: must be an integer ≥ 1 (scenes per candidate)",
                                  field="family_max_scenes")

    def _check_base(self) -> None:
        """A base goes without the drawing options; ``base_per_cell`` goes with a base."""
        if self.base is None:
            if self.base_per_cell is not None:
                raise ConfigError(f"suite.base_per_cell={self.base_per_cell}: counts the clean episodes taken per "
                                  "cell from suite.base; name the base (a built suite's name or file) or leave it "
                                  "out", field="base_per_cell")
            if self.base_skip:
                raise ConfigError(f"suite.base_skip={self.base_skip}: counts the clean episodes passed over per "
                                  "cell of suite.base; name the base (a built suite's name or file) or leave it "
                                  "out", field="base_skip")
            for name in SELECTION:
                if getattr(self, name) is not None:
                    raise ConfigError(f"suite.{name}={json.dumps(list(getattr(self, name)))}: selects cells of "
                                      "suite.base; name the base (a built suite's name or file) or leave it out",
                                      field=name)
            return
        if not self.base.strip():
            raise ConfigError("suite.base='': must be a built suite's name or file", field="base")
        default = SuiteBuildConfig()
        for name in _DRAWING:
            value = getattr(self, name)
            if value != getattr(default, name):
                text = json.dumps(to_mapping(value) if is_dataclass(value) else value)
                raise ConfigError(f"suite.{name}={text if len(text) <= 60 else text[:57] + '...'}: a suite built "
                                  f"from a base (suite.base={self.base!r}) has its base's; leave it out",
                                  field=name)

    def max_scenes(self, family: str) -> int:
        """Scenes a candidate of ``family`` may sample looking for its episode."""
        return (self.family_max_scenes or {}).get(family, self.max_scenes_per_candidate)

    def cells(self) -> list[tuple[str, str, str]]:
        """(catalogue, family, level) of each cell, in the suite's order."""
        return [(c, f, lv) for c in self.catalogues for f in self.families for lv in self.levels]

    def scene_for(self, catalogue: str, family: str) -> SceneConfig:
        """The scene options a cell's scenes are sampled with."""
        options = (self.family_scene or {}).get(family, {})
        return SceneConfig.from_dict({**self.env.scene.to_dict(), **options, "catalogue": catalogue})


@dataclass(frozen=True)
class Candidate:
    """One candidate episode and the oracle's verdict on it.

    Attributes:
        cell: index of its cell.
        k: its index in the cell.
        solved: the oracle succeeded through the env.
        reason: why not (:func:`rejection_reason`), "" when solved.
        episode: the episode's suite entry without ``id`` (when solved).
        steps: control steps the oracle took.
        variant: for an axis variant, ``axis strength twin`` (its cell is then the twin's id and ``k``
            the attempt).
    """

    cell: int
    k: int
    solved: bool
    reason: str = ""
    episode: dict[str, Any] | None = None
    steps: int = 0
    variant: str = ""


def rejection_reason(record: EpisodeRecord) -> str:
    """A countable reason for a failed oracle episode: its kind and the message with numbers as ``N``
    (``gave_up: PlanningError: ...``, ``safety: contact_force``, ``check: object N does not touch
    object N``, ``truncated``)."""
    if record.gave_up:
        text = record.gave_up
        kind = "gave_up"
    elif record.safety_events:
        text, kind = record.safety_events[-1], "safety"
    elif record.truncated:
        return "truncated"
    else:
        text, kind = str(record.check_reason), "check"
    return f"{kind}: {_NUMBER.sub('N', text)[:100]}"


# Instructions of the wanted family drawn on a scene before the next scene is sampled.
_INSTRUCTIONS_PER_SCENE = 8
# Candidates per cell in the first round: a cell all of whose first candidates find no episode of its
# family and level on their scenes is given up, so that no later column samples scenes for it.
_PROBE = 2
# Compiled scenes (and their annotations) a worker's environment keeps: the scenes of a column.
_COLUMN_SCENES = 64


def _cell_env(config: SuiteBuildConfig, catalogue: str, family: str) -> EvalConfig:
    env = replace(config.env, scene=config.scene_for(catalogue, family))
    return EvalConfig(policy="oracle", episodes=1, env=env)


# The worker's runners, most recently used last: one per catalogue and per family with scene options
# of its own (``family_scene``), so that a column's cells keep their scene caches.
# (Configs hold dicts, so the runners are a list searched by equality.)
_WORKER: list[tuple[EvalConfig, EpisodeRunner]] = []
_RUNNERS = 4


def _runner(config: SuiteBuildConfig, catalogue: str, family: str, slots: int = 0) -> EpisodeRunner:
    """The worker's oracle runner for a catalogue and family, kept across cells, columns and rounds;
    ``slots``: the object slots its observation needs at least (a variant's scene may hold more
    objects than the scenes the env samples)."""
    evaluation = _cell_env(config, catalogue, family)
    scene = evaluation.env.scene
    evaluation = replace(evaluation, env=replace(
        evaluation.env, scene_cache_size=max(evaluation.env.scene_cache_size, _COLUMN_SCENES,
                                             config.max_scenes(family)),
        scene=replace(scene, max_objects=max(scene.max_objects, slots))))
    held = next((i for i, (c, _) in enumerate(_WORKER) if c == evaluation), None)
    if held is None:
        while len(_WORKER) >= _RUNNERS:
            _WORKER.pop(0)[1].close()
        _WORKER.append((evaluation, EpisodeRunner(evaluation)))
    else:
        _WORKER.append(_WORKER.pop(held))
    return _WORKER[-1][1]


def scene_seeds(seed: int, k: int, count: int) -> list[int]:
    """The scene seeds candidate ``k`` of every cell draws from, in order."""
    return [int(np.random.SeedSequence([seed, k, a]).generate_state(1, np.uint32)[0]) for a in range(count)]


def _prove(config: SuiteBuildConfig, runner: EpisodeRunner, c: int, k: int) -> Candidate:
    """Draw candidate ``k`` of cell ``c`` and run the oracle on it."""
    catalogue, family, level = config.cells()[c]
    scenes = config.max_scenes(family)
    try:
        scene, instruction, seed = instruction_at_level(
            runner.env.cache, scene_seeds(config.seed, k, scenes), family, level,
            _INSTRUCTIONS_PER_SCENE, config.instruction_rounds)
    except SamplehdError:  # no episode of the family and level on the candidate's scenes
        return Candidate(c, k, False, f"draw: no {level} episode in {scenes} scenes")
    try:
        record = runner.run((k, seed, family), options={"scene": scene, "instruction": instruction})
    except SamplehdError as exc:  # the env refused the drawn start (e.g. objects inside each other)
        return Candidate(c, k, False, f"reset: {type(exc).__name__}")
    if not record.success:
        return Candidate(c, k, False, rejection_reason(record), steps=record.steps)
    ep = runner.env.episode
    ins = ep.instruction
    entry = SuiteEpisode(
        id=0, catalogue=catalogue, scene_seed=int(ep.scene.seed), reset_seed=int(record.seed), scene=ep.scene.to_dict(),
        instruction=ep.text,
        family=ep.family, task=dict(ins["task"]), program=list(ins.get("program", [])),
        program_sequence=str(ins.get("program_sequence", "")), targets=[int(t) for t in ins.get("targets", [])],
        level=episode_level(ins, ep.annotation), axis=CLEAN_AXIS, strength=0, twin=None,
        oracle_steps=record.steps, start_state=None, sensor=None).to_dict()
    del entry["id"]
    return Candidate(c, k, True, episode=entry, steps=record.steps)


def _to_try(done: dict[int, Candidate], tried: int, need: int, room: int, first: bool) -> int:
    """How many new candidates a cell tries this round: two in the first; later, as many as it lacks,
    from the third round on divided by the share of its candidates so far that were solved (at most
    twice as many), never more than ``room``."""
    solved = sum(x.solved for x in done.values())
    lacking = need - solved
    if first:
        want = min(lacking, _PROBE)
    elif tried > _PROBE and solved:
        want = min(2 * lacking, max(lacking, round(lacking * tried / solved)))
    else:
        want = lacking
    return max(0, min(want, room))


def _barren(done: dict[int, Candidate]) -> bool:
    """Whether a cell's candidates so far (its first round's) all found no episode of its family and
    level: the cell is then given up (``short_cells``, with the reason)."""
    return bool(done) and all(not x.solved and x.reason.startswith("draw:") for x in done.values())


def _prove_column(unit: tuple[SuiteBuildConfig, str, int, tuple[int, ...]]) -> list[Candidate]:
    """Candidate ``k`` of each of ``cells`` (all of one catalogue), in order: one work unit; the worker
    keeps its runners, whose scene caches hold the column's scenes."""
    config, catalogue, k, cells = unit
    return [_prove(config, _runner(config, catalogue, config.cells()[c][1]), c, k) for c in cells]


def _prove_cells(config: SuiteBuildConfig, backend: Backend,
                 progress: Callable[[Candidate], None] | None) -> tuple[list[dict[int, Candidate]], list[int]]:
    """Every cell's candidates by ``k`` and how many it tried: each cell's rounds (:func:`_to_try`), the
    next asked when the cell's last candidate is in (see the module docstring)."""
    cells = config.cells()
    done: list[dict[int, Candidate]] = [{} for _ in cells]
    tried = [0] * len(cells)
    rounds = [0] * len(cells)
    waiting = [0] * len(cells)  # the cell's candidates of this round not in yet
    feed = Feed()

    def ask(ready: list[int]) -> None:
        columns: dict[tuple[str, int], list[int]] = {}
        for c in ready:
            if _barren(done[c]):
                continue
            room = config.max_candidates_per_cell - tried[c]
            waiting[c] = _to_try(done[c], tried[c], config.episodes_per_cell, room, rounds[c] == 0)
            rounds[c] += 1
            for _ in range(waiting[c]):
                columns.setdefault((cells[c][0], tried[c]), []).append(c)
                tried[c] += 1
        for (catalogue, k), cs in sorted(columns.items(),
                                         key=lambda kv: (kv[0][1], config.catalogues.index(kv[0][0]))):
            feed.put((config, catalogue, k, tuple(cs)), priority=-max(rounds[c] for c in cs))

    ask(list(range(len(cells))))
    for _, column in feed.run(backend, _prove_column):
        ready = []
        for cand in column:
            done[cand.cell][cand.k] = cand
            waiting[cand.cell] -= 1
            if progress is not None:
                progress(cand)
            if not waiting[cand.cell]:
                ready.append(cand.cell)
        ask(ready)
    return done, tried


def _prove_variant(unit: tuple[SuiteBuildConfig, dict[str, Any], str, int, int]) -> Candidate:
    """Run the oracle on a physical axis' variant of a clean episode (one work unit)."""
    config, twin, axis, strength, attempt = unit
    label = f"{axis} {strength} {twin['id']}"
    try:
        variant = perturb(twin, axis, strength, config.seed, attempt)
    except SceneError as exc:  # e.g. no free spot for a distractor, or it made the instruction ambiguous
        return Candidate(int(twin["id"]), attempt, False, f"{axis}: {_NUMBER.sub('N', str(exc))[:100]}",
                         variant=label)
    # one runner for every variant: room for the most objects an axis adds (distractors: one per strength)
    scene = config.scene_for(twin["catalogue"], twin["family"])
    runner = _runner(config, twin["catalogue"], twin["family"], slots=scene.max_objects + max(config.strengths))
    options = SuiteEpisode.from_dict({"id": 0, **variant}).reset_options()
    try:
        record = runner.run((int(twin["id"]), int(twin["reset_seed"]), twin["family"]), options=options)
    except SamplehdError as exc:  # e.g. objects shifted off the table, or out of the region the instruction names
        return Candidate(int(twin["id"]), attempt, False, f"{axis}: {_NUMBER.sub('N', str(exc))[:100]}",
                         variant=label)
    if not record.success:
        return Candidate(int(twin["id"]), attempt, False, f"{axis}: {rejection_reason(record)}", steps=record.steps,
                         variant=label)
    return Candidate(int(twin["id"]), attempt, True, episode={**variant, "oracle_steps": record.steps},
                     steps=record.steps, variant=label)


def same_episode(variant: dict[str, Any], twin: dict[str, Any]) -> bool:
    """Whether a variant equals its twin apart from its axis labels."""
    skip = {"id", "axis", "strength", "twin"}
    return {k: v for k, v in variant.items() if k not in skip} == {k: v for k, v in twin.items() if k not in skip}


def _variants(config: SuiteBuildConfig, clean: list[dict[str, Any]], backend: Backend,
              progress: Callable[[Candidate], None] | None) -> tuple[list[dict[str, Any]], Counter[str], list[Any]]:
    """Each clean episode's variants (axis, strength, twin order), the reasons of rejected attempts and
    the variants left out."""
    out: dict[tuple[str, int, int], dict[str, Any]] = {}
    rejected: Counter[str] = Counter()
    pending = []
    for axis in config.axes:
        for strength in config.strengths:
            for twin in clean:
                if axis in PHYSICAL_AXES:
                    pending.append((axis, strength, twin))
                else:  # images or text only: the twin's rollout is this variant's, bit for bit
                    variant = perturb(twin, axis, strength, config.seed)
                    if same_episode(variant, twin):
                        rejected[f"{axis}: nothing to change"] += 1
                    else:
                        out[axis, strength, twin["id"]] = variant
    # A failed attempt's next one is queued at once, before the first attempts still waiting.
    feed = Feed()
    for axis, strength, twin in pending:
        feed.put((config, twin, axis, strength, 0))
    left: set[tuple[str, int, int]] = set()
    for (_, twin, axis, strength, attempt), cand in feed.run(backend, _prove_variant):
        if progress is not None:
            progress(cand)
        if cand.solved:
            out[axis, strength, int(twin["id"])] = cand.episode or {}
            continue
        rejected[cand.reason] += 1
        if attempt + 1 < config.max_attempts_per_variant:
            feed.put((config, twin, axis, strength, attempt + 1), priority=-(attempt + 1))
        else:
            left.add((axis, strength, int(twin["id"])))
    short = [{"axis": a, "strength": s, "twin": int(t["id"])} for a, s, t in pending if (a, s, int(t["id"])) in left]
    return [out[k] for k in sorted(out, key=lambda k: (config.axes.index(k[0]), k[1], k[2]))], rejected, short


def read_base(config: SuiteBuildConfig) -> Suite:
    """The suite ``config.base`` names, read and checked.

    Raises:
        ConfigError: one line naming ``suite.base`` and its value: no shipped suite of that name and no
            such file, a damaged or foreign file, a suite with no clean episode, or one itself built
            from a base (name that base instead: its build holds the env that proved the episodes).
    """
    base = str(config.base)
    try:
        path = suite_path(base)
    except ConfigError:
        raise ConfigError(f"suite.base={base!r}: no such shipped suite; shipped: {', '.join(shipped_suites())} "
                          "(or give a built suite file's path)", field="base") from None
    try:
        suite = read_suite(path)
    except ConfigError as exc:
        raise ConfigError(f"suite.base={base!r}: {exc}", field="base") from None
    if suite.build.get("base") is not None:
        raise ConfigError(f"suite.base={base!r}: suite {suite.name!r} is itself built from the base "
                          f"{suite.build['base']!r}; name that one", field="base")
    if not any(e.axis == CLEAN_AXIS for e in suite.episodes):
        raise ConfigError(f"suite.base={base!r}: suite {suite.name!r} has no clean episode (axis {CLEAN_AXIS!r}) "
                          "to make variants of", field="base")
    return suite


def _base_cells(base: Suite) -> list[tuple[str, str, str]]:
    """The base's cells (catalogue, family, level) in its order: its build's grid, then any other cell
    its clean episodes hold."""
    b = base.build
    grid = [(c, f, lv) for c in b.get("catalogues", ()) for f in b.get("families", ()) for lv in b.get("levels", ())]
    held = [(e.catalogue, e.family, e.level) for e in base.episodes if e.axis == CLEAN_AXIS]
    return list(dict.fromkeys([*grid, *held]))


def _selected(config: SuiteBuildConfig, cell: tuple[str, str, str]) -> bool:
    """Whether a base's cell (catalogue, family, level) is among those the suite takes."""
    chosen = (getattr(config, name) for name in SELECTION)
    return all(names is None or value in names for value, names in zip(cell, chosen, strict=True))


def _take_clean(config: SuiteBuildConfig, base: Suite) -> tuple[list[SuiteEpisode], list[dict[str, Any]]]:
    """The base's clean episodes the suite takes (the first ``base_per_cell`` of each cell after its
    first ``base_skip``, in suite order) and the cells that have fewer."""
    want = config.base_per_cell
    seen: Counter[tuple[str, str, str]] = Counter()
    taken: Counter[tuple[str, str, str]] = Counter()
    out = []
    for ep in base.episodes:
        cell = (ep.catalogue, ep.family, ep.level)
        if ep.axis != CLEAN_AXIS or not _selected(config, cell):
            continue
        seen[cell] += 1
        if seen[cell] > config.base_skip and (want is None or taken[cell] < want):
            taken[cell] += 1
            out.append(ep)
    short = [{"catalogue": c, "family": f, "level": lv, "episodes": taken[c, f, lv],
              "reason": f"the base has {seen[c, f, lv]} clean episodes of the cell"
                        + (f", of which the first {config.base_skip} are passed over" if config.base_skip else "")}
             for c, f, lv in _base_cells(base)
             if want is not None and taken[c, f, lv] < want and _selected(config, (c, f, lv))]
    return out, short


def _proof_config(config: SuiteBuildConfig, base: Suite) -> SuiteBuildConfig:
    """What a suite built from a base proves its physical variants with: the base's env and scene
    options, and its own seed, axes, strengths and attempts."""
    own = {k: getattr(config, k) for k in ("seed", "axes", "strengths", "max_attempts_per_variant")}
    try:
        return SuiteBuildConfig.from_dict({**{k: base.build[k] for k in _PROOF if k in base.build}, **own})
    except ConfigError as exc:  # a base built by another samplehd, whose env options this one does not know
        raise ConfigError(f"suite.base={config.base!r}: its build's options: {exc}", field="base") from None


def _manifest(episodes: list[dict[str, Any]], candidates: int, rejected: Counter[str],
              candidates_solved: dict[str, Any], short_cells: list[Any], short_variants: list[Any],
              spare: int = 0) -> dict[str, Any]:
    """The suite file's manifest (counts, rejection reasons, what the build could not fill; ``spare``:
    candidates solved beyond their cell's episodes)."""
    return {
        "episodes": len(episodes),
        **{f"by_{key}": dict(sorted(Counter(str(e[key]) for e in episodes).items()))
           for key in ("family", "level", "catalogue", "axis", "strength")},
        "candidates": candidates,
        "spare": spare,
        "rejected": dict(sorted(rejected.items(), key=lambda kv: (-kv[1], kv[0]))),
        "candidates_solved": candidates_solved,
        "oracle_success_on_suite": 1.0 if episodes else 0.0,
        "short_cells": short_cells,
        "short_variants": short_variants,
    }


def _build_from_base(name: str, config: SuiteBuildConfig, backend: Backend,
                     progress: Callable[[Candidate], None] | None) -> Suite:
    """A suite of a base's clean episodes and their variants (see the module docstring)."""
    base = read_base(config)
    taken, short = _take_clean(config, base)
    clean: list[dict[str, Any]] = [{**e.to_dict(), "id": i} for i, e in enumerate(taken)]
    variants, rejected, short_variants = _variants(_proof_config(config, base), clean, backend, progress)
    episodes = clean + [{"id": len(clean) + i, **v} for i, v in enumerate(variants)]
    manifest = {**_manifest(episodes, 0, rejected, {}, short, short_variants),
                "base": {"name": base.name, "content_hash": base.content_hash, "episodes": [e.id for e in taken]},
                "axes": list(config.axes), "strengths": list(config.strengths)}
    build = {"name": name, **{k: v for k, v in config.to_dict().items()  # base_skip only where it skips
                              if k not in _DRAWING and not (k in SELECTION and v is None)
                              and not (k == "base_skip" and not v)}}
    return Suite(name=name, path=None, content_hash=content_hash(episodes), build=build, manifest=manifest,
                 package_version=__version__, episodes=tuple(SuiteEpisode.from_dict(e) for e in episodes))


def build_suite(name: str, config: SuiteBuildConfig, backend: Backend | None = None,
                progress: Callable[[Candidate], None] | None = None) -> Suite:
    """Draw, prove and freeze a suite, or derive it from its base (see the module docstring); nothing
    is written.

    Args:
        name: the suite's name.
        config: what to build.
        backend: where candidates run (default: this process).
        progress: called with each finished candidate.

    Raises:
        ConfigError: a base that cannot be used (:func:`read_base`).
    """
    backend = backend or Backend()
    if config.base is not None:
        return _build_from_base(name, config, backend, progress)
    cells = config.cells()
    need = config.episodes_per_cell
    done, tried = _prove_cells(config, backend, progress)
    episodes: list[dict[str, Any]] = []
    rejected: Counter[str] = Counter()
    solve: dict[str, dict[str, Counter[str]]] = {"by_catalogue": {}, "by_family": {}, "by_catalogue_family": {}}
    short = []
    spare = 0
    for c, (catalogue, family, level) in enumerate(cells):
        solved = [done[c][k] for k in sorted(done[c]) if done[c][k].solved]
        spare += max(0, len(solved) - need)
        solved = solved[:need]
        if len(solved) < need:
            short.append({"catalogue": catalogue, "family": family, "level": level, "episodes": len(solved),
                          "candidates": tried[c], **({"reason": f"no episode of the family and level on the "
                                                      f"{len(done[c]) * config.max_scenes(family)} scenes "
                                                      "of its first candidates"} if _barren(done[c]) else {})})
        for k in sorted(done[c]):
            cand = done[c][k]
            for key, value in (("by_catalogue", catalogue), ("by_family", family),
                               ("by_catalogue_family", f"{catalogue} {family}")):
                group = solve[key].setdefault(value, Counter())
                group["tried"] += 1
                group["drawn"] += not cand.reason.startswith("draw:")  # the draw found an episode of the cell
                group["solved"] += cand.solved
            if not cand.solved:
                rejected[cand.reason] += 1
        for cand in solved:
            episodes.append({"id": len(episodes), **(cand.episode or {})})
    short_variants: list[Any] = []
    if config.axes:
        variants, variant_rejected, short_variants = _variants(config, episodes, backend, progress)
        rejected.update(variant_rejected)
        episodes += [{"id": len(episodes) + i, **v} for i, v in enumerate(variants)]
    solved_counts = {key: {v: {k: n[k] for k in ("tried", "drawn", "solved")} for v, n in groups.items()}
                     for key, groups in solve.items()}
    manifest = _manifest(episodes, sum(tried), rejected, solved_counts, short, short_variants, spare)
    build = {"name": name, **{k: v for k, v in config.to_dict().items() if k not in _BASE}}
    return Suite(name=name, path=None, content_hash=content_hash(episodes), build=build, manifest=manifest,
                 package_version=__version__, episodes=tuple(SuiteEpisode.from_dict(e) for e in episodes))
