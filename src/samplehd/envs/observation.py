"""What the tabletop environment observes: its observation space, the observation of an episode's
state (robot, objects, instruction, images per camera and modality), and the frames of ``render()``.

The renderers are made on first use and kept while the scene's model stays; a new model closes them.
"""

from __future__ import annotations

import string

import mujoco
import numpy as np
from gymnasium import spaces

from samplehd.envs.config import CAMERAS, EnvConfig
from samplehd.envs.episode_physics import EpisodePhysics
from samplehd.envs.tokens import encode_instruction, instruction_vocabulary
from samplehd.render.renderer import SceneRenderer
from samplehd.robot.constants import GRIPPER_STROKE
from samplehd.scene.world import OPERATOR_CAMERA

__all__ = ["DEPTH_MAX", "INSTRUCTION_CHARSET", "SEG_MAX", "Observation", "ObservationBuilder", "observation_space"]

INSTRUCTION_CHARSET = "".join(c for c in string.printable if c not in "\t\n\r\x0b\x0c")
DEPTH_MAX = 20.0  # [m]; farther depths are clipped (the room is a few metres across)
SEG_MAX = 255
# An observation: the arrays of :func:`observation_space` by key, and ``instruction``, the text.
Observation = dict[str, np.ndarray | str]


def observation_space(cfg: EnvConfig) -> spaces.Dict:
    """The ``Dict`` space of the environment's observations (see :mod:`samplehd.envs.tabletop`)."""
    n = cfg.scene.max_objects
    inf = np.inf
    d: dict[str, spaces.Space] = {
        "joint_pos": spaces.Box(-inf, inf, (6,), np.float32),
        "joint_vel": spaces.Box(-inf, inf, (6,), np.float32),
        "gripper": spaces.Box(-inf, inf, (3,), np.float32),
        "tcp_pos": spaces.Box(-inf, inf, (3,), np.float32),
        "tcp_quat": spaces.Box(-1.0, 1.0, (4,), np.float32),
        "object_pos": spaces.Box(-inf, inf, (n, 3), np.float32),
        "object_quat": spaces.Box(-1.0, 1.0, (n, 4), np.float32),
        "object_mask": spaces.MultiBinary(n),
        "instruction": spaces.Text(cfg.max_instruction_chars, min_length=1, charset=INSTRUCTION_CHARSET),
        "instruction_tokens": spaces.Box(0, len(instruction_vocabulary()) - 1, (cfg.max_instruction_tokens,),
                                         np.int64),
    }
    h, w = cfg.height, cfg.width
    for cam in cfg.cameras:
        for mod in cfg.modalities:
            if mod == "rgb":
                d[f"{cam}_rgb"] = spaces.Box(0, 255, (h, w, 3), np.uint8)
            elif mod == "depth":
                d[f"{cam}_depth"] = spaces.Box(0.0, DEPTH_MAX, (h, w), np.float32)
            else:
                d[f"{cam}_segmentation"] = spaces.Box(0, SEG_MAX, (h, w), np.int32)
    return spaces.Dict(d)


class ObservationBuilder:
    """Observations and ``render()`` frames of the environment configured by ``config``.

    Args:
        config: the environment's config (cameras, modalities, image size, instruction lengths).
    """

    def __init__(self, config: EnvConfig) -> None:
        self.config = config
        self.max_objects = config.scene.max_objects
        self.space = observation_space(config)
        self.model: mujoco.MjModel | None = None
        self.text = " "
        self.tokens = encode_instruction("", config.max_instruction_tokens)
        self._cam_names: dict[str, str] = {}
        self._renderer: SceneRenderer | None = None  # the observations' images
        self._viewer: SceneRenderer | None = None  # render()'s frames

    def start(self, model: mujoco.MjModel, instruction: str) -> None:
        """An episode on ``model`` with ``instruction``: a new model closes the renderers of the old one."""
        if model is not self.model:
            self.close()
            self.model = model
            cams = {mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_CAMERA, i) for i in range(model.ncam)}
            self._cam_names = {c: (c if c in cams else OPERATOR_CAMERA.name) for c in CAMERAS}
        cfg = self.config
        self.tokens = encode_instruction(instruction, cfg.max_instruction_tokens)
        text = "".join(c if c in INSTRUCTION_CHARSET else " " for c in instruction)
        self.text = text[: cfg.max_instruction_chars] or " "

    def _renderer_for(self, data: mujoco.MjData) -> SceneRenderer:
        if self._renderer is None:
            cfg = self.config
            self._renderer = cfg.image.renderer(self.model)
            # The first frame of a new GL context differs from later ones in a few pixels (texture
            # upload); render it once and throw it away so equal states give equal images.
            for cam in cfg.cameras:
                self._renderer.render(data, self._cam_names[cam], cfg.modalities)
        return self._renderer

    def observe(self, physics: EpisodePhysics) -> Observation:
        """The observation of ``physics``' current state."""
        d, n = physics.data, self.max_objects
        ctrl = physics.controller
        quat = np.empty(4)
        mujoco.mju_mat2Quat(quat, d.site_xmat[physics.tcp_site])
        bodies = physics.object_body
        k = min(len(bodies), n)
        obj_pos = np.zeros((n, 3), np.float32)
        obj_quat = np.zeros((n, 4), np.float32)
        mask = np.zeros(n, np.int8)
        obj_pos[:k] = d.xpos[bodies[:k]]
        obj_quat[:k] = d.xquat[bodies[:k]]
        mask[:k] = 1
        gripper = np.zeros(3, np.float32)
        gripper[:2] = d.qpos[physics.finger_qpos]
        gripper[2] = ctrl.gripper_width / GRIPPER_STROKE * 2.0 - 1.0
        obs: Observation = {
            "joint_pos": ctrl.joint_positions().astype(np.float32),
            "joint_vel": ctrl.joint_velocities().astype(np.float32),
            "gripper": gripper,
            "tcp_pos": d.site_xpos[physics.tcp_site].astype(np.float32),
            "tcp_quat": quat.astype(np.float32),
            "object_pos": obj_pos,
            "object_quat": obj_quat,
            "object_mask": mask,
            "instruction": self.text,
            "instruction_tokens": self.tokens.copy(),
        }
        mods = self.config.modalities
        if mods:
            r = self._renderer_for(d)
            for cam in self.config.cameras:
                images = r.render(d, self._cam_names[cam], mods)
                for mod, img in images.items():
                    if mod == "depth":
                        img = np.clip(img, 0.0, DEPTH_MAX)
                    obs[f"{cam}_{mod}"] = img
        return obs

    def render(self, data: mujoco.MjData) -> np.ndarray:
        """RGB image (H×W×3 uint8) of the config's ``render_camera``."""
        cfg = self.config
        cam = self._cam_names[cfg.render_camera]
        if self._viewer is None:
            self._viewer = cfg.image.renderer(self.model)
            self._viewer.render(data, cam, ("rgb",))  # warm-up
        return self._viewer.render(data, cam, ("rgb",))["rgb"]

    def close(self) -> None:
        """Free the renderers."""
        for r in (self._renderer, self._viewer):
            if r is not None:
                r.close()
        self._renderer = None
        self._viewer = None
