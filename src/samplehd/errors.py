"""Exceptions raised by samplehd.

Every error a user can cause derives from :class:`SamplehdError`; the CLI prints its message on one
line and exits with status 2. Messages name the file, field or value at fault and say what is valid.
"""

from __future__ import annotations

__all__ = [
    "ActionError",
    "AssetError",
    "ConfigError",
    "DatasetError",
    "KinematicsError",
    "PlanningError",
    "RenderError",
    "SafetyError",
    "SamplehdError",
    "SceneError",
    "TemplateError",
    "UnreachableError",
]


class SamplehdError(Exception):
    """Base class of every error samplehd raises on bad input or an impossible request."""


class ConfigError(SamplehdError, ValueError):
    """A configuration file or option is malformed or out of range."""


class AssetError(SamplehdError, ValueError):
    """A catalogue entry, asset menu or mesh file is malformed."""


class SceneError(SamplehdError):
    """A scene could not be sampled or a scene file is malformed."""


class TemplateError(SamplehdError, ValueError):
    """An instruction template file is malformed."""


class KinematicsError(SamplehdError, ValueError):
    """A kinematics query is malformed (wrong shape, NaN)."""


class UnreachableError(KinematicsError):
    """No joint configuration inside the limits reaches the requested pose."""


class ActionError(SamplehdError, ValueError):
    """An action or command is malformed (wrong shape, NaN, unknown mode)."""


class SafetyError(SamplehdError):
    """The safety monitor stopped the arm; reset it before commanding motion."""


class RenderError(SamplehdError):
    """Rendering failed: unknown camera, GL backend unavailable, bad resolution."""


class PlanningError(SamplehdError):
    """No motion plan satisfies the task's constraints."""


class DatasetError(SamplehdError):
    """A dataset directory or file is missing, malformed or cannot be written."""
