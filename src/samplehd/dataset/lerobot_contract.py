"""The LeRobot contract: the names, shapes and record that tie ``samplehd export lerobot``, LeRobot and
``samplehd/Tabletop-v0`` together, declared once.

The exporter (:mod:`samplehd.export.lerobot`) writes these features and ``meta/samplehd.json``; the
LeRobot env (:mod:`samplehd.benchmark.lerobot_tabletop`, behind the ``lerobot_env_samplehd`` plugin) and the
``samplehd evaluate --policy lerobot:CKPT`` policy read them. The env returns LeRobot's raw observation
keys, which LeRobot's ``preprocess_observation`` renames into the export's features:

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
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from samplehd.errors import ConfigError
from samplehd.render.image_spec import ImageSpec

__all__ = [
    "ACTION",
    "COMMAND_JOINT",
    "DEPTH_CODE_MAX",
    "DEPTH_VIDEO_PARAMS",
    "EXPORT_RECORD",
    "IMAGE_PREFIX",
    "STATE",
    "TCP_POSE",
    "VECTOR_FEATURES",
    "VECTOR_SIZE",
    "LeRobotFeature",
    "depth_video_key",
    "image_feature_key",
    "lerobot_features",
    "read_export_record",
]

EXPORT_RECORD = "meta/samplehd.json"  # what the environment needs to match an export
IMAGE_PREFIX = "observation.images."  # + camera: an RGB camera's video feature
STATE = "observation.state"
TCP_POSE = "observation.tcp_pose"
ACTION = "action"
COMMAND_JOINT = "command.joint"
VECTOR_SIZE = 7  # observation.state, observation.tcp_pose, action and command.joint

# The per-frame vector features, in the export's column order, with the names of their elements
# (``info.json`` ``names`` and ``meta/samplehd.json`` ``state_layout``).
VECTOR_FEATURES: dict[str, list[str]] = {
    STATE: [f"joint_{i}" for i in range(6)] + ["gripper_opening"],
    TCP_POSE: ["x", "y", "z", "qw", "qx", "qy", "qz"],
    ACTION: ["vx", "vy", "vz", "wx", "wy", "wz", "gripper"],
    COMMAND_JOINT: [f"joint_{i}" for i in range(6)] + ["gripper"],
}


# LeRobot's native depth videos (lerobot >= 0.6: ``lerobot.configs.video.DepthEncoderConfig``, decoded by
# ``lerobot.datasets.depth_utils.dequantize_depth``): depth quantized to 12-bit codes on a log scale,
# ``code = rint(4095 (ln(d + shift) - ln(min + shift)) / (ln(max + shift) - ln(min + shift)))`` with d in
# metres, clipped to [0, 4095], in a lossless HEVC gray12le video; the feature's ``info`` carries
# ``is_depth_map`` and these parameters under ``video.<name>``.
DEPTH_VIDEO_PARAMS: dict[str, float | bool] = {"depth_min": 0.01, "depth_max": 10.0, "shift": 3.5, "use_log": True}
DEPTH_CODE_MAX = 4095


def depth_video_key(camera: str) -> str:
    """A camera's native LeRobot depth video feature, named as LeRobot's depth cameras name theirs."""
    return f"{IMAGE_PREFIX}{camera}_depth"


def image_feature_key(camera: str, modality: str) -> str:
    """The export's feature of one camera's modality: ``observation.images.<cam>`` for RGB (what LeRobot's
    policies take), ``depth.<cam>`` / ``segmentation.<cam>`` otherwise (keys LeRobot's policies ignore)."""
    return f"{IMAGE_PREFIX}{camera}" if modality == "rgb" else f"{modality}.{camera}"


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
    out = {f"pixels/{cam}": LeRobotFeature(image_feature_key(cam, "rgb"), "VISUAL", image.shape("rgb"))
           for cam in image.cameras}
    out["agent_pos"] = LeRobotFeature(STATE, "STATE", (VECTOR_SIZE,))
    out["tcp_pose"] = LeRobotFeature(TCP_POSE, "STATE", (VECTOR_SIZE,))
    out["action"] = LeRobotFeature(ACTION, "ACTION", (VECTOR_SIZE,))
    return out


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
