"""Run every method on the same evidence per image: the records the accuracy, calibration and difficulty reports
are computed from.

Per image: the observation's evidence comes from the back-end once (or from the cache), one
:class:`~po3d_ppl.reasoning.SceneReasoner` computes its posterior tables once, and every question of the image is
answered by every method from them. Questions are scored against their ground-truth raw answer (the last node's
``_output``, the value the reference executor returns; ``tests/test_reasoning_certain.py`` compares the same way).
"""

from __future__ import annotations

import time
import warnings
from collections.abc import Callable, Collection, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

from po3d_ppl.errors import InputError
from po3d_ppl.evaluation.backends import EvidenceBackend, Observation
from po3d_ppl.evaluation.cache import EvidenceCache
from po3d_ppl.evaluation.difficulty import referents_found, trace_difficulty

#: Methods a run can ask for; ``ours`` is reported twice (given the presuppositions, and the joint). A method
#: with an answer calibration in the run is reported once more, recalibrated (``ours_calibrated``, ...).
METHODS = ("ours", "thresholded", "soft", "oracle")
#: The methods an answer calibration can be fitted for (the oracle's answers are certain and right).
CALIBRATABLE = ("ours", "thresholded", "soft")
#: The reported variants, in table order.
VARIANTS = {"ours": ("ours", "ours_joint"), "thresholded": ("thresholded",), "soft": ("soft",),
            "oracle": ("oracle",)}


def calibrated_variant(method: str) -> str:
    """The variant name of ``method``'s answers through its answer calibration."""
    return f"{method}_calibrated"


CALIBRATED = calibrated_variant("ours")
#: The predicted "answer" of a distribution whose largest mass is the invalid outcome.
INVALID = "<invalid>"
#: The paper's Table 1 columns, in order.
COLUMNS = ("Part", "Pose", "Occ.", "Part+Occ.")
CORE = "CLEVR core"


def parse_methods(text: str) -> tuple[str, ...]:
    """``"ours,soft"`` -> ("ours", "soft"), checked against :data:`METHODS`."""
    methods = tuple(m.strip() for m in text.split(",") if m.strip())
    unknown = [m for m in methods if m not in METHODS]
    if unknown or not methods:
        raise InputError("--methods", f"unknown method(s) {', '.join(unknown) or '(none given)'}; "
                                      f"choose from {','.join(METHODS)}")
    return methods


def variants_of(methods: Sequence[str], calibrated: Collection[str] = ()) -> tuple[str, ...]:
    """The reported variants of ``methods``; each method in ``calibrated`` gets its recalibrated variant right
    after its own (``ours``, ``ours_calibrated``, ``ours_joint``, ...)."""
    return tuple(v for m in methods
                 for v in (VARIANTS[m][:1] + ((calibrated_variant(m),) if m in calibrated else ()) + VARIANTS[m][1:]))


def table1_column(file: str, program: Sequence[dict]) -> str | None:
    """The paper's Table 1 column of a question: parts -> Part, pose -> Pose, the occlusion files -> Part+Occ.
    when the program touches parts, else Occ. (exactly the object-level families of ``obj_occlusion``);
    core -> the CLEVR core row; anything else (height_depth) -> None."""
    if file == "parts":
        return "Part"
    if file == "pose":
        return "Pose"
    if file in ("occlusion", "obj_occlusion"):
        return "Part+Occ." if any("part" in node["type"] for node in program) else "Occ."
    if file == "core":
        return CORE
    return None


@dataclass(frozen=True)
class QuestionItem:
    """A dataset question with what scoring needs."""

    file: str
    family: str  # "<template_filename>:<question_family_index>"
    image_index: int
    question_index: int
    question: str
    program: tuple  # public nodes without ``_output``
    truth: Any  # the raw answer
    column: str | None

    @staticmethod
    def from_public(file: str, q: dict) -> QuestionItem:
        program = tuple({k: v for k, v in node.items() if k != "_output"} for node in q["program"])
        return QuestionItem(file, f"{q['template_filename']}:{q['question_family_index']}", int(q["image_index"]),
                            int(q.get("question_index", -1)), q["question"], program, q["program"][-1]["_output"],
                            table1_column(file, q["program"]))


@dataclass(frozen=True)
class Prediction:
    """A method's answer: probabilities over raw answers (most probable first) and the invalid mass."""

    probs: tuple[tuple[Any, float], ...]
    invalid: float
    failure: str | None = None  # why there is no answer (a budget exceeded ...)

    @staticmethod
    def of(dist) -> Prediction:
        return Prediction(tuple(dist.probs.items()), float(dist.invalid))

    @property
    def top(self) -> Any:
        """The most probable outcome, :data:`INVALID` included."""
        best = max(self.probs, key=lambda kv: kv[1], default=(INVALID, 0.0))
        return best[0] if best[1] >= self.invalid and best[1] > 0 else INVALID

    @property
    def confidence(self) -> float:
        return max([self.invalid, *(p for _, p in self.probs)])

    def probability(self, answer: Any) -> float:
        return next((p for a, p in self.probs if _same(a, answer)), 0.0)


def _same(a: Any, b: Any) -> bool:
    """Answers are equal when value and kind are (``True`` is not the count ``1``)."""
    return type(a) is type(b) and a == b


@dataclass
class QuestionRecord:
    item: QuestionItem
    answer_type: str
    predictions: dict[str, Prediction]
    #: Difficulty (paper section 5.4): min occlusion ratio of the objects in the trace, largest part area (px).
    occlusion_ratio: float | None = None
    part_size: int | None = None
    #: Whether the evidence holds a proposal matched to every object of the trace (box IoU >= 0.5; None: the
    #: evidence has no boxes). Read from the scene, for analysis only, like the difficulty.
    referents_found: bool | None = None

    def correct(self, variant: str) -> bool:
        return _same(self.predictions[variant].top, self.item.truth)


@dataclass
class EvalRun:
    """Everything a report needs: the records plus per-stage timings and the evidence's provenance."""

    records: list[QuestionRecord]
    variants: tuple[str, ...]
    backend: dict[str, Any]
    split: str
    images: int
    timings: dict[str, float] = field(default_factory=dict)
    cache: dict[str, int] = field(default_factory=dict)
    failures: dict[str, int] = field(default_factory=dict)
    #: The scene model's priors the run used (``ScenePriors`` fields).
    priors: dict[str, float] = field(default_factory=dict)


def split_items(dataset, split: str, files: Sequence[str] | None = None) -> dict[int, list[QuestionItem]]:
    """The split's questions grouped by image, in image order."""
    part = dataset.split(split)
    by_image: dict[int, list[QuestionItem]] = {}
    for file, questions in sorted(part.questions.items()):
        if files is not None and file not in files:
            continue
        for q in questions:
            by_image.setdefault(int(q["image_index"]), []).append(QuestionItem.from_public(file, q))
    if not by_image:
        which = "" if files is None else f" in the files {', '.join(files)} (it has {', '.join(sorted(part.questions))})"
        raise InputError("--split", f"split {split!r} of {dataset.root} has no questions{which}")
    return dict(sorted(by_image.items()))


class _OnceParser:
    """The question parser with a memo, so the pipeline parses each question once whatever the number of methods."""

    def __init__(self, parser):
        self.parser, self.memo = parser, {}

    def parse(self, question: str, n: int = 3):
        key = (question, n)
        if key not in self.memo:
            self.memo[key] = self.parser.parse(question, n=n)
        return self.memo[key]


def evaluate(dataset, split: str, backend: EvidenceBackend, methods: Sequence[str] = METHODS, *,
             cache: EvidenceCache | None = None, limit: int | None = None, parse: bool = False, parser=None,
             priors=None, budget=None, device: str = "cpu",
             progress: Callable[[int, int], None] | None = None, semantics: str = "intended",
             answer_calibrations: Mapping[str, Any] | None = None, proposal_priors: bool = True,
             evidence_transform: Callable[[Any, Any], Any] | None = None,
             files: Sequence[str] | None = None) -> EvalRun:
    """Answer the split's questions (the first ``limit`` images) by every method on one evidence per image, under
    ``semantics`` (``public``: the dataset must be built with it; the evidence reads the public annotation).
    ``answer_calibrations`` maps methods of the run to their
    :class:`~po3d_ppl.reasoning.answer_calibration.AnswerCalibration`; each such method is also reported
    recalibrated (:func:`calibrated_variant`: ``ours_calibrated``, ...). ``proposal_priors`` lets the back-end set the priors
    its calibration knows for its proposals (``EvidenceBackend.scene_priors``); False uses ``priors`` as given.
    ``evidence_transform(evidence, scene)``, when given, edits each image's evidence after calibration (an analysis
    that substitutes truth, :mod:`po3d_ppl.evaluation.ceilings`; the cache keeps the untouched evidence).
    ``files`` keeps only those question files (e.g. ``("occlusion",)``)."""
    from dataclasses import asdict

    from po3d_ppl.catalogue.semantics import PUBLIC, check_semantics
    from po3d_ppl.questions.public import public_reading
    from po3d_ppl.reasoning import ScenePriors, SceneReasoner

    priors = priors or ScenePriors()
    priors = backend.scene_priors(priors) if proposal_priors else priors
    public = check_semantics(semantics) == PUBLIC

    methods = tuple(methods)
    for m in methods:
        if m not in METHODS:
            raise InputError("methods", f"unknown method {m!r}; choose from {', '.join(METHODS)}")
    cache = cache or EvidenceCache(None)
    by_image = split_items(dataset, split, files)
    images = list(by_image)[:limit] if limit else list(by_image)
    once = _OnceParser(parser or _default_parser()) if parse else None
    timings = {"perception_s": 0.0, "parse_s": 0.0, "posterior_s": 0.0,
               **{f"inference_{m}_s": 0.0 for m in methods if m != "oracle"}}
    calibrations = {m: c for m, c in (answer_calibrations or {}).items() if m in methods}
    unknown = [m for m in calibrations if m not in CALIBRATABLE]
    if unknown:
        raise InputError("answer_calibrations", f"no calibration applies to {', '.join(unknown)}; "
                                                f"choose from {', '.join(CALIBRATABLE)}")
    variants = variants_of(methods, calibrations)
    failures = {v: 0 for v in variants}
    records: list[QuestionRecord] = []
    identity = {**backend.identity(), "semantics": semantics} if public else backend.identity()
    for done, index in enumerate(images):
        scene = dataset.scene(index)
        observation = Observation(index, dataset.image_path(index), public_reading(scene) if public else scene)
        start = time.perf_counter()
        evidence = backend.calibrate(cache.get(observation.image_path, identity,
                                               lambda: backend.evidence(observation), device=device))
        timings["perception_s"] += time.perf_counter() - start
        if evidence_transform is not None:
            evidence = evidence_transform(evidence, observation.scene)
        found = _found_objects(evidence, scene)
        reasoner = SceneReasoner(evidence, priors, semantics)
        start = time.perf_counter()
        reasoner.posteriors  # computed once here, so the per-question timings are reasoning alone
        timings["posterior_s"] += time.perf_counter() - start
        for item in by_image[index]:
            record = _answer(item, scene, reasoner, methods, once, budget, timings, failures, semantics, found)
            for method, calibration in calibrations.items():
                record.predictions[calibrated_variant(method)] = recalibrated(record, calibration, method)
                failures[calibrated_variant(method)] += record.predictions[method].failure is not None
            records.append(record)
        if progress is not None:
            progress(done + 1, len(images))
    return EvalRun(records, variants, backend.provenance(), split, len(images), timings,
                   {"hits": cache.hits, "misses": cache.misses}, failures, asdict(priors))


def recalibrated(record: QuestionRecord, calibration, method: str = "ours") -> Prediction:
    """``method``'s answer of ``record`` recalibrated by an
    :class:`~po3d_ppl.reasoning.answer_calibration.AnswerCalibration`."""
    from po3d_ppl.reasoning import AnswerDistribution

    answer = record.predictions[method]
    if not answer.probs:
        return answer
    dist = AnswerDistribution(dict(answer.probs), answer.invalid, method, record.answer_type)
    return Prediction.of(calibration.apply(dist))


def _default_parser():
    """The shipped question parser (the ensemble when the manifest lists one), as ``answer()`` uses it."""
    from po3d_ppl.language.seq2seq.ensemble import load_question_parser

    return load_question_parser()


def _found_objects(evidence, scene) -> set[int] | None:
    """The scene's objects some proposal of ``evidence`` is matched to (box IoU >= 0.5); None without boxes."""
    from po3d_ppl.evaluation.projection import matched_proposals

    return None if evidence.boxes is None else set(matched_proposals(evidence, scene)[1])


def _answer(item: QuestionItem, scene, reasoner, methods, once, budget, timings, failures,
            semantics: str = "intended", found: set[int] | None = None) -> QuestionRecord:
    from po3d_ppl.questions.executor import execute

    reference = execute(scene, item.program, semantics=semantics)
    if not reference.valid or not _same(reference.answer, item.truth):
        raise InputError("dataset", f"image {item.image_index}, question {item.question_index} "
                                    f"({item.question!r}): the reference executor answers {reference.answer!r}, "
                                    f"the file says {item.truth!r}; rebuild the dataset with this version")
    ratio, size = trace_difficulty(scene, reference)
    predictions: dict[str, Prediction] = {}
    for method in methods:
        start = time.perf_counter()
        if method == "oracle":
            predictions["oracle"] = _oracle(item, scene, reference, once, timings, semantics)
            continue
        predictions.update(_infer(item, reasoner, method, once, budget, failures))
        timings[f"inference_{method}_s"] += time.perf_counter() - start
    return QuestionRecord(item, reference.answer_type, predictions, ratio, size, referents_found(reference, found))


def _oracle(item: QuestionItem, scene, reference, once, timings, semantics: str = "intended") -> Prediction:
    """The reference executor on the ground-truth scene (with ``--parse``: on the parser's best program)."""
    from po3d_ppl.questions.executor import execute

    if once is not None:
        start = time.perf_counter()
        best = once.parse(item.question).best.program
        timings["parse_s"] += time.perf_counter() - start
        reference = execute(scene, best, semantics=semantics)
    if not reference.valid:
        return Prediction((), 1.0)
    return Prediction(((reference.answer, 1.0),), 0.0)


def _infer(item: QuestionItem, reasoner, method: str, once, budget, failures) -> dict[str, Prediction]:
    from po3d_ppl.reasoning import BudgetExceeded, PresuppositionWarning

    engine = "auto" if method == "ours" else method
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", PresuppositionWarning)
            if once is not None:
                from po3d_ppl.pipeline import answer_question

                joint, _ = answer_question(reasoner, item.question, once, method=engine, budget=budget,
                                           presuppose=False)
            else:
                joint = reasoner.infer(list(item.program), engine, budget=budget)
    except BudgetExceeded as exc:
        for variant in VARIANTS[method]:
            failures[variant] += 1
        return {v: Prediction((), 1.0, failure=f"{type(exc).__name__}: {exc}") for v in VARIANTS[method]}
    if method != "ours":
        return {method: Prediction.of(joint)}
    return {"ours": Prediction.of(joint.given_presuppositions(warn_above=None)), "ours_joint": Prediction.of(joint)}
