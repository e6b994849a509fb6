"""``po3d answer`` end to end on a scene file."""

from __future__ import annotations

import json

import pytest
from typer.testing import CliRunner

from po3d_ppl.cli import app
from po3d_ppl.questions.toy_scenes import toy_object, toy_scene
from po3d_ppl.world.scene_io import save_scene

runner = CliRunner()


@pytest.fixture(scope="module")
def scene_file(tmp_path_factory):
    path = tmp_path_factory.mktemp("answer") / "scene.json"
    save_scene(toy_scene([toy_object("suv", "red", position=(0, 0, 0)), toy_object("jet", "blue", position=(1, 2, 0)),
                          toy_object("double", "red", position=(-2, 1, 0))]), path)
    return path


def test_answer_prints_a_distribution(scene_file):
    result = runner.invoke(app, ["answer", "--scene", str(scene_file), "--program",
                                 "count(filter_color[red](scene()))", "--json"])
    assert result.exit_code == 0, result.output
    out = json.loads(result.output)
    assert out["top"] == 2 and out["method"] == "exact" and out["probs"] == [[2, 1.0]]


def test_noisy_evidence_and_sampling(scene_file, tmp_path):
    program = tmp_path / "program.json"
    program.write_text(json.dumps([{"type": "scene", "inputs": []},
                                   {"type": "filter_shape", "inputs": [0], "value_inputs": ["bus"]},
                                   {"type": "unique", "inputs": [1]}, {"type": "query_color", "inputs": [2]}]))
    result = runner.invoke(app, ["answer", "--scene", str(scene_file), "--program", str(program), "--noise", "0.2",
                                 "--method", "sampling", "--samples", "2000", "--json"])
    assert result.exit_code == 0, result.output
    out = json.loads(result.output)
    assert out["method"] == "sampling" and 0 < out["probs"][0][1] < 1 and out["error"] > 0


@pytest.mark.parametrize("args, message", [
    (["--program", "count(filter_color[pink](scene()))"], "unknown Color value 'pink'"),
    (["--program", "count(scene()", "--method", "exact"], "line 1, column"),
    (["--program", "count(scene())", "--method", "magic"], "unknown inference method 'magic'"),
    (["--program", "count(scene())", "--samples", "0"], "--samples"),
    ([], "give exactly one of a question or --program"),
])
def test_bad_input_is_one_line_with_exit_code_2(scene_file, args, message):
    import subprocess
    import sys

    from po3d_ppl.cli import main  # noqa: F401  (errors are turned into exit code 2 by main)

    proc = subprocess.run([sys.executable, "-m", "po3d_ppl", "answer", "--scene", str(scene_file), *args],
                          capture_output=True, text=True)
    assert proc.returncode == 2, proc.stderr
    assert message in proc.stderr and "Traceback" not in proc.stderr


def test_demo_answers_rendered_questions_with_certain_evidence(tmp_path):
    """The README's main job, end to end (render, generate, parse, infer): with certain evidence every top answer
    is the question's ground truth, and invalid mass can only come from the parser's less likely programs."""
    result = runner.invoke(app, ["demo", "--out", str(tmp_path), "--questions", "4", "--evidence", "simulated",
                                 "--noise", "0"])
    assert result.exit_code == 0, result.output
    assert (tmp_path / "image.png").stat().st_size > 0 and (tmp_path / "scene.json").is_file()
    report = json.loads((tmp_path / "answers.json").read_text())
    assert len(report) == 4
    for row in report:
        answer = row["answer"]
        assert answer["invalid"] <= 1.0 - row["parses"][0]["probability"] + 1e-9
        assert str(answer["top"]).lower() == str(row["truth"]).lower(), row


def test_demo_reads_the_image_by_default(tmp_path):
    """The default demo parses the pixels (no ground truth) and writes the overlay of what perception read."""
    result = runner.invoke(app, ["demo", "--out", str(tmp_path), "--questions", "2"])
    assert result.exit_code == 0, result.output
    assert "perception on the image" in result.output
    assert (tmp_path / "overlay.png").stat().st_size > 0
    assert len(json.loads((tmp_path / "answers.json").read_text())) == 2
