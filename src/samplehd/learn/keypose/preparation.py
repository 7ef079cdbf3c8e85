"""The keypose policy's training samples: every decision of the dataset's episodes
(:func:`samplehd.learn.keypose.processing.decisions`) is one sample, the top-down grid of the scene
camera's RGB-D image it was made on with the instruction; the labels are where to grasp and where the
object goes.

The first decision of an episode is made on the dataset's scene image; a later one (after an object
was moved) on the scene camera's image of the recorded state at that frame, drawn with the renderer
the policy runs with. The prepared samples are kept in ``--out/prepared.npz`` until the run ends, so a
resumed run does not draw them again.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import mujoco
import numpy as np
from PIL import Image
from rich.console import Console
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn, TimeRemainingColumn

from samplehd.dataset.validate import validate_scene_files, validate_stored_config
from samplehd.envs.replay_check import replay_env
from samplehd.envs.tokens import encode_instruction
from samplehd.errors import ConfigError
from samplehd.learn.keypose.configuration import KEYPOSE_ATTRIBUTES, KeyposeGrid
from samplehd.learn.keypose.processing import (
    FACTOR,
    LABELS,
    SCENE_MODALITIES,
    attribute_maps,
    attribute_values,
    decisions,
    grid_of,
    input_channels,
    keypose_targets,
    scene_grid,
    task_cells,
)
from samplehd.render.renderer import SEG_ROBOT, SceneRenderer
from samplehd.world.layout import LAYOUT

__all__ = ["PREPARED_FILE", "check_scene_inputs", "prepare_samples"]

PREPARED_FILE = "prepared.npz"


def _episode_samples(reader: Any, k: int, env: Any, config: KeyposeGrid, tokens_len: int,
                     renderers: dict[str, Any], values: Mapping[str, list[str]], inputs: str = "rgb"
                     ) -> list[tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, int]]:
    """(grid, tokens, labels, attribute maps, objects put down before it) of each decision of episode
    ``k`` (``inputs="state"``: the grid with the cells of the objects the task moves marked)."""
    meta = reader.episode_meta(k)
    if not meta.success:
        return []
    fr = reader.frames(k, ["subtask_index", "tcp_pos", "tcp_quat", "gripper_opening", "qpos", "qvel"])
    ds = decisions(meta.subtasks, fr["subtask_index"], fr["tcp_pos"], fr["tcp_quat"], fr["gripper_opening"])
    if not ds:
        return []
    grid = grid_of(config)
    tokens = encode_instruction(meta.instruction or "", tokens_len)
    entry = reader.episodes[k]
    scene = reader.scene(entry.scene_index)
    out = []
    placed = 0
    for d in ds:
        if d.frame == 0 and scene["camera"]["width"] == config.width and scene["camera"]["height"] == config.height:
            stem = Path(scene["image_filename"]).stem
            rgb = np.asarray(Image.open(reader.root / "images" / f"{stem}.png").convert("RGB"))
            depth = np.load(reader.root / "depth" / f"{stem}.npy", allow_pickle=False).astype(np.float32)
            seg = np.asarray(Image.open(reader.root / "segmentation" / f"{stem}.png"))
            image, ids = grid.project_with_labels(rgb, seg, depth, scene["camera"], LAYOUT.table_height,
                                                  robot=seg == SEG_ROBOT)
        else:
            # the reader already open (a reset from the dataset's folder would parse its index files again)
            env.reset(options={"scene": scene, "instruction": reader.instruction(k),
                               "episode": reader.episode(k, images="none")})
            u = env.unwrapped
            u.data.qpos[:] = fr["qpos"][d.frame]
            u.data.qvel[:] = fr["qvel"][d.frame]
            mujoco.mj_forward(u.model, u.data)
            key = str(id(u.model))
            if key not in renderers:
                for r in renderers.values():
                    r.close()
                renderers.clear()
                renderers[key] = SceneRenderer(u.model, config.width, config.height, "fast")
                renderers[key].render(u.data, config.camera, SCENE_MODALITIES)  # a context's first frame differs
            image, ids = scene_grid(renderers[key], u.model, u.data, config, with_ids=True)
        if inputs == "state":
            image = np.concatenate([image, task_cells(ids, reader.instruction(k)["task"]["objects"])[None]])
        out.append((image.astype(np.float16), tokens, keypose_targets(d, grid), attribute_maps(ids, scene, values),
                    placed))
        placed += d.release
    return out


def check_scene_inputs(reader: Any) -> None:
    """Refuse, before anything is written, a dataset whose stored config, scene cameras or scene images
    (decoded, of the camera's size) the preparation reads and would fail on: the first problem in one
    line (``samplehd validate --deep`` lists them all).

    Raises:
        ConfigError: ``dataset=DIR: FILE: what is wrong``.
    """
    problems = validate_stored_config(reader.root, reader.info) + validate_scene_files(reader.root, reader.scenes,
                                                                                        deep=True, info=reader.info)
    if problems:
        more = f" (and {len(problems) - 1} more: samplehd validate --deep lists them)" if len(problems) > 1 else ""
        raise ConfigError(f"dataset={reader.root}: {problems[0]}{more}", field="dataset")


def prepare_samples(reader: Any, ks: Sequence[int], config: KeyposeGrid, tokens_len: int,
                    inputs: str = "rgb", label: str = "prepare", quiet: bool = True,
                    values: Mapping[str, list[str]] | None = None) -> dict[str, np.ndarray]:
    """The samples of episodes ``ks``: every decision's top-down view, instruction tokens, keypose
    targets, attribute maps and the count of objects its episode put down before it (a progress bar
    per episode on stderr unless ``quiet``). ``values``: the attribute values the maps index (default:
    those of the dataset's scenes; of every dataset trained on together when there are several)."""
    env = replay_env(reader)
    renderers: dict[str, Any] = {}
    values = attribute_values(reader.scenes) if values is None else values
    grids, toks, labels, attrs, episodes, placed = [], [], [], [], [], []
    # Drawing the samples renders every later decision's view: minutes on a large dataset, shown per episode.
    bars = Progress(TextColumn("{task.description:>12}"), BarColumn(), MofNCompleteColumn(), TextColumn("episodes"),
                    TimeElapsedColumn(), TimeRemainingColumn(), console=Console(stderr=True, quiet=quiet),
                    disable=quiet)
    try:
        with bars:
            task = bars.add_task(label, total=len(ks))
            for k in ks:
                for g, t, y, a, n in _episode_samples(reader, k, env, config, tokens_len, renderers, values,
                                                       inputs):
                    if y[12] > 0:
                        grids.append(g)
                        toks.append(t)
                        labels.append(y)
                        attrs.append(a)
                        episodes.append(k)
                        placed.append(n)
                bars.advance(task)
    finally:
        for r in renderers.values():
            r.close()
        env.close()
    if not grids:
        return {"grid": np.zeros((0, input_channels(inputs), config.rows, config.cols), np.float16),
                "tokens": np.zeros((0, tokens_len), np.int64), "labels": np.zeros((0, LABELS), np.float32),
                "attributes": np.zeros((0, len(KEYPOSE_ATTRIBUTES), config.rows // FACTOR, config.cols // FACTOR),
                                       np.int8),
                "episode": np.zeros(0, np.int64), "placed": np.zeros(0, np.int64)}
    return {"grid": np.stack(grids), "tokens": np.stack(toks), "labels": np.stack(labels),
            "attributes": np.stack(attrs), "episode": np.array(episodes, np.int64),
            "placed": np.array(placed, np.int64)}
