"""The LeRobot env contract (samplehd.benchmark.lerobot_tabletop): names and shapes of the export, is_success,
seeds of `samplehd evaluate`'s split; and, where lerobot is importable (its Python 3.12 venv), the
plugin's env factory and one LeRobot-style rollout step with a dummy policy."""

from __future__ import annotations

import json
import re
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from samplehd.benchmark.evaluation import benchmark_split
from samplehd.benchmark.lerobot_tabletop import LeRobotTabletop, make_lerobot_envs
from samplehd.benchmark.levels import reset_at_level
from samplehd.dataset.lerobot_contract import EXPORT_RECORD, VECTOR_FEATURES
from samplehd.envs.lerobot_contract import env_options_from_export
from samplehd.envs.tabletop import TabletopEnv
from samplehd.errors import ConfigError
from samplehd.export.lerobot import _env_record

SIZE = 32


@pytest.fixture()
def options(fast_options: dict) -> dict:
    return {**fast_options, "obs_mode": "rgb", "cameras": ["scene"], "width": SIZE, "height": SIZE}


def lerobot_keys(obs: dict[str, Any]) -> dict[str, tuple[int, ...]]:
    """Feature names and per-env shapes as LeRobot's preprocess_observation renames a raw observation:
    ``pixels`` dict → ``observation.images.<cam>`` (HWC → CHW), ``agent_pos`` → ``observation.state``,
    any other array ``k`` → ``observation.<k>``."""
    out = {f"observation.images.{cam}": (img.shape[2], *img.shape[:2]) for cam, img in obs["pixels"].items()}
    out["observation.state"] = obs["agent_pos"].shape
    out.update({f"observation.{k}": v.shape for k, v in obs.items() if k not in ("pixels", "agent_pos")})
    return out


def test_observations_are_named_and_shaped_as_the_export(options: dict) -> None:
    env = LeRobotTabletop("pick_up", options)
    obs, info = env.reset(seed=0)
    exported = {k: (len(n),) for k, n in VECTOR_FEATURES.items() if k.startswith("observation")}
    exported["observation.images.scene"] = (3, SIZE, SIZE)  # (H, W, 3) in info.json, CHW once loaded
    assert lerobot_keys(obs) == exported
    assert env.observation_space.contains(obs)
    assert obs["pixels"]["scene"].dtype == np.uint8
    raw = env.inner._observation()
    assert np.allclose(obs["agent_pos"][:6], raw["joint_pos"]) and obs["agent_pos"][6] == pytest.approx(
        raw["gripper"][:2].sum())  # gripper opening [m], as the recorder's
    assert np.allclose(obs["tcp_pose"], np.concatenate([raw["tcp_pos"], raw["tcp_quat"]]))
    assert info["is_success"] is False and env.task == "pick_up" and env.task_description == info["instruction"]
    assert env._max_episode_steps == 1500 and env.action_space.shape == (7,) and env.metadata["render_fps"] == 20
    assert isinstance(env.metadata["render_fps"], int)  # lerobot-eval writes its videos with PyAV
    obs, reward, _, _, info = env.step(np.zeros(7, np.float32))
    assert info["is_success"] == info["success"] == env.inner.check_success()["success"]
    assert env.render() is obs["pixels"]["scene"]
    env.close()


def test_seeds_reproduce_the_evaluate_split_and_levels(options: dict) -> None:
    families = ("place", "pick_up")
    env = LeRobotTabletop("pick_up", options, families=families, split_seed=5)
    _, info = env.reset(seed=3)
    seed, family = benchmark_split(8, families, 5)[7]  # episode 3 of family 1 of 2
    assert info["split_episode"] == 7 and family == "pick_up" and info["reset_seed"] == seed
    plain = TabletopEnv(**{**options, "families": ["pick_up"]})
    _, ref = plain.reset(seed=seed, options={"family": "pick_up"})
    assert info["instruction"] == ref["instruction"] and info["scene_seed"] == ref["scene_seed"]
    _, info = env.reset()  # Gymnasium's autoreset: the next episode
    assert info["split_episode"] == 9
    leveled = LeRobotTabletop("pick_up", options, families=families, split_seed=5, level="L1")
    _, info = leveled.reset(seed=0)
    _, ref, used = reset_at_level(plain, benchmark_split(2, families, 5)[1][0], "pick_up", "L1")
    assert info["reset_seed"] == used and info["instruction"] == ref["instruction"]
    for e in (env, leveled, plain):
        e.close()


def test_vector_envs_are_lerobots_nesting(options: dict) -> None:
    envs = make_lerobot_envs(["pick_up"], options, n_envs=2, max_episode_steps=7)
    assert list(envs) == ["pick_up"] and list(envs["pick_up"]) == [0]
    vec = envs["pick_up"][0]
    obs, info = vec.reset(seed=[0, 1])
    assert obs["pixels"]["scene"].shape == (2, SIZE, SIZE, 3) and obs["agent_pos"].shape == (2, 7)
    assert list(info["split_episode"]) == [0, 1] and vec.call("_max_episode_steps") == (7, 7)
    assert all(vec.call("task_description"))
    _, _, _, _, info = vec.step(np.zeros((2, 7), np.float32))
    assert info["is_success"].dtype == bool and info["is_success"].shape == (2,)
    vec.close()


def test_bad_options_are_one_line(options: dict, tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match=r"level='L9': valid: L1, L2, L3, L4"):
        LeRobotTabletop("pick_up", options, level="L9")
    with pytest.raises(ConfigError, match=r"obs_mode='state'"):
        LeRobotTabletop("pick_up", {**options, "obs_mode": "state"})
    with pytest.raises(ConfigError, match=r"task='stack': not among"):
        LeRobotTabletop("stack", options, families=("pick_up",))
    with pytest.raises(ConfigError, match=r"cannot read meta/samplehd.json .*samplehd export lerobot"):
        env_options_from_export(tmp_path)


def test_the_export_record_builds_the_env(tmp_path: Path) -> None:
    from samplehd.dataset.config import GenerateConfig

    settings = {"scene": {"mode": "fast", "width": 64, "height": 48, "modalities": ["rgb"]}}
    record = _env_record(GenerateConfig().to_dict(), settings, ["scene"], ["pick_up"])
    (tmp_path / "meta").mkdir()
    (tmp_path / EXPORT_RECORD).write_text(json.dumps(record))
    env = LeRobotTabletop("pick_up", env_options_from_export(tmp_path))
    assert env.observation_space["pixels"]["scene"].shape == (48, 64, 3)
    uneven = {**settings, "wrist": {**settings["scene"], "width": 32}}
    assert "env_note" in _env_record(GenerateConfig().to_dict(), uneven, ["scene", "wrist"], ["pick_up"])
    (tmp_path / EXPORT_RECORD).write_text(json.dumps(_env_record({}, uneven, ["scene", "wrist"], [])))
    with pytest.raises(ConfigError, match="no environment settings: cameras"):
        env_options_from_export(tmp_path)


def test_lerobot_factory_and_one_rollout_step(options: dict, tmp_path: Path) -> None:
    """Where lerobot is installed (its Python 3.12 venv with this plugin): LeRobot's make_env, its
    preprocess_observation and a dummy policy's step, as lerobot-eval's rollout does them."""
    pytest.importorskip("lerobot")
    torch = pytest.importorskip("torch")
    plugin = pytest.importorskip("lerobot_env_samplehd")
    from lerobot.envs.factory import make_env
    from lerobot.envs.utils import env_to_policy_features, preprocess_observation

    (tmp_path / "meta").mkdir()
    (tmp_path / EXPORT_RECORD).write_text(json.dumps({"env": {**options, "families": ["pick_up"]}}))
    cfg = plugin.SamplehdEnv(dataset=str(tmp_path), episode_length=5)  # task: the export's families
    features = env_to_policy_features(cfg)
    envs = make_env(cfg, n_envs=1)
    vec = envs["pick_up"][0]
    obs, _ = vec.reset(seed=[0])
    batch = preprocess_observation(obs)
    inputs = {k: tuple(f.shape) for k, f in features.items() if k != "action"}
    assert {k: tuple(v.shape[1:]) for k, v in batch.items()} == inputs
    image = batch["observation.images.scene"]
    assert image.dtype == torch.float32 and float(image.max()) <= 1
    action = torch.zeros((1, *features["action"].shape))  # a dummy policy's select_action
    _, _, _, _, info = vec.step(action.numpy())
    assert "is_success" in info
    vec.close()


# `samplehd evaluate --policy lerobot:CKPT`: refusals in one line before anything runs (with or without
# lerobot), and a tiny real LeRobot policy run end to end where lerobot is importable.

def _lerobot_importable() -> bool:
    import importlib.util

    return importlib.util.find_spec("lerobot") is not None


def _evaluate(argv: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, str, str]:
    from samplehd.cli import main

    rc = main(["evaluate", *argv])
    captured = capsys.readouterr()
    return rc, captured.out, captured.err


@pytest.mark.parametrize("case", ["missing", "empty", "config-only"])
def test_evaluate_lerobot_refusals_are_one_line(case: str, tmp_path: Path,
                                                capsys: pytest.CaptureFixture[str]) -> None:
    ckpt = tmp_path / "ckpt"
    if case != "missing":
        ckpt.mkdir()
    if case == "config-only":  # a type lerobot knows, but no weights
        (ckpt / "config.json").write_text(json.dumps({"type": "act"}))
    expected = {"missing": f"no folder '{ckpt}'", "empty": f"no config.json in '{ckpt}'",
                "config-only": ("no model.safetensors" if _lerobot_importable() else
                                "needs lerobot (Python >= 3.12), which is not importable here")}[case]
    out, video = tmp_path / "report.json", tmp_path / "videos"
    rc, stdout, err = _evaluate(["--policy", f"lerobot:{ckpt}", "--episodes", "1", "--out", str(out),
                                 "--video", str(video)], capsys)
    assert rc == 2 and stdout == ""
    assert err.count("\n") == 1 and err.startswith(f"samplehd evaluate: error: --policy 'lerobot:{ckpt}': ")
    assert expected in err
    assert not out.exists() and not video.exists()


@pytest.fixture(scope="module")
def tiny_lerobot_checkpoint(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A LeRobot ACT policy, untrained and tiny, saved by LeRobot's own save_pretrained with its processors."""
    pytest.importorskip("lerobot")
    torch = pytest.importorskip("torch")
    from lerobot.configs.types import FeatureType, PolicyFeature
    from lerobot.policies.act.configuration_act import ACTConfig
    from lerobot.policies.act.modeling_act import ACTPolicy
    from lerobot.policies.factory import make_pre_post_processors

    torch.manual_seed(0)
    image = "observation.images.scene"
    config = ACTConfig(input_features={image: PolicyFeature(FeatureType.VISUAL, (3, SIZE, SIZE)),
                                       "observation.state": PolicyFeature(FeatureType.STATE, (7,))},
                       output_features={"action": PolicyFeature(FeatureType.ACTION, (7,))},
                       device="cpu", chunk_size=4, n_action_steps=2, dim_model=16, n_heads=2, dim_feedforward=32,
                       n_encoder_layers=1, n_decoder_layers=1, use_vae=False, pretrained_backbone_weights=None)
    path = tmp_path_factory.mktemp("lerobot") / "pretrained_model"
    ACTPolicy(config).save_pretrained(path)
    stats = {"observation.state": {"mean": torch.zeros(7), "std": torch.ones(7)},
             "action": {"mean": torch.zeros(7), "std": torch.full((7,), 0.1)},
             image: {"mean": torch.full((3, 1, 1), 0.5), "std": torch.full((3, 1, 1), 0.25)}}
    for pipeline in make_pre_post_processors(config, dataset_stats=stats):
        pipeline.save_pretrained(path)
    return path


def test_evaluate_runs_a_lerobot_checkpoint(tiny_lerobot_checkpoint: Path, fast_options: dict, tmp_path: Path,
                                            capsys: pytest.CaptureFixture[str]) -> None:
    """Where lerobot is importable: LeRobot loads the checkpoint, the env comes from its config.json (32×32
    scene images; the scene pool from --env-options), and our evaluation runs and reports it."""
    options = tmp_path / "env.json"
    options.write_text(json.dumps(fast_options))
    out = tmp_path / "report.json"
    spec = f"lerobot:{tiny_lerobot_checkpoint.parent}"  # the folder above pretrained_model works too
    rc, stdout, err = _evaluate(["--policy", spec, "--families", "pick_up", "--episodes", "1",
                                 "--max-episode-steps", "5", "--env-options", str(options), "--out", str(out)],
                                capsys)
    assert rc == 0, err
    assert f"environment from {tiny_lerobot_checkpoint / 'config.json'}" in stdout
    report = json.loads(out.read_text())
    assert report["policy"] == spec and report["episodes"] == 1 and report["split"]["families"] == ["pick_up"]
    assert report["env"]["cameras"] == ["scene"] and (report["env"]["width"], report["env"]["height"]) == (SIZE, SIZE)
    record, = report["records"]
    assert record["steps"] == 5 and record["truncated"] and record["success"] is False
    assert record["seed"] == benchmark_split(1, ["pick_up"], 0)[0][0]


def test_evaluate_lerobot_env_from_the_training_export(tiny_lerobot_checkpoint: Path, fast_options: dict,
                                                       tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """The env and families come from the export the checkpoint was trained on (train_config.json's
    dataset.root, its meta/samplehd.json); an unknown policy type and a mismatching image size are refused."""
    import shutil

    from lerobot.configs.default import DatasetConfig
    from lerobot.configs.policies import PreTrainedConfig
    from lerobot.configs.train import TrainPipelineConfig

    export = tmp_path / "export"
    (export / "meta").mkdir(parents=True)
    env = {**fast_options, "obs_mode": "rgb", "cameras": ["scene"], "width": SIZE, "height": SIZE,
           "control_mode": "steering", "families": ["pick_up"]}
    (export / EXPORT_RECORD).write_text(json.dumps({"env": env, "families": ["pick_up"]}))
    ckpt = tmp_path / "pretrained_model"
    shutil.copytree(tiny_lerobot_checkpoint, ckpt)
    policy = PreTrainedConfig.from_pretrained(ckpt)
    TrainPipelineConfig(dataset=DatasetConfig(repo_id="samplehd/tiny", root=str(export)),
                        policy=policy)._save_pretrained(ckpt)
    rc, stdout, err = _evaluate(["--policy", f"lerobot:{ckpt}", "--episodes", "1", "--max-episode-steps", "3"],
                                capsys)
    assert rc == 0, err
    assert f"environment from {export / EXPORT_RECORD}" in stdout and re.search(r"pick_up\s+0/1", stdout)

    rc, _, err = _evaluate(["--policy", f"lerobot:{ckpt}", "--episodes", "1", "--width", "64"], capsys)
    assert rc == 2 and err.count("\n") == 1
    assert f"the policy reads observation.images.scene (3, {SIZE}, {SIZE})" in err

    config = json.loads((ckpt / "config.json").read_text())
    (ckpt / "config.json").write_text(json.dumps({**config, "type": "no_such_policy"}))
    rc, _, err = _evaluate(["--policy", f"lerobot:{ckpt}", "--episodes", "1"], capsys)
    assert rc == 2 and err.count("\n") == 1
    assert "unknown LeRobot policy type 'no_such_policy'; this lerobot knows act, " in err


def test_lerobot_policy_acts_as_under_lerobot_eval(tiny_lerobot_checkpoint: Path, options: dict,
                                                   tmp_path: Path) -> None:
    """The same checkpoint on the same split episode: LeRobot's own rollout (lerobot-eval's, in the plugin's
    env) and `samplehd evaluate`'s policy in Tabletop-v0 send the same actions, step by step."""
    plugin = pytest.importorskip("lerobot_env_samplehd")
    from lerobot.configs.policies import PreTrainedConfig
    from lerobot.envs.factory import make_env, make_env_pre_post_processors
    from lerobot.policies.factory import make_policy, make_pre_post_processors
    from lerobot.scripts.lerobot_eval import rollout

    from samplehd.benchmark.evaluation import split_episode
    from samplehd.benchmark.lerobot_policy import LeRobotPolicy

    steps, path = 6, str(tiny_lerobot_checkpoint)
    (tmp_path / "meta").mkdir()
    (tmp_path / EXPORT_RECORD).write_text(json.dumps({"env": {**options, "families": ["pick_up"]}}))
    env_cfg = plugin.SamplehdEnv(dataset=str(tmp_path), episode_length=steps)
    vec = make_env(env_cfg, n_envs=1)["pick_up"][0]
    policy_cfg = PreTrainedConfig.from_pretrained(path)
    policy_cfg.pretrained_path = tiny_lerobot_checkpoint
    policy = make_policy(policy_cfg, env_cfg=env_cfg)
    policy.eval()
    pre, post = make_pre_post_processors(policy_cfg, pretrained_path=path, preprocessor_overrides={
        "device_processor": {"device": "cpu"}, "rename_observations_processor": {"rename_map": {}}})
    env_pre, env_post = make_env_pre_post_processors(env_cfg, policy_cfg)
    theirs = rollout(vec, policy, env_pre, env_post, pre, post, seeds=[0])["action"][0].numpy()
    vec.close()

    env = TabletopEnv(**{**options, "families": ["pick_up"]})
    ours = LeRobotPolicy.load(f"lerobot:{path}", env)
    obs, _, used = reset_at_level(env, *split_episode(0, ["pick_up"], 0), None)
    ours.reset(seed=used)
    actions = []
    for _ in range(steps):
        actions.append(ours(obs))
        obs, *_ = env.step(actions[-1])
    env.close()
    assert theirs.shape == (steps, 7) and len(np.unique(theirs.round(6), axis=0)) > 1
    np.testing.assert_allclose(np.stack(actions), theirs, rtol=1e-5, atol=1e-6)
