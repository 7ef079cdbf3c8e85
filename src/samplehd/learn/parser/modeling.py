"""The parser's network: a GRU encoder–decoder with attention (Luong)."""

from __future__ import annotations

from samplehd.envs.tokens import SPECIAL_TOKENS
from samplehd.learn.training import nn, torch

__all__ = ["Seq2Seq"]


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
