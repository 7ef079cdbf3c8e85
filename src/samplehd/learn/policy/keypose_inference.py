"""The trained keypose policy acting in the environment (:class:`KeyposePolicy`): it looks at the table
through the scene camera (RGB-D, re-projected from above), decides where to grasp and where the object
goes, and carries the decision out with :class:`~samplehd.learn.policy.keyposes.KeyposeFollower`, one
steering vector per ``env.step``; after each release it looks again, until it decides that the
decision was the last.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from samplehd.envs.tokens import encode_instruction, instruction_vocabulary
from samplehd.errors import ConfigError
from samplehd.learn.policy.actions import _yaw
from samplehd.learn.policy.configuration import PolicyConfig
from samplehd.learn.policy.keypose_training import SCENE_MODALITIES, grid_of, predict_decisions, scene_grid
from samplehd.learn.policy.keyposes import Decision, KeyposeFollower
from samplehd.learn.policy.modeling import KeyposeNet
from samplehd.learn.policy.topdown import GRID_CHANNELS
from samplehd.learn.training import set_seed, torch
from samplehd.render.renderer import SceneRenderer

__all__ = ["KeyposePolicy"]

MAX_DECISIONS = 4  # an episode's decisions at most (the families move up to three objects)


class KeyposePolicy:
    """The keypose policy in ``env`` (steering control; any observation mode: it renders the scene
    camera itself, as the dataset's scene images were drawn).

    Args:
        config: the trained model's config.
        state: its state dict (None: an untrained network).
        env: the environment.
    """

    def __init__(self, config: PolicyConfig, state: Mapping[str, Any] | None, env: Any = None,
                 device: Any = None) -> None:
        set_seed(config.train.seed)
        self.config = config
        self.device = device or torch.device("cpu")
        self.net = KeyposeNet(len(instruction_vocabulary()), GRID_CHANNELS, config.model.width).to(self.device)
        if state is not None:
            self.net.load_state_dict(state)
        self.net.eval()
        self.grid = grid_of(config.grid)
        self.env = env
        if env is not None and env.unwrapped.config.control_mode != "steering":
            raise ConfigError(f"policy=bc: the environment's control_mode={env.unwrapped.config.control_mode!r}, "
                              f"the keypose policy needs 'steering'", field="policy")
        self._renderer: Any = None
        self._renderer_model: Any = None
        self.decisions: list[Decision] = []
        self.reset()

    def reset(self, seed: int | None = None) -> None:
        self._follower: KeyposeFollower | None = None
        self._home: np.ndarray | None = None
        self._episode: Any = None
        self.decisions = []

    def decide(self, instruction: str) -> Decision:
        """The decision on the scene camera's current view."""
        u = self.env.unwrapped
        cfg = self.config.grid
        if self._renderer_model is not u.model:
            self.close()
            self._renderer = SceneRenderer(u.model, cfg.width, cfg.height, "fast")
            self._renderer_model = u.model
            self._renderer.render(u.data, cfg.camera, SCENE_MODALITIES)  # a context's first frame differs
        grid = scene_grid(self._renderer, u.model, u.data, cfg)
        tokens = encode_instruction(instruction, self.config.tokens)
        with torch.no_grad():
            return predict_decisions(self.net, torch.as_tensor(grid[None], device=self.device),
                                     torch.as_tensor(tokens[None], device=self.device), self.grid)[0]

    def __call__(self, obs: Mapping[str, Any]) -> np.ndarray:
        episode = getattr(self.env.unwrapped, "episode", None)
        if self._home is None or episode is not self._episode:
            self.reset()
            self._episode = episode
            self._home = np.r_[np.asarray(obs["tcp_pos"], np.float64), _yaw(np.asarray(obs["tcp_quat"], np.float64))]
        follower = self._follower
        again = follower is None or (follower.done and not self.decisions[-1].last)
        if again and len(self.decisions) < MAX_DECISIONS:
            decision = self.decide(str(obs["instruction"]))
            self.decisions.append(decision)
            follower = self._follower = KeyposeFollower(decision, obs, self._home, self.env,
                                                        z_floor=float(self.net.z_floor))
        return follower(obs)

    def close(self) -> None:
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None
            self._renderer_model = None
