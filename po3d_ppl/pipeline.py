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
                    num_samples: int = 4096, seed: int = 0, budget: Budget | None = None
                    ) -> tuple[AnswerDistribution, object]:
    """(the answer distribution marginalised over the n-best programs, the parse); ``parser`` defaults to the
    shipped :class:`~po3d_ppl.language.QuestionParser`; ``budget`` bounds each program's inference call."""
    if parser is None:
        from po3d_ppl.language import QuestionParser

        parser = QuestionParser.load()
    parse = parser.parse(question, n=n_best)
    weighted = [(candidate.probability, reasoner.infer(candidate.program, method, num_samples=num_samples, seed=seed,
                                                       budget=budget))
                for candidate in parse.candidates]
    return AnswerDistribution.mixture(weighted, method=method), parse
