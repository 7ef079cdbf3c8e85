"""Does a behaviour-cloning policy move like its demonstrations? Its actions on a dataset's test frames.

For every 8th frame of the test episodes, the trained policy (`samplehd train policy`, any format)
predicts a chunk from the recorded images, instruction and robot state; the script compares its
first action with the recorded steering vector: the mean magnitude per axis (linear x, y, z, angular
x, y, z, gripper) of both, and, on the frames where the demonstration moves the TCP (some linear
value above 0.2), the cosine between the predicted and the recorded TCP velocity. A policy trained
with the L1 loss predicts near-zero velocities (the median of values that are zero on most frames)
and a low cosine; the closed loop then barely moves.

usage: python scripts/baselines/bc_actions.py MODELS/policy DATASET [--json]
"""

from __future__ import annotations

import argparse
import json

import numpy as np

from samplehd.learn.data import open_dataset
from samplehd.learn.policy.configuration import CAMERAS
from samplehd.learn.policy.inference import BCPolicy

AXES = ("x", "y", "z", "rx", "ry", "rz", "gripper")


def compare(models: str, dataset: str, every: int = 8) -> dict[str, object]:
    policy = BCPolicy.load(models)
    reader = open_dataset(dataset)
    pred, demo = [], []
    for e in reader.episodes:
        if e.split != "test":
            continue
        ep = reader.episode(e.instruction_index)
        f = ep.frames
        steering, opening = np.asarray(f["steering"]), np.asarray(f["gripper_opening"])
        images = {c: np.asarray(ep.images[c]["rgb"][:]) for c in CAMERAS}
        text = reader.instruction(e.instruction_index)["instruction"]
        for t in range(0, len(steering), every):
            obs = {f"{c}_rgb": images[c][t] for c in CAMERAS}
            obs.update(instruction=text, gripper=np.array([opening[t] / 2, opening[t] / 2, 0.0]),
                       joint_pos=np.asarray(f["joint_pos"][t]), tcp_pos=np.asarray(f["tcp_pos"][t]),
                       tcp_quat=np.asarray(f["tcp_quat"][t]))
            pred.append(policy.predict(obs)[0])
            demo.append(steering[t])
    p, d = np.array(pred), np.array(demo)
    moving = np.abs(d[:, :3]).max(1) > 0.2
    cos = (p[moving, :3] * d[moving, :3]).sum(1) / (
        np.linalg.norm(p[moving, :3], axis=1) * np.linalg.norm(d[moving, :3], axis=1) + 1e-9)
    return {
        "frames": len(d), "moving_frames": int(moving.sum()),
        "mean_abs_predicted": dict(zip(AXES, np.abs(p).mean(0).round(3).tolist(), strict=True)),
        "mean_abs_demonstrated": dict(zip(AXES, np.abs(d).mean(0).round(3).tolist(), strict=True)),
        "velocity_cosine_mean": round(float(cos.mean()), 3) if moving.any() else None,
        "velocity_cosine_above_0.7": round(float((cos > 0.7).mean()), 3) if moving.any() else None,
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("models", help="the --out folder of `samplehd train policy`")
    ap.add_argument("dataset", help="the dataset (its test episodes are used)")
    ap.add_argument("--json", action="store_true", help="print one JSON object")
    args = ap.parse_args()
    r = compare(args.models, args.dataset)
    if args.json:
        print(json.dumps(r))
        return
    print(f"{r['frames']} test frames ({r['moving_frames']} moving)")
    print("axis        " + " ".join(f"{a:>8}" for a in AXES))
    for key in ("mean_abs_predicted", "mean_abs_demonstrated"):
        print(f"{key[9:]:<12}" + " ".join(f"{v:8.3f}" for v in r[key].values()))
    print(f"cosine of predicted and recorded TCP velocity (moving frames): mean {r['velocity_cosine_mean']}, "
          f"share above 0.7 {r['velocity_cosine_above_0.7']}")


if __name__ == "__main__":
    main()
