"""A trained perception model (:class:`Perception`): RGB-D of the scene camera -> CLEVR-layout scene
annotation.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from samplehd.errors import ConfigError
from samplehd.learn.perception.configuration import (
    ATTRIBUTES,
    CROP,
    FORMAT,
    KIND_FIT,
    MIN_RISE,
    REACH_MARGIN,
    PerceptionConfig,
)
from samplehd.learn.perception.geometry import (
    backproject,
    downsampled,
    geometry_features,
    height_map,
    instance_parts,
    join_stacked,
    metric_extents,
    net_input,
    object_crop,
)
from samplehd.learn.perception.modeling import PerceptionNet
from samplehd.learn.training import check_weights_fit, load_model_files, read_model_config, torch
from samplehd.scene.annotate import SceneAnnotation
from samplehd.world.layout import DIRECTIONS, LAYOUT, table_parts_of
from samplehd.world.relations import compute_relationships

__all__ = ["Perception", "annotation_from_instances"]


class Perception:
    """A trained perception model: ``perceive(rgb, depth, camera)`` → CLEVR-layout scene annotation.

    Args:
        config: the model config (``config.json`` of ``samplehd train perception``).
        state: its state dict (None: fresh weights).
        device: torch device (default: CPU).
    """

    def __init__(self, config: PerceptionConfig, state: Mapping[str, Any] | None = None, device: Any = None) -> None:
        if config.format != FORMAT:
            raise ConfigError(f"perception model format {config.format!r}: this samplehd reads format "
                              f"{FORMAT} (train it again with `samplehd train perception`)")
        self.config = config
        self.vocab: dict[str, list[str]] = {k: list(v) for k, v in config.attributes.items()}
        self.kinds: list[str] = list(config.kinds)
        self.device = device or torch.device("cpu")
        self.net = PerceptionNet(config.model.seg_width, config.model.attr_width,
                                 [*(len(self.vocab[a]) for a in ATTRIBUTES), len(self.kinds)]).to(self.device)
        # kind -> class and size index, to turn the kind head's probabilities into class and size ones
        parts = [k.split("/") for k in self.kinds]
        self._kind_class = np.array([self.vocab["name"].index(p[0]) for p in parts])
        self._kind_size = np.array([self.vocab["size"].index(p[2]) for p in parts])
        templates = config.size_templates
        self._templates = {k: (np.asarray(v[0], float), np.asarray(v[1], float)) for k, v in templates.items()}
        if state is not None:
            self.net.load_state_dict(state)
        self.net.eval()
        self.factor = config.seg_downsample
        self.table_height = config.table_height

    @classmethod
    def load(cls, folder: str | Path, device: Any = None) -> Perception:
        """Load ``config.json`` + ``model.pt`` written by ``samplehd train perception``."""
        config, state = load_model_files(folder, "perception", FORMAT)
        perception = cls(read_model_config(PerceptionConfig, config, folder), None, device)
        check_weights_fit(perception.net, state, folder)
        return perception

    def segment(self, rgb: np.ndarray, depth: np.ndarray, camera: Mapping[str, Any],
                height: np.ndarray | None = None) -> list[np.ndarray]:
        """Instance masks at the image's full resolution (``height``: :func:`height_map`, if at hand)."""
        f = self.factor
        if height is None:
            height = height_map(depth, camera, self.table_height)
        x = net_input(downsampled(rgb, f, False), downsampled(depth, f, False), downsampled(height, f, False))
        with torch.no_grad():
            logits = self.net.segmenter(torch.as_tensor(x[None], device=self.device))
        labels = logits.argmax(1)[0].cpu().numpy()
        found = instance_parts(labels, downsampled(depth, f, True), camera)
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
                    size = metric_extents(geometry_features(rgb, depth, joined, camera, self.table_height,
                                                            whole=True)[1])
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
        ``whole[k]``: mask ``k`` may hold several objects (see :func:`geometry_features`)."""
        if not masks:
            return []
        if height is None:
            height = height_map(depth, camera, self.table_height)
        crops = np.stack([object_crop(rgb, depth, height, m, CROP) for m in masks])
        whole = whole or [False] * len(masks)
        geo = [geometry_features(rgb, depth, m, camera, self.table_height, w)
               for m, w in zip(masks, whole, strict=True)]
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
            result.append({**attrs, "position": pos, "metric_size": metric_extents(size), "scores": scores})
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
                 directions: Mapping[str, Any] | None = None) -> SceneAnnotation:
        """A scene annotation (``objects``, ``relationships``, ``directions``) from one RGB-D image, and
        ``attribute_scores``: per object, the probability of each likely value of each attribute."""
        height = height_map(depth, camera, self.table_height)
        masks = self.segment(rgb, depth, camera, height)
        found = self.classify(rgb, depth, masks, camera, height)
        ann = annotation_from_instances(found, masks, self.config.extents, directions)
        ann["attribute_scores"] = [f["scores"] for f in found]
        return ann


def annotation_from_instances(found: Sequence[Mapping[str, Any]], masks: Sequence[np.ndarray],
                              extents: Mapping[str, Sequence[float]],
                              directions: Mapping[str, Any] | None = None) -> SceneAnnotation:
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
