"""Training the behaviour-cloning policy on a dataset (``samplehd train policy``), with demonstrations
collected in the environment: noise-injected (DART) and on-policy corrective (DAgger) episodes.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np
from rich.console import Console

from samplehd.envs.tokens import instruction_vocabulary
from samplehd.errors import ConfigError
from samplehd.learn.actions import WaypointExpert, steering_speeds
from samplehd.learn.data import open_dataset, training_split
from samplehd.learn.demos import OBS_KEYS, CollectSpec, collect, episode_rng, record_observation, run_episode
from samplehd.learn.policy.configuration import CAMERAS, STATE_DIM, TARGET_DIM, PolicyConfig
from samplehd.learn.policy.inference import BCPolicy
from samplehd.learn.policy.modeling import BCNet
from samplehd.learn.policy.preparation import (
    collected_arrays,
    episode_arrays,
    image_size,
    inputs_state,
    load_arrays,
    save_arrays,
)
from samplehd.learn.training import Metrics, TrainRun, descend, pick_device, set_seed, step_rng, torch

__all__ = ["DAGGER_FILE", "DEMOS_FILE", "dagger_policy", "fill_from_dataset", "for_action", "lowest_tcp",
           "train_policy",
           "waypoint_dagger_episode"]

DEMOS_FILE = "demos.npz"  # the oracle episodes collected in the environment (kept for a resumed run)
DAGGER_FILE = "dagger_{}.npz"  # the episodes of DAgger round N
NEAR_TABLE = 0.03  # frames whose TCP is within this of the demonstrations' lowest TCP height [m]
RARE_CHANNEL = 0.05  # a steering value that moves in fewer of the training frames is sent as zero


def waypoint_dagger_episode(env: Any, oracle: Any, spec: CollectSpec, k: int, policy: Any) -> dict[str, Any] | None:
    """A DAgger episode of the waypoint policy: the oracle's episode first (its waypoints make the
    :class:`WaypointExpert`), then the same episode again, each step executing the policy's action (the
    expert follower's with probability ``spec.beta``), every state labelled with the expert's waypoint
    (``goal``)."""
    demo = run_episode(env, oracle, replace(spec, noise=0.0, beta=1.0, squeeze=True), k, None)
    if demo is None:
        return None
    grip = np.asarray(demo["gripper"], np.float64)
    expert = WaypointExpert.of_episode(demo["label"], demo["tcp_pos"], demo["tcp_quat"], grip[:, 0] + grip[:, 1])
    obs, _ = env.reset(seed=int(demo["seed"]), options={"family": demo["family"]})
    policy.reset(seed=int(demo["seed"]))
    rng = episode_rng(spec.seed, k, 2)
    speeds = steering_speeds(env)
    frames: dict[str, list[Any]] = {key: [] for key in (*OBS_KEYS, "goal", "executed", "target_object", *spec.cameras)}
    target = int(np.asarray(demo["target_object"])[0]) if len(demo["target_object"]) else -1
    info: dict[str, Any] = {}
    for _ in range(spec.max_steps):
        goal = expert.label(obs)
        mine = np.asarray(policy(obs), dtype=np.float64)
        executed = expert.action(obs, goal, speeds) if rng.random() < spec.beta else mine
        record_observation(frames, obs, spec.cameras)
        frames["goal"].append(goal)
        frames["executed"].append(executed.astype(np.float32))
        frames["target_object"].append(target)
        obs, _, terminated, truncated, info = env.step(executed.astype(np.float32))
        if terminated or truncated:
            break
    out = {key: np.stack(v) for key, v in frames.items()}
    out.update(instruction=str(obs["instruction"]), family=demo["family"], seed=demo["seed"],
               success=bool(info.get("success", False)))
    return out


def dagger_policy(args: tuple[PolicyConfig, Mapping[str, Any]], env: Any) -> BCPolicy:
    """The policy a DAgger round runs in a collecting process (``args``: its config and weights)."""
    return BCPolicy(args[0], args[1], env)


def train_policy(dataset: str | Path, out: str | Path, config: PolicyConfig, *, device: str | None = None,
                 quiet: bool = False, stop_after: int | None = None, workers: int = 1) -> Metrics:
    """Train the behaviour-cloning policy ``config`` on a dataset's training episodes, with the
    episodes of ``config.collect`` collected in the environment.

    With ``inputs: rgb`` (the visuomotor policy) it sees both cameras' RGB, the instruction and the
    robot state; the dataset needs the cameras' RGB. With ``inputs: state`` (the privileged-state
    reference) it sees no image but the target object's pose relative to the TCP besides the
    instruction and the robot state. A ``waypoint`` policy predicts one waypoint every step, its
    cameras ending in keypoints (:func:`for_action`).

    What the dataset says is filled in (:func:`fill_from_dataset`). The state input is normalised
    per dimension with the training frames' mean and standard deviation (kept in the model's
    buffers). ``train.near_weight`` weights the loss of frames whose TCP is within 3 cm of the lowest
    TCP height of the demonstrations (the grasps and releases near the table). ``train.steps`` counts
    the DAgger rounds' steps too (``collect.dagger_steps`` each).

    Metrics (``metrics.json``): ``train_loss`` (the loss over the chunk, last 50 steps), ``test_l1``
    (the test episodes' frames), ``test_l1_first`` (first action only), ``test_l1_by_axis`` (first
    action, per steering value), ``test_l1_near_table`` and ``test_z_near_table`` (the chunk's
    error and the first action's z error on test frames within 3 cm of the lowest TCP height),
    episode and frame counts.

    Args:
        dataset: a dataset folder written by ``samplehd generate``.
        out: the output folder (resumed when it holds a checkpoint).
        config: the policy to train.
        device: torch device (default: cuda when present, else cpu).
        quiet: no progress bar.
        stop_after: stop after this many steps (a checkpoint stays; for tests of resuming).
        workers: processes collecting episodes.

    Returns:
        The metrics written to ``metrics.json`` (``{"stopped_at": N}`` when stopped early).
    """
    config = for_action(config)
    if config.collect.dagger_rounds * config.collect.dagger_steps >= config.train.steps:
        raise ConfigError(f"train.steps={config.train.steps}: counts the DAgger rounds' steps too "
                          f"({config.collect.dagger_rounds} × {config.collect.dagger_steps}); give more",
                          field="train.steps")
    reader = open_dataset(dataset)
    cameras = CAMERAS if config.inputs == "rgb" else ()
    image = image_size(reader, dataset) if cameras else 0
    train_k, test_k = training_split(reader, dataset, config.families or None)
    dev = pick_device(device)
    set_seed(config.train.seed)
    stride, tokens = config.train.stride, config.tokens
    data = [episode_arrays(reader, k, stride, tokens, cameras, config.action) for k in train_k]
    test = [episode_arrays(reader, k, stride * 4, tokens, cameras, config.action) for k in test_k]
    config = fill_from_dataset(config, reader, dataset, image, train_k, data)
    total_steps = config.train.steps
    run = TrainRun(Path(out), config.to_dict(), total_steps, checkpoint_every=max(50, total_steps // 20), quiet=quiet,
                   stop_after=stop_after)
    run.prepare()
    train_set = set(train_k)
    trainer = _Trainer(config, Path(out), data, cameras, dev, workers, Console(stderr=True, quiet=quiet).print,
                       longest=max(e.num_frames for e in reader.episodes if e.instruction_index in train_set),
                       z_floor=lowest_tcp(data))
    if config.collect.demos:
        trainer.data += trainer.collected(DEMOS_FILE, trainer.base)
    trainer.build()
    losses, t = run.train(trainer.net, trainer.opt, trainer.train_step, "policy")
    if run.stopped:
        return {"stopped_at": len(losses)}
    metrics: dict[str, Any] = {"train_loss": float(np.mean(losses[-50:])) if losses else None,
                               **trainer.test_metrics(test)}
    metrics.update({
        "train_episodes": len(train_k), "train_frames": config.train.frames,
        "test_episodes": len(test_k), "test_frames": metrics.pop("test_frames"),
        "collected_episodes": len(trainer.data) - len(train_k),
        "collected_frames": int(sum(len(d["frames"]) for d in trainer.data[len(train_k):])),
        "families": list(config.families), "steps": total_steps, "seed": config.train.seed, "device": str(dev), **t,
    })
    run.finish(trainer.net, metrics)
    return metrics


def for_action(config: PolicyConfig) -> PolicyConfig:
    """``config`` with what its action fixes: a ``waypoint`` policy predicts one waypoint per step
    (chunk 1, executed at once, no ensembling), and its cameras end in keypoints (waypoints are image
    positions); a ``steering`` policy's cameras are flattened."""
    if config.action == "waypoint":
        return replace(config, chunk=1, execute=1, model=replace(config.model, encoder="keypoints"),
                       inference=replace(config.inference, ensemble=None))
    return replace(config, model=replace(config.model, encoder="flatten"))


def fill_from_dataset(config: PolicyConfig, reader: Any, dataset: str | Path, image: int, train_k: Sequence[int],
                      data: Sequence[Mapping[str, np.ndarray]]) -> PolicyConfig:
    """``config`` with what the dataset says filled in: its path and catalogue (the scenes of
    collected episodes and of the evaluation come from it), the side of its camera images (``image``
    [px]), the state's length, the lowest TCP height of the training episodes (``inference.z_floor``),
    the steering values they hardly use (``inference.zero_channels``), their families and their
    episode and frame counts (``data``: their arrays)."""
    z_floor = lowest_tcp(data)
    # Steering values the demonstrations hardly use (top-down grasps tilt the gripper in about 1 % of
    # the frames): the policy sends zero there, as small predicted values added up to a tilt of
    # 3-58 degrees over an episode and put the fingers on the table.
    moving = np.abs(np.concatenate([d["steering"][:, :6] for d in data])) > 1e-3
    zero_channels = tuple(int(c) for c in np.flatnonzero(moving.mean(axis=0) < RARE_CHANNEL))
    state_dim = STATE_DIM + (TARGET_DIM if config.inputs == "state" else 0)
    return replace(
        config, dataset=str(dataset), catalogue=reader.catalogue, image=image,
        model=replace(config.model, state_dim=state_dim),
        inference=replace(config.inference, z_floor=round(z_floor, 6), zero_channels=zero_channels),
        families=tuple(sorted({reader.instruction(k)["family"] for k in train_k})),
        train=replace(config.train, episodes=len(train_k), frames=int(sum(len(d["frames"]) for d in data))))


def lowest_tcp(data: Sequence[Mapping[str, np.ndarray]]) -> float:
    """The lowest TCP height of the episodes' arrays ``data`` [m]."""
    return float(min(d["z"].min() for d in data))


@dataclass
class _Trainer:
    """The training of one policy: its samples (the dataset's and those collected), network and
    optimiser, and the DAgger rounds done.

    Attributes:
        config: the policy's config (filled from the dataset).
        out: the output folder (collected episodes are kept there).
        data: the training episodes' arrays; collected episodes are added.
        cameras: the cameras the network sees.
        dev: the torch device.
        workers: processes collecting episodes.
        say: prints a progress line.
        longest: frames of the longest training episode.
        z_floor: the lowest TCP height of the dataset's training episodes [m] (unrounded).
    """

    config: PolicyConfig
    out: Path
    data: list[dict[str, np.ndarray]]
    cameras: tuple[str, ...]
    dev: Any
    workers: int
    say: Callable[..., None]
    longest: int
    z_floor: float
    net: Any = None
    opt: Any = None
    index: list[tuple[int, int]] = field(default_factory=list)
    rounds_done: set[int] = field(default_factory=set)
    channel_weight: Any = None

    @property
    def base(self) -> CollectSpec:
        """The oracle episodes of ``collect.demos`` (a DAgger round's follow them)."""
        c = self.config
        return CollectSpec(episodes=c.collect.demos, seed=c.train.seed, families=c.families, image=max(c.image, 16),
                           cameras=self.cameras, noise=c.collect.noise, still=c.inference.zero_channels,
                           squeeze=c.action == "waypoint", catalogue=c.catalogue)

    def collected(self, name: str, spec: CollectSpec, policy_args: Any = None) -> list[dict[str, np.ndarray]]:
        """The episodes of ``spec`` as training arrays; the raw episodes are kept in ``out/name`` (a
        resumed run reads them instead of collecting again)."""
        path = self.out / name
        if path.exists():
            raw = load_arrays(path)
        else:
            self.say(f"collecting {spec.episodes} {'DAgger' if policy_args else 'oracle'} episodes in the "
                     f"environment ({name})")
            runner = waypoint_dagger_episode if policy_args and self.config.action == "waypoint" else None
            raw = collect(spec, workers=self.workers, policy_factory=dagger_policy if policy_args else None,
                          policy_args=policy_args, runner=runner)
            save_arrays(path, [{k: np.asarray(v) for k, v in e.items()} for e in raw])
        c = self.config
        return [collected_arrays(e, c.train.stride, c.tokens, self.cameras, c.action) for e in raw]

    def build(self) -> None:
        """The network (its state normalised with the training samples' mean and spread), the
        optimiser, the samples' index and the loss weight of each action value."""
        c = self.config
        states = np.concatenate([inputs_state(d, c.inputs) for d in self.data]).astype(np.float64)
        mean, std = states.mean(0), np.maximum(states.std(0), 1e-2)
        m = c.model
        self.net = BCNet(len(instruction_vocabulary()), max(c.image, 1), c.chunk, m.width, m.hidden,
                         state_dim=m.state_dim, cameras=len(self.cameras), encoder=m.encoder).to(self.dev)
        with torch.no_grad():
            self.net.state_mean.copy_(torch.as_tensor(mean, dtype=torch.float32))
            self.net.state_std.copy_(torch.as_tensor(std, dtype=torch.float32))
        self.opt = torch.optim.Adam(self.net.parameters(), lr=c.train.lr)
        self.index = [(i, j) for i, d in enumerate(self.data) for j in range(len(d["frames"]))]
        # A waypoint's position is wanted to millimetres in a displacement of up to WAYPOINT_SCALE; roll and
        # pitch are none.
        weights = [10.0] * 3 + [0.0, 0.0, 3.0] if c.action == "waypoint" else [1.0] * 6
        self.channel_weight = torch.as_tensor([*weights, c.train.gripper_weight], dtype=torch.float32,
                                              device=self.dev)

    def dagger_round(self, r: int) -> None:
        """Round ``r``: run the current policy (the oracle's action with probability 0.5 ** (r + 1))
        and add the states it visits, labelled by the oracle. An episode ends after twice the
        longest dataset episode's steps: the states of a policy that has lost its way are not
        worth the time."""
        state = {k: v.detach().cpu().clone() for k, v in self.net.state_dict().items()}
        base, col = self.base, self.config.collect
        spec = replace(base, episodes=col.dagger_episodes, noise=0.0, beta=0.5 ** (r + 1),
                       first=col.demos + r * col.dagger_episodes, max_steps=min(base.max_steps, 2 * self.longest))
        self.data.extend(self.collected(DAGGER_FILE.format(r), spec, (self.config, state)))
        self.index[:] = [(i, j) for i, d in enumerate(self.data) for j in range(len(d["frames"]))]
        self.rounds_done.add(r)

    def near(self, items: Sequence[Mapping[str, Any]], pairs: Sequence[tuple[int, int]]) -> np.ndarray:
        """Which samples' TCP is within :data:`NEAR_TABLE` of the lowest TCP height."""
        return np.array([items[i]["z"][int(items[i]["frames"][j])] < self.z_floor + NEAR_TABLE for i, j in pairs])

    def batch_of(self, items: Sequence[Mapping[str, Any]], pairs: Sequence[tuple[int, int]],
                 rng: np.random.Generator | None) -> tuple[list[Any], Any, Any, Any]:
        """(images per camera, tokens, states, target chunks) of the samples ``pairs``; with ``rng``,
        the images shifted at random by up to 4 px."""
        image, chunk, dev = self.config.image, self.config.chunk, self.dev
        imgs = {c: np.stack([items[i][c][j] for i, j in pairs]) for c in self.cameras}  # j: the sample's image
        if rng is not None:  # random shifts of up to 4 px
            for c in self.cameras:
                pad = np.pad(imgs[c], ((0, 0), (4, 4), (4, 4), (0, 0)), mode="edge")
                sh = rng.integers(0, 9, size=(len(pairs), 2))
                imgs[c] = np.stack([pad[n, a:a + image, b:b + image] for n, (a, b) in enumerate(sh)])
        ims = [torch.as_tensor(imgs[c].transpose(0, 3, 1, 2).astype(np.float32) / 255.0, device=dev)
               for c in self.cameras]
        toks = torch.as_tensor(np.stack([items[i]["tokens"] for i, _ in pairs]), device=dev)
        states, targets = [], []
        for i, j in pairs:
            d = items[i]
            t = int(d["frames"][j])
            states.append(inputs_state(d, self.config.inputs, t))
            idx = np.minimum(np.arange(t, t + chunk), len(d["steering"]) - 1)
            targets.append(d["steering"][idx])
        return (ims, toks, torch.as_tensor(np.stack(states), device=dev),
                torch.as_tensor(np.stack(targets), device=dev))

    def train_step(self, step: int) -> float:
        """Optimiser step ``step`` (after the DAgger rounds it is due for): a batch of shifted samples,
        the learning rate decaying linearly over the last two thirds."""
        tr, col = self.config.train, self.config.collect
        steps = tr.steps - col.dagger_rounds * col.dagger_steps  # before the first DAgger round
        for r in range(col.dagger_rounds):  # a resumed run loads the rounds its checkpoint has seen
            if r not in self.rounds_done and step >= steps + r * col.dagger_steps:
                self.dagger_round(r)
        self.net.train()
        rng = step_rng(tr.seed, step)
        for g in self.opt.param_groups:
            g["lr"] = tr.lr * min(1.0, 1.5 * (1 - step / tr.steps))
        pairs = [self.index[i] for i in rng.integers(len(self.index), size=tr.batch)]
        ims, toks, st, tgt = self.batch_of(self.data, pairs, rng)
        diff = (self.net(ims, toks, st) - tgt) * self.channel_weight
        err = (diff.square() if tr.loss == "mse" else diff.abs()).mean(dim=(1, 2))
        if tr.near_weight != 1.0:
            w = torch.as_tensor(np.where(self.near(self.data, pairs), tr.near_weight, 1.0), dtype=err.dtype,
                                device=self.dev)
            total = (err * w).sum() / w.sum()
        else:
            total = err.mean()
        return descend(self.opt, total)

    def test_metrics(self, test: Sequence[Mapping[str, Any]]) -> dict[str, float | int | list[float] | None]:
        """The test episodes' errors (see :func:`train_policy`) and ``test_frames``."""
        self.net.eval()
        chunk_err, first_err, zero_err, nears = [], [], [], []
        with torch.no_grad():
            tpairs = [(i, j) for i, d in enumerate(test) for j in range(len(d["frames"]))]
            for k in range(0, len(tpairs), 256):
                part = tpairs[k:k + 256]
                ims, toks, st, tgt = self.batch_of(test, part, None)
                diff = (self.net(ims, toks, st) - tgt).abs().cpu().numpy().astype(np.float64)
                chunk_err.append(diff.mean(axis=(1, 2)))
                zero_err.append(tgt[:, 0].abs().cpu().numpy().astype(np.float64))
                first_err.append(diff[:, 0])
                nears.append(self.near(test, part))
        if not tpairs:
            return {"test_l1": None, "test_l1_first": None, "test_frames": 0}
        ce, fe, nr = np.concatenate(chunk_err), np.concatenate(first_err), np.concatenate(nears)
        near_err, near_z = (float(ce[nr].mean()), float(fe[nr, 2].mean())) if nr.any() else (None, None)
        return {
            "test_l1": float(ce.mean()), "test_l1_first": float(fe.mean()),
            "test_l1_by_axis": [round(float(v), 5) for v in fe.mean(0)],
            "test_l1_by_axis_zero_action": [round(float(v), 5) for v in np.concatenate(zero_err).mean(0)],
            "test_l1_near_table": near_err, "test_z_near_table": near_z, "test_frames_near_table": int(nr.sum()),
            "test_frames": len(tpairs),
        }
