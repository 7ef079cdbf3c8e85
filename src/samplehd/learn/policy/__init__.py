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
- :mod:`~samplehd.learn.policy.processing`: the cameras and the robot state vector the network sees;
- :mod:`~samplehd.learn.policy.actions`: steering and waypoint labels, :class:`WaypointExpert` and the
  waypoint follower;
- :mod:`~samplehd.learn.policy.modeling`: the network;
- :mod:`~samplehd.learn.policy.inference`: :class:`BCPolicy`, a trained policy that acts;
- :mod:`~samplehd.learn.policy.preparation`: training arrays from dataset and collected episodes;
- :mod:`~samplehd.learn.policy.training`: :func:`train_policy`, with DART demonstrations and DAgger rounds.

The keypose policy (``--action keypose``), one decision per object moved (where to grasp, where it
goes) from a top-down view of the scene camera's RGB-D, as in Transporter networks, CLIPort and PerAct:

- :mod:`~samplehd.learn.policy.topdown`: :class:`TopDownGrid`, the view;
- :mod:`~samplehd.learn.policy.keyposes`: :func:`decisions` read from recorded episodes, and
  :class:`KeyposeFollower`, which carries a decision out as steering vectors;
- :mod:`~samplehd.learn.policy.keypose_training`: :func:`train_keypose_policy`;
- :mod:`~samplehd.learn.policy.keypose_inference`: :class:`KeyposePolicy`, a trained one that acts, and
  the view and the decoding of the network's maps that training shares.

Importing this package loads only the configuration: ``samplehd evaluate`` reads a policy's
``config.json`` through :mod:`samplehd.learn.options` where PyTorch is not installed. The other names
load their module (and PyTorch, for the network) on first use.
"""

from __future__ import annotations

import importlib
from typing import Any

from samplehd.learn.policy.configuration import (
    ACTIONS,
    ENCODERS,
    FORMAT,
    INPUTS,
    LOSSES,
    STATE_DIM,
    TARGET_DIM,
    PolicyArchitecture,
    PolicyCollection,
    PolicyConfig,
    PolicyGrid,
    PolicyInference,
    PolicyTraining,
)

# name -> the module that defines it, imported on first use (PyTorch, the environment)
_DEFERRED = {
    "BCNet": "modeling",
    "BCPolicy": "inference",
    "CAMERAS": "processing",
    "Decision": "keyposes",
    "KeyposeFollower": "keyposes",
    "KeyposeNet": "modeling",
    "KeyposePolicy": "keypose_inference",
    "TopDownGrid": "topdown",
    "decisions": "keyposes",
    "train_keypose_policy": "keypose_training",
    "WaypointExpert": "actions",
    "follow_waypoints": "actions",
    "moving_frames": "actions",
    "policy_for_evaluation": "inference",
    "train_policy": "training",
    "waypoint_targets": "actions",
    "waypoints": "actions",
}

__all__ = ["ACTIONS", "CAMERAS", "ENCODERS", "FORMAT", "INPUTS", "LOSSES", "STATE_DIM", "TARGET_DIM", "BCNet",
           "BCPolicy", "Decision", "KeyposeFollower", "KeyposeNet", "KeyposePolicy", "PolicyArchitecture",
           "PolicyCollection", "PolicyConfig", "PolicyGrid", "PolicyInference", "PolicyTraining", "TopDownGrid",
           "WaypointExpert", "decisions", "follow_waypoints", "moving_frames", "policy_for_evaluation",
           "train_keypose_policy", "train_policy", "waypoint_targets", "waypoints"]


def __getattr__(name: str) -> Any:
    if name not in _DEFERRED:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    return getattr(importlib.import_module(f"{__name__}.{_DEFERRED[name]}"), name)


def __dir__() -> list[str]:
    return sorted({*globals(), *_DEFERRED})
