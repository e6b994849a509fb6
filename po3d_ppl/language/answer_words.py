"""Answers in words: beside each raw answer value, the words a person expects, as the public question files write
answers ("school bus" for ``school``, "back left wheel" for ``wheel_back_left``, "yes" for ``True``).

The words come from :func:`po3d_ppl.language.lexicon.value_words` (derived from the ontology), so answers are said
the way questions say the same values.
"""

from __future__ import annotations

from collections.abc import MutableMapping

from po3d_ppl.language.lexicon import value_words


def answer_words(value: object, answer_type: str) -> str | None:
    """Words for one raw answer value (None for no answer: an invalid execution)."""
    if value is None:
        return None
    return value_words(value, answer_type)


def add_answer_words(out: MutableMapping) -> MutableMapping:
    """Add ``top_words`` and ``words`` (``[[raw, words], ...]`` in ``probs`` order) to an answer distribution's
    ``to_dict()``; the raw values stay as they are."""
    kind = str(out.get("answer_type", ""))
    out["top_words"] = answer_words(out.get("top"), kind)
    out["words"] = [[raw, answer_words(raw, kind)] for raw, _ in out.get("probs", [])]
    return out
