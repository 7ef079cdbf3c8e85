"""Visuomotor behaviour cloning: scene and wrist camera RGB + instruction tokens + robot state →
the next ``chunk`` steering vectors of the dataset (SAMPLE-HD's 7-D steering, action chunking).

The network: one small CNN per camera whose last block is FiLM-modulated by the instruction (a GRU
over the token ids of :mod:`samplehd.envs.tokens`), a state MLP over the robot state normalised per
dimension (joint positions, TCP position and orientation, finger opening), and an MLP head that
writes ``chunk`` × 7 values in [-1, 1]. Training samples frames of the dataset's training episodes
(random shifts of the images, as in DrQ), minimises the squared error to the recorded chunk, and
reports the test episodes' error. The squared error, not the L1 error of the first version: more
than half of the frames hold the TCP still along x and y, so the L1 error's optimum under
uncertainty (the median) is a zero velocity, and an L1-trained policy barely moved.

In the environment, :class:`BCPolicy` predicts a chunk and executes its first ``execute`` actions
before looking again (or, with ``inference.ensemble``, averages every chunk's action for the step);
with ``inference.z_floor`` it keeps its TCP target at or above the lowest TCP height of its
demonstrations.

Modules, one job each (LeRobot's split of a model):

- :mod:`~samplehd.learn.policy.configuration`: :class:`PolicyConfig`, a model's ``config.json`` (no torch);
- :mod:`~samplehd.learn.policy.processing`: the robot state vector the network sees;
- :mod:`~samplehd.learn.policy.modeling`: the network;
- :mod:`~samplehd.learn.policy.inference`: :class:`BCPolicy`, a trained policy that acts, and the
  factory ``samplehd evaluate --policy bc`` calls (which also loads the keypose policy of
  :mod:`samplehd.learn.keypose`);
- :mod:`~samplehd.learn.policy.preparation`: training arrays from dataset and collected episodes;
- :mod:`~samplehd.learn.policy.training`: :func:`train_policy`, with DART demonstrations and DAgger rounds.

The steering and waypoint labels, :class:`~samplehd.learn.actions.WaypointExpert` and the waypoint
follower are :mod:`samplehd.learn.actions`.

Importing this package loads only the configuration: ``samplehd evaluate`` reads a policy's
``config.json`` through :mod:`samplehd.learn.options` where PyTorch is not installed. The other names
load their module (and PyTorch, for the network) on first use.
"""

from __future__ import annotations

import importlib
from typing import Any

from samplehd.learn.policy.configuration import (
    ACTIONS,
    CAMERAS,
    ENCODERS,
    FORMAT,
    INPUTS,
    LOSSES,
    STATE_DIM,
    TARGET_DIM,
    PolicyArchitecture,
    PolicyCollection,
    PolicyConfig,
    PolicyInference,
    PolicyTraining,
)

# name -> the module that defines it, imported on first use (PyTorch, the environment)
_DEFERRED = {
    "BCNet": "modeling",
    "BCPolicy": "inference",
    "policy_for_evaluation": "inference",
    "train_policy": "training",
}

__all__ = ["ACTIONS", "CAMERAS", "ENCODERS", "FORMAT", "INPUTS", "LOSSES", "STATE_DIM", "TARGET_DIM", "BCNet",
           "BCPolicy", "PolicyArchitecture", "PolicyCollection", "PolicyConfig", "PolicyInference", "PolicyTraining",
           "policy_for_evaluation", "train_policy"]


def __getattr__(name: str) -> Any:
    if name not in _DEFERRED:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    return getattr(importlib.import_module(f"{__name__}.{_DEFERRED[name]}"), name)


def __dir__() -> list[str]:
    return sorted({*globals(), *_DEFERRED})
