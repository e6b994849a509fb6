"""The seq2seq question parser: a short training run on hand-made pairs, constrained n-best decoding, save/load
through the manifest, determinism and tokenisation."""

from __future__ import annotations

import json
import math

import pytest
import torch
from language_pairs import pair_examples

from po3d_ppl import ontology
from po3d_ppl.errors import InputError, ModelFileError
from po3d_ppl.language import QuestionParser, check_program, parse_program, program_to_json
from po3d_ppl.language.seq2seq.data import Example, canonical_targets, examples_from_records
from po3d_ppl.language.seq2seq.decode import greedy_batch
from po3d_ppl.language.seq2seq.model_io import MODEL_NAME, save_parser
from po3d_ppl.language.seq2seq.train import TrainConfig, evaluate, train_parser
from po3d_ppl.language.seq2seq.vocab import tokenize
from po3d_ppl.language.typecheck import default_registry
from po3d_ppl.model_store import model_files, write_entry

CONFIG = TrainConfig(seed=3, epochs=60, batch_size=8, lr=1e-2, dropout=0.0, word_dropout=0.0)


pytestmark = pytest.mark.usefixtures("torch_one_thread")


@pytest.fixture(scope="module")
def trained(torch_one_thread):
    examples = pair_examples()
    return train_parser(examples, CONFIG, default_registry())


@pytest.fixture(scope="module")
def parser(trained):
    return QuestionParser(trained)


def test_tokenize_ignores_case_and_punctuation():
    assert tokenize("What's the SUV's colour?!") == ["what", "s", "the", "suv", "s", "colour"]
    assert tokenize("  big,red   car. ") == ["big", "red", "car"]


def test_training_fits_the_pairs(trained):
    report = evaluate(trained, pair_examples(), default_registry())
    assert report["exact_match"] >= 0.9
    assert set(report["per_file"]) == {"parts", "pose", "occlusion", "obj_occlusion", "core"}
    assert trained.history[-1]["train_loss"] < trained.history[0]["train_loss"]


def test_n_best_programs_are_distinct_well_typed_and_sorted(parser):
    result = parser.parse("What is the color of the wheel of the red car?", n=4)
    assert len(result.candidates) == 4
    probabilities = [c.probability for c in result.candidates]
    assert probabilities == sorted(probabilities, reverse=True)
    assert 0 < sum(probabilities) <= 1 + 1e-6
    assert len({tuple(c.tokens) for c in result.candidates}) == 4
    for candidate in result.candidates:
        check_program(candidate.program)
        assert math.isclose(candidate.probability, math.exp(candidate.log_prob))


def test_parse_is_robust_to_case_and_punctuation_and_reports_unknown_words(parser):
    plain = parser.parse("What is the color of the wheel of the red car?")
    shouted = parser.parse("WHAT is the COLOR of the wheel of the red car ??")
    assert shouted.best.program == plain.best.program
    assert shouted.unknown_words == ()
    odd = parser.parse("What is the color of the wheel of the flurbish car?")
    assert odd.unknown_words == ("flurbish",)
    check_program(odd.best.program)
    # an ordinary synonym outside the vocabulary is read as its corpus word (po3d_ppl.language.paraphrase)
    synonym = parser.parse("What is the color of the wheel of the crimson car?")
    assert synonym.unknown_words == () and synonym.corrections == (("crimson", "red"),)
    assert synonym.best.program == plain.best.program


def test_empty_question_is_a_typed_error(parser):
    with pytest.raises(InputError, match="question"):
        parser.parse(" ?! ")
    with pytest.raises(InputError, match="n"):
        parser.parse("How many cars?", n=0)


def test_part_names_are_targets_in_one_spelling(trained, parser):
    """Public records spell "back left wheel" two ways; examples and targets use the canonical one only."""
    values = set(trained.targets.values)
    assert set(ontology.CANONICAL_PARTNAME_VALUES) <= values
    assert {"wheel_back_left", "mirror_left", "right_mirror"}.isdisjoint(values)
    assert {"back_left_wheel", "left_mirror", "mirror_right"} <= values
    record = {"question": "What color is the back left wheel of the bus?",
              "program": program_to_json(parse_program("scene() | filter_shape[bus] | unique | object2part"
                                                       " | partfilter_partname[wheel_back_left] | unique"
                                                       " | partquery_color"))}
    (example,) = examples_from_records([record], "parts")
    assert [n.value for n in example.program if n.function == "partfilter_partname"] == ["back_left_wheel"]
    assert [n.value for n in example.program if n.function == "filter_shape"] == ["bus"]
    untouched = parse_program("scene() | filter_color[red] | object2part | partfilter_partname[wheel] | count")
    assert canonical_targets(untouched) is untouched
    # the parser can only write the canonical spelling, here for a pair trained from "mirror_left"
    best = parser.parse("Is the left mirror of the wagon occluded by the blue car?").best
    assert "partfilter_partname[left_mirror]" in best.tokens


def test_unconstrained_greedy_baseline_runs(trained):
    words = torch.tensor([trained.words.encode("How many red things are there?")[0]])
    arity = {trained.targets.op_id(op.name): len(op.inputs) for op in default_registry()}
    (ids,) = greedy_batch(trained.model, None, words, torch.tensor([words.shape[1]]), arity, max_len=20)
    assert 1 <= len(ids) <= 20


def test_training_is_deterministic_from_the_seed():
    examples = pair_examples()[:6]
    config = TrainConfig(seed=11, epochs=2, batch_size=4, embed=16, hidden=16)
    a = train_parser(examples, config, default_registry()).model.state_dict()
    b = train_parser(examples, config, default_registry()).model.state_dict()
    c = train_parser(examples, TrainConfig(seed=12, epochs=2, batch_size=4, embed=16, hidden=16),
                     default_registry()).model.state_dict()
    assert all(torch.equal(a[k], b[k]) for k in a)
    assert not all(torch.equal(a[k], c[k]) for k in a)


def test_save_load_round_trip_verifies_checksums(trained, parser, tmp_path):
    files = save_parser(trained, tmp_path)
    write_entry(MODEL_NAME, files, tmp_path, command="test", metrics={})
    assert set(model_files(MODEL_NAME, tmp_path)) == {f.name for f in files}
    loaded = QuestionParser.load(tmp_path)
    question = "Is the left mirror of the wagon occluded by the blue car?"
    a, b = parser.parse(question, n=2), loaded.parse(question, n=2)
    assert [c.tokens for c in a.candidates] == [c.tokens for c in b.candidates]
    assert [c.log_prob for c in a.candidates] == pytest.approx([c.log_prob for c in b.candidates], abs=1e-5)
    # a modified weight file is refused, naming the file and the fix
    weights = tmp_path / f"{MODEL_NAME}.safetensors"
    weights.write_bytes(weights.read_bytes()[:-1] + b"\x00")
    with pytest.raises(ModelFileError, match="question_parser.safetensors.*sha256.*retrain"):
        QuestionParser.load(tmp_path)
    weights.unlink()
    with pytest.raises(ModelFileError, match="missing"):
        QuestionParser.load(tmp_path)


def test_manifest_entries_of_other_models_are_kept(tmp_path):
    (tmp_path / "a.bin").write_bytes(b"abc")
    (tmp_path / "b.bin").write_bytes(b"defg")
    write_entry("one", [tmp_path / "a.bin"], tmp_path, data_seed=1)
    write_entry("two", [tmp_path / "b.bin"], tmp_path, data_seed=2)
    manifest = json.loads((tmp_path / "manifest.json").read_text())
    assert manifest["one"]["files"]["a.bin"]["bytes"] == 3
    assert manifest["two"]["data_seed"] == 2
    with pytest.raises(ModelFileError, match="no entry"):
        model_files("three", tmp_path)


def test_a_target_token_outside_the_vocabulary_is_a_typed_error():
    """Targets use canonical part names only; an example that was not respelled names its question."""
    program = parse_program("scene() | filter_shape[bus] | unique | object2part"
                            " | partfilter_partname[wheel_back_left] | unique | partquery_color")
    example = Example("What color is the back left wheel of the bus?", program, "parts", "parts:0")
    with pytest.raises(InputError, match="wheel_back_left.*target vocabulary"):
        train_parser([example], TrainConfig(max_steps=1), default_registry())


def test_unknown_word_mechanism_and_its_ablation(trained):
    """Typos within one edit are rewritten and reported; with the mechanism off they stay unknown."""
    on = QuestionParser(trained)
    off = QuestionParser(trained, unknown_words=False)
    clean = on.parse("What is the color of the wheel of the red car?")
    typo = on.parse("What is the colr of the wheel of the red car?")
    assert ("colr", "color") in typo.corrections and typo.unknown_words == ()
    assert typo.best.tokens == clean.best.tokens
    ablated = off.parse("What is the colr of the wheel of the red car?")
    assert ablated.corrections == () and ablated.unknown_words == ("colr",)


def test_low_confidence_is_a_warning(trained):
    from po3d_ppl.language.seq2seq.model_io import Calibration

    sure = QuestionParser(trained, calibration=Calibration())
    assert sure.parse("How many red things are there?").warning is None
    doubtful = QuestionParser(trained, calibration=Calibration(unknown=-20.0))
    result = doubtful.parse("How many zorblax things are there?")
    assert result.confidence < 0.5 and "zorblax" in result.warning


def test_subword_input_reads_unknown_words_by_their_letters():
    examples = pair_examples()[:6]
    config = TrainConfig(seed=1, epochs=1, batch_size=4, embed=16, hidden=16, ngram_buckets=257)
    small = train_parser(examples, config, default_registry())
    assert small.model.config.ngram_buckets == 257
    parser = QuestionParser(small)
    question = "What is the color of the zorblax wheel?"
    _, words, ngrams, _, unknown = parser.encode(question)
    assert unknown == ("zorblax",) and ngrams.shape[0] == words.shape[0] and int(ngrams[6].gt(0).sum()) > 3
    _, _, bare, _, _ = QuestionParser(small, unknown_words=False).encode(question)
    assert int(bare[6].gt(0).sum()) == 0  # the ablation: an unknown word is a bare <unk>
    assert parser.parse(question).candidates
