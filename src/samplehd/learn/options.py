"""Which trained policy a ``config.json`` holds, and what it asks of the environment.

A folder of ``samplehd train policy`` holds a behaviour-cloning policy
(:class:`~samplehd.learn.policy.configuration.PolicyConfig`, ``action`` steering or waypoint) or a
keypose policy (:class:`~samplehd.learn.keypose.configuration.KeyposeConfig`, ``action: keypose``);
:mod:`samplehd.learn.registry` says which class reads which. Needs no PyTorch: ``samplehd evaluate`` sets the
environment up from the config before any model is loaded, and works for the other policies where the
``learn`` extra is not installed.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

from samplehd.errors import ConfigError
from samplehd.fileio import read_json
from samplehd.learn.registry import PolicyConfigClass, policy_entry

__all__ = ["env_options", "policy_config_class"]


def policy_config_class(raw: Mapping[str, Any]) -> PolicyConfigClass:
    """The config class of the policy ``config.json`` object ``raw``, told by its ``action``
    (:func:`samplehd.learn.registry.policy_entry`)."""
    return policy_entry(raw).config


def env_options(folder: str | Path) -> dict[str, Any]:
    """The environment options the trained policy in ``folder`` needs; one-line errors naming ``models``."""
    path = Path(folder) / "config.json"
    if not path.exists() and not path.is_symlink():
        raise ConfigError(f"models={folder}: no config.json of a trained policy here (run `samplehd train policy` "
                          f"first)", field="models")
    cfg = read_json(path, ConfigError, f"models={folder}: {path}", field="models")
    if not isinstance(cfg, dict) or cfg.get("kind") != "policy":
        kind = cfg.get("kind") if isinstance(cfg, dict) else None
        raise ConfigError(f"models={folder}: {path} is a {kind!r} model, expected a policy", field="models")
    try:
        config = policy_config_class(cfg).from_dict(cfg)
    except ConfigError as exc:
        raise ConfigError(f"models={folder}: config.json: {exc}", field="models") from None
    return config.env_options()
