"""Fitting the answer calibration (:mod:`po3d_ppl.reasoning.answer_calibration`) on a validation split's records.

Per answer type, the (temperature, smoothing) pair minimising the NLL of the true answers, by a grid search (one
type has a few hundred questions and the NLL is smooth in both; a grid is deterministic and has no learning rate).
A true answer outside the type's support is counted at the NLL floor of :mod:`po3d_ppl.evaluation.calibration`.
Types with fewer than ``min_questions`` questions are left uncalibrated. ``objective="brier"`` minimises the
full distribution's Brier score instead, which a truth with no mass costs at most 2 rather than the floor's NLL
(a leave-one-seed-out comparison: ``benchmarks/answer_calibration_crossfit.py``).

Then, with ``top_answer`` (the default), the :class:`~po3d_ppl.reasoning.answer_calibration.TopAnswerMap` is
fitted on the same questions as the types recalibrate them: scikit-learn's isotonic regression of "the top
outcome is right" on its probability, every type pooled. On the four validation seeds, each held out in turn, it
lowered ours' ECE from 0.0205 to 0.0179 on average (soft's from 0.0201 to 0.0174); maps fitted per type followed
each seed's noise and raised it (docs/evaluation.md).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence

import torch

from po3d_ppl.errors import InputError
from po3d_ppl.evaluation.calibration import NLL_FLOOR, top_answers
from po3d_ppl.evaluation.runner import QuestionRecord, _same, recalibrated
from po3d_ppl.reasoning.answer_calibration import AnswerCalibration, TopAnswerMap, TypeCalibration, answer_support

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


def brier_grid(logp: torch.Tensor, sizes: torch.Tensor, truths: torch.Tensor) -> torch.Tensor:
    """Mean Brier score of the full distribution over each question's support for every (temperature, smoothing)
    of the grid: [T, S]. ``sum_k (p_k - y_k)^2 = sum_k p_k^2 - 2 p_true + 1``, and with ``p = (1 - s) q + s / n``
    over the ``n`` answers of the support, ``sum_k p_k^2 = (1 - s)^2 sum_k q_k^2 + (2 (1 - s) s + s^2) / n``."""
    inside = (truths >= 0).double()[:, None]  # a truth outside the support has p_true = 0
    column = truths.clamp(min=0)[:, None]
    s, n = SMOOTHINGS[None, :], sizes[:, None]
    out = torch.empty(len(TEMPERATURES), len(SMOOTHINGS), dtype=torch.float64)
    for i, t in enumerate(TEMPERATURES):
        q = torch.softmax(logp / t, dim=1)
        squares = (q * q).sum(1, keepdim=True)
        p_true = ((1.0 - s) * q.gather(1, column) + s / n) * inside
        out[i] = ((1.0 - s) ** 2 * squares + (2.0 * (1.0 - s) * s + s * s) / n - 2.0 * p_true + 1.0).mean(0)
    return out


#: The proper scoring rules a calibration can be fitted by (each a function of the grid: [T, S]).
OBJECTIVES = {"nll": nll_grid, "brier": brier_grid}


def check_objective(objective: str, option: str = "objective") -> str:
    """``objective`` if it names one of :data:`OBJECTIVES`, else a typed error listing them."""
    if objective not in OBJECTIVES:
        raise InputError(option, f"unknown {objective!r}; choose from {', '.join(OBJECTIVES)}")
    return objective


#: The fewest questions (all types together) a top-answer map is fitted on; with fewer it is left out.
MIN_TOP_ANSWER_QUESTIONS = 200


def fit_top_answer(records: Sequence[QuestionRecord], variant: str = "ours") -> TopAnswerMap | None:
    """The isotonic map of the top outcome's probability (the top answer's, or the invalid mass where that is
    larger) to its being right, over the questions of ``records`` that ``variant`` gives answers; None with fewer
    than :data:`MIN_TOP_ANSWER_QUESTIONS` of them."""
    from sklearn.isotonic import IsotonicRegression

    confidence, right = top_answers([r for r in records if r.predictions[variant].probs], variant)
    if len(confidence) < MIN_TOP_ANSWER_QUESTIONS:
        return None
    isotonic = IsotonicRegression(y_min=0.0, y_max=1.0, increasing=True, out_of_bounds="clip")
    isotonic.fit(confidence, [float(r) for r in right])
    return TopAnswerMap(tuple(map(float, isotonic.X_thresholds_)), tuple(map(float, isotonic.y_thresholds_)))


def fit(records: Sequence[QuestionRecord], variant: str = "ours", min_questions: int = 50, objective: str = "nll",
        top_answer: bool = True) -> tuple[AnswerCalibration, dict[str, dict]]:
    """(the calibration, per answer type: questions, fitted parameters and NLL before and after) from one run;
    ``objective`` names the proper scoring rule minimised (:data:`OBJECTIVES`); ``top_answer`` adds the
    :func:`fit_top_answer` map, fitted on the answers as the types recalibrate them (its knots under the
    report's ``top_answer`` key)."""
    check_objective(objective)
    by_type: dict[str, list[QuestionRecord]] = {}
    for r in records:
        if r.predictions[variant].probs:  # nothing to recalibrate when the presuppositions surely fail
            by_type.setdefault(r.answer_type, []).append(r)
    types, report = {}, {}
    for answer_type, members in sorted(by_type.items()):
        if len(members) < min_questions:
            report[answer_type] = {"questions": len(members), "fitted": None}
            continue
        tables = _tables(members, variant)
        grid = nll_grid(*tables)  # reported whatever the objective
        best = int(torch.argmin(grid if objective == "nll" else OBJECTIVES[objective](*tables)))
        t, s = divmod(best, len(SMOOTHINGS))
        fitted = TypeCalibration(round(float(TEMPERATURES[t]), 4), float(SMOOTHINGS[s]))
        types[answer_type] = fitted
        identity = grid[int(torch.argmin((TEMPERATURES - 1.0).abs())), 0]
        report[answer_type] = {"questions": len(members), "temperature": fitted.temperature,
                               "smoothing": fitted.smoothing, "nll_before": round(float(identity), 4),
                               "nll_after": round(float(grid[t, s]), 4)}
    calibration = AnswerCalibration(types)
    if top_answer:
        typed = [dataclasses.replace(r, predictions={variant: recalibrated(r, calibration, variant)}) for r in records]
        top = fit_top_answer(typed, variant)
        report["top_answer"] = {"questions": len(typed), "knots": 0 if top is None else len(top.confidence)}
        calibration = AnswerCalibration(types, top)
    return calibration, report
