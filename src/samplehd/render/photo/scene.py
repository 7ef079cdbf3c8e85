"""A Mitsuba scene of a compiled MuJoCo model, posed frame by frame from ``MjData``.

The scene is built once per model (parts, materials, lights); a frame moves the parts of bodies that
are not welded to the world (the arm, the gripper, the objects) to their poses in ``MjData`` and the
sensor to the camera's pose, then re-renders. The sensor uses the model camera's vertical field of
view with the principal point at the image centre, as the GL presets do, so pixels line up.
"""

from __future__ import annotations

from typing import Any

import mujoco
import numpy as np

from samplehd.render.photo.geometry import Part, model_parts, model_texture
from samplehd.render.photo.look import LookParams, bsdf_for, lights
from samplehd.render.photo.runtime import load_drjit, load_mitsuba, photo_backend
from samplehd.render.scene_lighting import model_lighting

__all__ = ["PhotoScene"]

MAX_DEPTH = 6  # camera → glass → glass → surface → light: enough for refraction through a glass
RR_DEPTH = 3  # Russian roulette from the third bounce: dim diffuse paths end early, glass paths go on


class PhotoScene:
    """Mitsuba scene of ``model``; call :meth:`pose` before each render.

    Attributes:
        parts: the model's parts, in the order of their shapes.
        shape_seg: segmentation id of each scene shape, in ``scene.shapes()`` order.
    """

    def __init__(self, model: mujoco.MjModel, data: mujoco.MjData, width: int, height: int, look: LookParams,
                 segmentation: np.ndarray | None = None, background: int = 0) -> None:
        """``segmentation``: each geom's segmentation id (as the GL renderer has them; default: all
        ``background``), to name what the geometry pass hits."""
        mi = load_mitsuba()
        self.mi = mi
        self.model = model
        self.look = look
        self.parts: list[Part] = model_parts(model)
        scene: dict[str, Any] = {"type": "scene"}
        self._dynamic: list[tuple[str, Part]] = []
        body_seg = np.full(model.nbody, background, dtype=np.int64)
        lut = np.full(model.ngeom, background) if segmentation is None else np.asarray(segmentation)
        body_seg[model.geom_bodyid] = lut
        self.background = background
        self._shape_seg: dict[str, int] = {}
        for i, part in enumerate(self.parts):
            key = f"part_{i:04d}"
            scene[key] = self._mesh(key, part, data)
            self._shape_seg[key] = int(body_seg[part.body])
            if not part.static:
                self._dynamic.append((key, part))
        for key, shape in lights(look, model_lighting(model)).items():
            # Made here, one by one: shapes made inside load_dict come out in a varying order, and the
            # order of the lights decides which one a random number picks (the same seed would give
            # another picture).
            scene[key] = mi.load_dict(shape)
            self._shape_seg[key] = background
        scene["integrator"] = {
            "type": "aov",
            "aovs": "albedo:albedo,nn:sh_normal",
            "image": {"type": "path", "max_depth": MAX_DEPTH, "rr_depth": RR_DEPTH, "hide_emitters": False},
        }
        scene["sensor"] = self._sensor_dict(width, height, 45.0)
        # A second sensor with one unjittered sample per pixel centre, where the GL rasteriser samples too:
        # its depth and shape ids check that the path-traced image lines up with GL depth and segmentation.
        scene["sensor_geometry"] = self._sensor_dict(width, height, 45.0, centre=True)
        self.scene = mi.load_dict(scene, parallel=False)  # sequential: the same scene, object for object
        self._sensors = ("sensor", "sensor_geometry")
        self._geometry_sensor = [s.id() for s in self.scene.sensors()].index("sensor_geometry")
        self._geometry_integrator = mi.load_dict({"type": "aov", "aovs": "pp:position,si:shape_index"})
        self.params = mi.traverse(self.scene)
        # On the GPU, recorded on the second frame (the first also uploads the scene) and replayed after:
        # tracing the integrator into a kernel costs ~50 ms a frame there, ten times the kernel itself, and
        # a replay gives the same image as a fresh trace. (The CPU variant cannot record this scene's
        # virtual calls, and gains little.)
        self._trace = self._replay = lambda scene, seed, spp: mi.render(scene, spp=spp, seed=seed)
        dr = load_drjit()
        if photo_backend() == "cuda_ad_rgb":
            self._replay = dr.freeze(self._trace)
        self._traced = False
        self._posed: dict[str, np.ndarray] = {}
        # The shape_index AOV holds each shape's id in Dr.Jit's instance registry (not its list position).
        shapes = self.scene.shapes()
        ids = np.asarray(dr.reinterpret_array(mi.UInt32, mi.ShapePtr(shapes)), dtype=np.int64)
        self.shape_seg = np.full(int(ids.max()) + 1, background, dtype=np.int64)
        self.shape_seg[ids] = [self._shape_seg[s.id()] for s in shapes]
        self._fovy: float | None = None
        self.size = (width, height)

    def _sensor_dict(self, width: int, height: int, fovy: float, centre: bool = False) -> dict[str, Any]:
        sampler = ({"type": "stratified", "sample_count": 1, "jitter": False} if centre
                   else {"type": "independent", "sample_count": 1})
        return {
            "type": "perspective",
            "fov": float(fovy),
            "fov_axis": "y",
            "near_clip": 0.01,
            "far_clip": 60.0,
            "sampler": sampler,
            "film": {"type": "hdrfilm", "width": int(width), "height": int(height), "rfilter": {"type": "box"},
                     "pixel_format": "rgb", "component_format": "float32"},
        }

    def _mesh(self, key: str, part: Part, data: mujoco.MjData) -> Any:
        mi = self.mi
        props = mi.Properties()
        image = model_texture(self.model, part.texture) if part.texture >= 0 else None
        props["bsdf"] = mi.load_dict(bsdf_for(part, self.look, image))
        mesh = mi.Mesh(key, len(part.vertices), len(part.faces), props=props,
                       has_vertex_normals=True, has_vertex_texcoords=True)
        p = mi.traverse(mesh)
        v, n = self._world(part, data)
        p["vertex_positions"] = mi.Float(v.ravel())
        p["vertex_normals"] = mi.Float(n.ravel())
        p["vertex_texcoords"] = mi.Float(part.texcoords.astype(np.float32).ravel())
        p["faces"] = mi.UInt32(part.faces.astype(np.uint32).ravel())
        p.update()
        return mesh

    @staticmethod
    def _world(part: Part, data: mujoco.MjData) -> tuple[np.ndarray, np.ndarray]:
        rot = data.xmat[part.body].reshape(3, 3)
        v = part.vertices @ rot.T + data.xpos[part.body]
        n = part.normals @ rot.T
        return v.astype(np.float32), n.astype(np.float32)

    def pose(self, data: mujoco.MjData, camera_id: int, width: int, height: int) -> None:
        """Move the moving parts and the sensor to ``data``'s state and camera ``camera_id``."""
        mi = self.mi
        for key, part in self._dynamic:
            where = np.concatenate([data.xpos[part.body], data.xmat[part.body]])
            if key in self._posed and np.array_equal(self._posed[key], where):
                continue  # not moved since the last frame
            self._posed[key] = where
            v, n = self._world(part, data)
            self.params[f"{key}.vertex_positions"] = mi.Float(v.ravel())
            self.params[f"{key}.vertex_normals"] = mi.Float(n.ravel())
        xmat = data.cam_xmat[camera_id].reshape(3, 3)
        pos = data.cam_xpos[camera_id]
        # MuJoCo cameras look along their -z with +y up.
        to_world = mi.ScalarTransform4f().look_at(origin=pos.tolist(), target=(pos - xmat[:, 2]).tolist(),
                                                  up=xmat[:, 1].tolist())
        if (width, height) != self.size:
            raise ValueError(f"this scene renders {self.size[0]}x{self.size[1]} px, not {width}x{height}")
        fovy = float(self.model.cam_fovy[camera_id])
        # Mitsuba keeps the field of view as x_fov: convert from the camera's vertical one.
        x_fov = float(np.rad2deg(2 * np.arctan(np.tan(np.deg2rad(fovy) / 2) * width / height)))
        for sensor in self._sensors:
            self.params[f"{sensor}.to_world"] = to_world
            if fovy != self._fovy:
                self.params[f"{sensor}.x_fov"] = x_fov
        self._fovy = fovy
        self._camera = (pos.copy(), xmat.copy())
        self.params.update()

    def geometry(self) -> tuple[np.ndarray, np.ndarray]:
        """(depth [m] along the optical axis, segmentation id) at pixel centres, as the path tracer sees the
        posed scene; depth is inf and id 0 where no surface is hit."""
        mi = self.mi
        img = np.asarray(mi.render(self.scene, sensor=self._geometry_sensor, integrator=self._geometry_integrator,
                                   spp=1, seed=0), dtype=np.float64)
        pos, xmat = self._camera
        z = -((img[..., 0:3] - pos) @ xmat[:, 2])  # along the optical axis (the camera's -z)
        hit = np.linalg.norm(img[..., 0:3], axis=-1) > 0
        index = np.rint(img[..., 3]).astype(np.int64)
        seg = np.where(hit, self.shape_seg[np.clip(index, 0, len(self.shape_seg) - 1)], self.background)
        return np.where(hit, z, np.inf).astype(np.float32), seg.astype(np.int32)

    def render(self, spp: int, seed: int) -> np.ndarray:
        """(H, W, 9) float32: linear RGB, albedo, shading normal."""
        return np.asarray(self.render_tensor(spp, seed), dtype=np.float32)

    def render_tensor(self, spp: int, seed: int) -> Any:
        """The same as :meth:`render`, as Mitsuba's tensor on its device (the GPU for ``cuda_ad_rgb``)."""
        trace = self._replay if self._traced else self._trace
        self._traced = True
        return trace(self.scene, self.mi.UInt32(int(seed)), int(spp))
