"""info["oracle_plan_subtask"]: where an episode stands in the oracle's plan, whatever policy drives."""

from __future__ import annotations

import numpy as np
import pytest

import samplehd  # noqa: F401  (GL backend before mujoco)
from samplehd.envs.oracle import OraclePolicy
from samplehd.envs.plan_tracker import PlanTracker
from samplehd.envs.tabletop import TabletopEnv
from samplehd.errors import ConfigError
from samplehd.record.episode import SUBTASK_NAMES


def test_tracker_follows_the_plan_forwards_only() -> None:
    t = np.linspace(0.0, 1.0, 50)
    tcp = np.stack([t, np.zeros_like(t), np.zeros_like(t)], axis=1)
    sub = (t * 4.999).astype(int)
    tracker = PlanTracker(tcp, np.full(50, 0.085), sub, SUBTASK_NAMES[:5])
    assert tracker.update(np.array([0.0, 0.0, 0.0]), 0.085) == SUBTASK_NAMES[0]
    assert tracker.update(np.array([0.55, 0.0, 0.0]), 0.085) == SUBTASK_NAMES[2]
    # Going back towards the start does not rewind the plan.
    assert tracker.update(np.array([0.0, 0.0, 0.0]), 0.085) == SUBTASK_NAMES[2]
    assert tracker.update(np.array([1.0, 0.0, 0.0]), 0.085) == SUBTASK_NAMES[4]


def test_plan_subtask_agrees_with_the_oracle_driving(fast_options: dict) -> None:
    env = TabletopEnv(control_mode="steering", oracle_subtask=True, **fast_options)
    obs, info = env.reset(seed=3, options={"family": "place"})
    assert info["oracle_plan_note"] == "" and info["oracle_plan_subtask"] == "GripperMoveAvoid"
    policy = OraclePolicy(env)
    policy.reset(seed=3)
    agree, steps, seen = 0, 0, []
    for _ in range(800):
        action = policy(obs)
        own = env.subtask
        obs, _, terminated, truncated, info = env.step(action)
        steps += 1
        agree += own == info["oracle_plan_subtask"]
        if not seen or seen[-1] != info["oracle_plan_subtask"]:
            seen.append(info["oracle_plan_subtask"])
        if terminated or truncated:
            break
    assert info["success"]
    # The plan's subtasks are visited in the SAMPLE-HD order (object after object) and match the
    # driving oracle's own.
    assert seen[:4] == ["GripperMoveAvoid", "ApproachGrasp", "CloseGripper", "MoveUP"]
    order = list(SUBTASK_NAMES)
    for a, b in zip(seen, seen[1:], strict=False):
        assert (order.index(b) - order.index(a)) % len(order) in (1, 2), (a, b)
    assert agree >= 0.8 * steps
    env.close()


def test_plan_subtask_is_off_by_default_and_the_option_is_checked(fast_options: dict) -> None:
    env = TabletopEnv(**fast_options)
    _, info = env.reset(seed=0)
    _, _, _, _, info = env.step(env.action_space.sample())
    assert info["oracle_plan_subtask"] == ""
    env.close()
    with pytest.raises(ConfigError, match="oracle_subtask"):
        TabletopEnv(oracle_subtask="yes")
