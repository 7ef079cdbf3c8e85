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
(see :func:`samplehd.envs.episodes.episode_from_options`), or ``suite`` (a shipped suite's name or a
suite file) + ``episode`` (its index) to start a benchmark suite's episode
(:mod:`samplehd.envs.suite_file`).
"""

from __future__ import annotations

import copy
from typing import Any

import gymnasium as gym
import mujoco
import numpy as np
from gymnasium import spaces

from samplehd.envs.config import CONTROL_MODES, EnvConfig
from samplehd.envs.episode_physics import EpisodePhysics
from samplehd.envs.episodes import EpisodeSpec, SceneCache, episode_from_options, sample_episode
from samplehd.envs.observation import INSTRUCTION_CHARSET, Observation, ObservationBuilder
from samplehd.envs.plan_tracker import plan_tracker
from samplehd.envs.reward import dense_term
from samplehd.envs.suite_file import suite_reset_options
from samplehd.errors import ActionError, ConfigError, SamplehdError
from samplehd.motion.assist import GraspAssist
from samplehd.robot.constants import JOINT_LIMITS
from samplehd.robot.controller import ControlConfig, RobotController
from samplehd.tasks.checker import CheckReport
from samplehd.tasks.task import Task, parse_task

__all__ = ["INSTRUCTION_CHARSET", "TabletopEnv"]


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

    The class holds the Gymnasium contract (spaces, action checks, reward, termination, info); an
    episode's physics, controller and grasp assist are an :class:`EpisodePhysics`, and the
    observations and ``render()`` frames come from an :class:`ObservationBuilder`.

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
        self.observer = ObservationBuilder(cfg)
        self.observation_space = self.observer.space
        # A state-only env makes no GL context (a context made before torch's triton import can crash the
        # process): its scenes are sampled, occlusion renders included, in a child process.
        self.cache = SceneCache(cfg.scene, cfg.scene_cache_size, 1.0 / cfg.physics_hz, grasp_welds=cfg.grasp_assist,
                                gl_free=cfg.obs_mode == "state" and cfg.render_mode is None)
        self.physics: EpisodePhysics | None = None
        self.episode: EpisodeSpec | None = None
        self.task: Task | None = None
        self.subtask = ""
        self._plan: Any = None
        self._plan_note, self.plan_subtask = "", ""
        self._steps = 0
        self._events: list[dict[str, Any]] = []
        self._success = False
        self._reason = ""
        self.last_safety_event: Any = None
        self._closed = False

    # The episode's simulation, for policies, wrappers and checks that read the state.
    @property
    def model(self) -> mujoco.MjModel | None:
        return self.physics.model if self.physics is not None else None

    @property
    def data(self) -> mujoco.MjData | None:
        return self.physics.data if self.physics is not None else None

    @property
    def controller(self) -> RobotController | None:
        return self.physics.controller if self.physics is not None else None

    @property
    def assist(self) -> GraspAssist | None:
        return self.physics.assist if self.physics is not None else None

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
        if "suite" in options:
            options = suite_reset_options(options)
        if {"scene", "instruction", "episode", "dataset", "episode_index"} & set(options):
            episode = episode_from_options(options, self.cache)
            if len(episode.scene.objects) > self.max_objects:  # the observation has a slot per object
                raise ConfigError(f"reset: the episode's scene has {len(episode.scene.objects)} objects, the "
                                  f"environment's observation {self.max_objects} slots; make the environment with "
                                  f"scene.max_objects ≥ {len(episode.scene.objects)}")
        else:
            family = options.pop("family", None)
            if options:
                raise ConfigError(f"reset: unknown option(s) {sorted(options)}; valid: dataset, episode, "
                                  "episode_index, family, instruction, scene, suite")
            episode = sample_episode(self.np_random, self.cache, self.config.task_families, family=family,
                                     num_scenes=self.config.num_scenes, scene_seed=self.config.scene_seed)
        self._start(episode)
        return self._observation(), self._info(None, None)

    def _start(self, episode: EpisodeSpec) -> None:
        model, pristine, _ = self.cache.compiled(episode.scene)
        self.observer.start(model, episode.text)
        data = self.data if model is self.model else mujoco.MjData(model)
        cfg = self.config
        self.physics = EpisodePhysics(model, data, pristine, episode, self.control, cfg.grasp_assist, cfg.checker)
        self.episode = episode
        self.task = parse_task(episode.instruction["task"], episode.family)
        self._steps = 0
        self._events = []
        self._success = False
        self._reason = ""
        self.subtask = ""
        self.last_safety_event = None
        self._plan, self._plan_note, self.plan_subtask = None, "", ""
        if cfg.oracle_subtask:
            directions = episode.annotation.get("directions") if episode.annotation else None
            self._plan, self._plan_note = plan_tracker(
                model, data, episode.scene, episode.instruction["task"], episode.family, directions,
                int(episode.scene.seed), cfg.physics_hz, cfg.control_hz)
            self._track_plan()

    # ------------------------------------------------------------------ stepping
    def step(self, action: Any) -> tuple[dict, float, bool, bool, dict]:
        """Apply one action for one control period; see the module docstring."""
        if self._closed:
            raise ActionError("step() after close(): the environment is closed; make a new one")
        physics = self.physics
        if physics is None:
            raise SamplehdError("call reset() before step()")
        a, clipped_box = self._checked_action(action)
        report = physics.apply(a, self._mode)
        self.last_safety_event = report.safety_event
        self._steps += 1
        event = report.safety_event.to_dict() if report.safety_event is not None else None
        if event is not None:
            self._events.append(event)
        if not self._success and (self._steps % self.config.success_check_every == 0):
            self._success, self._reason = physics.check(self.task)
        reward = 1.0 if self._success else 0.0
        obs = self._observation()
        if self.config.dense_reward:
            reward += dense_term(obs["tcp_pos"], physics.object_pos(self.task.objects[0]))
        terminated = bool(self._success or (physics.stopped and self.config.terminate_on_safety))
        limit = self.config.max_episode_steps
        truncated = bool(not terminated and limit is not None and self._steps >= limit)
        self._track_plan()
        info = self._info(report, event)
        info["action_clipped"] = bool(clipped_box or report.clipped)
        return obs, float(reward), terminated, truncated, info

    def _checked_action(self, action: Any) -> tuple[np.ndarray, bool]:
        """The action as floats inside the action space, and whether it was clipped into it."""
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
        clipped = bool(np.any(a < self._low) or np.any(a > self._high))
        return (np.clip(a, self._low, self._high) if clipped else a), clipped

    def _track_plan(self) -> None:
        if self._plan is not None:
            self.plan_subtask = self._plan.update(self.physics.tcp_pos(), self.physics.finger_opening())

    def check_success(self) -> CheckReport:
        """The shared checker's full report on the current state (with the stability window)."""
        return self.physics.report(self.task).to_dict()

    # ------------------------------------------------------------------ observations
    def _observation(self) -> Observation:
        return self.observer.observe(self.physics)

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
            "safety_stop": self.physics.stopped,
            "action_clipped": False,
            "clipped": list(report.clipped) if report is not None else [],
            "unreachable": bool(report.unreachable) if report is not None else False,
            "scene_seed": ep.scene.seed,
            "elapsed_steps": self._steps,
        }

    # ------------------------------------------------------------------ rendering
    def render(self) -> np.ndarray | None:
        """RGB image (H×W×3 uint8) of ``render_camera`` when ``render_mode="rgb_array"``."""
        if self.render_mode != "rgb_array" or self.physics is None:
            return None
        return self.observer.render(self.physics.data)

    def close(self) -> None:
        """Free the renderers; the environment cannot step or reset afterwards."""
        self.observer.close()
        self._closed = True
        super().close()


def _describe(value: Any) -> str:
    """A short description of a value for messages."""
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."
