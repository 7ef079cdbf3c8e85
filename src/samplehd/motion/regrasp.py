"""Re-grasping: the task's objects picked (and placed) in turn, a failed grasp answered by backing off and
grasping again.

One implementation for every planner that recovers: the closed-loop oracle
(:class:`samplehd.envs.oracle.OraclePolicy`) runs :func:`regrasping_plan` with its defaults, and the
recovery of a disturbed episode (:class:`samplehd.record.disturbances.Disturber`) with its hooks: the
failures it recovers from, a watch over the carried object, the wrong object grasped first, and its
labels.
"""

from __future__ import annotations

from collections.abc import Callable, Collection, Mapping
from typing import Any

from samplehd.motion.execute import AttemptFailed, Plan, Rollout
from samplehd.robot.constants import GRIPPER_STROKE
from samplehd.tasks.task import Task, get_family

__all__ = ["REGRASP_REASONS", "back_off", "regrasping_plan"]

# Failures (AttemptFailed reasons) answered by backing off and grasping the object again.
REGRASP_REASONS = ("grasp_missed", "grasp_slipped")


def back_off(ro: Rollout, i: int) -> Plan[None]:
    """OpenGripper wide, then MoveToDefaultPos: the arm leaves object ``i`` before grasping it again."""
    ro.hand = None
    yield from ro.hold("OpenGripper", i, ro.cfg.open_time, 1.0)
    yield from ro.go_home(i, GRIPPER_STROKE)


def _unwatched(plan: Plan[Any]) -> Plan[Any]:
    return plan


def regrasping_plan(ro: Rollout, task: Task, retries: int, *, reasons: tuple[str, ...] = REGRASP_REASONS,
                    exclude: Mapping[int, Collection[int]] | None = None,
                    watch: Callable[[Plan[Any]], Plan[Any]] = _unwatched,
                    before: Callable[[int], Plan[None]] | None = None,
                    on_failure: Callable[[AttemptFailed], bool] | None = None,
                    on_grasp: Callable[[int], None] | None = None) -> Plan[None]:
    """Pick (and, in families that place, place) each of the task's moved objects in the planner's order;
    a failure whose reason is in ``reasons`` is answered by :func:`back_off` and another pick of the
    object where it now lies, up to ``retries`` times per object, without the grasp that failed.

    Args:
        ro: the rollout.
        task: the task.
        retries: re-grasps per object; the failure after the last one propagates.
        reasons: the failures answered by a re-grasp; any other propagates.
        exclude: per object, grasp indices not to try (from earlier attempts).
        watch: wraps every pick and place plan (e.g. to throw a slip into it).
        before: a plan run at the start of the first object's first attempt (its failures count as
            that attempt's).
        on_failure: called with each failure that is answered, before the back-off; returns whether
            the grasp that failed is excluded from the next picks (default: always); it may raise to
            give up instead.
        on_grasp: called with the object after each successful pick.

    Raises:
        AttemptFailed: a failure that is not answered, or the last one.
    """
    exclude = exclude or {}
    places = get_family(task.family).places
    remaining = list(task.objects)
    lead = before
    while remaining:
        i = ro.next_object(task, remaining)
        remaining.remove(i)
        excluded = set(exclude.get(i, ()))
        for attempt in range(retries + 1):
            k = -1
            try:
                if lead is not None:
                    plan, lead = lead(i), None
                    yield from plan
                k = yield from watch(ro.pick(i, tuple(sorted(excluded))))
                if on_grasp is not None:
                    on_grasp(i)
                if places:
                    yield from watch(ro.place(i, task, k))
                break
            except AttemptFailed as exc:
                if exc.reason not in reasons or attempt == retries:
                    raise
                grasp = exc.grasp if exc.grasp >= 0 else k
                if (on_failure is None or on_failure(exc)) and grasp >= 0:
                    excluded.add(grasp)
                yield from back_off(ro, i)
        lead = None
