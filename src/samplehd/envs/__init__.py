"""samplehd.envs: the Gymnasium environment ``samplehd/Tabletop-v0``, its oracle and wrappers.

Evaluation, levels and the LeRobot adapters live a floor above, in :mod:`samplehd.benchmark`.

Call :func:`register_envs` (``import samplehd`` does) before ``gymnasium.make("samplehd/Tabletop-v0")``.
"""

from __future__ import annotations

from typing import Any

__all__ = ["ENV_ID", "make_tabletop", "register_envs"]

ENV_ID = "samplehd/Tabletop-v0"


def register_envs() -> None:
    """Register ``samplehd/Tabletop-v0`` with Gymnasium (idempotent; imports nothing heavy)."""
    import gymnasium

    if ENV_ID in gymnasium.registry:
        return
    # gymnasium.make consumes its own max_episode_steps (a TimeLimit wrapper; -1: none) and never
    # passes it on, so environments it makes leave the limit to that wrapper: its value is then the
    # one in force (the environment's own limit would otherwise cut every episode at 1500).
    gymnasium.register(
        id=ENV_ID,
        entry_point="samplehd.envs:make_tabletop",
        max_episode_steps=1500,
        kwargs={"max_episode_steps": None},
        disable_env_checker=False,
    )


def make_tabletop(**options: Any) -> Any:
    """The entry point of ``samplehd/Tabletop-v0``: a ``TabletopEnv`` of ``options``.

    A function rather than the class: ``gymnasium.make`` reads a class's ``metadata`` and turns
    ``render_mode="human"`` into ``rgb_array`` behind a pygame window wrapper; given a function it passes
    the mode on, and the config refuses it in one line (nothing here can show a window).
    """
    from samplehd.envs.tabletop import TabletopEnv  # deferred: registering must stay cheap (no mujoco)

    return TabletopEnv(**options)
