"""RGB, metric depth and instance segmentation from any named camera, at any resolution.

Segmentation ids (one ``int32`` per pixel):

=========  ==========================================
id         meaning
=========  ==========================================
0          background (floor, walls, counter, sky)
1          table
2          robot (arm and gripper)
3 + i      scene object ``i`` (body ``object_{i}``)
=========  ==========================================

Depth is the metric distance along the camera's optical axis (z-depth) [m], float32.

Passes: RGB and depth come from one render pass when that is exact (no MSAA with reflections); the
segmentation pass (flat id colours, no lighting) is cheap and also yields depth when requested.
"""

from __future__ import annotations

import math
import os
import threading
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from types import TracebackType
from typing import Any

import mujoco
import numpy as np

from samplehd.errors import RenderError
from samplehd.fixedmath import matmul
from samplehd.render.photo.renderer import PhotoOptions, PhotoTracer
from samplehd.render.photo.runtime import load_mitsuba

__all__ = [
    "MODALITIES",
    "PRESETS",
    "SEG_BACKGROUND",
    "SEG_OBJECT_OFFSET",
    "SEG_ROBOT",
    "SEG_TABLE",
    "RenderPreset",
    "SceneRenderer",
    "camera_intrinsics",
    "camera_names",
    "camera_pose",
    "check_size",
    "get_preset",
    "gl_device",
    "image_shape",
    "project_points",
    "segmentation_lut",
    "stored_segmentation_dtype",
]

SEG_BACKGROUND = 0
SEG_TABLE = 1
SEG_ROBOT = 2
SEG_OBJECT_OFFSET = 3

MODALITIES = ("rgb", "depth", "segmentation")
# What ``SceneRenderer.render`` returns for each modality (segmentation may also be written narrower:
# :func:`stored_segmentation_dtype`).
IMAGE_DTYPES = {"rgb": np.dtype(np.uint8), "depth": np.dtype(np.float32), "segmentation": np.dtype(np.int32)}


def image_shape(modality: str, width: int, height: int) -> tuple[int, ...]:
    """The shape of one image of ``modality``: (H, W, 3) for rgb, (H, W) for depth and segmentation."""
    return (height, width, 3) if modality == "rgb" else (height, width)

_FLAG = mujoco.mjtRndFlag


@dataclass(frozen=True)
class RenderPreset:
    """Rendering quality.

    Attributes:
        name: preset name.
        shadows: render shadow maps (a fixed cost per frame on a CPU rasteriser).
        msaa_samples: multisample anti-aliasing samples (0 = off).
        reflections: render reflective materials with a mirror pass.
        shadow_size: shadow map resolution [px] (allocated even when shadows are off, so keep it small).
        path_traced: RGB comes from the path tracer of ``samplehd.render.photo``; depth and segmentation
            still come from GL, so they are identical to the other presets'.
    """

    name: str
    shadows: bool
    msaa_samples: int
    reflections: bool
    shadow_size: int
    path_traced: bool = False


# The render presets: the one list of their names (``choices`` of every command that takes one).
PRESETS: dict[str, RenderPreset] = {
    "fast": RenderPreset("fast", shadows=False, msaa_samples=0, reflections=False, shadow_size=64),
    "hd": RenderPreset("hd", shadows=True, msaa_samples=4, reflections=True, shadow_size=2048),
    "photo": RenderPreset("photo", shadows=False, msaa_samples=0, reflections=False, shadow_size=64, path_traced=True),
}


def get_preset(name: str | RenderPreset) -> RenderPreset:
    """Look up a preset by name; raises RenderError listing the valid names."""
    if isinstance(name, RenderPreset):
        return name
    try:
        return PRESETS[name]
    except KeyError:
        raise RenderError(f"unknown render preset {name!r}; valid: {', '.join(PRESETS)}") from None


def camera_names(model: mujoco.MjModel) -> list[str]:
    """Names of the model's cameras, in id order."""
    return [mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_CAMERA, i) or f"#{i}" for i in range(model.ncam)]


def _camera_id(model: mujoco.MjModel, camera: str | int) -> int:
    if isinstance(camera, (int, np.integer)):
        if 0 <= int(camera) < model.ncam:
            return int(camera)
    else:
        cid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_CAMERA, camera)
        if cid >= 0:
            return cid
    raise RenderError(f"unknown camera {camera!r}; valid: {', '.join(camera_names(model)) or '(none)'}")


def stored_segmentation_dtype(model: mujoco.MjModel) -> np.dtype:
    """The dtype episode files store ``model``'s segmentation in: uint8, or uint16 when an id exceeds 255."""
    return np.dtype(np.uint8 if int(segmentation_lut(model).max(initial=0)) < 256 else np.uint16)


def segmentation_lut(model: mujoco.MjModel) -> np.ndarray:
    """Per-geom segmentation id (see module docstring), from body names and ancestry."""
    body_class = np.full(model.nbody, SEG_BACKGROUND, dtype=np.int32)
    for b in range(1, model.nbody):
        name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, b) or ""
        parent = int(model.body_parentid[b])
        if name == "robot_base":
            body_class[b] = SEG_ROBOT
        elif name == "table":
            body_class[b] = SEG_TABLE
        elif name.startswith("object_") and name[7:].isdigit():
            body_class[b] = SEG_OBJECT_OFFSET + int(name[7:])
        elif parent > 0:
            body_class[b] = body_class[parent]  # bodies are numbered parents first
    return body_class[model.geom_bodyid]


def camera_intrinsics(model: mujoco.MjModel, camera: str | int, width: int, height: int) -> np.ndarray:
    """3×3 pinhole intrinsics K [px] of a camera rendered at width × height (square pixels)."""
    cid = _camera_id(model, camera)
    fovy = np.deg2rad(model.cam_fovy[cid])
    f = 0.5 * height / math.tan(float(fovy) / 2.0)
    return np.array([[f, 0.0, width / 2.0], [0.0, f, height / 2.0], [0.0, 0.0, 1.0]])


def camera_pose(model: mujoco.MjModel, data: mujoco.MjData, camera: str | int) -> np.ndarray:
    """4×4 camera-to-world transform in MuJoCo's camera convention (looks along -z, y up)."""
    cid = _camera_id(model, camera)
    pose = np.eye(4)
    pose[:3, :3] = data.cam_xmat[cid].reshape(3, 3)
    pose[:3, 3] = data.cam_xpos[cid]
    return pose


def project_points(
    model: mujoco.MjModel,
    data: mujoco.MjData,
    camera: str | int,
    width: int,
    height: int,
    points: np.ndarray,
) -> np.ndarray:
    """Project world points (N, 3) [m] to (N, 3) rows of [u, v, depth] (pixels from top-left, metres)."""
    pose = camera_pose(model, data, camera)
    k = camera_intrinsics(model, camera, width, height)
    pts = np.atleast_2d(np.asarray(points, dtype=float))
    cam = matmul(pts - pose[:3, 3], pose[:3, :3])  # world → camera frame
    depth = -cam[:, 2]
    u = k[0, 2] + k[0, 0] * cam[:, 0] / depth
    v = k[1, 2] - k[1, 1] * cam[:, 1] / depth
    return np.stack([u, v, depth], axis=1)


_THREAD = threading.local()


def _shared_gl_context() -> Any:
    """One GL context per thread, made once and reused by every renderer of that thread.

    Making a context compiles the rasteriser's shaders (about a second on llvmpipe); the render
    size is set by MuJoCo's offscreen framebuffer, not by the context, so one context serves all.
    """
    ctx = getattr(_THREAD, "gl", None)
    if ctx is None:
        ctx = _context_class()(64, 64)
        _THREAD.gl = ctx
    return ctx


def gl_device() -> str:
    """What renders: the GL vendor and renderer strings of this thread's context, e.g. ``Mesa, llvmpipe
    (LLVM 15.0.6, 256 bits)`` (the CPU rasteriser) or ``NVIDIA Corporation, NVIDIA H100 PCIe/PCIe/SSE2``.

    Raises:
        RenderError: no GL context can be made.
    """
    from OpenGL import GL  # PyOpenGL, the platform matching MUJOCO_GL (set by configure_gl_backend)

    try:
        _shared_gl_context().make_current()
        vendor, renderer = (GL.glGetString(k) for k in (GL.GL_VENDOR, GL.GL_RENDERER))
    except Exception as exc:  # GL failures surface as many exception types
        raise RenderError(f"cannot create an offscreen GL context with MUJOCO_GL={_gl_backend()}: {exc}") from exc
    return ", ".join((v or b"?").decode(errors="replace") for v in (vendor, renderer))


def _context_class() -> Any:
    """The GL context class of the chosen backend.

    ``mujoco.GLContext`` is fixed when MuJoCo is first imported; a program that imported mujoco
    before samplehd (so before ``MUJOCO_GL`` was set) would get the windowed default, so the
    headless backends are imported by name.
    """
    backend = os.environ.get("MUJOCO_GL", "")
    if backend == "egl":
        from mujoco.egl import GLContext

        return GLContext
    if backend == "osmesa":
        from mujoco.osmesa import GLContext

        return GLContext
    return mujoco.GLContext


class SceneRenderer:
    """Offscreen renderer of one compiled model at one resolution and quality preset.

    Example:
        >>> with SceneRenderer(model, 640, 360, "fast") as r:  # doctest: +SKIP
        ...     images = r.render(data, "operator", ("rgb", "depth", "segmentation"))
    """

    def __init__(
        self,
        model: mujoco.MjModel,
        width: int,
        height: int,
        preset: str | RenderPreset = "fast",
        buffer_size: tuple[int, int] | None = None,
        photo: PhotoOptions | None = None,
        context: mujoco.MjrContext | None = None,
    ) -> None:
        """Make the GL resources of ``model`` for renders of ``width``×``height`` px; ``buffer_size``
        allocates a larger offscreen buffer, so that :meth:`resize` can render larger images later.
        ``photo`` (a ``samplehd.render.photo.PhotoOptions``) sets the path tracer of the ``photo`` preset.
        ``context``: MuJoCo's GL resources already made for this model (a GL preset only); they are
        borrowed, not freed by :meth:`close` (:class:`samplehd.render.renderer_cache.MeshSharingRenderers`)."""
        check_size(width, height)
        self.model = model
        self.preset = get_preset(preset)
        self._lut = segmentation_lut(model)
        # Segmentation may be written as int32, or as the narrowest of uint8/uint16 that holds every id.
        top = int(self._lut.max(initial=0))
        self._segment_dtypes = (IMAGE_DTYPES["segmentation"], *(np.dtype(t) for t in (np.uint8, np.uint16)
                                                                 if top <= np.iinfo(t).max))
        self._tracer: PhotoTracer | None = None
        self._photo_arg = photo
        if self.preset.path_traced:
            load_mitsuba()  # fails here, in one line, when Mitsuba or LLVM is missing
            self._tracer = PhotoTracer(model, photo, self._lut, SEG_BACKGROUND)
        self._gl: Any = None
        self._ctx = None
        self._owns_ctx = context is None
        bw, bh = buffer_size or (width, height)
        self.buffer_size = (max(width, int(bw)), max(height, int(bh)))
        check_size(*self.buffer_size)
        # The offscreen buffer, MSAA and shadow map are allocated when the context is made: size them
        # for this renderer (a 1080p buffer or a 4k shadow map costs seconds to allocate on llvmpipe).
        model.vis.global_.offwidth, model.vis.global_.offheight = self.buffer_size
        model.vis.quality.offsamples = self.preset.msaa_samples
        model.vis.quality.shadowsize = self.preset.shadow_size
        try:
            self._gl = _shared_gl_context()
            self._gl.make_current()
            self._ctx = context or mujoco.MjrContext(model, mujoco.mjtFontScale.mjFONTSCALE_100.value)
        except Exception as exc:  # GL failures surface as many exception types
            self.close()
            raise RenderError(
                f"cannot create an offscreen GL context with MUJOCO_GL={_gl_backend()}: {exc}; "
                "install libegl1 libegl-mesa0 libgl1-mesa-dri (or libosmesa6 with MUJOCO_GL=osmesa)"
            ) from exc
        mujoco.mjr_setBuffer(mujoco.mjtFramebuffer.mjFB_OFFSCREEN.value, self._ctx)
        self._ctx.readDepthMap = mujoco.mjtDepthMap.mjDEPTH_ZEROFAR
        self._scene = mujoco.MjvScene(model, maxgeom=_scene_capacity(model))
        self._option = mujoco.MjvOption()
        self._camera = mujoco.MjvCamera()
        self._camera.type = mujoco.mjtCamera.mjCAMERA_FIXED
        self.resize(width, height)
        extent = float(model.stat.extent)
        self._znear = np.float32(model.vis.map.znear * extent)
        self._zfar = np.float32(model.vis.map.zfar * extent)

    @property
    def photo_options(self) -> PhotoOptions | None:
        """The path tracer's options (``PhotoOptions``), or None for a GL preset."""
        return None if self._tracer is None else self._tracer.options

    def photo_geometry(self) -> tuple[np.ndarray, np.ndarray]:
        """Photo preset: (depth [m], segmentation ids) of what the path tracer hits at each pixel centre of
        the last rendered RGB frame (same pose and camera), to check it lines up with GL's depth and ids."""
        if self._tracer is None or self._tracer.scene is None:
            raise RenderError("photo_geometry needs the photo preset and a rendered RGB frame")
        return self._tracer.scene.geometry()

    def resize(self, width: int, height: int) -> None:
        """Render ``width``×``height`` px images from now on, within the offscreen buffer."""
        check_size(width, height)
        if width > self.buffer_size[0] or height > self.buffer_size[1]:
            raise RenderError(f"resolution {width}x{height} exceeds this renderer's buffer "
                              f"{self.buffer_size[0]}x{self.buffer_size[1]}; make a renderer with a larger buffer_size")
        self.width = width
        self.height = height
        self._rect = mujoco.MjrRect(0, 0, width, height)
        # Read-back buffers and the scratch arrays of depth and ids, made once per size.
        self._rgb = np.empty((height, width, 3), dtype=np.uint8)
        self._depth = np.empty((height, width), dtype=np.float32)
        self._depth64 = np.empty((height, width), dtype=np.float64)
        self._segid = np.empty((height, width), dtype=np.int32)
        self._segid_b = np.empty((height, width), dtype=np.int32)

    def __enter__(self) -> SceneRenderer:
        return self

    def __exit__(
        self, exc_type: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> None:
        self.close()

    def close(self) -> None:
        """Free the GL resources (safe to call twice)."""
        if self._ctx is not None:
            if self._owns_ctx:
                if self._gl is not None:
                    self._gl.make_current()
                self._ctx.free()
            self._ctx = None
        self._tracer = None
        self._gl = None  # the shared context lives on for the next renderer

    def __del__(self) -> None:
        try:
            self.close()
        except Exception:  # interpreter shutdown: GL may already be gone
            pass

    def _update(self, data: mujoco.MjData, camera_id: int, segment: bool) -> None:
        self._camera.fixedcamid = camera_id
        mujoco.mjv_updateScene(
            self.model, data, self._option, None, self._camera, mujoco.mjtCatBit.mjCAT_ALL.value, self._scene
        )
        while self._scene.ngeom >= self._scene.maxgeom:  # full: geoms may have been left out; make room, again
            self._scene = mujoco.MjvScene(self.model, maxgeom=2 * self._scene.maxgeom)
            mujoco.mjv_updateScene(
                self.model, data, self._option, None, self._camera, mujoco.mjtCatBit.mjCAT_ALL.value, self._scene
            )
        flags = self._scene.flags
        flags[_FLAG.mjRND_SEGMENT] = segment
        flags[_FLAG.mjRND_IDCOLOR] = segment
        flags[_FLAG.mjRND_SHADOW] = self.preset.shadows and not segment
        flags[_FLAG.mjRND_REFLECTION] = self.preset.reflections and not segment
        flags[_FLAG.mjRND_SKYBOX] = False

    def _metric_depth(self, raw: np.ndarray, dest: np.ndarray) -> None:
        """Reverse-Z perspective depth buffer → distance along the optical axis (as MuJoCo's Renderer), in
        float64 then rounded to float32, written into ``dest`` with rows from the top."""
        c = -(self._zfar + self._znear) / (self._zfar - self._znear)
        d = -(np.float32(2) * self._zfar * self._znear) / (self._zfar - self._znear)
        c = np.float32(-0.5) * c - np.float32(0.5)
        d = np.float32(-0.5) * d
        buf = self._depth64
        np.add(raw, c, out=buf, dtype=np.float64)
        np.divide(d, buf, out=buf, dtype=np.float64)
        np.copyto(dest, buf[::-1], casting="same_kind")

    def render(
        self,
        data: mujoco.MjData,
        camera: str | int,
        modalities: Iterable[str] = ("rgb",),
        out: Mapping[str, np.ndarray] | None = None,
    ) -> dict[str, np.ndarray]:
        """Render the requested modalities from a camera.

        Args:
            data: simulation state (``mj_forward`` or ``mj_step`` must have run).
            camera: camera name or id.
            modalities: any of ``rgb`` (H×W×3 uint8), ``depth`` (H×W float32 [m]) and
                ``segmentation`` (H×W int32 ids, see module docstring).
            out: arrays to write the images into, one per requested modality with that modality's shape
                and dtype (e.g. the frame's slot of an episode's preallocated stream); segmentation may also
                be uint8 or uint16 where this model's ids fit (as episode files store it); default: new arrays.

        Returns:
            A dict from modality to its array (``out``'s, or new ones), rows from the top of the image.
        """
        wanted = tuple(dict.fromkeys(modalities))
        bad = [m for m in wanted if m not in MODALITIES]
        if bad or not wanted:
            raise RenderError(f"unknown modalities {bad or '(none)'}; valid: {', '.join(MODALITIES)}")
        if self._ctx is None:
            raise RenderError("renderer is closed")
        cid = _camera_id(self.model, camera)
        dest = self._destinations(wanted, out)
        self._gl.make_current()
        # Bind this renderer's own offscreen buffer: freeing another renderer's context leaves none bound,
        # and the render would then read back a stale image.
        mujoco.mjr_setBuffer(mujoco.mjtFramebuffer.mjFB_OFFSCREEN.value, self._ctx)
        depth_from_rgb = "depth" in wanted and "segmentation" not in wanted and not (
            self.preset.reflections and self.preset.msaa_samples
        )
        depth_done = False
        if "rgb" in wanted and self._tracer is not None:
            dest["rgb"][...] = self._tracer.rgb(data, cid, self.width, self.height)
        elif "rgb" in wanted:
            self._update(data, cid, segment=False)
            mujoco.mjr_render(self._rect, self._scene, self._ctx)
            mujoco.mjr_readPixels(self._rgb, self._depth if depth_from_rgb else None, self._rect, self._ctx)
            np.copyto(dest["rgb"], self._rgb[::-1])
            if depth_from_rgb:
                self._metric_depth(self._depth, dest["depth"])
                depth_done = True
        if "segmentation" in wanted or ("depth" in wanted and not depth_done):
            self._update(data, cid, segment=True)
            mujoco.mjr_render(self._rect, self._scene, self._ctx)
            # the ids are the colours: depth is read back only when asked for (a read costs ~2 ms on llvmpipe)
            mujoco.mjr_readPixels(self._rgb, self._depth if "depth" in wanted else None, self._rect, self._ctx)
            if "depth" in wanted:
                self._metric_depth(self._depth, dest["depth"])
            if "segmentation" in wanted:
                self._segment_ids(self._rgb, dest["segmentation"])
        return dest

    def _destinations(self, wanted: tuple[str, ...], out: Mapping[str, np.ndarray] | None) -> dict[str, np.ndarray]:
        """The arrays to render ``wanted`` into: ``out``'s (checked) or new ones."""
        if out is None:
            return {m: np.empty(image_shape(m, self.width, self.height), dtype=IMAGE_DTYPES[m]) for m in wanted}
        dest = {}
        for m in wanted:
            arr = out.get(m)
            shape = image_shape(m, self.width, self.height)
            dtypes = self._segment_dtypes if m == "segmentation" else (IMAGE_DTYPES[m],)
            if not isinstance(arr, np.ndarray) or arr.shape != shape or arr.dtype not in dtypes:
                got = "nothing" if arr is None else f"{getattr(arr, 'shape', '?')} {getattr(arr, 'dtype', '?')}"
                raise RenderError(f"out[{m!r}]: needs a {shape} {' or '.join(str(d) for d in dtypes)} array, "
                                  f"got {got}")
            dest[m] = arr
        return dest

    def _segment_ids(self, idcolor: np.ndarray, dest: np.ndarray) -> None:
        """Per-pixel ids from the segmentation pass's colours (rows from the bottom) into ``dest`` (from the top)."""
        segid = self._segid  # r + (g << 8) + (b << 16) is the scene geom's index + 1; 0 = nothing drawn
        np.left_shift(idcolor[..., 1], 8, out=segid, dtype=np.int32)
        np.bitwise_or(segid, idcolor[..., 0], out=segid)
        if idcolor[..., 2].any():
            np.left_shift(idcolor[..., 2], 16, out=self._segid_b, dtype=np.int32)
            np.bitwise_or(segid, self._segid_b, out=segid)
        n = self._scene.ngeom
        table = np.full(n + 1, SEG_BACKGROUND, dtype=dest.dtype)
        geoms = self._scene.geoms
        geom_type = int(mujoco.mjtObj.mjOBJ_GEOM)
        for i in range(n):
            g = geoms[i]
            if g.objtype == geom_type and g.segid >= 0:
                table[g.segid + 1] = self._lut[g.objid]
        np.minimum(segid, n, out=segid)
        np.take(table, segid[::-1], out=dest, mode="clip")  # ids are in 0..n here


def _scene_capacity(model: mujoco.MjModel) -> int:
    """Room for the abstract geoms of one frame: every geom and site, tendon segments and sensor rays, with a
    margin. A full scene is made larger and updated again (``SceneRenderer._update``), so this only has to be a
    good first guess: allocating the scene costs time in proportion (about 14 ms for 10,000 geoms, once per
    renderer)."""
    return 2 * int(model.ngeom + model.nsite + model.nwrap + model.ntendon + model.nsensor + model.nbody) + 64


def check_size(width: int, height: int) -> None:
    """Raise RenderError unless ``width`` and ``height`` are integers in 8..8192 px."""
    if not (isinstance(width, int) and isinstance(height, int)) or not (8 <= width <= 8192 and 8 <= height <= 8192):
        raise RenderError(f"resolution {width}x{height} is invalid; width and height must be 8..8192 px")


def _gl_backend() -> str:
    return os.environ.get("MUJOCO_GL", "")

