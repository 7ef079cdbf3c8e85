"""The library entry point: plan and execute one instruction's ground-truth path with retries.

:func:`plan_and_execute` compiles the scene (or takes a compiled one), runs attempts from the
scene's initial state until one passes the success checker, and returns its :class:`Episode`. An
attempt drives the planner's control targets (:class:`samplehd.motion.execute.Rollout`) through the
controller's step wrapped by the frame recorder (:class:`samplehd.record.recorder.RecordingStep`). A
failed attempt is retried with another grasp and other destination draws; when every attempt fails
it raises :class:`PathRejected` with a short, countable reason. A failed path is never returned.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from functools import partial
from typing import Any, TypedDict

import mujoco
import numpy as np

from samplehd.catalogue import ObjectFacts
from samplehd.errors import ConfigError, PlanningError
from samplehd.motion.assist import GraspAssist, compile_scene_with_assist
from samplehd.motion.execute import AttemptFailed, Plan, Rollout, drive, initial_state, scene_facts, step_controller
from samplehd.record.disturbances import Disturbance, Disturber
from samplehd.record.episode import Episode
from samplehd.record.recorder import ActionStep, FrameRecorder, RecordingStep
from samplehd.render.states import LiveStates
from samplehd.robot.controller import ControlConfig
from samplehd.scene.spec import SceneSpec
from samplehd.schema import Config, bounded
from samplehd.tasks.checker import CheckerConfig, CheckResult, check_success
from samplehd.tasks.task import ProgramTask, Task, get_family, parse_task
from samplehd.world.bodies import SceneBodies
from samplehd.world.layout import LAYOUT, Directions
from samplehd.world.planner_config import PlannerConfig
from samplehd.world.robot_info import RobotInfo

__all__ = ["FailedAttempt", "PathConfig", "PathRejected", "plan_and_execute"]


@dataclass(frozen=True)
class PathConfig(Config, section="paths"):
    """Settings of ground-truth path generation.

    Attributes:
        planner: planner distances, speeds and budgets.
        checker: success checker tolerances.
        control_hz: control (and recording) rate [Hz].
        physics_hz: physics rate [Hz].
        max_attempts: attempts per instruction before it is rejected.
        grasp_assist: weld the held object to the gripper between CloseGripper and OpenGripper
            (needs a model compiled with :func:`~samplehd.motion.assist.compile_scene_with_assist`).
        reject_fallen: reject paths after which any object has fallen over.
    """

    planner: PlannerConfig = field(default_factory=PlannerConfig)
    checker: CheckerConfig = field(default_factory=CheckerConfig)
    control_hz: float = bounded(20.0, lo=0.0, hi=1000.0, lo_open=True, unit="Hz")
    physics_hz: float = bounded(500.0, lo=0.0, hi=100_000.0, lo_open=True, unit="Hz")
    max_attempts: int = bounded(3, lo=1, hi=100)
    grasp_assist: bool = True
    reject_fallen: bool = True

    def __post_init__(self) -> None:
        super().__post_init__()
        ratio = self.physics_hz / self.control_hz
        if ratio < 1 or abs(ratio - round(ratio)) > 1e-9:
            raise ConfigError(f"paths.physics_hz={self.physics_hz!r}: must be an integer multiple of control_hz "
                              f"({self.control_hz})")



class FailedAttempt(TypedDict):
    """One failed attempt of a rejected path: its number (0 first), the reason code and the message."""

    attempt: int
    reason: str
    message: str


class PathRejected(PlanningError):
    """No attempt produced a path that passes the checker.

    Attributes:
        reason: countable key of the last failure (e.g. "no_feasible_grasp", "checker_failed").
        attempts: per attempt, its reason and message.
        failed_episode: the frames of the last failed attempt (``success`` False), for inspection
            only; never ground truth.
    """

    def __init__(self, reason: str, message: str, attempts: list[FailedAttempt],
                 failed_episode: Episode | None = None) -> None:
        super().__init__(message)
        self.reason = reason
        self.attempts = attempts
        self.failed_episode = failed_episode


def _copy_state(src: mujoco.MjData, dst: mujoco.MjData) -> None:
    dst.qpos[:] = src.qpos
    dst.qvel[:] = src.qvel
    dst.act[:] = src.act
    dst.ctrl[:] = src.ctrl
    dst.time = src.time


def _new_rollout(model: mujoco.MjModel, data: mujoco.MjData, scene: SceneSpec, rng: np.random.Generator,
                 config: PathConfig, facts: list[ObjectFacts | None], directions: Directions | None,
                 live: LiveStates | None = None, as_actions: bool = False) -> tuple[Rollout, RecordingStep]:
    """The rollout of one attempt and its recording step function.

    ``as_actions``: execute the recorded steering vectors as the environment does
    (:class:`~samplehd.record.recorder.ActionStep`), for episodes whose outcome only a bit-exact replay
    reproduces (disturbed ones: fingers push objects about); otherwise the planner's joint targets
    (the undisturbed data, unchanged).
    """
    control = ControlConfig(physics_hz=config.physics_hz, control_hz=config.control_hz)
    ctrl = initial_state(model, data, control)
    robot = RobotInfo.from_model(model, data)
    bodies = SceneBodies(model, len(scene.objects))
    step_assist = None
    if as_actions and config.grasp_assist:
        step_assist = GraspAssist(model, bodies.num_objects)
        step_assist.release(data)
    # The scene as compiled: every instruction of it starts its first grasp search from the same state.
    memo = f"{json.dumps(scene.to_dict(), sort_keys=True)} nq={model.nq} ngeom={model.ngeom}"
    ro = Rollout(model, data, ctrl, robot, bodies, facts, config.planner, rng, LAYOUT, directions,
                 use_assist=config.grasp_assist and not as_actions, step_assist=step_assist, grasp_memo=memo)
    recorder = FrameRecorder(model, data, robot.arm_qpos, robot.arm_dof, robot.finger_qpos, ro.finger_bodies,
                             robot.tcp_site, bodies.object_body, live)
    if as_actions:
        return ro, ActionStep(recorder, ctrl, step_assist, ro.info["assist"])
    return ro, RecordingStep(recorder, partial(step_controller, ctrl))


def _attempt(ro: Rollout, task: Task, exclude: dict[int, set[int]]) -> Plan[None]:
    """The plan of one attempt: pick (and place) each moved object in turn, in the planner's order."""
    remaining = list(task.objects)
    while remaining:
        i = ro.next_object(task, remaining)
        remaining.remove(i)
        k = -1
        try:
            k = yield from ro.pick(i, tuple(exclude.get(i, ())))
            if get_family(task.family).places:
                yield from ro.place(i, task, k)
        except AttemptFailed as exc:
            if exc.grasp < 0:
                exc.grasp = k if k >= 0 else ro.current_grasp
            exc.object = i  # type: ignore[attr-defined]
            raise


def _run_attempt(ro: Rollout, step: RecordingStep, scene: SceneSpec, task: Task, config: PathConfig,
                 exclude: dict[int, set[int]], directions: Directions | None) -> CheckResult:
    drive(_attempt(ro, task, exclude), step)
    step.recorder.record_target(ro.final_target())
    return check_success(ro.model, ro.data, scene, task, config.checker, LAYOUT, directions)


def _passes(result: CheckResult, config: PathConfig) -> bool:
    return result.success and not (config.reject_fallen and result.fallen)


def _check_reason(result: CheckResult, config: PathConfig) -> str:
    """The countable failure of a final state the checker rejects ("" when it passes)."""
    if _passes(result, config):
        return ""
    return "checker_failed" if not result.success else "knocked_over"


def _run_disturbed(disturber: Disturber, step: RecordingStep, scene: SceneSpec, task: Task, config: PathConfig,
                   exclude: dict[int, set[int]], directions: Directions | None) -> CheckResult:
    """The disturbed attempt: the recovering plan, then, while the checker rejects the final state after the
    disturbance, a recovery from it (every moved object grasped where it lies and moved again). The final
    frame is recorded by the caller."""
    ro = disturber.ro
    run = disturber.step(step)
    drive(disturber.plan(task, exclude), run)
    result = check_success(ro.model, ro.data, scene, task, config.checker, LAYOUT, directions)
    while disturber.fired and not _passes(result, config) and disturber.labels.recoveries < disturber.max_recoveries:
        disturber.notice_check(result.reason or f"objects {list(result.fallen)} fell over")
        drive(disturber.recovery_plan(task), run)
        result = check_success(ro.model, ro.data, scene, task, config.checker, LAYOUT, directions)
    step.recorder.record_target(ro.final_target())
    return result


def _disturbed_episode(disturber: Disturber, ro: Rollout, step: RecordingStep, scene: SceneSpec,
                       scene_index: int | None, instruction_index: int, family: str, seed: int, info: dict[str, Any],
                       result: CheckResult, caller: tuple[mujoco.MjModel, mujoco.MjData] | None,
                       live: LiveStates | None, reason: str) -> Episode:
    """The episode of an attempt whose disturbance was applied, labelled, whatever its outcome
    (``reason``: the failure that ended it, "" for a success). A live render keeps its frames."""
    success = not reason
    if caller is not None:
        _copy_state(ro.data, caller[1])
        mujoco.mj_forward(*caller)
    if live is not None:
        live.finish(success=True)
    episode = _episode(ro, step, scene, scene_index, instruction_index, family, seed, success, info)
    return disturber.finish(episode, success, reason)


def _episode(ro: Rollout, step: RecordingStep, scene: SceneSpec, scene_index: int | None, instruction_index: int,
             family: str, seed: int, success: bool, info: dict[str, Any]) -> Episode:
    return Episode(
        scene_index=int(scene.index if scene_index is None else scene_index),
        instruction_index=int(instruction_index),
        family=family,
        seed=int(seed),
        subtasks=tuple(ro.subtasks) or ("GripperMoveAvoid",),
        frames=step.recorder.frames(),
        success=success,
        info=info,
    )


def plan_and_execute(
    scene: SceneSpec,
    task: ProgramTask | Task,
    rng: np.random.Generator,
    config: PathConfig | None = None,
    *,
    family: str | None = None,
    scene_index: int | None = None,
    instruction_index: int = 0,
    seed: int = 0,
    directions: Directions | None = None,
    compiled: tuple[mujoco.MjModel, mujoco.MjData] | None = None,
    live: LiveStates | None = None,
    disturbance: Disturbance | None = None,
    max_recoveries: int = 3,
) -> Episode:
    """Generate the ground-truth path of one instruction.

    Args:
        scene: the ``SceneSpec``.
        task: the executor's task dict (or a parsed Task).
        rng: the only source of randomness (destinations, RRT, retries).
        config: path settings.
        family: the instruction's family if it differs from the task type ("remove").
        scene_index: recorded in the episode (default: ``scene.index``).
        instruction_index: recorded in the episode.
        seed: recorded in the episode (the seed ``rng`` was made from).
        directions: the scene's direction vectors (default: the layout's).
        compiled: an already compiled (model, data) of this scene, to skip compilation; ``data`` is
            left in the episode's final state. A model without the grasp welds (plain
            ``compile_scene``) is replaced internally by an identical one with them
            (:func:`~samplehd.motion.assist.compile_scene_with_assist`) when the assist is on.
        live: every attempt's states also go there as they are recorded (each attempt restarts it), and it is
            finished when this returns (success) or raises (no episode), for rendering beside the rollout
            (:func:`samplehd.render.states.render_live`).
        disturbance: apply it in the rollout and let the oracle recover
            (:mod:`samplehd.record.disturbances`); once it has been applied, the episode is returned
            whatever its outcome, with its labels (``info["disturbance"]`` and the per-frame flags).
        max_recoveries: with a disturbance: recoveries before the episode is kept as a failure.

    Returns:
        The successful episode (``success`` True, checker report in ``info["check"]``), or with a
        disturbance that was applied, the episode whatever its outcome.

    Raises:
        PathRejected: every attempt failed; ``reason`` says why.
        PlanningError: the task is malformed.
    """
    try:
        episode = _plan_and_execute(scene, task, rng, config, family, scene_index, instruction_index, seed,
                                    directions, compiled, live, disturbance, max_recoveries)
    finally:
        if live is not None:
            live.finish(success=False)  # no-op after a success (only the first finish counts)
    return episode


def _plan_and_execute(scene: SceneSpec, task: ProgramTask | Task, rng: np.random.Generator,
                      config: PathConfig | None, family: str | None, scene_index: int | None,
                      instruction_index: int, seed: int, directions: Directions | None,
                      compiled: tuple[mujoco.MjModel, mujoco.MjData] | None, live: LiveStates | None,
                      disturbance: Disturbance | None = None, max_recoveries: int = 3) -> Episode:
    config = config or PathConfig()
    t = parse_task(task, family)
    n = len(scene.objects)
    for i in t.involved:
        if not 0 <= i < n:
            raise PlanningError(f"task names object {i}, but the scene has objects 0..{n - 1}")
    model, data = compiled if compiled is not None else compile_scene_with_assist(scene, 1.0 / config.physics_hz)
    caller: tuple[mujoco.MjModel, mujoco.MjData] | None = None
    if compiled is not None and config.grasp_assist and not GraspAssist(model, n).available:
        # A plain compile_scene model: run on an identical one with the grasp welds (same nq, nv,
        # na) from the caller's state, and hand the final state back to the caller's data.
        caller = compiled
        model, data = compile_scene_with_assist(scene, float(caller[0].opt.timestep))
        _copy_state(caller[1], data)
        mujoco.mj_forward(model, data)
    start = mujoco.MjData(model)
    mujoco.mj_copyData(start, model, data)
    facts = scene_facts(scene)
    exclude: dict[int, set[int]] = {}
    attempts: list[FailedAttempt] = []
    reason, message = "", ""
    last: tuple[Rollout, RecordingStep] | None = None
    for attempt in range(config.max_attempts):
        mujoco.mj_copyData(data, model, start)
        sub = np.random.default_rng(rng.integers(2**63))
        if live is not None:
            live.restart()
        ro, step = _new_rollout(model, data, scene, sub, config, facts, directions, live,
                                as_actions=disturbance is not None)
        disturber = None if disturbance is None else Disturber(disturbance, ro, max_recoveries)
        try:
            if disturber is None:
                result = _run_attempt(ro, step, scene, t, config, exclude, directions)
            else:
                result = _run_disturbed(disturber, step, scene, t, config, exclude, directions)
        except AttemptFailed as exc:
            if disturber is not None and disturber.fired:
                step.recorder.record_target(ro.final_target())
                result = check_success(ro.model, ro.data, scene, t, config.checker, LAYOUT, directions)
                info = {"scene": scene.to_dict(), "task": t.to_dict(), "attempts": attempt + 1,
                        "failed_attempts": attempts, "check": result.to_dict(), "control_hz": config.control_hz,
                        "physics_hz": config.physics_hz, **ro.info}
                # The outcome is the checker's verdict on the final state, as for a plan that ends (and as
                # `validate --replay` judges it): a failure after the task was done does not undo it.
                return _disturbed_episode(disturber, ro, step, scene, scene_index, instruction_index,
                                          family or t.family, seed, info, result, caller, live,
                                          "" if _passes(result, config) else exc.reason)
            last = ro, step
            reason, message = exc.reason, str(exc)
            attempts.append({"attempt": attempt, "reason": reason, "message": message})
            obj = getattr(exc, "object", -1)
            if exc.grasp >= 0 and obj >= 0:
                exclude.setdefault(obj, set()).add(exc.grasp)
            continue
        if disturber is not None and disturber.fired:
            info = {"scene": scene.to_dict(), "task": t.to_dict(), "attempts": attempt + 1,
                    "failed_attempts": attempts, "check": result.to_dict(), "control_hz": config.control_hz,
                    "physics_hz": config.physics_hz, **ro.info}
            return _disturbed_episode(disturber, ro, step, scene, scene_index, instruction_index,
                                      family or t.family, seed, info, result, caller, live,
                                      _check_reason(result, config))
        if not result.success or (config.reject_fallen and result.fallen):
            reason = "checker_failed" if not result.success else "knocked_over"
            message = result.reason or f"objects {list(result.fallen)} fell over"
            attempts.append({"attempt": attempt, "reason": reason, "message": message})
            last = ro, step
            # Try another grasp of the first moved object next time.
            for g in ro.info["grasps"][:1]:
                exclude.setdefault(int(g["object"]), set()).add(int(g["index"]))
            continue
        info = {
            "scene": scene.to_dict(),
            "task": t.to_dict(),
            "attempts": attempt + 1,
            "failed_attempts": attempts,
            "check": result.to_dict(),
            "control_hz": config.control_hz,
            "physics_hz": config.physics_hz,
            **ro.info,
        }
        if caller is not None:
            _copy_state(data, caller[1])
            mujoco.mj_forward(*caller)
        if live is not None:
            live.finish(success=True)
        return _episode(ro, step, scene, scene_index, instruction_index, family or t.family, seed, True, info)
    if caller is not None:
        _copy_state(data, caller[1])
        mujoco.mj_forward(*caller)
    ro, step = last
    failed = _episode(ro, step, scene, scene_index, instruction_index, family or t.family, seed, False,
                      {"task": t.to_dict(), "failed_attempts": attempts, **ro.info})
    raise PathRejected(reason, f"instruction {instruction_index}: {message}", attempts, failed)
