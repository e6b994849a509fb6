"""Calibration of the object parser's tables: temperatures and an existence scale fitted on a validation split.

Render-and-compare scores are sums over covered cells of vMF log-likelihood ratios, so their scale grows with an
object's size and is far too sharp as a likelihood (a 500-cell object's pose table can put 1e-80 on the second
best azimuth). One number per table rescales it: ``category_loglik / T_category``, ``pose_loglik / T_pose``,
``size_loglik / T_size``, and the existence log-odds ``a * score + b`` (Platt scaling: the proposal is a real object or not). They are fitted by
``po3d train calibration --data VAL`` on a dataset seed that neither trained the features nor tuned the parser,
minimising the NLL of the truth (:mod:`po3d_ppl.evaluation.objects` does the fitting, since it needs ground
truth); the parser reads them from ``models/object_calibration.safetensors`` (checksummed like every model).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, fields
from pathlib import Path

import torch

from po3d_ppl.errors import InputError, ModelFileError

MODEL_NAME = "object_calibration"
WEIGHTS = "object_calibration.safetensors"
RETRAIN = "refit it with `po3d train calibration --data DIR` (a validation dataset)"


@dataclass(frozen=True)
class TableCalibration:
    """Identity by default (raw scores)."""

    category_temperature: float = 1.0
    pose_temperature: float = 1.0
    existence_scale: float = 1.0
    existence_bias: float = 0.0
    #: The size table (large vs small) is a log-sum-exp of raw scores too: hundreds of nats apart, so unscaled it
    #: overrode the attribute network's reading (seed 712, 603 matched objects: size from the raw table 0.940,
    #: from the attribute network 0.988, their raw sum 0.944; aeroplanes' category mesh misjudges size most).
    size_temperature: float = 1.0

    def __post_init__(self) -> None:
        for f in fields(self):
            value = float(getattr(self, f.name))
            if not math.isfinite(value):
                raise InputError(f"TableCalibration.{f.name}", f"must be finite, got {value}")
        if min(self.category_temperature, self.pose_temperature, self.size_temperature, self.existence_scale) <= 0:
            raise InputError("TableCalibration", "temperatures and the existence scale must be > 0")

    def save(self, directory: Path) -> Path:
        from safetensors.torch import save_file

        path = Path(directory) / WEIGHTS
        save_file({f.name: torch.tensor([float(getattr(self, f.name))], dtype=torch.float64) for f in fields(self)},
                  str(path), metadata={"format": "1"})
        return path

    def to_dict(self) -> dict[str, float]:
        return {k: float(v) for k, v in asdict(self).items()}


def fit_temperature(logits: torch.Tensor, labels: torch.Tensor, low: float = 0.25, high: float = 1000.0,
                    steps: int = 201, offset: torch.Tensor | None = None) -> float:
    """The temperature in [low, high] (log-spaced grid, then a finer grid around the best) that minimises the NLL
    of ``softmax(logits / T + offset)`` (labels -1 are skipped; 1.0 when none is left). ``offset``: log-prior
    terms added after the temperature (a likelihood table scaled under the prior it will be multiplied by).

    A grid rather than gradient descent: one scalar, deterministic, no learning rate to tune, and NLL(T) is
    unimodal in log T in practice. The floor ``low`` matters when the validation split has no error at all: the
    NLL then keeps falling as T -> 0, and a near-zero temperature would turn any later mistake into an impossible
    event for the reasoning engine."""
    import torch.nn.functional as F

    keep = labels >= 0
    logits, labels = logits[keep].double(), labels[keep]
    if labels.numel() == 0:
        return 1.0

    shift = torch.zeros((), dtype=torch.float64) if offset is None else offset.double()

    def best(grid: torch.Tensor) -> float:
        nll = torch.stack([F.cross_entropy(logits / t + shift, labels) for t in grid])
        return float(grid[int(torch.argmin(nll))])

    coarse = best(torch.logspace(math.log10(low), math.log10(high), steps, dtype=torch.float64))
    ratio = (high / low) ** (1.0 / (steps - 1))
    return best(torch.logspace(math.log10(coarse / ratio), math.log10(coarse * ratio), 41, dtype=torch.float64))


def top_label_ece(logp: torch.Tensor, labels: torch.Tensor, bins: int = 15) -> float:
    """ECE of the top-1 prediction of log-probabilities ``logp`` [M, K] (labels -1 skipped): torchmetrics' binned
    calibration error on (top probability, correct), the probability clamped below 1 (torchmetrics issue #3510,
    see :mod:`po3d_ppl.evaluation.calibration`)."""
    from torchmetrics.functional.classification import binary_calibration_error

    keep = labels >= 0
    if not keep.any():
        return float("nan")
    confidence, guess = logp[keep].exp().max(-1)
    correct = (guess == labels[keep]).long()
    return float(binary_calibration_error(confidence.double().clamp(0.0, 1.0 - 1e-6).cpu(), correct.cpu(),
                                          n_bins=bins, norm="l1"))


def load_calibration(directory: Path | str | None = None, *, required: bool = False) -> TableCalibration:
    """The shipped calibration (checked against the manifest); the identity when none is shipped, unless
    ``required``."""
    from po3d_ppl.model_store import load_tensors, models_dir, read_manifest

    directory = Path(directory) if directory is not None else models_dir()
    if MODEL_NAME not in read_manifest(directory) and not required:
        return TableCalibration()
    path, _, tensors = load_tensors(MODEL_NAME, directory, RETRAIN, "1")
    try:
        return TableCalibration(**{f.name: float(tensors[f.name][0]) for f in fields(TableCalibration)})
    except (ValueError, KeyError, TypeError, InputError) as exc:
        raise ModelFileError(f"cannot load the table calibration from {path} ({exc}); {RETRAIN}") from None
