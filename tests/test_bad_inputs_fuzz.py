"""Property-based fuzzing of config documents: any JSON a user might write is either accepted as a
config that survives its own JSON round trip, or refused with a one-line ConfigError — never another
exception, never a value of the wrong type inside an accepted config."""

from __future__ import annotations

import json
import math
from typing import Any

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from samplehd.dataset.config import GenerateConfig, preset_config
from samplehd.envs.config import EnvConfig
from samplehd.errors import ConfigError

BASE = GenerateConfig()
TEMPLATE = BASE.to_dict()
ENV_TEMPLATE = EnvConfig().to_dict()

# JSON leaves, with the nasty ones a config file can hold (Python's json reads NaN and Infinity).
leaves = st.one_of(
    st.none(), st.booleans(), st.integers(min_value=-(2**70), max_value=2**70),
    st.floats(allow_nan=True, allow_infinity=True), st.text(max_size=12),
    st.sampled_from(["scene", "rgb", "mug", "red", "fast", "none", "place", "templates", "", "0", "1e9"]),
)
json_values = st.recursive(leaves, lambda inner: st.one_of(st.lists(inner, max_size=4),
                                                            st.dictionaries(st.text(max_size=8), inner, max_size=3)),
                           max_leaves=8)


def _paths(doc: Any, prefix: tuple[str, ...] = ()) -> list[tuple[str, ...]]:
    out = []
    for k, v in doc.items():
        out.append((*prefix, k))
        if isinstance(v, dict):
            out += _paths(v, (*prefix, k))
    return out


PATHS = _paths(TEMPLATE)
ENV_PATHS = _paths(ENV_TEMPLATE)


@st.composite
def mutated(draw: st.DrawFn, template: dict[str, Any], paths: list[tuple[str, ...]]) -> dict[str, Any]:
    """A partial document: a few fields of the template, some replaced by arbitrary JSON, maybe an
    unknown key."""
    doc: dict[str, Any] = {}
    for path in draw(st.lists(st.sampled_from(paths), min_size=1, max_size=4, unique=True)):
        node = doc
        for key in path[:-1]:
            node = node.setdefault(key, {})
            if not isinstance(node, dict):
                break
        else:
            original = template
            for key in path:
                original = original[key]
            node[path[-1]] = draw(st.one_of(st.just(original), json_values))
    if draw(st.booleans()):
        doc[draw(st.text(min_size=1, max_size=6))] = draw(json_values)
    return doc


def _json_clean(value: Any) -> bool:
    """Only JSON types and finite numbers."""
    if isinstance(value, float):
        return math.isfinite(value)
    if isinstance(value, dict):
        return all(isinstance(k, str) and _json_clean(v) for k, v in value.items())
    if isinstance(value, list):
        return all(_json_clean(v) for v in value)
    return value is None or isinstance(value, bool | int | str)


@settings(max_examples=120, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(mutated(TEMPLATE, PATHS))
def test_generate_config_documents_are_accepted_whole_or_refused_in_one_line(doc: dict[str, Any]) -> None:
    text = json.dumps(doc)  # what a user's file holds
    try:
        config = GenerateConfig.from_dict(json.loads(text), where="fuzz.json", base=preset_config("tiny"))
    except ConfigError as exc:
        assert "\n" not in str(exc) and str(exc).startswith("fuzz.json")
        return
    out = config.to_dict()
    assert _json_clean(out)
    assert GenerateConfig.from_dict(json.loads(json.dumps(out))) == config


@settings(max_examples=80, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(mutated(ENV_TEMPLATE, ENV_PATHS))
def test_env_options_are_accepted_whole_or_refused_in_one_line(doc: dict[str, Any]) -> None:
    try:
        config = EnvConfig.from_kwargs(**json.loads(json.dumps(doc)))
    except ConfigError as exc:
        assert "\n" not in str(exc)
        return
    out = config.to_dict()
    assert _json_clean(out)
    assert EnvConfig.from_kwargs(**json.loads(json.dumps(out))) == config
