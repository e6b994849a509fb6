"""``AnswerDistribution``: what every inference method returns, and what calibration studies consume.

A question presupposes its referents ("the red bus" says there is exactly one) and the values it asks for. Every
method returns the *joint*: answers and an explicit invalid outcome, the mass of executions whose presuppositions
fail. :meth:`AnswerDistribution.given_presuppositions` turns it into P(answer | the presuppositions hold), with
P(presupposition fails) kept beside it; that is what the question pipeline returns by default.
"""

from __future__ import annotations

import json
import math
import warnings
from dataclasses import dataclass, field, replace

from po3d_ppl import ontology


@dataclass(frozen=True)
class AnswerDistribution:
    """Probabilities over answers plus the mass of invalid executions (``unique`` of a set with != 1 member, a
    query of a missing value).

    Answers are raw program values: subtype names (``'suv'``), raw part names (``'wheel_back_left'``), colours,
    ``'front'``..., ``True``/``False``, counts. ``probs`` lists every answer with non-zero probability, most
    probable first. ``error`` bounds the total-variation error of ``probs`` (0 for exact inference; for sampling,
    three standard errors summed over answers); ``stderr`` gives per-answer standard errors when sampled.
    """

    probs: dict
    invalid: float
    method: str
    answer_type: str
    error: float = 0.0
    stderr: dict = field(default_factory=dict)
    #: what the method reports about its own cost (samples drawn, tensor sizes...)
    info: dict = field(default_factory=dict)
    #: For a distribution given the presuppositions: the probability that they fail (the joint's invalid mass);
    #: None for the joint itself.
    presupposition_failure: float | None = None

    @property
    def top(self):
        """The most probable answer (None when the program is most probably invalid)."""
        best = max(self.probs.items(), key=lambda kv: kv[1], default=(None, 0.0))
        return best[0] if best[1] >= self.invalid else None

    @property
    def top_probability(self) -> float:
        return max(self.probs.values(), default=0.0)

    @property
    def entropy(self) -> float:
        """Entropy in nats over the answers and the invalid outcome."""
        masses = [*self.probs.values(), self.invalid]
        return -sum(p * math.log(p) for p in masses if p > 0)

    def probability(self, answer) -> float:
        return self.probs.get(answer, 0.0)

    def words(self, answer) -> str:
        """How a question would phrase an answer (readable part and shape names)."""
        if isinstance(answer, str):
            if answer in ontology.SUBTYPE_WORDS:
                return ontology.SUBTYPE_WORDS[answer]
            return ontology.readable_name(answer)
        return str(answer).lower() if isinstance(answer, bool) else str(answer)

    @staticmethod
    def mixture(weighted: list[tuple[float, AnswerDistribution]], method: str | None = None) -> AnswerDistribution:
        """Marginalise over alternatives (e.g. the n-best parses of a question): weights are renormalised."""
        total = sum(w for w, _ in weighted)
        if not weighted or total <= 0:
            raise ValueError("a mixture needs alternatives with positive weight")
        probs: dict = {}
        for w, d in weighted:
            for answer, p in d.probs.items():
                probs[answer] = probs.get(answer, 0.0) + w / total * p
        types = {d.answer_type for _, d in weighted}
        return AnswerDistribution(
            probs=dict(sorted(probs.items(), key=lambda kv: -kv[1])),
            invalid=sum(w / total * d.invalid for w, d in weighted),
            method=method or weighted[0][1].method,
            answer_type=types.pop() if len(types) == 1 else "mixed",
            error=sum(w / total * d.error for w, d in weighted),
            info={"alternatives": [{"weight": w / total, **d.info} for w, d in weighted]},
        )

    def given_presuppositions(self, warn_above: float | None = 0.5) -> AnswerDistribution:
        """P(answer | the program's presuppositions hold), with ``presupposition_failure`` = P(they fail).

        Warns (:class:`PresuppositionWarning`) when the failure probability exceeds ``warn_above``. When it is 1
        there is nothing to condition on: the answers stay empty.
        """
        if self.presupposition_failure is not None:
            return self
        failure = self.invalid
        holds = 1.0 - failure
        if warn_above is not None and failure > warn_above:
            warnings.warn(f"the question's presuppositions (its referents, the values it asks about) fail with "
                          f"probability {failure:.2f}; the answers are conditioned on the remaining "
                          f"{holds:.2f}", PresuppositionWarning, stacklevel=2)
        if holds <= 0.0:
            return replace(self, probs={}, invalid=0.0, stderr={}, presupposition_failure=1.0)
        return replace(self, probs={a: p / holds for a, p in self.probs.items()}, invalid=0.0,
                       error=min(self.error / holds, 1.0), stderr={a: e / holds for a, e in self.stderr.items()},
                       presupposition_failure=failure)

    def to_dict(self) -> dict:
        return {
            "method": self.method,
            "answer_type": self.answer_type,
            "top": self.top,
            "probs": [[a, p] for a, p in self.probs.items()],
            "invalid": self.invalid,
            "entropy": self.entropy,
            "error": self.error,
            "stderr": [[a, s] for a, s in self.stderr.items()],
            "info": self.info,
            "presupposition_failure": self.presupposition_failure,
        }

    def to_json(self) -> str:
        return json.dumps(self.to_dict())

    def __str__(self) -> str:
        lines = [f"{self.method}: {self.answer_type} answer, top = {self.top!r}"]
        for answer, p in list(self.probs.items())[:8]:
            err = f" ± {self.stderr[answer]:.3f}" if answer in self.stderr else ""
            lines.append(f"  {self.words(answer):<24} {p:.4f}{err}")
        if len(self.probs) > 8:
            lines.append(f"  ... {len(self.probs) - 8} more")
        if self.presupposition_failure is None:
            lines.append(f"  {'(invalid)':<24} {self.invalid:.4f}")
        else:
            lines.append(f"  given the presuppositions; they fail with probability {self.presupposition_failure:.4f}")
        return "\n".join(lines)


    def _repr_html_(self) -> str:
        """A notebook view: each answer in words with its probability as a bar, and the presupposition or
        invalid mass below."""
        from html import escape

        rows = []
        for answer, p in list(self.probs.items())[:12]:
            bar = f'<div style="background:#4a7bd0;height:0.8em;width:{max(p, 0.0) * 12:.2f}em"></div>'
            rows.append(f"<tr><td>{escape(self.words(answer))}</td><td style='text-align:right'>{p:.4f}</td>"
                        f"<td>{bar}</td></tr>")
        if len(self.probs) > 12:
            rows.append(f"<tr><td colspan=3>... {len(self.probs) - 12} more</td></tr>")
        if self.presupposition_failure is None:
            foot = f"invalid (presuppositions fail): {self.invalid:.4f}"
        else:
            foot = f"given the presuppositions; they fail with probability {self.presupposition_failure:.4f}"
        head = escape(f"{self.method}: {self.answer_type} answer, top = {self.words(self.top) if self.top is not None else None}")
        return (f"<div><b>{head}</b><table>{''.join(rows)}</table><small>{escape(foot)}</small></div>")


class PresuppositionWarning(UserWarning):
    """A question's presuppositions probably fail: its answer distribution rests on little mass."""
