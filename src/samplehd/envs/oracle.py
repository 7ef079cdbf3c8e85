"""A closed-loop oracle policy: privileged state in, actions of the environment's control mode out.

The oracle runs the ground-truth path planner (:mod:`samplehd.motion`) on the environment's live
state, one subtask at a time, and turns each planned joint target into an action of the
environment's control mode:

- ``joint_pos``: the target itself;
- ``joint_delta``: the target minus the controller's current target;
- ``ee_delta``: the TCP motion between the two targets' forward kinematics (translation and
  rotation vector, base frame);
- ``steering``: the same motion divided by the steering scales (as the dataset's steering vectors).

It closes the loop: every subtask is planned from the state the previous one left; while it
carries an object it checks every step that the object is still between the fingers, and when a
grasp misses or the object slips it opens the gripper, backs off and plans a new grasp of the
object where it now lies (up to ``max_replans`` times per object).

The planner is written as straight-line code that executes subtasks as it goes; the oracle runs it
in a worker thread that hands over one action per :meth:`OraclePolicy.__call__` and waits for the
environment to step. Exactly one of the two threads runs at any time, so episodes are deterministic.
"""

from __future__ import annotations

import queue
import threading
from typing import Any

import numpy as np

from samplehd.errors import PlanningError
from samplehd.motion.execute import AttemptFailed, Rollout
from samplehd.motion.planner import PlannerConfig
from samplehd.motion.robot_info import RobotInfo
from samplehd.record.recorder import _rotvec, steering_from_targets
from samplehd.robot.constants import GRIPPER_STROKE
from samplehd.robot.controller import ControlReport, RobotController
from samplehd.robot.kinematics import fk_tcp
from samplehd.scene.layout import LAYOUT
from samplehd.tasks.state import SceneBodies

__all__ = ["OraclePolicy", "oracle_action"]

# Failures after which the oracle backs off and grasps the object again.
_REGRASP_REASONS = ("grasp_missed", "grasp_slipped")


class _Stop(Exception):
    """Raised inside the worker to end it (episode over or policy reset)."""


def oracle_action(mode: str, q_now: np.ndarray, q_next: np.ndarray, gripper: float, env: Any) -> np.ndarray:
    """Action of an environment control mode that moves the joint target from ``q_now`` to ``q_next``."""
    if mode == "joint_pos":
        a = np.append(q_next, gripper)
    elif mode == "joint_delta":
        a = np.append(q_next - q_now, gripper)
    else:
        t0, t1 = fk_tcp(q_now), fk_tcp(q_next)
        lin = t1[:3, 3] - t0[:3, 3]
        rot = _rotvec(t1[:3, :3] @ t0[:3, :3].T)
        if mode == "ee_delta":
            a = np.concatenate([lin, rot, [gripper]])
        else:
            c = env.control
            a = steering_from_targets(t0, t1, gripper, c.control_dt, c.max_linear_speed, c.max_angular_speed)
    # float64: in joint_pos mode the targets then reach the controller bit for bit, as in the
    # offline paths (float32 would round them by ~1e-7 rad, enough for contacts to diverge).
    lo, hi = env.action_space.low.astype(float), env.action_space.high.astype(float)
    return np.clip(np.asarray(a, dtype=float), lo, hi)


class _ActingController:
    """Stands in for the robot controller inside the planner's Rollout: each ``step`` becomes an
    action of the environment's control mode, taken by the environment on the caller's thread.

    Everything else (targets, config, state) is the environment's own controller.
    """

    def __init__(self, policy: OraclePolicy, controller: RobotController) -> None:
        self._policy = policy
        self._controller = controller
        self.rollout: Rollout | None = None

    def __getattr__(self, name: str) -> Any:
        return getattr(self._controller, name)

    def step(self, action: np.ndarray, mode: str = "joint_position") -> ControlReport:
        ctrl = self._controller
        ro = self.rollout
        name = ro.subtasks[-1] if ro is not None and ro.subtasks else ""
        if ro is not None and ro.hand is not None and name in ("ObjectMove", "MoveDOWN"):
            # Closed loop: the object must still be between the fingers.
            welded = getattr(self._policy.env, "_assist", None)
            if (welded is None or welded.active != ro.hand.index) and ro._grasped() != ro.hand.index:
                raise AttemptFailed("grasp_slipped", f"object {ro.hand.index} slipped out of the gripper in {name}")
        self._policy.subtask = name
        a = np.asarray(action, dtype=float)
        self._policy._hand_over(ctrl.target, a[:6], float(a[6]))
        return ControlReport(time=float(ctrl.data.time), safety_event=self._policy.env.last_safety_event)


class OraclePolicy:
    """The closed-loop oracle for one environment.

    Args:
        env: the environment (a ``gymnasium.make`` result or a :class:`TabletopEnv`); the oracle
            reads its privileged state through ``env.unwrapped``.
        seed: seed of the planner's generator (destinations, RRT); :meth:`reset` may change it.
        planner: planner settings (default: the dataset's).
        max_replans: re-grasps per object after a miss or a slip.

    Example:
        >>> oracle = OraclePolicy(env)                 # doctest: +SKIP
        >>> obs, info = env.reset(seed=0)              # doctest: +SKIP
        >>> oracle.reset(seed=0)                       # doctest: +SKIP
        >>> obs, *_ = env.step(oracle(obs))            # doctest: +SKIP
    """

    def __init__(self, env: Any, seed: int = 0, planner: PlannerConfig | None = None, max_replans: int = 2) -> None:
        self.env = env.unwrapped
        self.planner = planner or PlannerConfig()
        self.max_replans = max_replans
        self.seed = seed
        self.subtask = ""
        self.failure = ""
        self.replans = 0
        self._worker: threading.Thread | None = None
        self._actions: queue.Queue = queue.Queue(maxsize=1)
        self._resume: queue.Queue = queue.Queue(maxsize=1)
        self._episode: Any = None
        self._finished = False

    # ------------------------------------------------------------------ policy API
    def reset(self, seed: int | None = None) -> None:
        """Forget the current plan (call after ``env.reset``)."""
        self._stop_worker()
        if seed is not None:
            self.seed = seed
        self.subtask = ""
        self.failure = ""
        self.replans = 0
        self._episode = None
        self._finished = False

    def __call__(self, obs: Any = None) -> np.ndarray:
        """The next action; ``obs`` is unused (the oracle reads privileged state)."""
        env = self.env
        if self._episode is not env.episode or self._worker is None:
            self.reset()
            self._episode = env.episode
            self._start_worker()
        elif self._finished:
            return self._hold_action()
        else:
            self._resume.put("go")
        kind, payload = self._next()
        if kind == "action":
            return payload
        self._finished = True
        if kind == "error":
            raise payload
        return self._hold_action()  # done or given up: hold still

    @property
    def gave_up(self) -> bool:
        """Whether the oracle stopped trying in this episode (it then holds still)."""
        return self._finished and bool(self.failure)

    def _next(self) -> tuple[str, Any]:
        """Wait for the worker's next message; a worker that ended silently counts as done."""
        while True:
            try:
                return self._actions.get(timeout=0.5)
            except queue.Empty:
                w = self._worker
                if w is None or not w.is_alive():
                    try:
                        return self._actions.get_nowait()
                    except queue.Empty:
                        return "done", None

    def close(self) -> None:
        """End the worker thread."""
        self._stop_worker()

    def episode_task(self) -> Any:
        """The task to carry out (a :class:`samplehd.tasks.task.Task`): the environment's own.

        A policy that decides the task itself (from a parsed instruction and a perceived scene)
        overrides this; it runs on the worker thread before planning starts.
        """
        return self.env._task

    # ------------------------------------------------------------------ worker
    def _hold_action(self) -> np.ndarray:
        env = self.env
        ctrl = env.controller
        g = 2.0 * ctrl.gripper_width / GRIPPER_STROKE - 1.0
        return oracle_action(env.config.control_mode, ctrl.target, ctrl.target, g, env)

    def _hand_over(self, q_now: np.ndarray, q_next: np.ndarray, gripper: float) -> None:
        env = self.env
        env.subtask = self.subtask
        a = oracle_action(env.config.control_mode, q_now, q_next, gripper, env)
        self._actions.put(("action", a))
        if self._resume.get() == "stop":
            raise _Stop("policy reset")
        if env.controller.stopped is not None:
            raise _Stop(f"safety stop: {env.controller.stopped}")

    def _start_worker(self) -> None:
        self._finished = False
        self._actions = queue.Queue(maxsize=1)
        self._resume = queue.Queue(maxsize=1)
        self._worker = threading.Thread(target=self._work, name="samplehd-oracle", daemon=True)
        self._worker.start()

    def _stop_worker(self) -> None:
        w = self._worker
        self._worker = None
        if w is None or not w.is_alive():
            return
        # The worker waits in _hand_over for a resume message (or has finished and waits for nothing).
        try:
            self._resume.put_nowait("stop")
        except queue.Full:
            pass
        w.join(timeout=10.0)

    def _work(self) -> None:
        try:
            self._plan_and_act()
            self._actions.put(("done", None))
        except _Stop:
            return
        except Exception as exc:  # noqa: BLE001 - handed to the caller's thread
            self._actions.put(("error", exc))

    def _plan_and_act(self) -> None:
        from samplehd.catalogue import object_facts

        env = self.env
        model, data, ctrl = env.model, env.data, env.controller
        scene = env.episode.scene
        task = self.episode_task()
        facts = []
        for o in scene.objects:
            try:
                facts.append(object_facts(o.instance))
            except Exception:  # noqa: BLE001 - objects unknown to the catalogue fall back to model geometry
                facts.append(None)
        # The generator of the offline generator's first attempt (plan_and_execute draws each
        # attempt's generator from the episode's), so both make the same random choices.
        rng = np.random.default_rng(np.random.default_rng(self.seed).integers(2**63))
        directions = env.episode.annotation.get("directions") if env.episode.annotation else None
        robot = RobotInfo.from_model(model, data)
        bodies = SceneBodies(model, len(scene.objects))
        acting = _ActingController(self, ctrl)
        # The environment's grasp assist (when on) welds for every policy; the planner must not weld itself.
        ro = Rollout(model, data, acting, robot, bodies, facts, self.planner, rng, LAYOUT, directions,
                     use_assist=False)
        acting.rollout = ro
        for i in task.objects:
            exclude: set[int] = set()
            for attempt in range(self.max_replans + 1):
                k = -1
                try:
                    k = ro.pick(i, tuple(exclude))
                    if task.family != "pick_up":
                        ro.place(i, task, k)
                    break
                except AttemptFailed as exc:
                    grasp = exc.grasp if exc.grasp >= 0 else k
                    if exc.reason not in _REGRASP_REASONS or attempt == self.max_replans:
                        self.failure = exc.reason
                        return
                    self.replans += 1
                    if grasp >= 0:
                        exclude.add(grasp)
                    try:
                        self._back_off(ro, i)
                    except PlanningError as back:
                        self.failure = getattr(back, "reason", "no_path_home")
                        return
                except PlanningError as exc:
                    self.failure = f"planning: {exc}"
                    return
        self.subtask = "Completed"
        env.subtask = "Completed"

    def _back_off(self, ro: Rollout, i: int) -> None:
        """Open the gripper and retreat home before grasping object ``i`` again."""
        ro.hand = None
        ro.hold("OpenGripper", i, self.planner.open_time, 1.0)
        ro.go_home(i, GRIPPER_STROKE)
