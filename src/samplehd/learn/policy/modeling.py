"""The behaviour-cloning policy's network: one small CNN per camera whose last block is FiLM-modulated
by the instruction (a GRU over the token ids of :mod:`samplehd.envs.tokens`), or ends in keypoints
(a spatial softmax) for waypoints; a state MLP over the normalised robot state; an MLP head that
writes ``chunk`` × 7 values in [-1, 1].
"""

from __future__ import annotations

from collections.abc import Sequence

from samplehd.learn.policy.configuration import STATE_DIM
from samplehd.learn.policy.processing import CAMERAS
from samplehd.learn.training import nn, torch

__all__ = ["BCNet", "Encoder", "KeyposeNet", "KeypointEncoder"]


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


class _Block(nn.Module):
    """Two 3×3 convolutions with group norm, the second FiLM-modulated by the code ``c``."""

    def __init__(self, cin: int, cout: int, cond: int, stride: int = 1) -> None:
        super().__init__()
        self.a = nn.Sequential(nn.Conv2d(cin, cout, 3, stride=stride, padding=1), nn.GroupNorm(8, cout),
                               nn.ReLU(inplace=True))
        self.b = nn.Sequential(nn.Conv2d(cout, cout, 3, padding=1), nn.GroupNorm(8, cout))
        self.film = nn.Linear(cond, 2 * cout)

    def forward(self, x: torch.Tensor, c: torch.Tensor) -> torch.Tensor:
        h = self.b(self.a(x))
        gamma, beta = self.film(c).chunk(2, dim=1)
        return torch.relu(h * (1 + gamma[:, :, None, None]) + beta[:, :, None, None])


KEYPOSE_ATTRIBUTES = ("name", "color", "material", "size")  # the scene annotation's keys the auxiliary maps name
ATTRIBUTE_VALUES = 32  # logits per attribute (the catalogues have at most 16 values of any)
GRASP_OUT = 8  # heat, row and column offset, z, cos 2yaw, sin 2yaw, opening, lift
GOAL_OUT = 6  # heat, row and column offset, z, cos 2yaw, sin 2yaw


class KeyposeNet(nn.Module):
    """Top-down grid + instruction → a decision (:mod:`samplehd.learn.policy.keyposes`), as maps at half
    the grid's resolution.

    A U-Net whose blocks are FiLM-modulated by the instruction (a GRU over its tokens) writes per cell
    of the half-resolution map the grasp's heat (a logit; the softmax over all cells says where), the
    grasp's offset within the cell, height, yaw (as cos and sin of twice the yaw: the fingers are
    symmetric), opening and lift height. The goal's maps are written by a head modulated as well by the
    features at the grasp's cell (which object is carried); two logits say whether the gripper lets go
    at the goal and whether the decision is the last.
    """

    def __init__(self, vocab: int, channels: int, width: int = 32) -> None:
        super().__init__()
        w = width
        self.register_buffer("z_floor", torch.zeros(()))  # the lowest grasp height of the training decisions [m]
        self.embed = nn.Embedding(vocab, 64, padding_idx=0)
        self.text = nn.GRU(64, 128, batch_first=True)
        self.mix = nn.Linear(128 + 64, 128)
        self.down1 = _Block(channels, w, 128, stride=2)  # 1/2
        self.down2 = _Block(w, 2 * w, 128, stride=2)  # 1/4
        self.down3 = _Block(2 * w, 4 * w, 128, stride=2)  # 1/8
        self.down4 = _Block(4 * w, 4 * w, 128, stride=2)  # 1/16
        self.up3 = _Block(8 * w, 2 * w, 128)
        self.up2 = _Block(4 * w, w, 128)
        self.up1 = _Block(2 * w, w, 128)
        self.grasp = nn.Conv2d(w, GRASP_OUT, 1)
        self.goal_cond = nn.Linear(128 + w + 2, 128)
        self.goal = _Block(w, w, 128)
        self.goal_out = nn.Conv2d(w, GOAL_OUT, 1)
        self.flags = nn.Sequential(nn.Linear(4 * w + 128, 128), nn.ReLU(inplace=True), nn.Linear(128, 2))
        # training only: per cell, the class, colour, material and size of the object seen there
        self.attributes = nn.Conv2d(w, len(KEYPOSE_ATTRIBUTES) * ATTRIBUTE_VALUES, 1)

    def code(self, tokens: torch.Tensor) -> torch.Tensor:
        """The instruction's code: the GRU's last state beside the mean of its words' embeddings (the
        bag of words names the attributes whatever the template)."""
        emb = self.embed(tokens)
        lengths = (tokens != 0).sum(1).clamp(min=1)
        packed = nn.utils.rnn.pack_padded_sequence(emb, lengths.cpu(), batch_first=True, enforce_sorted=False)
        _, h = self.text(packed)
        words = emb.sum(1) / lengths[:, None].to(emb.dtype)
        return torch.relu(self.mix(torch.cat([h[-1], words], 1)))

    def features(self, grid: torch.Tensor, tokens: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
        """(the instruction's code, the half-resolution feature map, the flag logits)."""
        c = self.code(tokens)
        d1 = self.down1(grid, c)
        d2 = self.down2(d1, c)
        d3 = self.down3(d2, c)
        d4 = self.down4(d3, c)
        u3 = self.up3(torch.cat([nn.functional.interpolate(d4, size=d3.shape[2:]), d3], 1), c)
        u2 = self.up2(torch.cat([nn.functional.interpolate(u3, size=d2.shape[2:]), d2], 1), c)
        u1 = self.up1(torch.cat([nn.functional.interpolate(u2, size=d1.shape[2:]), d1], 1), c)
        flags = self.flags(torch.cat([d4.mean(dim=(2, 3)), c], 1))
        return c, u1, flags

    def goal_maps(self, c: torch.Tensor, feats: torch.Tensor, cell: torch.Tensor) -> torch.Tensor:
        """The goal's maps given the grasp's cell (N, 2: row, column of the half-resolution map)."""
        n, _, rows, cols = feats.shape
        at = feats[torch.arange(n, device=feats.device), :, cell[:, 0], cell[:, 1]]
        where = torch.stack([cell[:, 0].float() / max(rows - 1, 1), cell[:, 1].float() / max(cols - 1, 1)], 1) * 2 - 1
        cond = torch.relu(self.goal_cond(torch.cat([c, at, where], 1)))
        return self.goal_out(self.goal(feats, cond))

    def forward(self, grid: torch.Tensor, tokens: torch.Tensor, cell: torch.Tensor) -> tuple[torch.Tensor, ...]:
        """(grasp maps, goal maps, flag logits), the goal's given the grasp ``cell``."""
        c, feats, flags = self.features(grid, tokens)
        return self.grasp(feats), self.goal_maps(c, feats, cell), flags
