"""Routes of the viewer: a pure function from a GET request (path, query) to a :class:`Response`.

=============================================  ===============================================
endpoint                                       answer
=============================================  ===============================================
``/``                                          the page (static/index.html)
``/static/<file>``                             page assets shipped with the package
``/api/status``                                dataset name, info.json, per-file states, counts
``/api/scenes?family=&class=&colour=&``        scene summaries matching the filters, paged
``material=&split=&success=&offset=&limit=``   (``options`` lists every filter's values)
``/api/scenes/<i>``                            scene annotation, its instructions and episodes
``/api/scenes/<i>/image/<rgb|depth|``          PNG (depth and segmentation colourised)
``segmentation>``
``/api/scenes/<i>/thumb``                      JPEG thumbnail of the RGB image
``/api/scenes/<i>/ids``, ``…/depth_mm``        raw little-endian pixels (``X-Width``,
                                               ``X-Height``, ``X-Dtype`` headers)
``/api/instructions/<j>``                      instruction, its scene, its episodes and rejected paths
``/api/episodes?family=&success=``             episode summaries and rejected paths (journal)
``/api/episodes/<name>``                       per-frame series for the plots and timeline
                                               (name = file stem, e.g. ``s000012_03``)
``/api/episodes/<name>/frame/<t>?camera=&``    one frame as PNG (``format=jpeg`` for JPEG), stored
``modality=&v=``                               or rendered from the recorded state
``/files/<path>``                              a raw dataset file (data types inline, the rest as
                                               a download, never as code)
=============================================  ===============================================

Every path a request names is resolved and must lie inside the dataset (or the static folder):
anything else is answered 403. Missing or half-written data is answered 404 or 503 with a JSON
``{"error": ...}`` body, never a server error.
"""

from __future__ import annotations

import json
import re
import threading
from collections import OrderedDict
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from samplehd.errors import DatasetError
from samplehd.render.renderer import MODALITIES
from samplehd.viewer import imaging
from samplehd.viewer.index import FILTER_KEYS, DatasetIndex, filter_scene_summaries, matches_instruction
from samplehd.viewer.paths import resolve_inside

__all__ = ["STATIC_DIR", "Response", "ViewerApp"]

STATIC_DIR = Path(__file__).resolve().parent / "static"

# The page loads nothing from elsewhere: scripts, styles and images come from this server only.
SECURITY_HEADERS = {
    "Content-Security-Policy": "default-src 'self'; img-src 'self' data: blob:; style-src 'self'; "
    "script-src 'self'; connect-src 'self'; object-src 'none'; base-uri 'none'; frame-ancestors 'none'",
    "X-Content-Type-Options": "nosniff",
    "Referrer-Policy": "no-referrer",
}

# Policy of raw dataset files: no scripts, no requests (raw JSON and images still display).
_FILE_POLICY = "sandbox; default-src 'none'; img-src 'self'; style-src 'unsafe-inline'"

# Types of dataset files shown in the browser; everything else is sent as a download.
_INERT = {".json": "application/json", ".jsonl": "text/plain; charset=utf-8", ".png": "image/png",
          ".jpg": "image/jpeg", ".jpeg": "image/jpeg", ".txt": "text/plain; charset=utf-8",
          ".md": "text/plain; charset=utf-8", ".csv": "text/plain; charset=utf-8"}

_TYPES = {".js": "text/javascript; charset=utf-8", ".css": "text/css; charset=utf-8",
          ".html": "text/html; charset=utf-8", ".json": "application/json", ".png": "image/png",
          ".jpg": "image/jpeg", ".jpeg": "image/jpeg", ".svg": "image/svg+xml", ".txt": "text/plain; charset=utf-8",
          ".md": "text/plain; charset=utf-8"}


@dataclass
class Response:
    """An HTTP answer: status, body bytes, content type and extra headers."""

    status: int
    body: bytes
    content_type: str = "application/json"
    headers: dict[str, str] = field(default_factory=dict)

    @classmethod
    def json(cls, payload: Any, status: int = 200) -> Response:
        return cls(status, json.dumps(payload, allow_nan=False, default=_json_default).encode(), "application/json")

    @classmethod
    def error(cls, status: int, message: str) -> Response:
        return cls(status, json.dumps({"error": message}).encode(), "application/json")


def _json_default(value: Any) -> Any:
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, Path):
        return str(value)
    raise TypeError(f"{type(value).__name__} is not JSON serialisable")


def _sanitise(value: Any) -> Any:
    """Replace NaN/inf (not JSON) by None, recursively."""
    if isinstance(value, float):
        return value if np.isfinite(value) else None
    if isinstance(value, dict):
        return {k: _sanitise(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_sanitise(v) for v in value]
    return value


class _LRU:
    """Small thread-safe LRU of encoded images."""

    def __init__(self, size: int) -> None:
        self._size = size
        self._items: OrderedDict[Any, bytes] = OrderedDict()
        self._lock = threading.Lock()

    def get_or_make(self, key: Any, make: Callable[[], bytes]) -> bytes:
        with self._lock:
            if key in self._items:
                self._items.move_to_end(key)
                return self._items[key]
        value = make()
        with self._lock:
            self._items[key] = value
            while len(self._items) > self._size:
                self._items.popitem(last=False)
        return value


def _file_key(path: Path) -> tuple[str, int, int]:
    st = path.stat()
    return str(path), st.st_mtime_ns, st.st_size


def _int(text: str, what: str) -> int:
    try:
        return int(text)
    except ValueError as exc:
        raise _BadRequest(f"{what} {text!r}: expected an integer") from exc


_NAME = re.compile(r"[A-Za-z0-9_-]{1,64}")


class _BadRequest(DatasetError):
    """A malformed request (answered 400)."""


class _Refused(DatasetError):
    """A path outside the served folders (answered 403)."""


class _NotReady(DatasetError):
    """Data that exists but cannot be read yet (answered 503)."""


class ViewerApp:
    """The viewer's routes over one dataset.

    Args:
        index: the dataset.
        static_dir: folder of the page assets.
    """

    def __init__(self, index: DatasetIndex, static_dir: Path = STATIC_DIR) -> None:
        self.index = index
        self.static_dir = static_dir.resolve()
        self._images = _LRU(512)

    # -- entry point ---------------------------------------------------------------------------
    def handle(self, path: str, query: Mapping[str, str]) -> Response:
        """Answer ``GET path?query`` (path still percent-encoded, query decoded)."""
        try:
            response = self._route(path, query)
        except _BadRequest as exc:
            response = Response.error(400, str(exc))
        except _Refused as exc:
            response = Response.error(403, str(exc))
        except _NotReady as exc:
            response = Response.error(503, str(exc))
        except DatasetError as exc:
            response = Response.error(404, str(exc))
        except (OSError, ValueError, KeyError, IndexError, TypeError) as exc:
            # Half-written or malformed dataset content: say so instead of failing the request.
            complete = self.index.info()[0].get("status") == "complete"
            what = "damaged (`samplehd validate` lists every problem)" if complete else "still being written?"
            response = Response.error(503, f"dataset content unreadable ({what}): {type(exc).__name__}: {exc}")
        response.headers = {**SECURITY_HEADERS, **response.headers}
        return response

    def _route(self, path: str, query: Mapping[str, str]) -> Response:
        if "\x00" in path or "\\" in path:
            raise _Refused(f"path {path!r}: refused")
        if path in ("/", "/index.html"):
            return self._static("index.html")
        if path.startswith("/static/"):
            return self._static(path[len("/static/"):])
        if path.startswith("/files/"):
            return self._file(path[len("/files/"):])
        parts = [p for p in path.split("/") if p]
        if not parts or parts[0] != "api":
            raise DatasetError(f"{path}: no such page; the viewer serves /, /api/…, /static/… and /files/…")
        return self._api(parts[1:], query)

    # -- files ---------------------------------------------------------------------------------
    def _static(self, relative: str) -> Response:
        try:
            target = resolve_inside(self.static_dir, relative)
        except DatasetError as exc:
            raise _Refused(str(exc)) from exc
        if not target.is_file():
            raise DatasetError(f"/static/{relative}: no such asset")
        return Response(200, target.read_bytes(), _TYPES.get(target.suffix, "application/octet-stream"),
                        {"Cache-Control": "no-cache"})

    def _file(self, relative: str) -> Response:
        try:
            target = resolve_inside(self.index.root, relative)
        except DatasetError as exc:
            raise _Refused(str(exc)) from exc
        if target.is_dir():
            names = sorted(p.name + ("/" if p.is_dir() else "") for p in target.iterdir())
            return Response.json({"folder": relative, "entries": names})
        if not target.is_file():
            raise DatasetError(f"/files/{relative}: no such file (yet)")
        # Dataset files are data, never code: only inert types are shown inline (HTML, scripts and SVG
        # from a dataset would run with the viewer's origin), everything else downloads as bytes,
        # and a sandbox policy disables scripts in whatever the browser renders.
        kind = _INERT.get(target.suffix.lower())
        disposition = "inline" if kind else "attachment"
        safe_name = re.sub(r'[^A-Za-z0-9._-]', "_", target.name)
        return Response(200, target.read_bytes(), kind or "application/octet-stream",
                        {"Content-Disposition": f'{disposition}; filename="{safe_name}"',
                         "Content-Security-Policy": _FILE_POLICY})

    # -- api -----------------------------------------------------------------------------------
    def _api(self, parts: list[str], query: Mapping[str, str]) -> Response:
        head, rest = parts[0] if parts else "", parts[1:]
        if head == "status" and not rest:
            return Response.json(_sanitise(self.index.status()))
        if head == "scenes":
            if not rest:
                return self._scene_list(query)
            i = _int(rest[0], "scene")
            if len(rest) == 1:
                return self._scene(i)
            if rest[1:] == ["thumb"]:
                return self._thumb(i)
            if len(rest) == 3 and rest[1] == "image":
                return self._scene_image(i, rest[2].removesuffix(".png"))
            if rest[1:] in (["ids"], ["depth_mm"]):
                return self._scene_raw(i, rest[1])
        if head == "instructions" and len(rest) == 1:
            return self._instruction(_int(rest[0], "instruction"))
        if head == "episodes":
            return self._episodes(rest, query)
        raise DatasetError(f"/api/{'/'.join(parts)}: no such endpoint")

    def _scene_list(self, query: Mapping[str, str]) -> Response:
        summaries = self.index.summaries()
        criteria = {k: v for k, v in query.items() if k in FILTER_KEYS}
        unknown = sorted(set(query) - set(FILTER_KEYS) - {"offset", "limit"})
        if unknown:
            raise _BadRequest(f"unknown query parameter(s) {unknown}; valid: {[*FILTER_KEYS, 'offset', 'limit']}")
        matched = filter_scene_summaries(summaries, criteria)
        offset = max(0, _int(query.get("offset", "0"), "offset"))
        limit = max(1, min(1000, _int(query.get("limit", "120"), "limit")))
        options = {k: sorted({v for s in summaries for v in s[k]}) for k in FILTER_KEYS}
        return Response.json({"total": len(summaries), "matched": len(matched), "offset": offset, "limit": limit,
                              "options": options, "criteria": criteria, "scenes": matched[offset:offset + limit]})

    def _rejections(self, scene_index: int | None = None) -> list[dict[str, Any]]:
        """Rejected paths with their candidate's text, family and flat program; ``instruction_index``
        set when the candidate is also in the instructions (only while generation runs)."""
        instructions, _ = self.index.instructions()
        candidates = self.index.candidates()
        out = []
        for r in self.index.rejections():
            if scene_index is not None and r.get("scene_index") != scene_index:
                continue
            q = next((q for q in instructions if matches_instruction(r, q)), None)
            c = q or next((c for c in candidates if matches_instruction(r, c)), {})
            out.append({**r, "instruction_index": q.get("instruction_index") if q else None,
                        "instruction": c.get("instruction", ""), "family": c.get("family", ""),
                        "program_sequence": c.get("program_sequence", "")})
        return out

    def _with_outcomes(self, instructions: list[dict[str, Any]]) -> list[dict[str, Any]]:
        """Instructions with their ``episodes`` and ``rejections`` attached."""
        episodes, _ = self.index.episode_summaries()
        rejections = self.index.rejections()
        return [{**q, "episodes": [e for e in episodes if matches_instruction(e, q)],
                 "rejections": [r for r in rejections if matches_instruction(r, q)]} for q in instructions]

    def _scene(self, i: int) -> Response:
        scene = self.index.scene(i)
        images = {}
        for modality in MODALITIES:
            images[modality] = self.index.image_path(i, modality).is_file()
        offset = int(scene.get("segmentation_ids", {}).get("object_offset", 3))
        colours = [imaging.object_colour(k) for k in range(len(scene.get("objects", [])))]
        return Response.json(_sanitise({
            "scene": scene,
            "images": images,
            "segmentation_offset": offset,
            "object_colours": colours,
            "instructions": self._with_outcomes(self.index.instructions_of(i)),
            "rejections": self._rejections(i),
        }))

    def _existing(self, i: int, modality: str) -> Path:
        path = self.index.image_path(i, modality)
        if not path.is_file():
            raise DatasetError(f"scene {i}: {modality} image not written yet")
        return path

    def _thumb(self, i: int) -> Response:
        path = self._existing(i, "rgb")
        body = self._images.get_or_make(("thumb", *_file_key(path)),
                                        lambda: imaging.thumbnail(imaging.load_rgb(path)))
        return Response(200, body, "image/jpeg", {"Cache-Control": "no-cache"})

    def _scene_image(self, i: int, modality: str) -> Response:
        path = self._existing(i, modality)
        if modality == "rgb":
            return Response(200, path.read_bytes(), "image/png", {"Cache-Control": "no-cache"})

        def make() -> bytes:
            if modality == "depth":
                return imaging.encode_image(imaging.colourise_depth(imaging.load_depth_mm(path)))
            return imaging.encode_image(imaging.colourise_segmentation(imaging.load_ids(path)))

        body = self._images.get_or_make((modality, *_file_key(path)), make)
        return Response(200, body, "image/png", {"Cache-Control": "no-cache"})

    def _scene_raw(self, i: int, kind: str) -> Response:
        if kind == "ids":
            values = imaging.load_ids(self._existing(i, "segmentation"))
        else:
            values = imaging.load_depth_mm(self._existing(i, "depth"))
        body, dtype = imaging.raw_array_bytes(values)
        return Response(200, body, "application/octet-stream",
                        {"X-Width": str(values.shape[1]), "X-Height": str(values.shape[0]), "X-Dtype": dtype,
                         "Access-Control-Expose-Headers": "X-Width, X-Height, X-Dtype"})

    def _instruction(self, j: int) -> Response:
        instruction = self.index.instruction(j)
        scene_index = int(instruction.get("image_index", -1))
        try:
            scene = self.index.scene(scene_index)
        except DatasetError:
            scene = None
        joined = self._with_outcomes([instruction])[0]
        written = scene is not None and self.index.image_path(scene_index, "rgb").is_file()
        return Response.json(_sanitise({
            "instruction": instruction,
            "scene": scene,
            "image_written": written,
            "segmentation_offset": int((scene or {}).get("segmentation_ids", {}).get("object_offset", 3)),
            "episodes": joined["episodes"],
            "rejections": joined["rejections"],
        }))

    def _episodes(self, rest: list[str], query: Mapping[str, str]) -> Response:
        store = self.index.episodes
        if not rest:
            episodes, state = self.index.episode_summaries()
            family, success = query.get("family", ""), query.get("success", "")
            if family:
                episodes = [e for e in episodes if e.get("family") == family]
            if success:
                want = success == "success"
                episodes = [e for e in episodes if bool(e.get("success")) == want]
            rejections = self._rejections()
            if family:
                rejections = [r for r in rejections if r["family"] == family]
            if success == "success":
                rejections = []
            return Response.json(_sanitise({"state": state.to_dict(), "episodes": episodes,
                                            "rejections": rejections}))
        if store is None:
            raise DatasetError("this dataset holds no episodes")
        k = rest[0]
        if not _NAME.fullmatch(k):
            raise _BadRequest(f"episode {k!r}: expected a name like s000012_03")
        if len(rest) == 1:
            detail = store.detail(k)
            detail["version"] = "-".join(str(v) for v in np.atleast_1d(store.version(k)))
            return Response.json(_sanitise(detail))
        if len(rest) == 3 and rest[1] == "frame":
            t = _int(rest[2].split(".", 1)[0], "frame")
            if t < 0:  # Python's indexing would serve a frame counted from the end
                raise _BadRequest(f"frame {t}: expected a frame index ≥ 0")
            camera = query.get("camera", "")
            modality = query.get("modality", "rgb")
            fmt = "jpeg" if query.get("format") == "jpeg" else "png"

            def make() -> bytes:
                pixels = store.frame(k, t, camera, modality)
                if modality == "depth":
                    pixels = imaging.colourise_depth(pixels)
                elif modality == "segmentation":
                    pixels = imaging.colourise_segmentation(pixels)
                return imaging.encode_image(pixels, fmt)

            body = self._images.get_or_make(("episode", store.version(k), k, t, camera, modality, fmt), make)
            # the player puts the file's version in the URL (?v=), so a cached frame is never stale
            cache = "private, max-age=86400" if query.get("v") else "no-cache"
            return Response(200, body, "image/jpeg" if fmt == "jpeg" else "image/png", {"Cache-Control": cache})
        raise DatasetError(f"/api/episodes/{'/'.join(rest)}: no such endpoint")
