"""Where objects stand, read from the image: a heatmap of object *base centres* (the ground point under each
object's centre, projected) from the object parser's stride-8 features. Its peaks propose, inside the 3D-NMS
(:func:`~po3d_ppl.perception.object_parser.add_centre_proposals`), the objects render-and-compare misses.

**Why a learned head beside render-and-compare.** The 3D-NMS accepts a hypothesis when it explains enough image
that no accepted proposal explains already. An object behind another shows a fraction of its mesh and shares its
evidence with its occluder, so it loses (recall 0.41 for objects >= 20% occluded on seed 720). A detector trained
on where objects stand (amodal: the target is the base centre whether or not it shows) learns from the features
that a car's rear sticking out behind a bus means a car stands there; the features already encode which part of
which category a pixel shows.

**The network** is five 3x3 convolutions with dilations 1, 2, 4, 8 and 1 (a receptive field of ~250 px, the size of
a near bus) on the frozen unit features plus two coordinate channels (the camera prior ties image row to depth),
and a 1x1 logit per cell. It is trained from scratch (:mod:`~po3d_ppl.perception.train_centres`) with CenterNet's
penalty-reduced focal loss on Gaussian targets, on features of the *shipped* extractor: the extractor's sha256 is
stored with the head and checked when both are loaded (:func:`check_features`), so retraining the features without
the head is an error, not a silent drift.

Code runs on any device (inputs are moved to the module's). Loading goes through :mod:`po3d_ppl.model_store`.
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
from po3d_ppl.perception.features import STRIDE

MODEL_NAME = "centres"
WEIGHTS = "centres.safetensors"
FORMAT = 1
RETRAIN = ("retrain it with `po3d train centres --data /work/data/perc_train_s711 --out models/` (see "
           "docs/perception.md) or restore it with `git checkout models/`")
#: The feature model the head reads (its manifest name).
FEATURES_MODEL = "perception_features"


@dataclass(frozen=True)
class CentreConfig:
    """Architecture (stored with the weights, so a saved model rebuilds itself)."""

    feature_dim: int = 64
    width: int = 64
    dilations: tuple[int, ...] = (1, 2, 4, 8, 1)

    def __post_init__(self) -> None:
        for name in ("feature_dim", "width"):
            v = getattr(self, name)
            if not (isinstance(v, int) and v >= 4):
                raise InputError(f"CentreConfig.{name}", f"must be an integer >= 4, got {v!r}")
        if not self.dilations or not all(isinstance(d, int) and d >= 1 for d in self.dilations):
            raise InputError("CentreConfig.dilations", f"must be integers >= 1, got {self.dilations!r}")

    def to_dict(self) -> dict:
        return asdict(self) | {"dilations": list(self.dilations)}

    @classmethod
    def from_dict(cls, data: dict) -> CentreConfig:
        return cls(int(data["feature_dim"]), int(data["width"]), tuple(int(d) for d in data["dilations"]))


def _conv(cin: int, cout: int, dilation: int) -> nn.Sequential:
    return nn.Sequential(nn.Conv2d(cin, cout, 3, padding=dilation, dilation=dilation, bias=False),
                         nn.BatchNorm2d(cout), nn.ReLU(inplace=True))


class CentreNet(nn.Module):
    """Features ``[B, D, h, w]`` -> base-centre logits ``[B, h, w]`` (one per stride-8 cell)."""

    def __init__(self, config: CentreConfig = CentreConfig()):
        super().__init__()
        self.config = config
        widths = [config.feature_dim + 2] + [config.width] * len(config.dilations)
        self.body = nn.Sequential(*(_conv(a, b, d) for a, b, d in zip(widths, widths[1:], config.dilations)))
        self.logit = nn.Conv2d(config.width, 1, 1)
        nn.init.constant_(self.logit.bias, -4.0)  # cells are almost all empty: start near p = 0.02

    @property
    def device(self) -> torch.device:
        return self.logit.weight.device

    def num_parameters(self) -> int:
        return sum(p.numel() for p in self.parameters())

    def forward(self, features: torch.Tensor) -> torch.Tensor:
        if features.dim() != 4 or features.shape[1] != self.config.feature_dim:
            raise InputError("features", f"expected [B, {self.config.feature_dim}, h, w], got "
                                         f"{tuple(features.shape)}")
        b, _, h, w = features.shape
        rows = torch.linspace(-1, 1, h, device=features.device, dtype=features.dtype).view(1, 1, h, 1)
        cols = torch.linspace(-1, 1, w, device=features.device, dtype=features.dtype).view(1, 1, 1, w)
        x = torch.cat([features, rows.expand(b, 1, h, w), cols.expand(b, 1, h, w)], 1)
        return self.logit(self.body(x))[:, 0]

    @torch.no_grad()
    def heatmap(self, features: torch.Tensor) -> torch.Tensor:
        """Probabilities ``[h, w]`` that an object's base centre falls in each cell, from one image's features
        ``[D, h, w]`` (as :func:`~po3d_ppl.perception.features.extract_features` gives them)."""
        if features.dim() != 3:
            raise InputError("features", f"expected one image's [D, h, w], got {tuple(features.shape)}")
        self.eval()
        return torch.sigmoid(self(features[None].to(self.device, torch.float32)))[0]


@dataclass(frozen=True)
class CentrePeaks:
    """Local maxima of a heatmap above a threshold, most probable first: ``pixels`` [K, 2] (x, y of the cell
    centre, image pixels) and ``probabilities`` [K]."""

    pixels: torch.Tensor
    probabilities: torch.Tensor

    def __len__(self) -> int:
        return int(self.probabilities.shape[0])


def centre_peaks(heatmap: torch.Tensor, threshold: float) -> CentrePeaks:
    """The cells of ``heatmap`` [h, w] that are the maximum of their 3x3 neighbourhood and exceed ``threshold``."""
    if heatmap.dim() != 2:
        raise InputError("heatmap", f"expected [h, w], got {tuple(heatmap.shape)}")
    heat = heatmap.detach().float().cpu()
    top = F.max_pool2d(heat[None, None], 3, 1, 1)[0, 0]
    rows, cols = torch.nonzero((heat == top) & (heat > threshold), as_tuple=True)
    probs = heat[rows, cols]
    order = torch.argsort(probs, descending=True)
    pixels = torch.stack([cols[order], rows[order]], -1).double() * STRIDE + STRIDE / 2
    return CentrePeaks(pixels.reshape(-1, 2), probs[order])


def log_centre_prior(heatmap: torch.Tensor, pixels: torch.Tensor, floor: float = 1e-3) -> torch.Tensor:
    """[M] log of ``heatmap`` [h, w] (bilinear between cell centres, at least ``floor``) at image ``pixels`` [M, 2]:
    the centre head's belief that an object's base centre stands there, a prior on the position of a proposal."""
    heat = heatmap.detach().float().cpu()
    h, w = heat.shape
    cells = (pixels.float() - STRIDE / 2) / STRIDE
    grid = torch.stack([cells[:, 0] / max(w - 1, 1), cells[:, 1] / max(h - 1, 1)], -1) * 2 - 1
    sampled = F.grid_sample(heat[None, None], grid[None, None], align_corners=True, padding_mode="border")
    return sampled.reshape(-1).clamp_min(floor).log()


# --- files -----------------------------------------------------------------------------------------------------------


def save_centre_net(net: CentreNet, directory: Path | str, features_sha256: str, **manifest: Any) -> Path:
    """Write ``net`` to ``directory/centres.safetensors`` with the sha256 of the features it was trained on, and
    record it in the directory's manifest."""
    from safetensors.torch import save_file

    from po3d_ppl.model_store import write_entry

    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    tensors = {k: v.detach().cpu().contiguous() for k, v in net.state_dict().items()}
    path = directory / WEIGHTS
    save_file(tensors, str(path), metadata={"format": str(FORMAT), "config": json.dumps(net.config.to_dict()),
                                            "features_sha256": features_sha256})
    path.chmod(0o644)
    write_entry(MODEL_NAME, [path], directory, features_sha256=features_sha256, **manifest)
    return path


def load_centre_net(directory: Path | str | None = None, device: torch.device | str = "cpu") -> CentreNet:
    """The shipped centre head (or the one in ``directory``), sha256-checked and checked against the feature model
    beside it (:func:`check_features`); in eval mode on ``device``."""
    from po3d_ppl.model_store import load_tensors

    path, meta, tensors = load_tensors(MODEL_NAME, Path(directory) if directory else None, RETRAIN, str(FORMAT))
    try:
        net = CentreNet(CentreConfig.from_dict(json.loads(meta["config"])))
        net.load_state_dict(tensors)
        trained_on = meta["features_sha256"]
    except (OSError, ValueError, KeyError, TypeError, RuntimeError, InputError) as exc:
        raise ModelFileError(f"cannot load the centre head from {path} ({exc}); {RETRAIN}") from None
    check_features(trained_on, Path(directory) if directory else None, path)
    return net.to(device).eval()


def features_sha256(directory: Path | None = None) -> str:
    """The sha256 the manifest records for the feature model's weights (loading them checks the file against it,
    so it is not hashed again here)."""
    from po3d_ppl.model_store import read_manifest

    files = read_manifest(directory).get(FEATURES_MODEL, {}).get("files", {})
    shas = [meta.get("sha256") for name, meta in files.items() if name.endswith(".safetensors")]
    if len(shas) != 1 or not isinstance(shas[0], str):
        raise ModelFileError(f"model {FEATURES_MODEL!r} should have one safetensors file in the manifest, found "
                             f"{len(shas)}; {RETRAIN}")
    return shas[0]


def check_features(trained_on: str, directory: Path | None, path: Path) -> None:
    """A head reads the features it was trained on, or nothing: a retrained extractor moves every feature."""
    now = features_sha256(directory)
    if now != trained_on:
        raise ModelFileError(f"{path} was trained on features {trained_on[:12]}, but the feature model is "
                             f"{now[:12]}; {RETRAIN}")
