"""The cameras' intrinsics and extrinsics of a dataset, as exports carry them.

Per camera: the pinhole intrinsics K [px] at the stored image size, and the extrinsics as a 4×4
camera-to-world transform in MuJoCo's camera axes (the camera looks along -z, y up; OpenCV's axes are
x right, y down, z forward: flip the y and z columns). A camera fixed in the world (``scene``,
randomised per scene, and ``operator``) has one transform per episode, taken from the episode's first
recorded state; the ``wrist`` camera moves with the gripper, so its extrinsics are its mount: the
camera's pose in the frame of the gripper body (``robot_gripper``), the world pose at a frame being
that body's pose times the mount.
"""

from __future__ import annotations

from typing import Any

import mujoco
import numpy as np

from samplehd.fixedmath import inv_rigid, matmul
from samplehd.render.renderer import camera_intrinsics, camera_pose
from samplehd.robot.constants import WRIST_CAMERA
from samplehd.scene.spec import SceneSpec, compile_scene

__all__ = ["CAMERA_AXES", "GRIPPER_BODY", "CameraGeometry"]

CAMERA_AXES = "MuJoCo camera axes: looks along -z, y up (OpenCV: flip the y and z columns)"
GRIPPER_BODY = "robot_gripper"  # the body the wrist camera is mounted on


class CameraGeometry:
    """Intrinsics and extrinsics of ``cameras`` stored at ``sizes`` (camera → (width, height) [px]).

    Scenes are compiled once each (the arm drawn with primitives: the same kinematics).
    """

    def __init__(self, cameras: list[str], sizes: dict[str, tuple[int, int]]) -> None:
        self.cameras = list(cameras)
        self.sizes = sizes
        self._compiled: dict[int, tuple[mujoco.MjModel, mujoco.MjData]] = {}
        self.intrinsics: dict[str, list[list[float]]] = {}
        self.mounts: dict[str, list[list[float]]] = {}

    def episode_extrinsics(self, scene: dict[str, Any], qpos: np.ndarray) -> dict[str, list[float]]:
        """Camera-to-world transforms (16 floats, row-major) of the world-fixed cameras in an episode
        whose scene annotation is ``scene`` (``scenes.json`` entry) and first state ``qpos``; notes the
        intrinsics and the wrist mount on the way."""
        index = int(scene["image_index"])
        if index not in self._compiled:
            self._compiled = {index: compile_scene(SceneSpec.from_dict(scene["spec"]), robot_look="primitive")}
        model, data = self._compiled[index]
        data.qpos[:] = qpos
        mujoco.mj_kinematics(model, data)
        mujoco.mj_camlight(model, data)  # camera poses are not part of mj_kinematics
        out: dict[str, list[float]] = {}
        for cam in self.cameras:
            w, h = self.sizes[cam]
            self.intrinsics.setdefault(cam, camera_intrinsics(model, cam, w, h).tolist())
            pose = camera_pose(model, data, cam)
            if cam == WRIST_CAMERA:
                body = model.body(GRIPPER_BODY).id
                frame = np.eye(4)
                frame[:3, :3] = data.xmat[body].reshape(3, 3)
                frame[:3, 3] = data.xpos[body]
                self.mounts.setdefault(cam, np.round(matmul(inv_rigid(frame), pose), 9).tolist())
            else:
                out[cam] = [float(v) for v in pose.reshape(-1)]
        return out

    def record(self) -> dict[str, Any]:
        """Per camera: size, intrinsics and where its extrinsics are (for ``meta/samplehd.json``)."""
        cams: dict[str, Any] = {}
        for cam in self.cameras:
            w, h = self.sizes[cam]
            entry: dict[str, Any] = {"width": w, "height": h, "intrinsics": self.intrinsics.get(cam),
                                     "axes": CAMERA_AXES}
            if cam in self.mounts:
                entry["extrinsics"] = {"moves_with": GRIPPER_BODY, "mount": self.mounts[cam]}
            else:
                entry["extrinsics"] = {"per_episode": f"samplehd/extrinsics.{cam}",
                                       "layout": "camera-to-world 4x4, row-major, 16 floats [m]"}
            cams[cam] = entry
        return cams
