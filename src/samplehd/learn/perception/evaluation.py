"""How well perception does: instances matched to the ground truth, attribute accuracies, and the
test metrics of a trained model on a dataset.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from samplehd.errors import ConfigError
from samplehd.language.levels import HELD_OUT_CLASSES, held_out_object
from samplehd.learn.data import open_dataset, scene_examples
from samplehd.learn.perception.configuration import ATTRIBUTES, MIN_PIXELS
from samplehd.learn.perception.geometry import height_map
from samplehd.learn.perception.inference import Perception
from samplehd.learn.perception.preparation import load_scene_images
from samplehd.learn.training import Metrics, pick_device, timed

__all__ = ["evaluate_perception", "perception_test_metrics", "score_perception"]


def _match(pred: Sequence[np.ndarray], gt: Sequence[np.ndarray]) -> list[tuple[int, int, float]]:
    """Greedy one-to-one matching by IoU: (pred index, gt index, IoU) for pairs with IoU > 0."""
    pairs = []
    for i, p in enumerate(pred):
        for j, g in enumerate(gt):
            inter = np.logical_and(p, g).sum()
            if inter:
                pairs.append((inter / np.logical_or(p, g).sum(), i, j))
    used_p, used_g, out = set(), set(), []
    for iou, i, j in sorted(pairs, reverse=True):
        if i not in used_p and j not in used_g:
            used_p.add(i)
            used_g.add(j)
            out.append((i, j, float(iou)))
    return out


def evaluate_perception(model: Perception, scenes: Sequence[Mapping[str, Any]]) -> Metrics:
    """Mask IoU, detection F1 (IoU ≥ 0.5), attribute accuracy (per attribute and all four right, on
    detected objects) and position error [cm], over test scenes; attributes split by L1 objects and
    held-out ones."""
    ious, tp, n_pred, n_gt = [], 0, 0, 0
    rows: list[dict[str, Any]] = []
    gt_attr_rows: list[dict[str, Any]] = []
    for item in scenes:
        ann = item["annotation"]
        rgb, depth, seg = load_scene_images(item)
        height = height_map(depth, ann["camera"], model.table_height)
        masks = model.segment(rgb, depth, ann["camera"], height)
        found = model.classify(rgb, depth, masks, ann["camera"], height)
        objs = ann["objects"]
        gt_masks = [seg == o["segmentation_id"] for o in objs]
        matches = _match(masks, gt_masks)
        n_pred += len(masks)
        n_gt += len(objs)
        best = dict.fromkeys(range(len(objs)), 0.0)
        for i, j, iou in matches:
            best[j] = iou
            if iou >= 0.5:
                tp += 1
                o = objs[j]
                kind = "L4" if o["name"] in HELD_OUT_CLASSES else ("L2" if held_out_object(o) else "L1")
                err = float(np.linalg.norm(np.asarray(found[i]["position"][:2]) - np.asarray(o["3d_coords"][:2])))
                rows.append({"kind": kind, "error_cm": 100 * err,
                             **{a: found[i][a] == (o["name"] if a == "name" else o[a]) for a in ATTRIBUTES}})
        ious += list(best.values())
        # Attributes on ground-truth masks too: the classifier alone, without segmentation errors.
        visible = [j for j, g in enumerate(gt_masks) if g.sum() >= MIN_PIXELS]
        got = model.classify(rgb, depth, [gt_masks[j] for j in visible], ann["camera"], height)
        for j, f in zip(visible, got, strict=True):
            o = objs[j]
            kind = "L4" if o["name"] in HELD_OUT_CLASSES else ("L2" if held_out_object(o) else "L1")
            gt_attr_rows.append({"kind": kind, **{a: f[a] == (o["name"] if a == "name" else o[a])
                                                  for a in ATTRIBUTES}})

    def acc(rs: list[dict[str, str | float | bool]]) -> dict[str, float]:
        if not rs:
            return {"n": 0}
        out: dict[str, float] = {"n": len(rs), **{a: float(np.mean([r[a] for r in rs])) for a in ATTRIBUTES}}
        out["mean"] = float(np.mean([out[a] for a in ATTRIBUTES]))
        out["all_four"] = float(np.mean([all(r[a] for a in ATTRIBUTES) for r in rs]))
        return out

    prec = tp / n_pred if n_pred else 0.0
    rec = tp / n_gt if n_gt else 0.0
    seen = [r for r in rows if r["kind"] == "L1"]
    return {
        "mask_iou": float(np.mean(ious)) if ious else 0.0,
        "detection_precision": prec, "detection_recall": rec,
        "detection_f1": 2 * prec * rec / (prec + rec) if prec + rec else 0.0,
        "attributes_detected": acc(seen),
        "attributes_detected_by_level": {k: acc([r for r in rows if r["kind"] == k]) for k in ("L1", "L2", "L4")},
        "attributes_gt_masks": acc([r for r in gt_attr_rows if r["kind"] == "L1"]),
        "position_error_cm_median": float(np.median([r["error_cm"] for r in rows])) if rows else None,
        "position_error_cm_mean": float(np.mean([r["error_cm"] for r in rows])) if rows else None,
        "objects": n_gt,
        "scenes": len(scenes),
    }


def perception_test_metrics(model: Perception, scenes: Sequence[Mapping[str, Any]]) -> Metrics:
    """The ``test_*`` entries of a perception model's ``metrics.json`` (:func:`evaluate_perception`)."""
    m = evaluate_perception(model, scenes)
    return {
        "test_attribute_accuracy": m["attributes_detected"].get("mean"),
        "test_attribute_all_four": m["attributes_detected"].get("all_four"),
        "test_attribute_accuracy_by_attribute": {a: m["attributes_detected"].get(a) for a in ATTRIBUTES},
        "test_attribute_accuracy_gt_masks": m["attributes_gt_masks"].get("mean"),
        "test_attribute_accuracy_gt_masks_by_attribute": {a: m["attributes_gt_masks"].get(a) for a in ATTRIBUTES},
        "test_mask_iou": m["mask_iou"],
        "test_detection_f1": m["detection_f1"],
        "test_detection_precision": m["detection_precision"],
        "test_detection_recall": m["detection_recall"],
        "test_position_error_cm": m["position_error_cm_median"],
        "test_position_error_cm_mean": m["position_error_cm_mean"],
        "test_by_level": m["attributes_detected_by_level"],
        "test_scenes": m["scenes"],
        "test_objects": m["objects"],
    }


def score_perception(dataset: str | Path, models: str | Path, device: str | None = None) -> Metrics:
    """Test a trained perception model (the ``--out`` folder of ``samplehd train perception``) on a
    dataset's test scenes without training: the ``test_*`` metrics of ``metrics.json``, with the wall
    time and load average of the test (``test_wall_s``, ``test_load_average_1min``).

    Raises:
        ConfigError: no trained model in ``models``, no dataset (or test scenes) in ``dataset``, or
            scene images of another size than the model was trained on.
    """
    model = Perception.load(models, pick_device(device))
    data = scene_examples(open_dataset(dataset))
    if not data["test"]:
        raise ConfigError(f"dataset={dataset}: no test scenes (generate with a test split)", field="dataset")
    want = model.config.image
    cam = data["test"][0]["annotation"]["camera"]
    if (int(cam["width"]), int(cam["height"])) != (want.width, want.height):
        raise ConfigError(f"dataset={dataset}: scene images are {cam['width']}x{cam['height']}; the model in "
                          f"{models} was trained on {want.width}x{want.height}", field="dataset")
    with timed() as t:
        metrics = perception_test_metrics(model, data["test"])
    return {**metrics, **{f"test_{k}": v for k, v in t.items()}}
