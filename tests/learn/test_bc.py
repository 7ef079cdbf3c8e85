"""The behaviour-cloning policy: deterministic and resumable training, its state input, and the
inference options (temporal ensembling, the TCP floor) acting on a real network."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

torch = pytest.importorskip("torch")

from samplehd.errors import ConfigError  # noqa: E402
from samplehd.learn.bc import STATE_DIM, STATE_DIM_V1, BCPolicy, _rotation_columns, train_policy  # noqa: E402


def _weights(folder: Path) -> dict:
    return torch.load(folder / "model.pt", map_location="cpu", weights_only=True)


def _same(a: dict, b: dict) -> bool:
    return a.keys() == b.keys() and all(torch.equal(a[k], b[k]) for k in a)


def test_policy_training_is_deterministic_resumes_and_normalises_its_state(nano_dataset: Path,
                                                                          tmp_path: Path) -> None:
    a, b, c = tmp_path / "a", tmp_path / "b", tmp_path / "c"
    ma = train_policy(nano_dataset, a, steps=4, quiet=True)
    train_policy(nano_dataset, b, steps=4, quiet=True)
    assert _same(_weights(a), _weights(b)), "same seed on the CPU must give identical weights"
    assert train_policy(nano_dataset, c, steps=4, quiet=True, stop_after=2) == {"stopped_at": 2}
    assert not (c / "model.pt").exists()
    train_policy(nano_dataset, c, steps=4, quiet=True)
    assert _same(_weights(a), _weights(c)), "a resumed run must give the uninterrupted run's model"
    w = _weights(a)
    assert w["state_mean"].shape == (STATE_DIM,) and bool((w["state_std"] >= 1e-2).all())
    assert float(w["state_mean"][8]) > 0.5  # the TCP height [m] above the floor, as recorded
    config = json.loads((a / "config.json").read_text())
    assert config["format"] == 2 and 0.7 < config["inference"]["z_floor"] < 1.2
    assert len(ma["test_l1_by_axis"]) == 7 and ma["test_l1"] is not None
    # Weighting the frames near the table changes the model (and is recorded).
    d = tmp_path / "d"
    train_policy(nano_dataset, d, steps=4, quiet=True, near_weight=3.0)
    assert json.loads((d / "config.json").read_text())["train"]["near_weight"] == 3.0
    assert not _same(_weights(a), _weights(d))
    # The L1 loss of the first version is still there (its median is a zero velocity on most frames).
    e = tmp_path / "e"
    train_policy(nano_dataset, e, steps=2, quiet=True, loss="l1")
    assert json.loads((e / "config.json").read_text())["train"]["loss"] == "l1"
    with pytest.raises(ConfigError, match="loss='huber'"):
        train_policy(nano_dataset, tmp_path / "f", steps=2, quiet=True, loss="huber")
    assert not (tmp_path / "f").exists()


def test_rotation_columns_are_those_of_the_matrix_and_ignore_the_quaternion_sign() -> None:
    from scipy.spatial.transform import Rotation

    rng = np.random.default_rng(0)
    q = rng.normal(size=(5, 4))
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    mats = Rotation.from_quat(q[:, [1, 2, 3, 0]]).as_matrix()  # scipy: x y z w
    want = np.concatenate([mats[:, :, 0], mats[:, :, 1]], axis=1)
    assert np.allclose(_rotation_columns(q), want, atol=1e-12)
    assert np.allclose(_rotation_columns(-q), want, atol=1e-12)


def _config(**inference: object) -> dict:
    return {"kind": "policy", "format": 2, "image": 16, "chunk": 4, "execute": 2, "tokens": 8,
            "model": {"width": 8, "hidden": 16, "state_dim": STATE_DIM}, "inference": inference,
            "train": {"seed": 0}}


def _obs(z: float = 1.0) -> dict:
    rng = np.random.default_rng(1)
    return {"scene_rgb": rng.integers(0, 255, (16, 16, 3), dtype=np.uint8),
            "wrist_rgb": rng.integers(0, 255, (16, 16, 3), dtype=np.uint8),
            "instruction": "Pick up the mug.", "gripper": np.array([0.02, 0.02, 0.0]),
            "joint_pos": np.zeros(6), "tcp_pos": np.array([0.3, 0.0, z]), "tcp_quat": np.array([0.0, 1.0, 0.0, 0.0])}


def test_temporal_ensembling_averages_the_chunks_that_cover_a_step() -> None:
    plain = BCPolicy(_config(), None)
    chunk = plain.predict(_obs())  # an untrained network: some chunk; the same for the same observation
    policy = BCPolicy(_config(ensemble=0.0), None)  # equal weights
    policy.reset()
    for t in range(6):
        # the chunk predicted k steps ago holds this step's action at index k: all are `chunk`
        want = np.clip(chunk[: min(t + 1, 4)].mean(0), -1, 1)
        assert np.allclose(policy(_obs()), want, atol=1e-6)
    # Without it: `execute` actions of one chunk, then a new one.
    plain.reset()
    assert np.allclose(np.stack([plain(_obs()) for _ in range(4)]), np.clip(chunk[[0, 1, 0, 1]], -1, 1), atol=1e-6)


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


def test_a_format_1_model_still_loads_and_acts() -> None:
    config = {"kind": "policy", "format": 1, "image": 16, "chunk": 4, "execute": 2, "tokens": 8,
              "model": {"width": 8, "hidden": 16}, "train": {"seed": 0}}
    policy = BCPolicy(config, None)
    assert policy.v1 and policy.net.state[0].in_features == STATE_DIM_V1 and policy.ensemble is None
    assert policy(_obs()).shape == (7,)
