"""A LeRobot checkpoint as a ``samplehd evaluate`` policy: ``--policy lerobot:CKPT``.

``CKPT`` is the ``pretrained_model`` folder ``lerobot-train`` writes (``config.json``,
``model.safetensors``, the processor pipelines, ``train_config.json``), or the checkpoint folder
above it. LeRobot's own code loads it (its policies read their weights with safetensors, never by
unpickling), so lerobot must be importable: run samplehd from LeRobot's Python 3.12 venv.

Every step does what ``lerobot-eval``'s rollout does: the observation in LeRobot's names
(:func:`samplehd.envs.lerobot_contract.lerobot_observation`), LeRobot's ``preprocess_observation``,
the instruction text as ``task``, the checkpoint's preprocessor, ``select_action`` and its
postprocessor. On the same split episodes and step limit a checkpoint therefore acts as it does under
``lerobot-eval --env.type=samplehd``, and ``samplehd evaluate`` judges it with the same checker.

The environment is the one the policy was trained for: the options that ``samplehd export lerobot``
recorded in the training dataset (``train_config.json``'s ``dataset.root``, its
``meta/samplehd.json``), else cameras and image size from the checkpoint's input features (steering
control at 20 Hz, Tabletop-v0's defaults for the rest).
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from samplehd.dataset.lerobot_contract import EXPORT_RECORD, IMAGE_PREFIX, lerobot_features, read_export_record
from samplehd.envs.config import EnvConfig
from samplehd.envs.lerobot_contract import env_options_from_export, lerobot_observation
from samplehd.envs.observation import Observation
from samplehd.errors import ConfigError
from samplehd.render.image_spec import ImageSpec

__all__ = ["LEROBOT_PREFIX", "LeRobotCheckpoint", "LeRobotPolicy", "export_root", "is_lerobot_policy",
           "read_lerobot_checkpoint"]

LEROBOT_PREFIX = "lerobot:"
CONFIG_FILE = "config.json"
WEIGHTS_FILE = "model.safetensors"
TRAIN_CONFIG_FILE = "train_config.json"
PRETRAINED_DIR = "pretrained_model"
_LONGEST_PATH = 4096  # PATH_MAX of Linux [bytes]


def is_lerobot_policy(spec: str) -> bool:
    """Whether ``spec`` names a LeRobot checkpoint (``lerobot:CKPT``)."""
    return spec.startswith(LEROBOT_PREFIX)


@dataclass(frozen=True)
class LeRobotCheckpoint:
    """A checked LeRobot checkpoint and the environment it was trained for.

    Attributes:
        spec: the policy as given (``lerobot:CKPT``).
        path: the ``pretrained_model`` folder.
        policy_type: LeRobot's policy type (``act``, ``diffusion``, ...).
        features: the checkpoint's input and output features: name → shape (images channel first).
        env: Tabletop-v0 options whose observations match the features.
        env_source: the file the options came from.
        families: the training data's task families (empty: not recorded).
    """

    spec: str
    path: Path
    policy_type: str
    features: dict[str, tuple[int, ...]]
    env: dict[str, Any] = field(default_factory=dict)
    env_source: str = ""
    families: tuple[str, ...] = ()

    def check_env(self, options: dict[str, Any]) -> None:
        """Raise ConfigError unless the environment ``options`` give every feature the policy reads.

        Raises:
            ConfigError: ``policy='lerobot:…': the policy reads observation.images.scene (3, 96, 96); the
                environment gives …``.
        """
        config = EnvConfig.from_kwargs(**options)
        if "rgb" not in config.modalities or config.control_mode != "steering":
            raise ConfigError(f"policy={self.spec!r}: LeRobot policies of a samplehd export need RGB images and "
                              f"steering control; the environment has obs_mode={config.obs_mode!r}, "
                              f"control_mode={config.control_mode!r}", field="policy")
        given = {f.name: f.policy_shape for f in lerobot_features(config.image).values()}
        for name, shape in self.features.items():
            if given.get(name) != shape:
                offer = ", ".join(f"{k} {v}" for k, v in given.items())
                raise ConfigError(f"policy={self.spec!r}: the policy reads {name} {shape}; the environment "
                                  f"({self.env_source or 'options'}) gives {offer}", field="policy")


def _fail(spec: str, why: str) -> ConfigError:
    return ConfigError(f"policy={spec!r}: {why}", field="policy")


def _checkpoint_folder(spec: str) -> Path:
    text = spec[len(LEROBOT_PREFIX):]
    if not text:
        raise _fail(spec, "name a checkpoint folder after `lerobot:` (e.g. "
                          "lerobot:outputs/act/checkpoints/last/pretrained_model)")
    if len(text) > _LONGEST_PATH:
        raise _fail(spec[:80] + "…", f"a path of {len(text)} characters; the file system takes at most {_LONGEST_PATH}")
    try:
        path = Path(text).expanduser()
        folder = path.is_dir()
    except RuntimeError:  # ~user of a user this machine does not know
        raise _fail(spec, f"cannot expand {text.split('/')[0]!r}: no such user; give the checkpoint's path") from None
    except OSError as exc:
        raise _fail(spec, f"cannot read {text!r} ({exc.strerror}); give the checkpoint's path") from None
    if not folder:
        raise _fail(spec, f"no folder {str(path)!r}; expected lerobot-train's checkpoint folder "
                          f"(…/checkpoints/last/{PRETRAINED_DIR}, with {CONFIG_FILE} and {WEIGHTS_FILE})")
    if not (path / CONFIG_FILE).is_file() and (path / PRETRAINED_DIR / CONFIG_FILE).is_file():
        path = path / PRETRAINED_DIR
    if not (path / CONFIG_FILE).is_file():
        raise _fail(spec, f"no {CONFIG_FILE} in {str(path)!r}; expected lerobot-train's checkpoint folder "
                          f"(…/checkpoints/last/{PRETRAINED_DIR}, with {CONFIG_FILE} and {WEIGHTS_FILE})")
    return path


def _read_json(spec: str, path: Path) -> dict[str, Any]:
    try:
        doc = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError) as exc:
        raise _fail(spec, f"cannot read {str(path)!r} ({type(exc).__name__}); save the checkpoint again") from None
    if not isinstance(doc, dict):
        raise _fail(spec, f"{str(path)!r} is not a JSON object; save the checkpoint again")
    return doc


def _known_policy_types(spec: str) -> list[str]:
    """LeRobot's registered policy types; the one place that says lerobot is needed."""
    try:
        import lerobot.policies  # noqa: F401  (registers every policy config)
        from lerobot.configs.policies import PreTrainedConfig
    except ImportError as exc:
        raise _fail(spec, f"needs lerobot (Python >= 3.12), which is not importable here ({exc}); run samplehd "
                          "from LeRobot's venv (docs/LEROBOT.md)") from None
    return sorted(PreTrainedConfig.get_known_choices())


def _features(spec: str, config: dict[str, Any]) -> dict[str, tuple[int, ...]]:
    """The checkpoint's input and output features, checked to be ones a samplehd export has."""
    out: dict[str, tuple[int, ...]] = {}
    for group in ("input_features", "output_features"):
        feats = config.get(group)
        if not isinstance(feats, dict) or not feats:
            raise _fail(spec, f"{CONFIG_FILE} has no {group}; expected a policy trained by lerobot-train")
        for name, feat in feats.items():
            shape = feat.get("shape") if isinstance(feat, dict) else None
            if not (isinstance(shape, list) and all(isinstance(n, int) and n > 0 for n in shape)):
                raise _fail(spec, f"{CONFIG_FILE}: feature {name!r} has no shape")
            out[name] = tuple(shape)
    known = {f.name for f in lerobot_features(ImageSpec(cameras=())).values()}
    for name, shape in out.items():
        if name.startswith(IMAGE_PREFIX) and len(shape) == 3 and shape[0] == 3:
            continue
        if name not in known:
            raise _fail(spec, f"the policy reads {name!r}, which samplehd's environment does not give; it gives "
                              f"{IMAGE_PREFIX}<camera>, {', '.join(sorted(known))} (a policy trained on "
                              "`samplehd export lerobot` data)")
    return out


def _env_from_features(features: dict[str, tuple[int, ...]], spec: str) -> dict[str, Any]:
    images = {name[len(IMAGE_PREFIX):]: shape for name, shape in features.items() if name.startswith(IMAGE_PREFIX)}
    if not images:
        raise _fail(spec, "the policy reads no camera image; samplehd's LeRobot environment renders RGB cameras")
    sizes = sorted({shape[1:] for shape in images.values()})
    if len(sizes) > 1:
        raise _fail(spec, f"the policy's cameras differ in size {sizes}; the environment renders every camera alike")
    (height, width), = sizes
    return {"obs_mode": "rgb", "cameras": list(images), "width": width, "height": height,
            "control_mode": "steering", "control_hz": 20.0}


def export_root(checkpoint: Path, train_config: dict[str, Any]) -> Path | None:
    """The samplehd export the checkpoint was trained on (``train_config.json``'s ``dataset.root``
    holding ``meta/samplehd.json``), or None. A relative root is relative to the folder lerobot-train
    ran in, not to today's working folder: the folder above the checkpoint that holds its
    ``output_dir``, else the nearest folder above the checkpoint where the root is an export.

    Args:
        checkpoint: the ``pretrained_model`` folder.
        train_config: its ``train_config.json`` (``{}`` when absent).
    """
    dataset = train_config.get("dataset")
    root = dataset.get("root") if isinstance(dataset, dict) else None
    if not isinstance(root, str) or not root:
        return None
    if Path(root).is_absolute():
        return Path(root) if (Path(root) / EXPORT_RECORD).is_file() else None
    here = checkpoint.absolute()
    output_dir = train_config.get("output_dir")
    bases = list(here.parents)
    if isinstance(output_dir, str) and output_dir and not Path(output_dir).is_absolute():
        ran_in = [b for b in bases if (b / output_dir) in (here, *here.parents)]
        bases = ran_in + [b for b in bases if b not in ran_in]
    return next((b / root for b in bases if (b / root / EXPORT_RECORD).is_file()), None)


def read_lerobot_checkpoint(spec: str) -> LeRobotCheckpoint:
    """Check a ``lerobot:CKPT`` policy and find its environment, before anything runs.

    Raises:
        ConfigError: one line naming the policy: no such folder, no ``config.json`` or
            ``model.safetensors``, lerobot not importable, an unknown policy type, features that
            samplehd's environment does not give, or an export record that does not match them.
    """
    path = _checkpoint_folder(spec)
    config = _read_json(spec, path / CONFIG_FILE)
    policy_type = config.get("type")
    if not isinstance(policy_type, str) or not policy_type:
        raise _fail(spec, f"{CONFIG_FILE} has no policy type; expected a policy saved by LeRobot")
    known = _known_policy_types(spec)
    if policy_type not in known:
        raise _fail(spec, f"unknown LeRobot policy type {policy_type!r}; this lerobot knows {', '.join(known)}")
    if not (path / WEIGHTS_FILE).is_file():
        raise _fail(spec, f"no {WEIGHTS_FILE} in {str(path)!r}; the checkpoint is incomplete")
    features = _features(spec, config)
    train_config = _read_json(spec, path / TRAIN_CONFIG_FILE) if (path / TRAIN_CONFIG_FILE).is_file() else {}
    root = export_root(path, train_config)
    if root is not None:
        env, source = env_options_from_export(root), str(root / EXPORT_RECORD)
        families = tuple(read_export_record(root).get("families") or ())
    else:
        env, source, families = _env_from_features(features, spec), str(path / CONFIG_FILE), ()
        dataset = train_config.get("dataset")
        if isinstance(dataset, dict) and dataset.get("root"):  # say why the export's settings are not used
            source += f" (its {TRAIN_CONFIG_FILE}'s dataset.root {dataset['root']!r} holds no samplehd export)"
    checkpoint = LeRobotCheckpoint(spec, path, policy_type, features, env, source, families)
    checkpoint.check_env(env)
    return checkpoint


class LeRobotPolicy:
    """A LeRobot checkpoint acting in Tabletop-v0 as ``lerobot-eval`` runs it (see the module docstring).

    Args:
        checkpoint: from :func:`read_lerobot_checkpoint`.
        env: the Tabletop-v0 environment the policy acts in.
    """

    def __init__(self, checkpoint: LeRobotCheckpoint, env: Any) -> None:
        import torch
        from lerobot.configs.policies import PreTrainedConfig
        from lerobot.envs.utils import preprocess_observation
        from lerobot.policies.factory import get_policy_class, make_pre_post_processors

        path = str(checkpoint.path)
        config = PreTrainedConfig.from_pretrained(path)
        config.pretrained_path = checkpoint.path
        self.policy = get_policy_class(config.type).from_pretrained(path, config=config)
        self.policy.eval()
        # As lerobot-eval: the processors on the device the policy runs on, no renaming of observations.
        self.preprocessor, self.postprocessor = make_pre_post_processors(
            policy_cfg=config, pretrained_path=path,
            preprocessor_overrides={"device_processor": {"device": str(config.device)},
                                    "rename_observations_processor": {"rename_map": {}}})
        self._torch, self._preprocess = torch, preprocess_observation
        self.env = env
        self.cameras = tuple(env.unwrapped.config.cameras)
        self.task = ""

    @classmethod
    def load(cls, spec: str, env: Any) -> LeRobotPolicy:
        """The policy ``lerobot:CKPT`` for ``env``."""
        return cls(read_lerobot_checkpoint(spec), env)

    def reset(self, seed: int | None = None) -> None:
        """Start an episode: clear the policy's action queue and read the new instruction."""
        self.policy.reset()
        if seed is not None:  # sampling policies (diffusion) act the same on an episode whatever ran before
            self._torch.manual_seed(int(seed))
        self.task = str(self.env.unwrapped.episode.text)

    def __call__(self, obs: Observation) -> np.ndarray:
        batch = self._preprocess(lerobot_observation(obs, self.cameras))
        batch["task"] = [self.task]
        batch = self.preprocessor(batch)
        with self._torch.inference_mode():
            action = self.policy.select_action(batch)
        return self.postprocessor(action).to("cpu").numpy()[0]

