"""Reward of the tabletop environment.

The sparse reward is 1 on the step the shared success checker
(:func:`samplehd.tasks.checker.check_success`) first accepts the state, else 0.

The optional dense term (``dense_reward=True``) adds, every step,
``0.1 * (1 - tanh(5 * d))`` where ``d`` is the distance [m] from the tool centre point to the
centre of the first object the task moves: a small pull towards the object that matters, bounded
by 0.1 so that success (1) always dominates an episode's return.
"""

from __future__ import annotations

import math

import numpy as np

from samplehd.fixedmath import norm

__all__ = ["DENSE_SCALE", "dense_term"]

DENSE_SCALE = 0.1


def dense_term(tcp_pos: np.ndarray, object_pos: np.ndarray) -> float:
    """Shaping term for a TCP position and the moved object's position (world) [m]."""
    d = float(norm(np.asarray(tcp_pos) - np.asarray(object_pos)))
    return DENSE_SCALE * (1.0 - math.tanh(5.0 * d))
