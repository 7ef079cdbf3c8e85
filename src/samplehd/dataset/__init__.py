"""samplehd.dataset: the on-disk dataset format, generation, re-rendering, validation, stats (the exports
to other formats are :mod:`samplehd.export`).

The stable entry points are :class:`samplehd.dataset.reader.DatasetReader` (read a dataset) and
:func:`samplehd.dataset.container.read_episode` / :func:`~samplehd.dataset.container.write_episode`
(one episode file). See docs/FORMAT.md.
"""

from __future__ import annotations

from samplehd.dataset.layout import FORMAT_VERSION
from samplehd.dataset.reader import DatasetReader, EpisodeEntry

__all__ = ["FORMAT_VERSION", "DatasetReader", "EpisodeEntry"]
