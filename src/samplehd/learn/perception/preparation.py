"""Training data of perception: a dataset's scene images turned into network inputs and targets,
cached beside the model (``prepared.npz``).
"""

from __future__ import annotations

import json
import os
from collections.abc import Callable, Mapping, Sequence
from contextlib import nullcontext
from pathlib import Path
from typing import Any, TypedDict

import numpy as np
from PIL import Image
from rich.console import Console
from scipy import ndimage

from samplehd.learn.perception.configuration import (
    ATTRIBUTES,
    CROP,
    CROP_CHANNELS,
    CROP_VIEWS,
    MIN_PIXELS,
    N_FEATURES,
    PREPARED_FILE,
    object_kind,
)
from samplehd.learn.perception.geometry import (
    downsampled,
    geometry_features,
    height_map,
    net_input,
    object_crop,
    seg_labels,
)

__all__ = ["PreparedArrays", "load_scene_images", "prepare_perception", "prepared_arrays", "size_templates"]


def load_scene_images(item: Mapping[str, Any]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    rgb = np.asarray(Image.open(item["rgb"]).convert("RGB"))
    depth = np.load(item["depth"], allow_pickle=False).astype(np.float32)
    seg = np.asarray(Image.open(item["segmentation"])).astype(np.int64)
    return rgb, depth, seg


def _view_mask(mask: np.ndarray, factor: int, rng: np.random.Generator) -> np.ndarray:
    """A ground-truth mask as the segmenter would hand it over: at its resolution, blown up, its
    border moved by up to a pixel there (worked on a window around the mask)."""
    rows, cols = np.nonzero(mask)
    r0, c0 = max(rows.min() // factor - 2, 0) * factor, max(cols.min() // factor - 2, 0) * factor
    r1, c1 = min(rows.max() + 3 * factor, mask.shape[0]), min(cols.max() + 3 * factor, mask.shape[1])
    small = downsampled(mask[r0:r1, c0:c1], factor, True)
    grow = int(rng.integers(-1, 2))
    if grow > 0:
        small = ndimage.binary_dilation(small)
    elif grow < 0 and small.sum() > 4 * MIN_PIXELS:
        small = ndimage.binary_erosion(small)
    if small.sum() < MIN_PIXELS:
        return mask
    out = np.zeros_like(mask)
    big = np.kron(small, np.ones((factor, factor), bool))[: r1 - r0, : c1 - c0]
    out[r0:r0 + big.shape[0], c0:c0 + big.shape[1]] = big
    return out


class PreparedArrays(TypedDict):
    """Perception's training arrays (``prepared.npz``): the segmenter's downsampled RGB, depth and height
    inputs and labels; per training object its :data:`CROP_VIEWS` crops, their size features and its
    attribute and kind labels; the median box extents [m] by ``class/size``."""

    rgb: np.ndarray
    dh: np.ndarray
    y: np.ndarray
    crops: np.ndarray
    geo: np.ndarray
    labels: np.ndarray
    extents: dict[str, list[float]]


def prepare_perception(items: Sequence[Mapping[str, Any]], vocab: Mapping[str, Sequence[str]], kinds: Sequence[str],
             factor: int, table_height: float, seed: int, quiet: bool = True) -> PreparedArrays:
    """Arrays for training: the segmenter's downsampled inputs and labels, and :data:`CROP_VIEWS`
    crops (with their size features) of every training object."""
    rgbs, dhs, ys, crops, geos, labels, extents = [], [], [], [], [], [], {}
    rng = np.random.default_rng(np.random.SeedSequence([int(seed), 7]))
    console = Console(stderr=True, quiet=quiet)
    with console.status("reading and cropping the training scenes") if not quiet else nullcontext():
        for item in items:
            ann = item["annotation"]
            rgb, depth, seg = load_scene_images(item)
            height = height_map(depth, ann["camera"], table_height)
            x = net_input(downsampled(rgb, factor, False), downsampled(depth, factor, False),
                           downsampled(height, factor, False))
            rgbs.append(np.round(x[:3] * 255).astype(np.uint8))
            dhs.append(x[3:].astype(np.float16))
            ys.append(seg_labels(downsampled(seg, factor, True)).astype(np.int8))
            for j in item["train_objects"]:
                o = ann["objects"][j]
                mask = seg == o["segmentation_id"]
                if mask.sum() < MIN_PIXELS:
                    continue
                for view in range(CROP_VIEWS):
                    m = mask if view == 0 else _view_mask(mask, factor, rng)
                    jitter = None if view == 0 else rng.uniform([-0.06, -0.06, -0.12], [0.06, 0.06, 0.12])
                    crops.append(object_crop(rgb, depth, height, m, CROP, jitter).astype(np.float16))
                    geos.append(geometry_features(rgb, depth, m, ann["camera"], table_height)[1])
                labels.append([*(vocab[a].index(o["name"] if a == "name" else o[a]) for a in ATTRIBUTES),
                               kinds.index(object_kind(o))])
                extents.setdefault(f"{o['name']}/{o['size']}", []).append(o["bbox"]["extents"])
    n = len(labels)
    return {"rgb": np.stack(rgbs), "dh": np.stack(dhs), "y": np.stack(ys),
            "crops": np.stack(crops).reshape(n, CROP_VIEWS, CROP_CHANNELS, CROP, CROP),
            "geo": np.stack(geos).reshape(n, CROP_VIEWS, N_FEATURES), "labels": np.asarray(labels, np.int64),
            "extents": {k: np.median(np.asarray(v), axis=0).round(4).tolist() for k, v in sorted(extents.items())}}


def size_templates(geo: np.ndarray, kinds_of: np.ndarray, kinds: Sequence[str]) -> dict[str, list[list[float]]]:
    """Per kind (class/variant/size) of the training objects: the median and spread (standard deviation
    + 0.03) of the measured log dimensions (:func:`geometry_features`'s long and short extent and top height)
    over every training view. A size is a scale of a variant, so within a recognised class the nearest
    kind names the size; measured the same way in training and use, the templates carry the
    measurement's own bias (a cylinder's visible depth is its radius, not its diameter).

    Args:
        geo: (objects, views, :data:`N_FEATURES`) measured features.
        kinds_of: (objects,) index of each object's kind in ``kinds``.
    """
    out = {}
    for k in np.unique(kinds_of):
        x = geo[kinds_of == k][:, :, 3:6].reshape(-1, 3).astype(float)
        out[kinds[int(k)]] = [np.median(x, axis=0).round(4).tolist(), (x.std(axis=0) + 0.03).round(4).tolist()]
    return out


def prepared_arrays(out: Path, key: Mapping[str, Any], make: Callable[[], PreparedArrays]) -> PreparedArrays:
    """The prepared training arrays, cached in ``out/prepared.npz`` (made again when ``key`` differs).

    Decoding and cropping the scenes takes longer than many training steps; a resumed run reads them
    back instead. The cache holds plain arrays (read without pickle) and is removed when the run
    finishes.
    """
    path = out / PREPARED_FILE
    text = json.dumps(key, sort_keys=True)
    if path.exists():
        try:
            with np.load(path, allow_pickle=False) as f:
                if str(f["key"]) == text:
                    arrays = {k: f[k] for k in f.files if k not in ("key", "extents")}
                    arrays["extents"] = json.loads(str(f["extents"]))
                    return arrays
        except (OSError, ValueError, KeyError):
            pass  # unreadable or stale: make it again
    arrays = make()
    out.mkdir(parents=True, exist_ok=True)
    tmp = out / f".{PREPARED_FILE}.tmp-{os.getpid()}.npz"
    np.savez(tmp, key=np.array(text), extents=np.array(json.dumps(arrays["extents"])),
             **{k: v for k, v in arrays.items() if k != "extents"})
    tmp.replace(path)
    return arrays
