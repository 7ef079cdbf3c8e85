"""samplehd.envs: the Gymnasium environment ``samplehd/Tabletop-v0``, its oracle and evaluation.

Call :func:`register_envs` (``import samplehd`` does) before ``gymnasium.make("samplehd/Tabletop-v0")``.
"""

from __future__ import annotations

__all__ = ["ENV_ID", "register_envs"]

ENV_ID = "samplehd/Tabletop-v0"


def register_envs() -> None:
    """Register ``samplehd/Tabletop-v0`` with Gymnasium (idempotent; imports nothing heavy)."""
    import gymnasium

    if ENV_ID in gymnasium.registry:
        return
    gymnasium.register(
        id=ENV_ID,
        entry_point="samplehd.envs.tabletop:TabletopEnv",
        max_episode_steps=None,
        disable_env_checker=False,
    )
