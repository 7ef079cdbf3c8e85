"""What defines a trained instruction parser: the ``config.json`` of ``samplehd train parser``, declared
with :mod:`samplehd.schema` (a bad file is one line naming the file, the field, the value and what is
valid)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import ClassVar

from samplehd.learn.configuration import ModelConfig
from samplehd.schema import Config, bounded

__all__ = ["FORMAT", "ParserArchitecture", "ParserConfig", "ParserTraining"]

FORMAT = 1  # the config format of a parser model (bump when the network or its inputs change)


@dataclass(frozen=True)
class ParserArchitecture(Config, section="model"):
    """Sizes of the encoder–decoder.

    Attributes:
        embed: token embedding width.
        hidden: GRU hidden width.
    """

    embed: int = bounded(64, lo=1)
    hidden: int = bounded(128, lo=1)


@dataclass(frozen=True)
class ParserTraining(Config, section="train"):
    """How the parser was trained (recorded; a resumed run must match all but ``steps``).

    Attributes:
        steps: optimiser steps.
        seed: seed of the weights and the batches.
        batch: instructions per step.
        lr: learning rate before the decay.
        examples: training instructions of the dataset.
    """

    steps: int = bounded(2000, lo=1)
    seed: int = bounded(0, lo=0)
    batch: int = bounded(64, lo=1)
    lr: float = bounded(2e-3, lo=0.0, lo_open=True)
    examples: int = bounded(0, lo=0)


@dataclass(frozen=True)
class ParserConfig(ModelConfig, section="parser"):
    """A parser model's config.

    Attributes:
        kind: ``parser``.
        format: :data:`FORMAT` of the samplehd that wrote it.
        dataset: the dataset it was trained on.
        model: network sizes.
        target_vocab: the decoder's tokens (``<NULL>``, ``<START>``, ``<END>``, ``<UNK>``, then the
            program tokens of the training set, sorted).
        source_vocab_size: size of the instruction vocabulary it was trained with.
        train: training options.
    """

    KIND: ClassVar[str] = "parser"
    FORMAT: ClassVar[int] = FORMAT

    model: ParserArchitecture = field(default_factory=ParserArchitecture)
    target_vocab: tuple[str, ...] = bounded(("<NULL>", "<START>", "<END>", "<UNK>"), nonempty=True, unique=True)
    source_vocab_size: int = bounded(1, lo=1)
    train: ParserTraining = field(default_factory=ParserTraining)
