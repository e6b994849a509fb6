"""Unknown words before the network: ordinary synonyms read as corpus words (:mod:`po3d_ppl.language.paraphrase`),
typo correction within edit distance 1, compound splitting and joining.

Why here and not in the network: a word the training questions never used has no embedding, and its character
n-grams (the subword input) only say what it looks like. When a word is one edit (insertion, deletion,
substitution or swap of neighbours) from exactly the vocabulary's most frequent such word, or is two vocabulary
words run together ("rearwheel"), or two unknown halves form a vocabulary word ("wind shield"), the question is
rewritten to known words and the rewrite is reported (``QuestionParse.corrections``). Words that stay unknown keep
only their n-grams and are reported as ``unknown_words``; the confidence calibration counts both.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

from po3d_ppl.language.paraphrase import paraphrase

_LETTERS = "abcdefghijklmnopqrstuvwxyz0123456789"
#: Shorter words are never corrected: one edit of a 1-2 letter word is too often another word.
MIN_CORRECT = 3


@dataclass(frozen=True)
class Normalised:
    words: tuple[str, ...]
    #: (original, replacement) pairs, in order of appearance.
    corrections: tuple[tuple[str, str], ...]
    #: Words that stayed unknown.
    unknown: tuple[str, ...]


def edits1(word: str) -> set[str]:
    """Every string one deletion, neighbour swap, substitution or insertion away from ``word``."""
    splits = [(word[:i], word[i:]) for i in range(len(word) + 1)]
    deletes = {a + b[1:] for a, b in splits if b}
    swaps = {a + b[1] + b[0] + b[2:] for a, b in splits if len(b) > 1}
    replaces = {a + c + b[1:] for a, b in splits if b for c in _LETTERS}
    inserts = {a + c + b for a, b in splits for c in _LETTERS}
    return (deletes | swaps | replaces | inserts) - {word}


class Normaliser:
    """Rewrites unknown words of a tokenised question into vocabulary words where that is unambiguous."""

    def __init__(self, counts: Mapping[str, int]):
        self.counts = dict(counts)

    def correct(self, word: str) -> str | None:
        """The vocabulary word one edit from ``word`` (the most frequent if several), else None."""
        if len(word) < MIN_CORRECT or word.isdigit():
            return None
        found = [w for w in edits1(word) if w in self.counts and len(w) >= MIN_CORRECT]
        if not found:
            return None
        found.sort(key=lambda w: (-self.counts[w], w))
        return found[0]

    def split(self, word: str) -> tuple[str, str] | None:
        """Two vocabulary words that ``word`` runs together, the most balanced cut first."""
        cuts = [(word[:i], word[i:]) for i in range(2, len(word) - 1)]
        cuts = [c for c in cuts if c[0] in self.counts and c[1] in self.counts]
        return min(cuts, key=lambda c: abs(len(c[0]) - len(c[1]))) if cuts else None

    def __call__(self, words: Sequence[str]) -> Normalised:
        words, rewrites = paraphrase(words, self.counts)
        out: list[str] = []
        corrections: list[tuple[str, str]] = list(rewrites)
        unknown: list[str] = []
        i = 0
        while i < len(words):
            word = words[i]
            if word in self.counts:
                out.append(word)
                i += 1
                continue
            if i + 1 < len(words) and words[i + 1] not in self.counts and word + words[i + 1] in self.counts:
                joined = word + words[i + 1]
                corrections.append((f"{word} {words[i + 1]}", joined))
                out.append(joined)
                i += 2
                continue
            parts = self.split(word)
            if parts is not None:
                corrections.append((word, " ".join(parts)))
                out.extend(parts)
            else:
                fixed = self.correct(word)
                if fixed is not None:
                    corrections.append((word, fixed))
                    out.append(fixed)
                else:
                    unknown.append(word)
                    out.append(word)
            i += 1
        return Normalised(tuple(out), tuple(corrections), tuple(unknown))
