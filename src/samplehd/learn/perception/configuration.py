"""What defines a perception model: its format version, the labels and attribute heads, the
sizes and thresholds of its inputs, the vocabularies its heads name, and its ``config.json``
(:class:`PerceptionConfig`, declared with :mod:`samplehd.schema`).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any, ClassVar

from samplehd.catalogue import load_catalogue
from samplehd.errors import ConfigError
from samplehd.learn.configuration import ModelConfig
from samplehd.schema import Config, bounded
from samplehd.world.layout import LAYOUT

__all__ = ["PerceptionArchitecture", "PerceptionConfig", "PerceptionImage", "PerceptionTraining",
           "FORMAT", "SEG_CLASSES", "SEG_CHANNELS", "CROP", "CROP_CHANNELS", "CROP_VIEWS", "MIN_PIXELS", "MIN_RISE",
           "REACH_MARGIN", "DEPTH_JUMP", "MIN_PART", "CLUSTER_LINK", "FLOAT_LIFT", "STACK_NEAR", "GROUND_GAP",
           "RAISED", "KIND_FIT", "N_FEATURES", "PREPARED_FILE", "DEPTH_CENTRE", "DEPTH_SCALE", "ATTRIBUTES", "HEADS",
           "SIZE_SCALE", "attribute_vocab", "kind_vocab", "object_kind"]


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
SIZE_SCALE = 10.0  # the geometry features hold lengths in decimetres (inputs near 1 for the networks)
MIN_PART = 12  # pixels of the segmenter's grid: a part split off by a depth jump must be this large
CLUSTER_LINK = 0.02  # [m] points of one object's surface lie this near one another (see object_points)
FLOAT_LIFT = 0.02  # [m] an instance whose lowest points are this far above the table is an object's upper piece
STACK_NEAR = 0.03  # [m] ... joined with the instance whose ground-plane centre is this near its own
GROUND_GAP = 0.01  # [m] parts this far apart on the ground plane are different objects
RAISED = 0.0015  # [m] points this far above the table top are the object's when measuring its extents
KIND_FIT = 4.0  # spreads (size_templates) above a kind: 99 % of single test objects are within 3.1 of it
N_FEATURES = 21  # measured size and appearance features of an instance (see geometry_features)
PREPARED_FILE = "prepared.npz"
DEPTH_CENTRE, DEPTH_SCALE = 1.5, 0.5
ATTRIBUTES = ("name", "colour", "material", "size")
HEADS = (*ATTRIBUTES, "kind")  # kind: class/variant/size together, whose metric dimensions are fixed


@dataclass(frozen=True)
class PerceptionArchitecture(Config, section="model"):
    """Widths of the two networks.

    Attributes:
        seg_width: channels of the segmenter's first layer.
        attr_width: channels of the attribute network's first layer.
    """

    seg_width: int = bounded(8, lo=1)
    attr_width: int = bounded(24, lo=1)


@dataclass(frozen=True)
class PerceptionImage(Config, section="image"):
    """The scene images a perception model was trained on (it perceives images of this size).

    Attributes:
        camera: the camera.
        width: image width [px].
        height: image height [px].
    """

    camera: str = "scene"
    width: int = bounded(640, lo=8, hi=8192, unit="px")
    height: int = bounded(360, lo=8, hi=8192, unit="px")


@dataclass(frozen=True)
class PerceptionTraining(Config, section="train"):
    """How a perception model was trained (recorded; a resumed run must match all but ``steps``).

    Attributes:
        steps: optimiser steps.
        seed: seed of the weights, the batches and the crops.
        seg_batch: scenes per segmenter batch.
        attr_batch: object crops per attribute batch.
        patch: side of the square patches the segmenter trains on [px].
        seg_every: a segmenter step every this many steps.
        lr: learning rate before the decay.
        scenes: training scenes of the dataset.
        objects: training objects of the dataset.
    """

    steps: int = bounded(3000, lo=1)
    seed: int = bounded(0, lo=0)
    seg_batch: int = bounded(4, lo=1)
    attr_batch: int = bounded(64, lo=1)
    patch: int = bounded(128, lo=1, unit="px")
    seg_every: int = bounded(2, lo=1)
    lr: float = bounded(2e-3, lo=0.0, lo_open=True)
    scenes: int = bounded(0, lo=0)
    objects: int = bounded(0, lo=0)


@dataclass(frozen=True)
class PerceptionConfig(ModelConfig, section="perception"):
    """A perception model's config.

    Attributes:
        kind: ``perception``.
        format: :data:`FORMAT` of the samplehd that wrote it.
        dataset: the dataset it was trained on.
        model: network widths.
        attributes: the values of each head of :data:`ATTRIBUTES` (:func:`attribute_vocab`).
        kinds: the ``class/variant/size`` names of the kind head (:func:`kind_vocab`); each class and
            size is one of ``attributes``'.
        image: the scene images it was trained on.
        seg_downsample: the segmenter sees images shrunk by this factor.
        table_height: height of the table top [m].
        extents: ``class/size`` → box extents [m] of the training objects.
        size_templates: ``class/colour/size`` → (mean, spread) of the geometry features
            (:func:`samplehd.learn.perception.preparation.size_templates`).
        train: training options.
    """

    KIND: ClassVar[str] = "perception"
    FORMAT: ClassVar[int] = FORMAT

    model: PerceptionArchitecture = field(default_factory=PerceptionArchitecture)
    attributes: dict[str, list[str]] = field(default_factory=dict)
    kinds: tuple[str, ...] = bounded((), unique=True)
    image: PerceptionImage = field(default_factory=PerceptionImage)
    seg_downsample: int = bounded(1, lo=1)
    table_height: float = bounded(LAYOUT.table_height, lo=0.0, lo_open=True, unit="m")
    extents: dict[str, list[float]] = field(default_factory=dict)
    size_templates: dict[str, Any] = field(default_factory=dict)
    train: PerceptionTraining = field(default_factory=PerceptionTraining)

    def check_trained(self) -> None:
        """Its attributes name a list of values for each of :data:`ATTRIBUTES`, and each kind is a class
        and size of theirs."""
        missing = [a for a in ATTRIBUTES if not _names(self.attributes.get(a))]
        if missing:
            raise ConfigError(f"perception.attributes: needs a list of names for each of {', '.join(ATTRIBUTES)}; "
                              f"missing or not a list of names: {', '.join(missing)}", field="perception.attributes")
        for kind in self.kinds:
            parts = kind.split("/")
            if (len(parts) != 3 or parts[0] not in self.attributes["name"]
                    or parts[2] not in self.attributes["size"]):
                raise ConfigError(f"perception.kinds: {kind!r} is no class/variant/size of the attributes' names "
                                  f"and sizes", field="perception.kinds")

def _names(value: Any) -> bool:
    return isinstance(value, list | tuple) and all(isinstance(v, str) for v in value)


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


def kind_vocab(catalogue: str) -> list[str]:
    """Every ``class/variant/size`` of the built-in ``catalogue`` (sorted): each has one set of metric
    dimensions, so that the network can learn size as the dimensions of a recognised shape, not as a
    class-wide threshold (a large dessert fork and a medium dinner fork differ by 4 %)."""
    cat = load_catalogue(name=catalogue)
    out = set()
    for name in cat.classes:
        cls = cat.object_class(name)
        for v in cls.variants:
            out |= {f"{name}/{v}/{s}" for s in cls.variant(v).menu.size}
    return sorted(out)


def object_kind(o: Mapping[str, Any]) -> str:
    return f"{o['name']}/{o.get('variant', '')}/{o['size']}"
