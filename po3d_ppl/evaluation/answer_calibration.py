"""Fitting the answer calibration (:mod:`po3d_ppl.reasoning.answer_calibration`) on a validation split's records.

Per answer type, the (temperature, smoothing) pair minimising the NLL of the true answers, by a grid search (one
type has a few hundred questions and the NLL is smooth in both; a grid is deterministic and has no learning rate).
A true answer outside the type's support is counted at the NLL floor of :mod:`po3d_ppl.evaluation.calibration`.
Types with fewer than ``min_questions`` questions are left uncalibrated.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import torch

from po3d_ppl.evaluation.calibration import NLL_FLOOR
from po3d_ppl.evaluation.runner import QuestionRecord, _same
from po3d_ppl.reasoning.answer_calibration import AnswerCalibration, TypeCalibration, answer_support

TEMPERATURES = torch.logspace(math.log10(0.25), math.log10(40.0), 49, dtype=torch.float64)
SMOOTHINGS = torch.tensor([0.0, 0.002, 0.005, 0.01, 0.02, 0.03, 0.05, 0.075, 0.1, 0.125, 0.15, 0.2, 0.25, 0.3,
                           0.35, 0.4, 0.5, 0.6], dtype=torch.float64)


def _tables(records: Sequence[QuestionRecord], variant: str) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    """(log-probabilities [M, K] over each question's support, -inf padded; support sizes [M]; the true answer's
    column [M], -1 when outside the support)."""
    rows, sizes, truths = [], [], []
    for r in records:
        prediction = r.predictions[variant]
        values = answer_support(r.answer_type, [a for a, _ in prediction.probs])
        rows.append([math.log(p) if p > 0 else -math.inf for p in map(prediction.probability, values)])
        sizes.append(len(values))
        truths.append(next((i for i, v in enumerate(values) if _same(v, r.item.truth)), -1))
    logp = torch.full((len(rows), max(sizes)), -math.inf, dtype=torch.float64)
    for i, row in enumerate(rows):
        logp[i, :len(row)] = torch.tensor(row, dtype=torch.float64)
    return logp, torch.tensor(sizes, dtype=torch.float64), torch.tensor(truths)


def nll_grid(logp: torch.Tensor, sizes: torch.Tensor, truths: torch.Tensor) -> torch.Tensor:
    """Mean NLL of the true answers for every (temperature, smoothing) of the grid: [T, S]."""
    inside = truths >= 0
    column = truths.clamp(min=0)
    out = torch.empty(len(TEMPERATURES), len(SMOOTHINGS), dtype=torch.float64)
    for i, t in enumerate(TEMPERATURES):
        tempered = torch.softmax(logp / t, dim=1).gather(1, column[:, None])[:, 0]  # [M]
        p = (1.0 - SMOOTHINGS[None, :]) * tempered[:, None] + SMOOTHINGS[None, :] / sizes[:, None]  # [M, S]
        p = torch.where(inside[:, None], p, torch.zeros_like(p))
        out[i] = -torch.log(p.clamp(min=NLL_FLOOR)).mean(0)
    return out


def fit(records: Sequence[QuestionRecord], variant: str = "ours", min_questions: int = 50
        ) -> tuple[AnswerCalibration, dict[str, dict]]:
    """(the calibration, per answer type: questions, fitted parameters and NLL before and after) from one run."""
    by_type: dict[str, list[QuestionRecord]] = {}
    for r in records:
        if r.predictions[variant].probs:  # nothing to recalibrate when the presuppositions surely fail
            by_type.setdefault(r.answer_type, []).append(r)
    types, report = {}, {}
    for answer_type, members in sorted(by_type.items()):
        if len(members) < min_questions:
            report[answer_type] = {"questions": len(members), "fitted": None}
            continue
        grid = nll_grid(*_tables(members, variant))
        best = int(torch.argmin(grid))
        t, s = divmod(best, len(SMOOTHINGS))
        fitted = TypeCalibration(round(float(TEMPERATURES[t]), 4), float(SMOOTHINGS[s]))
        types[answer_type] = fitted
        identity = grid[int(torch.argmin((TEMPERATURES - 1.0).abs())), 0]
        report[answer_type] = {"questions": len(members), "temperature": fitted.temperature,
                               "smoothing": fitted.smoothing, "nll_before": round(float(identity), 4),
                               "nll_after": round(float(grid[t, s]), 4)}
    return AnswerCalibration(types), report
