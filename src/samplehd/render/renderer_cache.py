"""One renderer kept across the image requests of one model (:class:`RendererCache`), and one GL context
kept across the segmentation renders of many models of one world (:class:`MeshSharingRenderers`)."""

from __future__ import annotations

import hashlib
from types import TracebackType

import mujoco
import numpy as np

from samplehd.errors import RenderError
from samplehd.render.image_spec import ImageSpec
from samplehd.render.photo.renderer import PhotoOptions
from samplehd.render.renderer import SceneRenderer, _shared_gl_context, get_preset

__all__ = ["MeshSharingRenderers", "RendererCache"]


class RendererCache:
    """Keeps the last renderer made, so that several image requests of one model at different sizes share
    its GL resources (making them costs about 65 ms per model on llvmpipe).

    Example:
        >>> with RendererCache(buffer_size=(640, 360)) as cache:  # doctest: +SKIP
        ...     seg = cache.get(model, ImageSpec(320, 180, modalities=("segmentation",)))
        ...     rgb = cache.get(model, ImageSpec(640, 360))  # the same renderer, resized
    """

    def __init__(self, buffer_size: tuple[int, int] | None = None) -> None:
        self.buffer_size = buffer_size
        self._renderer: SceneRenderer | None = None

    def get(self, model: mujoco.MjModel, image: ImageSpec, photo: PhotoOptions | None = None) -> SceneRenderer:
        """A renderer of ``model`` at ``image``'s size and render preset: the kept one where it fits, else a
        new one (``photo``: the path tracer's options of the ``photo`` preset)."""
        r = self._renderer
        want = get_preset(image.preset)
        if (r is not None and r.model is model and r.preset == want and r._photo_arg == photo
                and image.width <= r.buffer_size[0] and image.height <= r.buffer_size[1]):
            r.resize(image.width, image.height)
            return r
        self.close()
        self._renderer = SceneRenderer(model, image.width, image.height, want, self.buffer_size, photo)
        return self._renderer

    def close(self) -> None:
        """Free the kept renderer."""
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None

    def __enter__(self) -> RendererCache:
        return self

    def __exit__(
        self, exc_type: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> None:
        self.close()


def mesh_signatures(model: mujoco.MjModel) -> list[bytes]:
    """Per mesh, a digest of everything ``mjr_uploadMesh`` draws it from (vertices, normals, faces,
    texture coordinates and the convex hull)."""
    out = []
    for i in range(model.nmesh):
        h = hashlib.blake2b(digest_size=16)
        v, nv = int(model.mesh_vertadr[i]), int(model.mesh_vertnum[i])
        f, nf = int(model.mesh_faceadr[i]), int(model.mesh_facenum[i])
        n, nn = int(model.mesh_normaladr[i]), int(model.mesh_normalnum[i])
        t, nt = int(model.mesh_texcoordadr[i]), int(model.mesh_texcoordnum[i])
        h.update(np.array([nv, nf, nn, nt if t >= 0 else -1], dtype=np.int64).tobytes())
        for part in (model.mesh_vert[v : v + nv], model.mesh_normal[n : n + nn], model.mesh_face[f : f + nf],
                     model.mesh_facenormal[f : f + nf]):
            h.update(np.ascontiguousarray(part).tobytes())
        if t >= 0:
            h.update(np.ascontiguousarray(model.mesh_texcoord[t : t + nt]).tobytes())
            h.update(np.ascontiguousarray(model.mesh_facetexcoord[f : f + nf]).tobytes())
        g = int(model.mesh_graphadr[i])
        if g >= 0:
            gv, gf = int(model.mesh_graph[g]), int(model.mesh_graph[g + 1])
            h.update(np.ascontiguousarray(model.mesh_graph[g : g + 2 + 3 * gv + 6 * gf]).tobytes())
        out.append(h.digest())
    return out


def _world_key(model: mujoco.MjModel, image: ImageSpec) -> tuple:
    """What, besides meshes, a context made for ``model`` holds that a segmentation render draws: the
    built-in shapes' and planes' subdivisions, the offscreen buffer, and the number of planes (an
    infinite plane's extent follows the model's size; it lies under the table, where it only draws
    background)."""
    q = model.vis.quality
    planes = model.geom_size[model.geom_type == mujoco.mjtGeom.mjGEOM_PLANE]
    return (image.width, image.height, image.preset, int(q.numslices), int(q.numstacks), int(q.numquads),
            len(planes), tuple(float(x) for x in planes.ravel()))


class MeshSharingRenderers:
    """Segmentation renders of a run of models of one world (the same arm, table and room, other objects)
    on one MuJoCo GL context: for each model only the meshes that differ from those the context holds are
    uploaded (``mjr_uploadMesh``), which on llvmpipe costs a few milliseconds where a new context costs
    about 45 (the arm's meshes). The images are those of a renderer of the model's own: segmentation
    draws no texture or light, and a mesh is drawn from the model's own data.

    A renderer from :meth:`get` is valid until the next :meth:`get`. A model with heightfields, skins or
    flexes, or with more meshes than the context has room for, gets a context of its own (which is then
    kept).

    Example:
        >>> renderers = MeshSharingRenderers()  # doctest: +SKIP
        >>> seg = renderers.get(model, ImageSpec(320, 180, "fast", ("scene",), ("segmentation",)))
    """

    def __init__(self) -> None:
        self._ctx: mujoco.MjrContext | None = None
        self._key: tuple | None = None
        self._meshes: list[bytes] = []
        self._renderer: SceneRenderer | None = None

    def get(self, model: mujoco.MjModel, image: ImageSpec) -> SceneRenderer:
        """A renderer of ``model`` for ``image`` (segmentation only, a GL preset).

        Raises:
            RenderError: ``image`` asks for more than segmentation, or for a path-traced preset.
        """
        if tuple(image.modalities) != ("segmentation",) or get_preset(image.preset).path_traced:
            raise RenderError(f"MeshSharingRenderers renders segmentation with a GL preset only, not "
                              f"{list(image.modalities)} with {image.preset!r}")
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None
        key = _world_key(model, image)
        sigs = mesh_signatures(model)
        fits = (self._ctx is not None and key == self._key and model.nmesh <= self._ctx.rangeMesh // 2
                and model.nhfield == 0 and model.nskin == 0 and model.nflex == 0)
        if not fits:
            self.close()
            own = SceneRenderer(model, image.width, image.height, image.preset)
            self._ctx, own._owns_ctx = own._ctx, False  # the context is kept here from now on
            self._key, self._meshes = key, sigs
            self._renderer = own
            return own
        assert self._ctx is not None
        _shared_gl_context().make_current()
        for i, sig in enumerate(sigs):
            if i >= len(self._meshes) or self._meshes[i] != sig:
                mujoco.mjr_uploadMesh(model, self._ctx, i)
        self._meshes = sigs + self._meshes[len(sigs):]
        self._renderer = SceneRenderer(model, image.width, image.height, image.preset, context=self._ctx)
        return self._renderer

    def close(self) -> None:
        """Free the kept context."""
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None
        if self._ctx is not None:
            _shared_gl_context().make_current()
            self._ctx.free()
            self._ctx = None
        self._key, self._meshes = None, []
