"""Frames of episodes stored without images (``--render none``), rendered on demand from their
recorded physics states with :func:`samplehd.render.states.set_state` — as ``samplehd rerender``
does, one frame at a time, without writing anything.

GL contexts belong to the thread that made them, and the HTTP server answers on many threads, so
every render runs on one dedicated worker thread; requests wait for it. Compiled scenes and their
renderers are kept for the few most recent scenes.
"""

from __future__ import annotations

import json
import queue
import threading
from collections import OrderedDict
from collections.abc import Mapping
from concurrent.futures import Future
from typing import Any

import numpy as np

from samplehd.envs.config import CAMERAS
from samplehd.errors import DatasetError, RenderError
from samplehd.render.image_spec import ImageSpec
from samplehd.render.renderer import MODALITIES
from samplehd.render.states import set_state
from samplehd.scene.spec import SceneSpec, compile_scene

__all__ = ["StateRenderer"]


class StateRenderer:
    """Renders single frames from physics states on one worker thread.

    Args:
        image: size and render preset of every frame (its cameras and modalities are each request's own).
        scenes_kept: how many compiled scenes (with their renderers) stay cached.
        timeout: longest wait for one frame [s].
    """

    def __init__(self, image: ImageSpec | None = None, scenes_kept: int = 3, timeout: float = 120.0) -> None:
        self.image = image or ImageSpec()
        self.scenes_kept = scenes_kept
        self.timeout = timeout
        self._jobs: queue.Queue[tuple[Any, Future[np.ndarray]] | None] = queue.Queue()
        self._thread: threading.Thread | None = None
        self._start_lock = threading.Lock()
        self._worlds: OrderedDict[str, tuple[Any, Any, Any]] = OrderedDict()
        self._broken = ""

    def render(self, scene: Mapping[str, Any], state: Mapping[str, np.ndarray], camera: str,
               modality: str) -> np.ndarray:
        """One image of ``scene`` in ``state`` (``qpos``, ``qvel``, ``act`` of one frame).

        Raises:
            DatasetError: the scene has no ``spec``, or an unknown camera/modality.
            RenderError: no GL context could be made (the message says which packages to install).
        """
        if self._broken:
            raise RenderError(self._broken)
        if camera not in CAMERAS or modality not in MODALITIES:
            raise DatasetError(f"camera {camera!r} / modality {modality!r}: valid cameras {list(CAMERAS)}, "
                               f"modalities {list(MODALITIES)}")
        if not isinstance(scene.get("spec"), Mapping):
            raise DatasetError(f"scene {scene.get('image_index')}: has no 'spec' to rebuild its world from")
        self._ensure_thread()
        future: Future[np.ndarray] = Future()
        self._jobs.put(((scene, state, camera, modality), future))
        return future.result(timeout=self.timeout)

    def close(self) -> None:
        """Stop the worker thread and free its GL resources."""
        if self._thread is not None:
            self._jobs.put(None)
            self._thread.join(timeout=10)
            self._thread = None

    def _ensure_thread(self) -> None:
        with self._start_lock:
            if self._thread is None:
                self._thread = threading.Thread(target=self._work, name="samplehd-viewer-render", daemon=True)
                self._thread.start()

    def _work(self) -> None:
        while True:
            job = self._jobs.get()
            if job is None:
                break
            args, future = job
            if not future.set_running_or_notify_cancel():
                continue
            try:
                future.set_result(self._render_now(*args))
            except Exception as exc:  # noqa: BLE001 - hand every failure to the waiting request
                if isinstance(exc, RenderError):
                    self._broken = str(exc)
                future.set_exception(exc)
        for _, _, renderer in self._worlds.values():
            renderer.close()
        self._worlds.clear()

    def _world(self, scene: Mapping[str, Any]) -> tuple[Any, Any, Any]:
        key = json.dumps(scene["spec"], sort_keys=True)
        if key in self._worlds:
            self._worlds.move_to_end(key)
            return self._worlds[key]
        model, data = compile_scene(SceneSpec.from_dict(dict(scene["spec"])))
        world = (model, data, self.image.renderer(model))
        self._worlds[key] = world
        while len(self._worlds) > self.scenes_kept:
            self._worlds.popitem(last=False)[1][2].close()
        return world

    def _render_now(self, scene: Mapping[str, Any], state: Mapping[str, np.ndarray], camera: str,
                    modality: str) -> np.ndarray:
        model, data, renderer = self._world(scene)
        set_state(model, data, state["qpos"], state["qvel"], state.get("act"))
        return renderer.render(data, camera, (modality,))[modality]
