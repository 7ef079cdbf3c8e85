"""The ``photo`` render preset: path-traced RGB (Mitsuba 3 + Open Image Denoise) with GL-exact depth and
segmentation. Mitsuba is imported only when a photo render is made."""

from samplehd.render.photo.look import LookParams, default_look, random_look
from samplehd.render.photo.renderer import PhotoRenderer, photo_info

__all__ = ["LookParams", "PhotoRenderer", "default_look", "photo_info", "random_look"]
