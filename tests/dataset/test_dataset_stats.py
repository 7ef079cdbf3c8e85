"""The frames-per-episode histogram of ``samplehd stats``: every bin from the lowest to the highest,
each labelled with the frame counts it holds, and every episode in the bin its label names."""

from __future__ import annotations

import json
from pathlib import Path

from samplehd.dataset.stats import dataset_stats


def test_histogram_bins_hold_what_their_labels_say(micro_dataset: Path) -> None:
    frames = [e["num_frames"] for e in json.loads((micro_dataset / "info.json").read_text())["episodes"]]
    fpe = dataset_stats(micro_dataset)["frames_per_episode"]
    width, hist = fpe["bin_width"], fpe["histogram"]
    starts = sorted(hist)
    assert starts == list(range(starts[0], starts[-1] + width, width))  # no bin left out, empty ones too
    assert sum(hist.values()) == len(frames)
    for start, count in hist.items():
        assert count == sum(start <= n <= start + width - 1 for n in frames)
