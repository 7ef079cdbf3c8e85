"""The behaviour-cloning policy's network: one small CNN per camera whose last block is FiLM-modulated
by the instruction (a GRU over the token ids of :mod:`samplehd.envs.tokens`), or ends in keypoints
(a spatial softmax) for waypoints; a state MLP over the normalised robot state; an MLP head that
writes ``chunk`` × 7 values in [-1, 1].
"""

from __future__ import annotations

from collections.abc import Sequence

from samplehd.learn.policy.configuration import CAMERAS, STATE_DIM
from samplehd.learn.training import nn, torch

__all__ = ["BCNet", "Encoder", "KeypointEncoder"]


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


class KeypointEncoder(nn.Module):
    """A camera's CNN that ends in a spatial softmax (Levine et al., 2016): each of ``keypoints``
    feature maps becomes the image position of its mass (x, y in [-1, 1]), read after the features
    are FiLM-modulated by the instruction code ``c``, so that the positions can follow the object
    the instruction names. Writes the positions and the average of the modulated features."""

    def __init__(self, w: int, cond: int, keypoints: int = 32) -> None:
        super().__init__()
        self.convs = nn.Sequential(
            nn.Conv2d(3, w, 3, stride=2, padding=1), nn.GroupNorm(8, w), nn.ReLU(inplace=True),
            nn.Conv2d(w, 2 * w, 3, stride=2, padding=1), nn.GroupNorm(8, 2 * w), nn.ReLU(inplace=True),
            nn.Conv2d(2 * w, 2 * w, 3, padding=1), nn.GroupNorm(8, 2 * w))
        self.film = nn.Linear(cond, 4 * w)
        self.points = nn.Conv2d(2 * w, keypoints, 1)
        self.features = 2 * keypoints + 2 * w

    def forward(self, x: torch.Tensor, c: torch.Tensor) -> torch.Tensor:
        h = self.convs(x)
        gamma, beta = self.film(c).chunk(2, dim=1)
        h = torch.relu(h * (1 + gamma[:, :, None, None]) + beta[:, :, None, None])
        maps = self.points(h)
        n, k, rows, cols = maps.shape
        weights = torch.softmax(maps.view(n, k, rows * cols), dim=2).view(n, k, rows, cols)
        ys = torch.linspace(-1.0, 1.0, rows, device=x.device, dtype=x.dtype)
        xs = torch.linspace(-1.0, 1.0, cols, device=x.device, dtype=x.dtype)
        px = (weights.sum(dim=2) * xs).sum(dim=2)
        py = (weights.sum(dim=3) * ys).sum(dim=2)
        return torch.cat([px, py, h.mean(dim=(2, 3))], dim=1)


class BCNet(nn.Module):
    """Images + instruction tokens + robot state → ``chunk`` steering vectors in [-1, 1]."""

    def __init__(self, vocab: int, image: int, chunk: int, width: int, hidden: int, state_dim: int = STATE_DIM,
                 normalise: bool = True, cameras: int = len(CAMERAS), encoder: str = "flatten") -> None:
        super().__init__()
        self.chunk = chunk
        self.normalise = normalise
        if normalise:  # per-dimension mean and spread of the training frames' states (set before training)
            self.register_buffer("state_mean", torch.zeros(state_dim))
            self.register_buffer("state_std", torch.ones(state_dim))
        self.embed = nn.Embedding(vocab, 64, padding_idx=0)
        self.text = nn.GRU(64, 128, batch_first=True)
        if encoder == "keypoints":
            self.encoders = nn.ModuleList([KeypointEncoder(width, 128) for _ in range(cameras)])
            feat = KeypointEncoder(width, 128).features
        else:
            self.encoders = nn.ModuleList([Encoder(width, 128) for _ in range(cameras)])
            side = image
            for _ in range(4):
                side = (side + 1) // 2
            feat = 2 * width * side * side
        self.state = nn.Sequential(nn.Linear(state_dim, 64), nn.ReLU(inplace=True))
        self.head = nn.Sequential(nn.Linear(cameras * feat + 64 + 128, hidden), nn.ReLU(inplace=True),
                                  nn.Linear(hidden, hidden), nn.ReLU(inplace=True), nn.Linear(hidden, chunk * 7))

    def forward(self, images: Sequence[torch.Tensor], tokens: torch.Tensor, state: torch.Tensor) -> torch.Tensor:
        lengths = (tokens != 0).sum(1).clamp(min=1).cpu()
        packed = nn.utils.rnn.pack_padded_sequence(self.embed(tokens), lengths, batch_first=True,
                                                   enforce_sorted=False)
        _, h = self.text(packed)
        c = h[-1]
        feats = [enc(img, c) for enc, img in zip(self.encoders, images, strict=True)]
        if self.normalise:
            state = (state - self.state_mean) / self.state_std
        out = self.head(torch.cat([*feats, self.state(state), c], 1))
        return torch.tanh(out).view(-1, self.chunk, 7)






