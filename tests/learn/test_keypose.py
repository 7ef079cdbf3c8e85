"""The keypose policy: decisions read from recorded episodes, the top-down view, the follower that acts
on them (proven on the recorded decisions), and a trained model acting through ``samplehd evaluate``."""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("torch")

from samplehd.dataset.reader import DatasetReader  # noqa: E402
from samplehd.envs.replay_check import replay_env  # noqa: E402
from samplehd.learn.actions import tcp_yaw  # noqa: E402
from samplehd.learn.keypose.follower import TILT_TOLERANCE, KeyposeFollower, tool_tilt  # noqa: E402
from samplehd.learn.keypose.processing import decisions  # noqa: E402
from samplehd.world.layout import LAYOUT  # noqa: E402

# Procedural, named: the keypose follower's expectations here were set on these seed-3 procedural scenes;
# on shop-vrb (the default since) following the recorded decisions, the descent onto an object and the
# privileged reference fail on them. Moving the keypose policy to shop-vrb is its own work.
KEYPOSE_DATA = {
    "num_scenes": 4,
    "seed": 3,
    "test_every": 4,
    "scene": {"min_objects": 3, "max_objects": 4, "catalogue": "procedural"},
    "instructions": {"per_scene": 2, "families": ["pick_up", "place"]},
    "render": {"mode": "none", "width": 320, "height": 180},
}


@pytest.fixture(scope="module")
def keypose_dataset(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """States-only episodes of pick_up and place with 320×180 scene images."""
    from samplehd.dataset.config import GenerateConfig, preset_config
    from samplehd.dataset.generate import generate_dataset

    out = tmp_path_factory.mktemp("keypose") / "ds"
    summary = generate_dataset(out, GenerateConfig.from_dict(KEYPOSE_DATA, base=preset_config("small")))
    assert summary.episodes >= 4
    return out


def _train(dataset: Path, out: Path, steps: int, batch: int, *, inputs: str = "rgb", language: str = "instruction",
           stop_after: int | None = None) -> dict:
    """``train_keypose`` of the policy ``samplehd train policy --action keypose`` builds from these flags."""
    from samplehd.learn.keypose.configuration import KeyposeConfig, KeyposeTraining
    from samplehd.learn.keypose.training import train_keypose

    config = KeyposeConfig(inputs=inputs, language=language, train=KeyposeTraining(steps=steps, batch=batch))
    return train_keypose(dataset, out, config, quiet=True, stop_after=stop_after)


def _decisions(reader: DatasetReader, k: int) -> list:
    meta = reader.episode_meta(k)
    fr = reader.frames(k, ["subtask_index", "tcp_pos", "tcp_quat", "gripper_opening"])
    return decisions(meta.subtasks, fr["subtask_index"], fr["tcp_pos"], fr["tcp_quat"], fr["gripper_opening"])


def test_decisions_are_read_from_the_recorded_subtasks(keypose_dataset: Path) -> None:
    reader = DatasetReader(keypose_dataset)
    families = set()
    for k, entry in enumerate(reader.episodes):
        ds = _decisions(reader, k)
        assert ds, f"episode {k} ({entry.family}) has no decisions"
        families.add(entry.family)
        assert ds[0].frame == 0 and ds[-1].last and not any(d.last for d in ds[:-1])
        assert [d.frame for d in ds] == sorted({d.frame for d in ds})
        for d in ds:
            assert LAYOUT.table_height < d.grasp[2] < LAYOUT.table_height + 0.35
            assert d.lift > d.grasp[2] + 0.05
            assert 0.0 < d.opening <= 0.086
            assert d.release == (entry.family == "place")
        if entry.family == "pick_up":
            assert len(ds) == 1 and np.allclose(ds[0].goal[:2], ds[0].grasp[:2], atol=0.005)
    assert families == {"pick_up", "place"}


def _step(env, follower: KeyposeFollower, obs: dict) -> tuple[dict, dict]:
    """One ``env.step`` of the follower's steering vector; the arm must not be stopped."""
    action = follower(obs)
    assert action.shape == (7,) and np.abs(action).max() <= 1.0
    obs, _, _, _, info = env.step(action)
    assert not info["safety_stop"], (follower.stage, info["safety_events"])
    return obs, info


def _hold_steps(env) -> int:
    """Control steps between two grip checks while holding."""
    from samplehd.learn.keypose.follower import HOLD_CHECK_PERIOD

    return round(HOLD_CHECK_PERIOD * env.unwrapped.control.control_hz)


def test_following_the_recorded_decisions_succeeds(keypose_dataset: Path) -> None:
    """The labels can be acted on: the follower, given each episode's own decisions, succeeds in the
    episode (what a perfect keypose policy does). Its grip checks (after the lift, before the release,
    now and then while holding a picked-up object) squeeze without stopping the arm and never take an
    object in the fingers for a lost one."""
    from samplehd.learn.keypose.follower import SETTLE_STEPS

    reader = DatasetReader(keypose_dataset)
    env = replay_env(reader)
    try:
        for k, entry in enumerate(reader.episodes):
            obs, _ = env.reset(options={"dataset": str(reader.root), "episode_index": k})
            home = np.r_[obs["tcp_pos"], tcp_yaw(obs["tcp_quat"])]
            success, steps = False, 0
            for d in _decisions(reader, k):
                follower = KeyposeFollower(d, obs, home, env)
                stages = []
                while not follower.done and steps < 600:
                    obs, info = _step(env, follower, obs)
                    stages.append(follower.stage)
                    steps += 1
                    success = success or bool(info["success"])
                assert follower.lost is None, (k, follower.lost)
                assert "lift check" in stages and ("release check" in stages) == d.release, (k, set(stages))
            assert success, f"episode {k} ({entry.family}): {info['check_reason']}"
            if d.release:
                continue
            # held on: three grip checks, each a few steps of squeeze, and the object stays up in the fingers
            stages = []
            for _ in range(3 * (_hold_steps(env) + SETTLE_STEPS)):
                obs, info = _step(env, follower, obs)
                stages.append(follower.stage)
            checks = sum(a != b == "hold check" for a, b in zip(stages, stages[1:], strict=False))
            assert checks >= 3 and follower.done and follower.lost is None, (k, checks, follower.stage)
            u = env.unwrapped
            held = u.task.objects[0]
            assert u.assist.active == held and u.physics.object_pos(held)[2] > LAYOUT.table_height + 0.05
    finally:
        env.close()


def test_an_arm_that_starts_tilted_is_turned_level_and_follows_the_decisions(keypose_dataset: Path) -> None:
    """A start pose with the tool tilted 0.2 rad off straight down (as a suite's robot start axis gives
    it): the follower turns the tool level on its first move and the recorded decisions succeed, where a
    tilted descent put the fingertips into the table (an environment collision stop)."""
    reader = DatasetReader(keypose_dataset)
    env = replay_env(reader)
    try:
        for k, entry in enumerate(reader.episodes):
            obs, _ = env.reset(options={"dataset": str(reader.root), "episode_index": k})
            assert np.linalg.norm(tool_tilt(obs["tcp_quat"])) < 1e-3  # level at the start pose
            for _ in range(4):  # 0.05 rad a step about x and y
                obs, *_ = env.step(np.array([0, 0, 0, 0.7, 0.7, 0, 1], np.float32))
            assert np.linalg.norm(tool_tilt(obs["tcp_quat"])) > 0.15
            home = np.r_[obs["tcp_pos"], tcp_yaw(obs["tcp_quat"])]
            success, tilts = False, []
            for d in _decisions(reader, k):
                follower = KeyposeFollower(d, obs, home, env)
                while not follower.done:
                    obs, info = _step(env, follower, obs)
                    if follower.stage in ("down to grasp", "close", "down to release"):
                        tilts.append(float(np.linalg.norm(tool_tilt(obs["tcp_quat"]))))
                    success = success or bool(info["success"])
            assert success, f"episode {k} ({entry.family}): {info['check_reason']}"
            assert max(tilts) < TILT_TOLERANCE + 0.005, max(tilts)
    finally:
        env.close()


def _drop_held_object(env) -> None:
    """Take the object the fingers hold out of them, as a slip would: its grasp weld off and the object
    set down 1.5 m aside, on the floor."""
    import mujoco

    u = env.unwrapped
    held = u.assist.active
    assert held >= 0, "nothing is held"
    u.assist.release(u.data)
    joint = u.model.body_jntadr[u.model.body(f"object_{held}").id]
    qpos, qvel = u.model.jnt_qposadr[joint], u.model.jnt_dofadr[joint]
    u.data.qpos[qpos:qpos + 3] = u.data.qpos[qpos:qpos + 3] + [1.5, 0.0, 0.0]
    u.data.qpos[qpos + 2] = 0.2
    u.data.qvel[qvel:qvel + 6] = 0.0
    mujoco.mj_forward(u.model, u.data)


@pytest.mark.parametrize(("family", "dropped_at", "noticed_at"), [
    ("pick_up", "lift", "lift"), ("pick_up", "done", "hold"), ("place", "carry", "release")])
def test_an_object_that_slips_out_is_noticed_and_the_arm_goes_home_open(
        keypose_dataset: Path, family: str, dropped_at: str, noticed_at: str) -> None:
    """An object taken out of the fingers during the lift, while held at the end of a pick_up, or during
    the carry of a place is noticed by the next grip check, from the fingers' width and the gripper's
    object detection (what a robot feels, not the object's pose): the follower
    is ``missed`` (``lost`` says where), goes back to its start pose open and stays there."""
    from samplehd.learn.keypose.follower import SETTLE_STEPS

    reader = DatasetReader(keypose_dataset)
    k = next(k for k, entry in enumerate(reader.episodes) if entry.family == family)
    env = replay_env(reader)
    try:
        obs, _ = env.reset(options={"dataset": str(reader.root), "episode_index": k})
        home = np.r_[obs["tcp_pos"], tcp_yaw(obs["tcp_quat"])]
        d = _decisions(reader, k)[0]
        assert d.release == (family == "place")
        follower = KeyposeFollower(d, obs, home, env)
        for _ in range(600):
            if follower.stage == dropped_at:
                break
            obs, _ = _step(env, follower, obs)
        assert follower.stage == dropped_at and follower.lost is None
        for _ in range(3):  # a few steps into the stage
            obs, _ = _step(env, follower, obs)
        _drop_held_object(env)
        steps, bound = 0, _hold_steps(env) + SETTLE_STEPS if dropped_at == "done" else 200
        while not follower.missed and steps < bound:
            obs, _ = _step(env, follower, obs)
            steps += 1
        assert follower.lost == noticed_at, (follower.lost, follower.stage, steps)
        stages = [follower.stage]
        for _ in range(400):
            if follower.done:
                break
            obs, _ = _step(env, follower, obs)
            stages.append(follower.stage)
        assert follower.done and "home" in stages and "open" not in stages, stages
        _stays_home_open(env, follower, obs, home, d.opening)  # no grip checks: the policy looks again
    finally:
        env.close()


def _follow_until_done(env, follower: KeyposeFollower, obs: dict, limit: int = 600) -> tuple[dict, list[str]]:
    """Step ``follower`` until it is done (at most ``limit`` steps): the last observation and the
    stages it went through."""
    stages = []
    for _ in range(limit):
        if follower.done:
            break
        obs, _ = _step(env, follower, obs)
        stages.append(follower.stage)
    return obs, stages


def _stays_home_open(env, follower: KeyposeFollower, obs: dict, home: np.ndarray, opening: float) -> None:
    """The follower is done at its start pose and stays there, fingers open wider than ``opening``,
    through a whole grip-check period (it checks no grip: it holds nothing)."""
    assert np.linalg.norm(obs["tcp_pos"] - home[:3]) < 0.01
    for _ in range(_hold_steps(env) + 10):
        obs, _ = _step(env, follower, obs)
        assert follower.stage == "done"
    assert float(obs["gripper"][0] + obs["gripper"][1]) > opening


def test_a_grasp_on_the_empty_table_is_missed_and_the_arm_goes_home_open(keypose_dataset: Path) -> None:
    """A grasp on the empty table (6 cm or more from every object, low enough that the descent meets the
    table) is missed: the grip check after the lift finds the fingers empty, and the follower goes back
    to its start pose open instead of carrying and holding nothing, and checks no grip there."""
    from samplehd.learn.keypose.processing import Decision

    reader = DatasetReader(keypose_dataset)
    k = next(k for k, entry in enumerate(reader.episodes) if entry.family == "pick_up")
    scene = reader.scenes[reader.episodes[k].scene_index]
    d = _decisions(reader, k)[0]
    lows = np.array([o["bbox"]["min"][:2] for o in scene["objects"]])
    highs = np.array([o["bbox"]["max"][:2] for o in scene["objects"]])

    def clearance(xy: np.ndarray) -> float:  # distance to the nearest object's footprint
        return float(np.linalg.norm(np.maximum(np.maximum(lows - xy, xy - highs), 0.0), axis=1).min())

    spots = [np.add(d.grasp[:2], (dx, dy)) for dx in (0.0, 0.1, -0.1, 0.2, -0.2) for dy in (0.0, 0.1, -0.1)]
    x, y = next(xy for xy in spots if clearance(xy) > 0.06)
    z = LAYOUT.table_height + 0.02
    env = replay_env(reader)
    try:
        obs, _ = env.reset(options={"dataset": str(reader.root), "episode_index": k})
        home = np.r_[obs["tcp_pos"], tcp_yaw(obs["tcp_quat"])]
        follower = KeyposeFollower(Decision((x, y, z, d.grasp[3]), d.opening, d.lift, (x, y, d.lift, d.grasp[3]),
                                            False, True), obs, home, env)
        obs, stages = _follow_until_done(env, follower, obs)
        # the fingertips pressed on the table hold the fingers 25 mm apart by friction: only the grip check
        # after the lift finds them empty
        assert follower.done and follower.lost == "lift", (follower.lost, stages[-5:])
        assert "close" in stages and "home" in stages and "carry" not in stages
        _stays_home_open(env, follower, obs, home, d.opening)
    finally:
        env.close()


def test_a_grasp_out_of_reach_is_given_up_and_the_arm_goes_home_open(keypose_dataset: Path) -> None:
    """A grasp 1.1 m from the robot base, beyond what the arm reaches: the move toward it stops coming
    closer, and after STUCK_STEPS control steps without progress the follower gives it up ("reach") and
    goes back to its start pose open instead of straining there until the episode's time is up."""
    from samplehd.learn.keypose.follower import STUCK_STEPS
    from samplehd.learn.keypose.processing import Decision

    reader = DatasetReader(keypose_dataset)
    d = _decisions(reader, 0)[0]
    x, y = LAYOUT.robot_base[0] + 1.1, 0.0
    env = replay_env(reader)
    try:
        obs, _ = env.reset(options={"dataset": str(reader.root), "episode_index": 0})
        home = np.r_[obs["tcp_pos"], tcp_yaw(obs["tcp_quat"])]
        follower = KeyposeFollower(Decision((x, y, d.grasp[2], d.grasp[3]), d.opening, d.lift,
                                            (x, y, d.lift, d.grasp[3]), True, True), obs, home, env)
        obs, stages = _follow_until_done(env, follower, obs)
        assert follower.done and follower.lost == "reach", (follower.lost, stages[-5:])
        assert stages.count("over grasp") >= STUCK_STEPS and "close" not in stages and "home" in stages
        _stays_home_open(env, follower, obs, home, d.opening)
    finally:
        env.close()


def test_a_descent_that_meets_an_object_stops_and_closes_there(keypose_dataset: Path) -> None:
    """A grasp predicted too low, on top of the widest object, closed fingers: the follower feels the
    descent stop on the object and closes there, instead of pushing on until the contact-force stop."""
    from samplehd.learn.keypose.processing import Decision

    reader = DatasetReader(keypose_dataset)
    scene = reader.scenes[reader.episodes[0].scene_index]
    widest = max(scene["objects"], key=lambda o: min(np.subtract(o["bbox"]["max"][:2], o["bbox"]["min"][:2])))
    top = widest["bbox"]["max"][2]
    x, y = np.add(widest["bbox"]["min"][:2], widest["bbox"]["max"][:2]) / 2
    env = replay_env(reader)
    try:
        obs, _ = env.reset(options={"dataset": str(reader.root), "episode_index": 0})
        home = np.r_[obs["tcp_pos"], tcp_yaw(obs["tcp_quat"])]
        low = LAYOUT.table_height + 0.01
        follower = KeyposeFollower(Decision((x, y, low, 0.0), 0.0, low + 0.15, (x, y, low + 0.15, 0.0), False, True),
                                   obs, home, env)
        stages = []
        for _ in range(300):
            obs, _, _, _, info = env.step(follower(obs))
            stages.append(follower.stage)
            assert not info["safety_stop"], (widest["name"], follower.stage, info["safety_events"])
            if follower.stage == "lift":
                break
        assert "close" in stages and follower.stage == "lift", stages[-5:]
        stopped = follower.steps[3][2][2]  # the height the fingers closed at
        assert stopped > low + 0.01 and stopped > top - 0.05, (widest["name"], stopped, top)
    finally:
        env.close()


def test_the_top_down_view_puts_each_object_where_it_stands(keypose_dataset: Path) -> None:
    from PIL import Image

    from samplehd.learn.topdown import HEIGHT_SCALE, TopDownGrid
    from samplehd.render.renderer import SEG_ROBOT

    grid = TopDownGrid()
    xy = np.array([[0.1, -0.2], [-0.3, 0.45]])
    assert np.allclose(grid.world(*grid.cell_of(xy).T), xy)
    assert np.allclose(grid.coarse(2).world(*grid.coarse(2).cell_of(xy).T), xy)
    reader = DatasetReader(keypose_dataset)
    scene = reader.scenes[0]
    stem = Path(scene["image_filename"]).stem
    rgb = np.asarray(Image.open(keypose_dataset / "images" / f"{stem}.png").convert("RGB"))
    depth = np.load(keypose_dataset / "depth" / f"{stem}.npy")
    seg = np.asarray(Image.open(keypose_dataset / "segmentation" / f"{stem}.png"))
    view = grid.project(rgb, depth, scene["camera"], LAYOUT.table_height, robot=seg == SEG_ROBOT)
    assert view.shape == (7, grid.rows, grid.cols) and view.dtype == np.float32
    assert 0.3 < view[4].mean() < 1.0  # most of the table is seen
    ids = grid.project_labels(seg, depth, scene["camera"], LAYOUT.table_height, robot=seg == SEG_ROBOT)
    both = grid.project_with_labels(rgb, seg, depth, scene["camera"], LAYOUT.table_height, robot=seg == SEG_ROBOT)
    assert np.array_equal(both[0], view) and np.array_equal(both[1], ids)
    assert ids.shape == (grid.rows, grid.cols) and not (ids == SEG_ROBOT).any()
    for obj in scene["objects"]:  # its highest point seen lies within its box, as high as its top
        lo = np.floor(grid.cell_of(np.array(obj["bbox"]["min"][:2]))).astype(int)
        hi = np.ceil(grid.cell_of(np.array(obj["bbox"]["max"][:2]))).astype(int) + 1
        box = (slice(max(lo[0], 0), hi[0]), slice(max(lo[1], 0), hi[1]))
        patch = view[3][box] * HEIGHT_SCALE
        top = obj["bbox"]["max"][2] - LAYOUT.table_height
        assert top - 0.015 < patch.max() <= top + 0.01, obj["name"]
        mine = ids == obj["segmentation_id"]  # the cells that show it lie in its box
        assert mine[box].sum() == mine.sum() > 0, obj["name"]


def test_a_keypose_policy_trains_resumes_and_acts_through_evaluate(keypose_dataset: Path, tmp_path: Path) -> None:
    from samplehd.cli import main
    from samplehd.learn.training import load_weights

    whole, cut = tmp_path / "whole", tmp_path / "cut"
    metrics = _train(keypose_dataset, whole, steps=4, batch=2)
    assert _train(keypose_dataset, cut, steps=4, batch=2, stop_after=2) == {"stopped_at": 2}
    with np.load(cut / "prepared.npz") as z:  # every decision with the attribute maps of what it sees
        assert len(z["train_attributes"]) == len(z["train_grid"]) and (z["train_attributes"] >= 0).any()
    _train(keypose_dataset, cut, steps=4, batch=2)
    assert not (cut / "prepared.npz").exists()
    a, b = load_weights(whole / "model.pt"), load_weights(cut / "model.pt")
    assert a.keys() == b.keys() and all(np.array_equal(a[k].numpy(), b[k].numpy()) for k in a)
    config = json.loads((whole / "config.json").read_text())
    assert config["action"] == "keypose" and config["grid"]["width"] == 320 and config["grid"]["height"] == 180
    assert metrics["train_decisions"] >= 3 and metrics["test_decisions"] >= 1
    assert set(metrics["test_grasp_error_m"]) == {"median", "mean", "within_1cm", "within_2cm"}
    assert 0 <= metrics["test_grasp_on_object"] <= 1  # which object the held-out grasps land on
    assert 0 <= metrics["test_class_accuracy"]["objects"] <= 1 and 0 <= metrics["test_class_accuracy"]["cells"] <= 1
    assert float(a["z_floor"]) > LAYOUT.table_height

    # a run may start from another keypose policy's weights (one line naming --init when it is not one)
    started = tmp_path / "started"
    assert main(["train", "policy", "--action", "keypose", "--dataset", str(keypose_dataset), "--out", str(started),
                 "--steps", "1", "--batch", "2", "--quiet", "--init", str(whole)]) == 0
    assert json.loads((started / "config.json").read_text())["train"]["init"] == str(whole)
    for bad in (keypose_dataset, started / "model.pt"):
        assert main(["train", "policy", "--action", "keypose", "--dataset", str(keypose_dataset), "--out",
                     str(tmp_path / "refused"), "--steps", "1", "--init", str(bad)]) == 2
    assert not (tmp_path / "refused").exists()

    # the product grasp head: its key and query in the weights, its name in the config; keypose only
    product = tmp_path / "product"
    assert main(["train", "policy", "--action", "keypose", "--grasp-head", "product", "--dataset",
                 str(keypose_dataset), "--out", str(product), "--steps", "1", "--batch", "2", "--quiet"]) == 0
    assert json.loads((product / "config.json").read_text())["model"]["grasp_head"] == "product"
    assert {"key.weight", "query.weight"} <= set(load_weights(product / "model.pt"))
    assert main(["train", "policy", "--grasp-head", "product", "--dataset", str(keypose_dataset), "--out",
                 str(tmp_path / "refused"), "--steps", "1"]) == 2
    assert main(["train", "policy", "--action", "keypose", "--dataset", str(keypose_dataset), "--out",
                 str(tmp_path / "refused"), "--steps", "1", "--init", str(product)]) == 2  # another network
    # the count of objects put down: its vectors in the weights, its name in the config; keypose only
    counted = tmp_path / "counted"
    assert main(["train", "policy", "--action", "keypose", "--placed-count", "--dataset", str(keypose_dataset),
                 "--out", str(counted), "--steps", "1", "--batch", "2", "--quiet"]) == 0
    assert json.loads((counted / "config.json").read_text())["model"]["placed_count"] is True
    assert "placed.weight" in load_weights(counted / "model.pt")
    assert main(["train", "policy", "--placed-count", "--dataset", str(keypose_dataset), "--out",
                 str(tmp_path / "refused"), "--steps", "1"]) == 2
    assert not (tmp_path / "refused").exists()
    code = main(["evaluate", "--policy", "bc", "--models", str(counted), "--families", "place", "--episodes", "1",
                 "--max-episode-steps", "60", "--out", str(tmp_path / "counted.json")])
    assert code == 0 and json.loads((tmp_path / "counted.json").read_text())["records"][0]["steps"] >= 1
    code = main(["evaluate", "--policy", "bc", "--models", str(product), "--families", "pick_up", "--episodes", "1",
                 "--max-episode-steps", "60", "--out", str(tmp_path / "product.json")])
    assert code == 0 and json.loads((tmp_path / "product.json").read_text())["records"][0]["steps"] >= 1

    report = tmp_path / "report.json"
    code = main(["evaluate", "--policy", "bc", "--models", str(whole), "--families", "pick_up", "--episodes", "1",
                 "--max-episode-steps", "60", "--out", str(report)])
    assert code == 0
    result = json.loads(report.read_text())
    assert result["episodes"] == 1 and result["records"][0]["steps"] >= 1


def test_the_held_out_metrics_say_which_object_is_grasped_and_what_the_class_map_calls_it() -> None:
    from samplehd.learn.keypose.training import _grounding_metrics

    # one view, 16 x 16 cells: a mug (class 0, colour 1) at rows 2-5, a bowl (class 1, colour 1) at rows 10-13
    attributes = np.full((2, 4, 16, 16), -1, np.int8)
    attributes[:, :, 2:6, 2:6] = np.array([0, 1, 0, 0])[:, None, None]
    attributes[:, :, 10:14, 2:6] = np.array([1, 1, 0, 0])[:, None, None]
    labels = np.zeros((2, 13), np.float32)
    labels[:, 0:2] = [3.0, 3.0]  # both decisions grasp the mug
    grasps = np.array([[4.0, 4.2], [11.0, 3.0]])  # the first on the mug, the second on the bowl
    classes = np.zeros((2, 16, 16), np.int64)  # the class map calls everything a mug
    m = _grounding_metrics(attributes, labels, grasps, classes)
    assert m["test_grasp_on_object"] == 0.5
    assert m["test_class_accuracy"] == {"objects": 0.5, "cells": 0.5}
    classes[:, 10:14, 2:6] = 1  # and now the bowl a bowl
    assert _grounding_metrics(attributes, labels, grasps, classes)["test_class_accuracy"]["objects"] == 1.0


def test_a_later_grasp_is_not_sought_where_an_earlier_one_was() -> None:
    import torch

    from samplehd.envs.tokens import encode_instruction, instruction_vocabulary
    from samplehd.learn.keypose.inference import AVOID_RADIUS, predict_decisions
    from samplehd.learn.keypose.modeling import KeyposeNet
    from samplehd.learn.topdown import GRID_CHANNELS, TopDownGrid

    torch.manual_seed(0)
    net = KeyposeNet(len(instruction_vocabulary()), GRID_CHANNELS, 8).eval()
    grid = TopDownGrid()
    view = torch.rand(1, GRID_CHANNELS, grid.rows, grid.cols)
    tokens = torch.as_tensor(encode_instruction("Put the red mug on the left side of the table.", 32)[None])
    with torch.no_grad():
        first = predict_decisions(net, view, tokens, grid)[0]
        avoid = [np.array(first.grasp[:2]), np.array(first.goal[:2])]
        second = predict_decisions(net, view, tokens, grid, [avoid])[0]
    for xy in avoid:  # the grasp's cell centre lies outside the radius; its offset moves it by under a cell
        assert np.linalg.norm(np.subtract(second.grasp[:2], xy)) > AVOID_RADIUS - grid.cell * 2


def test_each_sample_counts_the_objects_its_episode_put_down_before_it(keypose_dataset: Path) -> None:
    """The count a ``placed_count`` network reads: 0 for an episode's first decision, one more after
    each decision that lets go (a place moving two objects: 0 then 1)."""
    from samplehd.learn.keypose.configuration import KeyposeGrid
    from samplehd.learn.keypose.preparation import prepare_samples

    reader = DatasetReader(keypose_dataset)
    ks = list(range(len(reader.episodes)))
    arrays = prepare_samples(reader, ks, replace(KeyposeGrid(), width=320, height=180), 32)
    want = [n for k in ks if reader.episode_meta(k).success
            for n in np.cumsum([0] + [d.release for d in _decisions(reader, k)])[:-1]]
    assert arrays["placed"].tolist() == want and len(want) == len(arrays["grid"])
    assert 1 in want  # a place of two objects is among them


def test_a_placed_count_network_reads_the_count_and_starts_as_one_without() -> None:
    import torch

    from samplehd.envs.tokens import encode_instruction, instruction_vocabulary
    from samplehd.learn.keypose.modeling import PLACED_COUNTS, KeyposeNet
    from samplehd.learn.topdown import GRID_CHANNELS

    torch.manual_seed(0)
    plain = KeyposeNet(len(instruction_vocabulary()), GRID_CHANNELS, 8).eval()
    torch.manual_seed(0)
    counted = KeyposeNet(len(instruction_vocabulary()), GRID_CHANNELS, 8, placed_count=True).eval()
    shared = plain.state_dict()
    assert all(torch.equal(shared[k], v) for k, v in counted.state_dict().items() if k in shared)
    assert set(counted.state_dict()) - set(shared) == {"placed.weight"}
    tokens = torch.as_tensor(np.stack([encode_instruction("Stack the cup on the plate.", 32)] * 2))
    placed = torch.tensor([0, 1])
    with torch.no_grad():
        assert torch.equal(plain.code(tokens), counted.code(tokens, placed))  # zero at the start
        counted.placed.weight[1] = 1.0
        code = counted.code(tokens, placed)
        assert torch.equal(code[0], plain.code(tokens)[0]) and torch.equal(code[1], plain.code(tokens)[1] + 1.0)
        many = counted.code(tokens, torch.tensor([PLACED_COUNTS + 3, PLACED_COUNTS - 1]))
        assert torch.equal(many[0], many[1])  # counts past the last read as it


def test_the_policy_counts_the_objects_it_put_down(keypose_dataset: Path) -> None:
    """The count the policy gives its network: the decisions carried through to a release before this
    one, up to one the network called the last (a decision after it seeks that object again). The
    recorded decisions of an episode moving two objects, followed in the environment: 0 then 1; with
    the first called the last: 0 and 0."""
    from samplehd.learn.keypose.configuration import KeyposeConfig
    from samplehd.learn.keypose.inference import KeyposePolicy

    reader = DatasetReader(keypose_dataset)
    k = next(k for k in range(len(reader.episodes)) if reader.episode_meta(k).success
             and sum(d.release for d in _decisions(reader, k)) == 2)
    recorded = _decisions(reader, k)
    assert [d.last for d in recorded] == [False, True]
    env = replay_env(reader)
    try:
        for given, want in ((recorded, [0, 1]), ([replace(recorded[0], last=True), recorded[1]], [0, 0])):
            class Recorded(KeyposePolicy):  # the network's decisions replaced by these
                seen: list[int] = []
                decisions_given = given

                def decide(self, instruction: str):
                    self.seen.append(self.placed)
                    return self.decisions_given[len(self.seen) - 1]

            policy = Recorded(KeyposeConfig(), None, env)
            obs, _ = env.reset(options={"dataset": str(reader.root), "episode_index": k})
            for _ in range(1200):
                obs, _, terminated, truncated, info = env.step(policy(obs))
                if terminated or truncated or (len(policy.seen) == 2 and policy._follower.done):
                    break
            assert policy.seen == want and policy.retries == 0, (given, policy.seen)
    finally:
        env.close()


def test_the_privileged_reference_is_shown_the_objects_the_task_moves(keypose_dataset: Path, tmp_path: Path) -> None:
    """``--inputs state``: the view gains a channel marking the cells of the task's objects, in training
    and when acting; a run of other inputs is not started from its weights."""
    from samplehd.cli import main
    from samplehd.learn.topdown import GRID_CHANNELS, HEIGHT_SCALE

    out = tmp_path / "state"
    assert _train(keypose_dataset, out, steps=2, batch=2, inputs="state", stop_after=1) == {"stopped_at": 1}
    with np.load(out / "prepared.npz") as z:
        views = z["train_grid"].astype(np.float32)
    assert views.shape[1] == GRID_CHANNELS + 1
    marked = views[:, GRID_CHANNELS].reshape(len(views), -1)
    assert ((marked == 0) | (marked == 1)).all() and (marked.sum(1) > 0).all()
    # the marked cells stand above the table (objects), and are not all the cells that do
    raised = views[:, 3].reshape(len(views), -1) * HEIGHT_SCALE > 0.002
    assert raised[marked > 0].mean() > 0.95 and marked.sum() < raised.sum()
    assert main(["train", "policy", "--action", "keypose", "--inputs", "state", "--dataset", str(keypose_dataset),
                 "--out", str(out), "--steps", "2", "--batch", "2", "--quiet"]) == 0
    assert json.loads((out / "config.json").read_text())["inputs"] == "state"
    assert main(["train", "policy", "--action", "keypose", "--dataset", str(keypose_dataset), "--out",
                 str(tmp_path / "refused"), "--steps", "1", "--init", str(out)]) == 2
    assert not (tmp_path / "refused").exists()
    report = tmp_path / "report.json"
    assert main(["evaluate", "--policy", "bc", "--models", str(out), "--families", "place", "--episodes", "1",
                 "--max-episode-steps", "40", "--out", str(report)]) == 0
    assert json.loads(report.read_text())["records"][0]["steps"] >= 1


def test_keypose_training_refuses_what_it_does_not_use(keypose_dataset: Path, tmp_path: Path) -> None:
    from samplehd.cli import main

    out = tmp_path / "m"
    for extra in (["--demos", "5"], ["--hidden", "64"], ["--action", "steering", "--init", "x"]):
        assert main(["train", "policy", "--action", "keypose", "--dataset", str(keypose_dataset), "--out", str(out),
                     "--steps", "1", *extra]) == 2
        assert not out.exists()


def test_a_damaged_grid_in_a_policy_config_is_one_line_naming_the_field() -> None:
    from samplehd.errors import ConfigError
    from samplehd.learn.keypose.configuration import KeyposeConfig

    base = {"kind": "policy", "action": "keypose"}
    for grid, field in (({"rows": 100}, "grid.rows=100"), ({"origin": [0.1]}, "grid.origin=[0.1]"),
                        ({"cell": -0.01}, "grid.cell=-0.01"), ({"width": "wide"}, "grid.width='wide'")):
        with pytest.raises(ConfigError) as info:
            KeyposeConfig.from_dict({**base, "grid": grid})
        message = str(info.value)
        assert field in message and "\n" not in message, message
    with pytest.raises(ConfigError) as info:  # a count read or not: a JSON boolean
        KeyposeConfig.from_dict({**base, "model": {"placed_count": "yes"}})
    assert str(info.value) == "model.placed_count='yes': must be true or false"


def test_word_dropout_reads_a_share_of_the_words_as_unk_and_the_policy_reads_unheard_words_so() -> None:
    """Training reads each word as ``<UNK>`` with the configured probability (never a special token or the
    padding); a policy trained so reads a word outside its training instructions as ``<UNK>``, one of an
    earlier format (trained without) reads the words as they are."""
    from samplehd.envs.tokens import SPECIAL_TOKENS, encode_instruction, instruction_vocabulary
    from samplehd.learn.keypose.configuration import KeyposeConfig, KeyposeVocabulary, policy_tokens
    from samplehd.learn.keypose.training import _dropped_words

    unk = SPECIAL_TOKENS["<UNK>"]
    tokens = np.stack([encode_instruction("Pick up the red mug and put it in the bowl.", 32)] * 400)
    words = tokens >= len(SPECIAL_TOKENS)
    dropped = _dropped_words(tokens, 0.25, np.random.default_rng(0))
    assert (dropped[~words] == tokens[~words]).all()
    share = (dropped[words] == unk).mean()
    assert 0.22 < share < 0.28, share
    assert (_dropped_words(tokens, 0.25, np.random.default_rng(0)) == dropped).all()
    assert _dropped_words(tokens, 0.0, np.random.default_rng(0)) is tokens

    vocab = instruction_vocabulary()
    trained = KeyposeConfig(vocabulary=KeyposeVocabulary(words=("pick", "up", "the", "mug", ".")))
    text = "Make a stack of the mug."
    read = policy_tokens(trained, text)
    assert [int(t) for t in read[1:8]] == [unk, unk, unk, unk, vocab["the"], vocab["mug"], vocab["."]]
    train = {k: v for k, v in trained.train.to_dict().items() if k != "word_dropout"}
    legacy = KeyposeConfig.from_dict({**trained.to_dict(), "train": train})  # a file from before the option
    assert legacy.train.word_dropout == 0.0 and KeyposeConfig().train.word_dropout == 0.1
    assert (policy_tokens(legacy, text) == encode_instruction(text, legacy.tokens)).all()


def test_a_bad_word_dropout_in_a_policy_config_is_one_line_naming_the_field() -> None:
    from samplehd.errors import ConfigError
    from samplehd.learn.keypose.configuration import KeyposeConfig

    for value, shown in ((1.0, "1.0"), (-0.1, "-0.1"), ("some", "'some'")):
        with pytest.raises(ConfigError) as info:
            KeyposeConfig.from_dict({"kind": "policy", "action": "keypose", "train": {"word_dropout": value}})
        message = str(info.value)
        assert f"train.word_dropout={shown}" in message and "\n" not in message, message


def test_the_language_blind_control_reads_a_blank_instruction_in_training_and_when_acting(
        keypose_dataset: Path, tmp_path: Path) -> None:
    """``--blind-language``: every training sample and every decision reads the blank text, not the
    instruction; without ``--action keypose`` the flag is refused."""
    from samplehd.cli import main
    from samplehd.envs.tokens import encode_instruction
    from samplehd.learn.keypose.configuration import BLANK_TEXT, KeyposeConfig, policy_instruction
    from samplehd.learn.keypose.exclusion import unknown_nouns

    out = tmp_path / "blind"
    assert _train(keypose_dataset, out, steps=2, batch=2, language="blank", stop_after=1) == {"stopped_at": 1}
    with np.load(out / "prepared.npz") as z:  # the samples of a run not yet finished
        tokens = z["train_tokens"]
    assert len(tokens) and (tokens == encode_instruction(BLANK_TEXT, KeyposeConfig().tokens)[None]).all()
    assert main(["train", "policy", "--action", "keypose", "--blind-language", "--dataset", str(keypose_dataset),
                 "--out", str(out), "--steps", "2", "--batch", "2", "--quiet"]) == 0
    config = KeyposeConfig.from_dict(json.loads((out / "config.json").read_text()))
    assert config.language == "blank" and config.train.word_dropout == 0.0  # no word to drop
    assert policy_instruction(config, "Please pick up the mug.") == BLANK_TEXT
    assert policy_instruction(KeyposeConfig(), "Please pick up the mug.") == "Please pick up the mug."
    # nor does it ground an unheard word by exclusion: the rule reads what the policy reads
    report = tmp_path / "l4.json"
    assert main(["evaluate", "--policy", "bc", "--models", str(out), "--families", "pick_up", "--level", "L4",
                 "--episodes", "1", "--max-episode-steps", "5", "--out", str(report)]) == 0
    record = json.loads(report.read_text())["records"][0]
    assert unknown_nouns(record["instruction"], config.vocabulary) and record["diagnosis"]["exclusion"] is False
    assert main(["train", "policy", "--blind-language", "--dataset", str(keypose_dataset), "--out",
                 str(tmp_path / "refused"), "--steps", "1"]) == 2
    assert not (tmp_path / "refused").exists()
