"""Visuomotor behaviour cloning: scene and wrist camera RGB + instruction tokens + robot state →
the next ``chunk`` steering vectors of the dataset (SAMPLE-HD's 7-D steering, action chunking).

The network: one small CNN per camera whose last block is FiLM-modulated by the instruction (a GRU
over the token ids of :mod:`samplehd.envs.tokens`), a state MLP, and an MLP head that writes
``chunk`` × 7 values in [-1, 1]. Training samples frames of the dataset's training episodes (random
shifts of the images, as in DrQ), minimises the L1 error to the recorded chunk, and reports the
test episodes' error. In the environment, :class:`BCPolicy` predicts a chunk and executes its first
``execute`` actions before looking again.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from samplehd.dataset.container import camera_settings
from samplehd.envs.levels import episode_level, held_out_instruction
from samplehd.envs.tokens import encode_instruction, instruction_vocabulary
from samplehd.errors import ConfigError
from samplehd.learn.data import open_dataset
from samplehd.learn.options import POLICY_CAMERAS, env_options, env_options_from_config
from samplehd.learn.training import F, TrainRun, descend, load_model_files, nn, pick_device, set_seed, step_rng, torch

__all__ = ["BCPolicy", "env_options", "policy_for_evaluation", "train_policy"]

STATE_DIM = 10  # joint positions (6), TCP position (3), finger opening (1)
CAMERAS = POLICY_CAMERAS


def _state(joint_pos: np.ndarray, tcp_pos: np.ndarray, opening: np.ndarray) -> np.ndarray:
    return np.concatenate([joint_pos, tcp_pos, np.atleast_1d(opening)[..., None] * 10.0
                           if np.ndim(opening) else [opening * 10.0]], axis=-1).astype(np.float32)


class Encoder(nn.Module):
    """A camera's CNN; its last block is FiLM-modulated by the instruction code ``c``."""

    def __init__(self, w: int, cond: int) -> None:
        super().__init__()
        self.convs = nn.Sequential(
            nn.Conv2d(3, w, 3, stride=2, padding=1), nn.GroupNorm(8, w), nn.ReLU(inplace=True),
            nn.Conv2d(w, 2 * w, 3, stride=2, padding=1), nn.GroupNorm(8, 2 * w), nn.ReLU(inplace=True),
            nn.Conv2d(2 * w, 2 * w, 3, stride=2, padding=1), nn.GroupNorm(8, 2 * w))
        self.film = nn.Linear(cond, 4 * w)
        self.out = nn.Sequential(nn.ReLU(inplace=True), nn.Conv2d(2 * w, 2 * w, 3, stride=2, padding=1),
                                 nn.ReLU(inplace=True), nn.Flatten())

    def forward(self, x: torch.Tensor, c: torch.Tensor) -> torch.Tensor:
        h = self.convs(x)
        gamma, beta = self.film(c).chunk(2, dim=1)
        h = h * (1 + gamma[:, :, None, None]) + beta[:, :, None, None]
        return self.out(h)


class BCNet(nn.Module):
    """Images + instruction tokens + robot state → ``chunk`` steering vectors in [-1, 1]."""

    def __init__(self, vocab: int, image: int, chunk: int, width: int, hidden: int) -> None:
        super().__init__()
        self.chunk = chunk
        self.embed = nn.Embedding(vocab, 64, padding_idx=0)
        self.text = nn.GRU(64, 128, batch_first=True)
        self.encoders = nn.ModuleList([Encoder(width, 128) for _ in CAMERAS])
        side = image
        for _ in range(4):
            side = (side + 1) // 2
        feat = 2 * width * side * side
        self.state = nn.Sequential(nn.Linear(STATE_DIM, 64), nn.ReLU(inplace=True))
        self.head = nn.Sequential(nn.Linear(len(CAMERAS) * feat + 64 + 128, hidden), nn.ReLU(inplace=True),
                                  nn.Linear(hidden, hidden), nn.ReLU(inplace=True), nn.Linear(hidden, chunk * 7))

    def forward(self, images: Sequence[torch.Tensor], tokens: torch.Tensor, state: torch.Tensor) -> torch.Tensor:
        lengths = (tokens != 0).sum(1).clamp(min=1).cpu()
        packed = nn.utils.rnn.pack_padded_sequence(self.embed(tokens), lengths, batch_first=True,
                                                   enforce_sorted=False)
        _, h = self.text(packed)
        c = h[-1]
        feats = [enc(img, c) for enc, img in zip(self.encoders, images, strict=True)]
        out = self.head(torch.cat([*feats, self.state(state), c], 1))
        return torch.tanh(out).view(-1, self.chunk, 7)


class BCPolicy:
    """The trained policy acting in an environment with ``env_options(folder)``.

    Args:
        config, state: the trained model's config and state dict.
        env: the environment (checked: steering control, both cameras at the trained size).
    """

    def __init__(self, config: Mapping[str, Any], state: Mapping[str, Any] | None, env: Any = None,
                 device: Any = None) -> None:
        set_seed(int(config["train"]["seed"]))
        self.config = dict(config)
        self.device = device or torch.device("cpu")
        m = config["model"]
        self.net = BCNet(len(instruction_vocabulary()), config["image"], config["chunk"], m["width"],
                                  m["hidden"]).to(self.device)
        if state is not None:
            self.net.load_state_dict(state)
        self.net.eval()
        self.execute = int(config["execute"])
        self._queue: list[np.ndarray] = []
        if env is not None:
            c = env.unwrapped.config
            want = env_options_from_config(config)
            got = {"obs_mode": c.obs_mode, "cameras": list(c.cameras), "width": c.width, "height": c.height,
                   "control_mode": c.control_mode}
            bad = [k for k in want if want[k] != got[k]]
            if bad:
                raise ConfigError(f"--policy bc: the environment's {bad[0]}={got[bad[0]]!r}, the policy needs "
                                  f"{want[bad[0]]!r} (options: {want})")

    @classmethod
    def load(cls, folder: str | Path | None, env: Any = None) -> BCPolicy:
        if folder is None:
            raise ConfigError("--policy bc: needs --models (the folder of `samplehd train policy`)")
        config, state = load_model_files(folder, "policy")
        return cls(config, state, env)

    def reset(self, seed: int | None = None) -> None:
        self._queue = []

    def predict(self, obs: Mapping[str, Any]) -> np.ndarray:
        """The chunk (chunk, 7) for one observation of the environment."""

        imgs = [torch.as_tensor(np.ascontiguousarray(obs[f"{c}_rgb"]).transpose(2, 0, 1)[None].astype(np.float32)
                                / 255.0, device=self.device) for c in CAMERAS]
        tokens = torch.as_tensor(encode_instruction(str(obs["instruction"]), self.config["tokens"])[None],
                                 device=self.device)
        g = np.asarray(obs["gripper"], dtype=float)
        state = _state(np.asarray(obs["joint_pos"], float), np.asarray(obs["tcp_pos"], float), g[0] + g[1])
        with torch.no_grad():
            out = self.net(imgs, tokens, torch.as_tensor(state[None], device=self.device))
        return out[0].cpu().numpy()

    def __call__(self, obs: Mapping[str, Any]) -> np.ndarray:
        if not self._queue:
            self._queue = list(self.predict(obs)[: self.execute])
        return np.clip(self._queue.pop(0), -1.0, 1.0).astype(np.float32)


def policy_for_evaluation(env: Any, config: Any) -> BCPolicy:
    """The policy ``samplehd evaluate --policy bc`` runs (``config``: its EvalConfig)."""
    return BCPolicy.load(config.models, env)


def _episode_arrays(reader: Any, k: int, stride: int, tokens_len: int) -> dict[str, np.ndarray]:
    ep = reader.episode(k)
    f = ep.frames
    imgs = {c: np.asarray(ep.images[c]["rgb"][:]) for c in CAMERAS}
    t = np.arange(0, len(f["steering"]), stride)
    return {
        "frames": t, "steering": np.asarray(f["steering"], np.float32),
        "state": _state(np.asarray(f["joint_pos"]), np.asarray(f["tcp_pos"]), np.asarray(f["gripper_opening"])),
        **{c: imgs[c][t] for c in CAMERAS},
        "tokens": encode_instruction(reader.instruction(k)["instruction"], tokens_len),
    }


def train_policy(dataset: str | Path, out: str | Path, steps: int = 4000, seed: int = 0, device: str | None = None,
                 quiet: bool = False, stop_after: int | None = None, batch: int = 64, chunk: int = 8,
                 execute: int = 4, stride: int = 2,
                 lr: float = 1e-3, width: int = 16, hidden: int = 256, tokens: int = 32,
                 families: Sequence[str] | None = None) -> dict[str, Any]:
    """Train the behaviour-cloning policy on a dataset's training episodes (images needed).

    Metrics (``metrics.json``): ``train_loss`` (L1 over the chunk, last 50 steps), ``test_l1``
    (the test episodes' frames), ``test_l1_first`` (first action only), episode and frame counts.
    """

    reader = open_dataset(dataset)
    # A dataset still being written (or stopped early) has its render settings only in the config.
    render = reader.info.get("render") or reader.config.get("render") or {}
    cams = camera_settings(render) if render else {}
    if not all(c in cams and "rgb" in cams[c]["modalities"] for c in CAMERAS):
        raise ConfigError(f"--dataset {dataset}: episodes need RGB of cameras {', '.join(CAMERAS)} (generate with "
                          "--render fast --cameras scene wrist --modalities rgb)")
    sizes = {(cams[c]["width"], cams[c]["height"]) for c in CAMERAS}
    if len(sizes) != 1 or next(iter(sizes))[0] != next(iter(sizes))[1]:
        raise ConfigError(f"--dataset {dataset}: the cameras need one square image size; found {sorted(sizes)}")
    image = next(iter(sizes))[0]
    scenes = {s["image_index"]: s for s in reader.scenes}
    train_k, test_k = [], []
    for e in reader.episodes:
        if families and e.family not in families:
            continue
        ins = reader.instruction(e.instruction_index)
        if e.split == "test":
            test_k.append(e.instruction_index)
        elif not held_out_instruction(ins) and episode_level(ins, scenes[e.scene_index]) == "L1":
            train_k.append(e.instruction_index)
    if not train_k:
        raise ConfigError(f"--dataset {dataset}: no training episodes")
    dev = pick_device(device)
    set_seed(seed)
    data = [_episode_arrays(reader, k, stride, tokens) for k in train_k]
    test = [_episode_arrays(reader, k, stride * 4, tokens) for k in test_k]
    config = {
        "kind": "policy", "format": 1, "dataset": str(dataset), "image": image, "chunk": chunk, "execute": execute,
        "tokens": tokens, "model": {"width": width, "hidden": hidden},
        "families": sorted({reader.instruction(k)["family"] for k in train_k}),
        "train": {"steps": steps, "seed": seed, "batch": batch, "stride": stride, "lr": lr,
                  "episodes": len(train_k), "frames": int(sum(len(d["frames"]) for d in data))},
    }
    net = BCNet(len(instruction_vocabulary()), image, chunk, width, hidden).to(dev)
    opt = torch.optim.Adam(net.parameters(), lr=lr)
    run = TrainRun(Path(out), config, steps, checkpoint_every=max(50, steps // 20), quiet=quiet,
                   stop_after=stop_after)
    run.prepare()
    index = [(i, j) for i, d in enumerate(data) for j in range(len(d["frames"]))]

    def batch_of(items: Sequence[Mapping[str, Any]], pairs: Sequence[tuple[int, int]],
                 rng: np.random.Generator | None) -> tuple[list[Any], Any, Any, Any]:
        imgs = {c: np.stack([items[i][c][j] for i, j in pairs]) for c in CAMERAS}
        if rng is not None:  # random shifts of up to 4 px
            for c in CAMERAS:
                pad = np.pad(imgs[c], ((0, 0), (4, 4), (4, 4), (0, 0)), mode="edge")
                sh = rng.integers(0, 9, size=(len(pairs), 2))
                imgs[c] = np.stack([pad[n, a:a + image, b:b + image] for n, (a, b) in enumerate(sh)])
        ims = [torch.as_tensor(imgs[c].transpose(0, 3, 1, 2).astype(np.float32) / 255.0, device=dev)
               for c in CAMERAS]
        toks = torch.as_tensor(np.stack([items[i]["tokens"] for i, _ in pairs]), device=dev)
        states, targets = [], []
        for i, j in pairs:
            d = items[i]
            t = int(d["frames"][j])
            states.append(d["state"][t])
            idx = np.minimum(np.arange(t, t + chunk), len(d["steering"]) - 1)
            targets.append(d["steering"][idx])
        return (ims, toks, torch.as_tensor(np.stack(states), device=dev),
                torch.as_tensor(np.stack(targets), device=dev))

    def train_step(step: int) -> float:
        net.train()
        rng = step_rng(seed, step)
        for g in opt.param_groups:
            g["lr"] = lr * min(1.0, 1.5 * (1 - step / steps))
        pairs = [index[i] for i in rng.integers(len(index), size=batch)]
        ims, toks, st, tgt = batch_of(data, pairs, rng)
        loss = F.l1_loss(net(ims, toks, st), tgt)
        return descend(opt, loss)

    losses, t = run.train(net, opt, train_step, "policy")
    if run.stopped:
        return {"stopped_at": len(losses)}
    net.eval()
    errs, firsts = [], []
    with torch.no_grad():
        tpairs = [(i, j) for i, d in enumerate(test) for j in range(len(d["frames"]))]
        for k in range(0, len(tpairs), 256):
            ims, toks, st, tgt = batch_of(test, tpairs[k:k + 256], None)
            pred = net(ims, toks, st)
            errs.append(float(F.l1_loss(pred, tgt, reduction="sum")) / 7 / chunk)
            firsts.append(float(F.l1_loss(pred[:, 0], tgt[:, 0], reduction="sum")) / 7)
    n = max(len(tpairs), 1)
    metrics = {
        "train_loss": float(np.mean(losses[-50:])) if losses else None,
        "test_l1": sum(errs) / n if tpairs else None,
        "test_l1_first": sum(firsts) / n if tpairs else None,
        "train_episodes": len(train_k), "train_frames": config["train"]["frames"],
        "test_episodes": len(test_k), "test_frames": len(tpairs),
        "families": config["families"], "steps": steps, "seed": seed, "device": str(dev), **t,
    }
    run.finish(net, metrics)
    return metrics
