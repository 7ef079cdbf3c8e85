"""What a trained behaviour-cloning policy asks of the environment, read from its ``config.json``
(:class:`~samplehd.learn.policy.configuration.PolicyConfig`).

Needs no PyTorch: ``samplehd evaluate`` sets the environment up from it before any model is loaded,
and works for the other policies where the ``learn`` extra is not installed.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from samplehd.catalogue.loader import DEFAULT_CATALOGUE
from samplehd.errors import ConfigError
from samplehd.fileio import read_json
from samplehd.learn.policy.configuration import PolicyConfig

__all__ = ["POLICY_CAMERAS", "env_options", "env_options_from_config"]

POLICY_CAMERAS = ("scene", "wrist")  # the cameras the policy looks through, in the network's order


def env_options_from_config(config: PolicyConfig) -> dict[str, Any]:
    """The environment options of a policy config: RGB of both cameras at its image size and steering
    control; the privileged-state reference (``inputs: state``) needs no image, nor does the keypose
    policy (it renders the scene camera's RGB-D itself when it decides). A policy trained on
    another catalogue than the default one gets its scenes from that catalogue (``scene.catalogue``)."""
    if config.inputs == "state" or config.action == "keypose":  # the keypose policy draws its own scene view
        options: dict[str, Any] = {"obs_mode": "state", "control_mode": "steering"}
    else:
        options = {"obs_mode": "rgb", "cameras": list(POLICY_CAMERAS), "width": config.image, "height": config.image,
                   "control_mode": "steering"}
    if config.catalogue != DEFAULT_CATALOGUE:
        options["scene"] = {"catalogue": config.catalogue}
    return options


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
        config = PolicyConfig.from_dict(cfg)
    except ConfigError as exc:
        raise ConfigError(f"models={folder}: config.json: {exc}", field="models") from None
    return env_options_from_config(config)
