"""Training a perception model on a dataset (``samplehd train perception``).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from samplehd.learn.data import open_dataset, scene_examples
from samplehd.learn.perception.configuration import (
    ATTRIBUTES,
    CROP,
    CROP_VIEWS,
    FORMAT,
    N_FEATURES,
    PREPARED_FILE,
    PerceptionConfig,
    PerceptionImage,
    PerceptionTraining,
    attribute_vocab,
    kind_vocab,
)
from samplehd.learn.perception.evaluation import perception_test_metrics
from samplehd.learn.perception.inference import Perception
from samplehd.learn.perception.preparation import prepare_perception, prepared_arrays, size_templates
from samplehd.learn.training import F, Metrics, TrainRun, descend, pick_device, set_seed, step_rng, timed, torch
from samplehd.world.layout import LAYOUT

__all__ = ["train_perception"]


def train_perception(dataset: str | Path, out: str | Path, config: PerceptionConfig, *, device: str | None = None,
                     quiet: bool = False, stop_after: int | None = None) -> Metrics:
    """Train segmentation and attribute networks on a dataset's training scenes; test on its test scenes.

    Metrics (``metrics.json``): ``test_mask_iou`` (mean best IoU per ground-truth object),
    ``test_detection_f1``, ``test_attribute_accuracy`` (mean of the four attribute accuracies on
    detected objects of seen classes and combinations), ``test_attribute_all_four``,
    ``test_position_error_cm`` (median, ground plane) and held-out (L2, L4) figures.

    What the dataset says is filled in: its path, the attribute and kind vocabularies (of its
    catalogue), its scene images' size and the segmenter's downsampling, the table height, the
    training objects' extents and size templates, and the counts of training scenes and objects.

    Args:
        dataset: a dataset folder written by ``samplehd generate``.
        out: the output folder (resumed when it holds a checkpoint).
        config: the perception model to train.
        device: torch device (default: cuda when present, else cpu).
        quiet: no progress bar.
        stop_after: stop after this many steps (a checkpoint stays; for tests of resuming).

    Returns:
        The metrics written to ``metrics.json`` (``{"stopped_at": N}`` when stopped early).
    """
    reader = open_dataset(dataset)
    data = scene_examples(reader)
    vocab = attribute_vocab()
    kinds = kind_vocab(reader.catalogue)  # shop-vrb: its variants
    width = int(data["train"][0]["annotation"]["camera"]["width"])
    height = int(data["train"][0]["annotation"]["camera"]["height"])
    factor = 2 if width >= 400 else 1
    dev = pick_device(device)
    steps, seed = config.train.steps, config.train.seed
    set_seed(seed)
    key = {"format": FORMAT, "features": N_FEATURES, "dataset": str(Path(dataset).resolve()), "factor": factor,
           "crop": CROP, "views": CROP_VIEWS, "seed": seed, "table_height": LAYOUT.table_height,
           "scenes": [str(Path(item["rgb"]).name) for item in data["train"]], "vocab": vocab, "kinds": kinds}
    with timed() as prep_time:
        arrays = prepared_arrays(Path(out), key, lambda: prepare_perception(data["train"], vocab, kinds, factor,
                                                                  LAYOUT.table_height, seed, quiet))
    config = replace(
        config,
        dataset=str(dataset),
        attributes=vocab,
        kinds=tuple(kinds),
        image=PerceptionImage(camera="scene", width=width, height=height),
        seg_downsample=factor,
        table_height=LAYOUT.table_height,
        extents=arrays["extents"],
        size_templates=size_templates(arrays["geo"], arrays["labels"][:, len(ATTRIBUTES)], kinds),
        train=replace(config.train, scenes=len(data["train"]), objects=len(arrays["labels"])),
    )
    model = Perception(config, device=dev)
    net = model.net
    opt = torch.optim.Adam(net.parameters(), lr=config.train.lr)
    run = TrainRun(Path(out), config.to_dict(), steps, checkpoint_every=max(50, steps // 10), quiet=quiet,
                   stop_after=stop_after)
    run.prepare()
    losses, t = run.train(net, opt, _train_step(net, opt, arrays, config.train, dev), "perception")
    if run.stopped:
        return {"stopped_at": len(losses)}
    net.eval()
    metrics = {
        **perception_test_metrics(model, data["test"]),
        "train_scenes": len(data["train"]),
        "train_objects": len(arrays["labels"]),
        "train_loss": float(np.mean(losses[-50:])) if losses else None,
        "prepare_s": prep_time["wall_s"],
        "steps": steps,
        "seed": seed,
        "device": str(dev),
        **t,
    }
    run.finish(net, metrics)
    (Path(out) / PREPARED_FILE).unlink(missing_ok=True)  # only a resumed run needs it
    return metrics

def _train_step(net: Any, opt: Any, arrays: Mapping[str, Any], tr: PerceptionTraining, dev: Any) -> Any:
    """The optimiser step ``step`` of the run (``tr``: the config's training options): a segmenter
    batch every ``tr.seg_every`` steps, an attribute batch every step, the learning rate decaying
    linearly over the last two thirds."""
    seed, lr, steps, seg_batch, attr_batch, patch, seg_every = (tr.seed, tr.lr, tr.steps, tr.seg_batch,
                                                                tr.attr_batch, tr.patch, tr.seg_every)
    seg_weight = torch.tensor([1.0, 1.0, 3.0, 6.0], device=dev)
    rgb_all, dh_all, y_all = arrays["rgb"], arrays["dh"], arrays["y"]
    hh, ww = y_all.shape[1], y_all.shape[2]
    ph, pw = min(patch, hh), min(patch, ww)
    n_obj = len(arrays["labels"])

    def _seg_loss(rng: np.random.Generator) -> Any:
        """Cross-entropy of the segmenter on random patches (flipped left-right half of the time)."""
        idx = rng.integers(len(y_all), size=seg_batch)
        r0 = rng.integers(hh - ph + 1, size=seg_batch)
        c0 = rng.integers(ww - pw + 1, size=seg_batch)
        win = list(zip(idx, r0, c0, strict=True))
        xb = np.concatenate([np.stack([rgb_all[i, :, r:r + ph, c:c + pw] for i, r, c in win]).astype(np.float32) / 255,
                             np.stack([dh_all[i, :, r:r + ph, c:c + pw] for i, r, c in win]).astype(np.float32)], 1)
        yb = np.stack([y_all[i, r:r + ph, c:c + pw] for i, r, c in win])
        flip = rng.random(seg_batch) < 0.5
        xb[flip] = xb[flip][..., ::-1]
        yb[flip] = yb[flip][..., ::-1]
        xt = torch.as_tensor(np.ascontiguousarray(xb), device=dev)
        yt = torch.as_tensor(yb.astype(np.int64), device=dev)
        return F.cross_entropy(net.segmenter(xt), yt, weight=seg_weight)

    def train_step(step: int) -> float:
        net.train()
        rng = step_rng(seed, step)
        for g in opt.param_groups:
            g["lr"] = lr * min(1.0, 1.5 * (1 - step / steps))
        seg_loss = torch.zeros((), device=dev)
        if step % seg_every == 0:  # a segmenter step costs several attribute steps; it needs fewer
            seg_loss = _seg_loss(rng)
        # attributes: one of each object's views, mirrored half of the time, brightness jitter
        k = rng.integers(n_obj, size=attr_batch)
        v = rng.integers(CROP_VIEWS, size=attr_batch)
        cb = arrays["crops"][k, v].astype(np.float32)
        flip = rng.random(attr_batch) < 0.5
        cb[flip] = cb[flip][..., ::-1]
        cb[:, :3] *= rng.uniform(0.9, 1.1, size=(attr_batch, 1, 1, 1)).astype(np.float32)
        outs = net.attributes(torch.as_tensor(np.ascontiguousarray(cb), device=dev),
                              torch.as_tensor(arrays["geo"][k, v], device=dev))
        lab = torch.as_tensor(arrays["labels"][k], device=dev)
        attr_loss = sum(F.cross_entropy(o, lab[:, j]) for j, o in enumerate(outs))
        loss = seg_loss + attr_loss
        return descend(opt, loss)

    return train_step
