"""The behaviour-cloning policy's configuration, kept here so that existing imports work: it lives in
:mod:`samplehd.learn.policy.configuration`, and these are the same objects. Needs no PyTorch.
"""

from __future__ import annotations

from samplehd.learn.policy.configuration import *  # noqa: F403
from samplehd.learn.policy.configuration import __all__  # noqa: F401
