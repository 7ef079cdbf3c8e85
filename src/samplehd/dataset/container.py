"""One episode per HDF5 file: per-frame records, physics states and (optionally) images.

Layout of ``episodes/s{scene:06d}_{slot:02d}.h5``::

    /                       attrs: format_version, scene_index, slot, instruction_index, family, seed,
                                   success, num_frames, subtasks (JSON list), info (JSON), instruction
                                   (text), task (JSON)
    /frames/<field>         one dataset per :data:`samplehd.record.episode.FRAME_FIELDS` entry, shape
                            (T, ...) with the field's dtype, gzip + shuffle (lossless, bit-exact);
                            a disturbed episode also has the (T,) int8 flags of
                            :data:`samplehd.record.disturbances.LABEL_FIELDS` (``disturbance_active``,
                            ``recovery``) and ``info["disturbance"]``
    /images                 attrs: render (JSON: mode, width, height, cameras, modalities and
                            per_camera {camera: {mode, width, height, modalities}}; see
                            :func:`camera_settings`, :func:`render_record`)
    /images/<cam>/rgb       (T, H, W, 3) uint8, lossless gzip, one chunk per frame
    /images/<cam>/depth     (T, H, W) float32 metres, exact; gzip, one chunk per frame
    /images/<cam>/segmentation  (T, H, W) uint8 (uint16 when ids exceed 255) instance ids; gzip,
                            one chunk per frame
    /images/<cam>           attrs: frame_index (K,) int64, only when the camera has images at K < T
                            keyframes (``rerender --every N`` / ``--subtask-ends``): its streams are
                            then (K, ...), frame ``frame_index[k]`` stored at position k

Files are written under a temporary name (``.NAME.tmp-PID``) in the same directory, flushed, then
renamed over the final name, so a reader never sees a half-written episode and a killed writer
leaves only a temporary file behind. Every image access is per frame (one chunk or one PNG).

Image chunks are deflated by ISA-L (:data:`samplehd.render.deflated.IMAGE_DEFLATE_LEVEL`) and written as
they are (``write_direct_chunk``) into datasets with HDF5's standard gzip filter, so any HDF5 reader
decodes them; ISA-L's deflate is several times faster than zlib's at a slightly larger size, and image
compression is most of an episode's writing time. Streams given already deflated
(:class:`~samplehd.render.deflated.DeflatedFrames`, as ``samplehd generate`` renders them) are stored as
they come.
"""

from __future__ import annotations

import errno
import hashlib
import io
import json
import os
import shutil
import threading
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any, TypedDict

import h5py
import numpy as np

from samplehd.dataset.layout import FORMAT_VERSION, tmp_path
from samplehd.dataset.render import RenderConfig
from samplehd.errors import DatasetError
from samplehd.fileio import check_regular_file
from samplehd.record.disturbances import LABEL_FIELDS
from samplehd.record.episode import FRAME_FIELDS, Episode
from samplehd.render.deflated import IMAGE_DEFLATE_LEVEL, DeflatedFrames, deflate_frame
from samplehd.render.keyframes import SparseFrames
from samplehd.render.renderer import MODALITIES

__all__ = [
    "CameraRender",
    "EpisodeFile",
    "RenderRecord",
    "KEYFRAME_KEYS",
    "FrameImages",
    "camera_settings",
    "describe_settings",
    "episode_attrs",
    "merge_camera_settings",
    "read_episode",
    "read_frames",
    "read_image",
    "read_meta",
    "render_record",
    "write_episode",
    "write_error",
]

_GZIP = {"compression": "gzip", "compression_opts": 4, "shuffle": True}
_DISK_FULL = {errno.ENOSPC, errno.EFBIG, errno.EDQUOT}


@dataclass(frozen=True)
class EpisodeFile:
    """What the writer reports about one written episode file.

    Attributes:
        name: file name inside ``episodes/``.
        num_frames: frames in the episode.
        size: file size [bytes].
        sha256: hex digest of the file.
    """

    name: str
    num_frames: int
    size: int
    sha256: str


def _nearly_full(path: Path) -> bool:
    """Whether the file system holding ``path`` has (almost) no space left; some writers (numpy's
    ``save``) report a full disk without an errno."""

    p = Path(path)
    while not p.exists() and p != p.parent:
        p = p.parent
    try:
        return shutil.disk_usage(p).free < (1 << 20)
    except OSError:
        return False


def write_error(path: Path, exc: BaseException, retry: str = "run the same command again") -> DatasetError:
    """A one-line DatasetError for a failed write, naming disk-full and permission problems.

    Args:
        path: the file that could not be written.
        exc: the error.
        retry: how to continue once space is freed (``generate`` says ``run again with `resume```).
    """
    err = getattr(exc, "errno", None)
    text = str(exc)
    if err in _DISK_FULL or "No space left" in text or "File too large" in text or _nearly_full(path):
        return DatasetError(f"{path}: cannot write: the disk is full (no space left on device); free space "
                            f"and {retry}")
    if err in (errno.EACCES, errno.EPERM, errno.EROFS) or "Permission denied" in text:
        return DatasetError(f"{path}: cannot write: permission denied; choose a writable `out`")
    return DatasetError(f"{path}: cannot write: {getattr(exc, 'strerror', None) or text}")


def _modality_list(mods: Iterable[str]) -> list[str]:
    """Modalities in the canonical order (rgb, depth, segmentation), unknown names last."""
    names = list(dict.fromkeys(str(m) for m in mods))
    return sorted(names, key=lambda m: (MODALITIES.index(m) if m in MODALITIES else len(MODALITIES), m))


# Render settings beyond mode and size, kept per camera when set: which frames have images, the photo look.
KEYFRAME_KEYS = ("every", "subtask_ends", "look")


class CameraRender(TypedDict, total=False):
    """One camera's render settings (a render record's ``per_camera`` entry): mode (``fast``, ``hd``),
    image size [px], modalities in the order rgb, depth, segmentation, and where set the keyframe
    settings (:data:`KEYFRAME_KEYS`: every N-th frame, subtask ends) and the photo look."""

    mode: str
    width: int
    height: int
    modalities: list[str]
    every: int
    subtask_ends: bool
    look: str


class RenderRecord(TypedDict):
    """A render record (an episode file's ``/images`` attribute, ``info.json``'s ``render``): the mode,
    size and modalities every camera shares (``mode`` ``"mixed"`` and the others None where they
    differ), the cameras, and each camera's own settings."""

    mode: str
    width: int | None
    height: int | None
    cameras: list[str]
    modalities: list[str] | None
    per_camera: dict[str, CameraRender]


def camera_settings(render: Mapping[str, Any] | None) -> dict[str, CameraRender]:
    """The per-camera render settings of a render record (an episode file's ``/images`` attribute or
    ``info.json``'s ``render``).

    A record has ``per_camera`` when ``samplehd rerender --add`` may have given cameras different
    settings; an older (or uniform) record has only ``mode, width, height, cameras, modalities``,
    which apply to every camera.

    Returns:
        ``{camera: {mode, width, height, modalities}}`` (modalities in the order rgb, depth,
        segmentation); empty for None or mode ``none``.

    Raises:
        DatasetError: the record is malformed.
    """
    if not render:
        return {}
    try:
        per = render.get("per_camera")
        if per is None:
            if render.get("mode", "none") == "none":
                return {}
            per = {c: render for c in render.get("cameras", [])}
        return {str(c): {"mode": str(s["mode"]), "width": int(s["width"]), "height": int(s["height"]),
                         "modalities": _modality_list(s["modalities"]),
                         **{k: s[k] for k in KEYFRAME_KEYS if k in s}} for c, s in per.items()}
    except (AttributeError, KeyError, TypeError, ValueError) as exc:
        raise DatasetError(f"malformed render settings {dict(render)!r}: {exc!r}") from None


def render_record(per_camera: Mapping[str, Mapping[str, Any]]) -> RenderRecord | None:
    """The render record describing images with the given per-camera settings.

    ``mode``, ``width``, ``height`` and ``modalities`` hold the value every camera shares; where the
    cameras differ, ``mode`` is ``"mixed"`` and the others are None (``per_camera`` is then the
    only description). Returns None when there are no cameras (no images).
    """
    per = camera_settings({"per_camera": per_camera}) if per_camera else {}
    if not per:
        return None
    settings = list(per.values())

    def shared(key: str) -> Any:
        first = settings[0][key]
        return first if all(s[key] == first for s in settings) else None

    return {"mode": shared("mode") or "mixed", "width": shared("width"), "height": shared("height"),
            "cameras": list(per), "modalities": shared("modalities"), "per_camera": per}


def _missing_frame(where: str, t: int, frames: np.ndarray) -> DatasetError:
    shown = ", ".join(str(int(f)) for f in frames[:8]) + (", ..." if len(frames) > 8 else "")
    return DatasetError(f"{where}: frame {t} has no image; this camera has images at {len(frames)} keyframes "
                        f"({shown}); re-render without `every`/`subtask_ends` for every frame")


def _write_images(group: h5py.Group, images: Mapping[str, Mapping[str, np.ndarray]]) -> None:
    for cam, mods in images.items():
        g = group.require_group(cam)
        for mod, arr in mods.items():
            frames = arr.frames if isinstance(arr, (SparseFrames, FrameImages)) else None
            if frames is not None:
                if "frame_index" in g.attrs and not np.array_equal(g.attrs["frame_index"], frames):
                    raise DatasetError(f"camera {cam!r}: modalities with images at different frames")
                g.attrs["frame_index"] = frames
            if isinstance(arr, SparseFrames):
                arr = arr.images
            if isinstance(arr, FrameImages):
                # Kept from an existing file: copy the stored (compressed) chunks unchanged.
                try:
                    with h5py.File(arr.path, "r") as src:
                        g.copy(src[arr.key], g, name=mod)
                except (OSError, KeyError, RuntimeError) as exc:
                    raise DatasetError(f"{arr.path}: cannot copy {arr.key}: {exc}") from None
                continue
            if isinstance(arr, DeflatedFrames):
                if mod not in MODALITIES:
                    raise DatasetError(f"unknown image modality {mod!r}; valid: rgb, depth, segmentation")
                _store_chunks(g, mod, arr.shape, arr.dtype, arr.chunks)
                continue
            arr = np.asarray(arr)
            if mod == "rgb":
                _write_frames(g, mod, arr, np.uint8)
            elif mod == "depth":
                _write_frames(g, mod, arr, np.float32)
            elif mod == "segmentation":
                dtype = np.uint8 if arr.size == 0 or int(arr.max()) < 256 else np.uint16
                if arr.size and int(arr.min()) < 0:
                    raise DatasetError(f"segmentation of camera {cam!r} has negative ids")
                _write_frames(g, mod, arr, dtype)
            else:
                raise DatasetError(f"unknown image modality {mod!r}; valid: rgb, depth, segmentation")


def _write_frames(group: h5py.Group, name: str, arr: np.ndarray, dtype: type[np.generic]) -> None:
    """Store ``arr`` (T, ...) as ``dtype``, one gzip chunk per frame, each deflated by ISA-L."""
    _store_chunks(group, name, arr.shape, np.dtype(dtype), (deflate_frame(frame, dtype) for frame in arr))


def _store_chunks(group: h5py.Group, name: str, shape: tuple[int, ...], dtype: np.dtype,
                  chunks: Iterable[bytes]) -> None:
    """A (T, ...) dataset with HDF5's gzip filter, one chunk per frame, written from deflated frames."""
    ds = group.create_dataset(name, shape=shape, dtype=dtype, chunks=(1, *shape[1:]),
                              compression="gzip", compression_opts=IMAGE_DEFLATE_LEVEL)
    zeros = (0,) * (len(shape) - 1)
    for t, chunk in enumerate(chunks):
        ds.id.write_direct_chunk((t, *zeros), chunk)


def episode_attrs(episode: Episode, extra: Mapping[str, Any] | None = None) -> dict[str, Any]:
    """The root attributes of an episode file."""
    attrs: dict[str, Any] = {
        "format_version": FORMAT_VERSION,
        "scene_index": episode.scene_index,
        "instruction_index": episode.instruction_index,
        "family": episode.family,
        "seed": episode.seed,
        "success": bool(episode.success),
        "num_frames": episode.num_frames,
        "subtasks": json.dumps(list(episode.subtasks)),
        "info": json.dumps(episode.info, sort_keys=True),
    }
    for k, v in (extra or {}).items():
        attrs[k] = v if isinstance(v, (str, int, float, bool)) else json.dumps(v, sort_keys=True)
    return attrs


def write_episode(path: Path, episode: Episode, extra: Mapping[str, Any] | None = None,
                  render: Mapping[str, Any] | None = None, retry: str = "run the same command again") -> EpisodeFile:
    """Write ``episode`` atomically to ``path`` (temporary name, flush, rename).

    Args:
        path: the final file path.
        episode: the episode; its ``images`` (if any) are stored under ``/images``; an image stream
            given as :class:`FrameImages` (lazy, from another file) is copied chunk by chunk, unchanged.
        extra: more root attributes (slot, instruction text, task); non-scalars are stored as JSON.
        render: the render settings that produced the images (stored as ``/images`` attrs).
        retry: how to continue after a failed write (see :func:`write_error`).

    Returns:
        Name, frame count, size and SHA-256 of the written file.

    Raises:
        DatasetError: the file cannot be written (disk full, permission denied, ...), one line.
    """
    path = Path(path)
    tmp = tmp_path(path)
    # Build the file in memory, then write it with plain file I/O: a full disk then fails one clean
    # write() instead of leaving HDF5 handles half-flushed inside the library.
    buffer = io.BytesIO()
    with h5py.File(buffer, "w", track_order=True) as f:
        for k, v in episode_attrs(episode, extra).items():
            f.attrs[k] = v
        frames = f.create_group("frames")
        for key, (_, dtype) in FRAME_FIELDS.items():
            arr = np.asarray(episode.frames[key], dtype=dtype)
            frames.create_dataset(key, data=arr, **(_GZIP if arr.size > 64 else {}))
        for key, (_, dtype) in LABEL_FIELDS.items():
            if key in episode.frames:
                arr = np.asarray(episode.frames[key], dtype=dtype)
                frames.create_dataset(key, data=arr, **(_GZIP if arr.size > 64 else {}))
        if episode.images:
            g = f.create_group("images")
            g.attrs["render"] = json.dumps(dict(render or {}), sort_keys=True)
            _write_images(g, episode.images)
    data = buffer.getbuffer()
    # A file with images is tens of MB: its digest is taken on a second thread while this one writes and
    # syncs it (both let go of the GIL), instead of before.
    digest = _Digest(data, threaded=len(data) >= _THREADED_DIGEST_BYTES)
    try:
        with open(tmp, "wb") as fh:
            fh.write(data)
            fh.flush()
            os.fsync(fh.fileno())
            _drop_cached(fh.fileno())
        os.replace(tmp, path)
    except OSError as exc:
        digest.wait()
        try:
            tmp.unlink()
        except OSError:
            pass
        raise write_error(path, exc, retry) from None
    size = len(data)
    return EpisodeFile(path.name, episode.num_frames, size, digest.result())


# Files from this size on are hashed beside their writing (a thread costs more than hashing a small file).
_THREADED_DIGEST_BYTES = 4 << 20


class _Digest:
    """The SHA-256 of ``data``, computed now or (``threaded``) on a helper thread; :meth:`result` waits for it
    and raises what hashing raised."""

    def __init__(self, data: memoryview, threaded: bool) -> None:
        self._hex: str | None = None
        self._error: BaseException | None = None
        self._thread: threading.Thread | None = None
        if threaded:
            self._thread = threading.Thread(target=self._run, args=(data,), name="samplehd-digest", daemon=True)
            self._thread.start()
        else:
            self._run(data)

    def _run(self, data: memoryview) -> None:
        try:
            self._hex = hashlib.sha256(data).hexdigest()
        except BaseException as exc:  # handed to the caller by result()
            self._error = exc

    def wait(self) -> None:
        """Wait until the digest is taken."""
        if self._thread is not None:
            self._thread.join()
            self._thread = None

    def result(self) -> str:
        """The hex digest (after waiting for it)."""
        self.wait()
        if self._error is not None:
            raise self._error
        assert self._hex is not None
        return self._hex


def _drop_cached(fd: int) -> None:
    """Let the kernel reuse the (clean, synced) page cache of a file just written, which nothing reads soon.

    An episode with images is tens of MB; kept cached, every episode takes fresh pages, and on a machine
    whose free memory was never touched (a virtual machine) or whose cache is full, getting them cost
    ~7x the CPU of the copy itself (measured: 140 vs 20 ms per 68 MB). Released, the next episode's pages
    are the ones this one used.
    """
    if hasattr(os, "posix_fadvise"):
        try:
            os.posix_fadvise(fd, 0, 0, os.POSIX_FADV_DONTNEED)
        except OSError:
            pass  # only advice


class FrameImages:
    """Lazy, per-frame access to one image stream of an episode file.

    Indexing with an integer reads and decodes one frame; a slice or ``np.asarray`` reads several.
    The file is opened per access, so no handle is held between reads.

    Args:
        path: the episode file.
        key: dataset path inside the file, e.g. ``images/scene/rgb``.
    """

    def __init__(self, path: Path, key: str) -> None:
        self.path = Path(path)
        self.key = key
        with _open(self.path) as f:
            if key not in f:
                raise DatasetError(f"{self.path}: no image stream {key!r}")
            ds = f[key]
            self._len = int(ds.shape[0])
            self.shape = tuple(int(v) for v in ds.shape)
            self.dtype = ds.dtype
            group = ds.parent
            # Keyframes only: the stream stands for all T frames, of which ``frames`` have images.
            self.frames: np.ndarray | None = (np.asarray(group.attrs["frame_index"], dtype=np.int64)
                                              if "frame_index" in group.attrs else None)
            if self.frames is not None:
                self._len = int(f.attrs["num_frames"])
                self.shape = (self._len, *self.shape[1:])

    def __len__(self) -> int:
        return self._len

    def has_image(self, frame: int) -> bool:
        """Whether frame ``frame`` has an image (always, unless the camera has keyframes only)."""
        return 0 <= frame < self._len and (self.frames is None or bool(np.isin(frame, self.frames)))

    def stored(self) -> np.ndarray:
        """All stored images: T frames, or the K keyframes (see :attr:`frames`)."""
        try:
            with h5py.File(self.path, "r") as f:
                return f[self.key][:]
        except (OSError, KeyError, RuntimeError) as exc:
            raise DatasetError(f"{self.path}: cannot read {self.key}: {exc}") from None

    def __getitem__(self, index: int | slice) -> np.ndarray:
        if self.frames is not None:  # keyframes: a frame maps to its stored position, or has no image
            if isinstance(index, slice):
                ts = list(range(self._len)[index])
            else:
                t = int(index) + (self._len if int(index) < 0 else 0)
                if not 0 <= t < self._len:
                    raise IndexError(f"frame {index} outside 0..{self._len - 1}")
                ts = [t]
            pos = np.searchsorted(self.frames, ts)
            for t, p in zip(ts, pos, strict=True):
                if p >= len(self.frames) or self.frames[p] != t:
                    raise _missing_frame(f"{self.path}: {self.key}", t, self.frames)
            index = [int(p) for p in pos] if isinstance(index, slice) else int(pos[0])  # type: ignore[assignment]
        elif not isinstance(index, slice):
            t = int(index)
            t += self._len if t < 0 else 0
            if not 0 <= t < self._len:
                raise IndexError(f"frame {index} outside 0..{self._len - 1}")
            index = t
        try:
            with h5py.File(self.path, "r") as f:
                return f[self.key][index]
        except (OSError, KeyError, RuntimeError) as exc:
            raise DatasetError(f"{self.path}: cannot read {self.key}[{index}]: {exc}") from None

    def __array__(self, dtype: Any = None, copy: Any = None) -> np.ndarray:
        arr = self[:]
        return arr if dtype is None else arr.astype(dtype)

    def __repr__(self) -> str:
        return f"FrameImages({self.path.name}:{self.key}, shape={self.shape}, dtype={self.dtype})"


def _open(path: Path) -> h5py.File:
    check_regular_file(path, DatasetError, f"{path}: episode file")
    try:
        f = h5py.File(path, "r")
    except FileNotFoundError:
        raise DatasetError(f"{path}: episode file is missing") from None
    except OSError as exc:
        raise DatasetError(f"{path}: not a readable HDF5 episode file (truncated or corrupted): {exc}") from None
    version = f.attrs.get("format_version")
    version = version.decode() if isinstance(version, bytes) else version
    if version != FORMAT_VERSION:
        f.close()
        raise DatasetError(f"{path}: episode format_version {version!r} is not one this samplehd reads "
                           f"(valid: {FORMAT_VERSION!r}); use the samplehd version that wrote it")
    return f


def read_frames(path: Path, fields: Iterable[str] | None = None) -> dict[str, np.ndarray]:
    """Read some (default: all) frame fields of an episode file."""
    with _open(path) as f:
        try:
            return {k: f["frames"][k][()] for k in (fields or FRAME_FIELDS)}
        except (KeyError, OSError, RuntimeError) as exc:
            raise DatasetError(f"{path}: cannot read frames: {exc}") from None


def read_meta(path: Path) -> dict[str, Any]:
    """An episode file's attributes without reading frames or images.

    Returns:
        ``{stem, scene_index, slot, instruction_index, family, seed, success, num_frames, subtasks,
        info, task, instruction, render, images: {camera: [modalities]}}``; ``render`` is None and
        ``images`` empty when the episode stores no images (render mode none).

    Raises:
        DatasetError: the file is missing, truncated or corrupted.
    """
    path = Path(path)
    with _open(path) as f:
        try:
            out: dict[str, Any] = {"stem": path.stem}
            for k, v in f.attrs.items():
                v = v.item() if isinstance(v, np.generic) else v
                out[k] = json.loads(v) if k in ("subtasks", "info", "task") and isinstance(v, str) else v
            out["render"] = json.loads(f["images"].attrs["render"]) if "images" in f else None
            out["images"] = {cam: list(f["images"][cam]) for cam in f["images"]} if "images" in f else {}
            out["image_frames"] = {cam: [int(v) for v in f["images"][cam].attrs["frame_index"]]
                                   for cam in out["images"] if "frame_index" in f["images"][cam].attrs}
        except (KeyError, OSError, RuntimeError, ValueError) as exc:
            raise DatasetError(f"{path}: corrupted episode file: {exc}") from None
    return out


def read_image(path: Path, camera: str, modality: str, frame: int) -> np.ndarray:
    """One decoded image frame (reads one chunk)."""
    return FrameImages(path, f"images/{camera}/{modality}")[frame]


def read_episode(path: Path, images: str = "lazy", instruction_index: int | None = None) -> Episode:
    """Read an episode file.

    Args:
        path: the episode file.
        images: ``"lazy"`` (per-frame :class:`FrameImages`), ``"load"`` (decoded arrays) or ``"none"``.
        instruction_index: override the stored instruction index (the dataset's final numbering).

    Raises:
        DatasetError: the file is missing, truncated or corrupted (one line).
    """
    path = Path(path)
    if images not in ("lazy", "load", "none"):
        raise DatasetError(f"images={images!r}: valid: lazy, load, none")
    with _open(path) as f:
        try:
            a = f.attrs
            frames = {k: f["frames"][k][()] for k in (*FRAME_FIELDS, *LABEL_FIELDS) if k in FRAME_FIELDS
                      or k in f["frames"]}
            keys = []
            if images != "none" and "images" in f:
                for cam in f["images"]:
                    for mod in f["images"][cam]:
                        keys.append((cam, mod))
            meta = {
                "scene_index": int(a["scene_index"]),
                "instruction_index": int(a["instruction_index"] if instruction_index is None else instruction_index),
                "family": str(a["family"]),
                "seed": int(a["seed"]),
                "subtasks": tuple(json.loads(a["subtasks"])),
                "success": bool(a["success"]),
                "info": json.loads(a["info"]),
            }
        except (KeyError, OSError, RuntimeError, ValueError) as exc:
            raise DatasetError(f"{path}: corrupted episode file: {exc}") from None
    imgs: dict[str, dict[str, Any]] = {}
    for cam, mod in keys:
        lazy = FrameImages(path, f"images/{cam}/{mod}")
        if images == "lazy":
            imgs.setdefault(cam, {})[mod] = lazy
        elif lazy.frames is not None:
            imgs.setdefault(cam, {})[mod] = SparseFrames(lazy.frames, lazy.stored(), len(lazy))
        else:
            imgs.setdefault(cam, {})[mod] = np.asarray(lazy)
    return Episode(frames=frames, images=imgs, **meta)


def describe_settings(s: Mapping[str, Any]) -> str:
    """``WxH mode`` of one camera's settings (and its keyframes), for messages."""
    frames = (f" every {s['every']}" if s.get("every", 1) != 1 else "") + (
        " subtask ends" if s.get("subtask_ends") else "")
    return f"{s['width']}x{s['height']} {s['mode']}{frames}"


def merge_camera_settings(old: Mapping[str, Mapping[str, Any]], render: RenderConfig,
                          add: bool) -> dict[str, CameraRender]:
    """The per-camera settings of an episode's images after rendering ``render`` into it.

    Args:
        old: the file's current settings (:func:`samplehd.dataset.container.camera_settings`).
        render: what is rendered now (mode fast or hd).
        add: keep ``old``'s cameras (a camera + modality rendered again is overwritten); else only
            the new images remain.

    Returns:
        ``{camera: {mode, width, height, modalities}}``.

    Raises:
        DatasetError: with ``add``, a stored camera would keep some modalities at other settings
            (resolution or preset) than the ones rendered now; one camera has one setting.
    """
    new = camera_settings(render.to_dict())
    if not add:
        return new
    out = {c: dict(s) for c, s in camera_settings({"per_camera": old}).items()} if old else {}
    for cam, s in new.items():
        prev = out.get(cam)
        if prev is None:
            out[cam] = s
            continue
        same = all(prev.get(k) == s.get(k) for k in ("mode", "width", "height", *KEYFRAME_KEYS))
        if same:
            mods = set(prev["modalities"]) | set(s["modalities"])
            out[cam] = {**s, "modalities": [m for m in MODALITIES if m in mods]}
            continue
        left = [m for m in prev["modalities"] if m not in s["modalities"]]
        if left:
            raise DatasetError(
                f"camera {cam!r} is stored at {describe_settings(prev)} with {', '.join(left)}, which `add` would "
                f"keep beside new {describe_settings(s)} images; add `modalities` {' '.join(prev['modalities'])} "
                f"to re-render all of them, or re-render without `add`")
        out[cam] = s
    return out
