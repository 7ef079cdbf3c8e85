"""A trained parser: instructions in, :class:`ParsedProgram` out."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from samplehd.envs.tokens import instruction_vocabulary
from samplehd.learn.parser.configuration import FORMAT, ParserConfig
from samplehd.learn.parser.modeling import Seq2Seq
from samplehd.learn.parser.processing import MAX_TARGET, ParsedProgram, decode_target, encode_source, pad_batch
from samplehd.learn.training import check_weights_fit, load_model_files, read_model_config, torch

__all__ = ["InstructionParser"]


class InstructionParser:
    """A trained parser: ``parse(texts)`` → :class:`ParsedProgram` per text.

    Args:
        config: the model config (``config.json`` of ``samplehd train parser``).
        state: its state dict (None: fresh weights).
        device: torch device (default: CPU).
    """

    def __init__(self, config: ParserConfig, state: Mapping[str, Any] | None = None, device: Any = None) -> None:
        self.config = config
        self.target_vocab: list[str] = list(config.target_vocab)
        self.target_index = {t: i for i, t in enumerate(self.target_vocab)}
        self.device = device or torch.device("cpu")
        self.model = Seq2Seq(len(instruction_vocabulary()), len(self.target_vocab), config.model.embed,
                             config.model.hidden).to(self.device)
        if state is not None:
            self.model.load_state_dict(state)
        self.model.eval()

    @classmethod
    def load(cls, folder: str | Path, device: Any = None) -> InstructionParser:
        """Load ``config.json`` + ``model.pt`` written by ``samplehd train parser``."""
        config, state = load_model_files(folder, "parser", FORMAT)
        parser = cls(read_model_config(ParserConfig, config, folder), None, device)
        check_weights_fit(parser.model, state, folder)
        return parser

    def parse(self, texts: Sequence[str], batch: int = 256) -> list[ParsedProgram]:
        out: list[ParsedProgram] = []
        end = self.target_index["<END>"]
        for k in range(0, len(texts), batch):
            src = torch.as_tensor(pad_batch([encode_source(t) for t in texts[k:k + batch]]), device=self.device)
            ids = self.model.greedy(src, MAX_TARGET).cpu().numpy()
            for row in ids:
                toks = []
                for i in row:
                    if i == end:
                        break
                    toks.append(self.target_vocab[int(i)])
                out.append(decode_target(toks))
        return out
