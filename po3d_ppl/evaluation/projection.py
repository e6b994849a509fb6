"""Fitting and measuring the projected tables' calibration (:mod:`po3d_ppl.perception.projection_calibration`)
against ground truth, which is read here only.

Entries are those :mod:`po3d_ppl.evaluation.evidence_scores` scores: proposals matched to objects (box IoU >= 0.5),
the true subtype's part slots, ordered pairs of matched objects. Each table gets ``sigmoid(a * logodds + b)``
fitted by maximum likelihood (:func:`~po3d_ppl.evaluation.objects.fit_platt`), and its ECE (15 bins, the event's
probability against its frequency) before and after.
"""

from __future__ import annotations

from collections.abc import Iterable

import numpy as np
import torch

from po3d_ppl import ontology
from po3d_ppl.evaluation.calibration import binned_calibration_error
from po3d_ppl.evaluation.objects import fit_platt, match_boxes
from po3d_ppl.perception.projection_calibration import TABLES, ProjectionCalibration


def table_entries(evidence, scene, min_iou: float = 0.5) -> dict[str, tuple[list[float], list[bool]]]:
    """Per table: the log-odds of the matched entries and whether each event is true in the scene."""
    from po3d_ppl.perception.simulated import part_visible

    out: dict[str, tuple[list[float], list[bool]]] = {name: ([], []) for name in TABLES}

    def add(name: str, value, truth: bool) -> None:
        out[name][0].append(float(value))
        out[name][1].append(bool(truth))

    objs = scene.objects
    boxes = np.array([o.annotation.bbox for o in objs], dtype=np.float64).reshape(-1, 4)
    pairs = match_boxes(evidence.boxes.numpy(), boxes, min_iou)
    proposal_of = {j: i for i, j in pairs}
    for i, j in pairs:
        o = objs[j]
        s = ontology.SUBTYPES.index(o.subtype)
        add("occluded_logodds", evidence.occluded_logodds[i], o.occluded)
        others = [(k, proposal_of[k]) for k in proposal_of if k != j]
        for k, other in others:
            add("occludes_logodds", evidence.occludes_logodds[i, other], k in o.occluded_by)
        for p, raw in enumerate(ontology.PARTS[o.subtype]):
            add("part_visible_logodds", evidence.part_visible_logodds[i, s, p], part_visible(o, raw))
            add("part_occluded_logodds", evidence.part_occluded_logodds[i, s, p], o.part_occluded(raw))
            by = o.part_occluded_by(raw)
            for k, other in others:
                add("part_occludes_logodds", evidence.part_occludes_logodds[i, s, p, other], k in by)
    return out


def collect(pairs: Iterable[tuple[object, object]]) -> dict[str, tuple[torch.Tensor, torch.Tensor]]:
    """Every table's (log-odds, truth) over ``(evidence, scene)`` pairs."""
    values: dict[str, tuple[list[float], list[bool]]] = {name: ([], []) for name in TABLES}
    for evidence, scene in pairs:
        for name, (x, y) in table_entries(evidence, scene).items():
            values[name][0].extend(x)
            values[name][1].extend(y)
    return as_tensors(values)


def as_tensors(values: dict[str, tuple[list[float], list[bool]]]) -> dict[str, tuple[torch.Tensor, torch.Tensor]]:
    """Entries gathered as lists (``collect``, ``EvidenceCounts.entries``) as (float64, bool) tensors."""
    return {name: (torch.tensor(x, dtype=torch.float64), torch.tensor(y, dtype=torch.bool))
            for name, (x, y) in values.items()}


def table_figures(logodds: torch.Tensor, truth: torch.Tensor) -> dict[str, float | int]:
    """ECE, NLL and accuracy (at 0.5) of one table's entries."""
    p = torch.sigmoid(logodds)
    nll = torch.nn.functional.binary_cross_entropy(p.clamp(1e-6, 1 - 1e-6), truth.double())
    return {"entries": int(truth.numel()), "positive_rate": round(float(truth.double().mean()), 4),
            "ece": round(binned_calibration_error(p.tolist(), truth.tolist()), 4), "nll": round(float(nll), 4),
            "accuracy": round(float(((p > 0.5) == truth).double().mean()), 4)}


def fit_projection_calibration(entries: dict[str, tuple[torch.Tensor, torch.Tensor]]
                               ) -> tuple[ProjectionCalibration, dict]:
    """The Platt scaling of every table with both outcomes present, and each table's figures before and after."""
    platt, base_rate, report = {}, {}, {}
    for name, (x, y) in entries.items():
        before = table_figures(x, y) if y.numel() else {"entries": 0}
        if y.numel() == 0 or y.all() or not y.any():
            report[name] = {"before": before, "fitted": None}
            continue
        a, b = fit_platt(x, y, unit=1.0, what=name)
        platt[name] = (a, b)
        base_rate[name] = float(y.double().mean())
        report[name] = {"before": before, "scale": round(a, 4), "bias": round(b, 4),
                        "after": table_figures(x * a + b, y)}
    return ProjectionCalibration(platt, base_rate), report


def measure(calibration: ProjectionCalibration | None, entries: dict[str, tuple[torch.Tensor, torch.Tensor]]
            ) -> dict[str, dict]:
    """Each table's figures as they are and (with ``calibration``) after it, on entries of another split."""
    out = {}
    for name, (x, y) in entries.items():
        if y.numel() == 0:
            continue
        row = {"raw": table_figures(x, y)}
        if calibration is not None and name in calibration.platt:
            a, b = calibration.platt[name]
            row["calibrated"] = table_figures(x * a + b, y)  # the posterior at the fitted base rate
        out[name] = row
    return out
