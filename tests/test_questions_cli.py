"""``po3d execute`` and ``po3d dataset`` argument handling: answers, and one-line typed errors (exit code 2)."""

from __future__ import annotations

import json
import sys

import pytest

from po3d_ppl.cli import main
from po3d_ppl.questions.toy_scenes import toy_object, toy_scene
from po3d_ppl.world.scene_io import save_scene, save_scenes


def po3d(monkeypatch, capsys, *args: str) -> tuple[int, str, str]:
    monkeypatch.setattr(sys, "argv", ["po3d", *args])
    monkeypatch.setenv("COLUMNS", "400")  # rich wraps long messages at the terminal width
    code = 0
    try:
        main()
    except SystemExit as exc:
        code = exc.code or 0
    out = capsys.readouterr()
    return code, out.out, out.err


@pytest.fixture()
def scene_file(tmp_path):
    scene = toy_scene([toy_object("school", "red"), toy_object("utility", "blue", parts={"saddle": ("green", "metal")})])
    path = tmp_path / "scene.json"
    save_scene(scene, path)
    save_scenes([scene, scene], tmp_path / "scenes.json")
    return path


PROGRAM = [{"type": "scene", "inputs": []}, {"type": "filter_color", "inputs": [0], "value_inputs": ["red"]},
           {"type": "unique", "inputs": [1]}, {"type": "query_shape", "inputs": [2]}]


def test_execute_prints_raw_and_verbalised_answer(monkeypatch, capsys, scene_file, tmp_path):
    code, out, _ = po3d(monkeypatch, capsys, "execute", "--scene", str(scene_file), "--program", json.dumps(PROGRAM))
    assert code == 0 and "'school' -> 'school bus'" in out and "Shape" in out
    prog_file = tmp_path / "q.json"
    prog_file.write_text(json.dumps({"question": "?", "program": PROGRAM[:3]}))
    code, out, _ = po3d(monkeypatch, capsys, "execute", "--scene", str(scene_file), "--program", str(prog_file))
    assert code == 0 and "0  (Object)" in out
    code, out, _ = po3d(monkeypatch, capsys, "execute", "--scene", str(tmp_path / "scenes.json"), "--index", "1",
                        "--program", json.dumps(PROGRAM))
    assert code == 0 and "school bus" in out


def test_execute_reports_invalid_programs(monkeypatch, capsys, scene_file):
    prog = PROGRAM[:1] + [{"type": "unique", "inputs": [0]}, {"type": "query_color", "inputs": [1]}]
    code, out, _ = po3d(monkeypatch, capsys, "execute", "--scene", str(scene_file), "--program", json.dumps(prog))
    assert code == 1 and "invalid: program[1] (unique): unique of a set with 2 members" in out


@pytest.mark.parametrize(("args", "message"), [
    (["--program", json.dumps(PROGRAM[:1] + [{"type": "filter_colour", "inputs": [0], "value_inputs": ["red"]}])],
     "unknown operation 'filter_colour'; did you mean 'filter_color'"),
    (["--program", json.dumps(PROGRAM[:2] + [{"type": "unique", "inputs": [7]}])],
     "unique: input 7 must be the index of an earlier node (0..1) (node 2)"),
    (["--program", "[{"], "--program: not valid JSON"),
    (["--program", "no_such_file.json"], "is neither a JSON program list nor an existing file"),
    (["--program", json.dumps(PROGRAM), "--index", "3"], "--index: must be in 0..0"),
])
def test_execute_errors_are_one_line(monkeypatch, capsys, scene_file, args, message):
    code, out, err = po3d(monkeypatch, capsys, "execute", "--scene", str(scene_file), *args)
    assert code == 2
    assert message in err and "Traceback" not in err and len(err.strip().splitlines()) == 1


def test_execute_bad_scene_files(monkeypatch, capsys, tmp_path, scene_file):
    bad = tmp_path / "bad.json"
    data = json.loads(scene_file.read_text())
    data["objects"][0]["shape"] = "spaceship"
    bad.write_text(json.dumps(data))
    code, _, err = po3d(monkeypatch, capsys, "execute", "--scene", str(bad), "--program", json.dumps(PROGRAM))
    assert code == 2 and "spaceship" in err and "objects[0]" in err
    code, _, err = po3d(monkeypatch, capsys, "execute", "--scene", str(tmp_path / "scenes.json"),
                        "--program", json.dumps(PROGRAM))
    assert code == 2 and "holds 2 scenes" in err


def test_dataset_errors_are_one_line(monkeypatch, capsys, tmp_path):
    code, _, err = po3d(monkeypatch, capsys, "dataset", "build", "--out", str(tmp_path / "d"), "--scenes", "0")
    assert code == 2 and "scenes: must be at least 1" in err
    code, _, err = po3d(monkeypatch, capsys, "dataset", "build", "--out", str(tmp_path / "d"), "--scenes", "2",
                        "--workers", "0")
    assert code == 2 and "workers: must be a positive integer" in err
    code, _, err = po3d(monkeypatch, capsys, "dataset", "stats", str(tmp_path / "missing"))
    assert code == 2 and "is not a directory" in err
    (tmp_path / "half").mkdir()
    code, _, err = po3d(monkeypatch, capsys, "dataset", "stats", str(tmp_path / "half"))
    assert code == 2 and "manifest.json is missing" in err
