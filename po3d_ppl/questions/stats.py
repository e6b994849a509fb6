"""Per-family statistics of built question files: counts, answer entropy and the share of the top answer."""

from __future__ import annotations

import math
from collections import Counter, defaultdict
from collections.abc import Iterable, Mapping
from dataclasses import dataclass


@dataclass(frozen=True)
class FamilyStats:
    question_set: str
    template_filename: str
    family: int
    count: int
    distinct_answers: int
    #: Shannon entropy of the answers, in bits
    entropy_bits: float
    top_answer: str
    top_share: float


def answer_entropy(answers: Iterable) -> float:
    counts = Counter(map(str, answers))
    total = sum(counts.values())
    return max(0.0, -sum(c / total * math.log2(c / total) for c in counts.values())) if total else 0.0


def family_stats(questions: Mapping[str, list[dict]]) -> list[FamilyStats]:
    """One row per (question set, template file, family), in that order."""
    rows = []
    for name in sorted(questions):
        groups: dict[tuple[str, int], list] = defaultdict(list)
        for q in questions[name]:
            groups[(q["template_filename"], q["question_family_index"])].append(q["answer"])
        for (filename, family), answers in sorted(groups.items()):
            counts = Counter(map(str, answers))
            top, top_count = counts.most_common(1)[0]
            rows.append(FamilyStats(name, filename, family, len(answers), len(counts), answer_entropy(answers), top,
                                    top_count / len(answers)))
    return rows
