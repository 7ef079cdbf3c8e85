"""``validate --deep`` means "safe to train on": every file a trainer or exporter reads (the scene
images, depth and segmentation, the scene camera, the stored config) is checked, and the keypose
trainer, which reads them all, refuses the same damage in one line before it writes anything.

A tiny dataset with 64×36 scene images is made once; each case damages a copy of it, runs the real
command (``samplehd.cli.main``) and compares the copy's bytes before and after.
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import stat
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import samplehd  # noqa: F401  (sets MUJOCO_GL before mujoco is imported)
from samplehd.cli import main

SCENE_IMAGES = {
    "num_scenes": 2,
    "seed": 0,
    "test_every": 2,
    "scene": {"min_objects": 3, "max_objects": 3},
    "instructions": {"per_scene": 1, "families": ["pick_up"]},
    "render": {"mode": "none", "width": 64, "height": 36},
}
FIRST = "SHD_train_000000"


def _tree(root: Path) -> dict[str, str]:
    """Every path under ``root`` with the SHA-256 of its bytes ('dir' for folders, the target of a
    symbolic link, 'fifo' for a named pipe: never opened)."""
    out = {}
    for p in sorted(root.rglob("*")):
        mode = p.lstat().st_mode
        if stat.S_ISLNK(mode):
            out[str(p.relative_to(root))] = f"link to {os.readlink(p)}"
        elif stat.S_ISFIFO(mode):
            out[str(p.relative_to(root))] = "fifo"
        elif stat.S_ISDIR(mode):
            out[str(p.relative_to(root))] = "dir"
        else:
            out[str(p.relative_to(root))] = hashlib.sha256(p.read_bytes()).hexdigest()
    return out


def _edit_json(path: Path, change: Callable[[Any], None]) -> None:
    doc = json.loads(path.read_text())
    change(doc)
    path.write_text(json.dumps(doc))


def _truncate(path: Path) -> None:
    data = path.read_bytes()
    path.write_bytes(data[: len(data) // 2])


# (id, how the copy is damaged, the file the message must name, a fragment of the message)
DAMAGES: list[tuple[str, Callable[[Path], None], str, str]] = [
    ("images-deleted", lambda d: shutil.rmtree(d / "images"), f"images/{FIRST}.png", "missing"),
    ("png-truncated", lambda d: _truncate(d / "images" / f"{FIRST}.png"), f"images/{FIRST}.png", "truncated"),
    ("depth-npy-text", lambda d: (d / "depth" / f"{FIRST}.npy").write_text("0.5 0.5\n"), f"depth/{FIRST}.npy",
     ".npy"),
    ("segmentation-deleted", lambda d: (d / "segmentation" / f"{FIRST}.png").unlink(),
     f"segmentation/{FIRST}.png", "missing"),
    ("depth-png-is-rgb", lambda d: shutil.copyfile(d / "images" / f"{FIRST}.png", d / "depth" / f"{FIRST}.png"),
     f"depth/{FIRST}.png", "mode RGB"),
    ("depth-npy-wrong-size", lambda d: np.save(d / "depth" / f"{FIRST}.npy", np.zeros((36, 32), np.float32)),
     f"depth/{FIRST}.npy", "(36, 32)"),
    ("scene-without-camera", lambda d: _edit_json(d / "scenes.json", lambda doc: doc["scenes"][0].pop("camera")),
     "scenes.json", "camera"),
    ("camera-bad-intrinsics", lambda d: _edit_json(
        d / "scenes.json", lambda doc: doc["scenes"][0]["camera"].update(intrinsics=[[1, 0], [0, 1]])),
     "scenes.json", "camera.intrinsics"),
    ("config-catalogue-ikea", lambda d: _edit_json(
        d / "info.json", lambda doc: doc["config"]["scene"].update(catalogue="ikea")),
     "info.json", "procedural, shop-vrb"),
    ("recorded-catalogue-ikea", lambda d: _edit_json(
        d / "info.json", lambda doc: doc["catalogue"].update(name="ikea")),
     "info.json", "procedural, shop-vrb"),
    ("scene-object-unknown-class", lambda d: _edit_json(
        d / "scenes.json", lambda doc: doc["scenes"][0]["objects"][0].update(shape="teapot")),
     "scenes.json", "scene 0: objects[0].shape='teapot': not a class of the dataset's catalogue or config; valid: "),
    ("scene-spec-unknown-class", lambda d: _edit_json(
        d / "scenes.json", lambda doc: doc["scenes"][1]["spec"]["objects"][0]["instance"].update(class_name="teapot")),
     "scenes.json", "scene 1: spec.objects[0].instance.class_name='teapot'"),
]


@pytest.fixture(scope="module")
def scene_image_dataset(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A complete dataset: 2 scenes with 64×36 scene images, one pick_up episode each (states only)."""
    from samplehd.dataset.config import GenerateConfig, preset_config
    from samplehd.dataset.generate import generate_dataset

    out = tmp_path_factory.mktemp("scene_images") / "ds"
    summary = generate_dataset(out, GenerateConfig.from_dict(SCENE_IMAGES, base=preset_config("tiny")))
    assert summary.episodes >= 2
    return out


def _damaged(src: Path, dst: Path, damage: Callable[[Path], None]) -> Path:
    shutil.copytree(src, dst)
    damage(dst)
    return dst


@pytest.mark.parametrize(("damage", "file", "fragment"), [pytest.param(d, f, m, id=i) for i, d, f, m in DAMAGES])
def test_validate_deep_finds_what_the_trainers_read(scene_image_dataset, tmp_path, damage, file, fragment,
                                                    capsys) -> None:
    ds = _damaged(scene_image_dataset, tmp_path / "ds", damage)
    before = _tree(tmp_path)
    assert main(["validate", str(ds), "--deep"]) == 1
    out = capsys.readouterr().out
    lines = [line for line in out.splitlines() if str(ds / file) in line]
    assert lines and fragment in lines[0], out
    assert _tree(tmp_path) == before


@pytest.mark.parametrize(("damage", "file", "fragment"), [pytest.param(d, f, m, id=i) for i, d, f, m in DAMAGES])
def test_keypose_trainer_refuses_the_same_damage_before_writing(scene_image_dataset, tmp_path, damage, file,
                                                                fragment, capsys) -> None:
    pytest.importorskip("torch")
    ds = _damaged(scene_image_dataset, tmp_path / "ds", damage)
    before = _tree(tmp_path)
    code = main(["train", "policy", "--action", "keypose", "--dataset", str(ds), "--out", str(tmp_path / "model"),
                 "--steps", "1", "--batch", "2", "--quiet"])
    err = capsys.readouterr().err.strip()
    assert code == 2, err
    assert len(err.splitlines()) == 1 and "Traceback" not in err, err
    assert str(ds / file) in err and fragment in err, err
    assert _tree(tmp_path) == before  # no half-made --out, the dataset untouched


def test_a_dataset_validate_deep_passes_trains(scene_image_dataset, tmp_path, capsys) -> None:
    pytest.importorskip("torch")
    assert main(["validate", str(scene_image_dataset), "--deep"]) == 0
    out = tmp_path / "model"
    assert main(["train", "policy", "--action", "keypose", "--dataset", str(scene_image_dataset), "--out", str(out),
                 "--steps", "1", "--batch", "2", "--quiet"]) == 0
    assert (out / "model.pt").is_file()


# ---- files that would hang or never resolve: FIFOs and loops of symbolic links --------------------------


def _refused(argv: list[str], fragments: tuple[str, ...], capsys: pytest.CaptureFixture[str], root: Path) -> None:
    """``main(argv)`` exits 2 with one line holding ``fragments`` and changes nothing under ``root``."""
    before = _tree(root)
    code = main(argv)
    err = capsys.readouterr().err.strip()
    assert code == 2, err
    assert len(err.splitlines()) == 1 and "Traceback" not in err, err
    for fragment in fragments:
        assert fragment in err, err
    assert _tree(root) == before


@pytest.fixture
def loops(tmp_path: Path, scene_image_dataset: Path) -> Path:
    """``loop``: a link to itself; ``ds_loop``: the dataset with ``episodes`` a loop of two links."""
    (tmp_path / "loop").symlink_to("loop")
    ds = tmp_path / "ds_loop"
    shutil.copytree(scene_image_dataset, ds)
    shutil.rmtree(ds / "episodes")
    (ds / "episodes").symlink_to("other")
    (ds / "other").symlink_to("episodes")
    return tmp_path


LOOP_CASES = [
    ("generate-config", ["generate", "--quiet", "--out", "{w}/new", "--config", "{w}/loop"], "--config"),
    ("generate-out", ["generate", "--quiet", "--out", "{w}/loop"], "--out"),
    ("stats-out", ["stats", "{ds}", "--out", "{w}/loop"], "--out"),
    ("instructions-templates", ["instructions", "--scenes", "{ds}/scenes.json", "--out", "{w}/new.json",
                                "--templates", "{w}/loop"], "--templates"),
    ("validate-dataset", ["validate", "{w}/loop"], "{w}/loop"),
    ("stats-episodes-folder", ["stats", "{w}/ds_loop"], "episodes/"),
    ("export-episodes-folder", ["export", "lerobot", "{w}/ds_loop", "--out", "{w}/new"], "episodes/"),
]


@pytest.mark.parametrize(("argv", "fragment"), [pytest.param(a, f, id=i) for i, a, f in LOOP_CASES])
def test_a_loop_of_symbolic_links_is_one_line(loops, scene_image_dataset, argv, fragment, capsys,
                                             monkeypatch) -> None:
    monkeypatch.chdir(loops)
    values = {"w": str(loops), "ds": str(scene_image_dataset)}
    _refused([a.format(**values) for a in argv], (fragment.format(**values), "loop of symbolic links"), capsys,
             loops)


def test_validate_lists_an_episodes_folder_that_is_a_loop(loops, capsys) -> None:
    before = _tree(loops)
    assert main(["validate", str(loops / "ds_loop")]) == 1
    assert "is a loop of symbolic links, not an episode file" in capsys.readouterr().out
    assert _tree(loops) == before


# Run in a child process with a timeout: a read that waits for a FIFO's writer would hang the test run.
_FIFO_SCRIPT = """
import contextlib, io, json, sys
from samplehd.cli import main
results = []
for argv in json.loads(sys.argv[1]):
    err = io.StringIO()
    with contextlib.redirect_stderr(err):
        code = main(argv)
    results.append([code, err.getvalue()])
print(json.dumps(results))
"""


def test_a_fifo_is_refused_before_it_is_opened(tmp_path: Path, scene_image_dataset: Path) -> None:
    import subprocess
    import sys

    fifo = tmp_path / "fifo"
    os.mkfifo(fifo)
    ds = tmp_path / "ds_fifo"
    shutil.copytree(scene_image_dataset, ds)
    episode = sorted((ds / "episodes").iterdir())[0]
    episode.unlink()
    os.mkfifo(episode)
    cases = [
        (["generate", "--quiet", "--out", str(tmp_path / "new"), "--config", str(fifo)], "--config"),
        (["evaluate", "--policy", "oracle", "--episodes", "1", "--env-options", str(fifo)], "--env-options"),
        (["replay", str(fifo), "--out", str(tmp_path / "x.mp4")], str(fifo)),
        (["stats", str(ds)], str(episode)),
        (["export", "lerobot", str(ds), "--out", str(tmp_path / "new")], str(episode)),
    ]
    before = _tree(tmp_path)
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)}
    done = subprocess.run([sys.executable, "-c", _FIFO_SCRIPT, json.dumps([argv for argv, _ in cases])],
                          capture_output=True, text=True, timeout=120, env=env, cwd=tmp_path)
    assert done.returncode == 0, done.stderr[-2000:]
    for (code, err), (argv, fragment) in zip(json.loads(done.stdout.splitlines()[-1]), cases, strict=True):
        assert code == 2 and len(err.strip().splitlines()) == 1, (argv, err)
        assert fragment in err and "named pipe (FIFO)" in err, err
    validate = subprocess.run([sys.executable, "-m", "samplehd", "validate", str(ds)], capture_output=True,
                              text=True, timeout=120, env=env)
    assert validate.returncode == 1 and f"{episode}: is a named pipe (FIFO)" in validate.stdout
    assert _tree(tmp_path) == before


# ---- damaged model folders: one line naming the file, nothing written -----------------------------------


@pytest.fixture(scope="module")
def model_folders(scene_image_dataset: Path, tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """A keypose policy and a parser trained for one step, and damaged copies of the policy: a config.json
    that is not UTF-8, a config of another width, a parser's weights, and an unfinished run (checkpoint)
    whose config.json is damaged."""
    pytest.importorskip("torch")
    root = tmp_path_factory.mktemp("models")
    train = ["train", "policy", "--action", "keypose", "--dataset", str(scene_image_dataset), "--steps", "1",
             "--batch", "2", "--quiet", "--out"]
    assert main([*train, str(root / "keypose")]) == 0
    assert main(["train", "parser", "--dataset", str(scene_image_dataset), "--steps", "1", "--quiet", "--out",
                 str(root / "parser")]) == 0
    folders = {"keypose": root / "keypose", "parser": root / "parser"}
    for name in ("not_utf8", "other_width", "parser_weights"):
        shutil.copytree(root / "keypose", root / name)
        folders[name] = root / name
    (root / "not_utf8" / "config.json").write_bytes(b"\xff\xfe{\x00}\x00")
    _edit_json(root / "other_width" / "config.json", lambda doc: doc["model"].update(width=24))
    shutil.copyfile(root / "parser" / "model.pt", root / "parser_weights" / "model.pt")
    from samplehd.learn.keypose.configuration import KeyposeConfig, KeyposeTraining
    from samplehd.learn.keypose.training import train_keypose

    unfinished = root / "unfinished"
    config = KeyposeConfig(train=KeyposeTraining(steps=2, batch=2))
    assert train_keypose(scene_image_dataset, unfinished, config, quiet=True, stop_after=1) == {"stopped_at": 1}
    (unfinished / "config.json").write_bytes(b"\x00garbage")
    folders["unfinished"] = unfinished
    return folders


MODEL_CASES = [
    ("config-not-utf8", "not_utf8", "config.json", "utf-8"),
    ("weights-other-width", "other_width", "model.pt", "do not fit"),
    ("weights-of-a-parser", "parser_weights", "model.pt", "do not fit"),
    ("parser-folder", "parser", "config.json", "'parser' model"),
]


@pytest.mark.parametrize(("folder", "file", "fragment"), [pytest.param(f, n, m, id=i) for i, f, n, m in MODEL_CASES])
def test_a_damaged_model_folder_is_one_line(model_folders, tmp_path, folder, file, fragment, capsys) -> None:
    models = model_folders[folder]
    before = _tree(models)
    argv = ["evaluate", "--policy", "bc", "--models", str(models), "--families", "pick_up", "--episodes", "1",
            "--out", str(tmp_path / "report.json")]
    _refused(argv, (str(models / file), fragment), capsys, tmp_path)
    assert _tree(models) == before


def test_weights_that_do_not_fit_a_parser_are_one_line(model_folders, scene_image_dataset, capsys) -> None:
    parser = model_folders["parser"]
    folder = parser.parent / "parser_bad"
    shutil.copytree(parser, folder)
    shutil.copyfile(model_folders["keypose"] / "model.pt", folder / "model.pt")
    _refused(["train", "parser", "--dataset", str(scene_image_dataset), "--evaluate-only", "--out", str(folder)],
             (str(folder / "model.pt"), "do not fit"), capsys, folder)


def test_a_resumed_run_with_a_damaged_config_is_refused_not_overwritten(model_folders, scene_image_dataset,
                                                                        capsys) -> None:
    out = model_folders["unfinished"]
    _refused(["train", "policy", "--action", "keypose", "--dataset", str(scene_image_dataset), "--steps", "2",
              "--batch", "2", "--quiet", "--out", str(out)], (str(out / "config.json"),), capsys, out)


@pytest.mark.parametrize("batch", ["1000000000000", "5000"])
def test_a_batch_too_big_to_allocate_is_refused_with_the_range(scene_image_dataset, tmp_path, batch, capsys) -> None:
    pytest.importorskip("torch")
    _refused(["train", "policy", "--action", "keypose", "--dataset", str(scene_image_dataset), "--out",
              str(tmp_path / "model"), "--batch", batch], ("--batch", batch, "1..4096"), capsys, tmp_path)


# ---- evaluate --policy bc honours a flag or refuses it; never swaps it for the model's --------------------
EVAL_FLAG_CASES = [
    ("obs-mode", ["--obs-mode", "rgb"], ("--obs-mode rgb", "obs_mode='state'")),
    ("control-mode", ["--control-mode", "joint_delta"], ("--control-mode joint_delta", "control_mode='steering'")),
    ("env-options-file", ["--env-options", "{w}/options.json"], ("options.json", "control_mode='joint_delta'",
                                                                  "'steering'")),
    ("out-inside-models", ["--out", "{m}/report.json"], ("--out", "inside the model folder")),
    ("out-through-a-link", ["--out", "{w}/link/report.json"], ("--out", "inside the model folder")),
    ("video-inside-models", ["--video", "{m}/videos"], ("--video", "inside the model folder")),
]


@pytest.mark.parametrize(("extra", "fragments"), [pytest.param(e, f, id=i) for i, e, f in EVAL_FLAG_CASES])
def test_evaluate_never_silently_replaces_a_flag_with_the_models(model_folders, tmp_path, extra, fragments,
                                                                  capsys) -> None:
    models = model_folders["keypose"]
    (tmp_path / "options.json").write_text(json.dumps({"control_mode": "joint_delta"}))
    (tmp_path / "link").symlink_to(models)
    values = {"w": str(tmp_path), "m": str(models)}
    before = _tree(models)
    argv = ["evaluate", "--policy", "bc", "--models", str(models), "--families", "pick_up", "--episodes", "1",
            *(a.format(**values) for a in extra)]
    _refused(argv, tuple(f.format(**values) for f in fragments), capsys, tmp_path)
    assert _tree(models) == before


def test_evaluate_honours_a_flag_the_model_agrees_with(model_folders, tmp_path, capsys) -> None:
    report = tmp_path / "report.json"
    assert main(["evaluate", "--policy", "bc", "--models", str(model_folders["keypose"]), "--families", "pick_up",
                 "--episodes", "1", "--max-episode-steps", "5", "--control-mode", "steering", "--out",
                 str(report)]) == 0
    assert json.loads(report.read_text())["episodes"] == 1


# ---- evaluate --policy lerobot:CKPT -------------------------------------------------------------------------
@pytest.mark.parametrize(("ckpt", "fragment"), [("~nosuchuser_samplehd/x", "no such user"),
                                                ("p" * 5000, "5000 characters")])
def test_a_lerobot_path_that_cannot_be_a_folder_is_one_line(tmp_path, ckpt, fragment, capsys) -> None:
    _refused(["evaluate", "--policy", f"lerobot:{ckpt}", "--episodes", "1"], ("--policy", fragment), capsys,
             tmp_path)


def test_a_relative_export_root_is_found_from_the_checkpoint_not_the_cwd(tmp_path, monkeypatch) -> None:
    from samplehd.benchmark.lerobot_policy import export_root
    from samplehd.envs.lerobot_contract import EXPORT_RECORD

    ran_in = tmp_path / "project"
    checkpoint = ran_in / "outputs" / "act" / "checkpoints" / "last" / "pretrained_model"
    checkpoint.mkdir(parents=True)
    (ran_in / "data" / "export" / EXPORT_RECORD).parent.mkdir(parents=True)
    (ran_in / "data" / "export" / EXPORT_RECORD).write_text("{}")
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    monkeypatch.chdir(elsewhere)
    train_config = {"dataset": {"root": "data/export"}, "output_dir": "outputs/act"}
    assert export_root(checkpoint, train_config) == ran_in / "data" / "export"
    assert export_root(checkpoint, {"dataset": {"root": "data/export"}}) == ran_in / "data" / "export"
    assert export_root(checkpoint, {"dataset": {"root": "data/other"}}) is None
    assert export_root(checkpoint, {}) is None


# ---- the environment: reset options and constructor values ------------------------------------------------
@pytest.fixture(scope="module")
def two_slot_env():
    """Tabletop-v0 whose observation holds 2 objects (the dataset's scenes have 3)."""
    import gymnasium as gym

    env = gym.make("samplehd/Tabletop-v0", num_scenes=1, scene={"min_objects": 2, "max_objects": 2})
    yield env
    env.close()


@pytest.mark.parametrize("value", [5, None, b"ds", ["ds"]], ids=["int", "none", "bytes", "list"])
def test_a_dataset_option_that_is_no_path_is_one_line(two_slot_env, value) -> None:
    from samplehd.errors import ConfigError

    with pytest.raises(ConfigError) as caught:
        two_slot_env.reset(options={"dataset": value, "episode_index": 0})
    message = str(caught.value)
    assert len(message.splitlines()) == 1 and "'dataset'" in message and "a dataset folder" in message


def test_an_episode_with_more_objects_than_slots_is_refused(two_slot_env, scene_image_dataset) -> None:
    from samplehd.errors import ConfigError

    with pytest.raises(ConfigError, match=r"3 objects.*2 slots.*max_objects ≥ 3"):
        two_slot_env.reset(options={"dataset": str(scene_image_dataset), "episode_index": 0})


def test_numpy_integers_are_integers_and_human_rendering_is_refused() -> None:
    import gymnasium as gym

    from samplehd.envs.config import EnvConfig
    from samplehd.errors import ConfigError

    config = EnvConfig.from_kwargs(width=np.int64(64), height=np.int32(48), num_scenes=np.uint8(2))
    assert (config.width, config.height, config.num_scenes) == (64, 48, 2)
    assert type(config.width) is int and json.dumps(config.to_dict())
    with pytest.raises(ConfigError, match="render_mode='human': valid: rgb_array"):
        gym.make("samplehd/Tabletop-v0", render_mode="human")


# ---- validate: no false alarm while a writer runs -------------------------------------------------------------
def test_validate_says_a_running_rerender_is_running(scene_image_dataset, tmp_path, capsys) -> None:
    from samplehd.dataset.lock import dataset_lock

    ds = tmp_path / "ds"
    shutil.copytree(scene_image_dataset, ds)
    _edit_json(ds / "info.json", lambda info: info.update(rerender={"done": 1, "episodes": 2}))
    with dataset_lock(ds):  # as the rerender holds it (a second open file description conflicts in-process too)
        _refused(["validate", str(ds)], ("a rerender is running", f"process {os.getpid()}"), capsys, tmp_path)
    assert main(["validate", str(ds)]) == 1  # once it has ended, the unfinished record is a problem again
    assert "a rerender stopped after 1 of 2 episodes" in capsys.readouterr().out


def test_a_nan_in_recorded_steering_names_the_episode(scene_image_dataset, tmp_path, capsys) -> None:
    import h5py

    from samplehd.dataset.reader import DatasetReader
    from samplehd.envs.replay_check import replay_dataset
    from samplehd.errors import DatasetError
    from samplehd.fileio import file_sha256

    ds = tmp_path / "ds"
    shutil.copytree(scene_image_dataset, ds)
    path = DatasetReader(ds).episode_path(1)
    with h5py.File(path, "r+") as f:
        steering = f["frames/steering"][...]
        steering[3, 0] = np.nan
        f["frames/steering"][...] = steering
    _edit_json(ds / "info.json", lambda info: info["episodes"][1].update(size=path.stat().st_size,
                                                                         sha256=file_sha256(path)))
    assert main(["validate", str(ds), "--replay"]) == 1  # found before any replay
    assert f"{path}: frames/steering has non-finite values" in capsys.readouterr().out
    with pytest.raises(DatasetError, match=rf"{path} \(episode 1\): frames/steering has non-finite values at frame 3"):
        replay_dataset(ds)


# ---- quieter gaps ------------------------------------------------------------------------------------------------
def _episode_twice(ds: Path) -> None:
    def twice(info: dict) -> None:
        info["episodes"][1] = dict(info["episodes"][0], instruction_index=1)

    _edit_json(ds / "info.json", twice)


RERENDER_DAMAGES = [("scenes-json-missing", lambda d: (d / "scenes.json").unlink(), "scenes.json", "missing"),
                    ("episode-listed-twice", _episode_twice, "info.json", "again")]


@pytest.mark.parametrize(("damage", "file", "fragment"),
                         [pytest.param(d, f, m, id=i) for i, d, f, m in RERENDER_DAMAGES])
def test_rerender_refuses_a_damaged_listing_before_writing(scene_image_dataset, tmp_path, damage, file, fragment,
                                                           capsys) -> None:
    ds = _damaged(scene_image_dataset, tmp_path / "ds", damage)
    _refused(["rerender", str(ds), "--cameras", "scene", "--width", "32", "--height", "32", "--quiet"],
             (str(ds / file), fragment), capsys, tmp_path)


def test_export_sample_hd_of_a_states_only_dataset_is_refused(scene_image_dataset, tmp_path, capsys) -> None:
    _refused(["export", "sample-hd", str(scene_image_dataset), "--out", str(tmp_path / "shd"), "--workers", "1"],
             (str(scene_image_dataset), "store no images", "--no-images"), capsys, tmp_path)


@pytest.mark.parametrize("families", ["", ","])
def test_instructions_with_no_family_named_is_refused(scene_image_dataset, tmp_path, families, capsys) -> None:
    _refused(["instructions", "--scenes", str(scene_image_dataset / "scenes.json"), "--out",
              str(tmp_path / "i.json"), "--families", families], ("--families", "pick_up"), capsys, tmp_path)


def test_the_viewer_refuses_frame_minus_one(scene_image_dataset) -> None:
    from samplehd.viewer.app import ViewerApp
    from samplehd.viewer.server import open_dataset

    app = ViewerApp(open_dataset(scene_image_dataset, render=False))
    name = Path(json.loads((scene_image_dataset / "info.json").read_text())["episodes"][0]["file"]).stem
    assert app.handle(f"/api/episodes/{name}/frame/0", {"camera": "scene"}).status in (200, 404)
    response = app.handle(f"/api/episodes/{name}/frame/-1", {"camera": "scene"})
    assert response.status == 400 and b"frame -1" in response.body


def test_resuming_a_finished_dataset_says_there_is_nothing_to_do(scene_image_dataset, tmp_path, capsys) -> None:
    ds = tmp_path / "ds"
    shutil.copytree(scene_image_dataset, ds)
    config = tmp_path / "config.json"
    config.write_text(json.dumps(SCENE_IMAGES))
    episodes = {p.name: hashlib.sha256(p.read_bytes()).hexdigest() for p in (ds / "episodes").iterdir()}
    assert main(["generate", "--out", str(ds), "--resume", "--preset", "tiny", "--config", str(config),
                 "--quiet"]) == 0
    assert f"nothing to do: the dataset {ds} is complete" in capsys.readouterr().out
    assert {p.name: hashlib.sha256(p.read_bytes()).hexdigest() for p in (ds / "episodes").iterdir()} == episodes


def test_keypose_training_on_small_scene_images_warns(scene_image_dataset, tmp_path, capsys) -> None:
    pytest.importorskip("torch")
    from samplehd.learn.keypose.configuration import KeyposeGrid
    from samplehd.learn.keypose.training import _warn_if_small

    _warn_if_small(KeyposeGrid(width=64, height=36), quiet=False)
    err = capsys.readouterr().err
    assert "designed for 640x360 scene images; these are 64x36" in err and len(err.splitlines()) == 1
    _warn_if_small(KeyposeGrid(width=320, height=180), quiet=False)
    _warn_if_small(KeyposeGrid(width=64, height=36), quiet=True)
    assert capsys.readouterr().err == ""


def test_validate_replay_shows_progress_and_writes_a_per_episode_report(scene_image_dataset, tmp_path,
                                                                       capsys) -> None:
    report = tmp_path / "report.json"
    assert main(["validate", str(scene_image_dataset), "--replay", "--episodes", "1", "--out", str(report)]) == 0
    captured = capsys.readouterr()
    assert "replayed 1/1: episode 0 (pick_up) agrees" in captured.err
    doc = json.loads(report.read_text())
    assert doc["agrees"] and [e["index"] for e in doc["episodes"]] == [0] and doc["episodes"][0]["steps"] > 0
    _refused(["validate", str(scene_image_dataset), "--out", str(tmp_path / "r.json")], ("--out", "--replay"),
             capsys, tmp_path)


def test_validate_replay_on_two_workers_gives_the_same_report(scene_image_dataset, tmp_path, capsys) -> None:
    reports = []
    for workers in ("1", "2"):
        report = tmp_path / f"report{workers}.json"
        assert main(["validate", str(scene_image_dataset), "--replay", "--episodes", "2", "--workers", workers,
                     "--out", str(report)]) == 0
        err = capsys.readouterr().err
        assert sorted(line.split(": ", 1)[1] for line in err.splitlines() if line.startswith("replayed ")) == [
            "episode 0 (pick_up) agrees", "episode 1 (pick_up) agrees"], err
        assert "replayed 2/2: " in err
        reports.append(report.read_bytes())
    assert reports[0] == reports[1]
    assert [e["index"] for e in json.loads(reports[1])["episodes"]] == [0, 1]
    _refused(["validate", str(scene_image_dataset), "--workers", "2"], ("--workers", "--replay"), capsys, tmp_path)
    _refused(["validate", str(scene_image_dataset), "--replay", "--workers", "0"], ("--workers", "0"), capsys,
             tmp_path)


def test_generate_takes_families_as_a_flag(tmp_path, capsys) -> None:
    out = tmp_path / "ds"
    assert main(["generate", "--out", str(out), "--scenes", "1", "--render", "none", "--families", "pick_up",
                 "--quiet", "--workers", "1"]) == 0
    assert json.loads((out / "info.json").read_text())["config"]["instructions"]["families"] == ["pick_up"]
    _refused(["generate", "--out", str(tmp_path / "other"), "--families", "bogus", "--quiet"],
             ("--families", "bogus", "pick_up"), capsys, tmp_path)


def test_an_imported_class_the_config_names_is_a_known_class() -> None:
    """Imported classes take part only where a config names them (``scene.classes``): such an object is
    no unknown class, and one the config does not name still is."""
    from samplehd.dataset.validate import known_classes, validate_scene_files

    info = {"catalogue": {"name": "procedural"}, "config": {"scene": {"classes": ["mug", "teapot"]}}}
    valid = known_classes(info)
    assert valid is not None and "teapot" in valid and "mug" in valid
    scene = {"image_index": 0, "objects": [{"shape": "teapot"}]}
    assert not [p for p in validate_scene_files(Path("ds"), [scene], info=info) if "not a class" in p]
    other = {"image_index": 0, "objects": [{"shape": "kettle"}]}
    assert [p for p in validate_scene_files(Path("ds"), [other], info=info) if "objects[0].shape='kettle'" in p]
