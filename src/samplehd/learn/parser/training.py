"""Training a parser on a dataset's instructions (``samplehd train parser``)."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np

from samplehd.envs.tokens import instruction_vocabulary
from samplehd.learn.data import instruction_examples, open_dataset
from samplehd.learn.parser.configuration import ParserConfig
from samplehd.learn.parser.evaluation import parser_test_metrics
from samplehd.learn.parser.inference import InstructionParser
from samplehd.learn.parser.processing import MAX_TARGET, encode_source, encode_target, pad_batch
from samplehd.learn.training import Metrics, TrainRun, descend, pick_device, set_seed, step_rng, torch

__all__ = ["train_parser"]


def train_parser(dataset: str | Path, out: str | Path, config: ParserConfig, *, device: str | None = None,
                 quiet: bool = False, stop_after: int | None = None) -> Metrics:
    """Train the parser on a dataset's training instructions and test it on its test split.

    Metrics (``metrics.json``): ``test_exact_match`` (flat program, test instructions of seen
    templates and variants), ``test_node_exact_match``, ``test_executor_accuracy`` (the predicted
    program selects the same task on the scene), the same on held-out paraphrases (``l3_*``), and
    the training figures.

    What the dataset says is filled in: its path, the decoder's tokens (``target_vocab``, those of its
    training programs), the instruction vocabulary's size and the count of training instructions.

    Args:
        dataset: a dataset folder written by ``samplehd generate``.
        out: the output folder (resumed when it holds a checkpoint).
        config: the parser to train.
        device: torch device (default: cuda when present, else cpu).
        quiet: no progress bar.
        stop_after: stop after this many steps (a checkpoint stays; for tests of resuming).

    Returns:
        The metrics written to ``metrics.json`` (``{"stopped_at": N}`` when stopped early).
    """
    reader = open_dataset(dataset)
    data = instruction_examples(reader)
    train = data["train"]
    targets = [encode_target(e["program_sequence"], e["program"]) for e in train]
    vocab = ["<NULL>", "<START>", "<END>", "<UNK>", *sorted({t for ts in targets for t in ts})]
    config = replace(config, dataset=str(dataset), target_vocab=tuple(vocab),
                     source_vocab_size=len(instruction_vocabulary()), train=replace(config.train, examples=len(train)))
    steps, seed, batch, lr = config.train.steps, config.train.seed, config.train.batch, config.train.lr
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
        src = torch.as_tensor(pad_batch([src_all[i] for i in rows]), device=dev)
        tgt = torch.as_tensor(pad_batch([tgt_all[i] for i in rows]), device=dev)
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
