"""Visuomotor behaviour cloning: scene and wrist camera RGB + instruction tokens + robot state →
the next ``chunk`` steering vectors of the dataset (SAMPLE-HD's 7-D steering, action chunking).

The network: one small CNN per camera whose last block is FiLM-modulated by the instruction (a GRU
over the token ids of :mod:`samplehd.envs.tokens`), a state MLP over the robot state normalised per
dimension (joint positions, TCP position and orientation, finger opening), and an MLP head that
writes ``chunk`` × 7 values in [-1, 1]. Training samples frames of the dataset's training episodes
(random shifts of the images, as in DrQ), minimises the squared error to the recorded chunk, and
reports the test episodes' error. The squared error, not the L1 error of the first version: more
than half of the frames hold the TCP still along x and y, so the L1 error's optimum under
uncertainty (the median) is a zero velocity, and an L1-trained policy barely moved.

In the environment, :class:`BCPolicy` predicts a chunk and executes its first ``execute`` actions
before looking again (or, with ``inference.ensemble``, averages every chunk's action for the step);
with ``inference.z_floor`` it keeps its TCP target at or above the lowest TCP height of its
demonstrations.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
from rich.console import Console

from samplehd.dataset.container import camera_settings
from samplehd.envs.levels import episode_level, held_out_instruction
from samplehd.envs.tokens import encode_instruction, instruction_vocabulary
from samplehd.errors import ConfigError
from samplehd.learn.data import open_dataset
from samplehd.learn.demos import (
    OBS_KEYS,
    CollectSpec,
    collect,
    episode_rng,
    record_observation,
    run_episode,
    squeeze_command,
)
from samplehd.learn.options import POLICY_CAMERAS, env_options, env_options_from_config
from samplehd.learn.policy_configuration import (
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
from samplehd.learn.training import (
    TrainRun,
    descend,
    load_model_files,
    nn,
    pick_device,
    read_model_config,
    set_seed,
    step_rng,
    torch,
)

__all__ = ["BCPolicy", "PolicyConfig", "env_options", "policy_for_evaluation", "train_policy"]

CAMERAS = POLICY_CAMERAS
DEMOS_FILE = "demos.npz"  # the oracle episodes collected in the environment (kept for a resumed run)
DAGGER_FILE = "dagger_{}.npz"  # the episodes of DAgger round N
NEAR_TABLE = 0.03  # frames whose TCP is within this of the demonstrations' lowest TCP height [m]
RARE_CHANNEL = 0.05  # a steering value that moves in fewer of the training frames is sent as zero
# Waypoint actions: the network writes the displacement to the waypoint divided by this [m] ...
WAYPOINT_SCALE = 0.3
# ... and a frame this close to its segment's end (position [m], yaw [rad], finger opening [m]) is
# labelled with the next segment's waypoint: the switch a waypoint follower makes.
WAYPOINT_REACHED = (0.004, 0.05, 0.002)
WAYPOINT_AHEAD = 0.05  # the waypoint of a motion the episode's end cut short lies this far ahead [m]
WAYPOINT_GAIN = 3.0  # TCP velocity per metre of the remaining displacement [1/s]
WAYPOINT_SPEED = 0.16  # largest TCP speed of the waypoint follower [m/s]
YAW_GAIN = 3.0  # yaw rate per radian of the remaining yaw [1/s]
CLOSE_BELOW = -0.9  # a predicted gripper command below this closes the gripper (the label is -1)


def _rotation_columns(quat: np.ndarray) -> np.ndarray:
    """The first two columns of the rotation matrix of quaternions (..., 4: w x y z), as (..., 6).

    Unlike the quaternion, they do not change sign between q and -q, and are continuous in the pose.
    """
    q = np.asarray(quat, dtype=np.float64)
    q = q / np.linalg.norm(q, axis=-1, keepdims=True)
    w, x, y, z = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    return np.stack([1 - 2 * (y * y + z * z), 2 * (x * y + w * z), 2 * (x * z - w * y),
                     2 * (x * y - w * z), 1 - 2 * (x * x + z * z), 2 * (y * z + w * x)], axis=-1)


def _state(joint_pos: np.ndarray, tcp_pos: np.ndarray, tcp_quat: np.ndarray, opening: np.ndarray,
           joint_vel: np.ndarray, last_gripper: np.ndarray) -> np.ndarray:
    """The policy's raw state vector(s); the network normalises it per dimension."""
    opening = np.asarray(opening, np.float64)[..., None]
    last_gripper = np.asarray(last_gripper, np.float64)[..., None]
    return np.concatenate([np.asarray(joint_pos, np.float64), np.asarray(tcp_pos, np.float64),
                           _rotation_columns(tcp_quat), opening, np.asarray(joint_vel, np.float64), last_gripper],
                          axis=-1).astype(np.float32)


def _target_features(tcp_pos: np.ndarray, object_pos: np.ndarray, object_quat: np.ndarray,
                     target: np.ndarray) -> np.ndarray:
    """Per frame: the target object's position relative to the TCP and its rotation columns (zeros
    when a frame has no target)."""
    target = np.asarray(target, int)
    rows = np.arange(len(target))
    idx = np.maximum(target, 0)
    rel = np.asarray(object_pos, np.float64)[rows, idx] - np.asarray(tcp_pos, np.float64)
    out = np.concatenate([rel, _rotation_columns(np.asarray(object_quat, np.float64)[rows, idx])], axis=1)
    out[target < 0] = 0.0
    return out.astype(np.float32)


def moving_frames(steering: np.ndarray, tolerance: float = 1e-3) -> np.ndarray:
    """Indices of the frames a policy learns from: every frame but the waits.

    A wait is a frame whose TCP velocity is zero and whose gripper command equals the previous
    frame's (the demonstrations hold still between subtasks). Its observation looks like its
    neighbours', so a policy cannot tell how long to wait and imitating it stalls; leaving the
    waits out makes the next motion the label of the frame before it.
    """
    steering = np.asarray(steering, np.float64)
    still = np.abs(steering[:, :6]).max(axis=1) < tolerance
    same_grip = np.r_[False, np.abs(np.diff(steering[:, 6])) < tolerance]
    keep = ~(still & same_grip)
    keep[0] = True
    return np.flatnonzero(keep)


def _yaw(quat: np.ndarray) -> np.ndarray:
    """The heading of the TCP's x axis about the world z axis [rad]."""
    cols = _rotation_columns(quat)
    return np.arctan2(cols[..., 1], cols[..., 0])


def _wrap(angle: np.ndarray) -> np.ndarray:
    return (np.asarray(angle) + np.pi) % (2 * np.pi) - np.pi


def waypoints(steering: np.ndarray, tcp_pos: np.ndarray, tcp_quat: np.ndarray, opening: np.ndarray,
              tolerance: float = 1e-3) -> np.ndarray:
    """Per frame of an episode, its waypoint (T, 5): TCP position (3, world) [m], yaw [rad] and the
    gripper there (+1 open, -1 closed).

    The demonstration is cut into segments: runs of frames that move the TCP (cut where it all but
    stops and sets off again), and runs that hold it and change the gripper command (the waits
    between them belong to no segment). A segment's waypoint is the state it ends in, read where the
    next one starts (the TCP has settled in the wait), with the gripper -1 (closing) after a segment
    that closes it, else the oracle's command at its end (the width it opened to). A frame's label
    is the waypoint of its segment, of the next segment once it is within :data:`WAYPOINT_REACHED`
    of its own (a wait's: the next segment's); after the last segment, the last waypoint
    (:data:`WAYPOINT_AHEAD` beyond the end of a motion the episode's end cut short). So a
    follower that goes to the predicted waypoint and switches where the demonstrations switch meets
    a label at every state on the way, and no label depends on time.
    """
    steering = np.asarray(steering, np.float64)
    tcp = np.asarray(tcp_pos, np.float64)
    yaw = _yaw(tcp_quat)
    opening = np.asarray(opening, np.float64)
    n = len(steering)
    moving = np.abs(steering[:, :6]).max(axis=1) >= tolerance
    gripping = np.r_[False, np.abs(np.diff(steering[:, 6])) >= tolerance] & ~moving
    kind = np.where(moving, 1, np.where(gripping, 2, 0))
    # A motion also ends where the TCP all but stops and sets off again (a joint-space move to the
    # pre-grasp pose, then the straight descent).
    speed = np.sqrt((steering[:, :3] ** 2).sum(axis=1))
    cut = np.zeros(n, bool)
    cut[2:] = (speed[1:-1] < 0.05) & (speed[1:-1] <= speed[:-2]) & (speed[1:-1] < speed[2:])
    segments: list[tuple[int, int, int]] = []  # (first frame, last frame, kind)
    t = 0
    while t < n:
        if kind[t] == 0:
            t += 1
            continue
        e = t
        while e + 1 < n and kind[e + 1] == kind[t] and not cut[e + 1]:
            e += 1
        segments.append((t, e, int(kind[t])))
        t = e + 1
    out = np.empty((n, 5))
    if not segments:
        out[:, :3], out[:, 3], out[:, 4] = tcp, yaw, 1.0
        return out
    settled = [segments[j + 1][0] if j + 1 < len(segments) else n - 1 for j in range(len(segments))]
    # The gripper: -1 (close: squeeze_command) after a segment that closes it, else the oracle's
    # command (the width it opened to).
    closed, grippers = False, []
    for a, e, k in segments:
        change = steering[e, 6] - steering[max(a - 1, 0), 6]
        if k == 2 and abs(change) >= tolerance:
            closed = bool(change < 0)
        grippers.append(-1.0 if closed else float(steering[e, 6]))
    goal = np.array([[*tcp[f], yaw[f], g] for f, g in zip(settled, grippers, strict=True)])
    last = segments[-1]
    if last[2] == 1 and last[1] == n - 1:
        # The episode ended while this segment moved (the environment ends a successful episode at once,
        # in the middle of the lift): its waypoint lies ahead, where the motion was heading.
        heading = steering[n - 1, :3] / max(float(np.sqrt((steering[n - 1, :3] ** 2).sum())), 1e-9)
        goal[-1, :3] = tcp[n - 1] + WAYPOINT_AHEAD * heading
    pos_tol, yaw_tol, open_tol = WAYPOINT_REACHED

    def reached(t: int, j: int) -> bool:
        if segments[j][2] == 1:
            return bool(np.linalg.norm(goal[j, :3] - tcp[t]) < pos_tol and abs(_wrap(goal[j, 3] - yaw[t])) < yaw_tol)
        return bool(abs(opening[settled[j]] - opening[t]) < open_tol)

    j = 0
    for t in range(n):
        while j < len(segments) and t > segments[j][1]:
            j += 1
        k = j
        while k < len(segments) and t >= segments[k][0] and reached(t, k):
            k += 1
        out[t] = goal[min(k, len(segments) - 1)]
    return out


class WaypointExpert:
    """The waypoints of one demonstration (rows of :func:`waypoints`, distinct, in order) as an expert
    for any state of its episode: :meth:`label` is the waypoint of the phase the arm is in, and the
    phase advances where the labels switch (within :data:`WAYPOINT_REACHED`; a closing waypoint once
    the fingers stop). A waypoint (the grasp pose the oracle chose, where it lifts to) does not depend
    on where the arm is, so the label of a state off the demonstration's path is still right: the
    DAgger labeller of the waypoint policy."""

    def __init__(self, goals: np.ndarray) -> None:
        self.goals = np.asarray(goals, np.float64)
        self.phase = 0
        self._opening: float | None = None

    @classmethod
    def of_episode(cls, steering: np.ndarray, tcp_pos: np.ndarray, tcp_quat: np.ndarray,
                   opening: np.ndarray) -> WaypointExpert:
        goal = waypoints(steering, tcp_pos, tcp_quat, opening)
        distinct = [goal[0]] + [g for a, g in zip(goal[:-1], goal[1:], strict=True) if np.abs(g - a).max() > 1e-9]
        return cls(np.array(distinct))

    def label(self, obs: Mapping[str, Any]) -> np.ndarray:
        """The waypoint for ``obs``, after advancing the phase on it."""
        goal = self.goals[self.phase]
        opening = float(obs["gripper"][0]) + float(obs["gripper"][1])
        closing = goal[4] < CLOSE_BELOW and (self.phase == 0 or self.goals[self.phase - 1][4] >= CLOSE_BELOW)
        if closing:
            reached = self._opening is not None and abs(opening - self._opening) < 1e-4
        else:
            pos_tol, yaw_tol, _ = WAYPOINT_REACHED
            reached = bool(np.linalg.norm(goal[:3] - np.asarray(obs["tcp_pos"], float)) < pos_tol
                           and abs(_wrap(goal[3] - _yaw(np.asarray(obs["tcp_quat"], float)))) < yaw_tol)
        self._opening = opening
        if reached and self.phase < len(self.goals) - 1:
            self.phase += 1
        return self.goals[self.phase]

    def action(self, obs: Mapping[str, Any], goal: np.ndarray, speeds: tuple[float, float]) -> np.ndarray:
        """The follower's steering vector toward ``goal``."""
        target = waypoint_targets(goal[None], np.asarray(obs["tcp_pos"])[None], np.asarray(obs["tcp_quat"])[None])[0]
        return np.clip(_follow(target, obs["gripper"], speeds), -1.0, 1.0)


def follow_waypoints(env: Any, obs: Mapping[str, Any], goals: np.ndarray, max_steps: int) -> dict[str, Any]:
    """Drive the environment (reset by the caller, ``obs`` its observation) through ``goals``, the
    distinct waypoints of a demonstration of its episode, with the waypoint policy's follower and the
    switches of :class:`WaypointExpert`. What a perfect waypoint policy does: the check that the labels
    can be acted on. Returns the last step's info.
    """
    expert = WaypointExpert(goals)
    speeds = _speeds(env)
    info: dict[str, Any] = {}
    for _ in range(max_steps):
        action = expert.action(obs, expert.label(obs), speeds)
        obs, _, terminated, truncated, info = env.step(action.astype(np.float32))
        if terminated or truncated:
            break
    return info


def _speeds(env: Any) -> tuple[float, float]:
    """TCP speed and angular speed of a steering value of 1 in ``env`` [m/s, rad/s]."""
    control = getattr(getattr(env, "unwrapped", None), "control", None)
    if control is None:
        return (0.25, 1.0)
    return (float(control.max_linear_speed), float(control.max_angular_speed))


def _follow(out: np.ndarray, gripper: Any, speeds: tuple[float, float]) -> np.ndarray:
    """The steering vector that moves toward the waypoint ``out`` (:func:`waypoint_targets`): a TCP
    velocity of :data:`WAYPOINT_GAIN` times the displacement, at most :data:`WAYPOINT_SPEED`, a yaw rate
    of :data:`YAW_GAIN` times the remaining yaw; the gripper closing (:func:`squeeze_command`) where
    the predicted command is below :data:`CLOSE_BELOW`, else the predicted command."""
    lin_speed, ang_speed = speeds
    v = WAYPOINT_GAIN * WAYPOINT_SCALE * np.asarray(out[:3], np.float64)
    speed = float(np.sqrt((v * v).sum()))
    if speed > WAYPOINT_SPEED:
        v *= WAYPOINT_SPEED / speed
    action = np.zeros(7)
    action[:3] = v / lin_speed
    action[5] = YAW_GAIN * np.pi * float(out[5]) / ang_speed
    action[6] = squeeze_command(gripper) if out[6] < CLOSE_BELOW else float(out[6])
    return action


def waypoint_targets(goal: np.ndarray, tcp_pos: np.ndarray, tcp_quat: np.ndarray) -> np.ndarray:
    """The network's targets (T, 7) of frames with waypoints ``goal`` (:func:`waypoints`): the
    displacement to the waypoint over :data:`WAYPOINT_SCALE` (clipped to [-1, 1]), no roll or pitch,
    the remaining yaw over pi, the gripper command."""
    goal = np.asarray(goal, np.float64)
    out = np.zeros((len(goal), 7))
    out[:, :3] = np.clip((goal[:, :3] - np.asarray(tcp_pos, np.float64)) / WAYPOINT_SCALE, -1.0, 1.0)
    out[:, 5] = _wrap(goal[:, 3] - _yaw(tcp_quat)) / np.pi
    out[:, 6] = goal[:, 4]
    return out.astype(np.float32)


class Encoder(nn.Module):
    """A camera's CNN; its last block is FiLM-modulated by the instruction code ``c``."""

    def __init__(self, w: int, cond: int) -> None:
        super().__init__()
        self.convs = nn.Sequential(
            nn.Conv2d(3, w, 3, stride=2, padding=1), nn.GroupNorm(8, w), nn.ReLU(inplace=True),
            nn.Conv2d(w, 2 * w, 3, stride=2, padding=1), nn.GroupNorm(8, 2 * w), nn.ReLU(inplace=True),
            nn.Conv2d(2 * w, 2 * w, 3, stride=2, padding=1), nn.GroupNorm(8, 2 * w))
        self.film = nn.Linear(cond, 4 * w)
        self.out = nn.Sequential(nn.ReLU(inplace=True), nn.Conv2d(2 * w, 2 * w, 3, stride=2, padding=1),
                                 nn.ReLU(inplace=True), nn.Flatten())

    def forward(self, x: torch.Tensor, c: torch.Tensor) -> torch.Tensor:
        h = self.convs(x)
        gamma, beta = self.film(c).chunk(2, dim=1)
        h = h * (1 + gamma[:, :, None, None]) + beta[:, :, None, None]
        return self.out(h)


class KeypointEncoder(nn.Module):
    """A camera's CNN that ends in a spatial softmax (Levine et al., 2016): each of ``keypoints``
    feature maps becomes the image position of its mass (x, y in [-1, 1]), read after the features
    are FiLM-modulated by the instruction code ``c``, so that the positions can follow the object
    the instruction names. Writes the positions and the average of the modulated features."""

    def __init__(self, w: int, cond: int, keypoints: int = 32) -> None:
        super().__init__()
        self.convs = nn.Sequential(
            nn.Conv2d(3, w, 3, stride=2, padding=1), nn.GroupNorm(8, w), nn.ReLU(inplace=True),
            nn.Conv2d(w, 2 * w, 3, stride=2, padding=1), nn.GroupNorm(8, 2 * w), nn.ReLU(inplace=True),
            nn.Conv2d(2 * w, 2 * w, 3, padding=1), nn.GroupNorm(8, 2 * w))
        self.film = nn.Linear(cond, 4 * w)
        self.points = nn.Conv2d(2 * w, keypoints, 1)
        self.features = 2 * keypoints + 2 * w

    def forward(self, x: torch.Tensor, c: torch.Tensor) -> torch.Tensor:
        h = self.convs(x)
        gamma, beta = self.film(c).chunk(2, dim=1)
        h = torch.relu(h * (1 + gamma[:, :, None, None]) + beta[:, :, None, None])
        maps = self.points(h)
        n, k, rows, cols = maps.shape
        weights = torch.softmax(maps.view(n, k, rows * cols), dim=2).view(n, k, rows, cols)
        ys = torch.linspace(-1.0, 1.0, rows, device=x.device, dtype=x.dtype)
        xs = torch.linspace(-1.0, 1.0, cols, device=x.device, dtype=x.dtype)
        px = (weights.sum(dim=2) * xs).sum(dim=2)
        py = (weights.sum(dim=3) * ys).sum(dim=2)
        return torch.cat([px, py, h.mean(dim=(2, 3))], dim=1)


class BCNet(nn.Module):
    """Images + instruction tokens + robot state → ``chunk`` steering vectors in [-1, 1]."""

    def __init__(self, vocab: int, image: int, chunk: int, width: int, hidden: int, state_dim: int = STATE_DIM,
                 normalise: bool = True, cameras: int = len(CAMERAS), encoder: str = "flatten") -> None:
        super().__init__()
        self.chunk = chunk
        self.normalise = normalise
        if normalise:  # per-dimension mean and spread of the training frames' states (set before training)
            self.register_buffer("state_mean", torch.zeros(state_dim))
            self.register_buffer("state_std", torch.ones(state_dim))
        self.embed = nn.Embedding(vocab, 64, padding_idx=0)
        self.text = nn.GRU(64, 128, batch_first=True)
        if encoder == "keypoints":
            self.encoders = nn.ModuleList([KeypointEncoder(width, 128) for _ in range(cameras)])
            feat = KeypointEncoder(width, 128).features
        else:
            self.encoders = nn.ModuleList([Encoder(width, 128) for _ in range(cameras)])
            side = image
            for _ in range(4):
                side = (side + 1) // 2
            feat = 2 * width * side * side
        self.state = nn.Sequential(nn.Linear(state_dim, 64), nn.ReLU(inplace=True))
        self.head = nn.Sequential(nn.Linear(cameras * feat + 64 + 128, hidden), nn.ReLU(inplace=True),
                                  nn.Linear(hidden, hidden), nn.ReLU(inplace=True), nn.Linear(hidden, chunk * 7))

    def forward(self, images: Sequence[torch.Tensor], tokens: torch.Tensor, state: torch.Tensor) -> torch.Tensor:
        lengths = (tokens != 0).sum(1).clamp(min=1).cpu()
        packed = nn.utils.rnn.pack_padded_sequence(self.embed(tokens), lengths, batch_first=True,
                                                   enforce_sorted=False)
        _, h = self.text(packed)
        c = h[-1]
        feats = [enc(img, c) for enc, img in zip(self.encoders, images, strict=True)]
        if self.normalise:
            state = (state - self.state_mean) / self.state_std
        out = self.head(torch.cat([*feats, self.state(state), c], 1))
        return torch.tanh(out).view(-1, self.chunk, 7)


class BCPolicy:
    """The trained policy acting in an environment with ``env_options(folder)``.

    Without ``inference.ensemble`` in its config it predicts a chunk and executes the first
    ``execute`` actions before looking again; with it (ACT's temporal ensembling) it predicts a chunk
    every step and executes the weighted mean of every chunk's action for this step, weights
    ``exp(-ensemble * i)`` from the oldest (i = 0). With ``inference.z_floor`` it never moves its TCP
    target below that height (the lowest TCP height of its training demonstrations [m]): the z
    velocity is raised where it would.

    Args:
        config: the trained model's config (a JSON object is read with :meth:`PolicyConfig.from_dict`).
        state: its state dict (None: an untrained network).
        env: the environment (checked: steering control, both cameras at the trained size).
    """

    def __init__(self, config: PolicyConfig | Mapping[str, Any], state: Mapping[str, Any] | None, env: Any = None,
                 device: Any = None) -> None:
        config = config if isinstance(config, PolicyConfig) else PolicyConfig.from_dict(config)
        set_seed(config.train.seed)
        self.config = config
        self.device = device or torch.device("cpu")
        m = config.model
        self.inputs = config.inputs
        self.cameras = CAMERAS if self.inputs == "rgb" else ()
        self.action = config.action
        self.net = BCNet(len(instruction_vocabulary()), max(config.image, 1), config.chunk, m.width, m.hidden,
                         state_dim=m.state_dim, cameras=len(self.cameras), encoder=m.encoder).to(self.device)
        self.env = env.unwrapped if env is not None else None
        if state is not None:
            self.net.load_state_dict(state)
        self.net.eval()
        self.chunk = config.chunk
        self.execute = config.execute
        self.ensemble = config.inference.ensemble
        self.z_floor = config.inference.z_floor
        self.zero_channels = list(config.inference.zero_channels)
        self._lin_step = 0.25 / 20.0  # TCP travel of a steering value of 1 in one control step [m]
        self._speeds = _speeds(env)  # TCP speed and angular speed of a steering value of 1 [m/s, rad/s]
        self._queue: list[np.ndarray] = []
        self._chunks: list[np.ndarray] = []
        self._z: float | None = None
        self._last_gripper = 1.0
        self._start: np.ndarray | None = None
        if env is not None:
            c = env.unwrapped.config
            want = env_options_from_config(config)
            got = {"obs_mode": c.obs_mode, "cameras": list(c.cameras), "width": c.width, "height": c.height,
                   "control_mode": c.control_mode}
            bad = [k for k in want if want[k] != got[k]]
            if bad:
                raise ConfigError(f"policy=bc: the environment's {bad[0]}={got[bad[0]]!r}, the policy needs "
                                  f"{want[bad[0]]!r} (options: {want})", field="policy")
            control = getattr(env.unwrapped, "control", None)
            if control is not None:
                self._lin_step = float(control.max_linear_speed) / float(control.control_hz)

    @classmethod
    def load(cls, folder: str | Path | None, env: Any = None) -> BCPolicy:
        if folder is None:
            raise ConfigError("policy=bc: needs `models` (the folder of `samplehd train policy`)", field="policy")
        config, state = load_model_files(folder, "policy", FORMAT)
        return cls(read_model_config(PolicyConfig, config, folder), state, env)

    def reset(self, seed: int | None = None) -> None:
        self._queue = []
        self._chunks = []
        self._z = None
        self._last_gripper = 1.0
        self._start = None

    def _state(self, obs: Mapping[str, Any]) -> np.ndarray:
        g = np.asarray(obs["gripper"], dtype=float)
        robot = _state(np.asarray(obs["joint_pos"], float), np.asarray(obs["tcp_pos"], float),
                       np.asarray(obs["tcp_quat"], float), g[0] + g[1], _joint_vel(self.action, obs["joint_vel"]),
                       self._last_gripper)
        if self.inputs != "state":
            return robot
        target = np.array([self._target(obs)])
        feats = _target_features(np.asarray(obs["tcp_pos"], float)[None], np.asarray(obs["object_pos"])[None],
                                 np.asarray(obs["object_quat"])[None], target)[0]
        return np.concatenate([robot, feats]).astype(np.float32)

    def _target(self, obs: Mapping[str, Any]) -> int:
        """The privileged reference's target: the task object the gripper holds, else the first task
        object still within 3 cm of where it started (-1: none, or no environment)."""
        env = self.env
        if env is None or getattr(env, "task", None) is None:
            return -1
        objects = [int(i) for i in env.task.objects]
        held = env.assist.active if env.assist is not None else -1
        if held in objects:
            return held
        pos = np.asarray(obs["object_pos"], float)
        if self._start is None:
            self._start = pos.copy()
        for i in objects:
            if float(np.sqrt(((pos[i] - self._start[i]) ** 2).sum())) < 0.03:
                return i
        return objects[-1] if objects else -1

    def predict(self, obs: Mapping[str, Any]) -> np.ndarray:
        """The chunk (chunk, 7) for one observation of the environment."""

        imgs = [torch.as_tensor(np.ascontiguousarray(obs[f"{c}_rgb"]).transpose(2, 0, 1)[None].astype(np.float32)
                                / 255.0, device=self.device) for c in self.cameras]
        tokens = torch.as_tensor(encode_instruction(str(obs["instruction"]), self.config.tokens)[None],
                                 device=self.device)
        state = self._state(obs)
        with torch.no_grad():
            out = self.net(imgs, tokens, torch.as_tensor(state[None], device=self.device))
        return out[0].cpu().numpy()

    def __call__(self, obs: Mapping[str, Any]) -> np.ndarray:
        if self.action == "waypoint":
            action = _follow(self.predict(obs)[0], obs["gripper"], self._speeds)
        elif self.ensemble is not None:
            self._chunks = [*self._chunks, self.predict(obs)][-self.chunk:]
            n = len(self._chunks)  # chunk i (oldest first) was predicted n-1-i steps ago
            acts = np.stack([c[n - 1 - i] for i, c in enumerate(self._chunks)])
            w = np.exp(-self.ensemble * np.arange(n))
            action = (w[:, None] * acts).sum(0) / w.sum()
        else:
            if not self._queue:
                self._queue = list(self.predict(obs)[: self.execute])
            action = self._queue.pop(0)
        action = np.clip(action, -1.0, 1.0).astype(np.float64)
        action[self.zero_channels] = 0.0
        if self.z_floor is not None:
            action = self._above_floor(action, float(np.asarray(obs["tcp_pos"])[2]))
        self._last_gripper = float(action[6])
        return action.astype(np.float32)

    def _above_floor(self, action: np.ndarray, tcp_z: float) -> np.ndarray:
        """Raise the z velocity so that the TCP target stays at or above ``z_floor``.

        The target is followed by integrating the z velocities sent (steering moves the target by
        exactly that); it is taken from the observed TCP at the start and whenever the two part by
        more than 3 cm (a held target, e.g. an unreachable pose).
        """
        if self._z is None or abs(self._z - tcp_z) > 0.03:
            self._z = tcp_z
        lowest = (float(self.z_floor) - self._z) / self._lin_step
        if action[2] < lowest:
            action = action.copy()
            action[2] = min(lowest, 1.0)
        self._z += float(action[2]) * self._lin_step
        return action


def policy_for_evaluation(env: Any, config: Any) -> BCPolicy:
    """The policy ``samplehd evaluate --policy bc`` runs (``config``: its EvalConfig)."""
    return BCPolicy.load(config.models, env)


def _episode_arrays(reader: Any, k: int, stride: int, tokens_len: int, cameras: Sequence[str] = CAMERAS,
                    action: str = "steering") -> dict[str, np.ndarray]:
    """One episode's training arrays, its waits left out (:func:`moving_frames`).

    ``steering`` and ``state`` are the kept frames in order (a chunk's targets are the next kept
    frames' actions); ``frames`` are the positions in them that serve as samples (every
    ``stride``-th), and the images are those samples' frames.
    """
    ep = reader.episode(k)
    f = ep.frames
    steering = np.asarray(f["steering"], np.float32)
    labels, keep = _labels(action, steering, np.asarray(f["tcp_pos"]), np.asarray(f["tcp_quat"]),
                           np.asarray(f["gripper_opening"]))
    last_gripper = np.r_[1.0, steering[:-1, 6]]
    state = _state(np.asarray(f["joint_pos"]), np.asarray(f["tcp_pos"]), np.asarray(f["tcp_quat"]),
                   np.asarray(f["gripper_opening"]), _joint_vel(action, f["joint_vel"]), last_gripper)
    t = np.arange(0, len(keep), stride)
    tcp = np.asarray(f["tcp_pos"])
    target = _target_features(tcp, f["object_pos"], f["object_quat"], f["target_object"])
    return {
        "frames": t, "steering": labels, "state": state[keep], "target": target[keep],
        "z": tcp[keep, 2].astype(np.float64),
        **{c: np.asarray(ep.images[c]["rgb"][:])[keep[t]] for c in cameras},
        "tokens": encode_instruction(reader.instruction(k)["instruction"], tokens_len),
    }


def _labels(action: str, steering: np.ndarray, tcp_pos: np.ndarray, tcp_quat: np.ndarray, opening: np.ndarray
            ) -> tuple[np.ndarray, np.ndarray]:
    """An episode's training labels and the frames they belong to: the steering vectors of every frame
    but the waits (:func:`moving_frames`), or every frame's waypoint target (:func:`waypoints`)."""
    if action == "waypoint":
        goal = waypoints(steering, tcp_pos, tcp_quat, opening)
        return waypoint_targets(goal, tcp_pos, tcp_quat), np.arange(len(steering))
    keep = moving_frames(steering)
    return np.asarray(steering, np.float32)[keep], keep


def _joint_vel(action: str, joint_vel: Any) -> np.ndarray:
    """The joint velocities the network sees: none for waypoints (the follower moves unlike the
    demonstrations' timed paths, and the labels do not depend on the speed)."""
    v = np.asarray(joint_vel, np.float64)
    return np.zeros_like(v) if action == "waypoint" else v


def _image_size(reader: Any, dataset: str | Path) -> int:
    """The side of the dataset's square scene and wrist camera RGB images; one-line errors."""
    # A dataset still being written (or stopped early) has its render settings only in the config.
    render = reader.info.get("render") or reader.config.get("render") or {}
    cams = camera_settings(render) if render else {}
    if not all(c in cams and "rgb" in cams[c]["modalities"] for c in CAMERAS):
        raise ConfigError(f"dataset={dataset}: episodes need RGB of cameras {', '.join(CAMERAS)} (generate it with "
                          "render.mode fast, render.cameras [scene, wrist], render.modalities [rgb])",
                          field="dataset")
    sizes = {(cams[c]["width"], cams[c]["height"]) for c in CAMERAS}
    if len(sizes) != 1 or next(iter(sizes))[0] != next(iter(sizes))[1]:
        raise ConfigError(f"dataset={dataset}: the cameras need one square image size; found {sorted(sizes)}",
                          field="dataset")
    return int(next(iter(sizes))[0])


def _collected_arrays(raw: Mapping[str, Any], stride: int, tokens_len: int, cameras: Sequence[str] = CAMERAS,
                      action: str = "steering") -> dict[str, np.ndarray]:
    """A collected episode (:func:`samplehd.learn.demos.collect`) as :func:`_episode_arrays` gives one."""
    grip = np.asarray(raw["gripper"], np.float64)
    if "goal" in raw:  # a waypoint DAgger episode: labelled with the expert's waypoints
        labels = waypoint_targets(raw["goal"], raw["tcp_pos"], raw["tcp_quat"])
        keep = np.arange(len(labels))
    else:
        labels, keep = _labels(action, np.asarray(raw["label"], np.float32), np.asarray(raw["tcp_pos"]),
                               np.asarray(raw["tcp_quat"]), grip[:, 0] + grip[:, 1])
    last_gripper = np.r_[1.0, np.asarray(raw["executed"], np.float64)[:-1, 6]]
    state = _state(raw["joint_pos"], raw["tcp_pos"], raw["tcp_quat"], grip[:, 0] + grip[:, 1],
                   _joint_vel(action, raw["joint_vel"]), last_gripper)
    t = np.arange(0, len(keep), stride)
    target = _target_features(raw["tcp_pos"], raw["object_pos"], raw["object_quat"], raw["target_object"])
    return {"frames": t, "steering": labels, "state": state[keep], "target": target[keep],
            "z": np.asarray(raw["tcp_pos"], np.float64)[keep, 2],
            **{c: np.asarray(raw[c])[keep[t]] for c in cameras},
            "tokens": encode_instruction(str(raw["instruction"]), tokens_len)}


def _save_arrays(path: Path, episodes: Sequence[Mapping[str, np.ndarray]]) -> None:
    """Collected episodes' arrays in one ``.npz`` (plain arrays, read with ``allow_pickle=False``)."""
    tmp = path.with_name(f".{path.name}.tmp.npz")
    np.savez_compressed(tmp, count=np.array(len(episodes)),
             **{f"{n}/{k}": v for n, e in enumerate(episodes) for k, v in e.items()})
    tmp.replace(path)


def _load_arrays(path: Path) -> list[dict[str, np.ndarray]]:
    try:
        with np.load(path, allow_pickle=False) as z:
            out: list[dict[str, np.ndarray]] = [{} for _ in range(int(z["count"]))]
            for name in z.files:
                if name != "count":
                    n, key = name.split("/", 1)
                    out[int(n)][key] = z[name]
            return out
    except (OSError, KeyError, ValueError, IndexError) as exc:
        raise ConfigError(f"{path}: not readable collected episodes ({exc}); delete it to collect them again") from None


def _inputs_state(arrays: Mapping[str, np.ndarray], inputs: str, t: Any = slice(None)) -> np.ndarray:
    """The state the network sees at frame(s) ``t``: the robot's, and the target's for ``inputs="state"``."""
    if inputs == "state":
        return np.concatenate([arrays["state"][t], arrays["target"][t]], axis=-1)
    return arrays["state"][t]


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
                 quiet: bool = False, stop_after: int | None = None, batch: int = 64, chunk: int = 8,
                 execute: int = 4, stride: int = 2,
                 lr: float = 1e-3, width: int = 16, hidden: int = 256, tokens: int = 32,
                 families: Sequence[str] | None = None, loss: str = "mse", near_weight: float = 1.0,
                 ensemble: float | None = None, floor: bool = True, gripper_weight: float = 1.0,
                 demos: int = 0, noise: float = 0.0, dagger_rounds: int = 0, dagger_episodes: int = 50,
                 dagger_steps: int = 1000, workers: int = 1, inputs: str = "rgb", action: str = "steering"
                 ) -> dict[str, Any]:
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
    if action == "waypoint":  # one waypoint per frame, predicted every step
        chunk, execute, ensemble = 1, 1, None
    # Waypoints are image positions: the waypoint policy's cameras end in keypoints.
    encoder = "keypoints" if action == "waypoint" else "flatten"
    reader = open_dataset(dataset)
    cameras = CAMERAS if inputs == "rgb" else ()
    image = _image_size(reader, dataset) if cameras else 0
    scenes = {s["image_index"]: s for s in reader.scenes}
    train_k, test_k = [], []
    for e in reader.episodes:
        if families and e.family not in families:
            continue
        ins = reader.instruction(e.instruction_index)
        if e.split == "test":
            test_k.append(e.instruction_index)
        elif not held_out_instruction(ins) and episode_level(ins, scenes[e.scene_index]) == "L1":
            train_k.append(e.instruction_index)
    if not train_k:
        raise ConfigError(f"dataset={dataset}: no training episodes", field="dataset")
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
    config = PolicyConfig(
        format=FORMAT, dataset=str(dataset), inputs=inputs, action=action, image=image, chunk=chunk,
        execute=execute, tokens=tokens,
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
                       noise=noise, still=tuple(zero_channels), squeeze=action == "waypoint")
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
