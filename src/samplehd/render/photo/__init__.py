"""The ``photo`` render preset: path-traced RGB (Mitsuba 3 + Open Image Denoise) with GL-exact depth and
segmentation (``SceneRenderer(model, w, h, "photo", photo=PhotoOptions(...))``). Mitsuba is imported only when
a photo frame is rendered."""

from samplehd.render.photo.look import LookParams, default_look, random_look
from samplehd.render.photo.renderer import LOOKS, PhotoOptions, PhotoTracer, photo_info, photo_options

__all__ = ["LOOKS", "LookParams", "PhotoOptions", "PhotoTracer", "default_look", "photo_info", "photo_options",
           "random_look"]
