"""An episode unit draws each state while its path is still being recorded: the same file as drawing the
finished episode, and nothing left running, whether the path succeeds or is rejected."""

from __future__ import annotations

import threading
from pathlib import Path

import h5py
import numpy as np
import pytest

from samplehd.bench.paths import _bench_scene
from samplehd.dataset.container import read_frames
from samplehd.dataset.layout import EPISODE_DIR
from samplehd.dataset.render import RenderConfig
from samplehd.dataset.work import EpisodeUnit, run_episode_unit
from samplehd.motion.assist import compile_scene_with_assist
from samplehd.record.paths import PathConfig, plan_and_execute
from samplehd.render.renderer import MODALITIES
from samplehd.render.states import LiveStates
from samplehd.tasks.task import Task
from samplehd.world.layout import DIRECTIONS

pytestmark = pytest.mark.render

TASK = Task("place", (1,), part="left")


def _unit(out: Path, render: RenderConfig, task: Task = TASK, name: str = "e.h5") -> EpisodeUnit:
    (out / EPISODE_DIR).mkdir(exist_ok=True)
    return EpisodeUnit(str(out), name, 0, 3, 3, "place", task, "put the soda can on the left", "train",
                       _bench_scene(), {k: list(v) for k, v in DIRECTIONS.items()}, PathConfig(), render)


def _helpers_left() -> list[threading.Thread]:
    return [t for t in threading.enumerate() if t.name.startswith(("samplehd-path", "samplehd-frames"))]


def _chunks(path: Path) -> dict[str, list[bytes]]:
    out = {}
    with h5py.File(path, "r") as f:
        for cam in f["images"]:
            for mod, ds in f["images"][cam].items():
                out[f"{cam}/{mod}"] = [ds.id.read_direct_chunk((t,) + (0,) * (ds.ndim - 1))[1]
                                       for t in range(ds.shape[0])]
    return out


def test_images_drawn_beside_the_path_are_those_of_the_finished_episode(tmp_path: Path) -> None:
    render = RenderConfig("fast", 48, 32, ("operator", "wrist"), MODALITIES)
    done = run_episode_unit(_unit(tmp_path, render))
    assert done.ok and not _helpers_left()
    assert done.path_seconds > 0 and done.render_seconds > 0 and done.path_cpu_seconds > 0
    path = tmp_path / EPISODE_DIR / "e.h5"
    frames = read_frames(path, ("qpos", "qvel", "act", "time"))
    model, _ = compile_scene_with_assist(_bench_scene())
    after = render.images(model, frames, deflated=True)  # the finished episode's states, drawn afterwards
    beside = _chunks(path)
    assert len(beside["operator/rgb"]) == done.num_frames == len(frames["qpos"]) > 100
    for key, chunks in beside.items():
        cam, mod = key.split("/")
        assert chunks == after[cam][mod].chunks, key
    # With keyframes the images are drawn after the path (which frames they are depends on all of it): the
    # same frames again.
    sparse = run_episode_unit(_unit(tmp_path, RenderConfig("fast", 48, 32, ("operator", "wrist"), MODALITIES,
                                                           every=2), name="k.h5"))
    assert sparse.ok
    kept = _chunks(tmp_path / EPISODE_DIR / "k.h5")
    assert kept["wrist/depth"] == beside["wrist/depth"][::2]


def test_a_rejected_path_leaves_no_images_no_file_and_no_thread(tmp_path: Path) -> None:
    render = RenderConfig("fast", 32, 24, ("operator",), ("rgb",))
    done = run_episode_unit(_unit(tmp_path, render, task=Task("place", (9,), part="left")))
    assert done.status == "rejected" and "objects 0..3" in done.message
    # Its journal record: what a rejection by an error has (no attempts counted), nothing of an ok episode.
    assert set(done.to_dict()) == {"scene_index", "slot", "status", "reason", "message", "seconds", "cpu_seconds"}
    assert not list((tmp_path / EPISODE_DIR).iterdir()) and not _helpers_left()


def test_the_path_restarts_its_live_states_at_every_attempt_and_finishes_them() -> None:
    scene = _bench_scene()
    live = LiveStates()
    ep = plan_and_execute(scene, TASK, np.random.default_rng(3), compiled=compile_scene_with_assist(scene),
                          live=live)
    assert live.attempts == ep.info["attempts"] >= 1
    attempt = live.next_attempt()
    assert attempt == live.attempts
    states = list(live.states(attempt))
    assert len(states) == ep.num_frames
    for k, (qpos, qvel, act, t) in enumerate(states):
        assert np.array_equal(qpos, ep.frames["qpos"][k]) and np.array_equal(qvel, ep.frames["qvel"][k])
        assert np.array_equal(act, ep.frames["act"][k]) and t == ep.frames["time"][k]
