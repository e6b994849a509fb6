"""Answer balancing across a dataset build: which candidate question each scene contributes.

Scenes are processed in index order with running counts, so the result is the same however many worker
processes generated the candidates. Two rules:

- families of a question file are tried least-used first (random tie-break), at most one question per family
  per scene, until the file's per-scene quota is met;
- within a family, a candidate is accepted only if its answer would not lead the family's answer counts by more
  than one (``count[answer] <= count of the runner-up``); and, for answer types with three or more possible
  values, only if the answer would then hold at most half of the family's questions (after the first one).
  This is stricter than the public rule (skip if more than 1.1 x the runner-up): our candidates per scene already
  cover several answers, so strict balance costs few questions, and it removes answer priors a model could
  exploit. A family whose scenes keep offering one dominant answer is emitted less often instead.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Mapping, Sequence

import numpy as np

from po3d_ppl.questions.generator import Candidate, answer_support

FamilyKey = tuple[str, int]
#: (question set, template file, family index)
BalanceKey = tuple[str, str, int]


def answer_key(candidate: Candidate) -> str:
    """A hashable, type-distinguishing key of a candidate's raw answer (``True`` and ``1`` differ)."""
    raw = candidate.raw_answer
    return f"{type(raw).__name__}:{raw}"


class AnswerBalancer:
    """Running answer counts and usage counts per (question set, family)."""

    def __init__(self) -> None:
        self.answers: dict[BalanceKey, Counter] = {}
        self.usage: Counter = Counter()

    def accepts(self, family: BalanceKey, candidate: Candidate) -> bool:
        counts = self.answers.get(family)
        if not counts:
            return True
        key = answer_key(candidate)
        mine = counts.get(key, 0)
        others = [c for k, c in counts.items() if k != key]
        if mine > max(others, default=0):
            return False
        return answer_support(candidate.answer_type) < 3 or mine + 1 <= max(1, sum(others))

    def record(self, family: BalanceKey, candidate: Candidate) -> None:
        self.answers.setdefault(family, Counter())[answer_key(candidate)] += 1
        self.usage[family] += 1

    def select(self, question_set: str, families: Sequence[FamilyKey],
               candidates: Mapping[FamilyKey, Sequence[Candidate]], quota: int,
               rng: np.random.Generator) -> list[Candidate]:
        """Pick up to ``quota`` candidates of distinct families for one scene and record them.

        Counts are kept per question set: a family shared by two sets (occlusion and obj_occlusion) is balanced
        in each independently.
        """
        keys = [(question_set, *f) for f in families]
        tie = rng.permutation(len(families))
        order = sorted(range(len(families)), key=lambda k: (self.usage[keys[k]], tie[k]))
        chosen: list[Candidate] = []
        for k in order:
            if len(chosen) >= quota:
                break
            options = candidates.get(families[k], ())
            for j in rng.permutation(len(options)) if len(options) > 1 else range(len(options)):
                if self.accepts(keys[k], options[j]):
                    self.record(keys[k], options[j])
                    chosen.append(options[j])
                    break
        return chosen
