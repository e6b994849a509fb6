"""Training and measuring the centre head (:mod:`~po3d_ppl.perception.centres`).

The targets come from the scene files (training only): each object's base centre (its 3D centre dropped to the
ground, projected with the scene's camera) is the peak of a Gaussian whose width follows the object's visible box
(CenterNet's targets; sigma 0.12 of the box's geometric mean side, 0.7 to 2.5 cells). Objects with fewer than
``min_pixels`` visible pixels are no positives, and the cells around them are left out of the loss: the image
barely shows them, and calling their cells empty would teach the head to miss occluded objects. The loss is
CenterNet's penalty-reduced focal loss. The features of the shipped extractor are computed once per dataset and
cached as safetensors under ``<data>/../centre_features/`` (keyed by the scenes file and the extractor's sha256).
"""

from __future__ import annotations

import hashlib
import json
import math
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np
import torch

from po3d_ppl.errors import InputError
from po3d_ppl.model_store import sha256_file
from po3d_ppl.perception.centres import CentreConfig, CentreNet, centre_peaks, features_sha256
from po3d_ppl.perception.features import STRIDE

CACHE_FORMAT = 1
#: Object columns of :class:`CentreData`: image row, base-centre x and y (pixels), visible pixels, occluded flag,
#: visible box width and height, and the object's index in its scene.
OBJECT_COLUMNS = ("image", "base_x", "base_y", "visible_pixels", "occluded", "box_width", "box_height", "object")


@dataclass
class CentreData:
    """Cached features ``[I, D, h, w]`` (float16) of a dataset's images and one row per object
    (``OBJECT_COLUMNS``), with the images' dataset indices."""

    features: torch.Tensor
    objects: torch.Tensor
    indices: torch.Tensor

    def __len__(self) -> int:
        return int(self.features.shape[0])

    @classmethod
    def concat(cls, items: Sequence[CentreData]) -> CentreData:
        offsets = np.cumsum([0] + [len(d) for d in items[:-1]])
        objects = [d.objects.clone() for d in items]
        for o, off in zip(objects, offsets):
            o[:, 0] += float(off)
        return cls(torch.cat([d.features for d in items]), torch.cat(objects), torch.cat([d.indices for d in items]))


def _cache_path(root: Path, indices: Sequence[int], sha: str) -> Path:
    scenes = sha256_file(root / "scenes.json")
    key = hashlib.sha256(json.dumps([CACHE_FORMAT, scenes, sha, list(indices)]).encode()).hexdigest()
    return root.resolve().parent / "centre_features" / f"{root.resolve().name}-{key[:16]}.safetensors"


def load_centre_data(data: Path | str, splits: Sequence[str], *, model_dir: Path | str | None = None,
                     use_cache: bool = True, progress: Callable[[int, int], None] | None = None) -> CentreData:
    """Features and base centres of the ``splits`` of a dataset directory, from the cache or computed now, with
    the feature model of ``model_dir`` (default: the shipped one)."""
    from safetensors.torch import load_file, save_file

    from po3d_ppl.perception.features import extract_features
    from po3d_ppl.perception.image_input import load_image, project_points
    from po3d_ppl.perception.neural_mesh import load_feature_model
    from po3d_ppl.perception.train_attributes import split_indices
    from po3d_ppl.world.scene_io import load_scenes

    root = Path(data)
    if not (root / "scenes.json").is_file():
        raise InputError("data", f"{root} has no scenes.json; build one with `po3d dataset build --out {root}`")
    indices = split_indices(root, splits)
    model_dir = Path(model_dir) if model_dir is not None else None
    sha = features_sha256(model_dir)
    path = _cache_path(root, indices, sha)
    if use_cache and path.exists():
        tensors = load_file(str(path))
        if progress is not None:
            progress(len(indices), len(indices))
        return CentreData(tensors["features"], tensors["objects"], tensors["indices"])
    model = load_feature_model(model_dir)
    scenes = load_scenes(root / "scenes.json")
    features, rows = [], []
    for n, i in enumerate(indices):
        scene = scenes[i]
        image = load_image(root / "images" / scene.image_filename)
        features.append(extract_features(model.extractor, image.pixels).to(torch.float16).cpu())
        for k, obj in enumerate(scene.objects):
            base = project_points(scene.camera, np.array([obj.position[0], obj.position[1], 0.0]))
            _, _, width, height = obj.annotation.bbox
            rows.append([n, float(base[0]), float(base[1]), obj.annotation.visible_pixels, float(obj.occluded),
                         width, height, k])
        if progress is not None:
            progress(n + 1, len(indices))
    empty = torch.zeros(0, model.extractor.config.dim, 1, 1, dtype=torch.float16)
    out = CentreData(torch.stack(features) if features else empty,
                     torch.tensor(rows, dtype=torch.float32).reshape(-1, len(OBJECT_COLUMNS)),
                     torch.tensor(indices, dtype=torch.long))
    if use_cache:
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = path.with_suffix(".tmp")
        save_file({"features": out.features.contiguous(), "objects": out.objects, "indices": out.indices}, str(tmp),
                  metadata={"data": str(root.resolve()), "splits": ",".join(splits), "features_sha256": sha})
        tmp.replace(path)
    return out


def centre_targets(objects: torch.Tensor, images: int, size: tuple[int, int], min_pixels: int
                   ) -> tuple[torch.Tensor, torch.Tensor]:
    """Gaussian targets ``[images, h, w]`` (exactly 1 at each positive's own cell) and loss weights (0 around
    objects with fewer than ``min_pixels`` visible pixels) from ``objects`` rows (``OBJECT_COLUMNS``)."""
    h, w = size
    target = torch.zeros(images, h, w)
    weight = torch.ones(images, h, w)
    rows, cols = torch.meshgrid(torch.arange(h, dtype=torch.float32), torch.arange(w, dtype=torch.float32),
                                indexing="ij")
    for image, base_x, base_y, visible, _, box_w, box_h, _ in objects.tolist():
        i = int(image)
        cx, cy = base_x / STRIDE - 0.5, base_y / STRIDE - 0.5
        sigma = min(max(0.12 * math.sqrt(max(box_w * box_h, 1.0)) / STRIDE, 0.7), 2.5)
        gauss = torch.exp(-((cols - cx) ** 2 + (rows - cy) ** 2) / (2 * sigma * sigma))
        if visible < min_pixels:
            weight[i][gauss > 0.1] = 0.0
            continue
        col, row = int(round(cx)), int(round(cy))
        if 0 <= col < w and 0 <= row < h:
            gauss[row, col] = 1.0
        target[i] = torch.maximum(target[i], gauss)
    return target, weight


def focal_loss(logits: torch.Tensor, target: torch.Tensor, weight: torch.Tensor) -> torch.Tensor:
    """CenterNet's penalty-reduced focal loss (alpha 2, beta 4), normalised by the number of positives."""
    p = torch.sigmoid(logits).clamp(1e-4, 1 - 1e-4)
    positive = target >= 1.0
    pos = -((1 - p) ** 2 * torch.log(p))[positive].sum()
    neg = -(weight * (1 - target) ** 4 * p ** 2 * torch.log(1 - p))[~positive].sum()
    return (pos + neg) / positive.sum().clamp(min=1)


@dataclass(frozen=True)
class CentreTrainConfig:
    seed: int = 0
    epochs: int = 12
    batch_size: int = 16
    lr: float = 0.002
    weight_decay: float = 1e-4
    #: Objects with fewer visible pixels are no positives (and their cells no negatives).
    min_pixels: int = 50
    max_steps: int | None = None
    net: CentreConfig = CentreConfig()

    def __post_init__(self) -> None:
        if self.epochs < 1 or self.batch_size < 1 or self.lr <= 0 or self.min_pixels < 0:
            raise InputError("CentreTrainConfig", "epochs and batch_size must be >= 1, lr > 0, min_pixels >= 0")

    def to_dict(self) -> dict:
        return asdict(self) | {"net": self.net.to_dict()}


@dataclass
class TrainedCentres:
    net: CentreNet
    history: list[dict]
    seconds: float
    steps: int


def train_centres(data: CentreData, config: CentreTrainConfig = CentreTrainConfig(), *,
                  device: torch.device | str = "cpu", progress: Callable[[int, int, dict], None] | None = None
                  ) -> TrainedCentres:
    """Train a :class:`CentreNet` from scratch on ``data`` (seeded: the same seed, data and threads give the same
    weights)."""
    from po3d_ppl.perception.train_attributes import train_one_cycle

    if len(data) == 0:
        raise InputError("data", "no training images")
    if data.features.shape[1] != config.net.feature_dim:
        raise InputError("config.net.feature_dim", f"is {config.net.feature_dim}, the features have "
                                                   f"{data.features.shape[1]} channels")
    torch.manual_seed(config.seed)
    generator = torch.Generator().manual_seed(config.seed)
    net = CentreNet(config.net).to(device)
    target, weight = centre_targets(data.objects, len(data), tuple(data.features.shape[-2:]), config.min_pixels)
    steps_per_epoch = math.ceil(len(data) / config.batch_size)

    def epoch() -> Callable[[int], dict[str, torch.Tensor]]:
        order = torch.randperm(len(data), generator=generator)

        def losses(k: int) -> dict[str, torch.Tensor]:
            rows = order[k * config.batch_size:(k + 1) * config.batch_size]
            logits = net(data.features[rows].to(device, torch.float32))
            return {"focal": focal_loss(logits, target[rows].to(device), weight[rows].to(device))}
        return losses

    run = train_one_cycle(net, config, steps_per_epoch, epoch, progress)
    return TrainedCentres(net.cpu(), run.history, run.seconds, run.steps)


@torch.no_grad()
def heatmaps(net: CentreNet, data: CentreData, chunk: int = 32) -> torch.Tensor:
    """Probabilities ``[I, h, w]`` of every image of ``data``."""
    net.eval()
    out = [torch.sigmoid(net(data.features[k:k + chunk].to(net.device, torch.float32))).cpu()
           for k in range(0, len(data), chunk)]
    return torch.cat(out) if out else torch.zeros(0, *data.features.shape[-2:])


def measure(net: CentreNet, data: CentreData, thresholds: Sequence[float] = (0.2, 0.3, 0.5),
            min_pixels: int = 200) -> dict[str, Any]:
    """Per threshold: recall of objects with >= ``min_pixels`` visible pixels (a peak within max(2 cells, 0.15 of
    the box's mean side) of the base centre), the same for occluded objects, and peaks near no object per image."""
    heat = heatmaps(net, data)
    out: dict[str, Any] = {"images": len(data), "objects": int((data.objects[:, 3] >= min_pixels).sum()),
                           "occluded_objects": int(((data.objects[:, 3] >= min_pixels)
                                                    & (data.objects[:, 4] > 0)).sum())}
    for threshold in thresholds:
        peaks = [centre_peaks(h, threshold) for h in heat]
        explained = [torch.zeros(len(p), dtype=torch.bool) for p in peaks]
        hits = {"all": [0, 0], "occluded": [0, 0]}
        for image, base_x, base_y, visible, occluded, box_w, box_h, _ in data.objects.tolist():
            p = peaks[int(image)]
            radius = max(2.0 * STRIDE, 0.15 * math.sqrt(max(box_w * box_h, 1.0)))
            near = torch.hypot(p.pixels[:, 0] - base_x, p.pixels[:, 1] - base_y) <= radius if len(p) else \
                torch.zeros(0, dtype=torch.bool)
            explained[int(image)] |= near
            if visible < min_pixels:
                continue
            for key in ("all",) + (("occluded",) if occluded else ()):
                hits[key][0] += int(bool(near.any()))
                hits[key][1] += 1
        stray = sum(int((~e).sum()) for e in explained)
        out[f"threshold_{threshold}"] = {
            "recall": hits["all"][0] / max(hits["all"][1], 1),
            "recall_occluded": hits["occluded"][0] / max(hits["occluded"][1], 1),
            "peaks_per_image": sum(len(p) for p in peaks) / max(len(data), 1),
            "stray_peaks_per_image": stray / max(len(data), 1)}
    return out
