"""What defines a perception model: its format version, the labels and attribute heads, the
sizes and thresholds of its inputs, and the vocabularies its heads name.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from samplehd.catalogue import load_catalogue

__all__ = ["FORMAT", "SEG_CLASSES", "SEG_CHANNELS", "CROP", "CROP_CHANNELS", "CROP_VIEWS", "MIN_PIXELS", "MIN_RISE",
           "REACH_MARGIN", "DEPTH_JUMP", "MIN_PART", "CLUSTER_LINK", "FLOAT_LIFT", "STACK_NEAR", "GROUND_GAP",
           "RAISED", "KIND_FIT", "N_FEATURES", "PREPARED_FILE", "DEPTH_CENTRE", "DEPTH_SCALE", "ATTRIBUTES", "HEADS",
           "attribute_vocab", "kind_vocab"]


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


def kind_vocab(catalogue: str = "procedural") -> list[str]:
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


def _kind(o: Mapping[str, Any]) -> str:
    return f"{o['name']}/{o.get('variant', '')}/{o['size']}"
