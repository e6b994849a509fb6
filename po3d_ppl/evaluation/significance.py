"""Is a method better than a baseline, or is the gap noise? Paired bootstrap intervals over images.

The report compares methods on the same questions, and some of its gaps are small (raw ECE 0.0533 against 0.0527
on seed 720). A difference is read here with a percentile interval from resampling: each resample draws the
split's images with replacement and keeps all of their questions. The unit is the image, not the question,
because the questions of one image share its evidence (one misread object spoils several answers), so resampling
questions would make the interval too narrow. Both methods are scored on the same resample (paired), which is what
makes a small difference measurable at all.

Library: ``scipy.stats.bootstrap`` (percentile method: BCa's jackknife would cost one more ECE per image) draws
the resamples; accuracy and ECE of each are the report's own (:func:`~po3d_ppl.evaluation.calibration.
binned_calibration_error`, torchmetrics with the 1.0 clamp), so the interval brackets the printed figure.
"""

from __future__ import annotations

from collections import defaultdict
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from po3d_ppl.errors import InputError
from po3d_ppl.evaluation.calibration import N_BINS, binned_calibration_error, top_answers
from po3d_ppl.evaluation.runner import CALIBRATABLE, QuestionRecord, calibrated_variant

#: The metrics compared, and whether lower is better.
METRICS = {"accuracy": False, "ece": True}


@dataclass(frozen=True)
class Difference:
    """``metric(method) - metric(baseline)`` over all questions, with its bootstrap interval."""

    metric: str
    method: str
    baseline: str
    value: float
    low: float
    high: float
    level: float
    resamples: int

    @property
    def better(self) -> bool | None:
        """True when the interval says the method is better, False when it says worse, None when it straddles 0."""
        if self.low <= 0.0 <= self.high:
            return None
        return self.high < 0.0 if METRICS[self.metric] else self.low > 0.0

    def text(self) -> str:
        return f"{self.value:+.4f} [{self.low:+.4f}, {self.high:+.4f}]"


def paired_differences(records: Sequence[QuestionRecord], method: str, baselines: Sequence[str],
                       resamples: int = 1000, level: float = 0.95, seed: int = 0,
                       n_bins: int = N_BINS) -> list[Difference]:
    """Accuracy and ECE differences of ``method`` against each of ``baselines`` (every metric of :data:`METRICS`,
    baselines in order), with ``level`` percentile intervals from ``resamples`` image resamples (seeded)."""
    from scipy.stats import bootstrap

    if not records:
        raise InputError("records", "no questions to compare; evaluate a split with at least one question first")
    missing = [v for v in (method, *baselines) if v not in records[0].predictions]
    if missing:
        raise InputError("variants", f"{', '.join(missing)} not among the evaluated "
                                     f"{', '.join(records[0].predictions)}; add them to --methods")
    if resamples < 2 or not 0.0 < level < 1.0:
        raise InputError("bootstrap", f"need resamples >= 2 and 0 < level < 1, got {resamples} and {level}")
    variants = [method, *baselines]
    tops = {v: top_answers(records, v) for v in variants}
    confidence = {v: np.asarray(c, dtype=np.float64) for v, (c, _) in tops.items()}
    correct = {v: np.asarray(ok, dtype=bool) for v, (_, ok) in tops.items()}
    by_image: dict[int, list[int]] = defaultdict(list)
    for i, r in enumerate(records):
        by_image[r.item.image_index].append(i)
    groups = [np.asarray(rows) for rows in by_image.values()]

    def figures(rows: np.ndarray) -> np.ndarray:
        values = {v: (float(correct[v][rows].mean()),
                      binned_calibration_error(confidence[v][rows].tolist(), correct[v][rows].tolist(), "l1", n_bins))
                  for v in variants}
        return np.array([values[method][k] - values[b][k] for b in baselines for k in range(len(METRICS))])

    def statistic(images: np.ndarray) -> np.ndarray:
        return figures(np.concatenate([groups[int(g)] for g in images]))

    point = figures(np.arange(len(records)))
    if len(groups) < 2:  # one image: nothing to resample
        low = high = point
    else:
        result = bootstrap((np.arange(len(groups)),), statistic, n_resamples=resamples, confidence_level=level,
                           method="percentile", vectorized=False, random_state=seed)
        low, high = np.atleast_1d(result.confidence_interval.low), np.atleast_1d(result.confidence_interval.high)
    names = [(b, m) for b in baselines for m in METRICS]
    return [Difference(m, method, b, float(point[k]), float(low[k]), float(high[k]), level, resamples)
            for k, (b, m) in enumerate(names)]


def against_baselines(records: Sequence[QuestionRecord], variants: Sequence[str], resamples: int = 1000,
                      seed: int = 0) -> list[Difference]:
    """Ours against each evaluated baseline (thresholded, soft): raw against raw, and recalibrated against
    recalibrated where every one of them was (``<method>_calibrated``). Empty when ours or every baseline is
    missing."""
    ours, baselines = CALIBRATABLE[0], [v for v in CALIBRATABLE[1:] if v in variants]
    if ours not in variants or not baselines or not records:
        return []
    out = paired_differences(records, ours, baselines, resamples, seed=seed)
    calibrated = [calibrated_variant(v) for v in (ours, *baselines)]
    if all(v in variants for v in calibrated):
        out += paired_differences(records, calibrated[0], calibrated[1:], resamples, seed=seed)
    return out


def differences_markdown(differences: Sequence[Difference]) -> str:
    """What the intervals are, then one row per (method, baseline): each metric's difference and interval, and what
    the interval says. Empty without differences."""
    if not differences:
        return ""
    verdict = {True: "better", False: "worse", None: "not resolved"}
    rows: dict[tuple[str, str], dict[str, Difference]] = defaultdict(dict)
    for d in differences:
        rows[d.method, d.baseline][d.metric] = d
    first = differences[0]
    level = f"{100 * first.level:.0f}%"
    lines = [f"Differences ({first.method} minus the baseline) over the same questions, with {level} percentile "
             f"intervals from {first.resamples:,} bootstrap resamples of the images (all of an image's questions "
             "together: they share its evidence). 'not resolved': the interval contains 0, so this split cannot tell "
             "the two apart.", "",
             f"| method | baseline | accuracy difference [{level} interval] | | ECE difference | |",
             "|---|---|---|---|---|---|"]
    for (method, baseline), by_metric in rows.items():
        acc, ece = by_metric["accuracy"], by_metric["ece"]
        lines.append(f"| {method} | {baseline} | {acc.text()} | {verdict[acc.better]} | {ece.text()} | "
                     f"{verdict[ece.better]} |")
    return "\n".join(lines)
