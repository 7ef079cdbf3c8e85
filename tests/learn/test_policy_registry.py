"""One registration per trained policy: `samplehd train policy` and `samplehd evaluate --policy bc` reach
every registered policy through :mod:`samplehd.learn.registry`, and nothing else lists them."""

from __future__ import annotations

import inspect

import pytest

from samplehd.cli import build_parser
from samplehd.errors import ConfigError
from samplehd.learn.registry import POLICY_REGISTRY, policy_actions, policy_entry, policy_for_action


def test_every_registered_policy_is_reachable_from_train_and_evaluate() -> None:
    pytest.importorskip("torch")
    from samplehd.benchmark.evaluation import LEARNED
    from samplehd.commands.train import POLICY_FLAGS
    from samplehd.learn.options import policy_config_class

    assert set(POLICY_FLAGS) == set(POLICY_REGISTRY) and len(POLICY_REGISTRY) >= 2
    assert LEARNED["bc"] == "samplehd.learn.policy.inference:policy_for_evaluation"
    seen = []
    for entry in POLICY_REGISTRY.values():
        for action in entry.actions:
            args = build_parser("train").parse_args(["train", "policy", "--dataset", "d", "--out", "o",
                                                     "--action", action])
            assert policy_for_action(args.action) is entry
            config, options = POLICY_FLAGS[entry.name](args, 5)
            assert isinstance(config, entry.config) and config.train.steps == 5
            # evaluate reads the written config.json back to the same entry, its config class and runner
            written = config.to_dict()
            assert written["action"] == action
            assert policy_entry(written) is entry and policy_config_class(written) is entry.config
            train = entry.train_function()
            assert set(options) <= set(inspect.signature(train).parameters)
            assert {"dataset", "out", "config", "device", "quiet"} <= set(inspect.signature(train).parameters)
            assert inspect.isclass(entry.runner_class())
            seen.append(action)
    assert tuple(seen) == policy_actions()


def test_an_unknown_action_is_refused_with_the_valid_ones_and_a_config_without_one_is_bc() -> None:
    with pytest.raises(ConfigError, match="valid: steering, waypoint, keypose"):
        policy_for_action("teleport")
    assert policy_entry({"kind": "policy"}).name == "bc"
    assert policy_entry({"action": "keypose"}).name == "keypose"
