"""The pipeline that joins the stages: an image is parsed (perception), a question is parsed (language) and its
programs answered (reasoning).

The one place that imports perception, the parser and the reasoning engine together, so no stage imports another
for this. ``answer(image, question)`` and ``load_pipeline()`` run everything on pixels with the shipped models::

    import po3d_ppl
    dist = po3d_ppl.answer("scene.png", "How many cars are occluded?")

Answers are marginalised over the parser's n-best programs, weighted by their probabilities; on ground-truth
evidence (the simulated sensor)::

    from po3d_ppl.perception import simulated_evidence
    from po3d_ppl.pipeline import answer_question
    from po3d_ppl.reasoning import SceneReasoner

    dist, parse = answer_question(SceneReasoner(simulated_evidence(scene, noise=0.1)), "What color is the bus?")
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from functools import lru_cache
from pathlib import Path
from typing import TYPE_CHECKING

from po3d_ppl.errors import InputError
from po3d_ppl.evidence import ScenePriors
from po3d_ppl.reasoning import AnswerDistribution, Budget, SceneReasoner

if TYPE_CHECKING:
    from po3d_ppl.perception.scene_parser import ImageParser, ParsedScene
    from po3d_ppl.reasoning.answer_calibration import AnswerCalibration


def answer_question(reasoner: SceneReasoner, question: str, parser=None, *, n_best: int = 3, method: str = "auto",
                    num_samples: int = 4096, seed: int = 0, budget: Budget | None = None, presuppose: bool = True
                    ) -> tuple[AnswerDistribution, object]:
    """(the answer distribution marginalised over the n-best programs, the parse); ``parser`` defaults to the
    shipped parser (:func:`~po3d_ppl.language.load_question_parser`: an ensemble of
    :class:`~po3d_ppl.language.QuestionParser` members); ``budget`` bounds each program's inference call.

    By default the distribution is P(answer | the question's presuppositions hold), with P(they fail) in
    ``presupposition_failure`` and a :class:`~po3d_ppl.reasoning.answer.PresuppositionWarning` when it is high;
    ``presuppose=False`` gives the joint with its explicit invalid outcome."""
    parse = (parser or _shipped_parser()).parse(question, n=n_best)
    return answer_parse(reasoner, parse, method=method, num_samples=num_samples, seed=seed, budget=budget,
                        presuppose=presuppose), parse


def answer_parse(reasoner: SceneReasoner, parse, *, method: str = "auto", num_samples: int = 4096, seed: int = 0,
                 budget: Budget | None = None, presuppose: bool = True, calibration=None) -> AnswerDistribution:
    """The answer distribution of an already parsed question (its n-best programs weighted by probability), so a
    question asked of many images is parsed once; ``calibration`` (an
    :class:`~po3d_ppl.reasoning.answer_calibration.AnswerCalibration`) recalibrates it."""
    weighted = [(candidate.probability, reasoner.infer(candidate.program, method, num_samples=num_samples, seed=seed,
                                                       budget=budget))
                for candidate in parse.candidates]
    joint = AnswerDistribution.mixture(weighted, method=method)
    dist = joint.given_presuppositions() if presuppose else joint
    return dist if calibration is None else calibration.apply(dist)

@dataclass
class Pipeline:
    """The shipped models loaded once: perception (pixels -> ``SceneEvidence``), the question parser, the scene
    model's priors (fitted to the world: ``models/priors.json``) and the reasoning engine. ``answer_many`` parses
    each image once for all its questions."""

    perception: ImageParser
    parser: object
    priors: ScenePriors = field(default_factory=ScenePriors)
    #: Post-hoc recalibration of the answers (``models/answer_calibration.json``); None returns the raw posterior.
    answer_calibration: AnswerCalibration | None = None

    def scene(self, image) -> ParsedScene:
        """Everything perception read from ``image`` (evidence, proposals, projections, timings)."""
        return self.perception.parse(image)

    def answer(self, image, question: str, *, method: str = "auto", n_best: int = 3, presuppose: bool = True,
               budget: Budget | None = None, seed: int = 0) -> AnswerDistribution:
        """P(answer | image, question), marginalised over the scene posterior and the n-best parses."""
        return self.answer_many([image], [question], method=method, n_best=n_best, presuppose=presuppose,
                                budget=budget, seed=seed)[0][0]

    def answer_many(self, images: Sequence, questions: Sequence[str], *, method: str = "auto", n_best: int = 3,
                    presuppose: bool = True, budget: Budget | None = None, seed: int = 0
                    ) -> list[list[AnswerDistribution]]:
        """Every question about every image: ``out[i][q]``. Each image and each question is parsed once."""
        if isinstance(questions, str):
            raise InputError("questions", "expected a list of questions; for one question use answer()")
        parses = [self.parser.parse(q, n=n_best) for q in questions]
        out = []
        for image in images:
            reasoner = SceneReasoner(self.perception.evidence(image), self.priors)
            out.append([answer_parse(reasoner, parse, method=method, seed=seed, budget=budget,
                                     presuppose=presuppose, calibration=self.answer_calibration)
                        for parse in parses])
        return out


def load_pipeline(models_dir: str | Path | None = None, device: str | None = None, *,
                  single_parser: bool = False) -> Pipeline:
    """The shipped perception models and question parser (or those of ``models_dir``), checked against their
    sha256; ``device`` (default CPU) for the networks. The question parser is the ensemble the manifest lists
    (:func:`~po3d_ppl.language.load_question_parser`); ``single_parser=True`` takes its single parser instead
    (the ablation)."""
    from po3d_ppl.language import load_question_parser
    from po3d_ppl.perception.priors import load_priors
    from po3d_ppl.perception.scene_parser import ImageParser
    from po3d_ppl.reasoning.answer_calibration import load_answer_calibration

    device = device or "cpu"
    perception = ImageParser.load(models_dir, device)
    return Pipeline(perception, load_question_parser(models_dir, single=single_parser, device=device),
                    perception.scene_priors(load_priors(models_dir)), load_answer_calibration(models_dir))


@lru_cache(maxsize=2)
def _shipped_parser(single: bool = False):
    """The shipped question parser (the ensemble; ``single``: its single parser), loaded once per process."""
    from po3d_ppl.language import load_question_parser

    return load_question_parser(single=single)


@lru_cache(maxsize=1)
def _default_pipeline() -> Pipeline:
    return load_pipeline()


def answer(image, question: str, *, method: str = "auto", n_best: int = 3, presuppose: bool = True,
           budget: Budget | None = None) -> AnswerDistribution:
    """``answer(image, question)``: the answer distribution for one image (a path, HWC numpy array or PIL image)
    with the shipped models, loaded once per process. For many questions use :func:`load_pipeline`."""
    return _default_pipeline().answer(image, question, method=method, n_best=n_best, presuppose=presuppose,
                                      budget=budget)
