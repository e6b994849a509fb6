"""Calibration of the object parser's tables: temperatures and an existence scale fitted on a validation split.

Render-and-compare scores are sums over covered cells of vMF log-likelihood ratios, so their scale grows with an
object's size and is far too sharp as a likelihood (a 500-cell object's pose table can put 1e-80 on the second
best azimuth). One number per table rescales it: ``category_loglik / T_category``, ``pose_loglik / T_pose``, and
the existence log-odds ``a * score + b`` (Platt scaling: the proposal is a real object or not). They are fitted by
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

    def __post_init__(self) -> None:
        for f in fields(self):
            value = float(getattr(self, f.name))
            if not math.isfinite(value):
                raise InputError(f"TableCalibration.{f.name}", f"must be finite, got {value}")
        if self.category_temperature <= 0 or self.pose_temperature <= 0 or self.existence_scale <= 0:
            raise InputError("TableCalibration", "temperatures and the existence scale must be > 0")

    def save(self, directory: Path) -> Path:
        from safetensors.torch import save_file

        path = Path(directory) / WEIGHTS
        save_file({f.name: torch.tensor([float(getattr(self, f.name))], dtype=torch.float64) for f in fields(self)},
                  str(path), metadata={"format": "1"})
        return path

    def to_dict(self) -> dict[str, float]:
        return {k: float(v) for k, v in asdict(self).items()}


def load_calibration(directory: Path | str | None = None, *, required: bool = False) -> TableCalibration:
    """The shipped calibration (checked against the manifest); the identity when none is shipped, unless
    ``required``."""
    from safetensors import safe_open

    from po3d_ppl.model_store import model_files, models_dir, read_manifest

    directory = Path(directory) if directory is not None else models_dir()
    if MODEL_NAME not in read_manifest(directory) and not required:
        return TableCalibration()
    path = model_files(MODEL_NAME, directory, RETRAIN)[WEIGHTS]
    try:
        with safe_open(str(path), framework="pt") as f:
            values = {k: float(f.get_tensor(k)[0]) for k in f.keys()}  # noqa: SIM118 (safe_open is no dict)
        return TableCalibration(**{f.name: values[f.name] for f in fields(TableCalibration)})
    except (OSError, ValueError, KeyError, TypeError, RuntimeError, InputError) as exc:
        raise ModelFileError(f"cannot load the table calibration from {path} ({exc}); {RETRAIN}") from None
