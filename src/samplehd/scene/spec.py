"""The scene specification that flows from the scene sampler to every later stage.

A :class:`SceneSpec` says which objects stand where (their settled poses) and where the scene camera
is; :func:`compile_scene` turns it into a MuJoCo model + data, identically every time.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import mujoco
import numpy as np

from samplehd.catalogue import ObjectInstance
from samplehd.errors import SceneError
from samplehd.fixedmath import norm
from samplehd.scene.world import (
    DEFAULT_LIGHTING,
    DEFAULT_SURFACES,
    OPERATOR_CAMERA,
    CameraSpec,
    Lighting,
    PlacedObject,
    Surfaces,
    WorldConfig,
    compile_world,
)
from samplehd.world.bodies import object_body_name

__all__ = ["SceneObject", "SceneSpec", "compile_scene", "object_qpos_addresses"]


# Largest |coordinate| of an object in a scene spec [m].
_MAX_COORD = 2.0


@dataclass(frozen=True)
class SceneObject:
    """One object of a scene.

    Attributes:
        instance: the catalogue ``ObjectInstance`` (class, variant, colour, material, size).
        pos: position of the object frame in the world after settling [m].
        quat: orientation (w, x, y, z) after settling.
    """

    instance: Any
    pos: tuple[float, float, float]
    quat: tuple[float, float, float, float]

    def to_dict(self) -> dict[str, object]:
        return {"instance": self.instance.to_dict(), "pos": list(self.pos), "quat": list(self.quat)}

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> SceneObject:
        try:
            obj = cls(
                instance=ObjectInstance.from_dict(d["instance"]),
                pos=tuple(float(v) for v in d["pos"]),  # type: ignore[arg-type]
                quat=tuple(float(v) for v in d["quat"]),  # type: ignore[arg-type]
            )
        except (KeyError, TypeError, ValueError) as exc:
            raise SceneError(f"malformed scene object {d!r}: {exc}") from exc
        pos, quat = np.asarray(obj.pos), np.asarray(obj.quat)
        # Objects stand on the table (about 1.2 m × 0.8 m around the origin); 2 m is far outside it.
        if pos.shape != (3,) or not np.all(np.isfinite(pos)) or np.any(np.abs(pos) > _MAX_COORD):
            raise SceneError(f"scene object pos={list(obj.pos)!r}: must be 3 finite coordinates within "
                             f"±{_MAX_COORD} m of the table centre")
        if quat.shape != (4,) or not np.all(np.isfinite(quat)) or not 0.5 < norm(quat) < 1.5:
            raise SceneError(f"scene object quat={list(obj.quat)!r}: must be a unit quaternion (w, x, y, z)")
        return obj


@dataclass(frozen=True)
class SceneSpec:
    """A sampled scene.

    Attributes:
        index: scene index in its dataset.
        seed: seed the scene was sampled from.
        objects: the objects with their settled poses.
        camera: the scene camera (named ``scene``) drawn around the operator viewpoint.
        lighting: the scene lights (the kitchen's own by default; a benchmark axis changes them). A
            scene dict holds ``lighting`` only when it is not the default, so sampled scenes read as before.
        surfaces: the table's and walls' textures (the kitchen's own by default; a benchmark axis changes
            them); in a scene dict only when not the default, as ``lighting``.
    """

    index: int
    seed: int
    objects: tuple[SceneObject, ...]
    camera: CameraSpec = OPERATOR_CAMERA
    lighting: Lighting = DEFAULT_LIGHTING
    surfaces: Surfaces = DEFAULT_SURFACES

    def to_dict(self) -> dict[str, object]:
        out = {
            "index": self.index,
            "seed": self.seed,
            "objects": [o.to_dict() for o in self.objects],
            "camera": self.camera.to_dict(),
        }
        if self.lighting != DEFAULT_LIGHTING:
            out["lighting"] = self.lighting.to_dict()
        if self.surfaces != DEFAULT_SURFACES:
            out["surfaces"] = self.surfaces.to_dict()
        return out

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> SceneSpec:
        try:
            return cls(
                index=int(d["index"]),
                seed=int(d["seed"]),
                objects=tuple(SceneObject.from_dict(o) for o in d["objects"]),
                camera=CameraSpec.from_dict(d["camera"]),
                lighting=Lighting.from_dict(d["lighting"]) if "lighting" in d else DEFAULT_LIGHTING,
                surfaces=Surfaces.from_dict(d["surfaces"]) if "surfaces" in d else DEFAULT_SURFACES,
            )
        except (KeyError, TypeError, ValueError) as exc:
            raise SceneError(f"malformed scene spec: missing or bad field {exc}") from exc

    def world_config(self, timestep: float = 0.002, robot_look: str = "mesh") -> WorldConfig:
        """World options with the operator camera and this scene's camera (named ``scene``); ``robot_look``
        is how the arm is drawn (the physics is the same for every look)."""
        cams = (OPERATOR_CAMERA,)
        if self.camera.name != OPERATOR_CAMERA.name:
            cams = (OPERATOR_CAMERA, self.camera)
        return WorldConfig(timestep=timestep, cameras=cams, robot_look=robot_look, lighting=self.lighting,
                           surfaces=self.surfaces)


def compile_scene(scene: SceneSpec, timestep: float = 0.002,
                  robot_look: str = "mesh") -> tuple[mujoco.MjModel, mujoco.MjData]:
    """Compile the world with the scene's objects at their settled poses (robot at home), the arm drawn
    with ``robot_look``."""
    placed = [PlacedObject(o.instance, tuple(o.pos), tuple(o.quat)) for o in scene.objects]
    return compile_world(placed, scene.world_config(timestep, robot_look))


def object_qpos_addresses(model: mujoco.MjModel, count: int) -> np.ndarray:
    """qpos addresses of the free joints of objects 0..count-1 (7 entries each from there)."""
    adr = []
    for i in range(count):
        bid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, object_body_name(i))
        if bid < 0:
            raise SceneError(f"model has no body {object_body_name(i)!r}")
        adr.append(int(model.jnt_qposadr[model.body_jntadr[bid]]))
    return np.asarray(adr, dtype=np.int64)
