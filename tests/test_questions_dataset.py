"""Dataset builds with the real renderer: correctness of every question, coverage, balance, determinism,
resumability and atomic writes.

The suite's one 200-scene build (``conftest.shared_dataset``: 320x240, 2 workers, elevated aeroplanes so that every
family can occur) is shared with the reasoning tests; the determinism and resume tests use tiny builds of their own.
"""

from __future__ import annotations

import filecmp
import json
import os
import subprocess
import sys
import time
from collections import Counter, defaultdict
from pathlib import Path

import pytest

from po3d_ppl.errors import InputError
from po3d_ppl.questions import dataset as ds
from po3d_ppl.questions.dataset import BuildConfig, build_dataset
from po3d_ppl.questions.executor import execute
from po3d_ppl.questions.generator import answer_support
from po3d_ppl.questions.question_sets import question_sets
from po3d_ppl.questions.template_format import load_template_file
from po3d_ppl.questions.verbalise import verbalise_answer

pytestmark = pytest.mark.slow

SCENES = 200
SMALL = BuildConfig(scenes=3, seed=7, width=320, height=240)


@pytest.fixture(scope="module")
def built(shared_dataset):
    return shared_dataset


def _files(root: Path) -> list[Path]:
    return sorted(p.relative_to(root) for p in root.rglob("*") if p.is_file())


def test_layout_and_manifest(built):
    root, report, data = built
    assert report.built == SCENES and report.skipped == 0
    assert len(list((root / "images").glob("superCLEVR_new_*.png"))) == SCENES
    assert len(data.public_scenes) == SCENES
    assert [len(data.splits[k]) for k in ("train", "val", "test")] == [133, 33, 34]
    assert data.splits["train"] == list(range(133))
    counts = data.manifest["counts"]["questions"]
    assert set(counts) == set(question_sets(height_depth=True)) == set(data.questions)
    assert counts == {k: len(v) for k, v in data.questions.items()}
    per_scene = sum(counts.values()) / SCENES
    assert 25 <= per_scene <= 38
    first = data.questions["parts"][0]
    assert set(first) == {"image_index", "image_filename", "split", "question", "program", "answer",
                          "template_filename", "question_family_index", "question_index"}
    assert [q["question_index"] for q in data.questions["pose"]] == list(range(counts["pose"]))
    import cv2

    image = cv2.imread(str(data.image_path(0)))
    assert image.shape == (240, 320, 3)


def test_every_question_reexecutes_to_its_answer_on_the_saved_scene(built):
    _, _, data = built
    scenes = {}
    for name, questions in data.questions.items():
        for q in questions:
            index = q["image_index"]
            if index not in scenes:
                scenes[index] = data.scene(index)
                assert data.public_scenes[index]["split"] == q["split"]
            result = execute(scenes[index], q["program"])
            assert result.valid, (name, q["question"], result.reason)
            assert result.public_outputs() == [n["_output"] for n in q["program"]], q["question"]
            assert verbalise_answer(result.answer, result.answer_type) == q["answer"]
            for node in q["program"]:  # every unique referent is unambiguous
                if node["type"] == "unique":
                    assert len(q["program"][node["inputs"][0]]["_output"]) == 1


def test_every_family_appears(built):
    _, _, data = built
    for name, qset in question_sets(height_depth=True).items():
        seen = {(q["template_filename"], q["question_family_index"]) for q in data.questions[name]}
        assert seen == set(qset.families), (name, set(qset.families) - seen)


def test_answers_are_not_degenerate(built):
    _, _, data = built
    for name, questions in data.questions.items():
        groups = defaultdict(list)
        for q in questions:
            groups[(q["template_filename"], q["question_family_index"])].append(json.dumps(q["answer"]))
        for (filename, index), answers in groups.items():
            answer_type = load_template_file(filename)[index].answer_type
            support = answer_support(answer_type)
            top = Counter(answers).most_common(1)[0][1] / len(answers)
            if support >= 3 and len(answers) >= 10:
                assert top <= 0.5, (name, filename, index, Counter(answers).most_common(3))
            if len(answers) >= 10:
                assert len(set(answers)) >= 2, (name, filename, index)


def test_dataset_splits(built):
    _, _, data = built
    val = data.split("val")
    assert [s.image_index for s in val.scenes] == data.splits["val"]
    assert all(q["split"] == "val" and q["image_index"] in data.splits["val"] for q in val.questions["core"])
    assert sum(len(v) for v in val.questions.values()) > 0
    with pytest.raises(InputError, match="unknown split 'dev'"):
        data.split("dev")


def test_same_seed_gives_byte_identical_files_whatever_the_workers(tmp_path):
    one, two = tmp_path / "one", tmp_path / "two"
    build_dataset(one, SMALL, workers=1)
    build_dataset(two, SMALL, workers=2)
    assert _files(one) == _files(two)
    for rel in _files(one):
        assert filecmp.cmp(one / rel, two / rel, shallow=False), rel
    other = tmp_path / "other"
    build_dataset(other, BuildConfig(**{**SMALL.__dict__, "seed": 8, "scenes": 1}), workers=1)
    first = [json.loads((d / "scenes.json").read_text())["scenes"][0]["objects"] for d in (one, other)]
    assert first[0] != first[1]


def test_killed_build_resumes_to_the_same_result(tmp_path):
    config = BuildConfig(scenes=4, seed=11, width=320, height=240)
    clean = tmp_path / "clean"
    build_dataset(clean, config, workers=1)
    killed = tmp_path / "killed"
    cmd = [sys.executable, "-m", "po3d_ppl", "dataset", "build", "--out", str(killed), "--scenes", "4", "--seed",
           "11", "--width", "320", "--height", "240"]
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        deadline = time.monotonic() + 120
        while not ds.work_path(killed, 1).exists() and time.monotonic() < deadline and proc.poll() is None:
            time.sleep(0.05)
        proc.kill()
    finally:
        proc.wait()
    assert ds.work_path(killed, 0).exists() and not (killed / "manifest.json").exists()
    for work in (killed / "work").glob("*.gz"):  # whatever exists is complete
        scene_text, candidates = ds._read_work(killed, int(work.name[6:12]))
        assert json.loads(scene_text)["objects"] and candidates
    report = build_dataset(killed, config, workers=1)
    assert report.skipped >= 2 and report.built + report.skipped == 4
    again = build_dataset(killed, config, workers=1)
    assert again.built == 0 and again.skipped == 4
    assert _files(clean) == _files(killed)
    for rel in _files(clean):
        assert filecmp.cmp(clean / rel, killed / rel, shallow=False), rel


def test_writes_are_atomic(tmp_path, monkeypatch):
    root = tmp_path / "d"
    build_dataset(root, SMALL, workers=1)
    before = (root / "questions" / "core.json").read_bytes()
    stale = root / "work" / ".scene_000001.json.gz.999.tmp"
    stale.write_bytes(b"half")

    def broken_replace(src, dst):
        raise OSError("disk full")

    monkeypatch.setattr(os, "replace", broken_replace)
    with pytest.raises(OSError, match="disk full"):
        build_dataset(root, SMALL, workers=1)
    monkeypatch.undo()
    assert (root / "questions" / "core.json").read_bytes() == before
    assert not list(root.rglob("*.tmp")), "temporary files were left behind or not cleaned"
    target = root / "x.bin"
    target.write_bytes(b"old")
    monkeypatch.setattr(os, "replace", broken_replace)
    with pytest.raises(OSError):
        ds.atomic_write_bytes(target, b"new content")
    monkeypatch.undo()
    assert target.read_bytes() == b"old"


def test_changed_settings_are_refused(tmp_path):
    root = tmp_path / "d"
    (root).mkdir()
    (root / "build_config.json").write_text(json.dumps(SMALL.to_json()))
    with pytest.raises(InputError, match="different settings \\(seed\\)"):
        build_dataset(root, BuildConfig(**{**SMALL.__dict__, "seed": 99}), workers=1)
    with pytest.raises(InputError, match="split_fractions"):
        BuildConfig(scenes=3, split_fractions=(0.5, 0.5, 0.5))
