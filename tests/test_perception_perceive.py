"""``po3d perceive``: the object parser's record as JSON and an overlay PNG of the masks its meshes own."""

from __future__ import annotations

import json
import sys

import cv2
import pytest
from typer.testing import CliRunner

from po3d_ppl import ontology
from po3d_ppl.cli import app, main
from po3d_ppl.world import generate_scene
from po3d_ppl.world.sampler import SceneConfig


@pytest.fixture(scope="module")
def image_path(tmp_path_factory):
    rendered = generate_scene(4, SceneConfig(min_objects=1, max_objects=1, width=320, height=240, camera_jitter=0.0))
    path = tmp_path_factory.mktemp("perceive") / "image.png"
    assert cv2.imwrite(str(path), rendered.image[..., ::-1])
    return path, rendered.scene.objects[0]


def test_perceive_writes_the_record_and_an_overlay(image_path, tmp_path):
    path, truth = image_path
    result = CliRunner().invoke(app, ["perceive", str(path), "--out", str(tmp_path / "out")])
    assert result.exit_code == 0, result.output
    record = json.loads((tmp_path / "out" / "proposals.json").read_text())
    believed = [p for p in record["proposals"] if p["existence_logodds"] > 0]
    assert len(believed) == 1
    assert max(believed[0]["category"], key=believed[0]["category"].get) == ontology.CATEGORY_OF[truth.subtype]
    assert believed[0]["visible_pixels"] > 0 and sum(believed[0]["category"].values()) == pytest.approx(1.0)
    overlay = cv2.imread(str(tmp_path / "out" / "overlay.png"))
    assert overlay is not None and overlay.shape == (480, 640, 3)  # drawn at the parser's working size
    assert "1 objects" in result.output
    reading = json.loads((tmp_path / "out" / "evidence.json").read_text())
    assert len(reading["objects"]) == 1
    assert ontology.CATEGORY_OF[next(iter(reading["objects"][0]["subtype"]))] == ontology.CATEGORY_OF[truth.subtype]
    assert cv2.imread(str(tmp_path / "out" / "scene.png")).shape == (480, 640, 3)
    from safetensors import safe_open

    from po3d_ppl.evaluation.cache import evidence_from_tensors

    with safe_open(str(tmp_path / "out" / "evidence.safetensors"), framework="pt") as f:
        evidence = evidence_from_tensors({k: f.get_tensor(k) for k in f.keys()}, f.metadata())  # noqa: SIM118
    assert evidence.num_objects == 1 and evidence.camera is not None


def test_an_unreadable_image_is_a_one_line_error(monkeypatch, capsys, tmp_path):
    bad = tmp_path / "bad.png"
    bad.write_bytes(b"not a png")
    monkeypatch.setattr(sys, "argv", ["po3d", "perceive", str(bad), "--out", str(tmp_path / "out")])
    with pytest.raises(SystemExit) as stopped:
        main()
    err = capsys.readouterr().err
    assert stopped.value.code == 2 and err.startswith("error: ") and err.count("\n") == 1, err
    assert "bad.png" in err and "not a readable image" in err
