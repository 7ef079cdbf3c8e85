"""Every bad option, reset option and action of ``samplehd/Tabletop-v0`` is a clean refusal: a
samplehd error (a ``ValueError`` where the Gymnasium contract expects one) with a one-line message
naming the option and the bad value; never another exception and never a silent substitute."""

from __future__ import annotations

import copy
import json
import math
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import pytest

import samplehd  # noqa: F401  (registers the environment, sets MUJOCO_GL)
from samplehd.envs import ENV_ID, register_envs
from samplehd.envs.tabletop import TabletopEnv
from samplehd.errors import SamplehdError

FAST = {"scene": {"min_objects": 3, "max_objects": 3}, "num_scenes": 1, "scene_seed": 7}

# (id, options, fragment the message must hold)
ENV_OPTION_CASES: list[tuple[str, dict[str, Any], str]] = [
    ("obs-mode", {"obs_mode": "bogus"}, "obs_mode"),
    ("control-mode", {"control_mode": "bogus"}, "control_mode"),
    ("cameras-str", {"obs_mode": "rgb", "cameras": "scene"}, "cameras"),
    ("cameras-unknown", {"cameras": ["bogus"]}, "cameras"),
    ("cameras-dup", {"cameras": ["scene", "scene"]}, "cameras"),
    ("cameras-none-for-images", {"obs_mode": "rgb", "cameras": []}, "cameras"),
    ("width-zero", {"width": 0}, "width"),
    ("width-str", {"width": "64"}, "width"),
    ("width-float", {"width": 64.5}, "width"),
    ("height-huge", {"height": 100_000}, "height"),
    ("render-preset", {"render_preset": "bogus"}, "render_preset"),
    ("obs-mode-list", {"obs_mode": ["rgb"]}, "obs_mode"),
    ("control-mode-dict", {"control_mode": {"steering": 1}}, "control_mode"),
    ("render-preset-list", {"render_preset": ["fast"]}, "render_preset"),
    ("camera-list-in-list", {"obs_mode": "rgb", "cameras": [["scene"]]}, "cameras"),
    ("render-mode", {"render_mode": "bogus"}, "render_mode"),
    ("render-camera", {"render_camera": "bogus"}, "render_camera"),
    ("control-hz-zero", {"control_hz": 0}, "control_hz"),
    ("control-hz-nan", {"control_hz": math.nan}, "control_hz"),
    ("control-hz-str", {"control_hz": "20"}, "control_hz"),
    ("physics-not-multiple", {"physics_hz": 510.0}, "physics_hz"),
    ("physics-below-control", {"physics_hz": 10.0}, "physics_hz"),
    ("families-str", {"families": "place"}, "families"),
    ("families-unknown", {"families": ["bogus"]}, "families"),
    ("scene-str", {"scene": "x"}, "scene"),
    ("scene-unknown", {"scene": {"bogus_key": 1}}, "bogus_key"),
    ("scene-min-objects", {"scene": {"min_objects": 0}}, "min_objects"),
    ("scene-classes-str", {"scene": {"classes": "mug"}}, "classes"),
    ("num-scenes-neg", {"num_scenes": -1}, "num_scenes"),
    ("scene-seed-neg", {"scene_seed": -1}, "scene_seed"),
    ("max-steps-zero", {"max_episode_steps": 0}, "max_episode_steps"),
    ("max-steps-neg", {"max_episode_steps": -1}, "max_episode_steps"),
    ("max-steps-float", {"max_episode_steps": 10.5}, "max_episode_steps"),
    ("tokens-small", {"max_instruction_tokens": 1}, "max_instruction_tokens"),
    ("chars-small", {"max_instruction_chars": 2}, "max_instruction_chars"),
    ("dense-reward-str", {"dense_reward": "yes"}, "dense_reward"),
    ("check-every-zero", {"success_check_every": 0}, "success_check_every"),
    ("terminate-int", {"terminate_on_safety": 1}, "terminate_on_safety"),
    ("assist-none", {"grasp_assist": None}, "grasp_assist"),
    ("oracle-str", {"oracle_subtask": "no"}, "oracle_subtask"),
    ("cache-zero", {"scene_cache_size": 0}, "scene_cache_size"),
    ("checker-neg", {"checker": {"lift_height": -1}}, "lift_height"),
    ("checker-str", {"checker": "x"}, "checker"),
    ("checker-unknown", {"checker": {"bogus_key": 1}}, "bogus_key"),
    ("unknown-option", {"bogus_option": 1}, "bogus_option"),
]


def _one_line_error(exc: BaseException, fragment: str) -> None:
    assert isinstance(exc, SamplehdError), f"{type(exc).__name__}: {exc}"
    text = str(exc)
    assert "\n" not in text and fragment in text, text


@pytest.mark.parametrize(("options", "fragment"), [pytest.param(o, f, id=i) for i, o, f in ENV_OPTION_CASES])
def test_bad_env_option_is_refused(options: dict[str, Any], fragment: str) -> None:
    register_envs()
    makers = [lambda: TabletopEnv(**options)]
    if "max_episode_steps" not in options:  # gymnasium.make takes that one itself (see the next test)
        makers.append(lambda: gym.make(ENV_ID, **options))
    for make in makers:
        with pytest.raises(Exception) as info:  # noqa: PT011 - the type is checked below
            make()
        _one_line_error(info.value, fragment)


def test_gymnasium_make_step_limit_is_the_one_in_force() -> None:
    """gymnasium.make keeps max_episode_steps for its TimeLimit wrapper; that limit is the one that
    truncates (not a silent 1500 of the environment's own), and -1 means no limit, as Gymnasium says."""
    register_envs()
    env = gym.make(ENV_ID, max_episode_steps=3, **FAST)
    env.reset(seed=0)
    steps = [env.step(np.zeros(7, np.float32))[3] for _ in range(3)]
    assert steps == [False, False, True]
    assert env.unwrapped.config.max_episode_steps is None
    assert gym.make(ENV_ID, **FAST).spec.max_episode_steps == 1500
    unlimited = gym.make(ENV_ID, max_episode_steps=-1, **FAST)
    assert unlimited.spec.max_episode_steps is None and unlimited.unwrapped.config.max_episode_steps is None
    with pytest.raises(ValueError, match="max_episode_steps"):
        gym.make(ENV_ID, max_episode_steps=0, **FAST)


@pytest.fixture(scope="module")
def episode() -> dict[str, Any]:
    """One real reset: its environment, scene and instruction."""
    env = TabletopEnv(**FAST)
    env.reset(seed=3)
    return {"env": env, "scene": env.episode.scene.to_dict(), "instruction": copy.deepcopy(env.episode.instruction)}


def _absent_class(scene: dict[str, Any]) -> str:
    from samplehd.catalogue import catalogue_for

    present = {o["instance"]["class_name"] for o in scene["objects"]}
    return next(c for c in catalogue_for(()).classes if c not in present)


def _reset_cases(ep: dict[str, Any]) -> list[tuple[str, Any, str]]:
    scene, instruction = ep["scene"], ep["instruction"]
    n = len(scene["objects"])

    def with_task(**task: Any) -> dict[str, Any]:
        q = copy.deepcopy(instruction)
        q.pop("program", None)
        q.pop("program_sequence", None)
        q["task"] = {**q["task"], **task}
        return {"scene": scene, "instruction": q}

    far = copy.deepcopy(scene)
    far["objects"][0]["pos"] = [1e9, 0.0, 0.75]
    nan_pos = copy.deepcopy(scene)
    nan_pos["objects"][0]["pos"] = [math.nan, 0.0, 0.75]
    zero_quat = copy.deepcopy(scene)
    zero_quat["objects"][0]["quat"] = [0.0, 0.0, 0.0, 0.0]
    other_scene = copy.deepcopy(instruction)
    absent = _absent_class(scene)
    other_scene["program"] = [{"type": "scene", "inputs": [], "value_inputs": []},
                              {"type": "filter_name", "inputs": [0], "value_inputs": [absent]},
                              {"type": "unique", "inputs": [1], "value_inputs": []},
                              {"type": "pick_up", "inputs": [2], "value_inputs": []}]
    other_scene["instruction"] = f"Lift the {absent.replace('_', ' ')} off the table."
    other_scene.pop("task", None)
    other_scene.pop("program_sequence", None)
    mismatch = copy.deepcopy(instruction)
    mismatch["task"] = {**mismatch["task"], "objects": [(mismatch["task"]["objects"][0] + 1) % n]}
    return [
        ("options-str", "family=place", "options"),
        ("unknown", {"bogus_key": 1}, "bogus_key"),
        ("family", {"family": "bogus"}, "bogus"),
        ("scene-str", {"scene": "x", "instruction": instruction}, "scene"),
        ("scene-no-instruction", {"scene": scene}, "instruction"),
        ("instruction-str", {"scene": scene, "instruction": "Lift the mug."}, "instruction"),
        ("instruction-no-text", {"scene": scene, "instruction": {"task": instruction["task"]}}, "instruction"),
        ("instruction-no-task", {"scene": scene, "instruction": {"instruction": "Lift it."}}, "task"),
        ("task-str", {"scene": scene, "instruction": {"instruction": "x", "task": "pick_up"}}, "task"),
        ("task-target-range", with_task(objects=[n + 5]), str(n + 5)),
        ("task-target-negative", with_task(objects=[-1]), "-1"),
        ("task-type", with_task(type="juggle"), "juggle"),
        ("task-subject-range", with_task(type="stack", objects=[0], subject=n + 3), str(n + 3)),
        ("program-other-scene", {"scene": scene, "instruction": other_scene}, "does not fit the scene"),
        ("task-program-mismatch", {"scene": scene, "instruction": mismatch}, "another scene"),
        ("object-far", {"scene": far, "instruction": instruction}, "pos"),
        ("object-nan", {"scene": nan_pos, "instruction": instruction}, "pos"),
        ("object-quat", {"scene": zero_quat, "instruction": instruction}, "quat"),
        ("scene-missing-field", {"scene": {"index": 0}, "instruction": instruction}, "scene"),
        ("episode-index-alone", {"episode_index": 0}, "dataset"),
        ("dataset-missing", {"dataset": "/nonexistent/ds", "episode_index": 0}, "/nonexistent/ds"),
        ("episode-index-str", {"dataset": "/nonexistent/ds", "episode_index": "0"}, "episode_index"),
        ("episode-bad-state", {"scene": scene, "instruction": instruction, "episode": {"qpos": [0.0]}}, "episode"),
        *_start_state_cases(ep),
    ]


def _start_state_cases(ep: dict[str, Any]) -> list[tuple[str, Any, str]]:
    """Start states and object lists that are finite, in range, unique and apart only in name."""
    env, scene, instruction = ep["env"], ep["scene"], ep["instruction"]
    model = env.model
    good = {"qpos": env.data.qpos.copy(), "qvel": np.zeros(model.nv), "act": np.zeros(model.na)}
    limited = next(j for j in range(model.njnt) if model.jnt_limited[j] and model.jnt_type[j] in (2, 3))

    def state(key: str, index: int, value: float) -> dict[str, Any]:
        s = {k: v.copy() for k, v in good.items()}
        s[key][index] = value
        return {"scene": scene, "instruction": instruction, "episode": s}

    def objects(value: list[Any]) -> dict[str, Any]:
        q = copy.deepcopy(instruction)
        q.pop("program", None)
        q.pop("program_sequence", None)
        q["task"] = {"type": "pick_up", "objects": value, "subject": None, "relation": None}
        q["family"] = "pick_up"
        return {"scene": scene, "instruction": q}

    def overlapping(shift: float) -> dict[str, Any]:
        s = copy.deepcopy(scene)
        s["objects"][1]["pos"] = [s["objects"][0]["pos"][0] + shift, *s["objects"][0]["pos"][1:]]
        return {"scene": s, "instruction": instruction}

    return [
        ("state-qpos-nan", state("qpos", 0, math.nan), "qpos[0]"),
        ("state-qpos-inf", state("qpos", 2, math.inf), "qpos[2]"),
        ("state-qvel-nan", state("qvel", 1, math.nan), "qvel[1]"),
        ("state-joint-range", state("qpos", int(model.jnt_qposadr[limited]), float(model.jnt_range[limited][1]) + 1.0),
         "range"),
        ("objects-duplicate", objects([0, 0]), "twice"),
        ("objects-float", objects([0.5]), "integers"),
        ("objects-bool", objects([True]), "integers"),
        ("objects-str", objects(["0"]), "integers"),
        ("scene-interpenetrating", overlapping(0.0), "inside each other"),
        ("scene-interpenetrating-near", overlapping(0.01), "inside each other"),
    ]


SEED_CASES: list[tuple[str, Any]] = [("float", 1.5), ("str", "1"), ("negative", -1), ("bool", True),
                                     ("list", [1]), ("nan", math.nan)]


@pytest.mark.parametrize("seed", [pytest.param(s, id=i) for i, s in SEED_CASES])
def test_bad_seed_is_our_refusal(episode: dict[str, Any], seed: Any) -> None:
    with pytest.raises(SamplehdError) as info:
        episode["env"].reset(seed=seed)
    _one_line_error(info.value, "seed")


def test_bad_reset_options_are_refused(episode: dict[str, Any]) -> None:
    env = episode["env"]
    cases = _reset_cases(episode)
    assert len(cases) >= 20
    failures = []
    for cid, options, fragment in cases:
        try:
            env.reset(seed=0, options=options)
        except Exception as exc:  # noqa: BLE001 - every kind is judged below
            if not isinstance(exc, SamplehdError) or "\n" in str(exc) or fragment not in str(exc):
                failures.append(f"{cid}: {type(exc).__name__}: {exc}")
        else:
            failures.append(f"{cid}: accepted")
    assert not failures, "\n".join(failures)
    # the environment still works after the refusals
    env.reset(seed=0)


ACTION_CASES: list[tuple[str, Any, str]] = [
    ("short", [0.0] * 6, "shape"),
    ("long", [0.0] * 8, "shape"),
    ("matrix", np.zeros((7, 1)), "shape"),
    ("nan", [math.nan] + [0.0] * 6, "NaN"),
    ("inf", [math.inf] + [0.0] * 6, "NaN or infinite"),
    ("complex", np.array([1 + 2j] + [0j] * 6), "complex"),
    ("strings", ["a"] * 7, "real numbers"),
    ("string", "forward", "real numbers"),
    ("none", None, "real numbers"),
    ("dict", {"x": 1.0}, "real numbers"),
]


@pytest.mark.parametrize(("action", "fragment"), [pytest.param(a, f, id=i) for i, a, f in ACTION_CASES])
def test_bad_action_is_refused(episode: dict[str, Any], action: Any, fragment: str) -> None:
    env = episode["env"]
    with pytest.raises(ValueError) as info:
        env.step(action)
    _one_line_error(info.value, fragment)


def test_step_and_reset_after_close_are_refused() -> None:
    env = TabletopEnv(**FAST)
    with pytest.raises(SamplehdError, match="reset"):
        env.step(np.zeros(7))
    env.reset(seed=1)
    env.close()
    for call in (lambda: env.step(np.zeros(7)), lambda: env.reset(seed=1)):
        with pytest.raises(SamplehdError, match="closed") as info:
            call()
        assert "\n" not in str(info.value)


def test_policy_returning_the_wrong_thing_is_named(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                                   capsys: pytest.CaptureFixture[str]) -> None:
    from samplehd.cli import main

    (tmp_path / "bad_policy_module.py").write_text("def act(obs):\n    return 'forward'\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    options = tmp_path / "env.json"
    options.write_text(json.dumps(FAST))
    code = main(["evaluate", "--policy", "bad_policy_module:act", "--episodes", "1", "--env-options", str(options),
                 "--families", "pick_up"])
    err = capsys.readouterr().err.strip()
    assert code == 2 and len(err.splitlines()) == 1, err
    assert "policy returned 'forward' (str); expected 7 finite numbers" in err


def test_evaluate_keeps_env_options_the_flags_leave_alone(tmp_path: Path) -> None:
    """--env-options values are not replaced by the command line's defaults; a flag given wins."""
    from samplehd.cli import main

    options = tmp_path / "env.json"
    options.write_text(json.dumps({**FAST, "obs_mode": "rgb", "width": 64, "height": 48,
                                   "control_mode": "joint_delta", "max_episode_steps": 3}))
    report = tmp_path / "report.json"
    assert main(["evaluate", "--policy", "random", "--episodes", "1", "--families", "pick_up", "--env-options",
                 str(options), "--height", "40", "--out", str(report)]) == 0
    env = json.loads(report.read_text())["env"]
    assert (env["obs_mode"], env["width"], env["height"], env["control_mode"], env["max_episode_steps"]) == (
        "rgb", 64, 40, "joint_delta", 3)
