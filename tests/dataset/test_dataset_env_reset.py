"""The environment starts from a stored dataset episode: reset(options={"dataset", "episode_index"})."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import samplehd  # noqa: F401  (GL backend before mujoco)
from samplehd.dataset.reader import DatasetReader
from samplehd.envs.tabletop import TabletopEnv
from samplehd.errors import ConfigError, DatasetError


def test_reset_from_a_dataset_episode_reproduces_its_start(micro_dataset: Path) -> None:
    reader = DatasetReader(micro_dataset)
    index = 0
    stored = reader.episode(index, images="none")
    entry = reader.instruction(index)
    env = TabletopEnv(obs_mode="state")
    _, info = env.reset(options={"dataset": str(micro_dataset), "episode_index": index})
    assert info["task"] == entry["task"]
    assert env.episode.text == entry["instruction"]
    np.testing.assert_array_equal(env.data.qpos, stored.frames["qpos"][0])
    np.testing.assert_array_equal(env.data.qvel, stored.frames["qvel"][0])
    env.close()


@pytest.mark.parametrize(
    ("options", "error", "message"),
    [
        ({"episode_index": 0}, ConfigError, "go together"),
        ({"dataset": "DATASET", "episode_index": "first"}, ConfigError, "must be an integer"),
        ({"dataset": "DATASET", "episode_index": 10_000}, DatasetError, "no episode 10000"),
        ({"dataset": "DATASET", "episode_index": 0, "scene": {}}, ConfigError, "either"),
    ],
)
def test_bad_dataset_reset_options_are_one_line_errors(micro_dataset: Path, options: dict, error: type,
                                                       message: str) -> None:
    options = {k: (str(micro_dataset) if v == "DATASET" else v) for k, v in options.items()}
    env = TabletopEnv(obs_mode="state")
    with pytest.raises(error, match=message) as exc:
        env.reset(options=options)
    assert "\n" not in str(exc.value)
    env.close()
