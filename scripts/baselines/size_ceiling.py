"""How well can size be named at all? The ceiling of the size attribute on a dataset's test objects.

A size (small, medium, large) scales one of the class's shape variants by 0.8, 1.0 or 1.2, so an object's
size is a property of its variant, and two variants of one class can give (nearly) the same object:
a small dinner fork and a medium dessert fork are both 16 cm long, 2.1 and 2.2 cm wide. This script
finds, for each test object of the seen level (L1), the class's (variant, size) pairs whose catalogue
dimensions (long and short side, height) all lie within TOL of the object's own; where more than one
size is among them, the object's size cannot be told from its shape and dimensions, and the best any
model can do is the most common size of that group in the training split. The ceiling is the share
of test objects a model would name right that way (every other object counted right).

usage: python scripts/baselines/size_ceiling.py DATASET [--tol 0.05 ...]
"""

from __future__ import annotations

import argparse
from collections import Counter

import numpy as np

from samplehd.catalogue import load_catalogue
from samplehd.catalogue.facts import object_facts
from samplehd.catalogue.instance import ObjectInstance
from samplehd.language.levels import HELD_OUT_CLASSES, held_out_object
from samplehd.learn.data import open_dataset


def _dims(e: np.ndarray) -> np.ndarray:
    return np.array([*sorted(e[:2], reverse=True), e[2]])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("dataset")
    ap.add_argument("--tol", type=float, nargs="+", default=[0.02, 0.05, 0.08])
    args = ap.parse_args()
    reader = open_dataset(args.dataset)
    cat = load_catalogue(name=reader.catalogue)  # the shapes the dataset's scenes were drawn from
    templates: dict[str, list[tuple[str, str, np.ndarray]]] = {}
    for name in cat.classes:
        cls = cat.object_class(name)
        for v in cls.variants:
            menu = cls.variant(v).menu
            c, m = next(iter(menu.pairs))
            for s in menu.size:
                e = np.asarray(object_facts(ObjectInstance(name, v, c, m, s)).extents, float)
                templates.setdefault(name, []).append((v, s, _dims(e)))
    train = Counter()
    test = []
    for scene in reader.scenes:
        for o in scene["objects"]:
            if held_out_object(o) or o["name"] in HELD_OUT_CLASSES:
                continue
            if scene.get("split") == "test":
                test.append(o)
            else:
                train[(o["name"], o["variant"], o["size"])] += 1
    print(f"{len(test)} L1 test objects")
    for tol in args.tol:
        right, ambiguous = 0.0, Counter()
        for o in test:
            d = _dims(np.asarray(o["bbox"]["extents"], float))
            group = [(v, s) for v, s, t in templates[o["name"]] if np.all(np.abs(np.log(t / d)) <= tol)]
            sizes = {s for _, s in group}
            if len(sizes) <= 1:
                right += 1
                continue
            ambiguous[o["name"]] += 1
            votes = Counter()
            for v, s in group:
                votes[s] += train[(o["name"], v, s)]
            right += votes.most_common(1)[0][0] == o["size"]
        print(f"tol {tol:.0%}: size ceiling {right / len(test):.1%}; ambiguous objects by class {dict(ambiguous)}")


if __name__ == "__main__":
    main()
