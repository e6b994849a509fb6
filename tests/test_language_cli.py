"""`po3d parse`, `po3d train parser` and `po3d eval parser` end to end, on a small dataset directory written here."""

from __future__ import annotations

import json

import pytest
from language_pairs import PAIRS
from typer.testing import CliRunner

from po3d_ppl.cli import app
from po3d_ppl.language import parse_program, program_to_json

pytestmark = pytest.mark.usefixtures("torch_one_thread")


@pytest.fixture(scope="module")
def dataset(tmp_path_factory):
    """The layout `po3d dataset build` writes, with the hand-made pairs as questions (no images needed)."""
    root = tmp_path_factory.mktemp("dataset")
    (root / "questions").mkdir()
    records: dict[str, list] = {}
    for i, (source, question, text) in enumerate(PAIRS):
        records.setdefault(source, []).append({
            "image_index": i % 4, "question": question, "program": program_to_json(parse_program(text)),
            "template_filename": f"{source}.json", "question_family_index": i})
    for source, rows in records.items():
        (root / "questions" / f"{source}.json").write_text(json.dumps({"info": {}, "questions": rows}))
    (root / "splits.json").write_text(json.dumps({"train": [0, 1, 2, 3], "val": [3], "test": [0, 1]}))
    (root / "scenes.json").write_text(json.dumps({"info": {}, "scenes": []}))
    (root / "manifest.json").write_text(json.dumps({"seed": 77, "config": {"scenes": 4}}))
    return root


def test_train_then_eval_then_parse(dataset, tmp_path):
    runner = CliRunner()
    out = tmp_path / "model"
    result = runner.invoke(app, ["train", "parser", "--data", str(dataset), "--epochs", "1", "--max-steps", "2",
                                 "--hidden", "16", "--embed", "8", "--out", str(out)])
    assert result.exit_code == 0, result.output
    manifest = json.loads((out / "manifest.json").read_text())["question_parser"]
    assert set(manifest["files"]) == {"question_parser.safetensors", "question_parser.vocab.json"}
    assert manifest["data_seed"] == [77]
    assert manifest["command"].startswith("po3d train parser --data")
    assert manifest["metrics"]["train_questions"] == len(PAIRS)

    report_path = tmp_path / "eval.json"
    result = runner.invoke(app, ["eval", "parser", "--data", str(dataset), "--split", "test", "--model-dir",
                                 str(out), "--json", str(report_path), "--record"])
    assert result.exit_code == 0, result.output
    report = json.loads(report_path.read_text())
    recorded = json.loads((out / "manifest.json").read_text())["question_parser"]["metrics"]["eval_seed77_test"]
    assert recorded["exact_match"] == report["exact_match"] and recorded["command"].startswith("po3d eval parser")
    assert report["count"] == sum(1 for i in range(len(PAIRS)) if i % 4 in (0, 1))
    assert set(report["per_file"]) <= {"parts", "pose", "occlusion", "obj_occlusion", "core"}
    assert 0.0 <= report["exact_match"] <= report["in_n_best"] <= 1.0

    result = runner.invoke(app, ["parse", "How many zorblax things are there?", "--n", "2", "--json",
                                 "--model-dir", str(out)])
    assert result.exit_code == 0, result.output
    parsed = json.loads(result.output)
    assert parsed["unknown_words"] == ["zorblax"]
    assert len(parsed["programs"]) == 2
    for candidate in parsed["programs"]:
        assert parse_program(candidate["program"]) == parse_program(candidate["program"])
        assert 0.0 < candidate["probability"] <= 1.0


def test_missing_model_is_one_clear_error(tmp_path):
    result = CliRunner().invoke(app, ["parse", "How many cars?", "--model-dir", str(tmp_path)])
    assert result.exit_code != 0
    assert "question_parser" in str(result.exception)


def test_bad_dataset_directory(tmp_path):
    result = CliRunner().invoke(app, ["train", "parser", "--data", str(tmp_path / "nope")])
    assert result.exit_code != 0
    assert "--data" in str(result.exception) or "not a directory" in str(result.exception)


def test_a_named_parser_has_its_own_files_entry_and_command(dataset, tmp_path):
    """``--name``: an ensemble member is written, recorded and loaded under its own name, beside the default one."""
    from po3d_ppl.language import QuestionParser

    out = tmp_path / "model"
    result = CliRunner().invoke(app, ["train", "parser", "--data", str(dataset), "--epochs", "1", "--max-steps", "1",
                                      "--hidden", "16", "--embed", "8", "--out", str(out), "--name", "member_b"])
    assert result.exit_code == 0, result.output
    manifest = json.loads((out / "manifest.json").read_text())
    assert set(manifest) == {"member_b"}
    assert set(manifest["member_b"]["files"]) == {"member_b.safetensors", "member_b.vocab.json"}
    assert manifest["member_b"]["command"].endswith("--name member_b")
    assert QuestionParser.load(out, name="member_b").parse("How many cars are there?").candidates


@pytest.mark.parametrize("name", ["", "Member", "1st", "a/b", "x" * 65])
def test_a_bad_parser_name_is_a_typed_error(name, tmp_path):
    from po3d_ppl.errors import InputError

    result = CliRunner().invoke(app, ["train", "parser", "--corpus", "10", "--name", name, "--out", str(tmp_path)])
    assert isinstance(result.exception, InputError) and "--name" in str(result.exception)
