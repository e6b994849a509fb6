"""The pipeline that joins the stages: a question is parsed (language) and its programs answered (reasoning).

The one place that imports both the parser and the reasoning engine, so neither stage imports the other for this.
Answers are marginalised over the parser's n-best programs, weighted by their probabilities::

    from po3d_ppl.perception import simulated_evidence
    from po3d_ppl.pipeline import answer_question
    from po3d_ppl.reasoning import SceneReasoner

    dist, parse = answer_question(SceneReasoner(simulated_evidence(scene, noise=0.1)), "What color is the bus?")
"""

from __future__ import annotations

from po3d_ppl.reasoning import AnswerDistribution, Budget, SceneReasoner


def answer_question(reasoner: SceneReasoner, question: str, parser=None, *, n_best: int = 3, method: str = "auto",
                    num_samples: int = 4096, seed: int = 0, budget: Budget | None = None, presuppose: bool = True
                    ) -> tuple[AnswerDistribution, object]:
    """(the answer distribution marginalised over the n-best programs, the parse); ``parser`` defaults to the
    shipped :class:`~po3d_ppl.language.QuestionParser`; ``budget`` bounds each program's inference call.

    By default the distribution is P(answer | the question's presuppositions hold), with P(they fail) in
    ``presupposition_failure`` and a :class:`~po3d_ppl.reasoning.answer.PresuppositionWarning` when it is high;
    ``presuppose=False`` gives the joint with its explicit invalid outcome."""
    if parser is None:
        from po3d_ppl.language import QuestionParser

        parser = QuestionParser.load()
    parse = parser.parse(question, n=n_best)
    weighted = [(candidate.probability, reasoner.infer(candidate.program, method, num_samples=num_samples, seed=seed,
                                                       budget=budget))
                for candidate in parse.candidates]
    joint = AnswerDistribution.mixture(weighted, method=method)
    return (joint.given_presuppositions() if presuppose else joint), parse
