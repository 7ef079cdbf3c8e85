"""Instruction → program: a GRU encoder–decoder with attention (Luong) over the fixed instruction
vocabulary of :mod:`samplehd.envs.tokens`.

The decoder writes one sequence: the SAMPLE-HD flat program, ``<SEP>``, then the CLEVR node list,
each node as its token (``filter_color[red]``) followed by one ``@k`` token per input node. Both
formats come out of one greedy decode and go straight into the project's executor.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from samplehd.envs.tokens import SPECIAL_TOKENS, instruction_vocabulary, tokenize
from samplehd.errors import ConfigError
from samplehd.language.executor import ProgramError, execute
from samplehd.language.scene import parse_scene
from samplehd.language.vocab import program_node_tokens
from samplehd.learn.data import instruction_examples, open_dataset
from samplehd.learn.parser_configuration import FORMAT, ParserArchitecture, ParserConfig, ParserTraining
from samplehd.learn.training import (
    TrainRun,
    descend,
    load_model_files,
    nn,
    pick_device,
    read_model_config,
    set_seed,
    step_rng,
    timed,
    torch,
)

__all__ = ["InstructionParser", "ParsedProgram", "decode_target", "encode_target", "score_parser", "train_parser"]

SEP = "<SEP>"
MAX_SOURCE = 48
MAX_TARGET = 96


def encode_target(flat: str | Sequence[str], nodes: Sequence[Mapping[str, Any]]) -> list[str]:
    """The decoder's target tokens for one program in both formats."""
    out = list(flat.split() if isinstance(flat, str) else flat) + [SEP]
    for token, node in zip(program_node_tokens(nodes), nodes, strict=True):
        out.append(token)
        out += [f"@{k}" for k in node.get("inputs", [])]
    return out


@dataclass(frozen=True)
class ParsedProgram:
    """A decoded program: flat tokens and CLEVR nodes (None where the node part does not parse)."""

    flat: tuple[str, ...]
    nodes: tuple[dict[str, Any], ...] | None


def decode_target(tokens: Sequence[str]) -> ParsedProgram:
    """Inverse of :func:`encode_target`."""
    tokens = list(tokens)
    if SEP not in tokens:
        return ParsedProgram(tuple(tokens), None)
    cut = tokens.index(SEP)
    flat, rest = tokens[:cut], tokens[cut + 1:]
    nodes: list[dict[str, Any]] = []
    for t in rest:
        if t.startswith("@"):
            if not nodes or not t[1:].isdigit():
                return ParsedProgram(tuple(flat), None)
            nodes[-1]["inputs"].append(int(t[1:]))
        else:
            name, _, value = t.partition("[")
            values = value[:-1].split(",") if value.endswith("]") else []
            nodes.append({"type": name, "inputs": [], "value_inputs": values})
    return ParsedProgram(tuple(flat), tuple(nodes))


def encode_source(text: str) -> list[int]:
    vocab = instruction_vocabulary()
    unk = SPECIAL_TOKENS["<UNK>"]
    ids = [SPECIAL_TOKENS["<START>"], *(vocab.get(w, unk) for w in tokenize(text)), SPECIAL_TOKENS["<END>"]]
    return ids[:MAX_SOURCE]


class Seq2Seq(nn.Module):
    """Bidirectional GRU encoder, GRU decoder, bilinear attention over the encoder states."""

    def __init__(self, n_source: int, n_target: int, embed: int, hidden: int) -> None:
        super().__init__()
        self.src_embed = nn.Embedding(n_source, embed, padding_idx=0)
        self.encoder = nn.GRU(embed, hidden, batch_first=True, bidirectional=True)
        self.bridge = nn.Linear(2 * hidden, hidden)
        self.tgt_embed = nn.Embedding(n_target, embed, padding_idx=0)
        self.decoder = nn.GRU(embed, hidden, batch_first=True)
        self.attend = nn.Linear(hidden, 2 * hidden, bias=False)
        self.out = nn.Sequential(nn.Linear(3 * hidden, hidden), nn.Tanh(), nn.Linear(hidden, n_target))

    def encode(self, src: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
        enc, _ = self.encoder(self.src_embed(src))
        mask = src != 0
        pooled = (enc * mask.unsqueeze(-1)).sum(1) / mask.sum(1, keepdim=True).clamp(min=1)
        return enc, mask, torch.tanh(self.bridge(pooled)).unsqueeze(0)

    def step(self, tgt: torch.Tensor, enc: torch.Tensor, mask: torch.Tensor, h: torch.Tensor
             ) -> tuple[torch.Tensor, torch.Tensor]:
        dec, h = self.decoder(self.tgt_embed(tgt), h)
        scores = torch.bmm(self.attend(dec), enc.transpose(1, 2))
        scores = scores.masked_fill(~mask.unsqueeze(1), -1e9)
        context = torch.bmm(torch.softmax(scores, dim=-1), enc)
        return self.out(torch.cat([dec, context], dim=-1)), h

    def forward(self, src: torch.Tensor, tgt_in: torch.Tensor) -> torch.Tensor:
        enc, mask, h = self.encode(src)
        logits, _ = self.step(tgt_in, enc, mask, h)
        return logits

    @torch.no_grad()
    def greedy(self, src: torch.Tensor, max_len: int) -> torch.Tensor:
        enc, mask, h = self.encode(src)
        tok = torch.full((src.shape[0], 1), SPECIAL_TOKENS["<START>"], dtype=torch.long, device=src.device)
        out = []
        for _ in range(max_len):
            logits, h = self.step(tok, enc, mask, h)
            tok = logits.argmax(-1)
            out.append(tok)
        return torch.cat(out, dim=1)


def _pad(seqs: Sequence[Sequence[int]]) -> np.ndarray:
    n = max(len(s) for s in seqs)
    out = np.zeros((len(seqs), n), dtype=np.int64)
    for i, s in enumerate(seqs):
        out[i, : len(s)] = s
    return out


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
        return cls(read_model_config(ParserConfig, config, folder), state, device)

    def parse(self, texts: Sequence[str], batch: int = 256) -> list[ParsedProgram]:
        out: list[ParsedProgram] = []
        end = self.target_index["<END>"]
        for k in range(0, len(texts), batch):
            src = torch.as_tensor(_pad([encode_source(t) for t in texts[k:k + batch]]), device=self.device)
            ids = self.model.greedy(src, MAX_TARGET).cpu().numpy()
            for row in ids:
                toks = []
                for i in row:
                    if i == end:
                        break
                    toks.append(self.target_vocab[int(i)])
                out.append(decode_target(toks))
        return out


def _task_equal(program: Any, scene: Mapping[str, Any], task: Mapping[str, Any]) -> bool:
    try:
        got = execute(list(program), parse_scene(scene)).to_program_dict()
    except (ProgramError, ValueError, KeyError, IndexError):
        return False
    return got == {k: task.get(k) for k in got}


def evaluate_parser(parser: InstructionParser, examples: Sequence[Mapping[str, Any]]) -> dict[str, Any]:
    """Exact match (flat program; node list) and executor accuracy (same task on the scene), overall and per level."""
    preds = parser.parse([e["instruction"] for e in examples])
    rows = []
    for e, p in zip(examples, preds, strict=True):
        gt_flat = tuple(str(e["program_sequence"]).split())
        gt_nodes = [{"type": n["type"], "inputs": list(n.get("inputs", [])),
                     "value_inputs": list(n.get("value_inputs", []))} for n in e["program"]]
        rows.append({
            "level": e.get("level", "L1"),
            "exact": p.flat == gt_flat,
            "nodes_exact": p.nodes is not None and list(p.nodes) == gt_nodes,
            "executor": _task_equal(p.flat, e["scene"], e["task"]),
            "executor_nodes": p.nodes is not None and _task_equal(p.nodes, e["scene"], e["task"]),
        })

    def rates(rs: list[dict[str, Any]]) -> dict[str, Any]:
        n = len(rs)
        return {"n": n, **{k: (sum(r[k] for r in rs) / n if n else None)
                           for k in ("exact", "nodes_exact", "executor", "executor_nodes")}}

    by_level = {lv: rates([r for r in rows if r["level"] == lv]) for lv in sorted({r["level"] for r in rows})}
    return {"all": rates(rows), "by_level": by_level}


def train_parser(dataset: str | Path, out: str | Path, steps: int = 2000, seed: int = 0, batch: int = 64,
                 lr: float = 2e-3, embed: int = 64, hidden: int = 128, device: str | None = None,
                 quiet: bool = False, stop_after: int | None = None) -> dict[str, Any]:
    """Train the parser on a dataset's training instructions and test it on its test split.

    Metrics (``metrics.json``): ``test_exact_match`` (flat program, test instructions of seen
    templates and variants), ``test_node_exact_match``, ``test_executor_accuracy`` (the predicted
    program selects the same task on the scene), the same on held-out paraphrases (``l3_*``), and
    the training figures.
    """

    reader = open_dataset(dataset)
    data = instruction_examples(reader)
    train = data["train"]
    targets = [encode_target(e["program_sequence"], e["program"]) for e in train]
    vocab = ["<NULL>", "<START>", "<END>", "<UNK>", *sorted({t for ts in targets for t in ts})]
    config = ParserConfig(dataset=str(dataset), model=ParserArchitecture(embed=embed, hidden=hidden),
                          target_vocab=tuple(vocab), source_vocab_size=len(instruction_vocabulary()),
                          train=ParserTraining(steps=steps, seed=seed, batch=batch, lr=lr, examples=len(train)))
    dev = pick_device(device)
    set_seed(seed)
    parser = InstructionParser(config, device=dev)
    model = parser.model
    index = parser.target_index
    src_all = [encode_source(e["instruction"]) for e in train]
    tgt_all = [[index["<START>"], *(index[t] for t in ts), index["<END>"]][:MAX_TARGET + 1] for ts in targets]
    opt = torch.optim.Adam(model.parameters(), lr=lr)
    run = TrainRun(Path(out), config.to_dict(), steps, checkpoint_every=max(50, steps // 10), quiet=quiet,
                   stop_after=stop_after)
    run.prepare()
    loss_fn = torch.nn.CrossEntropyLoss(ignore_index=0)

    def train_step(step: int) -> float:
        model.train()
        for g in opt.param_groups:  # constant, then linear decay over the last two thirds
            g["lr"] = lr * min(1.0, 1.5 * (1 - step / steps))
        rows = step_rng(seed, step).integers(len(train), size=batch)
        src = torch.as_tensor(_pad([src_all[i] for i in rows]), device=dev)
        tgt = torch.as_tensor(_pad([tgt_all[i] for i in rows]), device=dev)
        logits = model(src, tgt[:, :-1])
        loss = loss_fn(logits.reshape(-1, logits.shape[-1]), tgt[:, 1:].reshape(-1))
        return descend(opt, loss, clip=model.parameters())

    losses, t = run.train(model, opt, train_step, "parser")
    if run.stopped:
        return {"stopped_at": len(losses)}
    model.eval()
    metrics = {
        **parser_test_metrics(parser, data["test"]),
        "train_examples": len(train),
        "train_loss": float(np.mean(losses[-50:])) if losses else None,
        "steps": steps,
        "seed": seed,
        "device": str(dev),
        **t,
    }
    run.finish(model, metrics)
    return metrics


def parser_test_metrics(parser: InstructionParser, test: Sequence[Mapping[str, Any]]) -> dict[str, Any]:
    """The ``test_*`` and ``l3_*`` entries of a parser's ``metrics.json`` (:func:`evaluate_parser`)."""
    seen = [e for e in test if e["level"] == "L1"]
    heldout = [e for e in test if e["level"] == "L3"]
    m_seen = evaluate_parser(parser, seen) if seen else {"all": {}}
    m_l3 = evaluate_parser(parser, heldout) if heldout else {"all": {}}
    m_all = evaluate_parser(parser, test) if test else {"all": {}, "by_level": {}}
    return {
        "test_exact_match": m_seen["all"].get("exact"),
        "test_node_exact_match": m_seen["all"].get("nodes_exact"),
        "test_executor_accuracy": m_seen["all"].get("executor"),
        "test_executor_accuracy_nodes": m_seen["all"].get("executor_nodes"),
        "test_examples": m_seen["all"].get("n", 0),
        "l3_exact_match": m_l3["all"].get("exact"),
        "l3_executor_accuracy": m_l3["all"].get("executor"),
        "l3_examples": m_l3["all"].get("n", 0),
        "test_by_level": m_all.get("by_level", {}),
    }


def score_parser(dataset: str | Path, models: str | Path, device: str | None = None) -> dict[str, Any]:
    """Test a trained parser (the ``--out`` folder of ``samplehd train parser``) on a dataset's test
    instructions without training: the ``test_*`` and ``l3_*`` metrics of ``metrics.json``, with the
    wall time and load average of the test (``test_wall_s``, ``test_load_average_1min``).

    Raises:
        ConfigError: no trained parser in ``models``, or no dataset (or test instructions) in ``dataset``.
    """
    parser = InstructionParser.load(models, pick_device(device))
    data = instruction_examples(open_dataset(dataset))
    if not data["test"]:
        raise ConfigError(f"dataset={dataset}: no test instructions (generate with a test split)", field="dataset")
    with timed() as t:
        metrics = parser_test_metrics(parser, data["test"])
    return {**metrics, **{f"test_{k}": v for k, v in t.items()}}
