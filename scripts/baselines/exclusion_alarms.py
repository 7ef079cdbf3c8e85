"""How often the keypose policy's rule of grounding by exclusion fires, per generalisation level, on
the instructions of a dataset that it was not trained on (``learn/keypose/exclusion.py``): at L4 (a
held-out class named) firing is right; at L1-L3 every firing is a false alarm. Counts distinct
instruction texts of successful episodes outside the policy's training set (the test split, and the
training split's L2-L4 episodes), each with its 95 % Wilson interval, and lists the L1-L3 texts it
fired on.

usage: python scripts/baselines/exclusion_alarms.py MODEL DATASET   (MODEL: a keypose policy folder
       of `samplehd train policy --action keypose`; DATASET: a `samplehd generate` folder; the Python
       that has samplehd)
"""

from __future__ import annotations

import json
import sys
from collections import defaultdict
from pathlib import Path

from samplehd.benchmark.statistics import proportion
from samplehd.dataset.reader import DatasetReader
from samplehd.language.levels import episode_level, held_out_instruction
from samplehd.learn.keypose.configuration import KeyposeConfig
from samplehd.learn.keypose.exclusion import unknown_nouns

LEVELS = ("L1", "L2", "L3", "L4")


def alarms(model: Path, dataset: Path) -> dict[str, tuple[int, int, list[str]]]:
    """level -> (instructions the rule fired on, instructions, the texts it fired on)."""
    vocabulary = KeyposeConfig.from_dict(json.loads((model / "config.json").read_text())).vocabulary
    reader = DatasetReader(dataset)
    scenes = {s["image_index"]: s for s in reader.scenes}
    texts: dict[str, set[str]] = defaultdict(set)
    for e in reader.episodes:
        if not reader.episode_meta(e.instruction_index).success:
            continue
        ins = reader.instruction(e.instruction_index)
        level = episode_level(ins, scenes[e.scene_index])
        if e.split != "test" and level == "L1" and not held_out_instruction(ins):
            continue  # a training episode
        texts[level].add(str(ins["instruction"]))
    out = {}
    for level in LEVELS:
        fired = sorted(t for t in texts[level] if unknown_nouns(t, vocabulary))
        out[level] = (len(fired), len(texts[level]), fired)
    return out


def main(argv: list[str]) -> int:
    if len(argv) != 2:
        print(__doc__.split("usage: ")[1].split("\n")[0], file=sys.stderr)
        return 2
    for level, (fired, n, which) in alarms(Path(argv[0]), Path(argv[1])).items():
        if n == 0:
            print(f"{level}: no instruction")
            continue
        rate = proportion(fired, n)
        kind = "right" if level == "L4" else "false alarms"
        print(f"{level}: fired on {fired}/{n} instructions ({kind}; 95 % interval "
              f"{100 * rate.low:.0f}-{100 * rate.high:.0f} %)")
        if level != "L4":
            for text in which:
                print(f"  {text}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
