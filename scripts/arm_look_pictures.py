"""Make docs/images/arm_looks.png: the arm's primitive and mesh looks side by side at three joint configurations.

    python scripts/arm_look_pictures.py docs/images/arm_looks.png [--width 320 --height 240]

Rows: primitive look (hd), mesh look (hd), mesh look (photo); columns: home, a reach to the side, a folded
configuration, each from a camera beside the arm, and a close-up of the gripper at home, half open.
"""

from __future__ import annotations

import samplehd  # noqa: F401  (sets MUJOCO_GL before mujoco is imported)

# isort: split
import argparse
from pathlib import Path

import mujoco
import numpy as np
from PIL import Image, ImageDraw

from samplehd.render.renderer import SceneRenderer
from samplehd.robot.constants import GRIPPER_FINGER_JOINTS, GRIPPER_STROKE, HOME_QPOS, JOINT_NAMES
from samplehd.scene.world import LAYOUT, CameraSpec, WorldConfig, compile_world

CONFIGURATIONS = (HOME_QPOS, np.array([0.5, -1.0, 1.2, -0.6, 1.2, 0.4]), np.array([2.0, -2.2, -1.4, 0.9, -0.7, 2.5]))
ROWS = (("primitive", "hd"), ("mesh", "hd"), ("mesh", "photo"))


def _label(img: np.ndarray, text: str) -> np.ndarray:
    im = Image.fromarray(img)
    d = ImageDraw.Draw(im)
    d.rectangle((0, 0, 7 * len(text) + 10, 16), fill=(0, 0, 0))
    d.text((5, 2), text, fill=(255, 255, 255))
    return np.asarray(im)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("out", type=Path)
    ap.add_argument("--width", type=int, default=320)
    ap.add_argument("--height", type=int, default=240)
    args = ap.parse_args()
    base = LAYOUT.robot_base_position
    camera = CameraSpec("beside", pos=tuple(base + [0.85, -1.45, 0.8]), target=tuple(base + [0.05, 0.0, 0.38]),
                        fovy=45.0)
    # the TCP at home is at world (0.05, 0, 1.10), the gripper pointing down
    close = CameraSpec("gripper", pos=(0.45, 0.22, 1.20), target=(0.05, 0.0, 1.17), fovy=30.0)
    rows = []
    for look, preset in ROWS:
        model, data = compile_world(config=WorldConfig(cameras=(camera, close), robot_look=look))
        qadr = [model.joint(j).qposadr[0] for j in JOINT_NAMES]
        tiles = []
        with SceneRenderer(model, args.width, args.height, preset) as r:
            for q in CONFIGURATIONS:
                data.qpos[qadr] = q
                mujoco.mj_forward(model, data)
                tiles.append(r.render(data, "beside")["rgb"])
            data.qpos[qadr] = HOME_QPOS
            data.qpos[[model.joint(j).qposadr[0] for j in GRIPPER_FINGER_JOINTS]] = GRIPPER_STROKE / 4
            mujoco.mj_forward(model, data)
            tiles.append(r.render(data, "gripper")["rgb"])
        tiles[0] = _label(tiles[0], f"{look}, {preset}")
        rows.append(np.concatenate(tiles, axis=1))
    Image.fromarray(np.concatenate(rows, axis=0)).save(args.out, optimize=True)


if __name__ == "__main__":
    main()
