"""Demonstrations collected in the environment by the closed-loop oracle: noise-injected (DART) and
on-policy corrective (DAgger) episodes for the behaviour-cloning policy.

The oracle (:class:`samplehd.envs.oracle.OraclePolicy`) plans from the live state and labels every
step with the action that moves the controller's current target to its plan's next one. So when the
executed action is not the label, the next label corrects for it:

- **DART** (Laskey et al., 2017): the executed action is the oracle's with Gaussian noise of
  standard deviation ``noise`` added to its velocity values (not the gripper value, nor the values
  the demonstrations never use: ``still``); the labels stay the oracle's own. The policy learns
  from states a little off the demonstration and the way back to it.
- **DAgger** (Ross et al., 2011): with probability ``beta`` a step executes the oracle's action,
  otherwise the policy's; every step is labelled with the oracle's action. The policy learns from
  the states it visits itself.

Each collected episode has the same arrays as a dataset episode read for training
(:func:`samplehd.learn.policy.preparation._episode_arrays`): the images the environment rendered, the robot state, the
labels, the instruction tokens. Only episodes the oracle finished with success are kept, and only
L1 ones (the levels' held-out items stay out of training). Episode ``k`` resets the environment with
the seed ``SeedSequence([seed, 0xDA, k])``: a function of its arguments only, and not among the seeds
``samplehd evaluate`` draws its split from.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass
from multiprocessing import get_context
from typing import Any

import numpy as np

from samplehd.catalogue.loader import DEFAULT_CATALOGUE
from samplehd.envs.oracle import OraclePolicy
from samplehd.envs.tabletop import TabletopEnv
from samplehd.errors import ConfigError, PlanningError
from samplehd.language.levels import episode_level, held_out_instruction
from samplehd.robot.constants import GRIPPER_STROKE

__all__ = ["OBS_KEYS", "CollectSpec", "collect", "episode_rng", "episode_seed", "record_observation", "run_episode",
           "squeeze_command"]

_STREAM = 0xDA  # the seed stream of collected episodes
SQUEEZE_STEP = 0.002  # a closing command asks for this much less than the fingers' opening [m]


@dataclass(frozen=True)
class CollectSpec:
    """What to collect.

    Attributes:
        episodes: episodes to attempt (failed and non-L1 ones are dropped).
        seed: base seed of the episodes' reset seeds and of the noise.
        families: task families, taken in turn.
        image: camera image side [px].
        cameras: cameras rendered (RGB).
        noise: DART: standard deviation of the noise added to the executed velocity values.
        beta: DAgger: probability that a step executes the oracle's action (1: the oracle's only).
        still: steering values (0-5) left without noise: those the demonstrations never use.
        max_steps: steps after which an episode is given up.
        first: index of the first episode (the seeds of a later round follow an earlier one's).
        squeeze: close the gripper as the waypoint policy does (:func:`squeeze_command`) from where
            a held-still step lowers the oracle's command until one raises it, instead of the
            oracle's own closing widths.
        catalogue: the built-in object catalogue the scenes draw from.
    """

    episodes: int
    seed: int
    families: tuple[str, ...]
    image: int
    cameras: tuple[str, ...]
    noise: float = 0.0
    beta: float = 1.0
    still: tuple[int, ...] = ()
    max_steps: int = 800
    first: int = 0
    squeeze: bool = False
    catalogue: str = DEFAULT_CATALOGUE

    def __post_init__(self) -> None:
        if not isinstance(self.episodes, int) or self.episodes < 0:
            raise ConfigError(f"collect: episodes={self.episodes!r}; valid: an integer ≥ 0")
        if not 0.0 <= self.noise <= 1.0:
            raise ConfigError(f"collect: noise={self.noise!r}; valid: a number in [0, 1]")
        if not 0.0 <= self.beta <= 1.0:
            raise ConfigError(f"collect: beta={self.beta!r}; valid: a number in [0, 1]")


def squeeze_command(gripper: Any) -> float:
    """The gripper command that closes the fingers :data:`SQUEEZE_STEP` narrower than they are
    (``gripper``: the observation's finger positions): repeated every step, it closes them until
    they touch, then squeezes what they hold, whatever its width."""
    width = float(gripper[0]) + float(gripper[1])
    return max(-1.0, 2.0 * (width - SQUEEZE_STEP) / GRIPPER_STROKE - 1.0)


OBS_KEYS = ("joint_pos", "joint_vel", "gripper", "tcp_pos", "tcp_quat", "object_pos", "object_quat")


def record_observation(frames: dict[str, list[Any]], obs: Any, cameras: Sequence[str]) -> None:
    """Append an observation's robot and object state (:data:`OBS_KEYS`) and camera RGB to ``frames``."""
    for key in OBS_KEYS:
        frames[key].append(np.asarray(obs[key]))
    for cam in cameras:
        frames[cam].append(obs[f"{cam}_rgb"])


def episode_rng(seed: int, k: int, part: int) -> np.random.Generator:
    """The random generator of part ``part`` of collected episode ``k`` (1: the oracle's noise and
    DAgger draws; 2: a waypoint DAgger episode's)."""
    return np.random.default_rng(np.random.SeedSequence([int(seed), _STREAM, int(k), int(part)]))


def episode_seed(seed: int, k: int) -> int:
    """The reset seed of collected episode ``k``."""
    return int(np.random.SeedSequence([int(seed), _STREAM, int(k)]).generate_state(1, np.uint32)[0])


# The policy a DAgger round runs, made once per worker process from (config, state dict).
PolicyFactory = Callable[[Any], Any]


def run_episode(env: TabletopEnv, oracle: OraclePolicy, spec: CollectSpec, k: int,
                 policy: Any) -> dict[str, Any] | None:
    """One collected episode's raw frames, or None when it failed or is not an L1 episode."""
    s = episode_seed(spec.seed, k)
    family = spec.families[k % len(spec.families)]
    obs, _ = env.reset(seed=s, options={"family": family})
    ep = env.episode
    if held_out_instruction(ep.instruction) or episode_level(ep.instruction, ep.annotation) != "L1":
        return None
    oracle.reset(seed=s)
    if policy is not None:
        policy.reset(seed=s)
    rng = episode_rng(spec.seed, k, 1)
    frames: dict[str, list[Any]] = {key: [] for key in (*OBS_KEYS, "label", "executed", "target_object",
                                                         *spec.cameras)}
    success = False
    closing, previous = False, None  # whether the oracle is closing or holding; its previous command
    for _ in range(spec.max_steps):
        try:
            label = oracle(obs)
        except PlanningError:
            break
        if oracle.gave_up:
            break
        executed = label.copy()
        if spec.squeeze:
            if previous is not None and np.abs(label[:6]).max() < 1e-3 and abs(label[6] - previous) >= 1e-3:
                closing = bool(label[6] < previous)
            previous = float(label[6])
            if closing:
                executed[6] = squeeze_command(obs["gripper"])
        if policy is not None:
            mine = np.asarray(policy(obs), dtype=float)  # the policy keeps its own memory of what it sent
            if rng.random() >= spec.beta:
                executed = mine
        if spec.noise > 0:
            noise = rng.normal(0.0, spec.noise, 6)
            noise[list(spec.still)] = 0.0
            executed[:6] = np.clip(executed[:6] + noise, -1.0, 1.0)
        record_observation(frames, obs, spec.cameras)
        frames["label"].append(label.astype(np.float32))
        frames["target_object"].append(oracle.target_object)
        frames["executed"].append(executed.astype(np.float32))
        obs, _, terminated, truncated, info = env.step(executed)
        success = bool(info["success"])
        if terminated or truncated:
            break
    # A DART episode is kept when it succeeded; a DAgger episode's labelled states are kept in any case
    # (the states where the policy went wrong are the ones it must learn from).
    if not frames["label"] or (policy is None and not success):
        return None
    out = {key: np.stack(v) for key, v in frames.items()}
    out["instruction"] = str(obs["instruction"])
    out["family"] = family
    out["seed"] = s
    out["success"] = success
    return out


_WORKER: dict[str, Any] = {}


# An episode's collector: (env, oracle, spec, k, policy) → its raw frames, or None to drop it.
EpisodeRunner = Callable[[TabletopEnv, OraclePolicy, CollectSpec, int, Any], "dict[str, Any] | None"]


def _collect_range(spec: CollectSpec, ks: Sequence[int], policy_factory: PolicyFactory | None,
                   policy_args: Any, runner: EpisodeRunner | None = None) -> list[dict[str, Any]]:
    held = _WORKER.get("env")
    if held is None or held[0] != spec:
        if held is not None:
            held[1].close()
        env = TabletopEnv(obs_mode="rgb" if spec.cameras else "state", cameras=spec.cameras or ("scene",),
                          width=spec.image, height=spec.image,
                          control_mode="steering", families=spec.families, max_episode_steps=spec.max_steps,
                          scene={"catalogue": spec.catalogue})
        _WORKER["env"] = held = (spec, env, OraclePolicy(env))
    _, env, oracle = held
    policy = policy_factory(policy_args, env) if policy_factory is not None else None
    out = []
    for k in ks:
        got = (runner or run_episode)(env, oracle, spec, k, policy)
        if got is not None:
            out.append(got)
    return out


def collect(spec: CollectSpec, workers: int = 1, policy_factory: PolicyFactory | None = None,
            policy_args: Any = None, progress: Callable[[int], None] | None = None,
            runner: EpisodeRunner | None = None) -> list[dict[str, Any]]:
    """Collect ``spec.episodes`` episodes (the kept ones, in episode order).

    Args:
        spec: what to collect.
        workers: processes (1: this one).
        policy_factory: DAgger: ``policy_factory(policy_args, env)`` makes the policy a worker runs
            (a module-level function, so that it can be sent to a worker process).
        progress: called with the number of episodes attempted so far.
        runner: what collects one episode (a module-level function; default :func:`run_episode`).

    Returns:
        Per kept episode: ``joint_pos``, ``joint_vel``, ``gripper``, ``tcp_pos``, ``tcp_quat``,
        ``object_pos``, ``object_quat``, ``label`` (the oracle's actions), ``executed`` (the actions
        sent), ``target_object`` (the object the oracle's subtask acts on), one RGB array per camera,
        ``instruction``, ``family``, ``seed``, ``success``.
    """
    ks = list(range(spec.first, spec.first + spec.episodes))
    parts = [ks[i:i + 8] for i in range(0, len(ks), 8)]
    results: dict[int, list[dict[str, Any]]] = {}
    done = 0
    if workers <= 1:
        for n, part in enumerate(parts):
            results[n] = _collect_range(spec, part, policy_factory, policy_args, runner)
            done += len(part)
            if progress:
                progress(done)
    else:
        with ProcessPoolExecutor(max_workers=workers, mp_context=get_context("spawn")) as pool:
            futures = {pool.submit(_collect_range, spec, part, policy_factory, policy_args, runner): n
                       for n, part in enumerate(parts)}
            for fut in futures:
                results[futures[fut]] = fut.result()
                done += len(parts[futures[fut]])
                if progress:
                    progress(done)
    return [e for n in sorted(results) for e in results[n]]

