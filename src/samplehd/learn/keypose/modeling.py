"""The keypose policy's network (:class:`KeyposeNet`): a U-Net over the top-down grid whose blocks are
FiLM-modulated by the instruction, writing the grasp's and the goal's maps."""

from __future__ import annotations

from samplehd.learn.keypose.configuration import ATTRIBUTE_VALUES, KEYPOSE_ATTRIBUTES
from samplehd.learn.training import nn, torch

__all__ = ["GOAL_OUT", "GRASP_OUT", "PLACED_COUNTS", "KeyposeNet"]

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


GRASP_OUT = 8  # heat, row and column offset, z, cos 2yaw, sin 2yaw, opening, lift
GOAL_OUT = 6  # heat, row and column offset, z, cos 2yaw, sin 2yaw
PRODUCT_CHANNELS = 32  # channels of the product head's key and query
PLACED_COUNTS = 8  # the counts of objects put down the code tells apart (higher ones read as the last)


class KeyposeNet(nn.Module):
    """Top-down grid + instruction → a decision (:mod:`samplehd.learn.keypose.follower`), as maps at half
    the grid's resolution.

    A U-Net whose blocks are FiLM-modulated by the instruction (a GRU over its tokens) writes per cell
    of the half-resolution map the grasp's heat (a logit; the softmax over all cells says where), the
    grasp's offset within the cell, height, yaw (as cos and sin of twice the yaw: the fingers are
    symmetric), opening and lift height. The goal's maps are written by a head modulated as well by the
    features at the grasp's cell (which object is carried); two logits say whether the gripper lets go
    at the goal and whether the decision is the last. With ``placed_count``, a learnt vector per count
    of objects the policy has put down so far is added to the instruction's code (zero at the start of
    training, so the network begins as the one without).
    """

    def __init__(self, vocab: int, channels: int, width: int = 32, grasp_head: str = "film",
                 placed_count: bool = False) -> None:
        super().__init__()
        w = width
        self.product = grasp_head == "product"
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
        if self.product:  # the grasp's heat also reads the instruction per cell: a key of the cell's features · a query
            self.key = nn.Conv2d(w, PRODUCT_CHANNELS, 1)
            self.query = nn.Linear(128, PRODUCT_CHANNELS)
        self.goal_cond = nn.Linear(128 + w + 2, 128)
        self.goal = _Block(w, w, 128)
        self.goal_out = nn.Conv2d(w, GOAL_OUT, 1)
        self.flags = nn.Sequential(nn.Linear(4 * w + 128, 128), nn.ReLU(inplace=True), nn.Linear(128, 2))
        # training only: per cell, the class, colour, material and size of the object seen there
        self.attributes = nn.Conv2d(w, len(KEYPOSE_ATTRIBUTES) * ATTRIBUTE_VALUES, 1)
        self.placed: nn.Embedding | None = None  # made last: the other weights start as without it
        if placed_count:
            self.placed = nn.Embedding(PLACED_COUNTS, 128)
            nn.init.zeros_(self.placed.weight)

    def code(self, tokens: torch.Tensor, placed: torch.Tensor | None = None) -> torch.Tensor:
        """The instruction's code: the GRU's last state beside the mean of its words' embeddings (the
        bag of words names the attributes whatever the template); with ``placed_count``, plus the vector
        of ``placed`` (N,: objects put down so far; None: 0)."""
        emb = self.embed(tokens)
        lengths = (tokens != 0).sum(1).clamp(min=1)
        packed = nn.utils.rnn.pack_padded_sequence(emb, lengths.cpu(), batch_first=True, enforce_sorted=False)
        _, h = self.text(packed)
        words = emb.sum(1) / lengths[:, None].to(emb.dtype)
        c = torch.relu(self.mix(torch.cat([h[-1], words], 1)))
        if self.placed is None:
            return c
        if placed is None:
            placed = torch.zeros(len(tokens), dtype=torch.long, device=tokens.device)
        return c + self.placed(placed.long().clamp(0, PLACED_COUNTS - 1))

    def features(self, grid: torch.Tensor, tokens: torch.Tensor, placed: torch.Tensor | None = None
                 ) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
        """(the instruction's code, the half-resolution feature map, the flag logits); ``placed``: see
        :meth:`code`."""
        c = self.code(tokens, placed)
        d1 = self.down1(grid, c)
        d2 = self.down2(d1, c)
        d3 = self.down3(d2, c)
        d4 = self.down4(d3, c)
        u3 = self.up3(torch.cat([nn.functional.interpolate(d4, size=d3.shape[2:]), d3], 1), c)
        u2 = self.up2(torch.cat([nn.functional.interpolate(u3, size=d2.shape[2:]), d2], 1), c)
        u1 = self.up1(torch.cat([nn.functional.interpolate(u2, size=d1.shape[2:]), d1], 1), c)
        flags = self.flags(torch.cat([d4.mean(dim=(2, 3)), c], 1))
        return c, u1, flags

    def grasp_maps(self, c: torch.Tensor, feats: torch.Tensor) -> torch.Tensor:
        """The grasp's maps (N, :data:`GRASP_OUT`, rows, cols); with the ``product`` head, the heat plus
        the scaled dot product of each cell's key with the instruction's query."""
        maps = self.grasp(feats)
        if not self.product:
            return maps
        match = (self.key(feats) * self.query(c)[:, :, None, None]).sum(1, keepdim=True) / PRODUCT_CHANNELS ** 0.5
        return torch.cat([maps[:, :1] + match, maps[:, 1:]], 1)

    def attribute_maps(self, feats: torch.Tensor) -> torch.Tensor:
        """The auxiliary maps' logits (N, attribute of :data:`KEYPOSE_ATTRIBUTES`, :data:`ATTRIBUTE_VALUES`,
        rows, cols): per cell, the class, colour, material and size of the object seen there."""
        n, _, rows, cols = feats.shape
        return self.attributes(feats).view(n, len(KEYPOSE_ATTRIBUTES), ATTRIBUTE_VALUES, rows, cols)

    def goal_maps(self, c: torch.Tensor, feats: torch.Tensor, cell: torch.Tensor) -> torch.Tensor:
        """The goal's maps given the grasp's cell (N, 2: row, column of the half-resolution map)."""
        n, _, rows, cols = feats.shape
        at = feats[torch.arange(n, device=feats.device), :, cell[:, 0], cell[:, 1]]
        where = torch.stack([cell[:, 0].float() / max(rows - 1, 1), cell[:, 1].float() / max(cols - 1, 1)], 1) * 2 - 1
        cond = torch.relu(self.goal_cond(torch.cat([c, at, where], 1)))
        return self.goal_out(self.goal(feats, cond))

    def forward(self, grid: torch.Tensor, tokens: torch.Tensor, cell: torch.Tensor,
                placed: torch.Tensor | None = None) -> tuple[torch.Tensor, ...]:
        """(grasp maps, goal maps, flag logits), the goal's given the grasp ``cell``."""
        c, feats, flags = self.features(grid, tokens, placed)
        return self.grasp_maps(c, feats), self.goal_maps(c, feats, cell), flags
