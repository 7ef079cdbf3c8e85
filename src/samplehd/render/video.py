"""MP4 encoding with PyAV, the one video writer: LeRobot's concatenated episode videos, SAMPLE-HD
export previews, ``samplehd replay`` and evaluation videos."""

from __future__ import annotations

import os
from collections.abc import Iterable
from fractions import Fraction
from pathlib import Path

import av
import numpy as np

from samplehd.errors import ConfigError, DatasetError

__all__ = ["VideoWriter", "pick_codec", "write_mp4"]

# LeRobot's default is AV1 (SVT-AV1, CRF 30, GOP 2); H.264 and MPEG-4 are fallbacks for PyAV builds
# without it.
_CODECS = ("libsvtav1", "libx264", "mpeg4")
PIXEL_FORMATS = ("yuv420p", "gray12le")  # RGB videos; 12-bit single-channel videos (depth codes)


def pick_codec(preferred: str | None = None) -> str:
    """The first available codec of ``preferred`` then LeRobot's default and the fallbacks."""
    if preferred:
        try:
            av.codec.Codec(preferred, "w")
        except Exception:  # noqa: BLE001 - PyAV raises several types for an unknown or decode-only codec
            usable = [c for c in _CODECS if c in av.codecs_available]
            raise ConfigError(f"codec={preferred!r}: not a video encoder of this PyAV build; try one of "
                              f"{', '.join(usable)}", field="codec") from None
    for name in ((preferred,) if preferred else ()) + _CODECS:
        if name in av.codecs_available:
            return name
    raise DatasetError(f"no usable video encoder in this PyAV build; tried {', '.join(_CODECS)}")


class VideoWriter:
    """Append frames to one MP4 file; frame ``k`` gets timestamp ``k / fps`` exactly.

    Args:
        path: output file (parent folders are created).
        width: frame width [px] (even, for yuv420p).
        height: frame height [px] (even, for yuv420p).
        fps: frames per second.
        codec: PyAV encoder name (default: :func:`pick_codec`); gray12le always uses libx265.
        crf: constant rate factor (quality; lower is better).
        gop: keyframe interval [frames] (LeRobot uses 2 for fast random access); None: the codec's.
        pix_fmt: ``yuv420p``: H×W×3 uint8 RGB frames, lossy; ``gray12le``: H×W uint16 frames of 12-bit
            codes, lossless HEVC (Main 12, as LeRobot stores depth maps).
    """

    def __init__(self, path: Path, width: int, height: int, fps: int, codec: str | None = None, crf: int = 30,
                 gop: int | None = 2, pix_fmt: str = "yuv420p") -> None:
        # SVT-AV1 logs its whole configuration to stderr unless told otherwise (1 = errors only).
        os.environ.setdefault("SVT_LOG", "1")
        if pix_fmt not in PIXEL_FORMATS:
            raise ConfigError(f"pix_fmt={pix_fmt!r}: must be one of {', '.join(PIXEL_FORMATS)}", field="pix_fmt")
        if pix_fmt == "yuv420p" and (width % 2 or height % 2):
            raise DatasetError(f"video {path}: {width}x{height} must have even sides for yuv420p")
        self.path = Path(path)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self.pix_fmt = pix_fmt
        keyframes = {} if gop is None else {"g": str(gop)}
        if pix_fmt == "gray12le":
            self.codec = pick_codec("libx265")
            options = {"x265-params": "lossless=1:log-level=error", **keyframes}
        else:
            self.codec = pick_codec(codec)
            options = {"crf": str(crf), **keyframes}
            if self.codec == "libsvtav1":
                options.update({"preset": "12"})
            if self.codec == "mpeg4":
                options = {"qscale": "3", **keyframes}
        self.container = av.open(str(self.path), mode="w")
        self.stream = self.container.add_stream(self.codec, rate=fps, options=options)
        self.stream.width, self.stream.height = width, height
        self.stream.pix_fmt = pix_fmt
        self.stream.time_base = Fraction(1, fps)
        self.frames = 0

    def write(self, frames: Iterable[np.ndarray]) -> None:
        """Append frames: H×W×3 uint8 RGB (yuv420p) or H×W uint16 codes below 4096 (gray12le)."""
        for image in frames:
            if self.pix_fmt == "gray12le":
                frame = av.VideoFrame.from_ndarray(np.ascontiguousarray(image, dtype=np.uint16), format="gray12le")
            else:
                frame = av.VideoFrame.from_ndarray(np.ascontiguousarray(image, dtype=np.uint8), format="rgb24")
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


def write_mp4(path: str | Path, rgb: np.ndarray, fps: float = 20.0, crf: int = 20) -> Path:
    """Write (T, H, W, 3) uint8 frames as one H.264 MP4 (odd sides lose their last row/column).

    Args:
        path: output file (parent folders are created).
        rgb: the frames.
        fps: frames per second.
        crf: constant rate factor (quality; lower is better).
    """
    h, w = rgb.shape[1:3]
    h2, w2 = h - h % 2, w - w % 2
    with VideoWriter(Path(path), w2, h2, int(round(fps)), codec="libx264", crf=crf, gop=None) as video:
        video.write(frame[:h2, :w2] for frame in rgb)
    return Path(path)
