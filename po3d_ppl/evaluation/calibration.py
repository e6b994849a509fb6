"""Calibration of answer confidence: ECE (15 bins), MCE, Brier, NLL and reliability bins, per method.

Library: ``torchmetrics`` (``binary_calibration_error``, norms ``l1`` and ``max``). It is maintained, already
torch-based like the rest of the package (no second array stack, and its wheel pulls no CUDA build when torch is
installed), and its binned ECE is the standard definition (uniform bins on [0, 1], weighted by count). Its one
known flaw, issue #3510: ``torch.bucketize(..., right=True)`` puts a confidence of exactly 1.0 into a 16th bin of
its own instead of the last of the 15, so the binning depends on whether an answer is certain (0.99 right, 0.999
right and 1.0 wrong: 0.337 instead of the standard 0.330, and the reliability diagram would need a 16th bar).
Certain answers are common here (the oracle, the thresholded baseline, certain evidence), so confidences are
clamped to ``1 - 1e-6`` first, which puts them in the last bin, as the standard definition does. ``netcal`` pulls in its own plotting stack and
``relplot`` estimates smooth ECE (not the paper-style binned numbers); we keep one dependency.

Two views, for every method:

- **top answer**: confidence = the mass of the predicted outcome (the invalid outcome included: a method may
  answer "the question's presuppositions fail"), accuracy = whether it is the true answer;
- **full distribution (classwise)**: for every answer value k of the split, over the questions whose answer
  type can be k, the predicted P(k) against [truth == k]; the ECE of each class with at least one positive,
  averaged over classes (Kull et al. 2019, unweighted).

Brier (top): mean (confidence - correct)^2; Brier (full): mean over questions of sum_k (p_k - [truth = k])^2 with
the invalid mass as one more outcome. NLL: mean -log P(truth), with P floored at 1e-6 (a certain wrong answer
costs 13.8 nats instead of infinity; the floor is printed with the numbers).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import torch

from po3d_ppl.evaluation.runner import EvalRun, QuestionRecord, _same

N_BINS = 15
#: torchmetrics issue #3510: a confidence of exactly 1.0 falls outside the last bin.
CLAMP = 1.0 - 1e-6
NLL_FLOOR = 1e-6


def _tensor(values: Sequence[float]) -> torch.Tensor:
    return torch.tensor(list(values), dtype=torch.float64)


def binned_calibration_error(confidences: Sequence[float], correct: Sequence[bool], norm: str = "l1",
                             n_bins: int = N_BINS) -> float:
    """torchmetrics' binned calibration error (``l1`` = ECE, ``max`` = MCE) with the 1.0 clamp."""
    from torchmetrics.functional.classification import binary_calibration_error

    if len(confidences) == 0:
        return float("nan")
    preds = _tensor(confidences).clamp(0.0, CLAMP)
    target = torch.tensor([int(bool(c)) for c in correct])
    return float(binary_calibration_error(preds, target, n_bins=n_bins, norm=norm))


@dataclass(frozen=True)
class ReliabilityBin:
    lower: float
    upper: float
    count: int
    confidence: float | None
    accuracy: float | None


def reliability_bins(confidences: Sequence[float], correct: Sequence[bool], n_bins: int = N_BINS
                     ) -> list[ReliabilityBin]:
    """Uniform bins (the last one closed) for reliability diagrams; the same binning as the ECE above."""
    bins: list[list[tuple[float, bool]]] = [[] for _ in range(n_bins)]
    for c, ok in zip(confidences, correct, strict=True):
        bins[min(int(min(max(c, 0.0), CLAMP) * n_bins), n_bins - 1)].append((c, ok))
    out = []
    for i, members in enumerate(bins):
        n = len(members)
        out.append(ReliabilityBin(i / n_bins, (i + 1) / n_bins, n,
                                  sum(c for c, _ in members) / n if n else None,
                                  sum(ok for _, ok in members) / n if n else None))
    return out


@dataclass
class CalibrationReport:
    """Calibration of one method (variant) on a run."""

    method: str
    n: int
    accuracy: float
    mean_confidence: float
    ece: float
    mce: float
    brier_top: float
    brier_full: float
    nll: float
    classwise_ece: float
    classes: int
    bins: list[ReliabilityBin] = field(default_factory=list)

    def row(self) -> dict:
        return {k: v for k, v in self.__dict__.items() if k != "bins"}


def top_answers(records: Sequence[QuestionRecord], variant: str) -> tuple[list[float], list[bool]]:
    return ([r.predictions[variant].confidence for r in records], [r.correct(variant) for r in records])


def _brier_full(record: QuestionRecord, variant: str) -> float:
    p = record.predictions[variant]
    truth_p = p.probability(record.item.truth)
    others = sum(q * q for a, q in p.probs if not _same(a, record.item.truth))
    return (1.0 - truth_p) ** 2 + others + p.invalid ** 2


def classwise_ece(records: Sequence[QuestionRecord], variant: str, n_bins: int = N_BINS) -> tuple[float, int]:
    """(mean ECE over answer classes, number of classes); see the module docstring."""
    classes: dict[tuple[str, str, object], list[QuestionRecord]] = {}
    values_by_type: dict[str, set] = {}
    for r in records:
        values_by_type.setdefault(r.answer_type, set()).add((type(r.item.truth).__name__, r.item.truth))
    for r in records:
        for kind, value in values_by_type[r.answer_type]:
            classes.setdefault((r.answer_type, kind, value), []).append(r)
    eces = []
    for (_, _, value), members in classes.items():
        probs = [m.predictions[variant].probability(value) for m in members]
        hits = [_same(m.item.truth, value) for m in members]
        if any(hits):
            eces.append(binned_calibration_error(probs, hits, "l1", n_bins))
    return (sum(eces) / len(eces) if eces else float("nan")), len(eces)


def calibration_report(records: Sequence[QuestionRecord], variant: str, n_bins: int = N_BINS) -> CalibrationReport:
    conf, correct = top_answers(records, variant)
    n = len(records)
    nll = sum(-math.log(max(r.predictions[variant].probability(r.item.truth), NLL_FLOOR)) for r in records) / n
    cw, classes = classwise_ece(records, variant, n_bins)
    return CalibrationReport(
        variant, n, sum(correct) / n, sum(conf) / n,
        binned_calibration_error(conf, correct, "l1", n_bins), binned_calibration_error(conf, correct, "max", n_bins),
        sum((c - ok) ** 2 for c, ok in zip(conf, correct, strict=True)) / n,
        sum(_brier_full(r, variant) for r in records) / n, nll, cw, classes, reliability_bins(conf, correct, n_bins))


def calibration_reports(run: EvalRun, n_bins: int = N_BINS) -> list[CalibrationReport]:
    return [calibration_report(run.records, v, n_bins) for v in run.variants]


def calibration_markdown(reports: Sequence[CalibrationReport]) -> str:
    lines = ["| method | n | accuracy | mean confidence | ECE | MCE | Brier (top) | Brier (full) | NLL | "
             "classwise ECE (classes) |", "|" + "---|" * 10]
    for r in reports:
        lines.append(f"| {r.method} | {r.n} | {r.accuracy:.4f} | {r.mean_confidence:.4f} | {r.ece:.4f} | "
                     f"{r.mce:.4f} | {r.brier_top:.4f} | {r.brier_full:.4f} | {r.nll:.3f} | "
                     f"{r.classwise_ece:.4f} ({r.classes}) |")
    return "\n".join(lines)


@dataclass(frozen=True)
class SweepPoint:
    noise: float
    method: str
    accuracy: float
    ece: float
    n: int
