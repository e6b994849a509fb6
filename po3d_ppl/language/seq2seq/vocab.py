"""Question words and program target tokens, as id vocabularies for the seq2seq model.

Questions are lower-cased and split into runs of letters and digits, so case and punctuation never matter
("What's the SUV's colour?" -> what s the suv s colour). Words outside the training vocabulary become ``<unk>``
and are reported to the caller.

Program targets are the prefix token sequence of :mod:`po3d_ppl.language.tokens` with each value split off
into a token of its own (``filter_color[red]`` -> ``filter_color``, ``red``): a value is then one embedding
shared by every operation that takes it, and the decoder's constraint knows which value type may come next.
Part names are targets in their canonical spelling only (:func:`po3d_ppl.language.seq2seq.data.canonical_targets`
respells imported programs).
"""

from __future__ import annotations

import re
import zlib
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field

from po3d_ppl import ontology
from po3d_ppl.catalogue import OperationRegistry, value_vocabulary
from po3d_ppl.language.ast import Program
from po3d_ppl.language.tokens import format_token, program_from_tokens, program_to_tokens, split_token

PAD, UNK = "<pad>", "<unk>"
_WORD = re.compile(r"[a-z0-9]+")


def tokenize(question: str) -> list[str]:
    """Lower-cased words of ``question``; punctuation and spacing are dropped."""
    return _WORD.findall(question.lower())


#: Longest n-gram list per word (longer words keep their first ones).
MAX_NGRAMS = 32


def word_ngrams(word: str, buckets: int, sizes: tuple[int, ...] = (3, 4, 5)) -> list[int]:
    """Hashed character n-grams of ``<word>`` (boundary marks included) in ``1..buckets-1``; 0 is padding.
    crc32, not ``hash``: the ids must be the same in every process."""
    if buckets <= 1 or not word:
        return []
    marked = f"<{word}>"
    grams = [marked[i:i + n] for n in sizes for i in range(len(marked) - n + 1)] or [marked]
    return [1 + zlib.crc32(g.encode()) % (buckets - 1) for g in grams[:MAX_NGRAMS]]


def ngram_tensor_rows(words: Sequence[str], buckets: int) -> list[list[int]]:
    """Padded n-gram id rows, one per word."""
    rows = [word_ngrams(w, buckets) for w in words]
    width = max((len(r) for r in rows), default=1) or 1
    return [r + [0] * (width - len(r)) for r in rows]


@dataclass(frozen=True)
class WordVocabulary:
    """Question words -> ids; id 0 is padding, id 1 is ``<unk>``. ``counts`` (training frequencies) rank typo
    corrections."""

    words: tuple[str, ...]
    counts: tuple[int, ...] = field(default=())

    def __post_init__(self) -> None:
        object.__setattr__(self, "_index", {w: i for i, w in enumerate(self.words)})
        counts = self.counts or (1,) * len(self.words)
        object.__setattr__(self, "_counts", {w: c for w, c in zip(self.words[2:], counts[2:])})

    @classmethod
    def build(cls, questions: Iterable[str], min_count: int = 1) -> WordVocabulary:
        counts: dict[str, int] = {}
        for question in questions:
            for word in tokenize(question):
                counts[word] = counts.get(word, 0) + 1
        kept = sorted(w for w, c in counts.items() if c >= min_count)
        return cls((PAD, UNK, *kept), (0, 0, *(counts[w] for w in kept)))

    def frequencies(self) -> dict[str, int]:
        """Known word -> training count."""
        return self._counts

    def ids(self, words: Sequence[str]) -> list[int]:
        """Ids of already tokenised words (unknown -> ``<unk>``)."""
        return [self._index.get(w, 1) for w in words]

    def encode(self, question: str) -> tuple[list[int], list[str]]:
        """Word ids of ``question`` and the words that were not in the vocabulary (in order of appearance)."""
        ids, unknown = [], []
        for word in tokenize(question):
            index = self._index.get(word)
            if index is None:
                unknown.append(word)
                index = 1
            ids.append(index)
        return ids, unknown

    def __len__(self) -> int:
        return len(self.words)


@dataclass(frozen=True)
class TargetVocabulary:
    """Operation and value tokens -> ids. Id 0 is padding and doubles as the decoder's start token."""

    operations: tuple[str, ...]
    values: tuple[str, ...]

    def __post_init__(self) -> None:
        tokens = (PAD, *self.operations, *self.values)
        object.__setattr__(self, "tokens", tokens)
        object.__setattr__(self, "_op_index", {op: 1 + i for i, op in enumerate(self.operations)})
        object.__setattr__(self, "_value_index",
                           {v: 1 + len(self.operations) + i for i, v in enumerate(self.values)})

    @classmethod
    def from_registry(cls, registry: OperationRegistry) -> TargetVocabulary:
        """Every registered operation and every literal of every value type an operation takes; part names only
        in their canonical spelling (``ontology.CANONICAL_PARTNAME_VALUES``): two raw names that read the same
        mean the same parts, so the parser has one token per wording and its output is a function of the text."""
        values: set[str] = set()
        for op in registry:
            if op.value == "Partname":
                values.update(ontology.CANONICAL_PARTNAME_VALUES)
            elif op.value is not None:
                values.update(value_vocabulary(op.value))
        return cls(tuple(registry.names()), tuple(sorted(values)))

    def __len__(self) -> int:
        return len(self.tokens)

    def op_id(self, name: str) -> int | None:
        return self._op_index.get(name)

    def value_id(self, value: str) -> int | None:
        return self._value_index.get(value)

    def is_value(self, token_id: int) -> bool:
        return token_id > len(self.operations)

    def encode(self, program: Program) -> list[int]:
        """Target ids of ``program`` (prefix order, values split off). Raises KeyError for unknown tokens."""
        ids: list[int] = []
        for token in program_to_tokens(program):
            function, value = split_token(token)
            ids.append(self._op_index[function])
            if value is not None:
                ids.append(self._value_index[value])
        return ids

    def decode_tokens(self, ids: Sequence[int]) -> list[str]:
        """Public prefix tokens (``filter_color[red]``) from target ids."""
        out: list[str] = []
        for token_id in ids:
            token = self.tokens[token_id]
            if self.is_value(token_id):
                out[-1] = format_token(out[-1], token)
            else:
                out.append(token)
        return out

    def decode(self, ids: Sequence[int], registry: OperationRegistry) -> Program:
        return program_from_tokens(self.decode_tokens(ids), registry)
