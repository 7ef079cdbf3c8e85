"""The header every trained model's ``config.json`` starts with (:class:`ModelConfig`): what kind of
model it is, the config format of the samplehd that wrote it and the dataset it was trained on.
Needs no PyTorch.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any, ClassVar, Self

from samplehd.catalogue.loader import DEFAULT_CATALOGUE
from samplehd.errors import ConfigError
from samplehd.schema import Config, bounded

__all__ = ["ModelConfig", "catalogue_options"]


@dataclass(frozen=True)
class ModelConfig(Config):
    """Base of the model configs: a subclass names its :attr:`KIND` and :attr:`FORMAT` and adds its
    sections after these fields.

    Attributes:
        kind: the model's kind, :attr:`KIND` ("" when built in code: set to it).
        format: the config format of the samplehd that wrote it, :attr:`FORMAT` (0 when built in
            code: set to it).
        dataset: the dataset it was trained on.
    """

    KIND: ClassVar[str] = ""
    FORMAT: ClassVar[int] = 1
    # keys (``section.key`` in a section) that files of earlier versions hold and this config no longer has:
    # dropped on reading, whatever their value
    DROPPED: ClassVar[tuple[str, ...]] = ()

    kind: str = ""
    format: int = bounded(0, lo=0)
    dataset: str = ""

    def __post_init__(self) -> None:
        if not self.kind:
            object.__setattr__(self, "kind", self.KIND)
        if not self.format:
            object.__setattr__(self, "format", self.FORMAT)
        super().__post_init__()
        if self.kind != self.KIND:
            raise ConfigError(f"{self._section}.kind={self.kind!r}: valid: {self.KIND}", field=f"{self._section}.kind")

    @classmethod
    def from_dict(cls, d: Mapping[str, Any], where: str | None = None) -> Self:
        """Read a trained model's config from a JSON object (:meth:`Config.from_dict`), the keys of
        :attr:`DROPPED` left out, checked by :meth:`check_trained`."""
        if cls.DROPPED and isinstance(d, Mapping):
            d = {k: dict(v) if isinstance(v, Mapping) else v for k, v in d.items()}
            for key in cls.DROPPED:
                section, _, name = key.rpartition(".")
                holder = d.get(section) if section else d
                if isinstance(holder, dict):
                    holder.pop(name, None)
        config = super().from_dict(d, where)
        config.check_trained()
        return config

    def check_trained(self) -> None:
        """What a trained model's config must hold besides its fields' bounds (a config to train may
        leave it to the dataset); raises :class:`ConfigError`. Nothing here."""


def catalogue_options(catalogue: str) -> dict[str, dict[str, str]]:
    """The environment options of a policy trained on ``catalogue``: none for the default one, else
    its scenes from that catalogue."""
    return {} if catalogue == DEFAULT_CATALOGUE else {"scene": {"catalogue": catalogue}}
