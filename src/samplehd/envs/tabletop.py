"""``samplehd/Tabletop-v0``: language-conditioned manipulation on the kitchen tabletop, as a
Gymnasium environment.

Each episode is a scene (sampled, or given) and an instruction about it. The agent commands the
UR5e through the robot controller at the control rate; physics runs at its own rate in between.

Actions (``float32``, all in the robot base frame, which is parallel to the world frame; the last
value is the gripper: +1 open, -1 closed, linear in between):

=================  =====  ========================================================================
control_mode       shape  meaning
=================  =====  ========================================================================
``joint_pos``      (7,)   6 joint targets [rad] within the joint limits
``joint_delta``    (7,)   6 joint target increments [rad], each within ±``max_joint_delta`` (0.15)
``ee_delta``       (7,)   TCP translation [m] (±0.05 per axis) and rotation vector [rad] (±0.25)
                          for this step, solved by analytic IK near the current target
``steering``       (7,)   SAMPLE-HD steering: TCP linear (x, y, z) and angular (x, y, z) velocity
                          in [-1, 1], scaled to 0.25 m/s and 1 rad/s
=================  =====  ========================================================================

NaN or infinite actions raise :class:`~samplehd.errors.ActionError` (a ``ValueError``); values
outside the action space are clipped and reported in ``info["action_clipped"]``.

Observations: a ``Dict`` with ``joint_pos`` (6) [rad], ``joint_vel`` (6) [rad/s], ``gripper`` (3:
finger joint positions [m] and the gripper command), ``tcp_pos`` (3, world) [m], ``tcp_quat`` (4,
w x y z), ``object_pos`` (N_max, 3) [m], ``object_quat`` (N_max, 4), ``object_mask`` (N_max) for
the scene's objects, the instruction as ``instruction`` (``Text``) and ``instruction_tokens``
(fixed-length ids of :mod:`samplehd.envs.tokens`), and per camera and modality
``{camera}_rgb`` (H×W×3 uint8), ``{camera}_depth`` (H×W float32 [m]) and ``{camera}_segmentation``
(H×W int32 ids: 0 background, 1 table, 2 robot, 3+i object i).

Grasp assist (option ``grasp_assist``, on by default): at the start of each step, when the gripper
command does not open the fingers and both fingers are within 0.5 mm of an object's collision geoms,
the object is welded to the gripper where it is; the weld is released when the command opens again.
It is the rule of the dataset's paths, one implementation (:class:`samplehd.motion.assist.GraspAssist`),
the same for every policy, so recorded actions replay to the recorded outcome; the fingers still
close physically and the safety monitor watches every contact.

Reward (:mod:`samplehd.envs.reward`): 1 when the shared success checker accepts the state, plus an
optional dense term. ``terminated`` on success or a safety stop; ``truncated`` after
``max_episode_steps`` steps.

Info keys: ``instruction``, ``family``, ``task`` (executor dict), ``targets``, ``program`` (CLEVR
nodes), ``program_sequence`` (flat tokens), ``subtask`` (the oracle's current subtask when an
oracle drives the episode, else ""), ``oracle_plan_subtask`` (with option ``oracle_subtask``: the
subtask of the oracle's plan nearest the current state, whatever policy drives; ``oracle_plan_note``
says why there is none when the planner rejects the instruction), ``success``/``is_success``, ``check_reason``,
``safety_event`` (this step's event dict or None), ``safety_events`` (all of the episode),
``safety_stop``, ``action_clipped``, ``clipped`` (names of clipped fields), ``unreachable`` (IK had
no solution for a Cartesian command), ``scene_seed``, ``elapsed_steps``.

Vectorised use: ``gymnasium.vector.SyncVectorEnv`` and ``AsyncVectorEnv`` both work; give
``AsyncVectorEnv`` ``context="spawn"`` when the parent process has rendered before (an EGL context
does not survive ``fork``).

Reset options (``reset(seed=..., options=...)``): ``family`` (draw an instruction of this family),
or ``scene`` + ``instruction`` (+ ``episode``) to reproduce a given episode exactly, or ``dataset``
(a directory written by ``samplehd generate``) + ``episode_index`` to start from a stored episode
(see :func:`samplehd.envs.episodes.episode_from_options`).
"""

from __future__ import annotations

import copy
import string
from dataclasses import replace
from typing import Any

import gymnasium as gym
import mujoco
import numpy as np
from gymnasium import spaces

from samplehd.envs.config import CAMERAS, CONTROL_MODES, EnvConfig
from samplehd.envs.episodes import EpisodeSpec, SceneCache, episode_from_options, sample_episode
from samplehd.envs.plan_tracker import plan_tracker
from samplehd.envs.reward import dense_term
from samplehd.envs.tokens import encode_instruction, instruction_vocabulary
from samplehd.errors import ActionError, ConfigError, SamplehdError
from samplehd.motion.assist import GraspAssist
from samplehd.motion.execute import initial_state
from samplehd.render.renderer import SceneRenderer
from samplehd.robot.constants import GRIPPER_STROKE, JOINT_LIMITS
from samplehd.robot.controller import ControlConfig, RobotController
from samplehd.tasks.checker import check_success
from samplehd.tasks.task import Task, get_family, parse_task
from samplehd.world.bodies import SceneBodies

__all__ = ["INSTRUCTION_CHARSET", "TabletopEnv"]

INSTRUCTION_CHARSET = "".join(c for c in string.printable if c not in "\t\n\r\x0b\x0c")
_DEPTH_MAX = 20.0  # [m]; farther depths are clipped (the room is a few metres across)
_SEG_MAX = 255


def action_bounds(mode: str, control: ControlConfig) -> tuple[np.ndarray, np.ndarray]:
    """(low, high) of the action space of an environment control mode."""
    if mode == "joint_pos":
        lo, hi = JOINT_LIMITS[:, 0], JOINT_LIMITS[:, 1]
    elif mode == "joint_delta":
        lo = np.full(6, -control.max_joint_delta)
        hi = -lo
    elif mode == "ee_delta":
        lin, rot = control.max_cartesian_delta
        hi = np.array([lin] * 3 + [rot] * 3)
        lo = -hi
    else:
        lo, hi = -np.ones(6), np.ones(6)
    return np.append(lo, -1.0).astype(np.float32), np.append(hi, 1.0).astype(np.float32)


class TabletopEnv(gym.Env):
    """The tabletop environment; keyword options are the fields of :class:`EnvConfig`.

    Example:
        >>> import gymnasium as gym, samplehd                      # doctest: +SKIP
        >>> env = gym.make("samplehd/Tabletop-v0", obs_mode="rgb")  # doctest: +SKIP
        >>> obs, info = env.reset(seed=0)                           # doctest: +SKIP
        >>> print(obs["instruction"], info["task"])                 # doctest: +SKIP
    """

    metadata = {"render_modes": ["rgb_array"], "render_fps": 20}

    def __init__(self, **options: Any) -> None:
        cfg = EnvConfig.from_kwargs(**options)
        self.config = cfg
        self.render_mode = cfg.render_mode
        self.metadata = {"render_modes": ["rgb_array"], "render_fps": int(round(cfg.control_hz))}
        self.control = ControlConfig(physics_hz=cfg.physics_hz, control_hz=cfg.control_hz)
        self._mode = CONTROL_MODES[cfg.control_mode]
        low, high = action_bounds(cfg.control_mode, self.control)
        self.action_space = spaces.Box(low, high, dtype=np.float32)
        self._low, self._high = low.astype(float), high.astype(float)
        self.max_objects = cfg.scene.max_objects
        self.observation_space = self._observation_space()
        # A state-only env makes no GL context (a context made before torch's triton import can crash the
        # process): its scenes are sampled, occlusion renders included, in a child process.
        self.cache = SceneCache(cfg.scene, cfg.scene_cache_size, 1.0 / cfg.physics_hz, grasp_welds=cfg.grasp_assist,
                                gl_free=cfg.obs_mode == "state" and cfg.render_mode is None)
        self.episode: EpisodeSpec | None = None
        self.subtask = ""
        self._plan: Any = None
        self._plan_note, self.plan_subtask = "", ""
        self.model: mujoco.MjModel | None = None
        self.data: mujoco.MjData | None = None
        self.controller: RobotController | None = None
        self._renderer: Any = None
        self._render_viewer: Any = None
        self._steps = 0
        self._events: list[dict[str, Any]] = []
        self._success = False
        self._reason = ""
        self.task: Task | None = None
        self._cam_names: dict[str, str] = {}
        self.last_safety_event: Any = None
        self.assist: GraspAssist | None = None
        self._closed = False

    # ------------------------------------------------------------------ spaces
    def _observation_space(self) -> spaces.Dict:
        cfg = self.config
        n = self.max_objects
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
                    d[f"{cam}_depth"] = spaces.Box(0.0, _DEPTH_MAX, (h, w), np.float32)
                else:
                    d[f"{cam}_segmentation"] = spaces.Box(0, _SEG_MAX, (h, w), np.int32)
        return spaces.Dict(d)

    # ------------------------------------------------------------------ episodes
    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None) -> tuple[dict, dict]:
        """Start an episode: draw a scene and an instruction from ``np_random`` or reproduce given ones."""
        if self._closed:
            raise ActionError("reset() after close(): the environment is closed; make a new one")
        if options is not None and not isinstance(options, dict):
            raise ConfigError(f"reset: options must be a dict, got {type(options).__name__}")
        if seed is not None and (not isinstance(seed, (int, np.integer)) or isinstance(seed, bool) or seed < 0):
            raise ConfigError(f"reset: seed {seed!r}: must be an integer ≥ 0, or None")
        super().reset(seed=None if seed is None else int(seed))
        options = dict(options or {})
        if {"scene", "instruction", "episode", "dataset", "episode_index"} & set(options):
            episode = episode_from_options(options, self.cache)
        else:
            family = options.pop("family", None)
            if options:
                raise ConfigError(f"reset: unknown option(s) {sorted(options)}; valid: dataset, episode, "
                                  "episode_index, family, instruction, scene")
            episode = sample_episode(self.np_random, self.cache, self.config.task_families, family=family,
                                     num_scenes=self.config.num_scenes, scene_seed=self.config.scene_seed)
        self._start(episode)
        return self._observation(), self._info(None, None)

    def _start(self, episode: EpisodeSpec) -> None:
        model, pristine, _ = self.cache.compiled(episode.scene)
        if model is not self.model:
            self._close_renderers()
            self.model = model
            self.data = mujoco.MjData(model)
            cams = {mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_CAMERA, i) for i in range(model.ncam)}
            self._cam_names = {c: (c if c in cams else "operator") for c in CAMERAS}
        data = self.data
        mujoco.mj_copyData(data, model, pristine)
        self.controller = initial_state(model, data, self.control)
        if episode.initial_state is not None:
            data.qpos[:] = episode.initial_state["qpos"]
            data.qvel[:] = episode.initial_state["qvel"]
            data.act[:] = episode.initial_state["act"]
            mujoco.mj_forward(model, data)
            self.controller.reset(None, gripper=1.0)
        self.assist = None
        if self.config.grasp_assist:
            self.assist = GraspAssist(model, len(episode.scene.objects))
            self.assist.release(data)
        self.episode = episode
        self.task = parse_task(episode.instruction["task"], episode.family)
        self._object_body = np.array(
            [model.body(f"object_{i}").id for i in range(len(episode.scene.objects))], dtype=int)
        self._tcp_site = model.site("tcp").id
        self._finger_qpos = np.array([model.jnt_qposadr[model.joint(j).id]
                                      for j in ("robot_left_finger_joint", "robot_right_finger_joint")])

        self._gripper_bodies = np.array(sorted(SceneBodies(model, len(episode.scene.objects)).gripper_bodies), int)
        self._start_pos = np.array([o.pos for o in episode.scene.objects], dtype=float).reshape(-1, 3)
        self._gate_shift = 0.5 * min(self.config.checker.relation_margin, self.config.checker.lift_height, 0.01)
        self._tokens = encode_instruction(episode.text, self.config.max_instruction_tokens)
        self._text = "".join(c if c in INSTRUCTION_CHARSET else " " for c in episode.text)
        self._text = self._text[: self.config.max_instruction_chars] or " "
        self._steps = 0
        self._events = []
        self._success = False
        self._reason = ""
        self.subtask = ""
        self.last_safety_event = None
        self._plan, self._plan_note, self.plan_subtask = None, "", ""
        if self.config.oracle_subtask:
            directions = episode.annotation.get("directions") if episode.annotation else None
            self._plan, self._plan_note = plan_tracker(
                model, data, episode.scene, episode.instruction["task"], episode.family, directions,
                int(episode.scene.seed), self.config.physics_hz, self.config.control_hz)
            self._track_plan()

    # ------------------------------------------------------------------ stepping
    def step(self, action: Any) -> tuple[dict, float, bool, bool, dict]:
        """Apply one action for one control period; see the module docstring."""
        if self._closed:
            raise ActionError("step() after close(): the environment is closed; make a new one")
        if self.controller is None:
            raise SamplehdError("call reset() before step()")
        raw = np.asarray(action)
        if raw.dtype.kind not in "biuf":
            raise ActionError(f"action must be real numbers of shape {self.action_space.shape}, got dtype "
                              f"{raw.dtype} ({_describe(action)})")
        a = raw.astype(float)
        if a.shape != self.action_space.shape:
            raise ActionError(f"action must have shape {self.action_space.shape} for control_mode "
                              f"{self.config.control_mode!r}, got {a.shape}")
        if not np.all(np.isfinite(a)):
            raise ActionError(f"action contains NaN or infinite values: {a.tolist()}")
        clipped_box = bool(np.any(a < self._low) or np.any(a > self._high))
        if clipped_box:
            a = np.clip(a, self._low, self._high)
        if self.assist is not None:
            self.assist.update(self.data, float(a[-1]), stopped=self.controller.stopped is not None)
        report = self.controller.step(a, self._mode)
        self.last_safety_event = report.safety_event
        self._steps += 1
        event = report.safety_event.to_dict() if report.safety_event is not None else None
        if event is not None:
            self._events.append(event)
        reward = 0.0
        if not self._success and (self._steps % self.config.success_check_every == 0):
            self._success, self._reason = self._check()
        if self._success:
            reward = 1.0
        obs = self._observation()
        if self.config.dense_reward:
            reward += dense_term(obs["tcp_pos"], self.data.xpos[self._object_body[self.task.objects[0]]])
        stopped = self.controller.stopped is not None
        terminated = bool(self._success or (stopped and self.config.terminate_on_safety))
        limit = self.config.max_episode_steps
        truncated = bool(not terminated and limit is not None and self._steps >= limit)
        self._track_plan()
        info = self._info(report, event)
        info["action_clipped"] = bool(clipped_box or report.clipped)
        return obs, float(reward), terminated, truncated, info

    def _track_plan(self) -> None:
        if self._plan is not None:
            d = self.data
            self.plan_subtask = self._plan.update(d.site_xpos[self._tcp_site], float(d.qpos[self._finger_qpos].sum()))

    def _may_succeed(self) -> bool:
        """A necessary condition of success that costs microseconds, so the checker runs only when needed.

        Every family's predicate needs the moved objects off their scene poses (templates only
        ask for a change), and every family but pick_up needs them out of the gripper's touch
        (the checker's "resting"); pick_up needs the object lifted.
        """
        d = self.data
        task = self.task
        moved = self._object_body[list(task.objects)]
        shift = np.linalg.norm(d.xpos[moved] - self._start_pos[list(task.objects)], axis=1)
        if np.any(shift < self._gate_shift):
            return False
        if not get_family(task.family).places:  # held objects touch the gripper
            return True
        if d.ncon:
            bodies = self.model.geom_bodyid[d.contact.geom]
            touch = np.isin(bodies, self._gripper_bodies)
            held = np.isin(bodies, moved)
            if np.any((touch[:, 0] & held[:, 1]) | (touch[:, 1] & held[:, 0])):
                return False
        return True

    def _check(self) -> tuple[bool, str]:
        if not self._may_succeed():
            return False, "the moved objects are still in place or in the gripper"
        ep = self.episode
        directions = ep.annotation.get("directions") if ep.annotation else None
        # A window-free pass is cheap; only a state that passes it is run through the stability window.
        quick = check_success(self.model, self.data, ep.scene, self.task, replace(self.config.checker, window=0.0),
                              directions=directions)
        if not quick.success:
            return False, quick.reason
        full = check_success(self.model, self.data, ep.scene, self.task, self.config.checker, directions=directions)
        return full.success, full.reason

    def check_success(self) -> dict[str, Any]:
        """The shared checker's full report on the current state (with the stability window)."""

        ep = self.episode
        directions = ep.annotation.get("directions") if ep.annotation else None
        return check_success(self.model, self.data, ep.scene, self.task, self.config.checker,
                             directions=directions).to_dict()

    # ------------------------------------------------------------------ observations
    def _renderer_for(self) -> SceneRenderer:
        if self._renderer is None:
            cfg = self.config
            self._renderer = cfg.image.renderer(self.model)
            # The first frame of a new GL context differs from later ones in a few pixels (texture
            # upload); render it once and throw it away so equal states give equal images.
            for cam in cfg.cameras:
                self._renderer.render(self.data, self._cam_names[cam], cfg.modalities)
        return self._renderer

    def _observation(self) -> dict[str, Any]:
        m, d, n = self.model, self.data, self.max_objects
        ctrl = self.controller
        quat = np.empty(4)
        mujoco.mju_mat2Quat(quat, d.site_xmat[self._tcp_site])
        k = min(len(self._object_body), n)
        obj_pos = np.zeros((n, 3), np.float32)
        obj_quat = np.zeros((n, 4), np.float32)
        mask = np.zeros(n, np.int8)
        obj_pos[:k] = d.xpos[self._object_body[:k]]
        obj_quat[:k] = d.xquat[self._object_body[:k]]
        mask[:k] = 1
        gripper = np.zeros(3, np.float32)
        gripper[:2] = d.qpos[self._finger_qpos]
        gripper[2] = ctrl.gripper_width / GRIPPER_STROKE * 2.0 - 1.0
        obs: dict[str, Any] = {
            "joint_pos": ctrl.joint_positions().astype(np.float32),
            "joint_vel": ctrl.joint_velocities().astype(np.float32),
            "gripper": gripper,
            "tcp_pos": d.site_xpos[self._tcp_site].astype(np.float32),
            "tcp_quat": quat.astype(np.float32),
            "object_pos": obj_pos,
            "object_quat": obj_quat,
            "object_mask": mask,
            "instruction": self._text,
            "instruction_tokens": self._tokens.copy(),
        }
        mods = self.config.modalities
        if mods:
            r = self._renderer_for()
            for cam in self.config.cameras:
                images = r.render(d, self._cam_names[cam], mods)
                for mod, img in images.items():
                    if mod == "depth":
                        img = np.clip(img, 0.0, _DEPTH_MAX)
                    obs[f"{cam}_{mod}"] = img
        del m
        return obs

    def _info(self, report: Any, event: dict[str, Any] | None) -> dict[str, Any]:
        ep = self.episode
        ins = ep.instruction
        return {
            "instruction": ep.text,
            "family": ep.family,
            "task": copy.deepcopy(ins["task"]),
            "targets": list(ins.get("targets", [])),
            "program": copy.deepcopy(ins.get("program", [])),
            "program_sequence": ins.get("program_sequence", ""),
            "subtask": self.subtask,
            "oracle_plan_subtask": self.plan_subtask,
            "oracle_plan_note": self._plan_note,
            "success": self._success,
            "is_success": self._success,
            "check_reason": self._reason,
            "safety_event": event,
            "safety_events": list(self._events),
            "safety_stop": self.controller.stopped is not None,
            "action_clipped": False,
            "clipped": list(report.clipped) if report is not None else [],
            "unreachable": bool(report.unreachable) if report is not None else False,
            "scene_seed": ep.scene.seed,
            "elapsed_steps": self._steps,
        }

    # ------------------------------------------------------------------ rendering
    def render(self) -> np.ndarray | None:
        """RGB image (H×W×3 uint8) of ``render_camera`` when ``render_mode="rgb_array"``."""
        if self.render_mode != "rgb_array" or self.model is None:
            return None

        cfg = self.config
        if self._render_viewer is None:
            self._render_viewer = cfg.image.renderer(self.model)
            self._render_viewer.render(self.data, self._cam_names[cfg.render_camera], ("rgb",))  # warm-up
        return self._render_viewer.render(self.data, self._cam_names[cfg.render_camera], ("rgb",))["rgb"]

    def _close_renderers(self) -> None:
        for r in (self._renderer, self._render_viewer):
            if r is not None:
                r.close()
        self._renderer = None
        self._render_viewer = None

    def close(self) -> None:
        """Free the renderers; the environment cannot step or reset afterwards."""
        self._close_renderers()
        self._closed = True
        super().close()


def _describe(value: Any) -> str:
    """A short description of a value for messages."""
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."
