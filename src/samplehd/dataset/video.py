"""MP4 encoding with PyAV: LeRobot's concatenated episode videos and per-episode previews."""

from __future__ import annotations

import os
from collections.abc import Iterable
from pathlib import Path

import numpy as np

from samplehd.errors import ConfigError, DatasetError

__all__ = ["VideoWriter", "pick_codec"]

# LeRobot's default is AV1 (SVT-AV1, CRF 30, GOP 2); H.264 and MPEG-4 are fallbacks for PyAV builds
# without it.
_CODECS = ("libsvtav1", "libx264", "mpeg4")


def pick_codec(preferred: str | None = None) -> str:
    """The first available codec of ``preferred`` then LeRobot's default and the fallbacks."""
    import av

    if preferred:
        try:
            av.codec.Codec(preferred, "w")
        except Exception:  # noqa: BLE001 - PyAV raises several types for an unknown or decode-only codec
            usable = [c for c in _CODECS if c in av.codecs_available]
            raise ConfigError(f"--codec {preferred!r}: not a video encoder of this PyAV build; try one of "
                              f"{', '.join(usable)}") from None
    for name in ((preferred,) if preferred else ()) + _CODECS:
        if name in av.codecs_available:
            return name
    raise DatasetError(f"no usable video encoder in this PyAV build; tried {', '.join(_CODECS)}")


class VideoWriter:
    """Append RGB frames to one MP4 file; frame ``k`` gets timestamp ``k / fps`` exactly.

    Args:
        path: output file (parent folders are created).
        width: frame width [px] (even, for yuv420p).
        height: frame height [px] (even).
        fps: frames per second.
        codec: PyAV encoder name (default: :func:`pick_codec`).
        crf: constant rate factor (quality; lower is better).
        gop: keyframe interval [frames] (LeRobot uses 2 for fast random access).
    """

    def __init__(self, path: Path, width: int, height: int, fps: int, codec: str | None = None, crf: int = 30,
                 gop: int = 2) -> None:
        import av

        # SVT-AV1 logs its whole configuration to stderr unless told otherwise (1 = errors only).
        os.environ.setdefault("SVT_LOG", "1")
        if width % 2 or height % 2:
            raise DatasetError(f"video {path}: {width}x{height} must have even sides for yuv420p")
        self.path = Path(path)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self.codec = pick_codec(codec)
        self.container = av.open(str(self.path), mode="w")
        options = {"crf": str(crf), "g": str(gop)}
        if self.codec == "libsvtav1":
            options.update({"preset": "12"})
        if self.codec == "mpeg4":
            options = {"qscale": "3", "g": str(gop)}
        self.stream = self.container.add_stream(self.codec, rate=fps, options=options)
        self.stream.width, self.stream.height = width, height
        self.stream.pix_fmt = "yuv420p"
        from fractions import Fraction

        self.stream.time_base = Fraction(1, fps)
        self.frames = 0

    def write(self, frames: Iterable[np.ndarray]) -> None:
        """Append H×W×3 uint8 frames."""
        import av

        for rgb in frames:
            frame = av.VideoFrame.from_ndarray(np.ascontiguousarray(rgb, dtype=np.uint8), format="rgb24")
            frame.pts = self.frames
            self.frames += 1
            for packet in self.stream.encode(frame):
                self.container.mux(packet)

    def close(self) -> None:
        for packet in self.stream.encode():
            self.container.mux(packet)
        self.container.close()

    def __enter__(self) -> VideoWriter:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
