"""Training data of the behaviour-cloning policy: a dataset's episodes, or episodes collected in the
environment, as arrays of samples (states, labels, images, instruction tokens), and the collected
episodes kept beside the model (``.npz``).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from samplehd.dataset.container import camera_settings
from samplehd.envs.tokens import encode_instruction
from samplehd.errors import ConfigError
from samplehd.learn.actions import moving_frames, waypoint_targets, waypoints
from samplehd.learn.policy.configuration import CAMERAS
from samplehd.learn.policy.processing import policy_state, seen_joint_velocities, target_features

__all__ = ["collected_arrays", "episode_arrays", "image_size", "inputs_state", "load_arrays", "save_arrays"]




def episode_arrays(reader: Any, k: int, stride: int, tokens_len: int, cameras: Sequence[str] = CAMERAS,
                    action: str = "steering") -> dict[str, np.ndarray]:
    """One episode's training arrays, its waits left out (:func:`moving_frames`).

    ``steering`` and ``state`` are the kept frames in order (a chunk's targets are the next kept
    frames' actions); ``frames`` are the positions in them that serve as samples (every
    ``stride``-th), and the images are those samples' frames.
    """
    ep = reader.episode(k)
    f = ep.frames
    steering = np.asarray(f["steering"], np.float32)
    labels, keep = action_labels(action, steering, np.asarray(f["tcp_pos"]), np.asarray(f["tcp_quat"]),
                           np.asarray(f["gripper_opening"]))
    last_gripper = np.r_[1.0, steering[:-1, 6]]
    state = policy_state(np.asarray(f["joint_pos"]), np.asarray(f["tcp_pos"]), np.asarray(f["tcp_quat"]),
                   np.asarray(f["gripper_opening"]), seen_joint_velocities(action, f["joint_vel"]), last_gripper)
    t = np.arange(0, len(keep), stride)
    tcp = np.asarray(f["tcp_pos"])
    target = target_features(tcp, f["object_pos"], f["object_quat"], f["target_object"])
    return {
        "frames": t, "steering": labels, "state": state[keep], "target": target[keep],
        "z": tcp[keep, 2].astype(np.float64),
        **{c: np.asarray(ep.images[c]["rgb"][:])[keep[t]] for c in cameras},
        "tokens": encode_instruction(reader.instruction(k)["instruction"], tokens_len),
    }


def action_labels(action: str, steering: np.ndarray, tcp_pos: np.ndarray, tcp_quat: np.ndarray, opening: np.ndarray
            ) -> tuple[np.ndarray, np.ndarray]:
    """An episode's training labels and the frames they belong to: the steering vectors of every frame
    but the waits (:func:`moving_frames`), or every frame's waypoint target (:func:`waypoints`)."""
    if action == "waypoint":
        goal = waypoints(steering, tcp_pos, tcp_quat, opening)
        return waypoint_targets(goal, tcp_pos, tcp_quat), np.arange(len(steering))
    keep = moving_frames(steering)
    return np.asarray(steering, np.float32)[keep], keep


def image_size(reader: Any, dataset: str | Path) -> int:
    """The side of the dataset's square scene and wrist camera RGB images; one-line errors."""
    # A dataset still being written (or stopped early) has its render settings only in the config.
    render = reader.info.get("render") or reader.config.get("render") or {}
    cams = camera_settings(render) if render else {}
    if not all(c in cams and "rgb" in cams[c]["modalities"] for c in CAMERAS):
        raise ConfigError(f"dataset={dataset}: episodes need RGB of cameras {', '.join(CAMERAS)} (generate it with "
                          "render.mode fast, render.cameras [scene, wrist], render.modalities [rgb])",
                          field="dataset")
    sizes = {(cams[c]["width"], cams[c]["height"]) for c in CAMERAS}
    if len(sizes) != 1 or next(iter(sizes))[0] != next(iter(sizes))[1]:
        raise ConfigError(f"dataset={dataset}: the cameras need one square image size; found {sorted(sizes)}",
                          field="dataset")
    return int(next(iter(sizes))[0])


def collected_arrays(raw: Mapping[str, Any], stride: int, tokens_len: int, cameras: Sequence[str] = CAMERAS,
                      action: str = "steering") -> dict[str, np.ndarray]:
    """A collected episode (:func:`samplehd.learn.demos.collect`) as :func:`episode_arrays` gives one."""
    grip = np.asarray(raw["gripper"], np.float64)
    if "goal" in raw:  # a waypoint DAgger episode: labelled with the expert's waypoints
        labels = waypoint_targets(raw["goal"], raw["tcp_pos"], raw["tcp_quat"])
        keep = np.arange(len(labels))
    else:
        labels, keep = action_labels(action, np.asarray(raw["label"], np.float32), np.asarray(raw["tcp_pos"]),
                               np.asarray(raw["tcp_quat"]), grip[:, 0] + grip[:, 1])
    last_gripper = np.r_[1.0, np.asarray(raw["executed"], np.float64)[:-1, 6]]
    state = policy_state(raw["joint_pos"], raw["tcp_pos"], raw["tcp_quat"], grip[:, 0] + grip[:, 1],
                   seen_joint_velocities(action, raw["joint_vel"]), last_gripper)
    t = np.arange(0, len(keep), stride)
    target = target_features(raw["tcp_pos"], raw["object_pos"], raw["object_quat"], raw["target_object"])
    return {"frames": t, "steering": labels, "state": state[keep], "target": target[keep],
            "z": np.asarray(raw["tcp_pos"], np.float64)[keep, 2],
            **{c: np.asarray(raw[c])[keep[t]] for c in cameras},
            "tokens": encode_instruction(str(raw["instruction"]), tokens_len)}


def save_arrays(path: Path, episodes: Sequence[Mapping[str, np.ndarray]]) -> None:
    """Collected episodes' arrays in one ``.npz`` (plain arrays, read with ``allow_pickle=False``)."""
    tmp = path.with_name(f".{path.name}.tmp.npz")
    np.savez_compressed(tmp, count=np.array(len(episodes)),
             **{f"{n}/{k}": v for n, e in enumerate(episodes) for k, v in e.items()})
    tmp.replace(path)


def load_arrays(path: Path) -> list[dict[str, np.ndarray]]:
    try:
        with np.load(path, allow_pickle=False) as z:
            out: list[dict[str, np.ndarray]] = [{} for _ in range(int(z["count"]))]
            for name in z.files:
                if name != "count":
                    n, key = name.split("/", 1)
                    out[int(n)][key] = z[name]
            return out
    except (OSError, KeyError, ValueError, IndexError) as exc:
        raise ConfigError(f"{path}: not readable collected episodes ({exc}); delete it to collect them again") from None


def inputs_state(arrays: Mapping[str, np.ndarray], inputs: str, t: Any = slice(None)) -> np.ndarray:
    """The state the network sees at frame(s) ``t``: the robot's, and the target's for ``inputs="state"``."""
    if inputs == "state":
        return np.concatenate([arrays["state"][t], arrays["target"][t]], axis=-1)
    return arrays["state"][t]
