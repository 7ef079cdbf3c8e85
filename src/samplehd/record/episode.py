"""Per-frame records of one executed instruction: everything needed to train on it, to check it,
and to re-render it later from any camera at any resolution without re-simulating.

One frame is recorded per control step. Arrays have the frame count ``T`` as first axis; ``N`` is the
number of scene objects.

=====================  ==============  =========================================================
field                  shape / dtype   meaning
=====================  ==============  =========================================================
time                   (T,) f8         simulation time [s]
subtask_index          (T,) i2         index into ``subtasks`` of the subtask being executed
subtask_progress       (T,) f4         progress of that subtask in [0, 1]
target_object          (T,) i2         scene object the subtask acts on (-1 none)
joint_pos              (T, 6) f8       arm joint positions [rad]
joint_vel              (T, 6) f8       arm joint velocities [rad/s]
gripper_opening        (T,) f4         distance between the fingers [m]
gripper_command        (T,) f4         +1 open, -1 close
command_joint_pos      (T, 6) f8       commanded joint targets at that step [rad]
tcp_pos                (T, 3) f8       tool centre point in the world [m]
tcp_quat               (T, 4) f8       TCP orientation (w, x, y, z)
steering               (T, 7) f4       SAMPLE-HD steering vector in [-1, 1] reproducing the motion
object_pos             (T, N, 3) f8    object positions [m]
object_quat            (T, N, 4) f8    object orientations (w, x, y, z)
grasped_object         (T,) i2         object held by the gripper (-1 none)
safety_event           (T,) i1         0 none, else a ``samplehd.robot.safety`` event code
qpos                   (T, nq) f8      full physics state for exact replay
qvel                   (T, nv) f8
act                    (T, na) f8
=====================  ==============  =========================================================
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from samplehd.errors import DatasetError

__all__ = ["FRAME_FIELDS", "SUBTASK_NAMES", "Episode"]

# SAMPLE-HD's recorded subtask names, per moved object, in order.
SUBTASK_NAMES = (
    "GripperMoveAvoid",
    "ApproachGrasp",
    "CloseGripper",
    "MoveUP",
    "ObjectMove",
    "MoveDOWN",
    "OpenGripper",
    "MoveToDefaultPos",
)

# field → (trailing shape using symbols N/nq/nv/na, dtype)
FRAME_FIELDS: dict[str, tuple[tuple[str | int, ...], str]] = {
    "time": ((), "f8"),
    "subtask_index": ((), "i2"),
    "subtask_progress": ((), "f4"),
    "target_object": ((), "i2"),
    "joint_pos": ((6,), "f8"),
    "joint_vel": ((6,), "f8"),
    "gripper_opening": ((), "f4"),
    "gripper_command": ((), "f4"),
    "command_joint_pos": ((6,), "f8"),
    "tcp_pos": ((3,), "f8"),
    "tcp_quat": ((4,), "f8"),
    "steering": ((7,), "f4"),
    "object_pos": (("N", 3), "f8"),
    "object_quat": (("N", 4), "f8"),
    "grasped_object": ((), "i2"),
    "safety_event": ((), "i1"),
    "qpos": (("nq",), "f8"),
    "qvel": (("nv",), "f8"),
    "act": (("na",), "f8"),
}


@dataclass(frozen=True)
class Episode:
    """One executed instruction.

    Attributes:
        scene_index: index of the scene in the dataset's scenes.json.
        instruction_index: index of the instruction in instructions.json.
        family: task family (place, stack, put, remove, pick_up, place_relative, stack_three).
        seed: seed the episode's randomness was drawn from.
        subtasks: subtask names, indexed by ``frames["subtask_index"]``.
        frames: the per-frame arrays of :data:`FRAME_FIELDS`.
        success: the success checker's verdict on the final state.
        info: checker report, grasp choices, retries, control/physics rates, ... (JSON-serialisable).
        images: optional rendered images: ``images[camera][modality]`` with first axis T.
    """

    scene_index: int
    instruction_index: int
    family: str
    seed: int
    subtasks: tuple[str, ...]
    frames: dict[str, np.ndarray]
    success: bool
    info: dict[str, Any] = field(default_factory=dict)
    images: dict[str, dict[str, np.ndarray]] = field(default_factory=dict)

    def __post_init__(self) -> None:
        self.validate()

    @property
    def num_frames(self) -> int:
        return int(len(self.frames["time"]))

    def validate(self) -> None:
        """Check every frame field is present with a consistent shape; raises DatasetError."""
        missing = [k for k in FRAME_FIELDS if k not in self.frames]
        if missing:
            raise DatasetError(f"episode {self.instruction_index}: missing frame fields {missing}")
        t = len(self.frames["time"])
        dims = {
            "N": self.frames["object_pos"].shape[1] if self.frames["object_pos"].ndim == 3 else -1,
            "nq": self.frames["qpos"].shape[-1],
            "nv": self.frames["qvel"].shape[-1],
            "na": self.frames["act"].shape[-1],
        }
        for key, (shape, _) in FRAME_FIELDS.items():
            want = (t, *(dims[s] if isinstance(s, str) else s for s in shape))
            got = tuple(self.frames[key].shape)
            if got != want:
                raise DatasetError(f"episode {self.instruction_index}: frame field {key!r} has shape {got}, "
                                   f"expected {want}")
        idx = self.frames["subtask_index"]
        if t and (idx.min() < 0 or idx.max() >= len(self.subtasks)):
            raise DatasetError(f"episode {self.instruction_index}: subtask_index outside 0..{len(self.subtasks) - 1}")
        for cam, mods in self.images.items():
            for mod, arr in mods.items():
                if len(arr) != t:
                    raise DatasetError(f"episode {self.instruction_index}: images[{cam}][{mod}] has {len(arr)} "
                                       f"frames, expected {t}")
