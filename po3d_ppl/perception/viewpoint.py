"""The viewpoint network: a discriminative azimuth reading of each proposal's crop, combined with the
render-and-compare pose table (issue "Perception I": azimuth; a flipped azimuth also misplaces every projected part).

**Why a second pose reader.** Render-and-compare scores a pose by how well the neural-mesh vertex features match
the image's, cell by cell. The features are local (stride 8), and the front and back halves of a bus or an
airliner look alike at that scale, so its pose table often puts its mass on the flipped azimuth (buses and
aeroplanes: 0.49 and 0.50 within 30 degrees on seed 713). A small CNN that sees the whole object at once (the
attribute network's object crop: RGB and visible mask, plus the box scalars) reads the layout that tells the front
from the back: where the windscreen, the cab, the wheels and the tail are. The two readings are combined as a
product of experts, ``log P(azimuth | category) = log_softmax(pose_rc / T_rc + viewpoint / T_vp)``, each with its
own temperature (:func:`combine_pose`).

**Frame.** Bins are the object parser's (``ParserConfig.azimuths``: 0, 15, ..., 345 degrees) in the contract's
``pose_degree`` frame, clockwise from the viewing ray, which is what a view depends on: the same crop means the
same bin wherever the object stands. A horizontal mirror of the crop maps ``pose_degree`` to ``-pose_degree``, so
bin k to bin -k: inference averages the reading of the crop and of its mirror image with the bins permuted back,
and training mirrors crops and labels alike.

**Training** (:mod:`po3d_ppl.perception.train_viewpoint`, ``po3d train viewpoint``): the attribute network's
cached crops around the ground-truth visible masks (never at inference), soft labels on the two bins nearest the
true ``pose_degree``, plus the dense part-segmentation auxiliary target (left/right and front/back parts are what
the azimuth is), with mirror, window and mask jitter.
"""

from __future__ import annotations

import json
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import torch
import torch.nn.functional as F
from torch import nn

from po3d_ppl.errors import InputError, ModelFileError
from po3d_ppl.perception.attributes import (
    DENSE_CLASSES,
    OBJECT_CHANNELS,
    OBJECT_GEOMETRY,
    AttributeConfig,
    CropNet,
    as_pixels,
    check_masks,
    mirror_object_geometry,
    object_inputs,
)

MODEL_NAME = "viewpoint"
WEIGHTS = "viewpoint.safetensors"
FORMAT = 1
RETRAIN = ("retrain it with `po3d train viewpoint --data /work/data/perc_train_s711 --val-data "
           "/work/data/perc_val_s712` (see docs/perception.md) or restore it with `git checkout models/`")


@dataclass(frozen=True)
class ViewpointConfig:
    """Bins and the crop network's size (stored with the weights)."""

    azimuth_bins: int = 24
    object_size: int = 64
    object_widths: tuple[int, int, int, int] = (16, 32, 64, 128)
    hidden: int = 128

    def __post_init__(self) -> None:
        if not (isinstance(self.azimuth_bins, int) and self.azimuth_bins >= 4 and self.azimuth_bins % 2 == 0):
            raise InputError("ViewpointConfig.azimuth_bins", f"must be an even integer >= 4, got {self.azimuth_bins!r}")

    @property
    def crops(self) -> AttributeConfig:
        """The crop geometry: the attribute network's object crops (so the crop cache serves both)."""
        return AttributeConfig(object_size=self.object_size, object_widths=self.object_widths, hidden=self.hidden)

    @property
    def bin_degrees(self) -> float:
        return 360.0 / self.azimuth_bins

    def to_dict(self) -> dict:
        d = asdict(self)
        d["object_widths"] = list(self.object_widths)
        return d

    @classmethod
    def from_dict(cls, data: dict) -> ViewpointConfig:
        d = dict(data)
        d["object_widths"] = tuple(d["object_widths"])
        return cls(**d)


def mirror_bins(bins: int) -> torch.Tensor:
    """Bin k of a crop -> bin of its mirror image (pose_degree -> -pose_degree)."""
    return (-torch.arange(bins)) % bins


def soft_azimuth_targets(pose_degree: torch.Tensor, bins: int) -> torch.Tensor:
    """[N, bins] targets: each angle's mass split linearly between the two nearest bin centres (k * 360 / bins)."""
    pos = (pose_degree.double() % 360.0) / (360.0 / bins)
    low = torch.floor(pos).long() % bins
    frac = (pos - torch.floor(pos)).float()
    out = torch.zeros(pose_degree.shape[0], bins)
    out.scatter_add_(1, low[:, None], (1 - frac)[:, None])
    out.scatter_add_(1, ((low + 1) % bins)[:, None], frac[:, None])
    return out


class ViewpointNet(nn.Module):
    """Object crop -> azimuth-bin logits (and, in training, the dense part map). ``temperature`` divides the logits
    (1 until fitted on a validation split)."""

    def __init__(self, config: ViewpointConfig = ViewpointConfig()):
        super().__init__()
        self.config = config
        self.net = CropNet(OBJECT_CHANNELS, config.object_widths, OBJECT_GEOMETRY, config.hidden,
                           {"azimuth": config.azimuth_bins}, dense=DENSE_CLASSES)
        self.register_buffer("temperature", torch.ones(()))
        self.register_buffer("mirror", mirror_bins(config.azimuth_bins), persistent=False)

    @property
    def device(self) -> torch.device:
        return self.temperature.device

    def num_parameters(self) -> int:
        return sum(p.numel() for p in self.parameters())

    def forward(self, crops: torch.Tensor, geometry: torch.Tensor) -> dict[str, torch.Tensor]:
        return self.net(crops, geometry)

    def logits(self, crops: torch.Tensor, geometry: torch.Tensor) -> torch.Tensor:
        """Uncalibrated azimuth logits ``[N, bins]``, in eval mode averaged with the mirrored crop's (bins mapped
        back), which removes any left/right bias the network learnt."""
        out = self.net(crops, geometry)["azimuth"]
        if not self.training:
            flipped = self.net(crops.flip(-1), mirror_object_geometry(geometry))["azimuth"]
            out = (out + flipped[:, self.mirror]) / 2
        return out

    @torch.no_grad()
    def azimuth_loglik(self, image: Any, masks: torch.Tensor, calibrated: bool = True) -> torch.Tensor:
        """Per-proposal calibrated log-probabilities ``[N, bins]`` over the azimuth bins (``pose_degree`` frame)
        from the image (``[3, H, W]`` float or uint8, or an ``ImageInput``) and one bool visible mask per proposal."""
        pixels = as_pixels(image, self.device)
        masks = check_masks(masks, pixels, "masks")
        if masks.shape[0] == 0:
            return torch.zeros(0, self.config.azimuth_bins)
        inputs = object_inputs(pixels, masks, self.config.crops)
        self.eval()
        logits = self.logits(inputs.crops, inputs.geometry)
        return F.log_softmax(logits / (self.temperature if calibrated else 1.0), -1).cpu()


def combine_pose(pose_loglik: torch.Tensor, pose_support: torch.Tensor, viewpoint_loglik: torch.Tensor,
                 weight: float = 1.0, temperature: float = 1.0) -> torch.Tensor:
    """``log P(azimuth | category)`` [N, 5, K]: the render-and-compare table times the viewpoint reading ``[N, K]``
    raised to ``weight``, the product tempered by ``temperature`` (the two readings see the same pixels, so their
    errors are not independent) and renormalised per category. The support must be the network's bins."""
    n, _, k = pose_loglik.shape
    if viewpoint_loglik.shape != (n, k):
        raise InputError("viewpoint_loglik", f"expected [{n}, {k}] to match the pose table, got "
                                             f"{list(viewpoint_loglik.shape)}")
    if not (weight >= 0 and temperature > 0):
        raise InputError("combine_pose", f"weight must be >= 0 and temperature > 0, got {weight}, {temperature}")
    if n:
        centres = torch.arange(k, dtype=pose_support.dtype) * (360.0 / k)
        if not torch.allclose(pose_support, centres.expand_as(pose_support), atol=1e-6):
            raise InputError("pose_support", f"the viewpoint network reads {k} bins at multiples of {360 / k} "
                                             "degrees; the object parser's azimuth bins differ")
    combined = pose_loglik + weight * viewpoint_loglik.to(pose_loglik.dtype)[:, None, :]
    return torch.log_softmax(combined / temperature, -1)


# --- files -----------------------------------------------------------------------------------------------------------


def save_viewpoint_net(net: ViewpointNet, directory: Path | str, **manifest: Any) -> Path:
    """Write ``net`` to ``directory/viewpoint.safetensors`` and record it in the directory's manifest."""
    from safetensors.torch import save_file

    from po3d_ppl.model_store import write_entry

    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    tensors = {k: v.detach().cpu().contiguous() for k, v in net.state_dict().items()}
    path = directory / WEIGHTS
    save_file(tensors, str(path), metadata={"format": str(FORMAT), "config": json.dumps(net.config.to_dict())})
    path.chmod(0o644)
    write_entry(MODEL_NAME, [path], directory, **manifest)
    return path


def load_viewpoint_net(directory: Path | str | None = None, device: torch.device | str = "cpu") -> ViewpointNet:
    """The shipped viewpoint network (or the one in ``directory``), sha256-checked; in eval mode on ``device``."""
    from po3d_ppl.model_store import load_tensors

    path, meta, tensors = load_tensors(MODEL_NAME, directory, RETRAIN, str(FORMAT))
    try:
        net = ViewpointNet(ViewpointConfig.from_dict(json.loads(meta["config"])))
        net.load_state_dict(tensors)
    except (OSError, ValueError, KeyError, TypeError, RuntimeError, InputError) as exc:
        raise ModelFileError(f"cannot load the viewpoint network from {path} ({exc}); {RETRAIN}") from None
    return net.to(device).eval()
