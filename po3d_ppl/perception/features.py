"""The feature extractor of render-and-compare: a small CNN, trained from scratch, giving L2-normalised features at
stride 8 (paper §4.2; NeMo's backbone is an ImageNet ResNet-50 U-Net, whose weights cannot be downloaded here).

**Why this shape.** A vertex feature must say *which* part of *which* category a cell shows (front-left wheel of
a car, not of a bus), so a cell's receptive field must span most of an object (60-250 px in a 640x480 render).
A plain stride-8 stack sees ~60 px; so the network goes on to strides 16 and 32 and comes back (a light U-Net:
bilinear upsampling added to 1x1 lateral projections), for a receptive field of several hundred pixels at a
small cost, since the deep layers run on 40x30 and 20x15 maps. Channels stay narrow (24 ... 128) because the
whole model must run a 640x480 image in well under a second on 2 CPU cores and train within minutes.

BatchNorm (eval mode at inference, so a feature does not depend on the rest of the batch) and ReLU throughout;
no dropout. Output: ``[B, dim, ceil(H/8), ceil(W/8)]``, unit length along the channel axis. Runs on any device
(tensors follow the module's parameters). 566k parameters (2.3 MB). Speed (``benchmarks/bench_features.py``,
2-core CPU shared with other work): 37-41 ms for a 640x480 image on one torch thread (up to ~140 ms when both
cores are busy; two threads are slower than one on a busy machine). Training lives in
:mod:`po3d_ppl.perception.train_features`, with what the trained features tell apart.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import torch
import torch.nn.functional as F
from torch import nn

from po3d_ppl.errors import InputError

#: The feature map's stride (pixels per cell): fixed, the neural meshes are projected at it.
STRIDE = 8


@dataclass(frozen=True)
class FeatureConfig:
    """Architecture of :class:`FeatureExtractor` (stored with the weights, so a saved model rebuilds itself)."""

    #: Feature dimension (the neural texture's too).
    dim: int = 64
    #: Channels at strides 2, 4, 8, 16 and 32.
    widths: tuple[int, int, int, int, int] = (24, 32, 64, 96, 128)

    def __post_init__(self) -> None:
        if not (isinstance(self.dim, int) and 4 <= self.dim <= 1024):
            raise InputError("FeatureConfig.dim", f"must be an integer in 4..1024, got {self.dim!r}")
        if len(self.widths) != 5 or not all(isinstance(w, int) and w >= 4 for w in self.widths):
            raise InputError("FeatureConfig.widths", f"must be five integers >= 4, got {self.widths!r}")

    def to_dict(self) -> dict:
        return {"dim": self.dim, "widths": list(self.widths)}

    @classmethod
    def from_dict(cls, data: dict) -> FeatureConfig:
        return cls(dim=int(data["dim"]), widths=tuple(int(w) for w in data["widths"]))


def _conv(cin: int, cout: int, stride: int = 1) -> nn.Sequential:
    return nn.Sequential(nn.Conv2d(cin, cout, 3, stride, 1, bias=False), nn.BatchNorm2d(cout), nn.ReLU(inplace=True))


class FeatureExtractor(nn.Module):
    """Image ``[B, 3, H, W]`` (RGB in [0, 1]) -> unit features ``[B, dim, ceil(H/8), ceil(W/8)]``."""

    stride = STRIDE

    def __init__(self, config: FeatureConfig = FeatureConfig()):
        super().__init__()
        self.config = config
        w2, w4, w8, w16, w32 = config.widths
        self.s4 = nn.Sequential(_conv(3, w2, 2), _conv(w2, w4, 2), _conv(w4, w4))
        self.s8 = nn.Sequential(_conv(w4, w8, 2), _conv(w8, w8), _conv(w8, w8))
        self.s16 = nn.Sequential(_conv(w8, w16, 2), _conv(w16, w16))
        self.s32 = nn.Sequential(_conv(w16, w32, 2), _conv(w32, w32))
        self.lat32 = nn.Conv2d(w32, w16, 1)
        self.lat16 = nn.Conv2d(w16, w8, 1)
        self.merge = _conv(w8, w8)
        self.head = nn.Conv2d(w8, config.dim, 1)

    def forward(self, images: torch.Tensor) -> torch.Tensor:
        if images.dim() != 4 or images.shape[1] != 3:
            raise InputError("images", f"expected [B, 3, H, W] RGB, got shape {tuple(images.shape)}")
        x = (images - 0.5) / 0.25
        f8 = self.s8(self.s4(x))
        f16 = self.s16(f8)
        f32 = self.s32(f16)
        up16 = f16 + F.interpolate(self.lat32(f32), size=f16.shape[-2:], mode="bilinear", align_corners=False)
        up8 = f8 + F.interpolate(self.lat16(up16), size=f8.shape[-2:], mode="bilinear", align_corners=False)
        return F.normalize(self.head(self.merge(up8)), dim=1)

    def num_parameters(self) -> int:
        return sum(p.numel() for p in self.parameters())


def feature_map_size(height: int, width: int) -> tuple[int, int]:
    """(rows, columns) of the stride-8 feature map of a ``height`` x ``width`` image (80 x 60 for 640 x 480)."""
    return -(-height // STRIDE), -(-width // STRIDE)


@torch.no_grad()
def extract_features(extractor: FeatureExtractor, pixels: torch.Tensor) -> torch.Tensor:
    """Features of one image ``[3, H, W]`` (e.g. ``load_image(path).pixels``) or a batch ``[B, 3, H, W]``, in eval
    mode on the extractor's device: ``[dim, H/8, W/8]`` or ``[B, dim, H/8, W/8]``."""
    single = pixels.dim() == 3
    batch = pixels[None] if single else pixels
    device = next(extractor.parameters()).device
    was_training = extractor.training
    extractor.eval()
    try:
        out = extractor(batch.to(device=device, dtype=torch.float32))
    finally:
        extractor.train(was_training)
    return out[0] if single else out


def config_dict(config: FeatureConfig) -> dict:
    return asdict(config)
