"""The parser ensemble (po3d_ppl/language/seq2seq/ensemble.py) on the shipped parser: one member is the parser
itself, copies of a member change nothing, teacher forcing reproduces the beam's scores, and the combined n-best
probabilities are a (sub-)distribution; `po3d parse --parser-dir`."""

from __future__ import annotations

import json
import math

import pytest
from typer.testing import CliRunner

from po3d_ppl.cli import app
from po3d_ppl.errors import InputError
from po3d_ppl.language import QuestionParser, parse_program
from po3d_ppl.language.seq2seq.ensemble import RULES, ParserEnsemble, combine, sequence_log_probs
from po3d_ppl.model_store import models_dir

pytestmark = pytest.mark.usefixtures("torch_one_thread")

QUESTIONS = ("What color is the front wheel of the big red car?",
             "Is the number of blorp trucks greater than the number of sednas?")


@pytest.fixture(scope="module")
def shipped(torch_one_thread) -> QuestionParser:
    return QuestionParser.load()


def _tokens(parse) -> list[tuple[str, ...]]:
    return [tuple(c.tokens) for c in parse.candidates]


@pytest.mark.parametrize("rule", RULES)
def test_an_ensemble_of_one_is_the_parser(shipped, rule):
    for question in QUESTIONS:
        single = shipped.parse(question, n=3)
        alone = ParserEnsemble([shipped], rule).parse(question, n=3)
        assert alone.best.tokens == single.best.tokens
        assert _tokens(alone) == _tokens(single)
        assert [c.log_prob for c in alone.candidates] == pytest.approx([c.log_prob for c in single.candidates])
        assert sum(c.probability for c in alone.candidates) <= 1 + 1e-6
        assert alone.confidence == pytest.approx(single.confidence)
        assert (alone.unknown_words, alone.corrections) == (single.unknown_words, single.corrections)


@pytest.mark.parametrize("rule", RULES)
def test_two_copies_give_the_distribution_of_one(shipped, rule):
    question = QUESTIONS[1]
    once = ParserEnsemble([shipped], rule).parse(question, n=4)
    twice = ParserEnsemble([shipped, shipped], rule).parse(question, n=4)
    assert _tokens(twice) == _tokens(once)
    assert [c.probability for c in twice.candidates] == pytest.approx([c.probability for c in once.candidates])


def test_different_members_combine_into_a_sub_distribution(shipped):
    # Without the unknown-word mechanism the typo'd question reads differently: two members that disagree.
    bare = QuestionParser(shipped.trained, unknown_words=False)
    for rule in RULES:
        parse = ParserEnsemble([shipped, bare], rule).parse(QUESTIONS[1], n=5)
        probabilities = [c.probability for c in parse.candidates]
        assert probabilities == sorted(probabilities, reverse=True)
        assert 0 < sum(probabilities) <= 1 + 1e-6
        assert len(set(_tokens(parse))) == len(parse.candidates)


def test_teacher_forcing_reproduces_the_beam_and_rejects_what_cannot_be_said(shipped):
    question = QUESTIONS[0]
    parse = shipped.parse(question, n=4)
    _, words, ngrams, _, _ = shipped.encode(question)
    programs = [c.program for c in parse.candidates] + [parse_program("scene()")]  # not a question's type
    scores = sequence_log_probs(shipped, words, ngrams, programs)
    assert scores[:-1] == pytest.approx([c.log_prob for c in parse.candidates], abs=1e-4)
    assert scores[-1] == -math.inf


def test_combination_rules():
    a, b = math.log(0.5), math.log(0.1)
    assert combine([a, b], "product") == pytest.approx(math.log(math.sqrt(0.05)))
    assert combine([a, b], "mixture") == pytest.approx(math.log(0.3))
    assert combine([a, -math.inf], "product") == -math.inf
    assert combine([a, -math.inf], "mixture") == pytest.approx(math.log(0.25))
    with pytest.raises(InputError):
        ParserEnsemble([], "mixture")


def test_cli_parses_with_an_ensemble(shipped):
    question = QUESTIONS[0]
    result = CliRunner().invoke(app, ["parse", question, "--n", "2", "--json", "--parser-dir", str(models_dir())])
    assert result.exit_code == 0, result.output
    programs = json.loads(result.output)["programs"]
    assert [p["tokens"] for p in programs] == [c.tokens for c in shipped.parse(question, n=2).candidates]
    bad = CliRunner().invoke(app, ["parse", question, "--parser-dir", str(models_dir()), "--ensemble-rule", "vote"])
    assert bad.exit_code != 0


# ----- the shipped ensemble (models/manifest.json: question_parser_ensemble) -----------------------------------------

SHIPPED_MEMBERS = ["question_parser", "question_parser_cr_seed0", "question_parser_w2_seed2"]


@pytest.fixture(scope="module")
def shipped_ensemble(torch_one_thread):
    from po3d_ppl.language import load_question_parser

    return load_question_parser()


def test_the_default_loader_returns_the_shipped_ensemble(shipped_ensemble, shipped):
    from po3d_ppl.language import load_question_parser

    assert isinstance(shipped_ensemble, ParserEnsemble)
    assert shipped_ensemble.names == SHIPPED_MEMBERS and shipped_ensemble.rule == "mixture"
    assert shipped_ensemble.calibration is not None  # its own, fitted by po3d train parser-ensemble
    single = load_question_parser(single=True)
    assert isinstance(single, QuestionParser)
    assert single.parse(QUESTIONS[0]).best.tokens == shipped.parse(QUESTIONS[0]).best.tokens
    parse = shipped_ensemble.parse(QUESTIONS[0], n=3)
    assert parse.best.tokens == shipped.parse(QUESTIONS[0]).best.tokens
    assert 0 < sum(c.probability for c in parse.candidates) <= 1 + 1e-6 and 0 < parse.confidence < 1
    bare = load_question_parser(unknown_words=False)
    assert all(not m.unknown_words for m in bare.members)


def _copy_parsers(tmp_path):
    """models/'s parser files and manifest in ``tmp_path`` (the perception entries' files are not needed)."""
    import shutil

    directory = tmp_path / "models"
    directory.mkdir()
    for path in models_dir().iterdir():
        if path.name == "manifest.json" or path.name.startswith("question_parser"):
            shutil.copyfile(path, directory / path.name)
    return directory


def test_a_corrupt_or_missing_member_is_a_typed_error_naming_the_file(tmp_path, torch_one_thread):
    from po3d_ppl.errors import ModelFileError
    from po3d_ppl.language import load_question_parser

    directory = _copy_parsers(tmp_path)
    weights = directory / "question_parser_w2_seed2.safetensors"
    data = bytearray(weights.read_bytes())
    data[len(data) // 2] ^= 0xFF
    weights.write_bytes(bytes(data))
    with pytest.raises(ModelFileError, match=r"question_parser_w2_seed2\.safetensors does not match its sha256"):
        load_question_parser(directory)
    assert isinstance(load_question_parser(directory, single=True), QuestionParser)  # the ablation still loads
    (directory / "question_parser_cr_seed0.vocab.json").unlink()
    with pytest.raises(ModelFileError, match=r"question_parser_cr_seed0\.vocab\.json is missing"):
        load_question_parser(directory)
    (directory / "question_parser_ensemble.json").write_text("{}")
    with pytest.raises(ModelFileError, match=r"question_parser_ensemble\.json"):
        load_question_parser(directory)


def test_a_directory_without_an_ensemble_loads_its_single_parser(tmp_path, torch_one_thread):
    from po3d_ppl.language import load_question_parser
    from po3d_ppl.model_store import read_manifest

    directory = _copy_parsers(tmp_path)
    manifest = read_manifest(directory)
    del manifest["question_parser_ensemble"]
    (directory / "manifest.json").write_text(json.dumps(manifest))
    assert isinstance(load_question_parser(directory), QuestionParser)


def test_cli_parses_with_the_shipped_ensemble_or_the_single_parser(shipped_ensemble, shipped):
    question = QUESTIONS[1]
    default = CliRunner().invoke(app, ["parse", question, "--n", "3", "--json"])
    single = CliRunner().invoke(app, ["parse", question, "--n", "3", "--json", "--single-parser"])
    assert default.exit_code == 0 and single.exit_code == 0, default.output + single.output
    assert json.loads(default.output)["confidence"] == pytest.approx(shipped_ensemble.parse(question, n=3).confidence)
    assert [p["tokens"] for p in json.loads(single.output)["programs"]] == [
        c.tokens for c in shipped.parse(question, n=3).candidates]


def test_the_joint_beam_scores_each_candidate_as_its_members_do(shipped_ensemble):
    """The shipped members share their targets, so the ensemble decodes with one joint beam: each candidate's score
    is the rule applied to the members' own (teacher-forced) log-probabilities of it, and the top programs are
    the re-scoring path's."""
    assert shipped_ensemble.joint
    for question in QUESTIONS:
        joint = shipped_ensemble.parse(question, n=3)
        for candidate in joint.candidates:
            per_member = []
            for member in shipped_ensemble.members:
                _, words, ngrams, _, _ = member.encode(question)
                per_member += sequence_log_probs(member, words, ngrams, [candidate.program])
            assert candidate.log_prob == pytest.approx(combine(per_member, shipped_ensemble.rule), abs=1e-4)
        shipped_ensemble.joint = False
        try:
            rescored = shipped_ensemble.parse(question, n=3)
        finally:
            shipped_ensemble.joint = True
        assert _tokens(joint)[0] == _tokens(rescored)[0]
        assert joint.candidates[0].log_prob == pytest.approx(rescored.candidates[0].log_prob, abs=1e-4)
