"""The behaviour-cloning policy's configuration, kept here so that existing imports work: it lives in
:mod:`samplehd.learn.policy.configuration`, and these are the same objects. Needs no PyTorch.
"""

from __future__ import annotations

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
    PolicyInference,
    PolicyTraining,
)

__all__ = ["ACTIONS", "ENCODERS", "FORMAT", "INPUTS", "LOSSES", "STATE_DIM", "TARGET_DIM", "PolicyArchitecture",
           "PolicyCollection", "PolicyConfig", "PolicyInference", "PolicyTraining"]
