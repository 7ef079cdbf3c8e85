"""One renderer kept across the image requests of one model (:class:`RendererCache`)."""

from __future__ import annotations

from types import TracebackType

import mujoco

from samplehd.render.image_spec import ImageSpec
from samplehd.render.photo.renderer import PhotoOptions
from samplehd.render.renderer import SceneRenderer, get_preset

__all__ = ["RendererCache"]


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
