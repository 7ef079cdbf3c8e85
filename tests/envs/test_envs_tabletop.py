"""Tabletop-v0: the Gymnasium contract, spaces, seeding, actions, episodes from options."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

from samplehd.envs import ENV_ID
from samplehd.envs.config import CONTROL_MODES
from samplehd.envs.tabletop import TabletopEnv
from samplehd.envs.tokens import instruction_vocabulary
from samplehd.errors import ActionError, ConfigError


def _same(a: dict, b: dict) -> bool:
    return a.keys() == b.keys() and all(
        (a[k] == b[k]) if isinstance(a[k], str) else np.array_equal(a[k], b[k]) for k in a
    )


@pytest.mark.parametrize("mode", list(CONTROL_MODES))
def test_check_env_passes_for_every_control_mode(mode: str, fast_options: dict) -> None:
    env = TabletopEnv(control_mode=mode, obs_mode="rgb", width=32, height=32, render_mode="rgb_array",
                      **fast_options)
    check_env(env, skip_render_check=False)
    env.close()


def test_make_registers_and_spaces_follow_options(fast_options: dict) -> None:
    env = gym.make(ENV_ID, obs_mode="rgbd_seg", cameras=["scene", "wrist"], width=48, height=32, **fast_options)
    obs, info = env.reset(seed=3)
    assert env.observation_space.contains(obs)
    for cam in ("scene", "wrist"):
        assert obs[f"{cam}_rgb"].shape == (32, 48, 3) and obs[f"{cam}_rgb"].dtype == np.uint8
        assert obs[f"{cam}_depth"].shape == (32, 48) and obs[f"{cam}_depth"].dtype == np.float32
        assert obs[f"{cam}_segmentation"].shape == (32, 48)
    # Segmentation shows the table (1) and some scene object (>= 3) from the scene camera.
    ids = set(np.unique(obs["scene_segmentation"]).tolist())
    assert 1 in ids and any(i >= 3 for i in ids)
    assert isinstance(obs["instruction"], str) and obs["instruction"] == info["instruction"]
    # Options that name no catalogue get SAMPLE-HD's SHOP-VRB shapes (its variants are shopvrb1, ...).
    assert all(o.instance.variant.startswith("shopvrb") for o in env.unwrapped.episode.scene.objects)
    tokens = obs["instruction_tokens"]
    assert tokens[0] == 1 and 2 in tokens and 3 not in tokens  # <START> ... <END>, no <UNK>
    assert tokens.max() < len(instruction_vocabulary())
    for key in ("program", "program_sequence", "task", "targets", "family", "subtask", "success",
                "safety_events", "safety_event"):
        assert key in info
    env.close()


def test_seeded_resets_give_identical_observations(fast_options: dict) -> None:
    env = TabletopEnv(obs_mode="rgb", width=32, height=32, **fast_options)
    a, ia = env.reset(seed=11)
    env.reset(seed=12)
    b, ib = env.reset(seed=11)
    assert _same(a, b) and ia["task"] == ib["task"]
    env.close()


def test_same_seed_and_actions_give_identical_trajectories(fast_options: dict) -> None:
    envs = [TabletopEnv(control_mode="ee_delta", **fast_options) for _ in range(2)]
    rng = np.random.default_rng(0)
    actions = [envs[0].action_space.low + rng.random(7) * (envs[0].action_space.high - envs[0].action_space.low)
               for _ in range(30)]
    traj = []
    for env in envs:
        obs, _ = env.reset(seed=5)
        seq = [obs]
        for a in actions:
            obs, r, term, trunc, info = env.step(a)
            seq.append(obs)
            if term or trunc:
                break
        traj.append(seq)
    assert len(traj[0]) == len(traj[1])
    assert all(_same(x, y) for x, y in zip(*traj, strict=True))
    assert np.array_equal(envs[0].data.qpos, envs[1].data.qpos)


def test_nan_actions_raise_and_out_of_bounds_are_clipped_and_flagged(fast_options: dict) -> None:
    env = TabletopEnv(control_mode="steering", **fast_options)
    env.reset(seed=1)
    with pytest.raises(ValueError, match="NaN"):
        env.step(np.full(7, np.nan, dtype=np.float32))
    with pytest.raises(ActionError):
        env.step(np.zeros(6, dtype=np.float32))
    _, _, _, _, info = env.step(np.array([5, 0, 0, 0, 0, 0, 1], dtype=np.float32))
    assert info["action_clipped"]
    _, _, _, _, info = env.step(np.array([0.1, 0, 0, 0, 0, 0, 1], dtype=np.float32))
    assert not info["action_clipped"]


@pytest.mark.parametrize(
    ("options", "message"),
    [
        ({"obs_mode": "depth"}, "obs_mode"),
        ({"control_mode": "torque"}, "control_mode"),
        ({"cameras": ["ceiling"]}, "cameras"),
        ({"families": ["juggle"]}, "families"),
        ({"width": 3}, "width"),
        ({"physics_hz": 510.0}, "physics_hz"),
        ({"colour": "red"}, "unknown option"),
        ({"scene": {"max_objects": 99}}, "max_objects"),
    ],
)
def test_bad_options_are_one_line_errors(options: dict, message: str) -> None:
    with pytest.raises(ConfigError, match=message) as exc:
        TabletopEnv(**options)
    assert "\n" not in str(exc.value)


def test_reset_reproduces_a_given_scene_and_instruction(fast_options: dict) -> None:
    env = TabletopEnv(obs_mode="rgb", width=32, height=32, **fast_options)
    obs, info = env.reset(seed=4)
    scene = env.episode.scene.to_dict()
    instruction = dict(env.episode.instruction)
    other = TabletopEnv(obs_mode="rgb", width=32, height=32, scene=fast_options["scene"])
    obs2, info2 = other.reset(seed=99, options={"scene": scene, "instruction": instruction})
    assert _same(obs, obs2) and info2["task"] == info["task"]
    # An instruction given only by its text and program is executed on the scene.
    bare = {"instruction": instruction["instruction"], "program": instruction["program"]}
    _, info3 = other.reset(options={"scene": scene, "instruction": bare})
    assert info3["task"]["objects"] == info["task"]["objects"]
    with pytest.raises(ConfigError, match="instruction"):
        other.reset(options={"scene": scene})


def test_reset_family_option_and_safety_stop_terminates(fast_options: dict) -> None:
    env = TabletopEnv(control_mode="steering", families=["pick_up", "place"], **fast_options)
    _, info = env.reset(seed=2, options={"family": "pick_up"})
    assert info["family"] == "pick_up"
    # Drive the TCP straight down into the table: the safety monitor stops the arm.
    for _ in range(200):
        _, reward, term, trunc, info = env.step(np.array([0, 0, -1, 0, 0, 0, 1], dtype=np.float32))
        if term:
            break
    assert term and info["safety_stop"] and info["safety_events"] and reward == 0.0
    assert info["safety_events"][0]["kind"] in ("environment_collision", "contact_force", "joint_torque")


def test_truncation_at_the_step_limit(fast_options: dict) -> None:
    env = TabletopEnv(control_mode="joint_delta", max_episode_steps=5, **fast_options)
    env.reset(seed=0)
    flags = [env.step(np.zeros(7, dtype=np.float32))[3] for _ in range(5)]
    assert flags == [False, False, False, False, True]
