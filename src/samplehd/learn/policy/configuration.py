"""What defines a trained behaviour-cloning policy: the ``config.json`` of ``samplehd train policy``
(``--action steering`` or ``waypoint``), declared with :mod:`samplehd.schema` (a bad file is one line
naming the file, the field, the value and what is valid). Needs no PyTorch: ``samplehd evaluate`` reads
it to set the environment up (:meth:`PolicyConfig.env_options`).

Files written before this declaration load unchanged: a key that format-3 files of earlier versions
lack (``inputs``, ``action``, ``model.encoder``, ``inference.zero_channels``) has the value those
versions meant, and the keypose policy's keys they hold (``grid``, ``train.init``) are dropped.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import ClassVar

from samplehd.catalogue.loader import CATALOGUES, LEGACY_CATALOGUE
from samplehd.errors import ConfigError
from samplehd.learn.configuration import ModelConfig, catalogue_options
from samplehd.robot.constants import WRIST_CAMERA
from samplehd.scene.world import SCENE_CAMERA
from samplehd.schema import Config, bounded

__all__ = ["ACTIONS", "CAMERAS", "ENCODERS", "FORMAT", "INPUTS", "LOSSES", "STATE_DIM", "TARGET_DIM",
           "PolicyArchitecture", "PolicyCollection", "PolicyConfig", "PolicyInference", "PolicyTraining"]

FORMAT = 3  # the config format of a policy model (bump when the network or its inputs change)
# joint positions (6), TCP position (3), TCP orientation (6: two rotation columns), finger opening (1),
# joint velocities (6), the gripper command of the previous action (1)
STATE_DIM = 23
# The privileged-state reference adds the target object's position relative to the TCP (3) and its
# orientation (6: two rotation columns) and sees no image.
TARGET_DIM = 9
INPUTS = ("rgb", "state")  # rgb: the visuomotor policy; state: the privileged-state reference
# steering: chunks of steering vectors; waypoint: one waypoint per step (the keypose policy is
# :mod:`samplehd.learn.keypose`)
ACTIONS = ("steering", "waypoint")
CAMERAS = (SCENE_CAMERA, WRIST_CAMERA)  # the cameras the policy looks through, in the network's order
ENCODERS = ("flatten", "keypoints")
LOSSES = ("mse", "l1")


@dataclass(frozen=True)
class PolicyArchitecture(Config, section="model"):
    """Sizes of the network.

    Attributes:
        width: channels of each camera CNN's first layer.
        hidden: width of the head's hidden layers.
        state_dim: length of the state input (:data:`STATE_DIM`, plus :data:`TARGET_DIM` for
            ``inputs: state``).
        encoder: ``flatten`` (the CNN's last map, flattened) or ``keypoints`` (a spatial softmax).
    """

    width: int = bounded(16, lo=1)
    hidden: int = bounded(256, lo=1)
    state_dim: int = bounded(STATE_DIM, lo=1)
    encoder: str = bounded("flatten", choices=ENCODERS)


@dataclass(frozen=True)
class PolicyInference(Config, section="inference"):
    """How the trained policy acts (see :class:`samplehd.learn.policy.inference.BCPolicy`).

    Attributes:
        ensemble: temporal ensembling's weight decay (weights ``exp(-ensemble * i)``); None: execute
            ``execute`` actions of a chunk before predicting again.
        z_floor: lowest TCP target height [m] (the demonstrations' lowest TCP); None: no floor.
        zero_channels: steering values (0-5) always sent as zero.
    """

    ensemble: float | None = bounded(None, lo=0.0)
    z_floor: float | None = bounded(None, unit="m")
    zero_channels: tuple[int, ...] = bounded((), lo=0, hi=5)


@dataclass(frozen=True)
class PolicyCollection(Config, section="collect"):
    """Episodes collected in the environment besides the dataset's (recorded).

    Attributes:
        demos: oracle episodes.
        noise: DART: std of the noise added to the executed velocities, a fraction of full speed.
        dagger_rounds: DAgger rounds after the first ``train.steps``.
        dagger_episodes: episodes per DAgger round.
        dagger_steps: optimiser steps after each DAgger round.
    """

    demos: int = bounded(0, lo=0)
    noise: float = bounded(0.0, lo=0.0, hi=1.0)
    dagger_rounds: int = bounded(0, lo=0)
    dagger_episodes: int = bounded(50, lo=1)
    dagger_steps: int = bounded(1000, lo=1)


@dataclass(frozen=True)
class PolicyTraining(Config, section="train"):
    """How the policy was trained (recorded; a resumed run must match all but ``steps``).

    Attributes:
        steps: optimiser steps in all (DAgger's included).
        seed: seed of the weights, the batches and the collected episodes.
        batch: frames per step.
        stride: every this many frames of an episode is a sample.
        lr: learning rate before the decay.
        loss: ``mse`` or ``l1`` over the chunk.
        near_weight: loss weight of frames near the table.
        gripper_weight: loss weight of the gripper command.
        episodes: training episodes of the dataset.
        frames: training samples of the dataset.
    """

    steps: int = bounded(4000, lo=1)
    seed: int = bounded(0, lo=0)
    batch: int = bounded(64, lo=1)
    stride: int = bounded(2, lo=1)
    lr: float = bounded(1e-3, lo=0.0, lo_open=True)
    loss: str = bounded("mse", choices=LOSSES)
    near_weight: float = bounded(1.0, lo=0.0)
    gripper_weight: float = bounded(1.0, lo=0.0)
    episodes: int = bounded(0, lo=0)
    frames: int = bounded(0, lo=0)


@dataclass(frozen=True)
class PolicyConfig(ModelConfig, section="policy"):
    """A behaviour-cloning policy's config.

    Attributes:
        kind: ``policy``.
        format: :data:`FORMAT` of the samplehd that wrote it.
        dataset: the dataset it was trained on.
        catalogue: the built-in object catalogue of that dataset's scenes (``procedural`` or
            ``shop-vrb``): the one its evaluation and its collected episodes draw from.
        inputs: ``rgb`` (both cameras' RGB, instruction, robot state) or ``state`` (no image; the
            target object's pose instead).
        action: ``steering`` (chunks of steering vectors) or ``waypoint`` (one waypoint per step).
        image: side of the square camera images [px] (0: no image; in a config to train, filled in from
            the dataset).
        chunk: actions per prediction.
        execute: actions of a chunk executed before predicting again.
        tokens: instruction length in tokens.
        model: network sizes.
        inference: how it acts.
        families: the task families of its training episodes.
        collect: episodes collected in the environment.
        train: training options.
    """

    KIND: ClassVar[str] = "policy"
    FORMAT: ClassVar[int] = FORMAT
    DROPPED: ClassVar[tuple[str, ...]] = ("grid", "train.init")

    # A config.json without the field was written before catalogues had names: procedural. The trainer
    # always fills it from the dataset.
    catalogue: str = bounded(LEGACY_CATALOGUE, choices=tuple(CATALOGUES))
    inputs: str = bounded("rgb", choices=INPUTS)
    action: str = bounded("steering", choices=ACTIONS)
    image: int = bounded(0, lo=0, unit="px")
    chunk: int = bounded(8, lo=1)
    execute: int = bounded(4, lo=1)
    tokens: int = bounded(32, lo=1)
    model: PolicyArchitecture = field(default_factory=PolicyArchitecture)
    inference: PolicyInference = field(default_factory=PolicyInference)
    families: tuple[str, ...] = ()
    collect: PolicyCollection = field(default_factory=PolicyCollection)
    train: PolicyTraining = field(default_factory=PolicyTraining)

    def check_trained(self) -> None:
        """An ``rgb`` policy names the side of its images."""
        if self.inputs == "rgb" and self.image < 1:
            raise ConfigError(f"policy.image={self.image}: the rgb policy needs the side of its camera images, "
                              f"an integer ≥ 1 px", field="policy.image")

    def env_options(self) -> dict[str, object]:
        """The environment options the policy needs: RGB of both cameras at its image size and steering
        control; the privileged-state reference (``inputs: state``) needs no image. A policy trained on
        another catalogue than the default one gets its scenes from that catalogue (``scene.catalogue``)."""
        images = {} if self.inputs == "state" else {"cameras": list(CAMERAS), "width": self.image, "height": self.image}
        return {"obs_mode": "state" if self.inputs == "state" else "rgb", **images, "control_mode": "steering",
                **catalogue_options(self.catalogue)}
