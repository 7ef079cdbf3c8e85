"""The two networks of perception: a U-Net that labels pixels, an attribute network that names an
instance's class, colour, material, size and kind.
"""

from __future__ import annotations

from collections.abc import Sequence

from samplehd.learn.perception.configuration import CROP_CHANNELS, N_FEATURES, SEG_CHANNELS, SEG_CLASSES
from samplehd.learn.training import F, nn, torch

__all__ = ["UNet", "AttributeNet", "PerceptionNet"]


def _block(cin: int, cout: int) -> nn.Module:
    return nn.Sequential(nn.Conv2d(cin, cout, 3, padding=1), nn.BatchNorm2d(cout), nn.ReLU(inplace=True),
                         nn.Conv2d(cout, cout, 3, padding=1), nn.BatchNorm2d(cout), nn.ReLU(inplace=True))


class UNet(nn.Module):
    """Per-pixel labels (:data:`SEG_CLASSES`) from the 4-channel RGB-D input."""

    def __init__(self, width: int) -> None:
        super().__init__()
        w = width
        self.e1, self.e2, self.e3 = _block(SEG_CHANNELS, w), _block(w, 2 * w), _block(2 * w, 4 * w)
        self.mid = _block(4 * w, 4 * w)
        self.d3, self.d2, self.d1 = _block(8 * w, 2 * w), _block(4 * w, w), _block(2 * w, w)
        self.head = nn.Conv2d(w, len(SEG_CLASSES), 1)
        self.pool = nn.MaxPool2d(2)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        e1 = self.e1(x)
        e2 = self.e2(self.pool(e1))
        e3 = self.e3(self.pool(e2))
        m = self.mid(self.pool(e3))

        def up(t: torch.Tensor, ref: torch.Tensor) -> torch.Tensor:
            return F.interpolate(t, size=ref.shape[-2:], mode="nearest")

        d3 = self.d3(torch.cat([up(m, e3), e3], 1))
        d2 = self.d2(torch.cat([up(d3, e2), e2], 1))
        d1 = self.d1(torch.cat([up(d2, e1), e1], 1))
        return self.head(d1)


class AttributeNet(nn.Module):
    """Class, colour, material and size logits from an instance crop and its metric size."""

    def __init__(self, width: int, sizes: Sequence[int]) -> None:
        super().__init__()
        w = width
        self.features = nn.Sequential(
            nn.Conv2d(CROP_CHANNELS, w, 3, padding=1), nn.BatchNorm2d(w), nn.ReLU(inplace=True), nn.MaxPool2d(2),
            nn.Conv2d(w, 2 * w, 3, padding=1), nn.BatchNorm2d(2 * w), nn.ReLU(inplace=True), nn.MaxPool2d(2),
            nn.Conv2d(2 * w, 4 * w, 3, padding=1), nn.BatchNorm2d(4 * w), nn.ReLU(inplace=True), nn.MaxPool2d(2),
            nn.Conv2d(4 * w, 4 * w, 3, padding=1), nn.BatchNorm2d(4 * w), nn.ReLU(inplace=True),
            nn.AdaptiveAvgPool2d(1), nn.Flatten())
        self.geometry = nn.Sequential(nn.Linear(N_FEATURES, 64), nn.ReLU(inplace=True), nn.Linear(64, 64),
                                      nn.ReLU(inplace=True))
        self.trunk = nn.Sequential(nn.Linear(4 * w + 64, 128), nn.ReLU(inplace=True))
        self.heads = nn.ModuleList([nn.Linear(128, n) for n in sizes])

    def forward(self, crops: torch.Tensor, features: torch.Tensor) -> list[torch.Tensor]:
        h = self.trunk(torch.cat([self.features(crops), self.geometry(features)], 1))
        return [head(h) for head in self.heads]


class PerceptionNet(nn.Module):
    """The two networks in one state dict."""

    def __init__(self, seg_width: int, attr_width: int, sizes: Sequence[int]) -> None:
        super().__init__()
        self.segmenter = UNet(seg_width)
        self.attributes = AttributeNet(attr_width, sizes)
