"""Post-hoc calibration of answer distributions: a temperature and a smoothing per answer type, fitted on a
validation split.

**Why.** The scene model multiplies its evidence tables as if their errors were independent. Perception's errors
are not: one wrong pose misplaces every projected part of an object, and a missed object leaves every count short
with nothing in the evidence to say so. The exact posterior over answers is therefore sharper than its accuracy
(seed 713 from the image: mean confidence 0.845 at accuracy 0.726). Tempering each answer type's distribution,
``p_k ∝ p_k ** (1 / T)``, is the standard remedy (temperature scaling, Guo et al. 2017): one scalar per answer
type. A temperature alone cannot help where the posterior gives the true answer no mass at all (the count of a
missed object), and NLL then drives it far too high (seed 712: confidence 0.62 at accuracy 0.69); so a share
``smoothing`` of the mass is also spread uniformly over the type's answers (as label smoothing does). Both are
fitted by NLL on a validation seed's questions (:func:`po3d_ppl.evaluation.answer_calibration.fit`), never on the
test split. The map is monotone over the answers, so the most probable answer stays the most probable answer.

The types' stage keeps the invalid mass (presupposition failure) as it is: only the answers' shares are
tempered. Where the best answer and the invalid mass are close, tempering can move the best answer below it (or
above), so the top outcome, and the accuracy, change in those few questions (seed 720: Part+Occ. 66.87% raw,
66.92% recalibrated). The pipeline applies the shipped calibration (``models/answer_calibration.json``) to the
distributions it returns; the raw posterior stays available (``Pipeline(answer_calibration=None)``) and the
evaluation reports both.

**The top answer's confidence.** Fitted by NLL, the smoothing that pays for missed objects also takes mass from
the many answers that are right, so the most probable answer ends up under-confident (validation seeds 712 and
716, the fit's own questions: confidence 0.887 at accuracy 0.896). A second, optional stage
(:class:`TopAnswerMap`, fitted after the first on the same questions, all types pooled) maps the top outcome's
probability (the top answer's, or the invalid mass where that is larger) to how often such outcomes were right: a
monotone map (isotonic regression) applied to the top outcome alone, the others rescaled to keep the total, which
is top-label calibration (Gupta and Ramdas, 2022). It never demotes the top outcome below the runner-up. The
invalid mass is an outcome like the answers here: a baseline that is sure no object fits is as wrong as one that
is sure of a wrong answer.

**Baselines.** A calibration fitted the same way for a baseline method (``models/answer_calibration_soft.json``,
``..._thresholded.json``; :func:`model_name`) is never used to answer: the evaluation applies it so that the
methods' ECEs are also compared like for like, each through a map fitted on the same validation questions.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from po3d_ppl.errors import InputError, ModelFileError
from po3d_ppl.reasoning.answer import AnswerDistribution

MODEL_NAME = "answer_calibration"
FILE = "answer_calibration.json"
#: The method whose answers the pipeline returns; its calibration keeps the plain names above.
PIPELINE_METHOD = "ours"


def _retrain(method: str) -> str:
    """How to remake ``method``'s calibration file, for the errors that find it missing or unreadable."""
    option = "" if method == PIPELINE_METHOD else f" --method {method}"
    return (f"refit it with `po3d train answer-calibration --data VAL --perception image{option}` (a validation "
            "dataset) or `git checkout models/`")


#: The invalid outcome (presupposition failure) beside the answers, inside :meth:`TopAnswerMap.remap`.
_INVALID_OUTCOME = object()

#: Integer answers are smoothed over 0..max(this, the largest answer with mass): the most objects a scene holds.
MIN_INTEGER_SUPPORT = 10


@dataclass(frozen=True)
class TypeCalibration:
    """How one answer type is recalibrated: ``(1 - smoothing) * p ** (1 / temperature) + smoothing * uniform``."""

    temperature: float = 1.0
    smoothing: float = 0.0

    def __post_init__(self) -> None:
        if not (math.isfinite(self.temperature) and self.temperature > 0):
            raise InputError("AnswerCalibration", f"temperature must be finite and > 0, got {self.temperature!r}")
        if not 0.0 <= self.smoothing < 1.0:
            raise InputError("AnswerCalibration", f"smoothing must be in [0, 1), got {self.smoothing!r}")


def answer_support(answer_type: str, answers) -> list:
    """The answers a type's smoothing spreads over: the type's vocabulary (counts 0..max(10, largest answer)),
    plus any answer of the distribution outside it. A type without a vocabulary (``"mixed"``: parses of several
    types in one distribution) spreads over its own answers."""
    from po3d_ppl.reasoning.values import has_support, support

    answers = list(answers)
    if not has_support(answer_type):
        return answers
    largest = max([MIN_INTEGER_SUPPORT, *(a for a in answers if isinstance(a, int) and not isinstance(a, bool))])
    values = support(answer_type, largest)
    known = set(map(repr, values))
    return values + [a for a in answers if repr(a) not in known]


@dataclass(frozen=True)
class TopAnswerMap:
    """The top outcome's probability -> how often such outcomes are right: knots ``confidence`` -> ``accuracy``
    (both non-decreasing, in [0, 1]), linear between knots and flat beyond them."""

    confidence: tuple[float, ...]
    accuracy: tuple[float, ...]

    def __post_init__(self) -> None:
        x, y = np.asarray(self.confidence, dtype=float), np.asarray(self.accuracy, dtype=float)
        if x.ndim != 1 or x.shape != y.shape or len(x) == 0:
            raise InputError("TopAnswerMap", f"needs as many accuracies as confidences (at least one), got "
                                             f"{len(self.confidence)} and {len(self.accuracy)}")
        if not (np.isfinite(x).all() and np.isfinite(y).all() and x.min() >= 0 and x.max() <= 1 and y.min() >= 0
                and y.max() <= 1):
            raise InputError("TopAnswerMap", "confidences and accuracies must lie in [0, 1]")
        if (np.diff(x) < 0).any() or (np.diff(y) < 0).any():
            raise InputError("TopAnswerMap", "confidences and accuracies must be non-decreasing (a monotone map "
                                             "keeps the order of the answers' confidences)")

    def __call__(self, confidence: float) -> float:
        return float(np.interp(confidence, self.confidence, self.accuracy))

    def remap(self, probs: dict, invalid: float, support: list) -> tuple[dict, float]:
        """(answers, invalid mass) with the top outcome's probability mapped (the top answer's, or the invalid
        mass when that is larger) and the other outcomes rescaled to keep the total. The top outcome stays on
        top: the map's value is raised, where needed, to the runner-up as rescaled (an answer wins a tie with the
        invalid mass, as :attr:`AnswerDistribution.top` reads it, so a top invalid mass that the map would bring
        down to an answer is left as it is)."""
        outcomes = {**probs, _INVALID_OUTCOME: invalid}  # the invalid mass last: an answer wins ties
        best, top = max(outcomes.items(), key=lambda kv: kv[1])

        def is_best(outcome) -> bool:
            return type(outcome) is type(best) and outcome == best

        total = sum(outcomes.values())
        rest = total - top
        second = max((p for a, p in outcomes.items() if not is_best(a)), default=0.0)
        floor = second * total / (rest + second) if rest + second > 0 else 0.0
        mapped = min(max(self(top), floor), total)
        if best is _INVALID_OUTCOME and (mapped <= floor * (1 + 1e-9) or rest <= 0):
            return probs, invalid
        if rest > 0:  # (the min keeps rounding from lifting the runner-up over a top answer at the floor)
            out = {best: mapped, **{a: min(p * (total - mapped) / rest, mapped) for a, p in outcomes.items()
                                    if not is_best(a)}}
        else:  # no other outcome has mass: what the map takes from the top goes evenly to the type's other answers
            others = [a for a in support if not is_best(a)]
            if not others:
                return probs, invalid
            out = {best: mapped, **{a: (total - mapped) / len(others) for a in others}}
        return out, out.pop(_INVALID_OUTCOME, invalid)

    def to_dict(self) -> dict[str, list[float]]:
        return {"confidence": [round(x, 6) for x in self.confidence],
                "accuracy": [round(y, 6) for y in self.accuracy]}


@dataclass(frozen=True)
class AnswerCalibration:
    """A :class:`TypeCalibration` per answer type (``Bool``, ``Integer``, ``Color``, ...; others are left as
    they are), then, if fitted, one :class:`TopAnswerMap` for every type."""

    types: dict[str, TypeCalibration] = field(default_factory=dict)
    top_answer: TopAnswerMap | None = None

    def apply(self, dist: AnswerDistribution) -> AnswerDistribution:
        """``dist`` recalibrated: its answer type's temperature and smoothing (the answers' total, 1 - the invalid
        mass, unchanged), then the top outcome's map (the total of answers and invalid mass unchanged)."""
        calibration = self.types.get(dist.answer_type)
        total = sum(dist.probs.values())
        if (calibration is None and self.top_answer is None) or total <= 0.0:
            return dist
        values = answer_support(dist.answer_type, dist.probs)
        probs, info = dict(dist.probs), {}
        if calibration is not None:
            top = max(dist.probs.values())
            # relative to the top answer, so p ** (1 / T) never underflows for every answer at once
            weights = {a: (p / top) ** (1.0 / calibration.temperature) for a, p in dist.probs.items() if p > 0}
            norm = sum(weights.values())
            uniform = calibration.smoothing / len(values)
            probs = {a: total * ((1.0 - calibration.smoothing) * weights.get(a, 0.0) / norm + uniform)
                     for a in values}
            info = {"temperature": calibration.temperature, "smoothing": calibration.smoothing}
        invalid = dist.invalid
        if self.top_answer is not None:
            probs, invalid = self.top_answer.remap({a: p for a, p in probs.items() if p > 0}, invalid, values)
            info["top_answer"] = True
        # most probable first; on a tie the answer that came first (the top answer, placed first by the map) wins
        probs = {a: p for a, p in sorted(probs.items(), key=lambda kv: -kv[1]) if p > 0}
        return replace(dist, probs=probs, invalid=invalid, info={**dist.info, "recalibrated": info})

    def to_dict(self) -> dict[str, dict]:
        types = {name: {"temperature": c.temperature, "smoothing": c.smoothing} for name, c in self.types.items()}
        return {"types": types, "top_answer": None if self.top_answer is None else self.top_answer.to_dict()}

    @staticmethod
    def from_dict(record: dict) -> AnswerCalibration:
        """The inverse of :meth:`to_dict`."""
        missing = [key for key in ("types", "top_answer") if key not in record]
        if missing:
            raise InputError("answer calibration", f"has no {' or '.join(map(repr, missing))} entry (a file written "
                                                   "before the top-answer map, or not a calibration file)")
        types, top = record["types"], record["top_answer"]
        return AnswerCalibration(
            {str(name): TypeCalibration(float(c["temperature"]), float(c["smoothing"])) for name, c in types.items()},
            None if top is None else TopAnswerMap(tuple(map(float, top["confidence"])),
                                                  tuple(map(float, top["accuracy"]))))

    def save(self, directory: Path, method: str = PIPELINE_METHOD) -> Path:
        path = Path(directory) / f"{model_name(method)}.json"
        path.write_text(json.dumps(self.to_dict(), indent=1) + "\n")
        return path


def model_name(method: str = PIPELINE_METHOD) -> str:
    """The manifest name (and file stem) of ``method``'s calibration: ``answer_calibration`` for the pipeline's
    method, ``answer_calibration_<method>`` for a baseline's."""
    if not method.isidentifier():
        raise InputError("method", f"must be a method name such as 'ours' or 'soft', got {method!r}")
    return MODEL_NAME if method == PIPELINE_METHOD else f"{MODEL_NAME}_{method}"


def load_answer_calibration(directory: Path | str | None = None, method: str = PIPELINE_METHOD
                            ) -> AnswerCalibration | None:
    """The shipped calibration of ``method``'s answers (checked against the manifest's sha256), or None when
    none is listed."""
    from po3d_ppl.model_store import model_files, read_manifest

    directory = Path(directory) if directory is not None else None
    name = model_name(method)
    if name not in read_manifest(directory):
        return None
    retrain = _retrain(method)
    path = model_files(name, directory, retrain)[f"{name}.json"]
    try:
        return AnswerCalibration.from_dict(json.loads(path.read_text()))
    except (ValueError, TypeError, KeyError, AttributeError, InputError) as exc:
        raise ModelFileError(f"cannot read the answer calibration from {path} ({exc}); {retrain}") from None
