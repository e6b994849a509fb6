"""Paired bootstrap differences (po3d_ppl.evaluation.significance) on synthetic records with known gaps."""

from __future__ import annotations

import random

import pytest

from po3d_ppl.errors import InputError
from po3d_ppl.evaluation.calibration import calibration_report
from po3d_ppl.evaluation.runner import Prediction, QuestionItem, QuestionRecord
from po3d_ppl.evaluation.significance import differences_markdown, paired_differences


def _records(images: int, per_image: int, accuracy: dict[str, float], confidence: dict[str, float],
             seed: int = 0) -> list[QuestionRecord]:
    """Yes/no questions; each method answers right with its ``accuracy`` at its stated ``confidence``."""
    rng = random.Random(seed)
    out = []
    for image in range(images):
        for q in range(per_image):
            item = QuestionItem("core", "t:0", image, q, "?", (), True, None)
            predictions = {}
            for method, acc in accuracy.items():
                answer = rng.random() < acc
                c = confidence[method]
                predictions[method] = Prediction(((answer, c), (not answer, 1.0 - c)), 0.0)
            out.append(QuestionRecord(item, "bool", predictions))
    return out


def test_a_large_gap_is_resolved_and_the_point_figures_are_the_reports():
    records = _records(120, 10, {"ours": 0.9, "base": 0.6}, {"ours": 0.9, "base": 0.9})
    acc, ece = paired_differences(records, "ours", ["base"], resamples=300)
    ours, base = calibration_report(records, "ours"), calibration_report(records, "base")
    assert acc.value == pytest.approx(ours.accuracy - base.accuracy)
    assert ece.value == pytest.approx(ours.ece - base.ece)
    assert acc.low <= acc.value <= acc.high and ece.low <= ece.value <= ece.high
    assert acc.better is True and ece.better is True  # base is 0.9 confident and 0.6 right: far worse ECE
    assert "better" in differences_markdown([acc, ece])


def test_no_gap_is_not_resolved_and_the_interval_narrows_with_more_images():
    same = {"ours": 0.8, "base": 0.8}
    conf = {"ours": 0.8, "base": 0.8}
    small = paired_differences(_records(30, 10, same, conf, seed=1), "ours", ["base"], resamples=300)
    large = paired_differences(_records(600, 10, same, conf, seed=1), "ours", ["base"], resamples=300)
    assert small[0].better is None and large[1].better is None
    assert large[0].high - large[0].low < small[0].high - small[0].low


def test_images_not_questions_are_resampled():
    """Questions of an image answered alike (all right or all wrong) vary together: resampling images must give a
    wider interval than the same answers spread one per image."""
    clustered, spread = [], []
    rng = random.Random(3)
    for image in range(60):
        right = rng.random() < 0.7
        for q in range(10):
            item = QuestionItem("core", "t:0", image, q, "?", (), True, None)
            clustered.append(QuestionRecord(item, "bool", {"ours": Prediction(((right, 0.7),), 0.3),
                                                           "base": Prediction(((True, 0.7),), 0.3)}))
            lone = QuestionItem("core", "t:0", image * 10 + q, 0, "?", (), True, None)
            spread.append(QuestionRecord(lone, "bool", clustered[-1].predictions))
    wide = paired_differences(clustered, "ours", ["base"], resamples=300)[0]
    narrow = paired_differences(spread, "ours", ["base"], resamples=300)[0]
    assert wide.value == pytest.approx(narrow.value)
    assert wide.high - wide.low > 1.5 * (narrow.high - narrow.low)


def test_bad_requests_name_what_is_wrong():
    records = _records(5, 2, {"ours": 0.9}, {"ours": 0.9})
    with pytest.raises(InputError, match="soft"):
        paired_differences(records, "ours", ["soft"])
    with pytest.raises(InputError, match="no questions"):
        paired_differences([], "ours", ["soft"])
    with pytest.raises(InputError, match="resamples"):
        paired_differences(records, "ours", [], resamples=1)
