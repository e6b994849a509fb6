"""Ordinary synonyms read as corpus words (po3d_ppl.language.paraphrase): where they apply, where they must not,
and that no phrase of the table ever occurs in the training corpus (so in-distribution questions are untouched)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from po3d_ppl.language.paraphrase import PHRASES, POSTPOSED, WORDS, paraphrase
from po3d_ppl.language.seq2seq.normalise import Normaliser
from po3d_ppl.language.seq2seq.vocab import tokenize
from po3d_ppl.questions.parser_corpus import CorpusConfig, iter_corpus

MODELS = Path(__file__).resolve().parents[1] / "models"
MEMBERS = ("question_parser", "question_parser_cr_seed0", "question_parser_w2_seed2")


def _vocabulary(name: str) -> frozenset[str]:
    return frozenset(json.loads((MODELS / f"{name}.vocab.json").read_text())["words"])


VOCAB = frozenset({"what", "color", "is", "the", "red", "car", "behind", "partially", "hides", "bus", "facing",
                   "to", "left", "small", "thing", "there", "a", "in", "of", "back", "shape", "front", "dirt",
                   "bike"})


def test_an_unknown_synonym_is_read_as_its_corpus_word():
    words, rewrites = paraphrase(tokenize("What hue is the red car?"), VOCAB)
    assert words == ["what", "color", "is", "the", "red", "car"]
    assert rewrites == [("hue", "color")]


def test_a_word_the_vocabulary_knows_keeps_its_own_meaning():
    vocabulary = VOCAB | {"model"}
    words, rewrites = paraphrase(["what", "model", "is", "the", "car"], vocabulary)
    assert words == ["what", "model", "is", "the", "car"] and rewrites == []


def test_phrases_are_read_even_when_every_word_is_known():
    words, rewrites = paraphrase(tokenize("Is there a car in back of the bus?"), VOCAB)
    assert words == ["is", "there", "a", "car", "behind", "the", "bus"]
    assert rewrites == [("in back of", "behind")]
    words, _ = paraphrase(tokenize("the car hides part of the bus"), VOCAB)
    assert words == ["the", "car", "partially", "hides", "the", "bus"]


def test_a_pose_adjective_moves_behind_its_noun_phrase():
    words, rewrites = paraphrase(tokenize("What colour is the left-facing small dirt bike?"), VOCAB | {"colour"})
    assert words == ["what", "colour", "is", "the", "small", "dirt", "bike", "facing", "to", "the", "left"]
    assert rewrites == [("left facing small dirt bike", "small dirt bike facing to the left")]
    # no noun phrase follows: read in place
    assert paraphrase(["the", "left", "facing"], VOCAB)[0] == ["the", "facing", "to", "the", "left"]


def test_a_reading_outside_the_vocabulary_is_not_applied():
    words, rewrites = paraphrase(["a", "teal", "car"], VOCAB)       # "cyan" is not in VOCAB
    assert words == ["a", "teal", "car"] and rewrites == []


def test_the_normaliser_reports_paraphrases_before_typo_corrections():
    counts = {w: 10 for w in VOCAB} | {"shape": 1000}
    normalised = Normaliser(counts)(["what", "shade", "is", "the", "car"])
    # one letter from "shape", but a synonym of "color": the table wins over the typo corrector
    assert normalised.words == ("what", "color", "is", "the", "car")
    assert normalised.corrections == (("shade", "color"),)


@pytest.mark.parametrize("name", MEMBERS)
def test_every_reading_is_in_the_shipped_vocabularies(name):
    vocabulary = _vocabulary(name)
    for table in (WORDS, PHRASES, POSTPOSED):
        missing = {k: v for k, v in table.items() if not set(v.split()) <= vocabulary}
        assert not missing, f"{name}: readings with words outside the vocabulary: {missing}"


def test_no_single_word_entry_is_a_word_every_member_already_knows():
    known = frozenset.intersection(*(_vocabulary(n) for n in MEMBERS))
    assert not [w for w in WORDS if w in known], "dead entries: every shipped parser reads these itself"


def test_no_phrase_occurs_in_the_training_corpus():
    phrases = [f" {p} " for p in (*PHRASES, *POSTPOSED)]
    for config in (CorpusConfig(seed=5), CorpusConfig(seed=6, extra_families=("compare_relate", "wording2"))):
        for example in iter_corpus(4000, config):
            text = f" {' '.join(tokenize(example.question))} "
            found = [p.strip() for p in phrases if p in text]
            assert not found, f"{found} occur in the corpus question {example.question!r}"
