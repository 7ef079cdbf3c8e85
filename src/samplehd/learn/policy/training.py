"""Training the behaviour-cloning policy on a dataset (``samplehd train policy``), with demonstrations
collected in the environment: noise-injected (DART) and on-policy corrective (DAgger) episodes.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
from rich.console import Console

from samplehd.envs.tokens import instruction_vocabulary
from samplehd.errors import ConfigError
from samplehd.learn.data import open_dataset
from samplehd.learn.demos import OBS_KEYS, CollectSpec, collect, episode_rng, record_observation, run_episode
from samplehd.learn.policy.actions import WaypointExpert, _speeds
from samplehd.learn.policy.configuration import (
    ACTIONS,
    FORMAT,
    INPUTS,
    LOSSES,
    STATE_DIM,
    TARGET_DIM,
    PolicyArchitecture,
    PolicyCollection,
    PolicyConfig,
    PolicyInference,
    PolicyTraining,
)
from samplehd.learn.policy.inference import BCPolicy
from samplehd.learn.policy.keypose_training import train_keypose_policy
from samplehd.learn.policy.modeling import BCNet
from samplehd.learn.policy.preparation import (
    _collected_arrays,
    _episode_arrays,
    _image_size,
    _inputs_state,
    _load_arrays,
    _save_arrays,
    training_split,
)
from samplehd.learn.policy.processing import CAMERAS
from samplehd.learn.training import TrainRun, descend, pick_device, set_seed, step_rng, torch

__all__ = ["train_policy"]

DEMOS_FILE = "demos.npz"  # the oracle episodes collected in the environment (kept for a resumed run)
DAGGER_FILE = "dagger_{}.npz"  # the episodes of DAgger round N
NEAR_TABLE = 0.03  # frames whose TCP is within this of the demonstrations' lowest TCP height [m]
RARE_CHANNEL = 0.05  # a steering value that moves in fewer of the training frames is sent as zero


def _waypoint_dagger_episode(env: Any, oracle: Any, spec: CollectSpec, k: int, policy: Any) -> dict[str, Any] | None:
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
    speeds = _speeds(env)
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


def _dagger_policy(args: tuple[PolicyConfig, Mapping[str, Any]], env: Any) -> BCPolicy:
    """The policy a DAgger round runs in a collecting process (``args``: its config and weights)."""
    return BCPolicy(args[0], args[1], env)


def train_policy(dataset: str | Path, out: str | Path, steps: int = 4000, seed: int = 0, device: str | None = None,
                 quiet: bool = False, stop_after: int | None = None, batch: int | None = None, chunk: int = 8,
                 execute: int = 4, stride: int = 2,
                 lr: float = 1e-3, width: int = 16, hidden: int = 256, tokens: int = 32,
                 families: Sequence[str] | None = None, loss: str = "mse", near_weight: float = 1.0,
                 ensemble: float | None = None, floor: bool = True, gripper_weight: float = 1.0,
                 demos: int = 0, noise: float = 0.0, dagger_rounds: int = 0, dagger_episodes: int = 50,
                 dagger_steps: int = 1000, workers: int = 1, inputs: str = "rgb", action: str = "steering",
                 init: str | Path | None = None) -> dict[str, Any]:
    """Train the behaviour-cloning policy on a dataset's training episodes.

    With ``inputs="rgb"`` (the visuomotor policy) it sees both cameras' RGB, the instruction and the
    robot state; the dataset needs the cameras' RGB. With ``inputs="state"`` (the privileged-state
    reference) it sees no image but the target object's pose relative to the TCP besides the
    instruction and the robot state.

    The state input (joint positions, TCP position and orientation, finger opening) is normalised
    per dimension with the training frames' mean and standard deviation (kept in the model's
    buffers). ``near_weight`` weights the loss of frames whose TCP is within 3 cm of the lowest TCP
    height of the demonstrations (the grasps and releases near the table). ``ensemble`` and
    ``floor`` go into the config's ``inference`` options (see :class:`BCPolicy`).

    Metrics (``metrics.json``): ``train_loss`` (the loss over the chunk, last 50 steps), ``test_l1``
    (the test episodes' frames), ``test_l1_first`` (first action only), ``test_l1_by_axis`` (first
    action, per steering value), ``test_l1_near_table`` and ``test_z_near_table`` (the chunk's
    error and the first action's z error on test frames within 3 cm of the lowest TCP height),
    episode and frame counts.
    """

    if loss not in LOSSES:
        raise ConfigError(f"train_policy: loss={loss!r}; valid: {', '.join(LOSSES)}")
    if inputs not in INPUTS:
        raise ConfigError(f"train_policy: inputs={inputs!r}; valid: {', '.join(INPUTS)}")
    if action not in ACTIONS:
        raise ConfigError(f"train_policy: action={action!r}; valid: {', '.join(ACTIONS)}")
    if action == "keypose":
        if demos or dagger_rounds:
            raise ConfigError("train_policy: action='keypose' learns from the dataset's scene images and decisions: "
                              "no demos or DAgger rounds")
        return train_keypose_policy(dataset, out, steps=steps, seed=seed, device=device, quiet=quiet,
                                    stop_after=stop_after, batch=batch or 16, lr=lr, width=width,
                                    tokens=tokens, families=families, init=init, inputs=inputs)
    if init is not None:
        raise ConfigError(f"train_policy: init={init}: only a keypose policy starts from another's weights")
    batch = batch or 64
    if action == "waypoint":  # one waypoint per frame, predicted every step
        chunk, execute, ensemble = 1, 1, None
    # Waypoints are image positions: the waypoint policy's cameras end in keypoints.
    encoder = "keypoints" if action == "waypoint" else "flatten"
    reader = open_dataset(dataset)
    cameras = CAMERAS if inputs == "rgb" else ()
    image = _image_size(reader, dataset) if cameras else 0
    train_k, test_k = training_split(reader, dataset, families)
    dev = pick_device(device)
    set_seed(seed)
    data = [_episode_arrays(reader, k, stride, tokens, cameras, action) for k in train_k]
    test = [_episode_arrays(reader, k, stride * 4, tokens, cameras, action) for k in test_k]
    families_used = tuple(sorted({reader.instruction(k)["family"] for k in train_k}))
    train_set = set(train_k)
    longest = max(e.num_frames for e in reader.episodes if e.instruction_index in train_set)
    z_floor = float(min(d["z"].min() for d in data))
    # Steering values the demonstrations hardly use (top-down grasps tilt the gripper in about 1 % of
    # the frames): the policy sends zero there, as small predicted values added up to a tilt of
    # 3-58 degrees over an episode and put the fingers on the table.
    moving = np.abs(np.concatenate([d["steering"][:, :6] for d in data])) > 1e-3
    zero_channels = [int(c) for c in np.flatnonzero(moving.mean(axis=0) < RARE_CHANNEL)]
    total_steps = steps + dagger_rounds * dagger_steps
    state_dim = STATE_DIM + (TARGET_DIM if inputs == "state" else 0)
    # The scenes of collected episodes and of the evaluation come from the dataset's catalogue.
    catalogue = reader.catalogue
    config = PolicyConfig(
        format=FORMAT, dataset=str(dataset), catalogue=catalogue, inputs=inputs, action=action, image=image,
        chunk=chunk, execute=execute, tokens=tokens,
        model=PolicyArchitecture(width=width, hidden=hidden, state_dim=state_dim, encoder=encoder),
        inference=PolicyInference(ensemble=ensemble, z_floor=round(z_floor, 6) if floor else None,
                                  zero_channels=tuple(zero_channels)),
        families=families_used,
        collect=PolicyCollection(demos=demos, noise=noise, dagger_rounds=dagger_rounds,
                                 dagger_episodes=dagger_episodes, dagger_steps=dagger_steps),
        train=PolicyTraining(steps=total_steps, seed=seed, batch=batch, stride=stride, lr=lr, loss=loss,
                             near_weight=near_weight, gripper_weight=gripper_weight, episodes=len(train_k),
                             frames=int(sum(len(d["frames"]) for d in data))))
    run = TrainRun(Path(out), config.to_dict(), total_steps, checkpoint_every=max(50, total_steps // 20), quiet=quiet,
                   stop_after=stop_after)
    run.prepare()
    say = Console(stderr=True, quiet=quiet).print

    def collected(name: str, spec: CollectSpec, policy_args: Any = None) -> list[dict[str, np.ndarray]]:
        """The episodes of ``spec`` as training arrays; the raw episodes are kept in ``out/name`` (a
        resumed run reads them instead of collecting again)."""
        path = Path(out) / name
        if path.exists():
            raw = _load_arrays(path)
        else:
            say(f"collecting {spec.episodes} {'DAgger' if policy_args else 'oracle'} episodes in the environment "
                f"({name})")
            runner = _waypoint_dagger_episode if policy_args and action == "waypoint" else None
            raw = collect(spec, workers=workers, policy_factory=_dagger_policy if policy_args else None,
                          policy_args=policy_args, runner=runner)
            _save_arrays(path, [{k: np.asarray(v) for k, v in e.items()} for e in raw])
        return [_collected_arrays(e, stride, tokens, cameras, action) for e in raw]

    base = CollectSpec(episodes=demos, seed=seed, families=families_used, image=max(image, 16), cameras=cameras,
                       noise=noise, still=tuple(zero_channels), squeeze=action == "waypoint", catalogue=catalogue)
    if demos:
        data += collected(DEMOS_FILE, base)
    states = np.concatenate([_inputs_state(d, inputs) for d in data]).astype(np.float64)
    mean, std = states.mean(0), np.maximum(states.std(0), 1e-2)
    net = BCNet(len(instruction_vocabulary()), max(image, 1), chunk, width, hidden, state_dim=state_dim,
                cameras=len(cameras), encoder=encoder).to(dev)
    with torch.no_grad():
        net.state_mean.copy_(torch.as_tensor(mean, dtype=torch.float32))
        net.state_std.copy_(torch.as_tensor(std, dtype=torch.float32))
    opt = torch.optim.Adam(net.parameters(), lr=lr)
    index = [(i, j) for i, d in enumerate(data) for j in range(len(d["frames"]))]
    rounds_done: set[int] = set()
    # A waypoint's position is wanted to millimetres in a displacement of up to WAYPOINT_SCALE; roll and pitch are none.
    weights = [10.0] * 3 + [0.0, 0.0, 3.0] if action == "waypoint" else [1.0] * 6
    channel_weight = torch.as_tensor([*weights, gripper_weight], dtype=torch.float32, device=dev)

    def dagger_round(r: int) -> None:
        """Round ``r``: run the current policy (the oracle's action with probability 0.5 ** (r + 1))
        and add the states it visits, labelled by the oracle. An episode ends after twice the
        longest dataset episode's steps: the states of a policy that has lost its way are not
        worth the time."""
        state = {k: v.detach().cpu().clone() for k, v in net.state_dict().items()}
        spec = replace(base, episodes=dagger_episodes, noise=0.0, beta=0.5 ** (r + 1),
                       first=demos + r * dagger_episodes, max_steps=min(base.max_steps, 2 * longest))
        data.extend(collected(DAGGER_FILE.format(r), spec, (config, state)))
        index[:] = [(i, j) for i, d in enumerate(data) for j in range(len(d["frames"]))]
        rounds_done.add(r)

    def near(items: Sequence[Mapping[str, Any]], pairs: Sequence[tuple[int, int]]) -> np.ndarray:
        return np.array([items[i]["z"][int(items[i]["frames"][j])] < z_floor + NEAR_TABLE for i, j in pairs])

    def batch_of(items: Sequence[Mapping[str, Any]], pairs: Sequence[tuple[int, int]],
                 rng: np.random.Generator | None) -> tuple[list[Any], Any, Any, Any]:
        imgs = {c: np.stack([items[i][c][j] for i, j in pairs]) for c in cameras}  # j: the sample's image
        if rng is not None:  # random shifts of up to 4 px
            for c in cameras:
                pad = np.pad(imgs[c], ((0, 0), (4, 4), (4, 4), (0, 0)), mode="edge")
                sh = rng.integers(0, 9, size=(len(pairs), 2))
                imgs[c] = np.stack([pad[n, a:a + image, b:b + image] for n, (a, b) in enumerate(sh)])
        ims = [torch.as_tensor(imgs[c].transpose(0, 3, 1, 2).astype(np.float32) / 255.0, device=dev)
               for c in cameras]
        toks = torch.as_tensor(np.stack([items[i]["tokens"] for i, _ in pairs]), device=dev)
        states, targets = [], []
        for i, j in pairs:
            d = items[i]
            t = int(d["frames"][j])
            states.append(_inputs_state(d, inputs, t))
            idx = np.minimum(np.arange(t, t + chunk), len(d["steering"]) - 1)
            targets.append(d["steering"][idx])
        return (ims, toks, torch.as_tensor(np.stack(states), device=dev),
                torch.as_tensor(np.stack(targets), device=dev))

    def train_step(step: int) -> float:
        for r in range(dagger_rounds):  # a resumed run loads the rounds its checkpoint has seen
            if r not in rounds_done and step >= steps + r * dagger_steps:
                dagger_round(r)
        net.train()
        rng = step_rng(seed, step)
        for g in opt.param_groups:
            g["lr"] = lr * min(1.0, 1.5 * (1 - step / total_steps))
        pairs = [index[i] for i in rng.integers(len(index), size=batch)]
        ims, toks, st, tgt = batch_of(data, pairs, rng)
        diff = (net(ims, toks, st) - tgt) * channel_weight
        err = (diff.square() if loss == "mse" else diff.abs()).mean(dim=(1, 2))
        if near_weight != 1.0:
            w = torch.as_tensor(np.where(near(data, pairs), near_weight, 1.0), dtype=err.dtype, device=dev)
            total = (err * w).sum() / w.sum()
        else:
            total = err.mean()
        return descend(opt, total)

    losses, t = run.train(net, opt, train_step, "policy")
    if run.stopped:
        return {"stopped_at": len(losses)}
    net.eval()
    chunk_err, first_err, zero_err, nears = [], [], [], []
    with torch.no_grad():
        tpairs = [(i, j) for i, d in enumerate(test) for j in range(len(d["frames"]))]
        for k in range(0, len(tpairs), 256):
            part = tpairs[k:k + 256]
            ims, toks, st, tgt = batch_of(test, part, None)
            diff = (net(ims, toks, st) - tgt).abs().cpu().numpy().astype(np.float64)
            chunk_err.append(diff.mean(axis=(1, 2)))
            zero_err.append(tgt[:, 0].abs().cpu().numpy().astype(np.float64))
            first_err.append(diff[:, 0])
            nears.append(near(test, part))
    metrics: dict[str, Any] = {"train_loss": float(np.mean(losses[-50:])) if losses else None}
    if tpairs:
        ce, fe, nr = np.concatenate(chunk_err), np.concatenate(first_err), np.concatenate(nears)
        near_err, near_z = (float(ce[nr].mean()), float(fe[nr, 2].mean())) if nr.any() else (None, None)
        metrics.update({
            "test_l1": float(ce.mean()), "test_l1_first": float(fe.mean()),
            "test_l1_by_axis": [round(float(v), 5) for v in fe.mean(0)],
            "test_l1_by_axis_zero_action": [round(float(v), 5) for v in np.concatenate(zero_err).mean(0)],
            "test_l1_near_table": near_err, "test_z_near_table": near_z, "test_frames_near_table": int(nr.sum()),
        })
    else:
        metrics.update({"test_l1": None, "test_l1_first": None})
    metrics.update({
        "train_episodes": len(train_k), "train_frames": config.train.frames,
        "test_episodes": len(test_k), "test_frames": len(tpairs),
        "collected_episodes": len(data) - len(train_k),
        "collected_frames": int(sum(len(d["frames"]) for d in data[len(train_k):])),
        "families": list(config.families), "steps": total_steps, "seed": seed, "device": str(dev), **t,
    })
    run.finish(net, metrics)
    return metrics
