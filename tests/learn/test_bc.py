"""The behaviour-cloning policy: deterministic and resumable training, its state input, and the
inference options (temporal ensembling, the TCP floor) acting on a real network."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

torch = pytest.importorskip("torch")

from samplehd.errors import ConfigError  # noqa: E402
from samplehd.learn.actions import moving_frames, rotation_columns  # noqa: E402
from samplehd.learn.policy import (  # noqa: E402
    STATE_DIM,
    BCPolicy,
    PolicyCollection,
    PolicyConfig,
    PolicyTraining,
    train_policy,
)


def _weights(folder: Path) -> dict:
    return torch.load(folder / "model.pt", map_location="cpu", weights_only=True)


def _same(a: dict, b: dict) -> bool:
    return a.keys() == b.keys() and all(torch.equal(a[k], b[k]) for k in a)


def _train(dataset: Path, out: Path, steps: int, *, stop_after: int | None = None, inputs: str = "rgb",
           action: str = "steering", demos: int = 0, noise: float = 0.0, dagger_rounds: int = 0,
           dagger_episodes: int = 50, dagger_steps: int = 1000, **train: object) -> dict:
    """``train_policy`` of the policy ``samplehd train policy`` builds from these flags (``steps``:
    before the DAgger rounds)."""
    collect = PolicyCollection(demos=demos, noise=noise, dagger_rounds=dagger_rounds,
                               dagger_episodes=dagger_episodes, dagger_steps=dagger_steps)
    config = PolicyConfig(inputs=inputs, action=action, collect=collect,
                          train=PolicyTraining(steps=steps + dagger_rounds * dagger_steps, **train))
    return train_policy(dataset, out, config, quiet=True, stop_after=stop_after)


def test_policy_training_is_deterministic_resumes_and_normalises_its_state(nano_dataset: Path,
                                                                          tmp_path: Path) -> None:
    a, b, c = tmp_path / "a", tmp_path / "b", tmp_path / "c"
    ma = _train(nano_dataset, a, steps=4)
    _train(nano_dataset, b, steps=4)
    assert _same(_weights(a), _weights(b)), "same seed on the CPU must give identical weights"
    assert _train(nano_dataset, c, steps=4, stop_after=2) == {"stopped_at": 2}
    assert not (c / "model.pt").exists()
    _train(nano_dataset, c, steps=4)
    assert _same(_weights(a), _weights(c)), "a resumed run must give the uninterrupted run's model"
    w = _weights(a)
    assert w["state_mean"].shape == (STATE_DIM,) and bool((w["state_std"] >= 1e-2).all())
    assert float(w["state_mean"][8]) > 0.5  # the TCP height [m] above the floor, as recorded
    config = json.loads((a / "config.json").read_text())
    assert config["format"] == 3 and 0.7 < config["inference"]["z_floor"] < 1.2
    assert config["inference"]["zero_channels"] == [3, 4]  # top-down grasps never tilt the gripper
    assert len(ma["test_l1_by_axis"]) == 7 and ma["test_l1"] is not None
    # Weighting the frames near the table changes the model (and is recorded).
    d = tmp_path / "d"
    _train(nano_dataset, d, steps=4, near_weight=3.0)
    assert json.loads((d / "config.json").read_text())["train"]["near_weight"] == 3.0
    assert not _same(_weights(a), _weights(d))
    # The L1 loss of the first version is still there (its median is a zero velocity on most frames).
    e = tmp_path / "e"
    _train(nano_dataset, e, steps=2, loss="l1")
    assert json.loads((e / "config.json").read_text())["train"]["loss"] == "l1"
    with pytest.raises(ConfigError, match="loss='huber'"):
        _train(nano_dataset, tmp_path / "f", steps=2, loss="huber")
    assert not (tmp_path / "f").exists()


def test_evaluate_names_the_factory_that_loads_either_policy() -> None:
    """``evaluate --policy bc`` names the module that defines its factory; the package loads its other
    names on first use only."""
    import importlib

    import samplehd.learn.policy as policy
    from samplehd.benchmark.evaluation import LEARNED

    module, factory = LEARNED["bc"].split(":")
    assert getattr(importlib.import_module(module), factory) is policy.policy_for_evaluation
    with pytest.raises(AttributeError, match="no attribute 'nope'"):
        policy.nope  # noqa: B018


def test_rotation_columns_are_those_of_the_matrix_and_ignore_the_quaternion_sign() -> None:
    from scipy.spatial.transform import Rotation

    rng = np.random.default_rng(0)
    q = rng.normal(size=(5, 4))
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    mats = Rotation.from_quat(q[:, [1, 2, 3, 0]]).as_matrix()  # scipy: x y z w
    want = np.concatenate([mats[:, :, 0], mats[:, :, 1]], axis=1)
    assert np.allclose(rotation_columns(q), want, atol=1e-12)
    assert np.allclose(rotation_columns(-q), want, atol=1e-12)


def _config(**inference: object) -> dict:
    return {"kind": "policy", "format": 3, "image": 16, "chunk": 4, "execute": 2, "tokens": 8,
            "model": {"width": 8, "hidden": 16, "state_dim": STATE_DIM}, "inference": inference,
            "train": {"seed": 0}}


def _obs(z: float = 1.0) -> dict:
    rng = np.random.default_rng(1)
    return {"scene_rgb": rng.integers(0, 255, (16, 16, 3), dtype=np.uint8),
            "wrist_rgb": rng.integers(0, 255, (16, 16, 3), dtype=np.uint8),
            "instruction": "Pick up the mug.", "gripper": np.array([0.02, 0.02, 0.0]),
            "joint_pos": np.zeros(6), "joint_vel": np.zeros(6),
            "tcp_pos": np.array([0.3, 0.0, z]), "tcp_quat": np.array([0.0, 1.0, 0.0, 0.0])}


def test_temporal_ensembling_averages_the_chunks_that_cover_a_step() -> None:
    policy = BCPolicy(_config(ensemble=0.0), None)  # equal weights
    chunks: list[np.ndarray] = []
    predict = policy.predict
    policy.predict = lambda obs: chunks.append(predict(obs)) or chunks[-1]  # type: ignore[method-assign]
    policy.reset()
    for t in range(6):
        action = policy(_obs())
        # the chunk predicted k steps ago holds this step's action at index k
        want = np.clip(np.mean([c[t - n] for n, c in enumerate(chunks) if t - n < 4], axis=0), -1, 1)
        assert len(chunks) == t + 1 and np.allclose(action, want, atol=1e-6)
    # Without it: `execute` actions of one chunk, then a new one.
    plain = BCPolicy(_config(), None)
    chunks.clear()
    predict = plain.predict
    plain.predict = lambda obs: chunks.append(predict(obs)) or chunks[-1]  # type: ignore[method-assign]
    plain.reset()
    actions = np.stack([plain(_obs()) for _ in range(4)])
    assert len(chunks) == 2
    assert np.allclose(actions, np.clip([chunks[0][0], chunks[0][1], chunks[1][0], chunks[1][1]], -1, 1), atol=1e-6)


def test_the_tcp_target_never_goes_below_the_floor() -> None:
    step = 0.25 / 20  # TCP travel of a steering value of 1 in one control step [m]
    plain = BCPolicy(_config(), None)
    low = BCPolicy(_config(z_floor=0.5), None)  # far below: the actions are the network's
    plain.reset()
    low.reset()
    assert all(np.array_equal(plain(_obs()), low(_obs())) for _ in range(5))
    for start in (0.76, 0.7705, 0.80):  # starting below the floor, just above it, well above it
        policy = BCPolicy(_config(z_floor=0.77), None)
        policy.reset()
        target = start
        for t in range(20):
            action = policy(_obs(target))
            if t == 0 and start < 0.77:
                assert action[2] >= (0.77 - start) / step - 1e-5  # raised back to the floor at once
            target += float(action[2]) * step
            assert target >= 0.77 - 1e-6
    with pytest.raises(ConfigError, match="inference.ensemble"):
        BCPolicy(_config(ensemble=-1), None)


def test_the_waits_are_left_out_of_the_frames_a_policy_learns_from() -> None:
    moving = [0.2, 0, 0, 0, 0, 0]
    still = [0.0] * 6
    steering = np.array([[*still, -0.6],   # the first frame is always kept
                         [*moving, -0.6],
                         [*still, -0.6],   # a wait: no motion, the gripper command unchanged
                         [*still, -0.6],
                         [*still, -0.8],   # closing: kept
                         [*still, -0.8],   # a wait after the close
                         [*moving, -0.8]])
    assert moving_frames(steering).tolist() == [0, 1, 4, 6]


def test_the_policy_state_holds_joint_velocities_and_its_last_gripper_command() -> None:
    policy = BCPolicy(_config(), None)
    policy.reset()
    obs = dict(_obs(), joint_vel=np.arange(6.0))
    state = policy._state(obs)  # noqa: SLF001 - the state the network sees
    assert state.shape == (STATE_DIM,) and state[16:22].tolist() == list(range(6)) and state[22] == 1.0
    action = policy(obs)
    assert policy._state(obs)[22] == pytest.approx(float(action[6]))  # noqa: SLF001
    policy.reset()
    assert policy._state(obs)[22] == 1.0  # noqa: SLF001 - the gripper starts open


def test_oracle_demos_are_noisy_where_executed_clean_where_labelled_and_reproducible() -> None:
    from samplehd.learn.demos import CollectSpec, collect

    spec = CollectSpec(episodes=3, seed=0, families=("pick_up",), image=16, cameras=("scene", "wrist"), noise=0.2,
                       still=(3, 4))
    a, b = collect(spec), collect(spec)
    assert a, "some of three L1 pick_up episodes must succeed"
    for x, y in zip(a, b, strict=True):
        assert all(np.array_equal(x[k], y[k]) for k in ("label", "executed", "scene", "tcp_pos"))
        assert x["success"] and x["scene"].shape[1:] == (16, 16, 3)
        noise = x["executed"][:, :6] - x["label"][:, :6]
        assert 0.1 < float(np.abs(noise[:, [0, 1, 2, 5]]).mean()) < 0.25  # |N(0, 0.2)| has mean 0.16
        assert not noise[:, [3, 4]].any()  # the values the demonstrations never use stay clean
        assert np.array_equal(x["executed"][:, 6], x["label"][:, 6])  # the gripper is not perturbed


def test_dart_demos_and_a_dagger_round_join_training_and_a_resumed_run_reuses_them(nano_dataset: Path,
                                                                                tmp_path: Path) -> None:
    opts = dict(steps=2, demos=4, noise=0.1, dagger_rounds=1, dagger_episodes=2, dagger_steps=2)
    a, c = tmp_path / "a", tmp_path / "c"
    ma = _train(nano_dataset, a, **opts)
    assert (a / "demos.npz").exists() and (a / "dagger_0.npz").exists()
    assert ma["collected_episodes"] >= 2 and ma["steps"] == 4
    config = json.loads((a / "config.json").read_text())
    assert config["collect"] == {"demos": 4, "noise": 0.1, "dagger_rounds": 1, "dagger_episodes": 2,
                                 "dagger_steps": 2}
    assert _train(nano_dataset, c, stop_after=3, **opts) == {"stopped_at": 3}  # after the DAgger round
    _train(nano_dataset, c, **opts)
    assert _same(_weights(a), _weights(c)), "a resumed run must collect and train exactly as an uninterrupted one"


def test_the_privileged_state_reference_sees_the_target_and_no_image(nano_dataset: Path, tmp_path: Path) -> None:
    from samplehd.envs.tabletop import TabletopEnv
    from samplehd.learn.options import env_options
    from samplehd.learn.policy import TARGET_DIM

    out = tmp_path / "state"
    metrics = _train(nano_dataset, out, steps=3, inputs="state")
    config = json.loads((out / "config.json").read_text())
    assert config["inputs"] == "state" and config["model"]["state_dim"] == STATE_DIM + TARGET_DIM
    assert metrics["test_l1"] is not None
    assert not any(k.startswith("encoders.") for k in _weights(out)), "no camera network"
    options = env_options(out)
    assert options["obs_mode"] == "state"
    env = TabletopEnv(**options, families=("pick_up",))
    try:
        policy = BCPolicy.load(out, env)
        obs, _ = env.reset(seed=0)
        policy.reset()
        state = policy._state(obs)  # noqa: SLF001 - the state the network sees
        target = int(env.task.objects[0])
        rel = np.asarray(obs["object_pos"][target], float) - np.asarray(obs["tcp_pos"], float)
        assert np.allclose(state[STATE_DIM:STATE_DIM + 3], rel, atol=1e-5)
        assert policy(obs).shape == (7,)
    finally:
        env.close()


def test_the_steering_values_the_demonstrations_never_use_stay_zero() -> None:
    free, fixed = BCPolicy(_config(), None), BCPolicy(_config(zero_channels=[3, 4]), None)
    for policy in (free, fixed):
        policy.reset()
    a, b = free(_obs()), fixed(_obs())
    assert a[3] != 0 and a[4] != 0  # an untrained network's values
    assert b[3] == 0 and b[4] == 0 and np.array_equal(np.delete(a, [3, 4]), np.delete(b, [3, 4]))
    with pytest.raises(ConfigError, match="zero_channels"):
        BCPolicy(_config(zero_channels=[6]), None)


def _demo_episode() -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """A pick-up as the oracle records it: move to a pre-grasp pose and down (one joint move, one line,
    the TCP all but stopping between them), wait, close the gripper, wait, lift."""
    lin = 0.25 / 20.0
    steer: list[list[float]] = []
    for v in [0.2, 0.6, 0.6, 0.2, 0.01, 0.3, 0.3, 0.1]:  # +x, then (after the near-stop) -z
        steer.append([v, 0, 0, 0, 0, 0, -0.5] if len(steer) < 4 else [0, 0, -v, 0, 0, 0, -0.5])
    steer += [[0, 0, 0, 0, 0, 0, -0.5]] * 2  # wait
    steer += [[0, 0, 0, 0, 0, 0, g] for g in (-0.6, -0.7, -0.8, -0.8)]  # close (the last one holds: a wait)
    steer += [[0, 0, 0.5, 0, 0, 0, -0.8]] * 3 + [[0, 0, 0, 0, 0, 0, -0.8]] * 2  # lift, hold
    steering = np.array(steer)
    tcp = np.zeros((len(steer), 3))
    tcp[0] = (0.1, 0.0, 1.0)
    for t in range(1, len(steer)):
        tcp[t] = tcp[t - 1] + steering[t - 1, :3] * lin
    quat = np.tile([0.0, 1.0, 0.0, 0.0], (len(steer), 1))  # pointing down
    opening = (np.r_[-0.5, steering[:-1, 6]] + 1.0) / 2.0 * 0.085
    return steering, tcp, quat, opening


def test_waypoints_are_where_each_segment_ends_and_the_gripper_closes_after_a_closing_segment() -> None:
    from samplehd.learn.actions import waypoint_targets, waypoints

    steering, tcp, quat, opening = _demo_episode()
    goal = waypoints(steering, tcp, quat, opening)
    # Segments: the move in x (cut at the near-stop), the descent, the closing, the lift; each one's
    # waypoint is read where the next starts.
    pre, grasp, lift = tcp[5], tcp[8], tcp[len(tcp) - 1]
    assert np.allclose(goal[0, :3], pre) and goal[0, 4] == -0.5
    assert np.allclose(goal[5, :3], grasp) and goal[5, 4] == -0.5  # on the way down
    assert np.allclose(goal[9, :3], grasp) and goal[9, 4] == -1.0  # the wait before closing: close there
    assert np.allclose(goal[14, :3], lift) and goal[14, 4] == -1.0  # lifting, closed
    assert np.allclose(goal[-1, :3], lift)  # after the last segment: hold its end
    # A frame within reach of its waypoint is labelled with the next one.
    tcp_near = tcp.copy()
    tcp_near[6] = grasp + [0.002, 0.0, 0.0]
    assert goal[6, 4] == -0.5 and waypoints(steering, tcp_near, quat, opening)[6, 4] == -1.0
    target = waypoint_targets(goal, tcp, quat)
    assert target.shape == (len(tcp), 7) and np.abs(target).max() <= 1.0
    assert np.allclose(target[0, :3] * 0.3, pre - tcp[0], atol=1e-6) and not target[:, 3:5].any()


def test_squeezing_closes_narrower_than_the_fingers_are_and_stays_in_range() -> None:
    from samplehd.learn.demos import SQUEEZE_STEP, squeeze_command
    from samplehd.robot.constants import GRIPPER_STROKE

    for width in (0.085, 0.03, 0.001):
        g = squeeze_command([width / 2, width / 2])
        assert -1.0 <= g <= 1.0
        assert np.isclose((g + 1.0) / 2.0 * GRIPPER_STROKE, max(0.0, width - SQUEEZE_STEP))


def test_a_waypoint_policy_trains_and_acts_with_keypoints(nano_dataset: Path, tmp_path: Path) -> None:
    from samplehd.envs.tabletop import TabletopEnv
    from samplehd.learn.actions import WAYPOINT_SPEED
    from samplehd.learn.options import env_options

    out = tmp_path / "wp"
    metrics = _train(nano_dataset, out, steps=3, action="waypoint")
    config = json.loads((out / "config.json").read_text())
    assert config["action"] == "waypoint" and config["chunk"] == 1 and config["model"]["encoder"] == "keypoints"
    assert metrics["test_l1"] is not None
    with pytest.raises(ConfigError, match="action='joints'"):
        _train(nano_dataset, tmp_path / "bad", steps=2, action="joints")
    assert not (tmp_path / "bad").exists()
    env = TabletopEnv(**env_options(out), families=("pick_up",))
    try:
        policy = BCPolicy.load(out, env)
        obs, _ = env.reset(seed=0)
        policy.reset()
        for _ in range(3):
            a = policy(obs)
            assert a.shape == (7,) and np.abs(a).max() <= 1.0 and a[3] == 0 and a[4] == 0
            assert np.linalg.norm(a[:3]) * 0.25 <= WAYPOINT_SPEED + 1e-6
            obs, *_ = env.step(a)
    finally:
        env.close()


def test_a_motion_the_episode_cut_short_has_its_waypoint_ahead() -> None:
    from samplehd.learn.actions import WAYPOINT_AHEAD, waypoints

    steering, tcp, quat, opening = _demo_episode()
    cut = 16  # the environment ended the episode (success) in the middle of the lift
    goal = waypoints(steering[:cut], tcp[:cut], quat[:cut], opening[:cut])
    assert np.allclose(goal[-1, :3], tcp[cut - 1] + [0.0, 0.0, WAYPOINT_AHEAD])


def test_following_the_oracles_waypoints_succeeds() -> None:
    """The waypoint labels can be acted on: the follower, given the waypoints of the oracle's episode,
    succeeds in the same episode (what a perfect waypoint policy does)."""
    from samplehd.envs.oracle import OraclePolicy
    from samplehd.envs.tabletop import TabletopEnv
    from samplehd.learn.actions import WaypointExpert, follow_waypoints

    env = TabletopEnv(obs_mode="state", control_mode="steering", families=("pick_up",), max_episode_steps=300)
    try:
        oracle = OraclePolicy(env)
        for seed in (0, 1):
            obs, _ = env.reset(seed=seed)
            oracle.reset(seed=seed)
            frames: dict[str, list] = {"label": [], "tcp_pos": [], "tcp_quat": [], "opening": []}
            for _ in range(300):
                a = oracle(obs)
                for k, v in (("label", a), ("tcp_pos", obs["tcp_pos"]), ("tcp_quat", obs["tcp_quat"]),
                             ("opening", obs["gripper"][0] + obs["gripper"][1])):
                    frames[k].append(np.asarray(v))
                obs, _, terminated, truncated, info = env.step(a)
                if terminated or truncated:
                    break
            assert info["success"]
            expert = WaypointExpert.of_episode(*(np.asarray(frames[k]) for k in ("label", "tcp_pos", "tcp_quat",
                                                                                  "opening")))
            obs, _ = env.reset(seed=seed)
            assert follow_waypoints(env, obs, expert.goals, 300)["success"]
    finally:
        env.close()


def test_a_waypoint_dagger_round_labels_the_policys_states_with_the_experts_waypoints(nano_dataset: Path,
                                                                                      tmp_path: Path) -> None:
    from samplehd.learn.policy.preparation import load_arrays

    out = tmp_path / "wpd"
    metrics = _train(nano_dataset, out, steps=2, action="waypoint", inputs="state",
                           dagger_rounds=1, dagger_episodes=3, dagger_steps=2)
    raw = load_arrays(out / "dagger_0.npz")
    assert raw and metrics["collected_episodes"] == len(raw)
    for episode in raw:
        goal = episode["goal"]
        assert goal.shape == (len(episode["tcp_pos"]), 5)
        # The labels are the expert's waypoints, in order: each phase's waypoint held until the next.
        changes = np.flatnonzero(np.abs(np.diff(goal, axis=0)).max(axis=1) > 1e-9)
        assert len(changes) <= 12 and np.isin(goal[:, 4][goal[:, 4] < -0.9], [-1.0]).all()


def test_a_policy_keeps_its_datasets_catalogue_for_collecting_and_evaluation(tmp_path: Path) -> None:
    """A policy trained on a dataset of the other catalogue than the default (procedural) collects its
    demonstrations in procedural scenes, records the catalogue, and ``samplehd evaluate`` sets its episodes
    up in that catalogue (an ``--env-options`` file may name the default, shop-vrb)."""
    from samplehd.cli import main
    from samplehd.dataset.config import GenerateConfig, preset_config
    from samplehd.dataset.generate import generate_dataset
    from samplehd.learn import demos
    from samplehd.learn.options import env_options

    doc = {"num_scenes": 2, "seed": 0, "test_every": 2, "render": {"mode": "none"},
           "scene": {"min_objects": 3, "max_objects": 3, "catalogue": "procedural"},
           "instructions": {"per_scene": 1, "families": ["pick_up"]}}
    data = tmp_path / "ds"
    assert generate_dataset(data, GenerateConfig.from_dict(doc, base=preset_config("tiny"))).episodes >= 1
    out = tmp_path / "policy"
    _train(data, out, steps=2, inputs="state", demos=1)
    assert json.loads((out / "config.json").read_text())["catalogue"] == "procedural"
    assert demos._WORKER["env"][1].config.scene.catalogue == "procedural"  # noqa: SLF001 - the collecting env
    assert env_options(out)["scene"] == {"catalogue": "procedural"}
    reports = {}
    for name, extra in (("trained", []), ("shop-vrb", ["--env-options", str(tmp_path / "p.json")])):
        (tmp_path / "p.json").write_text(json.dumps({"scene": {"catalogue": "shop-vrb"}}))
        report = tmp_path / f"{name}.json"
        assert main(["evaluate", "--policy", "bc", "--models", str(out), "--families", "pick_up", "--episodes", "1",
                     "--max-episode-steps", "5", "--workers", "1", "--out", str(report), *extra]) == 0
        reports[name] = json.loads(report.read_text())
    assert reports["trained"]["catalogue"]["name"] == "procedural"
    assert reports["shop-vrb"]["catalogue"]["name"] == "shop-vrb"
