"""What defines a trained keypose policy: the ``config.json`` of ``samplehd train policy --action
keypose``, declared with :mod:`samplehd.schema` (a bad file is one line naming the file, the field, the
value and what is valid). Needs no PyTorch: ``samplehd evaluate`` reads it to set the environment up
(:meth:`KeyposeConfig.env_options`).

Its files say ``kind: policy`` and ``action: keypose``, as the behaviour-cloning policy's files say
``kind: policy`` and their action (``samplehd evaluate --policy bc`` runs either). Files of earlier
versions, written with the behaviour-cloning policy's keys, load unchanged: the keys this policy never
used (``image``, ``chunk``, ``execute``, ``inference``, ``collect`` and the network and training options
of the other network) are dropped.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from functools import cache
from typing import Any, ClassVar, Self

import numpy as np

from samplehd.benchmark.axes import BLANK_INSTRUCTION
from samplehd.catalogue.loader import CATALOGUES, LEGACY_CATALOGUE
from samplehd.envs.tokens import SPECIAL_TOKENS, encode_instruction, instruction_vocabulary
from samplehd.errors import ConfigError
from samplehd.learn.configuration import ModelConfig, catalogue_options
from samplehd.schema import Config, bounded

__all__ = ["ACTION", "ATTRIBUTE_VALUES", "BLANK_TEXT", "FORMAT", "GRASP_HEADS", "INPUTS", "KEYPOSE_ATTRIBUTES",
           "LANGUAGE", "KeyposeArchitecture", "KeyposeConfig", "KeyposeGrid", "KeyposeTraining", "KeyposeVocabulary",
           "ShapeRange", "policy_instruction", "policy_tokens"]

FORMAT = 3  # the config format of a keypose policy (bump when the network or its inputs change)
# the ``action`` its config.json names (the behaviour-cloning policy's: steering, waypoint)
ACTION = "keypose"
# rgb: the scene camera's RGB-D re-projected from above; state: that view, the cells of the objects the
# task moves marked (the privileged-state reference)
INPUTS = ("rgb", "state")
# instruction: the policy reads the instruction; blank: a language-blind control that reads the neutral
# text BLANK_TEXT in training and when it acts (the benchmark's blank instruction: no word, the full stop).
LANGUAGE = ("instruction", "blank")
BLANK_TEXT = BLANK_INSTRUCTION
GRASP_HEADS = ("film", "product")  # how the grasp's heat reads the instruction (KeyposeArchitecture.grasp_head)
KEYPOSE_ATTRIBUTES = ("name", "color", "material", "size")  # the scene annotation's keys the auxiliary maps name
ATTRIBUTE_VALUES = 32  # logits per attribute (the catalogues have at most 16 values of any)


@dataclass(frozen=True)
class KeyposeArchitecture(Config, section="model"):
    """Sizes of the network.

    Attributes:
        width: channels of the U-Net's first level.
        grasp_head: ``film``: the grasp's maps read the instruction through the FiLM-modulated features
            alone; ``product``: their heat also adds, per cell, the product of a key of the cell's features
            with a query of the instruction (:data:`GRASP_HEADS`).
        placed_count: the instruction's code also reads how many objects the policy has put down so far
            in the episode (0 for the first decision; a learnt vector per count up to
            :data:`~samplehd.learn.keypose.modeling.PLACED_COUNTS`), so that what it looks for can change
            from one object of a multi-object task to the next.
    """

    width: int = bounded(16, lo=1)
    grasp_head: str = bounded("film", choices=GRASP_HEADS)
    placed_count: bool = False


@dataclass(frozen=True)
class KeyposeGrid(Config, section="grid"):
    """What the keypose policy looks at (:mod:`samplehd.learn.topdown`): the scene camera's RGB-D
    image at ``width`` × ``height`` px, re-projected onto ``rows`` × ``cols`` cells of side ``cell`` from
    the corner ``origin`` (world x, y)."""

    camera: str = "scene"
    width: int = bounded(640, lo=1, unit="px")
    height: int = bounded(360, lo=1, unit="px")
    origin: tuple[float, ...] = (-0.512, -0.64)
    cell: float = bounded(0.008, lo=0.0, lo_open=True, unit="m")
    rows: int = bounded(128, lo=16)
    cols: int = bounded(160, lo=16)

    def __post_init__(self) -> None:
        super().__post_init__()
        if len(self.origin) != 2:
            raise ConfigError(f"grid.origin={list(self.origin)}: the grid's corner, two numbers (world x, y) [m]",
                              field="grid.origin")
        if self.rows % 16 or self.cols % 16:
            raise ConfigError(f"grid.rows={self.rows}, grid.cols={self.cols}: each a multiple of 16 (the network "
                              f"halves the grid four times)", field="grid.rows")


@dataclass(frozen=True)
class KeyposeTraining(Config, section="train"):
    """How the keypose policy was trained (recorded; a resumed run must match all but ``steps``).

    Attributes:
        steps: optimiser steps.
        seed: seed of the weights and the batches.
        batch: decisions per step.
        lr: learning rate before the decay.
        episodes: training episodes of the dataset.
        init: the folder of the keypose policy whose weights the training started from ("": none).
        word_dropout: the share of an instruction's words read as ``<UNK>`` in each training batch, so
            that no single word decides (a trained ``<UNK>`` means "a word I do not know"; the policy
            then reads every word outside its training instructions as one: see :func:`policy_tokens`).
        attribute_weight: the weight of the auxiliary maps' loss (per cell, the class, colour, material
            and size of the object seen there) beside the grasp's and the goal's.
    """

    steps: int = bounded(3000, lo=1)
    seed: int = bounded(0, lo=0)
    batch: int = bounded(16, lo=1)
    lr: float = bounded(1e-3, lo=0.0, lo_open=True)
    episodes: int = bounded(0, lo=0)
    init: str = ""
    word_dropout: float = bounded(0.1, lo=0.0, hi=1.0, hi_open=True)
    attribute_weight: float = bounded(0.5, lo=0.0)


@dataclass(frozen=True)
class ShapeRange(Config, section="vocabulary.shapes"):
    """The sizes one known class was seen with on the policy's map of its training views (the 10th to
    90th percentile of its objects' :func:`samplehd.learn.keypose.exclusion.object_shape`).

    Attributes:
        name: the class.
        low: the smallest (height, length, width) [m].
        high: the largest (height, length, width) [m].
    """

    name: str
    low: tuple[float, float, float]
    high: tuple[float, float, float]


@dataclass(frozen=True)
class KeyposeVocabulary(Config, section="vocabulary"):
    """What the keypose policy was trained on, for grounding by exclusion
    (:mod:`samplehd.learn.keypose.exclusion`): the words of its training instructions and, per attribute
    of :data:`KEYPOSE_ATTRIBUTES`, the values its auxiliary maps name, in the order of their logits
    (a held-out class is none of ``name``'s). Filled in from the dataset by the trainer; empty in the
    files of earlier versions (the rule then never fires).

    Attributes:
        words: the training instructions' words.
        name: object classes.
        color: colours.
        material: materials.
        size: sizes.
        shapes: the sizes each class of ``name`` was seen with (empty in the files of earlier versions:
            any size then fits any class).
    """

    words: tuple[str, ...] = ()
    name: tuple[str, ...] = ()
    color: tuple[str, ...] = ()
    material: tuple[str, ...] = ()
    size: tuple[str, ...] = ()
    shapes: tuple[ShapeRange, ...] = ()

    def values(self, attribute: str) -> tuple[str, ...]:
        """The values of one attribute of :data:`KEYPOSE_ATTRIBUTES`."""
        return tuple(getattr(self, attribute))


@dataclass(frozen=True)
class KeyposeConfig(ModelConfig, section="policy"):
    """A keypose policy's config.

    Attributes:
        kind: ``policy``.
        format: :data:`FORMAT` of the samplehd that wrote it.
        dataset: the dataset it was trained on (the first, when there were several).
        more_datasets: the others it was trained on with it (their episodes added to the first's).
        catalogue: the built-in object catalogue of that dataset's scenes: the one its evaluation
            draws from.
        inputs: ``rgb`` or ``state`` (:data:`INPUTS`).
        language: ``instruction``, or ``blank`` for the language-blind control (:data:`LANGUAGE`).
        action: ``keypose``.
        tokens: instruction length in tokens.
        model: network sizes.
        grid: its view of the table.
        families: the task families of its training episodes.
        train: training options.
        vocabulary: the words and attribute values it was trained on.
    """

    KIND: ClassVar[str] = "policy"
    FORMAT: ClassVar[int] = FORMAT
    DROPPED: ClassVar[tuple[str, ...]] = (
        "image", "chunk", "execute", "inference", "collect", "model.hidden", "model.state_dim", "model.encoder",
        "train.stride", "train.loss", "train.near_weight", "train.gripper_weight", "train.frames")

    # A config.json without the field was written before catalogues had names: procedural. The trainer
    # always fills it from the dataset.
    catalogue: str = bounded(LEGACY_CATALOGUE, choices=tuple(CATALOGUES))
    more_datasets: tuple[str, ...] = ()
    inputs: str = bounded("rgb", choices=INPUTS)
    language: str = bounded("instruction", choices=LANGUAGE)
    action: str = bounded(ACTION, choices=(ACTION,))
    tokens: int = bounded(32, lo=1)
    model: KeyposeArchitecture = field(default_factory=KeyposeArchitecture)
    grid: KeyposeGrid = field(default_factory=KeyposeGrid)
    families: tuple[str, ...] = ()
    train: KeyposeTraining = field(default_factory=KeyposeTraining)
    vocabulary: KeyposeVocabulary = field(default_factory=KeyposeVocabulary)

    @classmethod
    def from_dict(cls, d: Mapping[str, Any], where: str | None = None) -> Self:
        """Read a config file (:meth:`ModelConfig.from_dict`); one whose ``train`` section has no
        ``word_dropout`` was written before the option existed: trained without it."""
        train = d.get("train") if isinstance(d, Mapping) else None
        if isinstance(train, Mapping) and "word_dropout" not in train:
            d = {**d, "train": {**train, "word_dropout": 0.0}}
        return super().from_dict(d, where)

    def env_options(self) -> dict[str, object]:
        """The environment options the policy needs: steering control and no image (it renders the
        scene camera's RGB-D itself when it decides); the scenes of its dataset's catalogue."""
        return {"obs_mode": "state", "control_mode": "steering", **catalogue_options(self.catalogue)}


@cache
def _token_ids(words: tuple[str, ...]) -> np.ndarray:
    """The ids of ``words`` in the fixed vocabulary (read once per policy's words, not per decision)."""
    vocab = instruction_vocabulary()
    ids = np.array([vocab[w] for w in words if w in vocab], dtype=np.int64)
    ids.flags.writeable = False
    return ids


def policy_tokens(config: KeyposeConfig, text: str) -> np.ndarray:
    """The token ids the policy reads for an instruction (:func:`policy_instruction`'s text). A policy
    trained with word dropout reads a word outside its training instructions as ``<UNK>``, the token it
    learnt stands for a word it does not know; the embedding of a word it never read is untrained and
    would steer it at random."""
    tokens = encode_instruction(policy_instruction(config, text), config.tokens)
    if config.language != "instruction" or not config.train.word_dropout or not config.vocabulary.words:
        return tokens
    unheard = (tokens >= len(SPECIAL_TOKENS)) & ~np.isin(tokens, _token_ids(config.vocabulary.words))
    return np.where(unheard, SPECIAL_TOKENS["<UNK>"], tokens)


def policy_instruction(config: KeyposeConfig, text: str) -> str:
    """The text the policy reads for an instruction: the instruction itself, or :data:`BLANK_TEXT` for
    the language-blind control (the same in training and when it acts)."""
    return text if config.language == "instruction" else BLANK_TEXT
