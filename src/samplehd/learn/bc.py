"""The behaviour-cloning policy's former single module, kept so that existing imports work: every name
it held now lives in the package :mod:`samplehd.learn.policy` (one module per job) and is the same
object here. New code imports from the package.
"""

# The names below are re-exported for existing imports; only those of `__all__` are star-imported, as before.
# ruff: noqa: F401

from __future__ import annotations

from samplehd.learn.options import POLICY_CAMERAS, env_options, env_options_from_config
from samplehd.learn.policy.actions import (
    CLOSE_BELOW,
    WAYPOINT_AHEAD,
    WAYPOINT_GAIN,
    WAYPOINT_REACHED,
    WAYPOINT_SCALE,
    WAYPOINT_SPEED,
    YAW_GAIN,
    WaypointExpert,
    _follow,
    _speeds,
    _wrap,
    _yaw,
    follow_waypoints,
    moving_frames,
    waypoint_targets,
    waypoints,
)
from samplehd.learn.policy.configuration import (
    ACTIONS,
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
from samplehd.learn.policy.inference import BCPolicy, policy_for_evaluation
from samplehd.learn.policy.modeling import BCNet, Encoder, KeypointEncoder
from samplehd.learn.policy.preparation import (
    _collected_arrays,
    _episode_arrays,
    _image_size,
    _inputs_state,
    _labels,
    _load_arrays,
    _save_arrays,
)
from samplehd.learn.policy.processing import (
    CAMERAS,
    _joint_vel,
    _rotation_columns,
    _state,
    _target_features,
)
from samplehd.learn.policy.training import (
    DAGGER_FILE,
    DEMOS_FILE,
    NEAR_TABLE,
    RARE_CHANNEL,
    _dagger_policy,
    _waypoint_dagger_episode,
    train_policy,
)

__all__ = ["BCPolicy", "PolicyConfig", "env_options", "policy_for_evaluation", "train_policy"]
