"""One way to declare a config: samplehd.schema.Config gives validation, to_dict and from_dict."""

from __future__ import annotations

import dataclasses
import json

import pytest

from samplehd.benchmark.evaluation import EvalConfig
from samplehd.dataset.config import GenerateConfig, InstructionConfig
from samplehd.dataset.render import RenderConfig
from samplehd.envs.config import EnvConfig
from samplehd.errors import ConfigError
from samplehd.record.disturbances import DisturbanceConfig
from samplehd.record.paths import PathConfig
from samplehd.robot.controller import ControlConfig
from samplehd.robot.safety import SafetyConfig
from samplehd.scene.config import SceneConfig
from samplehd.scene.world import WorldConfig
from samplehd.schema import Config
from samplehd.tasks.checker import CheckerConfig
from samplehd.world.planner_config import PlannerConfig

CONFIGS = [CheckerConfig, ControlConfig, DisturbanceConfig, EnvConfig, EvalConfig, GenerateConfig, InstructionConfig,
           PathConfig, PlannerConfig, RenderConfig, SafetyConfig, SceneConfig, WorldConfig]


@pytest.mark.parametrize("cls", CONFIGS, ids=lambda c: c.__name__)
def test_a_config_is_declared_once_and_round_trips_through_json(cls: type[Config]) -> None:
    assert issubclass(cls, Config) and dataclasses.is_dataclass(cls)
    cfg = cls()
    doc = json.loads(json.dumps(cfg.to_dict()))
    assert cls.from_dict(doc) == cfg


@pytest.mark.parametrize("cls, bad, where", [
    (ControlConfig, {"physics_hz": -1.0}, "ControlConfig.physics_hz=-1.0"),
    (ControlConfig, {"control_hz": 30.0}, "ControlConfig.physics_hz=500.0"),
    (ControlConfig, {"safety_checks_per_step": 4}, "ControlConfig.safety_checks_per_step=4"),
    (ControlConfig, {"max_cartesian_delta": [0.05, -1.0]}, "ControlConfig.max_cartesian_delta[1]=-1.0"),
    (SafetyConfig, {"torque_ratio": 0.0}, "SafetyConfig.torque_ratio=0.0"),
    (SafetyConfig, {"nope": 1}, "SafetyConfig: unknown option(s) ['nope']"),
    (EnvConfig, {"width": 0}, "Tabletop-v0.width=0"),
    (EnvConfig, {"physics_hz": 510.0}, "Tabletop-v0.physics_hz=510.0"),
    (EnvConfig, {"obs_mode": "rgb", "cameras": []}, "Tabletop-v0.cameras=[]"),
    (EvalConfig, {"episodes": 0}, "EvalConfig.episodes=0"),
    (EvalConfig, {"policy": "bc"}, "EvalConfig.policy='bc'"),
    (EvalConfig, {"env": {"nope": 1}}, "EvalConfig.env: unknown option(s) ['nope']"),
    (WorldConfig, {"timestep": 0.5}, "world.timestep=0.5"),
    (DisturbanceConfig, {"kinds": ["slip", "slip"]}, "disturbances.kinds=['slip', 'slip']"),
    (WorldConfig, {"cameras": [{"name": "a", "pos": [1, 0, 1]}]}, "world.cameras[0]: missing option(s) ['target']"),
])
def test_errors_are_one_line_and_name_the_field(cls: type[Config], bad: dict, where: str) -> None:
    with pytest.raises(ConfigError) as err:
        cls.from_dict(bad)
    assert str(err.value).startswith(where) and "\n" not in str(err.value)


def test_a_nested_config_comes_from_its_json_object() -> None:
    cfg = ControlConfig.from_dict({"safety": {"max_contact_force": 90}})
    assert cfg.safety == SafetyConfig(max_contact_force=90.0)
    assert ControlConfig.from_dict({"safety": None}).safety is None


def test_the_command_line_says_a_library_field_as_its_flag() -> None:
    from samplehd.cli import build_parser
    from samplehd.commands._options import in_flags, option_flags
    from samplehd.errors import DatasetError

    flags = option_flags(build_parser("generate").parse_args(["generate", "--out", "x"])._parser)
    err = DatasetError("out=/d: already holds a dataset; pass `resume` to continue it or choose another `out`",
                       field="out")
    assert in_flags(err, flags) == ("--out /d: already holds a dataset; pass --resume to continue it or choose "
                                    "another --out")
    assert in_flags(ConfigError("resume: the config differs", field="resume"), flags) == "--resume: the config differs"
    # A backticked name that is no option of the command stays as the library wrote it.
    assert in_flags(ConfigError("run `samplehd rerender` or set `nothing`"), flags) == (
        "run `samplehd rerender` or set `nothing`")
