"""The keypose policy (``samplehd train policy --action keypose``, ``evaluate --policy bc``): per object
moved, one decision (where to grasp, where it goes) from a top-down view of the scene camera's RGB-D,
as in Transporter networks, CLIPort and PerAct. Modules, one job each (LeRobot's split of a model):

- :mod:`~samplehd.learn.keypose.configuration`: :class:`KeyposeConfig`, a model's ``config.json`` (no torch);
- :mod:`~samplehd.learn.keypose.processing`: a demonstration's decisions, the view of the table
  (the grid of :mod:`samplehd.learn.topdown`) and a decision as labels;
- :mod:`~samplehd.learn.keypose.modeling`: :class:`KeyposeNet`, the network;
- :mod:`~samplehd.learn.keypose.follower`: :class:`KeyposeFollower`, which carries a decision out as
  steering vectors;
- :mod:`~samplehd.learn.keypose.inference`: :class:`KeyposePolicy`, a trained one that acts;
- :mod:`~samplehd.learn.keypose.exclusion`: grounding a noun it never heard by exclusion (L4);
- :mod:`~samplehd.learn.keypose.preparation`: the training samples of a dataset;
- :mod:`~samplehd.learn.keypose.training`: :func:`train_keypose`.

Importing this package loads only the configuration; the other names load their module (and PyTorch,
for the network) on first use.
"""

from __future__ import annotations

import importlib
from typing import Any

from samplehd.learn.keypose.configuration import (
    FORMAT,
    INPUTS,
    KeyposeArchitecture,
    KeyposeConfig,
    KeyposeGrid,
    KeyposeTraining,
    KeyposeVocabulary,
)

# name -> the module that defines it, imported on first use (PyTorch, the environment)
_DEFERRED = {
    "Decision": "processing",
    "exclusion_target": "exclusion",
    "KeyposeFollower": "follower",
    "KeyposeNet": "modeling",
    "KeyposePolicy": "inference",
    "decisions": "processing",
    "train_keypose": "training",
}

__all__ = ["FORMAT", "INPUTS", "Decision", "KeyposeArchitecture", "KeyposeConfig", "KeyposeFollower", "KeyposeGrid",
           "KeyposeNet", "KeyposePolicy", "KeyposeTraining", "KeyposeVocabulary", "decisions", "exclusion_target",
           "train_keypose"]


def __getattr__(name: str) -> Any:
    if name not in _DEFERRED:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    return getattr(importlib.import_module(f"{__name__}.{_DEFERRED[name]}"), name)


def __dir__() -> list[str]:
    return sorted({*globals(), *_DEFERRED})
