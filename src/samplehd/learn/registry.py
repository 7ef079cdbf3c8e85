"""The trained policies: one registration each, read by ``samplehd train policy``, by the evaluation's
``bc`` policy and by :mod:`samplehd.learn.options`.

An entry names the policy's config class (which reads its ``config.json``), the ``action`` values that
select it (``--action``; the ``action`` of its ``config.json``), its trainer and the class that runs it.
The trainer and the runner are named by module path and imported only when asked for, so the registry,
like the configs, needs no PyTorch (``samplehd evaluate`` reads a policy's environment options first).

A new policy is one :func:`register_policy` call below (and its package under ``samplehd.learn``): the
trainer is called as ``train(dataset, out, config, device=..., quiet=..., **options)`` and the runner as
``Runner(config, None, env)`` with a ``net`` whose weights ``model.safetensors`` holds.
"""

from __future__ import annotations

import importlib
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from samplehd.errors import ConfigError
from samplehd.learn.keypose.configuration import ACTION as KEYPOSE_ACTION
from samplehd.learn.keypose.configuration import KeyposeConfig
from samplehd.learn.policy.configuration import ACTIONS as BC_ACTIONS
from samplehd.learn.policy.configuration import PolicyConfig

__all__ = ["POLICY_REGISTRY", "PolicyEntry", "policy_actions", "policy_entry", "policy_for_action",
           "register_policy"]

PolicyConfigClass = type[PolicyConfig] | type[KeyposeConfig]


@dataclass(frozen=True)
class PolicyEntry:
    """One trained policy.

    Attributes:
        name: the policy's name (``bc``, ``keypose``).
        actions: the ``action`` values that select it; the first is the default of its config.
        config: the config class that reads its ``config.json``.
        trainer: ``module:function`` that trains it (``train(dataset, out, config, *, device, quiet, ...)``).
        runner: ``module:class`` that runs it in the environment (``Runner(config, None, env)``).
    """

    name: str
    actions: tuple[str, ...]
    config: PolicyConfigClass
    trainer: str
    runner: str

    def train_function(self) -> Any:
        """The trainer (imports PyTorch)."""
        return _resolve(self.trainer)

    def runner_class(self) -> Any:
        """The class that runs the policy (imports PyTorch)."""
        return _resolve(self.runner)


POLICY_REGISTRY: dict[str, PolicyEntry] = {}


def register_policy(entry: PolicyEntry) -> PolicyEntry:
    """Add a policy; its name and its actions must be new.

    Raises:
        ConfigError: the name or one of the actions is taken.
    """
    taken = [a for a in entry.actions if a in policy_actions()]
    if entry.name in POLICY_REGISTRY or taken:
        raise ConfigError(f"policy {entry.name!r}: name or action {taken or entry.name!r} already registered")
    POLICY_REGISTRY[entry.name] = entry
    return entry


def policy_actions() -> tuple[str, ...]:
    """Every registered ``action``, in registration order (the ``--action`` choices)."""
    return tuple(a for e in POLICY_REGISTRY.values() for a in e.actions)


def policy_for_action(action: str) -> PolicyEntry:
    """The policy an ``action`` selects.

    Raises:
        ConfigError: no policy has that action (the message lists the valid ones).
    """
    for entry in POLICY_REGISTRY.values():
        if action in entry.actions:
            return entry
    raise ConfigError(f"action={action!r}: valid: {', '.join(policy_actions())}", field="action")


def policy_entry(raw: Mapping[str, Any]) -> PolicyEntry:
    """The policy whose ``config.json`` object is ``raw``, told by its ``action`` (absent, or unknown: the
    first registered policy, whose config then names what is wrong)."""
    action = str(raw.get("action", ""))
    return next((e for e in POLICY_REGISTRY.values() if action in e.actions), next(iter(POLICY_REGISTRY.values())))


def _resolve(spec: str) -> Any:
    # Trainers and runners import PyTorch: imported when asked for, so that the registry does not.
    module, attr = spec.split(":")
    return getattr(importlib.import_module(module), attr)


register_policy(PolicyEntry("bc", BC_ACTIONS, PolicyConfig, "samplehd.learn.policy.training:train_policy",
                            "samplehd.learn.policy.inference:BCPolicy"))
register_policy(PolicyEntry("keypose", (KEYPOSE_ACTION,), KeyposeConfig,
                            "samplehd.learn.keypose.training:train_keypose",
                            "samplehd.learn.keypose.inference:KeyposePolicy"))
