"""Exceptions raised by samplehd.

Every error a user can cause derives from :class:`SamplehdError`; the CLI prints its message on one
line and exits with status 2. Messages name the file, field or value at fault and say what is valid.
The library names its own parameters and config fields (``workers=0: must be an integer ≥ 1``), never a
command-line flag; an error whose subject is one carries its name (``field``), and the CLI says it as
its flag (``--workers 0: ...``).
"""

from __future__ import annotations

import importlib
from types import ModuleType

__all__ = [
    "ActionError",
    "AssetError",
    "ConfigError",
    "DatasetError",
    "KinematicsError",
    "MissingExtraError",
    "PlanningError",
    "RenderError",
    "SafetyError",
    "SamplehdError",
    "SceneError",
    "TemplateError",
    "UnreachableError",
    "require_extra",
]


class SamplehdError(Exception):
    """Base class of every error samplehd raises on bad input or an impossible request.

    Attributes:
        field: the parameter or config field the message is about, when the message begins with it
            (``out=/tmp/x: is a file``, ``resume: the config differs ...``), so that a front end can name
            it in its own words; None otherwise.
    """

    def __init__(self, *args: object, field: str | None = None) -> None:
        super().__init__(*args)
        self.field = field


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


class MissingExtraError(ConfigError):
    """An optional dependency of the requested feature is not installed."""


def require_extra(module: str, extra: str, feature: str) -> ModuleType:
    """Import an optional dependency, or fail with one line naming the extra that provides it.

    Args:
        module: module to import (``trimesh``, ``pyarrow.parquet``, ``ray``).
        extra: the samplehd extra that installs it (``mesh``, ``lerobot``, ``ray``).
        feature: what needs it, for the message (``samplehd assets import``).

    Raises:
        MissingExtraError: ``{feature} needs {module}: pip install 'samplehd[{extra}]'``.
    """
    try:
        return importlib.import_module(module)
    except ImportError:
        top = module.split(".")[0]
        raise MissingExtraError(f"{feature} needs {top}, which is not installed: pip install 'samplehd[{extra}]'") \
            from None
