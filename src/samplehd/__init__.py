"""samplehd: a MuJoCo simulator and dataset generator for language-conditioned tabletop manipulation."""

from __future__ import annotations

from samplehd.render.backend import configure_gl_backend

# Must run before anything imports mujoco: MuJoCo fixes its GL backend at first import.
configure_gl_backend()

from samplehd.envs import register_envs  # noqa: E402
from samplehd.errors import SamplehdError  # noqa: E402
from samplehd.version import __version__  # noqa: E402

# `gymnasium.make("samplehd/Tabletop-v0")` works after `import samplehd` (string entry point: cheap).
register_envs()

__all__ = ["SamplehdError", "__version__"]
