"""The sensor axis: noisy, blurred RGB and noisy, holed depth, applied to a suite episode's observations.

A suite episode of the ``sensor`` axis carries ``sensor``: ``rgb_noise`` (standard deviation of added
Gaussian noise [intensity levels of 255]), ``rgb_blur`` (standard deviation of a Gaussian blur [px]),
``depth_noise`` (standard deviation of added Gaussian noise [m]) and ``depth_holes`` (fraction of
depth pixels that read 0, as a structured-light camera's missing returns). The noise is drawn from
the episode's ``reset_seed``, so two evaluations see the same pixels.

``samplehd evaluate --suite`` applies it; a Gymnasium user wraps the env in :class:`SuiteSensor`,
which reads the same field when ``reset`` is given ``{"suite": ..., "episode": i}``. The environment
itself always renders clean images, and state observations are never changed.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import gymnasium as gym
import numpy as np

from samplehd.envs.observation import Observation
from samplehd.envs.suite_file import read_suite

__all__ = ["SuiteSensor", "corrupt_observation", "sensor_rng"]


def sensor_rng(reset_seed: int) -> np.random.Generator:
    """The generator of an episode's sensor noise."""
    return np.random.default_rng(np.random.SeedSequence([int(reset_seed), 5381]))


def _blur(image: np.ndarray, sigma: float) -> np.ndarray:
    """Separable Gaussian blur of an H×W×C float image (edges repeated)."""
    radius = max(1, int(np.ceil(3 * sigma)))
    x = np.arange(-radius, radius + 1, dtype=float)
    kernel = np.exp(-0.5 * (x / sigma) ** 2)
    kernel /= kernel.sum()
    out = image
    for axis in (0, 1):
        padded = np.pad(out, [(radius, radius) if a == axis else (0, 0) for a in range(out.ndim)], mode="edge")
        out = sum(k * np.take(padded, np.arange(i, i + out.shape[axis]), axis=axis) for i, k in enumerate(kernel))
    return out


def corrupt_observation(obs: Observation, sensor: Mapping[str, float] | None,
                        rng: np.random.Generator) -> Observation:
    """``obs`` with every ``*_rgb`` and ``*_depth`` image corrupted as ``sensor`` says (None: unchanged)."""
    out = dict(obs)
    if not sensor:
        return out
    for key, value in obs.items():
        if key.endswith("_rgb"):
            img = np.asarray(value, dtype=float)
            if sensor.get("rgb_blur", 0.0) > 0:
                img = _blur(img, float(sensor["rgb_blur"]))
            img = img + rng.normal(0.0, float(sensor.get("rgb_noise", 0.0)), img.shape)
            out[key] = np.clip(np.rint(img), 0, 255).astype(np.uint8)
        elif key.endswith("_depth"):
            depth = np.asarray(value, dtype=np.float32)
            depth = depth + rng.normal(0.0, float(sensor.get("depth_noise", 0.0)), depth.shape).astype(np.float32)
            depth[rng.random(depth.shape) < float(sensor.get("depth_holes", 0.0))] = 0.0
            out[key] = np.maximum(depth, 0.0).astype(np.float32)
    return out


class SuiteSensor(gym.Wrapper):
    """Applies a suite episode's ``sensor`` corruption to the observations of the episode it resets to."""

    def __init__(self, env: gym.Env) -> None:
        super().__init__(env)
        self._sensor: Mapping[str, float] | None = None
        self._rng = sensor_rng(0)

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None) -> tuple[Any, dict]:
        obs, info = self.env.reset(seed=seed, options=options)
        self._sensor = None
        if options and "suite" in options:
            episode = read_suite(options["suite"]).episode(options["episode"])
            self._sensor, self._rng = episode.sensor, sensor_rng(episode.reset_seed)
        return corrupt_observation(obs, self._sensor, self._rng), info

    def step(self, action: Any) -> tuple[Any, float, bool, bool, dict]:
        obs, reward, terminated, truncated, info = self.env.step(action)
        return corrupt_observation(obs, self._sensor, self._rng), reward, terminated, truncated, info
