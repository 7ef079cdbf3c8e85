"""The Tabletop-v0 side of the LeRobot contract (:mod:`samplehd.dataset.lerobot_contract`).

The keys and features are tabled in that module.

The LeRobot env (:mod:`samplehd.benchmark.lerobot_tabletop`, behind the ``lerobot_env_samplehd`` plugin) and
the ``samplehd evaluate --policy lerobot:CKPT`` policy (:mod:`samplehd.benchmark.lerobot_policy`) both turn a
Tabletop-v0 observation into LeRobot's raw env observation with :func:`lerobot_observation`, and build
their environment from an export's record with :func:`env_options_from_export`. The feature names,
shapes and the record's path are declared in :mod:`samplehd.dataset.lerobot_contract`.

Nothing here imports lerobot.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any, TypedDict

import numpy as np

from samplehd.dataset.lerobot_contract import EXPORT_RECORD, read_export_record
from samplehd.envs.config import EnvConfig
from samplehd.errors import ConfigError

if TYPE_CHECKING:
    from samplehd.envs.observation import Observation

__all__ = ["LeRobotObservation", "env_options_from_export", "lerobot_observation"]


class LeRobotObservation(TypedDict):
    """LeRobot's raw env observation (see the module docstring): RGB images by camera, the joint angles
    with the finger opening [rad, m], and the TCP position and quaternion [m]."""

    pixels: dict[str, np.ndarray]
    agent_pos: np.ndarray
    tcp_pose: np.ndarray


def lerobot_observation(obs: Observation, cameras: Sequence[str]) -> LeRobotObservation:
    """A Tabletop-v0 observation as LeRobot's raw env observation (see the module docstring)."""
    g = np.asarray(obs["gripper"], np.float32)
    return {
        "pixels": {cam: obs[f"{cam}_rgb"] for cam in cameras},
        "agent_pos": np.concatenate([obs["joint_pos"], g[:2].sum(keepdims=True)]).astype(np.float32),
        "tcp_pose": np.concatenate([obs["tcp_pos"], obs["tcp_quat"]]).astype(np.float32),
    }


def env_options_from_export(root: str | Path) -> dict[str, Any]:
    """The ``samplehd/Tabletop-v0`` options recorded by ``samplehd export lerobot`` in ``root``.

    Raises:
        ConfigError: no record (not a samplehd export, or one made before the record existed), or the
            export has no environment that matches it (the record's note says why).
    """
    record = read_export_record(root)
    if "env" not in record:
        why = record.get("env_note", "it was exported before samplehd recorded environment settings; export again")
        raise ConfigError(f"dataset={str(root)!r}: {EXPORT_RECORD} has no environment settings: {why}",
                          field="dataset")
    EnvConfig.from_kwargs(**record["env"])  # one-line errors now, not in a worker process
    return dict(record["env"])
