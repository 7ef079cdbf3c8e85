"""Perception: scene-camera RGB-D → object instances with class, colour, material, size and 3-D
position, as a CLEVR-layout scene annotation the executor and planner consume.

Two small networks:

- a U-Net on the image at half resolution labels every pixel background, robot, object, or
  *contact* (an object pixel touching another object's pixel); instances are the connected components
  of the object pixels, and contact pixels join the nearest instance;
- an attribute network looks at each instance's crop (RGB, mask, relative depth) plus its metric size
  from the depth (width, depth, height [m]) and appearance measures (highlights, fine texture) and names
  its class, colour, material and size, and its *kind* (class, shape variant and size together, which
  fixes the metric dimensions): the class and size it names are the averages of their own heads and of
  the kind head (its class marginal; its sizes within the class found).

The position is geometry, not learning: the instance's pixels are lifted to 3-D with the depth and the
camera's calibration; the centre of their ground-plane bounding box, on the table top, is the
object's ``3d_coords``. Table parts and relationships follow from positions as in the dataset.
"""

from __future__ import annotations

import json
import os
from collections import Counter
from collections.abc import Callable, Mapping, Sequence
from contextlib import nullcontext
from pathlib import Path
from typing import Any

import numpy as np
from PIL import Image
from rich.console import Console
from scipy import ndimage
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from samplehd.catalogue import load_catalogue
from samplehd.envs.levels import HELD_OUT_CLASSES, held_out_object
from samplehd.errors import ConfigError
from samplehd.learn.data import open_dataset, scene_examples
from samplehd.learn.training import (
    F,
    TrainRun,
    descend,
    load_model_files,
    nn,
    pick_device,
    set_seed,
    step_rng,
    timed,
    torch,
)
from samplehd.world.layout import DIRECTIONS, LAYOUT, table_parts_of
from samplehd.world.relations import compute_relationships

__all__ = ["Perception", "backproject", "evaluate_perception", "score_perception", "train_perception"]

FORMAT = 4  # bump when the inputs or networks change (older models: train again)
SEG_CLASSES = ("background", "robot", "object", "contact")
SEG_CHANNELS = 5  # RGB, depth, height above the table
CROP = 48
CROP_CHANNELS = 6  # RGB, mask, relative depth, height above the table
CROP_VIEWS = 4  # training views of every object: the mask's own crop, then jittered crops of altered masks
MIN_PIXELS = 6
MIN_RISE = 0.002  # [m] an instance lower than this above the table (95th percentile) is the table
REACH_MARGIN = 0.10  # [m] an instance this far beyond the arm's reach is not a scene object
DEPTH_JUMP = 0.03  # [m] a depth step this large between neighbouring pixels may part two objects
_SIZE_SCALE = 10.0  # the geometry features hold lengths in decimetres (inputs near 1 for the networks)
MIN_PART = 12  # pixels of the segmenter's grid: a part split off by a depth jump must be this large
CLUSTER_LINK = 0.02  # [m] points of one object's surface lie this near one another (see object_points)
FLOAT_LIFT = 0.02  # [m] an instance whose lowest points are this far above the table is an object's upper piece
STACK_NEAR = 0.03  # [m] ... joined with the instance whose ground-plane centre is this near its own
GROUND_GAP = 0.01  # [m] parts this far apart on the ground plane are different objects
RAISED = 0.0015  # [m] points this far above the table top are the object's when measuring its extents
KIND_FIT = 4.0  # spreads (size_templates) above a kind: 99 % of single test objects are within 3.1 of it
N_FEATURES = 21  # measured size and appearance features of an instance (see _geometry)
PREPARED_FILE = "prepared.npz"
DEPTH_CENTRE, DEPTH_SCALE = 1.5, 0.5
ATTRIBUTES = ("name", "colour", "material", "size")
HEADS = (*ATTRIBUTES, "kind")  # kind: class/variant/size together, whose metric dimensions are fixed


def attribute_vocab() -> dict[str, list[str]]:
    """Values of each attribute, from the catalogue (sorted)."""
    cat = load_catalogue()
    colours, materials, sizes = set(), set(), set()
    for name in cat.classes:
        cls = cat.object_class(name)
        for v in cls.variants:
            menu = cls.variant(v).menu
            for c, m in menu.pairs:
                colours.add(c)
                materials.add(m)
            sizes |= set(menu.size)
    return {"name": sorted(cat.classes), "colour": sorted(colours), "material": sorted(materials),
            "size": sorted(sizes)}


def kind_vocab() -> list[str]:
    """Every ``class/variant/size`` of the catalogue (sorted): each has one set of metric dimensions, so
    that the network can learn size as the dimensions of a recognised shape, not as a class-wide
    threshold (a large dessert fork and a medium dinner fork differ by 4 %)."""
    cat = load_catalogue()
    out = set()
    for name in cat.classes:
        cls = cat.object_class(name)
        for v in cls.variants:
            out |= {f"{name}/{v}/{s}" for s in cls.variant(v).menu.size}
    return sorted(out)


def _kind(o: Mapping[str, Any]) -> str:
    return f"{o['name']}/{o.get('variant', '')}/{o['size']}"


def backproject(depth: np.ndarray, rows: np.ndarray, cols: np.ndarray, camera: Mapping[str, Any]) -> np.ndarray:
    """World points (N, 3) [m] of pixels (rows, cols) of a depth image [m] from a scene annotation's camera.

    The image may be a scaled copy of the camera's (intrinsics scale with it).
    """
    k = np.asarray(camera["intrinsics"], dtype=float)
    pose = np.asarray(camera["extrinsics"], dtype=float)
    s = depth.shape[1] / float(camera["width"])
    f, cx, cy = k[0, 0] * s, k[0, 2] * s, k[1, 2] * s
    d = depth[rows, cols].astype(float)
    u, v = cols + 0.5, rows + 0.5
    cam = np.stack([(u - cx) * d / f, -(v - cy) * d / f, -d], axis=1)
    return cam @ pose[:3, :3].T + pose[:3, 3]


def seg_labels(seg: np.ndarray) -> np.ndarray:
    """Per-pixel training labels from an instance-id image (0 bg, 1 table, 2 robot, 3+ objects)."""
    out = np.zeros(seg.shape, dtype=np.int64)
    out[seg == 2] = 1
    obj = seg >= 3
    out[obj] = 2
    contact = np.zeros_like(obj)
    for dr, dc in ((0, 1), (1, 0), (1, 1), (1, -1)):
        a = seg[max(dr, 0):seg.shape[0], max(dc, 0):seg.shape[1] + min(dc, 0)]
        b = seg[0:seg.shape[0] - dr, max(-dc, 0):seg.shape[1] - max(dc, 0)]
        touch = (a >= 3) & (b >= 3) & (a != b)
        contact[max(dr, 0):, max(dc, 0):seg.shape[1] + min(dc, 0)] |= touch
        contact[:seg.shape[0] - dr, max(-dc, 0):seg.shape[1] - max(dc, 0)] |= touch
    out[contact] = 3
    return out


def _downsample(img: np.ndarray, factor: int, nearest: bool) -> np.ndarray:
    if factor == 1:
        return img
    if nearest:
        return img[factor // 2::factor, factor // 2::factor]
    h, w = img.shape[0] // factor * factor, img.shape[1] // factor * factor
    x = img[:h, :w].astype(np.float32)
    return x.reshape(h // factor, factor, w // factor, factor, *img.shape[2:]).mean(axis=(1, 3))


def height_map(depth: np.ndarray, camera: Mapping[str, Any], table_height: float) -> np.ndarray:
    """Height [m] above the table top of every pixel of a depth image (the image may be a scaled copy)."""
    rows, cols = np.indices(depth.shape)
    z = backproject(depth, rows.ravel(), cols.ravel(), camera)[:, 2]
    return (z - table_height).reshape(depth.shape).astype(np.float32)


def _net_input(rgb: np.ndarray, depth: np.ndarray, height: np.ndarray) -> np.ndarray:
    """(5, H, W) float32: RGB in [0, 1], normalised depth, height above the table [dm]."""
    d = (np.clip(depth, 0.0, 4.0) - DEPTH_CENTRE) / DEPTH_SCALE
    h = np.clip(height, -0.2, 0.5) * 10.0
    return np.concatenate([np.moveaxis(rgb.astype(np.float32) / 255.0, -1, 0), d[None].astype(np.float32),
                           h[None].astype(np.float32)])


def instance_masks(labels: np.ndarray, depth: np.ndarray | None = None,
                   camera: Mapping[str, Any] | None = None) -> list[np.ndarray]:
    """Instances from per-pixel labels: components of object pixels; contact pixels join the nearest.

    With the ``depth`` of the labels' pixels [m] and the ``camera``, a component is also split where the
    depth jumps between neighbouring pixels (an object in front of another) into parts that stand apart
    on the ground plane (:func:`split_by_depth`)."""
    return [m for m, _ in instance_parts(labels, depth, camera)]


def instance_parts(labels: np.ndarray, depth: np.ndarray | None = None,
                   camera: Mapping[str, Any] | None = None) -> list[tuple[np.ndarray, int]]:
    """:func:`instance_masks` with, for each mask, the connected component of object pixels it came
    from (masks split from one component by a depth jump share it)."""
    comp, n = ndimage.label(labels == 2)
    if n == 0:
        return []
    parent = np.arange(n + 1)
    if depth is not None and camera is not None:
        comp, n, parent = split_by_depth(comp, n, depth, camera)
    contact = labels == 3
    if contact.any():
        _, (ri, ci) = ndimage.distance_transform_edt(comp == 0, return_indices=True)
        nearest = comp[ri, ci]
        comp = np.where(contact, nearest, comp)
    masks = [(comp == i, int(parent[i])) for i in range(1, n + 1)]
    return [(m, p) for m, p in masks if m.sum() >= MIN_PIXELS]


def split_by_depth(comp: np.ndarray, n: int, depth: np.ndarray, camera: Mapping[str, Any],
                   jump: float = DEPTH_JUMP, min_part: int = MIN_PART,
                   gap: float = GROUND_GAP) -> tuple[np.ndarray, int, np.ndarray]:
    """Split labelled components (``comp``: 0 background, 1..n) where the depth jumps.

    In each component, the farther pixel of every pair of 4-neighbours whose depths differ by more than
    ``jump`` [m] is set aside; the rest falls into parts (4-connected). Parts of at least ``min_part``
    pixels become instances of their own when their 3-D points are more than ``gap`` [m] apart on the
    ground plane from every other such part (two objects, one in front of the other); otherwise they
    stay together (a bowl's near rim before its inside, a mug's handle before its body, one object with
    a depth jump within it). Set-aside pixels and small parts join the nearest instance. Returns the new
    labels, their count, and each new label's component (``parent[label]``)."""
    out = np.zeros_like(comp)
    count = 0
    parent = [0]
    dz = np.abs(np.diff(depth, axis=0)) > jump
    dx = np.abs(np.diff(depth, axis=1)) > jump
    for i in range(1, n + 1):
        mine = comp == i
        far = np.zeros_like(mine)
        cut = dz & mine[1:] & mine[:-1]
        down = depth[1:] > depth[:-1]
        far[1:] |= cut & down
        far[:-1] |= cut & ~down
        cut = dx & mine[:, 1:] & mine[:, :-1]
        right = depth[:, 1:] > depth[:, :-1]
        far[:, 1:] |= cut & right
        far[:, :-1] |= cut & ~right
        parts, k = ndimage.label(mine & ~far)
        sizes = np.bincount(parts.ravel(), minlength=k + 1)
        big = [j for j in range(1, k + 1) if sizes[j] >= min_part]
        groups = _ground_groups(parts, big, depth, camera, gap) if len(big) > 1 else [big]
        if len(groups) <= 1:
            count += 1
            parent.append(i)
            out[mine] = count
            continue
        sub = np.zeros_like(comp)
        for g in groups:
            count += 1
            parent.append(i)
            sub[np.isin(parts, g)] = count
        _, (ri, ci) = ndimage.distance_transform_edt(sub == 0, return_indices=True)
        out[mine] = sub[ri, ci][mine]
    return out, count, np.asarray(parent)


def _ground_groups(parts: np.ndarray, big: Sequence[int], depth: np.ndarray, camera: Mapping[str, Any],
                   gap: float) -> list[list[int]]:
    """Parts whose ground-plane points come within ``gap`` of each other, grouped (transitively)."""
    trees = []
    for j in big:
        rows, cols = np.nonzero(parts == j)
        trees.append(cKDTree(backproject(depth, rows, cols, camera)[:, :2]))
    near = [(a, b) for a in range(len(big)) for b in range(a + 1, len(big))
            if trees[a].count_neighbors(trees[b], gap) > 0]
    return [[big[a] for a in g] for g in _linked_groups(len(big), near)]


def _linked_groups(n: int, links: Sequence[tuple[int, int]]) -> list[list[int]]:
    """Items 0..n-1 grouped by the ``links`` between them (transitively), each group in ascending order,
    the groups in the order of their first item."""
    pairs = np.asarray(links, dtype=int).reshape(-1, 2)
    graph = csr_matrix((np.ones(len(pairs), bool), (pairs[:, 0], pairs[:, 1])), shape=(n, n))
    _, label = connected_components(graph, directed=False)
    groups: dict[int, list[int]] = {}
    for k, g in enumerate(label):
        groups.setdefault(int(g), []).append(k)
    return list(groups.values())


def join_stacked(masks: Sequence[np.ndarray], depth: np.ndarray, camera: Mapping[str, Any], table_height: float,
                 lift: float = FLOAT_LIFT, near: float = STACK_NEAR) -> list[np.ndarray]:
    """Join each instance that floats above the table with the instance beneath it on the ground plane.

    Every scene object stands on the table top, so an instance whose lowest own points
    (:func:`object_points`, 5th percentile) are ``lift`` [m] above it is the upper piece of an object
    whose lower piece the segmenter labelled apart: a wine glass's bowl above its stem, a glass's rim above
    its body where the thin wall was missed. It joins the lower instance whose ground-plane centre is nearest
    to its own, when within ``near`` [m]: no two objects stand there, as scene objects do not overlap on the
    table. An object seen only above a nearer one (its foot hidden) has its centre at least the two
    objects' radii from the nearer one's and stays apart."""
    masks = list(masks)
    if len(masks) < 2:
        return masks
    centre, low = [], []
    for m in masks:
        rows, cols = np.nonzero(m)
        pts = object_points(backproject(depth, rows, cols, camera), table_height)
        lo, hi = np.percentile(pts[:, :2], 3, axis=0), np.percentile(pts[:, :2], 97, axis=0)
        centre.append((lo + hi) / 2)
        low.append(float(np.percentile(pts[:, 2], 5)) - table_height)
    links = []
    for a in range(len(masks)):
        if low[a] < lift:
            continue
        below = [(float(np.linalg.norm(centre[a] - centre[b])), b) for b in range(len(masks)) if low[b] < low[a]]
        d, b = min(below, default=(np.inf, a))
        if d <= near:
            links.append((a, b))
    return [np.logical_or.reduce([masks[k] for k in g]) for g in _linked_groups(len(masks), links)]


def _crop(rgb: np.ndarray, depth: np.ndarray, height: np.ndarray, mask: np.ndarray, size: int,
          jitter: np.ndarray | None = None) -> np.ndarray:
    """(6, size, size) crop around a mask at the image's full resolution: RGB, mask, depth relative to
    the instance's median [dm], height above the table [dm]. ``jitter`` (row, column, scale), as
    fractions of the crop's side, moves and scales the window (training augmentation)."""
    rows, cols = np.nonzero(mask)
    r0, r1, c0, c1 = rows.min(), rows.max() + 1, cols.min(), cols.max() + 1
    side = max(r1 - r0, c1 - c0) * 1.3 + 4
    cr, cc = (r0 + r1) / 2, (c0 + c1) / 2
    if jitter is not None:
        cr, cc, side = cr + jitter[0] * side, cc + jitter[1] * side, side * (1 + jitter[2])
    t = (np.arange(size) + 0.5) / size - 0.5
    rr = np.clip(np.round(cr + t * side - 0.5).astype(int), 0, mask.shape[0] - 1)
    cc_ = np.clip(np.round(cc + t * side - 0.5).astype(int), 0, mask.shape[1] - 1)
    grid = np.ix_(rr, cc_)
    med = float(np.median(depth[mask]))
    out = np.empty((CROP_CHANNELS, size, size), np.float32)
    out[:3] = np.moveaxis(rgb[grid].astype(np.float32) / 255.0, -1, 0)
    out[3] = mask[grid]
    out[4] = np.clip((depth[grid] - med) / 0.1, -3, 3)
    out[5] = np.clip(height[grid], -0.1, 0.5) * 10.0
    return out


def object_points(pts: np.ndarray, table_height: float, link: float = CLUSTER_LINK) -> np.ndarray:
    """The points of a mask (N, 3) [m] that lie on the object itself.

    A mask from the segmenter's coarser grid takes in a rim of what lies around the object, and beside a
    tall object that is not the table next to it but the table top, floor, wall or robot far behind it
    (the depth jumps at the silhouette). The object's own points are those above the table top whose
    largest cluster (points within ``link`` [m] of one another, transitively) they fall in; a flat object
    with fewer than three raised points keeps them all."""
    raised = pts[pts[:, 2] > table_height + RAISED]
    if len(raised) < 3:
        return pts
    pairs = cKDTree(raised).query_pairs(link, output_type="ndarray")
    n = len(raised)
    graph = csr_matrix((np.ones(len(pairs), bool), (pairs[:, 0], pairs[:, 1])), shape=(n, n))
    _, label = connected_components(graph, directed=False)
    return raised[label == np.bincount(label).argmax()]


def _metric_size(features: np.ndarray) -> np.ndarray:
    """Long and short extent and height [m] from :func:`_geometry`'s features."""
    return features[:3] / _SIZE_SCALE


def _geometry(rgb: np.ndarray, depth: np.ndarray, mask: np.ndarray, camera: Mapping[str, Any],
              table_height: float, whole: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """(position [x, y, z] of the object's base, the :data:`N_FEATURES` measured features) of a mask.

    Size: the extents of the object's visible points (:func:`object_points`) along their principal
    horizontal axes (long, short) and the height of the top above the table (none depends on the
    object's rotation about the vertical), their logarithms, and the metric side of the crop window.
    Appearance, at the image's full resolution (the crop may shrink a highlight away): percentiles of the
    brightness and the spread of the saturation over the mask, which tell shiny materials from matte ones.
    With ``whole``, the mask may hold several objects (a union to be judged): all its points above the
    table count, not only the largest cluster's.
    """
    rows, cols = np.nonzero(mask)
    pts = backproject(depth, rows, cols, camera)
    own = pts[pts[:, 2] > table_height + RAISED] if whole else object_points(pts, table_height)
    own = own if len(own) >= 3 else pts
    lo, hi = np.percentile(own, 3, axis=0), np.percentile(own, 97, axis=0)
    centre = (lo + hi) / 2
    pos = np.array([centre[0], centre[1], table_height])
    # Position, extents and height from the object's own points only: a mask from the segmenter's coarser
    # grid takes in a rim of table around the object, which would add a pixel or two to every side, and
    # beside a tall object the table, wall or robot far behind it.
    xy = own[:, :2] - own[:, :2].mean(axis=0)
    if len(xy) >= 3:
        _, vecs = np.linalg.eigh(np.cov(xy.T) + 1e-12 * np.eye(2))
        proj = xy @ vecs[:, ::-1]
        ext = np.percentile(proj, 99.5, axis=0) - np.percentile(proj, 0.5, axis=0)
    else:
        ext = np.zeros(2)
    top = max(float(np.percentile(own[:, 2], 99.5)) - table_height, 0.0)
    focal = float(np.asarray(camera["intrinsics"], dtype=float)[0, 0]) * depth.shape[1] / float(camera["width"])
    side_px = max(rows.max() - rows.min() + 1, cols.max() - cols.min() + 1) * 1.3 + 4
    side_m = side_px * float(np.median(depth[rows, cols])) / focal
    px = rgb[rows, cols].astype(np.float32) / 255.0
    v, lo_c = px.max(axis=1), px.min(axis=1)
    sat = (v - lo_c) / np.maximum(v, 1e-3)
    vp = np.percentile(v, (10, 50, 90, 98, 100))
    size = [ext[0] * _SIZE_SCALE, ext[1] * _SIZE_SCALE, top * _SIZE_SCALE, np.log(ext[0] + 0.005),
            np.log(ext[1] + 0.005), np.log(top + 0.005), side_m * _SIZE_SCALE]
    look = [*vp, vp[3] - vp[1], float(np.mean(v > vp[1] + 0.25)), float(np.std(v)), *np.percentile(sat, (10, 50, 90))]
    return pos, np.asarray(size + look + _texture_energy(rgb, mask), dtype=np.float32)


def _texture_energy(rgb: np.ndarray, mask: np.ndarray) -> list[float]:
    """Fine texture inside a mask at full resolution (brushed metal's streaks, rubber's grain, wood's
    rings against smooth plastic and ceramic): the mean absolute brightness step to the right and
    downward neighbours where both pixels are the object's, relative to the mean brightness, and the
    ratio of the two (streaks run one way)."""
    r0, r1 = np.nonzero(mask.any(axis=1))[0][[0, -1]]
    c0, c1 = np.nonzero(mask.any(axis=0))[0][[0, -1]]
    m = mask[r0:r1 + 1, c0:c1 + 1]
    v = rgb[r0:r1 + 1, c0:c1 + 1].astype(np.float32).max(axis=2) / 255.0
    mean = float(v[m].mean()) + 0.05
    both_x, both_y = m[:, 1:] & m[:, :-1], m[1:] & m[:-1]
    dx = float(np.abs(np.diff(v, axis=1))[both_x].mean()) if both_x.any() else 0.0
    dy = float(np.abs(np.diff(v, axis=0))[both_y].mean()) if both_y.any() else 0.0
    return [10 * dx / mean, 10 * dy / mean, (max(dx, dy) + 1e-3) / (min(dx, dy) + 1e-3) - 1]


def _block(cin: int, cout: int) -> nn.Module:
    return nn.Sequential(nn.Conv2d(cin, cout, 3, padding=1), nn.BatchNorm2d(cout), nn.ReLU(inplace=True),
                         nn.Conv2d(cout, cout, 3, padding=1), nn.BatchNorm2d(cout), nn.ReLU(inplace=True))


class UNet(nn.Module):
    """Per-pixel labels (:data:`SEG_CLASSES`) from the 4-channel RGB-D input."""

    def __init__(self, width: int) -> None:
        super().__init__()
        w = width
        self.e1, self.e2, self.e3 = _block(SEG_CHANNELS, w), _block(w, 2 * w), _block(2 * w, 4 * w)
        self.mid = _block(4 * w, 4 * w)
        self.d3, self.d2, self.d1 = _block(8 * w, 2 * w), _block(4 * w, w), _block(2 * w, w)
        self.head = nn.Conv2d(w, len(SEG_CLASSES), 1)
        self.pool = nn.MaxPool2d(2)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        e1 = self.e1(x)
        e2 = self.e2(self.pool(e1))
        e3 = self.e3(self.pool(e2))
        m = self.mid(self.pool(e3))

        def up(t: torch.Tensor, ref: torch.Tensor) -> torch.Tensor:
            return F.interpolate(t, size=ref.shape[-2:], mode="nearest")

        d3 = self.d3(torch.cat([up(m, e3), e3], 1))
        d2 = self.d2(torch.cat([up(d3, e2), e2], 1))
        d1 = self.d1(torch.cat([up(d2, e1), e1], 1))
        return self.head(d1)


class AttributeNet(nn.Module):
    """Class, colour, material and size logits from an instance crop and its metric size."""

    def __init__(self, width: int, sizes: Sequence[int]) -> None:
        super().__init__()
        w = width
        self.features = nn.Sequential(
            nn.Conv2d(CROP_CHANNELS, w, 3, padding=1), nn.BatchNorm2d(w), nn.ReLU(inplace=True), nn.MaxPool2d(2),
            nn.Conv2d(w, 2 * w, 3, padding=1), nn.BatchNorm2d(2 * w), nn.ReLU(inplace=True), nn.MaxPool2d(2),
            nn.Conv2d(2 * w, 4 * w, 3, padding=1), nn.BatchNorm2d(4 * w), nn.ReLU(inplace=True), nn.MaxPool2d(2),
            nn.Conv2d(4 * w, 4 * w, 3, padding=1), nn.BatchNorm2d(4 * w), nn.ReLU(inplace=True),
            nn.AdaptiveAvgPool2d(1), nn.Flatten())
        self.geometry = nn.Sequential(nn.Linear(N_FEATURES, 64), nn.ReLU(inplace=True), nn.Linear(64, 64),
                                      nn.ReLU(inplace=True))
        self.trunk = nn.Sequential(nn.Linear(4 * w + 64, 128), nn.ReLU(inplace=True))
        self.heads = nn.ModuleList([nn.Linear(128, n) for n in sizes])

    def forward(self, crops: torch.Tensor, features: torch.Tensor) -> list[torch.Tensor]:
        h = self.trunk(torch.cat([self.features(crops), self.geometry(features)], 1))
        return [head(h) for head in self.heads]


class PerceptionNet(nn.Module):
    """The two networks in one state dict."""

    def __init__(self, seg_width: int, attr_width: int, sizes: Sequence[int]) -> None:
        super().__init__()
        self.segmenter = UNet(seg_width)
        self.attributes = AttributeNet(attr_width, sizes)


class Perception:
    """A trained perception model: ``perceive(rgb, depth, camera)`` → CLEVR-layout scene annotation.

    Args:
        config: the model config (``config.json`` of ``samplehd train perception``).
        state: its state dict (None: fresh weights).
        device: torch device (default: CPU).
    """

    def __init__(self, config: Mapping[str, Any], state: Mapping[str, Any] | None = None, device: Any = None) -> None:
        if config.get("format") != FORMAT:
            raise ConfigError(f"perception model format {config.get('format')!r}: this samplehd reads format "
                              f"{FORMAT} (train it again with `samplehd train perception`)")
        self.config = dict(config)
        self.vocab: dict[str, list[str]] = {k: list(v) for k, v in config["attributes"].items()}
        self.kinds: list[str] = list(config["kinds"])
        self.device = device or torch.device("cpu")
        arch = config["model"]
        self.net = PerceptionNet(arch["seg_width"], arch["attr_width"],
                                 [*(len(self.vocab[a]) for a in ATTRIBUTES), len(self.kinds)]).to(self.device)
        # kind -> class and size index, to turn the kind head's probabilities into class and size ones
        parts = [k.split("/") for k in self.kinds]
        self._kind_class = np.array([self.vocab["name"].index(p[0]) for p in parts])
        self._kind_size = np.array([self.vocab["size"].index(p[2]) for p in parts])
        templates = config.get("size_templates") or {}
        self._templates = {k: (np.asarray(v[0], float), np.asarray(v[1], float)) for k, v in templates.items()}
        if state is not None:
            self.net.load_state_dict(state)
        self.net.eval()
        self.factor = int(config["seg_downsample"])
        self.table_height = float(config["table_height"])

    @classmethod
    def load(cls, folder: str | Path, device: Any = None) -> Perception:
        """Load ``config.json`` + ``model.pt`` written by ``samplehd train perception``."""
        config, state = load_model_files(folder, "perception", FORMAT)
        try:
            return cls(config, state, device)
        except ConfigError as exc:
            raise ConfigError(f"{Path(folder) / 'config.json'}: {exc}") from None

    def segment(self, rgb: np.ndarray, depth: np.ndarray, camera: Mapping[str, Any],
                height: np.ndarray | None = None) -> list[np.ndarray]:
        """Instance masks at the image's full resolution (``height``: :func:`height_map`, if at hand)."""
        f = self.factor
        if height is None:
            height = height_map(depth, camera, self.table_height)
        x = _net_input(_downsample(rgb, f, False), _downsample(depth, f, False), _downsample(height, f, False))
        with torch.no_grad():
            logits = self.net.segmenter(torch.as_tensor(x[None], device=self.device))
        labels = logits.argmax(1)[0].cpu().numpy()
        found = instance_parts(labels, _downsample(depth, f, True), camera)
        masks = [m for m, _ in found]
        if f > 1:
            masks = [np.kron(m, np.ones((f, f), bool))[: rgb.shape[0], : rgb.shape[1]] for m in masks]
            masks = [np.pad(m, ((0, rgb.shape[0] - m.shape[0]), (0, rgb.shape[1] - m.shape[1]))) for m in masks]
        keep = [k for k, m in enumerate(masks) if self._plausible(m, depth, height, camera)]
        masks = self._join_alike([masks[k] for k in keep], [found[k][1] for k in keep], rgb, depth, camera, height)
        return join_stacked(masks, depth, camera, self.table_height)

    def _join_alike(self, masks: list[np.ndarray], parents: Sequence[int], rgb: np.ndarray, depth: np.ndarray,
                    camera: Mapping[str, Any], height: np.ndarray) -> list[np.ndarray]:
        """Keep the parts split from one component (by a depth jump) apart unless they are one object: the
        inside of a bowl or pan behind its near rim, or a wine glass's bowl above its stem, are one object
        that the network knows whole; a glass in front of a tray are two it knows apart.

        The union is one object when the attribute network is at least as sure of it as of any part and its
        measured dimensions fit a kind of the class it names (:meth:`fits_kind`): the network is sure of
        much that it has never seen, such as three objects in a row named a pan. Otherwise parts named the
        same class and colour are joined where their union fits that class (a bowl's rim and inside), and
        the rest stay apart (two mugs side by side)."""
        split = sorted(p for p, k in Counter(parents).items() if k > 1)
        if not split:
            return masks
        out = [m for m, p in zip(masks, parents, strict=True) if p not in split]
        for p in split:
            parts = [m for m, q in zip(masks, parents, strict=True) if q == p]
            union = np.logical_or.reduce(parts)
            found = self.classify(rgb, depth, [*parts, union], camera, height, [False] * len(parts) + [True])
            sure = [max(f["scores"]["name"].values()) for f in found]
            if sure[-1] >= max(sure[:-1]) and self.fits_kind(found[-1]["name"], found[-1]["metric_size"]):
                out.append(union)
                continue
            alike: dict[tuple[str, str], list[int]] = {}
            for k, f in enumerate(found[:-1]):
                alike.setdefault((f["name"], f["colour"]), []).append(k)
            for (name, _), ks in alike.items():
                if len(ks) > 1:
                    joined = np.logical_or.reduce([parts[k] for k in ks])
                    size = _metric_size(_geometry(rgb, depth, joined, camera, self.table_height, whole=True)[1])
                    if self.fits_kind(name, size):
                        out.append(joined)
                        continue
                out += [parts[k] for k in ks]
        return out

    def fits_kind(self, name: str, metric_size: np.ndarray, limit: float = KIND_FIT) -> bool:
        """Whether measured dimensions (long and short extent, top height [m]) fit some kind of class
        ``name`` (:func:`size_templates`): none more than ``limit`` of the kind's spreads above its training
        median. Only too large counts: an object partly hidden (behind another, at the image's edge)
        measures smaller than its kind, while two objects taken for one measure larger than either. A
        class without templates (held out of training, or a model without them) fits anything."""
        x = np.log(np.asarray(metric_size, float)[:3] + 0.005)
        fits = [float(np.max((x - mu) / sd)) <= limit for kind, (mu, sd) in self._templates.items()
                if kind.split("/")[0] == name]
        return any(fits) or not fits

    def _plausible(self, mask: np.ndarray, depth: np.ndarray, height: np.ndarray, camera: Mapping[str, Any]) -> bool:
        """Whether an instance can be an object: it rises above the table top (a patch of the table's
        grain or a highlight on it does not: the thinnest object part, a small fork's head, is 2.4 mm),
        and it lies within the arm's reach, where scenes place objects (with a margin)."""
        if float(np.percentile(height[mask], 95)) < MIN_RISE:
            return False
        rows, cols = np.nonzero(mask)
        xy = backproject(depth, rows, cols, camera)[:, :2].mean(axis=0)
        return float(np.hypot(*(xy - np.asarray(LAYOUT.robot_base)))) <= LAYOUT.reach_max + REACH_MARGIN

    def classify(self, rgb: np.ndarray, depth: np.ndarray, masks: Sequence[np.ndarray],
                 camera: Mapping[str, Any], height: np.ndarray | None = None,
                 whole: Sequence[bool] | None = None) -> list[dict[str, Any]]:
        """Attributes and geometry of each mask (logits averaged over the crop and its mirror image);
        ``whole[k]``: mask ``k`` may hold several objects (see :func:`_geometry`)."""
        if not masks:
            return []
        if height is None:
            height = height_map(depth, camera, self.table_height)
        crops = np.stack([_crop(rgb, depth, height, m, CROP) for m in masks])
        whole = whole or [False] * len(masks)
        geo = [_geometry(rgb, depth, m, camera, self.table_height, w) for m, w in zip(masks, whole, strict=True)]
        sizes = torch.as_tensor(np.stack([g[1] for g in geo]).astype(np.float32), device=self.device)
        with torch.no_grad():
            x = torch.as_tensor(crops, device=self.device)
            outs = self.net.attributes(x, sizes)
            mirrored = self.net.attributes(torch.flip(x, dims=(3,)), sizes)
            probs = [torch.softmax(o, 1) + torch.softmax(m, 1) for o, m in zip(outs, mirrored, strict=True)]
        probs = [(p / 2).cpu().numpy() for p in probs]
        probs = self._with_kinds(probs, [g[1] for g in geo])
        result = []
        for k, (pos, size) in enumerate(geo):
            attrs = {a: self.vocab[a][int(probs[j][k].argmax())] for j, a in enumerate(ATTRIBUTES)}
            scores = {a: {v: round(float(q), 4) for v, q in zip(self.vocab[a], probs[j][k], strict=True) if q >= 0.01}
                      for j, a in enumerate(ATTRIBUTES)}
            result.append({**attrs, "position": pos, "metric_size": _metric_size(size), "scores": scores})
        return result

    def _with_kinds(self, probs: list[np.ndarray], features: Sequence[np.ndarray] | None = None) -> list[np.ndarray]:
        """Class and size probabilities averaged with the kind head's: its class marginal, and its size
        distribution given the class so found (the four attribute heads' probabilities, in order).

        With size templates in the config and the instances' measured ``features``, the size is the
        measured dimensions' nearest kind of that class instead (:func:`size_templates`)."""
        name_p, colour_p, material_p, size_p, kind_p = probs
        n = len(kind_p)
        by_class = np.zeros_like(name_p)
        np.add.at(by_class.T, self._kind_class, kind_p.T)
        name_p = (name_p + by_class) / 2
        best = name_p.argmax(axis=1)
        size_given = np.zeros_like(size_p)
        for i in range(n):
            mine = self._kind_class == best[i]
            np.add.at(size_given[i], self._kind_size[mine], kind_p[i, mine])
        total = size_given.sum(axis=1, keepdims=True)
        size_given = np.where(total > 1e-6, size_given / np.maximum(total, 1e-6), size_p)
        size_p = (size_p + size_given) / 2
        if self._templates and features is not None:
            for i in range(n):
                measured = self._size_by_template(self.vocab["name"][best[i]], features[i])
                if measured is not None:
                    size_p[i] = measured
        return [name_p, colour_p, material_p, size_p]

    def _size_by_template(self, name: str, features: np.ndarray) -> np.ndarray | None:
        """Size probabilities from the measured dimensions (log long and short extent, log top height):
        a Gaussian score of each kind of the class around its training median, summed by size."""
        x = np.asarray(features[3:6], float)
        scores, sizes = [], []
        for kind, (mu, sd) in self._templates.items():
            cls, _, size = kind.split("/")
            if cls == name:
                scores.append(-0.5 * float(np.sum(((x - mu) / sd) ** 2)))
                sizes.append(self.vocab["size"].index(size))
        if not scores:
            return None
        w = np.exp(np.asarray(scores) - max(scores))
        out = np.zeros(len(self.vocab["size"]))
        np.add.at(out, sizes, w)
        return out / out.sum()

    def perceive(self, rgb: np.ndarray, depth: np.ndarray, camera: Mapping[str, Any],
                 directions: Mapping[str, Any] | None = None) -> dict[str, Any]:
        """A scene annotation (``objects``, ``relationships``, ``directions``) from one RGB-D image, and
        ``attribute_scores``: per object, the probability of each likely value of each attribute."""
        height = height_map(depth, camera, self.table_height)
        masks = self.segment(rgb, depth, camera, height)
        found = self.classify(rgb, depth, masks, camera, height)
        ann = annotation_from_instances(found, masks, self.config.get("extents", {}), directions)
        ann["attribute_scores"] = [f["scores"] for f in found]
        return ann


def annotation_from_instances(found: Sequence[Mapping[str, Any]], masks: Sequence[np.ndarray],
                              extents: Mapping[str, Sequence[float]],
                              directions: Mapping[str, Any] | None = None) -> dict[str, Any]:
    """Turn perceived instances into a CLEVR-layout scene dict (objects with the fields the executor reads)."""
    objects = []
    for f, m in zip(found, masks, strict=True):
        pos = [float(v) for v in f["position"]]
        ext = extents.get(f"{f['name']}/{f['size']}") or [float(max(f["metric_size"][0], 0.02)),
                                                          float(max(f["metric_size"][1], 0.02)),
                                                          float(max(f["metric_size"][2], 0.01))]
        rows, cols = np.nonzero(m)
        objects.append({
            "name": f["name"], "shape": f["name"], "colour": f["colour"], "color": f["colour"],
            "material": f["material"], "size": f["size"], "table_part": table_parts_of(np.array(pos[:2])),
            "3d_coords": pos, "bbox": {"extents": [float(e) for e in ext]},
            "pixel_coords": [float(cols.mean()), float(rows.mean()), 0.0],
        })
    dirs = dict(directions) if directions else {k: list(map(float, v)) for k, v in DIRECTIONS.items()}
    return {"objects": objects, "directions": dirs,
            "relationships": compute_relationships(objects, dirs) if objects
            else {r: [] for r in ("left", "right", "front", "behind")}}


def _load_scene_images(item: Mapping[str, Any]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    rgb = np.asarray(Image.open(item["rgb"]).convert("RGB"))
    depth = np.load(item["depth"], allow_pickle=False).astype(np.float32)
    seg = np.asarray(Image.open(item["segmentation"])).astype(np.int64)
    return rgb, depth, seg


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


def evaluate_perception(model: Perception, scenes: Sequence[Mapping[str, Any]]) -> dict[str, Any]:
    """Mask IoU, detection F1 (IoU ≥ 0.5), attribute accuracy (per attribute and all four right, on
    detected objects) and position error [cm], over test scenes; attributes split by L1 objects and
    held-out ones."""
    ious, tp, n_pred, n_gt = [], 0, 0, 0
    rows: list[dict[str, Any]] = []
    gt_attr_rows: list[dict[str, Any]] = []
    for item in scenes:
        ann = item["annotation"]
        rgb, depth, seg = _load_scene_images(item)
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

    def acc(rs: list[dict[str, Any]]) -> dict[str, Any]:
        if not rs:
            return {"n": 0}
        out: dict[str, Any] = {"n": len(rs), **{a: float(np.mean([r[a] for r in rs])) for a in ATTRIBUTES}}
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


def _view_mask(mask: np.ndarray, factor: int, rng: np.random.Generator) -> np.ndarray:
    """A ground-truth mask as the segmenter would hand it over: at its resolution, blown up, its
    border moved by up to a pixel there (worked on a window around the mask)."""
    rows, cols = np.nonzero(mask)
    r0, c0 = max(rows.min() // factor - 2, 0) * factor, max(cols.min() // factor - 2, 0) * factor
    r1, c1 = min(rows.max() + 3 * factor, mask.shape[0]), min(cols.max() + 3 * factor, mask.shape[1])
    small = _downsample(mask[r0:r1, c0:c1], factor, True)
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


def _prepare(items: Sequence[Mapping[str, Any]], vocab: Mapping[str, Sequence[str]], kinds: Sequence[str],
             factor: int, table_height: float, seed: int, quiet: bool = True) -> dict[str, Any]:
    """Arrays for training: the segmenter's downsampled inputs and labels, and :data:`CROP_VIEWS`
    crops (with their size features) of every training object."""
    rgbs, dhs, ys, crops, geos, labels, extents = [], [], [], [], [], [], {}
    rng = np.random.default_rng(np.random.SeedSequence([int(seed), 7]))
    console = Console(stderr=True, quiet=quiet)
    with console.status("reading and cropping the training scenes") if not quiet else nullcontext():
        for item in items:
            ann = item["annotation"]
            rgb, depth, seg = _load_scene_images(item)
            height = height_map(depth, ann["camera"], table_height)
            x = _net_input(_downsample(rgb, factor, False), _downsample(depth, factor, False),
                           _downsample(height, factor, False))
            rgbs.append(np.round(x[:3] * 255).astype(np.uint8))
            dhs.append(x[3:].astype(np.float16))
            ys.append(seg_labels(_downsample(seg, factor, True)).astype(np.int8))
            for j in item["train_objects"]:
                o = ann["objects"][j]
                mask = seg == o["segmentation_id"]
                if mask.sum() < MIN_PIXELS:
                    continue
                for view in range(CROP_VIEWS):
                    m = mask if view == 0 else _view_mask(mask, factor, rng)
                    jitter = None if view == 0 else rng.uniform([-0.06, -0.06, -0.12], [0.06, 0.06, 0.12])
                    crops.append(_crop(rgb, depth, height, m, CROP, jitter).astype(np.float16))
                    geos.append(_geometry(rgb, depth, m, ann["camera"], table_height)[1])
                labels.append([*(vocab[a].index(o["name"] if a == "name" else o[a]) for a in ATTRIBUTES),
                               kinds.index(_kind(o))])
                extents.setdefault(f"{o['name']}/{o['size']}", []).append(o["bbox"]["extents"])
    n = len(labels)
    return {"rgb": np.stack(rgbs), "dh": np.stack(dhs), "y": np.stack(ys),
            "crops": np.stack(crops).reshape(n, CROP_VIEWS, CROP_CHANNELS, CROP, CROP),
            "geo": np.stack(geos).reshape(n, CROP_VIEWS, N_FEATURES), "labels": np.asarray(labels, np.int64),
            "extents": {k: np.median(np.asarray(v), axis=0).round(4).tolist() for k, v in sorted(extents.items())}}


def size_templates(geo: np.ndarray, kinds_of: np.ndarray, kinds: Sequence[str]) -> dict[str, list[list[float]]]:
    """Per kind (class/variant/size) of the training objects: the median and spread (standard deviation
    + 0.03) of the measured log dimensions (:func:`_geometry`'s long and short extent and top height)
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


def prepared_arrays(out: Path, key: Mapping[str, Any], make: Callable[[], dict[str, Any]]) -> dict[str, Any]:
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


def train_perception(dataset: str | Path, out: str | Path, steps: int = 3000, seed: int = 0, device: str | None = None,
                     quiet: bool = False, stop_after: int | None = None, seg_batch: int = 4, attr_batch: int = 64,
                     patch: int = 128, seg_every: int = 2,
                     lr: float = 2e-3, seg_width: int = 8, attr_width: int = 24) -> dict[str, Any]:
    """Train segmentation and attribute networks on a dataset's training scenes; test on its test scenes.

    Metrics (``metrics.json``): ``test_mask_iou`` (mean best IoU per ground-truth object),
    ``test_detection_f1``, ``test_attribute_accuracy`` (mean of the four attribute accuracies on
    detected objects of seen classes and combinations), ``test_attribute_all_four``,
    ``test_position_error_cm`` (median, ground plane) and held-out (L2, L4) figures.
    """
    reader = open_dataset(dataset)
    data = scene_examples(reader)
    vocab = attribute_vocab()
    kinds = kind_vocab()
    width = int(data["train"][0]["annotation"]["camera"]["width"])
    height = int(data["train"][0]["annotation"]["camera"]["height"])
    factor = 2 if width >= 400 else 1
    dev = pick_device(device)
    set_seed(seed)
    key = {"format": FORMAT, "features": N_FEATURES, "dataset": str(Path(dataset).resolve()), "factor": factor,
           "crop": CROP, "views": CROP_VIEWS, "seed": seed, "table_height": LAYOUT.table_height,
           "scenes": [str(Path(item["rgb"]).name) for item in data["train"]], "vocab": vocab, "kinds": kinds}
    with timed() as prep_time:
        arrays = prepared_arrays(Path(out), key, lambda: _prepare(data["train"], vocab, kinds, factor,
                                                                  LAYOUT.table_height, seed, quiet))
    config = {
        "kind": "perception",
        "format": FORMAT,
        "dataset": str(dataset),
        "model": {"seg_width": seg_width, "attr_width": attr_width},
        "attributes": vocab,
        "kinds": kinds,
        "image": {"camera": "scene", "width": width, "height": height},
        "seg_downsample": factor,
        "table_height": LAYOUT.table_height,
        "extents": arrays["extents"],
        "size_templates": size_templates(arrays["geo"], arrays["labels"][:, len(ATTRIBUTES)], kinds),
        "train": {"steps": steps, "seed": seed, "seg_batch": seg_batch, "attr_batch": attr_batch, "patch": patch,
                  "seg_every": seg_every, "lr": lr, "scenes": len(data["train"]), "objects": len(arrays["labels"])},
    }
    model = Perception(config, device=dev)
    net = model.net
    opt = torch.optim.Adam(net.parameters(), lr=lr)
    run = TrainRun(Path(out), config, steps, checkpoint_every=max(50, steps // 10), quiet=quiet,
                   stop_after=stop_after)
    run.prepare()
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

    losses, t = run.train(net, opt, train_step, "perception")
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


def perception_test_metrics(model: Perception, scenes: Sequence[Mapping[str, Any]]) -> dict[str, Any]:
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


def score_perception(dataset: str | Path, models: str | Path, device: str | None = None) -> dict[str, Any]:
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
    want = model.config["image"]
    cam = data["test"][0]["annotation"]["camera"]
    if (int(cam["width"]), int(cam["height"])) != (int(want["width"]), int(want["height"])):
        raise ConfigError(f"dataset={dataset}: scene images are {cam['width']}x{cam['height']}; the model in "
                          f"{models} was trained on {want['width']}x{want['height']}", field="dataset")
    with timed() as t:
        metrics = perception_test_metrics(model, data["test"])
    return {**metrics, **{f"test_{k}": v for k, v in t.items()}}
