"""Synthetic viewer test data: a small dataset in the layout of ``samplehd scenes`` +
``samplehd instructions`` (coloured rectangles, no rendering) and an episode store with synthetic
episodes and frames."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
from PIL import Image

from samplehd.viewer.index import DatasetIndex, FileState

__all__ = ["FakeEpisodeStore", "make_fake_dataset"]

WIDTH, HEIGHT = 320, 180
CLASSES = [("mug", "red", "ceramic"), ("bowl", "blue", "plastic"), ("plate", "white", "ceramic"),
           ("fork", "metallic", "metal"), ("soda_can", "green", "metal"), ("baking_tray", "black", "metal")]
FAMILIES = ["place", "stack", "pick_up"]


def _object(k: int, cls: tuple[str, str, str], box: tuple[int, int, int, int]) -> dict[str, Any]:
    name, colour, material = cls
    x0, y0, x1, y1 = box
    return {
        "name": name, "shape": name, "colour": colour, "color": colour, "material": material, "size": "medium",
        "table_part": ["left" if k % 2 == 0 else "right"], "3d_coords": [0.05 * k, -0.2 + 0.15 * k, 0.76],
        "rotation": 10.0 * k, "pixel_coords": [(x0 + x1) // 2, (y0 + y1) // 2, 1.4],
        "bbox": {"extents": [0.08, 0.08, 0.1]}, "footprint_half_extents": [0.04, 0.04], "segmentation_id": 3 + k,
        "affordances": {"graspable": True, "container": name in ("bowl", "mug")},
    }


def make_fake_dataset(root: Path, num_scenes: int = 4) -> Path:
    """Write a small dataset in the layout of ``samplehd scenes`` + ``samplehd instructions``.

    Scene i holds 3 objects drawn as coloured rectangles; its instructions cycle through
    place / stack / pick_up with CLEVR programs. Scene 3 (if any) is in the test split.
    """
    for folder in ("images", "depth", "segmentation", "scenes"):
        (root / folder).mkdir(parents=True, exist_ok=True)
    scenes, instructions = [], []
    for i in range(num_scenes):
        stem = f"SHD_{'test' if i == 3 else 'train'}_{i:06d}"
        ids = np.ones((HEIGHT, WIDTH), np.uint8)
        ids[: HEIGHT // 3] = 0
        rgb = np.full((HEIGHT, WIDTH, 3), 180, np.uint8)
        depth = np.full((HEIGHT, WIDTH), 1500, np.uint16)
        objects = []
        for k in range(3):
            cls = CLASSES[(i + k) % len(CLASSES)]
            box = (30 + 95 * k, 80, 90 + 95 * k, 150)
            ids[box[1]:box[3], box[0]:box[2]] = 3 + k
            rgb[box[1]:box[3], box[0]:box[2]] = (60 + 60 * k, 200 - 50 * k, 90 + 30 * i)
            depth[box[1]:box[3], box[0]:box[2]] = 1300 + 20 * k
            objects.append(_object(k, cls, box))
        Image.fromarray(rgb).save(root / "images" / f"{stem}.png")
        Image.fromarray(ids).save(root / "segmentation" / f"{stem}.png")
        Image.fromarray(depth).save(root / "depth" / f"{stem}.png")
        scene = {"split": "test" if i == 3 else "train", "image_index": i, "image_filename": f"{stem}.png",
                 "seed": 100 + i, "objects": objects, "relationships": {},
                 "camera": {"pos": [1.2, 0.0, 1.5], "fovy": 45.0},
                 "manipulator": {"joint_positions": [0.0] * 6, "tcp_position": [0.0, 0.0, 1.1]},
                 "segmentation_ids": {"background": 0, "table": 1, "robot": 2, "object_offset": 3}}
        (root / "scenes" / f"{stem}.json").write_text(json.dumps(scene))
        scenes.append(scene)
        for family in FAMILIES[: 2 + (i % 2)]:
            a, b = objects[0]["name"], objects[1]["name"]
            program = [{"type": "scene", "inputs": [], "value_inputs": []},
                       {"type": "filter_name", "inputs": [0], "value_inputs": [a]},
                       {"type": "unique", "inputs": [1], "value_inputs": []}]
            task: dict[str, Any] = {"type": family, "objects": [0], "subject": None, "relation": None}
            if family == "stack":
                program += [{"type": "scene", "inputs": [], "value_inputs": []},
                            {"type": "filter_name", "inputs": [3], "value_inputs": [b]},
                            {"type": "unique", "inputs": [4], "value_inputs": []},
                            {"type": "stack", "inputs": [2, 5], "value_inputs": []}]
                flat, text, task["subject"], targets = f"stack scene filter_name[{a}] scene filter_name[{b}]", \
                    f"Stack the {a} onto the {b}.", 1, [0, 1]
            elif family == "place":
                program.append({"type": "place", "inputs": [2], "value_inputs": ["left"]})
                flat, text, task["subject"], targets = f"place[left] scene filter_name[{a}]", \
                    f"Put the {a} on the left.", "left", [0]
            else:
                program.append({"type": "pick_up", "inputs": [2], "value_inputs": []})
                flat, text, targets = f"pick_up scene filter_name[{a}]", f"Pick up the {a}.", [0]
            slot = sum(1 for q in instructions if q["image_index"] == i)
            instructions.append({"split": scene["split"], "image_index": i, "image_filename": f"{stem}.png",
                                 "slot": slot,
                                 "instruction_index": len(instructions), "instruction": text, "family": family,
                                 "template_name": family, "task": task, "targets": targets, "program": program,
                                 "program_sequence": flat, "params": {}})
    (root / "scenes.json").write_text(json.dumps({"info": {"num_scenes": num_scenes}, "scenes": scenes}))
    (root / "instructions.json").write_text(json.dumps({"info": {}, "instructions": instructions}))
    return root


class FakeEpisodeStore:
    """Episode store with synthetic episodes (one per instruction of scenes 0 and 1) and images."""

    subtask_names = ("GripperMoveAvoid", "ApproachGrasp", "CloseGripper", "MoveUP", "ObjectMove", "MoveDOWN",
                     "OpenGripper", "MoveToDefaultPos")

    def __init__(self, index: DatasetIndex, frames: int = 40) -> None:
        self.index = index
        self.frames = frames
        instructions, _ = index.instructions()
        self.items = [q for q in instructions if q["image_index"] in (0, 1)]

    def state(self) -> FileState:
        return FileState("episodes", "ok")

    def summaries(self) -> list[dict[str, Any]]:
        return [{"episode": self.name(k), "scene_index": q["image_index"], "slot": q["slot"],
                 "instruction_index": q["instruction_index"],
                 "instruction": q["instruction"], "family": q["family"], "success": k != 1,
                 "failure_reason": "" if k != 1 else "object_dropped", "num_frames": self.frames}
                for k, q in enumerate(self.items)]

    def name(self, k: int) -> str:
        q = self.items[k]
        return f"s{q['image_index']:06d}_{q['slot']:02d}"

    def _number(self, name: str) -> int:
        from samplehd.errors import DatasetError

        for k in range(len(self.items)):
            if self.name(k) == name:
                return k
        raise DatasetError(f"episode {name}: not in the dataset")

    def count(self) -> int:
        return len(self.items)

    def rejections(self) -> list[dict[str, Any]]:
        return [{"scene_index": 2, "slot": 1, "reason": "no_feasible_grasp", "message": "no grasp of object 1"}]

    def version(self, name: str) -> int:
        return 0

    def detail(self, name: str) -> dict[str, Any]:
        k = self._number(name)
        t = np.arange(self.frames) / 20.0
        sub = np.minimum((np.arange(self.frames) * len(self.subtask_names)) // self.frames, 7)
        segments, start = [], 0
        for f in range(1, self.frames + 1):
            if f == self.frames or sub[f] != sub[start]:
                segments.append({"start": start, "end": f, "index": int(sub[start]),
                                 "name": self.subtask_names[sub[start]], "target": 0})
                start = f
        joint = np.stack([np.sin(t + j) for j in range(6)], axis=1)
        return {**self.summaries()[k], "control_hz": 20.0, "subtasks": list(self.subtask_names),
                "segments": segments, "cameras": {"operator": ["rgb", "depth", "segmentation"]},
                "series": {"time": t.tolist(), "subtask_index": sub.tolist(), "joint_pos": joint.tolist(),
                           "joint_names": [f"joint_{j}" for j in range(6)],
                           "gripper_opening": (0.04 + 0.04 * np.cos(t)).tolist(),
                           "gripper_command": np.sign(np.cos(t)).tolist(),
                           "steering": np.clip(np.stack([np.sin(2 * t + j) for j in range(7)], 1), -1, 1).tolist(),
                           "tcp_pos": np.stack([0.1 * np.sin(t), 0.2 * np.cos(t), 0.9 + 0 * t], 1).tolist(),
                           "object_pos": np.tile([[0.0, -0.2, 0.76], [0.1, 0.0, 0.76], [0.2, 0.2, 0.76]],
                                                 (self.frames, 1, 1)).tolist(),
                           "grasped_object": [-1] * self.frames, "target_object": [0] * self.frames,
                           "safety_event": [0] * self.frames},
                "layout": {"table_size": [1.0, 1.4], "robot_base": [-0.4, 0.0], "workspace_min": [-0.15, -0.4],
                           "workspace_max": [0.3, 0.4], "workspace_center": [0.075, 0.0], "band": 0.06},
                "previous": self.name(k - 1) if k > 0 else None,
                "next": self.name(k + 1) if k + 1 < len(self.items) else None,
                "info": {"checker": {"success": k != 1}}}

    def frame(self, name: str, t: int, camera: str, modality: str) -> np.ndarray:
        from samplehd.errors import DatasetError

        k = self._number(name)
        if not 0 <= t < self.frames:
            raise DatasetError(f"episode {k}: frame {t} outside 0..{self.frames - 1}")
        if modality == "depth":
            return np.full((HEIGHT, WIDTH), 1.0 + t / 100.0, np.float32)
        if modality == "segmentation":
            ids = np.zeros((HEIGHT, WIDTH), np.int32)
            ids[50:100, 4 * t: 4 * t + 30] = 3
            return ids
        rgb = np.full((HEIGHT, WIDTH, 3), 200, np.uint8)
        rgb[50:100, 4 * t: 4 * t + 30] = (200, 30, 30)
        return rgb
