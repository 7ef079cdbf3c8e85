"""Point geometry of perception: depth lifted to 3-D, heights above the table, instances from
the segmenter's labels (split by depth jumps, stacked pieces joined) and each instance's crop
and measured size and appearance features.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
from scipy import ndimage
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from samplehd.learn.perception.configuration import (
    CLUSTER_LINK,
    CROP_CHANNELS,
    DEPTH_CENTRE,
    DEPTH_JUMP,
    DEPTH_SCALE,
    FLOAT_LIFT,
    GROUND_GAP,
    MIN_PART,
    MIN_PIXELS,
    RAISED,
    SIZE_SCALE,
    STACK_NEAR,
)

__all__ = ["backproject", "seg_labels", "height_map", "instance_masks", "instance_parts", "split_by_depth",
           "join_stacked", "object_points", "downsampled", "net_input", "object_crop", "metric_extents",
           "geometry_features"]


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


def downsampled(img: np.ndarray, factor: int, nearest: bool) -> np.ndarray:
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


def net_input(rgb: np.ndarray, depth: np.ndarray, height: np.ndarray) -> np.ndarray:
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


def object_crop(rgb: np.ndarray, depth: np.ndarray, height: np.ndarray, mask: np.ndarray, size: int,
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


def metric_extents(features: np.ndarray) -> np.ndarray:
    """Long and short extent and height [m] from :func:`geometry_features`'s features."""
    return features[:3] / SIZE_SCALE


def geometry_features(rgb: np.ndarray, depth: np.ndarray, mask: np.ndarray, camera: Mapping[str, Any],
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
    size = [ext[0] * SIZE_SCALE, ext[1] * SIZE_SCALE, top * SIZE_SCALE, np.log(ext[0] + 0.005),
            np.log(ext[1] + 0.005), np.log(top + 0.005), side_m * SIZE_SCALE]
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
