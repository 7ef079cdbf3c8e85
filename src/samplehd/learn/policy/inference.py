"""A trained behaviour-cloning policy acting in the environment (:class:`BCPolicy`), and the factory
``samplehd evaluate --policy bc`` calls.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from samplehd.envs.tokens import encode_instruction, instruction_vocabulary
from samplehd.errors import ConfigError
from samplehd.learn.actions import steering_speeds, waypoint_steering
from samplehd.learn.policy.configuration import CAMERAS, FORMAT, PolicyConfig
from samplehd.learn.policy.modeling import BCNet
from samplehd.learn.policy.processing import policy_state, seen_joint_velocities, target_features
from samplehd.learn.registry import policy_entry
from samplehd.learn.training import check_weights_fit, load_model_files, read_model_config, set_seed, torch

__all__ = ["BCPolicy", "policy_for_evaluation"]


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
        self._speeds = steering_speeds(env)  # TCP speed and angular speed of a steering value of 1 [m/s, rad/s]
        self._queue: list[np.ndarray] = []
        self._chunks: list[np.ndarray] = []
        self._z: float | None = None
        self._last_gripper = 1.0
        self._start: np.ndarray | None = None
        if env is not None:
            c = env.unwrapped.config
            # What the network needs of the images and the control; its scenes may come from another catalogue.
            want = {k: v for k, v in config.env_options().items() if k != "scene"}
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
        policy = cls(read_model_config(PolicyConfig, config, folder), None, env)
        check_weights_fit(policy.net, state, folder)
        return policy

    def reset(self, seed: int | None = None) -> None:
        self._queue = []
        self._chunks = []
        self._z = None
        self._last_gripper = 1.0
        self._start = None

    def _state(self, obs: Mapping[str, Any]) -> np.ndarray:
        g = np.asarray(obs["gripper"], dtype=float)
        robot = policy_state(np.asarray(obs["joint_pos"], float), np.asarray(obs["tcp_pos"], float),
                             np.asarray(obs["tcp_quat"], float), g[0] + g[1],
                             seen_joint_velocities(self.action, obs["joint_vel"]), self._last_gripper)
        if self.inputs != "state":
            return robot
        target = np.array([self._target(obs)])
        feats = target_features(np.asarray(obs["tcp_pos"], float)[None], np.asarray(obs["object_pos"])[None],
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
            action = waypoint_steering(self.predict(obs)[0], obs["gripper"], self._speeds)
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


def policy_for_evaluation(env: Any, config: Any) -> Any:
    """The policy ``samplehd evaluate --policy bc`` runs (``config``: its EvalConfig): the one trained in
    ``config.models``, run by the class its entry in :mod:`samplehd.learn.registry` names (a
    :class:`BCPolicy`, a keypose policy, ...), told by its config's ``action``."""
    if config.models is None:
        raise ConfigError("policy=bc: needs `models` (the folder of `samplehd train policy`)", field="policy")
    raw, state = load_model_files(config.models, "policy", FORMAT)
    entry = policy_entry(raw)
    policy_config = read_model_config(entry.config, raw, config.models)
    policy = entry.runner_class()(policy_config, None, env)
    check_weights_fit(policy.net, state, config.models)
    return policy

