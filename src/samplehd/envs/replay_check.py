"""Replay a dataset's recorded actions in the environment and compare the outcome with the recording.

Each episode starts the environment from its stored first state (``reset(options={"dataset": ...,
"episode_index": i})``) and sends the recorded SAMPLE-HD steering vectors open loop, one per control
step, in the dataset's control and physics rates, success checker and grasp assist. The last frame
holds the final state with a hold command that was never executed, so an episode of ``T`` frames
sends ``T - 1`` actions; after action ``t`` the state is compared with frame ``t + 1``.

A recorded push (a ``nudge`` disturbance, :mod:`samplehd.record.disturbances`) is applied again at its
frame. The replayed outcome is judged as the dataset judged its recording: the shared success checker on
the final state (the state of the last frame), and with the dataset's ``paths.reject_fallen`` an object
fallen over makes it a failure (the environment's ``info["success"]``, which ``samplehd evaluate``
counts, is any step's checker verdict and does not look at falls: a recovery that ends with an object
on its side in the right place passes there). It agrees when that equals the recorded outcome. Because the
dataset's rollout and the environment weld a grasped object by one rule
(:class:`samplehd.motion.assist.GraspAssist`), every recording must replay to its outcome, success or
failure; a disagreement is a bug, or drift after a changed MuJoCo or samplehd version.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from samplehd.dataset.reader import DatasetReader
from samplehd.envs.tabletop import TabletopEnv
from samplehd.errors import ConfigError, DatasetError, SamplehdError
from samplehd.fixedmath import norm
from samplehd.workers import Backend
from samplehd.world.bodies import object_body_name

__all__ = ["EpisodeReplay", "FamilyReplay", "ReplayReport", "final_outcome", "replay_dataset", "replay_env",
           "replay_episode"]


@dataclass(frozen=True)
class EpisodeReplay:
    """One episode's recorded actions replayed in the environment.

    Attributes:
        index: episode index in the dataset.
        family: task family.
        recorded_success: the outcome the dataset recorded.
        replayed_success: the replay's outcome, judged as the dataset judges (the checker on the final
            state, falls rejected when the dataset rejects them).
        tcp_deviation: largest distance between the replayed and the recorded TCP position [m].
        object_deviation: largest distance between a replayed and the recorded object position [m].
        steps: actions sent.
    """

    index: int
    family: str
    recorded_success: bool
    replayed_success: bool
    tcp_deviation: float
    object_deviation: float
    steps: int

    @property
    def agrees(self) -> bool:
        return self.recorded_success == self.replayed_success


@dataclass(frozen=True)
class FamilyReplay:
    """The episodes of one family: counts and the largest deviations [m]."""

    family: str
    episodes: int
    recorded_successes: int
    replayed_successes: int
    agreeing: int
    tcp_deviation: float
    object_deviation: float


@dataclass(frozen=True)
class ReplayReport:
    """Every replayed episode of a dataset."""

    episodes: tuple[EpisodeReplay, ...]

    @property
    def agrees(self) -> bool:
        """Whether every replayed outcome equals the recorded one."""
        return all(e.agrees for e in self.episodes)

    def to_dict(self) -> dict[str, object]:
        """The report as JSON data: the verdict, per family and per episode (deviations in metres)."""
        return {"agrees": self.agrees, "families": [asdict(f) for f in self.families()],
                "episodes": [{**asdict(e), "agrees": e.agrees} for e in self.episodes]}

    def families(self) -> list[FamilyReplay]:
        """Per family, in name order."""
        out = []
        for family in sorted({e.family for e in self.episodes}):
            eps = [e for e in self.episodes if e.family == family]
            out.append(FamilyReplay(
                family=family,
                episodes=len(eps),
                recorded_successes=sum(e.recorded_success for e in eps),
                replayed_successes=sum(e.replayed_success for e in eps),
                agreeing=sum(e.agrees for e in eps),
                tcp_deviation=max(e.tcp_deviation for e in eps),
                object_deviation=max(e.object_deviation for e in eps),
            ))
        return out


def replay_env(reader: DatasetReader) -> TabletopEnv:
    """A state-only, steering-mode environment with the dataset's rates, checker, grasp assist and scene
    options."""
    paths = reader.config.get("paths", {})
    options = {key: paths[key] for key in ("control_hz", "physics_hz", "checker", "grasp_assist") if key in paths}
    if isinstance(reader.config.get("scene"), dict):  # its object count sizes the observation
        options["scene"] = reader.config["scene"]
    try:
        return TabletopEnv(obs_mode="state", control_mode="steering", max_episode_steps=None, **options)
    except SamplehdError as exc:
        raise DatasetError(f"{reader.root / 'info.json'}: config: its settings make no environment: "
                           f"{_own_words(exc)}") from None


def _own_words(exc: Exception) -> str:
    """An environment error's message without the environment's own prefixes (``reset:``,
    ``Tabletop-v0.``), which name no file of the dataset."""
    text = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
    for prefix in ("reset: ", "step: ", "Tabletop-v0."):
        text = text.removeprefix(prefix)
    return text


def replay_episode(env: TabletopEnv, reader: DatasetReader, index: int) -> EpisodeReplay:
    """Reset ``env`` from episode ``index`` of ``reader``'s dataset and send its recorded actions."""
    where = f"{reader.episode_path(index)} (episode {index})"
    frames = reader.frames(index, ["steering", "tcp_pos", "object_pos"])
    steering = np.asarray(frames["steering"])
    bad = np.flatnonzero(~np.all(np.isfinite(steering), axis=tuple(range(1, steering.ndim))))
    if len(bad):
        raise DatasetError(f"{where}: frames/steering has non-finite values at frame {int(bad[0])} "
                           f"({len(bad)} frame(s)); the recording is damaged")
    try:
        env.reset(options={"dataset": str(reader.root), "episode_index": index})
    except SamplehdError as exc:
        raise DatasetError(f"{where}: cannot start the environment from it: {_own_words(exc)}") from None
    tcp_rec, obj_rec = np.asarray(frames["tcp_pos"]), np.asarray(frames["object_pos"])
    tcp_dev = obj_dev = 0.0
    meta = reader.episode_meta(index)
    push = _recorded_push(meta.info)
    for t in range(len(steering) - 1):
        _apply_push(env, push, t)
        try:
            obs, *_ = env.step(steering[t])
        except SamplehdError as exc:
            raise DatasetError(f"{where}: frame {t}: the recorded action is refused: {_own_words(exc)}") from None
        tcp_dev = max(tcp_dev, norm(obs["tcp_pos"].astype(float) - tcp_rec[t + 1]))
        k = len(obj_rec[t + 1])
        # A recorded frame of a push holds that frame's push step, which the replay applies only before
        # the next action: those frames' objects are compared from the push's end on.
        if k and (push is None or not push[0] <= t + 1 < push[0] + push[1]):
            diff = obs["object_pos"][:k].astype(float) - obj_rec[t + 1]
            obj_dev = max(obj_dev, float(np.max(norm(diff, axis=1))))
    success = final_outcome(env, _rejects_fallen(reader))
    entry = reader.episodes[index]
    return EpisodeReplay(index, entry.family, meta.success, success, tcp_dev, obj_dev, max(0, len(steering) - 1))


def final_outcome(env: TabletopEnv, reject_fallen: bool = True) -> bool:
    """Whether ``env``'s current state completes its task as a dataset records it: the shared checker's
    verdict (with its stability window) and, with ``reject_fallen``, no object fallen over
    (:class:`samplehd.record.paths.PathConfig`)."""
    final = env.unwrapped.check_success()
    return bool(final["success"]) and not (reject_fallen and final["fallen"])


def _rejects_fallen(reader: DatasetReader) -> bool:
    """Whether the dataset counts a final state with an object fallen over as a failure
    (``paths.reject_fallen``, true by default)."""
    paths = reader.config.get("paths", {})
    return bool(paths.get("reject_fallen", True)) if isinstance(paths, dict) else True


def _recorded_push(info: object) -> tuple[int, int, int, np.ndarray] | None:
    """A recorded nudge (``info["disturbance"]``): (first frame, frames, object, step [m]); None for none.

    A push is an event from outside, not an action: the replay applies it where the recording did
    (the object moved by ``push_step`` and put at rest at the start of each of ``push_frames`` steps),
    as it sends the actions.
    """
    label = info.get("disturbance") if isinstance(info, dict) else None
    if not isinstance(label, dict) or "push_step" not in label:
        return None
    return int(label["frame"]), int(label["push_frames"]), int(label["object"]), np.asarray(label["push_step"], float)


def _apply_push(env: TabletopEnv, push: tuple[int, int, int, np.ndarray] | None, t: int) -> None:
    if push is None or not push[0] <= t < push[0] + push[1]:
        return
    model, data = env.unwrapped.model, env.unwrapped.data
    joint = int(model.body_jntadr[model.body(object_body_name(push[2])).id])
    adr, dof = int(model.jnt_qposadr[joint]), int(model.jnt_dofadr[joint])
    data.qpos[adr:adr + 2] += push[3]
    data.qvel[dof:dof + 6] = 0.0


def replay_dataset(root: str | Path, episodes: int | None = None,
                   on_episode: Callable[[int, int, EpisodeReplay], None] | None = None,
                   backend: Backend | None = None) -> ReplayReport:
    """Replay the first ``episodes`` episodes of a dataset (all when None) on ``backend`` (default: in
    this process); ``on_episode(done, total, replay)`` after each, in the order they finish (progress).

    The report lists the episodes in index order whichever worker replayed them: the same for any number
    of workers.

    Raises:
        DatasetError: ``root`` is not a dataset directory, or an episode cannot be replayed.
        ConfigError: ``episodes`` is not a positive integer, or the dataset has no episodes.
    """
    if episodes is not None and (isinstance(episodes, bool) or not isinstance(episodes, int) or episodes < 1):
        raise ConfigError(f"replay: episodes must be a positive integer, got {episodes!r}")
    reader = DatasetReader(root)
    count = len(reader.episodes)
    if count == 0:
        raise ConfigError(f"{reader.root}: the dataset has no episodes to replay")
    env = replay_env(reader)  # a config that makes no environment is refused before any worker starts
    total = min(count, episodes or count)
    backend = backend or Backend()
    if backend.kind == "local" and backend.workers > total:  # no idle worker processes to start
        backend = Backend("local", total)
    _close_worker_env()
    if backend.kind == "local" and backend.workers == 1:  # units run in this process: keep the env
        _worker_env.append((str(reader.root), reader, env))
    else:
        env.close()
    done: list[EpisodeReplay] = []
    try:
        for _, replayed in backend.map(_replay_unit, ((str(reader.root), i) for i in range(total))):
            done.append(replayed)
            if on_episode is not None:
                on_episode(len(done), total, replayed)
    finally:
        _close_worker_env()
    return ReplayReport(tuple(sorted(done, key=lambda e: e.index)))


# A worker's environment, kept from one unit to the next (building one compiles the scene model):
# (dataset root, its reader, the environment).
_worker_env: list[tuple[str, DatasetReader, TabletopEnv]] = []


def _replay_unit(unit: tuple[str, int]) -> EpisodeReplay:
    """Work unit of :func:`replay_dataset`: replay episode ``index`` of the dataset at ``root``."""
    root, index = unit
    if not _worker_env or _worker_env[0][0] != root:
        _close_worker_env()
        reader = DatasetReader(root)
        _worker_env.append((root, reader, replay_env(reader)))
    _, reader, env = _worker_env[0]
    return replay_episode(env, reader, index)


def _close_worker_env() -> None:
    while _worker_env:
        _worker_env.pop()[2].close()
