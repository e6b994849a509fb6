"""Calibration of the projected tables: one Platt scaling (``a * logodds + b``) per binary table of the evidence.

The projection (:mod:`po3d_ppl.perception.scene_parser`) reads "part p is visible", "object i is occluded by j"
and so on off renderings of its hypotheses and squashes their weighted frequency into log-odds with a fixed floor
(0.05 on each side). Most entries sit at that floor, so the floor *is* the confidence, and one wrong pose or mask
makes many of them wrong together. How often an entry at the floor is right is an empirical question: it is
answered per table on a validation seed (ground truth is read there only, by
:func:`po3d_ppl.evaluation.projection.fit_projection_calibration`), and the scene parser applies the fitted
scaling to every image (``ImageParser.load`` reads ``models/projection_calibration.safetensors`` when shipped).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from pathlib import Path

import torch

from po3d_ppl.errors import InputError, ModelFileError
from po3d_ppl.evidence import SceneEvidence

MODEL_NAME = "projection_calibration"
WEIGHTS = "projection_calibration.safetensors"
RETRAIN = "refit it with `po3d train projection --data VAL` (a validation dataset) or `git checkout models/`"
#: The binary tables of the contract that the projection fills.
TABLES = ("occluded_logodds", "occludes_logodds", "part_visible_logodds", "part_occluded_logodds",
          "part_occludes_logodds")


@dataclass(frozen=True)
class ProjectionCalibration:
    """``(scale, bias)`` per table of ``TABLES``; a table not listed is left as it is."""

    platt: dict[str, tuple[float, float]] = field(default_factory=dict)

    def __post_init__(self) -> None:
        for name, (scale, bias) in self.platt.items():
            if name not in TABLES:
                raise InputError("ProjectionCalibration", f"unknown table {name!r} (known: {', '.join(TABLES)})")
            if not (math.isfinite(scale) and math.isfinite(bias) and scale > 0):
                raise InputError("ProjectionCalibration", f"{name}: scale must be > 0 and both finite, got "
                                                          f"{(scale, bias)}")

    def apply(self, evidence: SceneEvidence) -> SceneEvidence:
        """The evidence with every calibrated table rescaled (``occludes`` keeps its ignored diagonal at 0)."""
        changes = {}
        for name, (scale, bias) in self.platt.items():
            table = getattr(evidence, name)
            scaled = table * scale + bias
            if name == "occludes_logodds" and table.numel():
                scaled = scaled * (1 - torch.eye(table.shape[0], dtype=table.dtype, device=table.device))
            changes[name] = scaled
        return dataclasses.replace(evidence, **changes)

    def save(self, directory: Path) -> Path:
        from safetensors.torch import save_file

        path = Path(directory) / WEIGHTS
        tensors = {name: torch.tensor(list(values), dtype=torch.float64) for name, values in self.platt.items()}
        save_file(tensors, str(path), metadata={"format": "1"})
        path.chmod(0o644)
        return path

    def to_dict(self) -> dict[str, list[float]]:
        return {name: list(values) for name, values in self.platt.items()}


def load_projection_calibration(directory: Path | str | None = None) -> ProjectionCalibration | None:
    """The shipped calibration (checked against the manifest), or None when none is listed."""
    from po3d_ppl.model_store import load_tensors, models_dir, read_manifest

    directory = Path(directory) if directory is not None else models_dir()
    if MODEL_NAME not in read_manifest(directory):
        return None
    path, _, tensors = load_tensors(MODEL_NAME, directory, RETRAIN, "1")
    try:
        return ProjectionCalibration({name: (float(v[0]), float(v[1])) for name, v in tensors.items()})
    except (ValueError, IndexError, TypeError, InputError) as exc:
        raise ModelFileError(f"cannot load the projection calibration from {path} ({exc}); {RETRAIN}") from None
