"""The CLI prints every error and every user-provided text literally, and bad input is a typed one-line error.

Regression tests of issue 10 ("Reliability"): rich read ``[...]`` in messages, paths and programs as markup
(``[/x]`` crashed, other brackets vanished), and negative seeds or non-UTF-8 program files escaped as numpy /
codec tracebacks. Commands run in-process: through :func:`po3d_ppl.cli.main` where the error printing is under
test, through typer's CliRunner otherwise.
"""

from __future__ import annotations

import json
import sys

import pytest
from typer.testing import CliRunner

from po3d_ppl.cli import app, main
from po3d_ppl.questions.toy_scenes import toy_object, toy_scene
from po3d_ppl.world.scene_io import save_scene

runner = CliRunner()


@pytest.fixture(scope="module")
def scene_file(tmp_path_factory):
    path = tmp_path_factory.mktemp("reliability") / "scene.json"
    save_scene(toy_scene([toy_object("suv", "red", position=(0, 0, 0)), toy_object("jet", "blue", position=(1, 2, 0)),
                          toy_object("sedan", "red", position=(-2, 1, 0))]), path)
    return path


def run_main(monkeypatch, capsys, *args: str) -> tuple[int, str, str]:
    """(exit code, stdout, stderr) of ``po3d ARGS`` run by the real entry point, in this process."""
    monkeypatch.setattr(sys, "argv", ["po3d", *args])
    with pytest.raises(SystemExit) as stopped:
        main()
    out = capsys.readouterr()
    return stopped.value.code or 0, out.out, out.err


def assert_one_line_error(code: int, err: str, *fragments: str) -> None:
    assert code == 2, err
    assert "Traceback" not in err and err.startswith("error: ") and err.count("\n") == 1, err
    for fragment in fragments:
        assert fragment in err, (fragment, err)


# ---- errors and texts are printed literally -----------------------------------------------------------------------
@pytest.mark.parametrize("path", ["[/x].json", "[bold]x.json", "[red]a[/red].json"])
def test_paths_with_brackets_are_printed_as_given(monkeypatch, capsys, tmp_path, path):
    code, _, err = run_main(monkeypatch, capsys, "answer", "--scene", str(tmp_path / path), "--program", "count(scene())")
    assert_one_line_error(code, err, str(tmp_path / path))


def test_caret_snippet_keeps_its_values_and_column(monkeypatch, capsys, scene_file):
    code, _, err = run_main(monkeypatch, capsys, "answer", "--scene", str(scene_file), "--program",
                            "count(filter_shape[car](scene())")
    assert code == 2 and "Traceback" not in err
    lines = err.splitlines()
    assert lines[1] == "  count(filter_shape[car](scene())"
    assert lines[2].index("^") == len(lines[1])  # column 33: just past the end of the program


@pytest.mark.parametrize("program, hint", [
    ("count(filter_shape(scene()))", "e.g. filter_shape[suv](...)"),
    ("count(scene[car]())", "got [car]; write scene(...) without brackets"),
])
def test_hints_keep_their_brackets(monkeypatch, capsys, scene_file, program, hint):
    code, _, err = run_main(monkeypatch, capsys, "answer", "--scene", str(scene_file), "--program", program)
    assert code == 2 and hint in err, err
    assert program in err.splitlines()[1]


def test_long_errors_are_not_wrapped_at_the_console_width(monkeypatch, capsys, tmp_path):
    monkeypatch.setenv("COLUMNS", "40")
    missing = tmp_path / ("a-long-directory-name-" * 4) / "scene.json"
    code, _, err = run_main(monkeypatch, capsys, "answer", "--scene", str(missing), "--program", "count(scene())")
    assert_one_line_error(code, err, str(missing))


def test_answer_prints_parses_with_their_values(scene_file):
    result = runner.invoke(app, ["answer", "--scene", str(scene_file), "How many [/x] cars are there?",
                                 "--parses", "2"], env={"COLUMNS": "200"})
    assert result.exit_code == 0, result.output
    lines = result.output.splitlines()
    # "x" is an unknown word where an adjective goes: the parser may read it as a filter, with a warning
    assert "count(filter_shape[car](" in lines[0], result.output
    assert all("[" in line for line in lines[:2]), result.output  # no parse lost its values
    assert any(line.startswith("unknown words:") for line in lines), result.output


def test_execute_prints_invalid_reasons_literally(scene_file):
    program = json.dumps([{"type": "scene", "inputs": []}, {"type": "unique", "inputs": [0]},
                          {"type": "query_shape", "inputs": [1]}])
    result = runner.invoke(app, ["execute", "--scene", str(scene_file), "--program", program])
    assert result.exit_code == 1 and "invalid: program[1] (unique)" in result.output, result.output


def test_render_prints_its_output_path_literally(tmp_path):
    out = tmp_path / "[/x]" / "[bold]scene"
    result = runner.invoke(app, ["world", "render", "--seed", "1", "--out", str(out), "--objects", "1", "--width", "160",
                                 "--height", "120"], env={"COLUMNS": "400"})
    assert result.exit_code == 0, result.output
    assert result.output.startswith(f"{out}: 1 objects"), result.output


def test_dataset_build_and_stats_print_paths_literally(tmp_path):
    out = tmp_path / "[/x]" / "[bold]data"
    env = {"COLUMNS": "400"}
    built = runner.invoke(app, ["dataset", "build", "--out", str(out), "--scenes", "2", "--width", "160", "--height",
                                "120"], env=env)
    assert built.exit_code == 0, built.output
    assert f"{out}: 2 scenes (2 built, 0 already done)" in built.output, built.output
    stats = runner.invoke(app, ["dataset", "stats", str(out)], env=env)
    assert stats.exit_code == 0, stats.output
    assert f"{out}: 2 scenes" in stats.output, stats.output


# ---- typed one-line errors ----------------------------------------------------------------------------------------
@pytest.mark.parametrize("command", [
    ["answer", "--program", "count(scene())", "--noise", "0.1"],
    ["demo"],
    ["dataset", "build", "--scenes", "1"],
    ["train", "parser", "--data", "{tmp}"],
    ["world", "render"],
])
@pytest.mark.parametrize("seed", ["-1", str(2**64)])
def test_bad_seeds_are_one_line_errors_naming_the_option(monkeypatch, capsys, scene_file, tmp_path, command, seed):
    command = [arg.replace("{tmp}", str(tmp_path)) for arg in command]
    if command[0] == "answer":
        command += ["--scene", str(scene_file)]
    elif command[0] in ("demo", "dataset", "world"):
        command += ["--out", str(tmp_path / "out")]
    code, _, err = run_main(monkeypatch, capsys, *command, "--seed", seed)
    assert_one_line_error(code, err, "--seed", seed)
    assert not (tmp_path / "out").exists()  # refused before any work


@pytest.mark.parametrize("command", ["answer", "execute"])
def test_program_file_that_is_not_utf8_is_a_one_line_error(monkeypatch, capsys, scene_file, tmp_path, command):
    program = tmp_path / "program.txt"
    program.write_bytes("count(filter_color[red](scene()))  # déjà".encode("latin-1"))
    code, _, err = run_main(monkeypatch, capsys, command, "--scene", str(scene_file), "--program", str(program))
    assert_one_line_error(code, err, "--program", str(program), "not UTF-8", "save it as UTF-8")
