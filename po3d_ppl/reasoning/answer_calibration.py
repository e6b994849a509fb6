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

The invalid mass (presupposition failure) is kept as it is: only the answers' shares are tempered. Where the best
answer and the invalid mass are close, tempering can move the best answer below it (or above), so the top outcome,
and the accuracy, change in those few questions (seed 720: Part+Occ. 66.87% raw, 66.92% recalibrated). The pipeline
applies the shipped calibration (``models/answer_calibration.json``) to the distributions it returns; the raw
posterior stays available (``Pipeline(answer_calibration=None)``) and the evaluation reports both.

**Baselines.** A calibration fitted the same way for a baseline method (``models/answer_calibration_soft.json``,
``..._thresholded.json``; :func:`model_name`) is never used to answer: the evaluation applies it so that the
methods' ECEs are also compared like for like, each through a map fitted on the same validation questions.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field, replace
from pathlib import Path

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
    plus any answer of the distribution outside it."""
    from po3d_ppl.reasoning.values import support

    answers = list(answers)
    largest = max([MIN_INTEGER_SUPPORT, *(a for a in answers if isinstance(a, int) and not isinstance(a, bool))])
    values = support(answer_type, largest)
    known = set(map(repr, values))
    return values + [a for a in answers if repr(a) not in known]


@dataclass(frozen=True)
class AnswerCalibration:
    """A :class:`TypeCalibration` per answer type (``Bool``, ``Integer``, ``Color``, ...); others are left as
    they are."""

    types: dict[str, TypeCalibration] = field(default_factory=dict)

    def apply(self, dist: AnswerDistribution) -> AnswerDistribution:
        """``dist`` with its answers recalibrated (their total, 1 - the invalid mass, unchanged)."""
        calibration = self.types.get(dist.answer_type)
        total = sum(dist.probs.values())
        if calibration is None or total <= 0.0:
            return dist
        top = max(dist.probs.values())
        # relative to the top answer, so p ** (1 / T) never underflows for every answer at once
        weights = {a: (p / top) ** (1.0 / calibration.temperature) for a, p in dist.probs.items() if p > 0}
        norm = sum(weights.values())
        values = answer_support(dist.answer_type, dist.probs)
        uniform = calibration.smoothing / len(values)
        probs = {a: total * ((1.0 - calibration.smoothing) * weights.get(a, 0.0) / norm + uniform) for a in values}
        probs = {a: p for a, p in sorted(probs.items(), key=lambda kv: -kv[1]) if p > 0}
        return replace(dist, probs=probs, info={**dist.info, "recalibrated": {
            "temperature": calibration.temperature, "smoothing": calibration.smoothing}})

    def to_dict(self) -> dict[str, dict[str, float]]:
        return {name: {"temperature": c.temperature, "smoothing": c.smoothing} for name, c in self.types.items()}

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
        record = json.loads(path.read_text())
        return AnswerCalibration({str(name): TypeCalibration(float(c["temperature"]), float(c["smoothing"]))
                                  for name, c in record.items()})
    except (ValueError, TypeError, KeyError, AttributeError, InputError) as exc:
        raise ModelFileError(f"cannot read the answer calibration from {path} ({exc}); {retrain}") from None
