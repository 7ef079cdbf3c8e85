"""The names, shapes and settings that tie ``samplehd export lerobot``, LeRobot and Tabletop-v0 together.

One place for the feature-name and layout conversion: the LeRobot env
(:mod:`samplehd.benchmark.lerobot_tabletop`, behind the ``lerobot_env_samplehd`` plugin) and the
``samplehd evaluate --policy lerobot:CKPT`` policy (:mod:`samplehd.benchmark.lerobot_policy`) both turn a
Tabletop-v0 observation into LeRobot's raw env observation with :func:`lerobot_observation`, and
LeRobot's ``preprocess_observation`` renames it into the export's features:

==================  ============================  ===============================================
env key             LeRobot feature               value
==================  ============================  ===============================================
``pixels/<cam>``    ``observation.images.<cam>``  RGB (H, W, 3) uint8 (LeRobot makes it CHW float)
``agent_pos``       ``observation.state``         6 joint angles [rad] + gripper opening [m]
``tcp_pose``        ``observation.tcp_pose``      TCP position [m] + quaternion (w, x, y, z)
``action``          ``action``                    SAMPLE-HD's 7-D steering vector
==================  ============================  ===============================================

Nothing here imports lerobot.
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from samplehd.envs.config import EnvConfig
from samplehd.errors import ConfigError
from samplehd.render.image_spec import ImageSpec

__all__ = ["EXPORT_RECORD", "LeRobotFeature", "env_options_from_export", "lerobot_features", "lerobot_observation"]

EXPORT_RECORD = "meta/samplehd.json"  # written by samplehd.export.lerobot (its SAMPLEHD_RECORD)
VECTOR_SIZE = 7  # observation.state, observation.tcp_pose and action


@dataclass(frozen=True)
class LeRobotFeature:
    """One feature as LeRobot sees it.

    Attributes:
        name: LeRobot's feature name (``observation.images.scene``).
        kind: LeRobot's ``FeatureType`` name: ``VISUAL``, ``STATE`` or ``ACTION``.
        shape: the shape the environment returns (images (H, W, 3)).
    """

    name: str
    kind: str
    shape: tuple[int, ...]

    @property
    def policy_shape(self) -> tuple[int, ...]:
        """The shape in a policy's ``config.json`` (images channel first, as LeRobot loads them)."""
        return (self.shape[2], *self.shape[:2]) if self.kind == "VISUAL" else self.shape


def lerobot_features(image: ImageSpec) -> dict[str, LeRobotFeature]:
    """The env keys (``pixels/<cam>`` of ``image``'s cameras, ``agent_pos``, ``tcp_pose``, ``action``) and
    their LeRobot features (images: RGB at ``image``'s size)."""
    out = {f"pixels/{cam}": LeRobotFeature(f"observation.images.{cam}", "VISUAL", image.shape("rgb"))
           for cam in image.cameras}
    out["agent_pos"] = LeRobotFeature("observation.state", "STATE", (VECTOR_SIZE,))
    out["tcp_pose"] = LeRobotFeature("observation.tcp_pose", "STATE", (VECTOR_SIZE,))
    out["action"] = LeRobotFeature("action", "ACTION", (VECTOR_SIZE,))
    return out


def lerobot_observation(obs: dict[str, Any], cameras: Sequence[str]) -> dict[str, Any]:
    """A Tabletop-v0 observation as LeRobot's raw env observation (see the module docstring)."""
    g = np.asarray(obs["gripper"], np.float32)
    return {
        "pixels": {cam: obs[f"{cam}_rgb"] for cam in cameras},
        "agent_pos": np.concatenate([obs["joint_pos"], g[:2].sum(keepdims=True)]).astype(np.float32),
        "tcp_pose": np.concatenate([obs["tcp_pos"], obs["tcp_quat"]]).astype(np.float32),
    }


def read_export_record(root: str | Path) -> dict[str, Any]:
    """``meta/samplehd.json`` of a ``samplehd export lerobot`` folder.

    Raises:
        ConfigError: the file is missing or not JSON (not a samplehd export).
    """
    path = Path(root) / EXPORT_RECORD
    try:
        record = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError) as exc:
        raise ConfigError(f"dataset={str(root)!r}: cannot read {EXPORT_RECORD} ({type(exc).__name__}); expected "
                          "a folder written by `samplehd export lerobot`", field="dataset") from None
    if not isinstance(record, dict):
        raise ConfigError(f"dataset={str(root)!r}: {EXPORT_RECORD} is not a JSON object; export again",
                          field="dataset")
    return record


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
