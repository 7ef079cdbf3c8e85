"""The closed-loop oracle through every control mode, and `samplehd evaluate` end to end."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from samplehd.benchmark.evaluation import EvalConfig, benchmark_split, evaluate
from samplehd.catalogue import load_catalogue
from samplehd.envs.config import CONTROL_MODES
from samplehd.envs.oracle import OraclePolicy, oracle_action
from samplehd.envs.tabletop import TabletopEnv
from samplehd.robot.constants import HOME_QPOS


def _run(env: TabletopEnv, oracle: OraclePolicy, seed: int, family: str) -> dict:
    obs, info = env.reset(seed=seed, options={"family": family})
    oracle.reset(seed=seed)
    subtasks = set()
    for _ in range(env.config.max_episode_steps):
        obs, reward, term, trunc, info = env.step(oracle(obs))
        subtasks.add(info["subtask"])
        if term or trunc or oracle.gave_up:
            break
    info["subtasks_seen"] = subtasks
    return info


@pytest.mark.parametrize("mode", list(CONTROL_MODES))
def test_oracle_picks_up_through_every_control_mode(mode: str, fast_options: dict) -> None:
    env = TabletopEnv(control_mode=mode, families=["pick_up"], max_episode_steps=400, **fast_options)
    oracle = OraclePolicy(env)
    info = _run(env, oracle, seed=0, family="pick_up")
    assert info["success"], (info["check_reason"], oracle.failure)
    assert {"GripperMoveAvoid", "ApproachGrasp", "CloseGripper"} <= info["subtasks_seen"]
    assert not info["safety_events"]
    oracle.close()


def test_oracle_actions_reproduce_the_joint_target_in_every_mode(fast_options: dict) -> None:
    """One step of each mode's oracle action moves the controller's target to the planned one."""
    q_next = HOME_QPOS + np.array([0.03, -0.02, 0.02, 0.01, -0.02, 0.03])
    for mode in CONTROL_MODES:
        env = TabletopEnv(control_mode=mode, **fast_options)
        env.reset(seed=0)
        a = oracle_action(mode, env.controller.target, q_next, 1.0, env)
        env.step(a)
        assert np.allclose(env.controller.target, q_next, atol=2e-3), mode


def test_benchmark_split_is_fixed_and_balanced() -> None:
    a = benchmark_split(12, ("place", "stack", "put"), 0)
    assert a == benchmark_split(12, ("place", "stack", "put"), 0)
    assert [f for _, f in a].count("stack") == 4
    assert len({s for s, _ in a}) == 12
    assert benchmark_split(3, ("place",), 1) != benchmark_split(3, ("place",), 0)


def test_evaluate_random_policy_writes_a_report_and_videos(tmp_path: Path, fast_options: dict) -> None:
    cfg = EvalConfig(policy="random", episodes=2, families=("pick_up", "place"), seed=3,
                     env={**fast_options, "max_episode_steps": 20, "width": 32, "height": 32},
                     video_dir=str(tmp_path / "videos"))
    report = evaluate(cfg, tmp_path / "report.json")
    saved = json.loads((tmp_path / "report.json").read_text())
    assert saved["episodes"] == 2 and saved["success_rate"] == report.success_rate == 0.0
    assert set(saved["by_family"]) <= {"pick_up", "place"}
    assert saved["catalogue"] == load_catalogue().record() and saved["catalogue"]["imported"] == {}
    rec = saved["records"][0]
    for key in ("seed", "family", "success", "steps", "safety_events"):
        assert key in rec
    videos = sorted((tmp_path / "videos").glob("*.mp4"))
    assert len(videos) == 2 and videos[0].stat().st_size > 0


def test_evaluate_records_the_objects_an_episode_disturbed(tmp_path: Path, fast_options: dict,
                                                           monkeypatch: pytest.MonkeyPatch) -> None:
    """A record lists the objects the task does not name that the episode moved; a policy that shoves one
    aside has it listed, and a success beside it would not count as undisturbed."""
    (tmp_path / "shoving_agents.py").write_text(
        "import mujoco\n"
        "import numpy as np\n"
        "def make(env):\n"
        "    def act(obs):\n"
        "        u = env.unwrapped\n"
        "        if getattr(u, 'shoved', None) is not u.episode:\n"
        "            u.shoved = u.episode\n"
        "            other = next(i for i in range(len(u.episode.scene.objects)) if i not in u.task.objects)\n"
        "            body = u.physics.object_body[other]\n"
        "            adr = u.model.jnt_qposadr[u.model.body_jntadr[body]]\n"
        "            u.data.qpos[adr:adr + 2] += 0.05\n"
        "            mujoco.mj_forward(u.model, u.data)\n"
        "        return np.zeros(7, dtype=np.float32)\n"
        "    return act\n"
    )
    monkeypatch.syspath_prepend(str(tmp_path))
    for spec, moved in (("random", False), ("shoving_agents:make", True)):
        cfg = EvalConfig(policy=spec, episodes=1, families=("place",), env={**fast_options, "max_episode_steps": 3})
        report = evaluate(cfg)
        assert bool(report.records[0].disturbed) == moved, report.records[0]
        assert report.overall.successes_undisturbed == 0


def test_evaluate_cli_rejects_a_bad_policy_in_one_line() -> None:
    for spec in ("not a policy", "no_such_module_xyz:act", "json:no_such_callable"):
        proc = subprocess.run([sys.executable, "-m", "samplehd", "evaluate", "--policy", spec, "--episodes", "1"],
                              capture_output=True, text=True, timeout=120)
        assert proc.returncode == 2, proc.stderr
        assert len(proc.stderr.strip().splitlines()) == 1 and "--policy" in proc.stderr


def test_evaluate_loads_a_user_policy_and_a_policy_factory(tmp_path: Path, fast_options: dict,
                                                           monkeypatch: pytest.MonkeyPatch) -> None:
    (tmp_path / "user_agents.py").write_text(
        "import numpy as np\n"
        "def act(obs):\n"
        "    return np.zeros(7, dtype=np.float32)\n"
        "def make(env):\n"
        "    return lambda obs: env.action_space.low * 0\n"
    )
    monkeypatch.syspath_prepend(str(tmp_path))
    for spec in ("user_agents:act", "user_agents:make"):
        cfg = EvalConfig(policy=spec, episodes=1, families=("pick_up",), env={**fast_options, "max_episode_steps": 5})
        report = evaluate(cfg)
        assert report.overall.episodes == 1 and report.records[0].steps == 5


def test_oracle_grasps_again_an_object_that_slipped(fast_options: dict) -> None:
    """Taken out of the gripper while carried (put back where it stood), the object is noticed missing;
    the oracle backs off and grasps it again (samplehd.motion.regrasp, the plan disturbed episodes
    recover with too) and still places it."""
    env = TabletopEnv(families=["place"], max_episode_steps=900, **fast_options)
    oracle = OraclePolicy(env)
    obs, _ = env.reset(seed=0, options={"family": "place"})
    oracle.reset(seed=0)
    model, data = env.model, env.data
    i = env.task.objects[0]
    joint = int(model.body_jntadr[model.body(f"object_{i}").id])
    adr, dof = int(model.jnt_qposadr[joint]), int(model.jnt_dofadr[joint])
    start = data.qpos[adr:adr + 7].copy()
    seen, taken = [], False
    for _ in range(env.config.max_episode_steps):
        obs, _, term, trunc, info = env.step(oracle(obs))
        if not seen or seen[-1] != info["subtask"]:
            seen.append(info["subtask"])
        if info["subtask"] == "ObjectMove" and not taken:
            env.assist.release(data)
            data.qpos[adr:adr + 7] = start
            data.qvel[dof:dof + 6] = 0.0
            taken = True
        if term or trunc or oracle.gave_up:
            break
    assert taken and info["success"], (info["check_reason"], oracle.failure)
    assert oracle.replans == 1
    again = seen.index("ObjectMove") + 1
    assert seen[again:again + 3] == ["OpenGripper", "MoveToDefaultPos", "GripperMoveAvoid"], seen
    assert seen.count("CloseGripper") == len(env.task.objects) + 1  # one grasp per object, one again
    oracle.close()


def test_oracle_gives_up_when_its_finished_plan_fails_the_check(fast_options: dict) -> None:
    """One plan per episode: a pick_up whose lift the checker does not accept (it asks for 0.5 m) ends
    with the oracle giving up on the check's reason once its plan has run, instead of planning the
    episode over until the step limit (the replans of one plan are not reset either)."""
    env = TabletopEnv(families=["pick_up"], max_episode_steps=600, checker={"lift_height": 0.5}, **fast_options)
    oracle = OraclePolicy(env)
    obs, _ = env.reset(seed=0, options={"family": "pick_up"})
    oracle.reset(seed=0)
    subtasks = []
    for _ in range(600):
        obs, _, term, trunc, info = env.step(oracle(obs))
        subtasks.append(info["subtask"])
        if term or trunc or oracle.gave_up:
            break
    assert not info["success"] and not trunc and oracle.gave_up, oracle.failure
    assert oracle.failure.startswith("check_failed: "), oracle.failure
    assert "Completed" in subtasks and subtasks.count("CloseGripper") == len(
        [s for s in subtasks[:subtasks.index("Completed")] if s == "CloseGripper"])
    oracle.close()
