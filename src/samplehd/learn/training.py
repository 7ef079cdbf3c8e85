"""What every training run shares: device choice, seeding, checkpoints, resume, progress, metrics.

A run writes into its ``--out`` folder::

    config.json       the model's JSON config (architecture, vocabularies, training options)
    checkpoint.pt     model + optimiser state dicts and the step reached (resume point)
    model.pt          the final model state dict
    metrics.json      the test metrics and the training figures (steps, final loss, wall time, device)
    prepared.npz      perception only: the decoded and cropped training scenes, kept until the run ends

Every file is written under a temporary name and renamed. Weights are plain state dicts, read back
with ``torch.load(..., weights_only=True)`` (no pickled objects). The batches of step ``k`` and every
random draw inside it depend only on ``(seed, k)``, so a run resumed from a checkpoint makes the same
model as one that was never interrupted, and on the CPU two runs with one seed give identical weights.
"""

from __future__ import annotations

import json
import os
import time
import warnings
from collections.abc import Callable, Iterator, Mapping
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, TypeVar

import numpy as np
from rich.console import Console
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn, TimeRemainingColumn

from samplehd.errors import ConfigError, require_extra
from samplehd.fileio import read_json
from samplehd.schema import Config

# The `learn` extra: without PyTorch, importing any model module is one line naming the extra.
FEATURE = "samplehd.learn (samplehd train, evaluate --policy neurosymbolic|bc)"
torch = require_extra("torch", "learn", FEATURE)
nn = require_extra("torch.nn", "learn", FEATURE)
F = require_extra("torch.nn.functional", "learn", FEATURE)

__all__ = [
    "F",
    "MetricValue",
    "Metrics",
    "TrainRun",
    "check_weights_fit",
    "load_model_files",
    "nn",
    "read_model_config",
    "load_weights",
    "pick_device",
    "step_rng",
    "torch",
    "write_json",
]

CONFIG_FILE = "config.json"
CHECKPOINT_FILE = "checkpoint.pt"
MODEL_FILE = "model.pt"
METRICS_FILE = "metrics.json"
# A ``metrics.json`` entry: a figure or a count (None: not measured, e.g. no test example of a level), a
# name (the device), or a table of them (by level, attribute or family).
MetricValue = float | int | bool | str | None | list[float] | dict[str, "MetricValue"]
Metrics = dict[str, MetricValue]


def pick_device(requested: str | None = None) -> Any:
    """The torch device: ``requested`` if given, else CUDA when present, else the CPU."""
    if requested:
        if requested.startswith("cuda") and not torch.cuda.is_available():
            raise ConfigError(f"device={requested!r}: no CUDA device here; valid: cpu", field="device")
        try:
            return torch.device(requested)
        except RuntimeError:
            raise ConfigError(f"device={requested!r}: not a torch device; valid: cpu, cuda, cuda:N",
                              field="device") from None
    return torch.device("cuda" if torch.cuda.is_available() else "cpu")


def load_weights(path: Path) -> Any:
    """``torch.load(path, weights_only=True)`` onto the CPU, any failure (a pickled object, a garbage
    or truncated file) one line naming the file; torch's own warnings are folded into that line.

    Raises:
        ConfigError: the file cannot be read as plain tensors and containers.
    """
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            return torch.load(path, map_location="cpu", weights_only=True)
    except Exception as exc:  # noqa: BLE001 - any unreadable file is one user-facing error
        reason = next((line.strip() for line in str(exc).splitlines() if line.strip()), type(exc).__name__)
        raise ConfigError(f"{path}: not a state dict readable with weights_only=True ({reason[:200]}); delete "
                          f"it or give another folder") from None


def step_rng(seed: int, step: int, stream: int = 0) -> np.random.Generator:
    """The generator of training step ``step`` (batches, augmentations): a function of its arguments only."""
    return np.random.default_rng(np.random.SeedSequence([int(seed), int(step), int(stream)]))


def write_json(path: Path, data: Any) -> None:
    """Write JSON atomically (temporary name, rename)."""
    tmp = path.with_name(f".{path.name}.tmp-{os.getpid()}")
    tmp.write_text(json.dumps(data, indent=1) + "\n", encoding="utf-8")
    tmp.replace(path)


def _save_torch(path: Path, obj: Any) -> None:
    tmp = path.with_name(f".{path.name}.tmp-{os.getpid()}")
    torch.save(obj, tmp)
    tmp.replace(path)


def load_model_files(folder: str | Path, kind: str, fmt: int) -> tuple[dict[str, Any], dict[str, torch.Tensor]]:
    """Read ``config.json`` and ``model.pt`` of a trained model; one-line errors.

    Args:
        folder: the ``--out`` folder of ``samplehd train KIND``.
        kind: parser, perception or policy (checked against the config's ``kind``).
        fmt: the config ``format`` this samplehd writes and reads for ``kind``.

    Returns:
        (config, state dict) — the state dict loaded with ``weights_only=True`` onto the CPU.
    """
    folder = Path(folder)
    cfg_path = folder / CONFIG_FILE
    if not cfg_path.exists() and not cfg_path.is_symlink():
        raise ConfigError(f"{cfg_path}: no trained {kind} model here (run `samplehd train {kind}` first)")
    config = read_json(cfg_path, ConfigError)
    if not isinstance(config, dict) or config.get("kind") != kind:
        got = config.get("kind") if isinstance(config, dict) else None
        raise ConfigError(f"{cfg_path}: kind={got!r}, expected {kind!r}")
    if config.get("format") != fmt:
        raise ConfigError(f"{cfg_path}: format {config.get('format')!r}; this samplehd reads {kind} models of format "
                          f"{fmt}: train it again with this version (samplehd train {kind})")
    weights = folder / MODEL_FILE
    if not weights.exists():
        raise ConfigError(f"{weights}: missing (the {kind} training did not finish; run it again to resume)")
    return config, load_weights(weights)


def check_weights_fit(module: Any, state: Mapping[str, Any], folder: str | Path) -> None:
    """Load the state dict read from ``folder``'s ``model.pt`` into ``module`` (the network its
    ``config.json`` describes); weights of another width or another model are one line, not torch's
    list of every missing key and shape.

    Raises:
        ConfigError: ``FOLDER/model.pt: its weights do not fit ...``.
    """
    try:
        module.load_state_dict(state)
    except (RuntimeError, KeyError, TypeError, ValueError) as exc:
        lines = [line.strip() for line in str(exc).splitlines() if line.strip()]
        detail = next((line for line in lines if not line.startswith("Error(s) in loading")), type(exc).__name__)
        raise ConfigError(f"{Path(folder) / MODEL_FILE}: its weights do not fit the network that "
                          f"{CONFIG_FILE} describes ({detail[:160]}); give the folder of a model trained with this "
                          f"config, or train it again") from None


C = TypeVar("C", bound=Config)


def read_model_config(cls: type[C], config: Mapping[str, Any], folder: str | Path) -> C:
    """The typed config (a :class:`samplehd.schema.Config`) of a trained model from the object
    :func:`load_model_files` read from ``folder``'s ``config.json``.

    Raises:
        ConfigError: ``FOLDER/config.json: section.field=value: what is valid``, or an unknown key.
    """
    try:
        return cls.from_dict(config)
    except ConfigError as exc:
        raise ConfigError(f"{Path(folder) / CONFIG_FILE}: {exc}") from None


@dataclass
class TrainRun:
    """One training run in an output folder: resume, checkpoints, progress bar, final files.

    Args:
        out: the output folder.
        config: the model's JSON config; a resumed run must have the same one.
        steps: total optimiser steps.
        checkpoint_every: steps between checkpoints.
        quiet: no progress bar.
        stop_after: end the loop after this many steps, with a checkpoint, as an interruption
            would (the tests' stand-in for a killed run); None: run to ``steps``.
    """

    out: Path
    config: dict[str, Any]
    steps: int
    checkpoint_every: int = 100
    quiet: bool = False
    stop_after: int | None = None
    stopped: bool = False
    _resume_state: dict[str, Any] | None = field(default=None, init=False, repr=False)

    def __post_init__(self) -> None:
        if not isinstance(self.steps, int) or self.steps < 1:
            raise ConfigError(f"steps={self.steps!r}: must be a positive integer", field="steps")
        self.out = Path(self.out)

    def prepare(self) -> None:
        """Create the folder; refuse to resume a run whose config differs (names the field) or whose
        checkpoint cannot be read, before anything is written."""
        ckpt = self.out / CHECKPOINT_FILE
        self._resume_state = None
        if ckpt.exists():
            state = load_weights(ckpt)
            if not isinstance(state, dict) or not {"model", "optimizer", "step"} <= set(state):
                raise ConfigError(f"{ckpt}: not a samplehd checkpoint (needs model, optimizer and step); delete it "
                                  f"to start over")
            self._resume_state = state
        self.out.mkdir(parents=True, exist_ok=True)
        path = self.out / CONFIG_FILE
        if (path.exists() or path.is_symlink()) and (self.out / CHECKPOINT_FILE).exists():
            # The config of the run being resumed: a damaged one is refused, never overwritten unseen.
            old = read_json(path, ConfigError)
            if not isinstance(old, dict):
                raise ConfigError(f"{path}: a JSON {type(old).__name__}, not the config of the run in `out`; delete "
                                  f"{self.out / CHECKPOINT_FILE} to start over")
            if isinstance(old, dict):
                for key in sorted(set(old) | set(self.config)):
                    if key == "train":  # step count may grow on resume
                        continue
                    if old.get(key) != self.config.get(key):
                        raise ConfigError(f"{path}: {key} differs from this run's; use another `out` or delete "
                                          f"{self.out / CHECKPOINT_FILE} to start over")
        write_json(path, self.config)

    def resume(self, model: Any, optimizer: Any) -> int:
        """Load the checkpoint if there is one; return the step to continue from."""

        state = self._resume_state
        if state is None:
            return 0
        try:
            model.load_state_dict(state["model"])
            optimizer.load_state_dict(state["optimizer"])
        except (RuntimeError, KeyError, ValueError, TypeError) as exc:
            reason = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
            raise ConfigError(f"{self.out / CHECKPOINT_FILE}: does not fit this model ({reason[:200]}); delete it "
                              f"to start over") from None
        return int(state["step"])

    def checkpoint(self, model: Any, optimizer: Any, step: int) -> None:
        _save_torch(self.out / CHECKPOINT_FILE, {"model": model.state_dict(), "optimizer": optimizer.state_dict(),
                                                 "step": step})

    def loop(self, model: Any, optimizer: Any, train_step: Callable[[int], float],
             description: str) -> Iterator[tuple[int, float]]:
        """Run ``train_step(step)`` (returns the loss) from the resume point to ``steps``.

        Yields (step, loss) after every step; checkpoints every ``checkpoint_every`` steps and at the end.
        """
        start = self.resume(model, optimizer)
        console = Console(stderr=True, quiet=self.quiet)
        bars = Progress(TextColumn("{task.description:>12}"), BarColumn(), MofNCompleteColumn(),
                        TextColumn("loss {task.fields[loss]:.4f}"), TimeElapsedColumn(), TextColumn("eta"),
                        TimeRemainingColumn(), console=console, disable=self.quiet, refresh_per_second=4)
        ema = float("nan")
        with bars:
            task = bars.add_task(description, total=self.steps, completed=start, loss=float("nan"))
            for step in range(start, self.steps):
                loss = float(train_step(step))
                ema = loss if ema != ema else 0.95 * ema + 0.05 * loss
                bars.update(task, completed=step + 1, loss=ema)
                interrupted = self.stop_after is not None and step + 1 >= self.stop_after and step + 1 < self.steps
                if (step + 1) % self.checkpoint_every == 0 or step + 1 == self.steps or interrupted:
                    self.checkpoint(model, optimizer, step + 1)
                yield step, loss
                if interrupted:
                    self.stopped = True
                    return

    def train(self, model: Any, optimizer: Any, train_step: Callable[[int], float],
              description: str) -> tuple[list[float], dict[str, float]]:
        """Run :meth:`loop` to its end (or the interruption point).

        Returns:
            The losses of the steps run now, and the wall time [s] and load average around them.
        """
        losses: list[float] = []
        with timed() as times:
            for _, loss in self.loop(model, optimizer, train_step, description):
                losses.append(loss)
        return losses, times

    def finish(self, model: Any, metrics: Metrics) -> None:
        """Write the final model and ``metrics.json``."""
        state = {k: v.detach().cpu() for k, v in model.state_dict().items()}
        _save_torch(self.out / MODEL_FILE, state)
        write_json(self.out / METRICS_FILE, metrics)


@contextmanager
def timed() -> Iterator[dict[str, float]]:
    """Measure wall time and the 1-minute load average around a block."""
    out: dict[str, float] = {}
    t0 = time.perf_counter()
    try:
        yield out
    finally:
        out["wall_s"] = round(time.perf_counter() - t0, 2)
        try:
            out["load_average_1min"] = round(os.getloadavg()[0], 2)
        except OSError:
            pass


def descend(optimizer: Any, loss: Any, clip: Any = None, max_norm: float = 5.0) -> float:
    """One optimiser step on ``loss``; gradients of the parameters ``clip`` are clipped to ``max_norm``.

    Returns:
        The loss as a float.
    """
    optimizer.zero_grad()
    loss.backward()
    if clip is not None:
        torch.nn.utils.clip_grad_norm_(clip, max_norm)
    optimizer.step()
    return float(loss.detach())


def set_seed(seed: int) -> None:
    """Seed torch for model initialisation and make CPU kernels deterministic.

    Also runs torch's CPU kernels on one thread (``SAMPLEHD_TORCH_THREADS`` overrides): these models
    are small, and on a loaded 2-core machine two spinning threads made a step 5–20× slower than one.
    """
    torch.set_num_threads(max(1, int(os.environ.get("SAMPLEHD_TORCH_THREADS", "1"))))
    torch.manual_seed(int(seed))
    torch.use_deterministic_algorithms(True, warn_only=True)
