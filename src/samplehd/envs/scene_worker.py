"""A child process that samples scenes, so that the process asking for them makes no GL context.

Scene sampling renders an occlusion check; a GL context made in a process that later imports torch
(whose triton import then crashes the process) or forks is a hazard for state-only users. The child
is a plain ``python -m samplehd.envs.scene_worker`` (not ``multiprocessing``, which would re-run the
user's main script), speaks one JSON line per request on stdin/stdout and lives as long as its parent.
"""

from __future__ import annotations

import json
import subprocess
import sys
import threading
from typing import Any

from samplehd.errors import SceneError
from samplehd.scene.config import SceneConfig
from samplehd.scene.sampler import sample_scene
from samplehd.scene.spec import SceneSpec

__all__ = ["SceneWorker", "sample_in_child"]


class SceneWorker:
    """The child process and its pipes (started on first use)."""

    def __init__(self) -> None:
        self._proc: subprocess.Popen[str] | None = None
        self._lock = threading.Lock()

    def sample(self, index: int, seed: int, config: SceneConfig) -> SceneSpec:
        """``sample_scene(index, seed, config).scene``, computed in the child."""
        request = json.dumps({"index": int(index), "seed": int(seed), "config": config.to_dict()})
        with self._lock:
            if self._proc is None or self._proc.poll() is not None:
                self._proc = subprocess.Popen([sys.executable, "-m", "samplehd.envs.scene_worker"],
                                              stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
            assert self._proc.stdin is not None and self._proc.stdout is not None
            self._proc.stdin.write(request + "\n")
            self._proc.stdin.flush()
            line = self._proc.stdout.readline()
        if not line:
            raise SceneError(f"scene {index} (seed {seed}): the scene sampling process ended unexpectedly")
        reply = json.loads(line)
        if "error" in reply:
            raise SceneError(reply["error"])
        return SceneSpec.from_dict(reply["scene"])

    def close(self) -> None:
        if self._proc is not None and self._proc.poll() is None:
            self._proc.stdin.close()  # type: ignore[union-attr]
            self._proc.wait(timeout=10)
        self._proc = None


_WORKER = SceneWorker()


def sample_in_child(index: int, seed: int, config: SceneConfig) -> SceneSpec:
    """Sample a scene in the shared child process (started on first use)."""
    return _WORKER.sample(index, seed, config)


def _serve() -> None:
    for line in sys.stdin:
        req = json.loads(line)
        try:
            scene = sample_scene(req["index"], req["seed"], SceneConfig.from_dict(req["config"])).scene
            reply: dict[str, Any] = {"scene": scene.to_dict()}
        except SceneError as exc:
            reply = {"error": str(exc)}
        sys.stdout.write(json.dumps(reply) + "\n")
        sys.stdout.flush()


if __name__ == "__main__":
    _serve()
