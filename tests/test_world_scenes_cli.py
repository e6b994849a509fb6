"""``po3d world render``: the files it writes, and one-line errors (exit code 2) for bad options."""

import sys

import cv2
import numpy as np
import pytest

from po3d_ppl.cli import main
from po3d_ppl.world import rle
from po3d_ppl.world.scene_io import load_scene


def run(monkeypatch, *args):
    monkeypatch.setattr(sys, "argv", ["po3d", "world", "render", *args])
    with pytest.raises(SystemExit) as exc:
        main()
    return exc.value.code


def test_render_writes_image_scene_and_masks(monkeypatch, tmp_path, capsys):
    out = tmp_path / "scene"
    assert run(monkeypatch, "--seed", "4", "--out", str(out), "--objects", "3", "--width", "320", "--height",
               "240") in (0, None)
    image = cv2.imread(str(out / "image.png"))
    masks = cv2.imread(str(out / "masks.png"))
    assert image.shape == masks.shape == (240, 320, 3)
    scene = load_scene(out / "scene.json")
    assert len(scene) == 3 and scene.camera.width == 320 and scene.camera.K[0, 0] == pytest.approx(350.0)
    for obj in scene.objects:
        mask = rle.decode(obj.annotation.visible_mask, 240, 320)
        assert mask.sum() >= 200
        assert len(np.unique(masks[mask].reshape(-1, 3), axis=0)) >= 2  # object colour, part shades, edges
    assert "3 objects" in capsys.readouterr().out


@pytest.mark.parametrize("args, option", [
    (["--seed", "-1"], "--seed"),
    (["--seed", "abc"], "--seed"),
    (["--seed", "1", "--objects", "0"], "--objects"),
    (["--seed", "1", "--objects", "many"], "--objects"),
    (["--seed", "1", "--width", "8"], "--width"),
    (["--seed", "1", "--height", "100000"], "--height"),
])
def test_bad_options_give_one_line_and_exit_code_2(monkeypatch, tmp_path, capsys, args, option):
    assert run(monkeypatch, *args, "--out", str(tmp_path / "x")) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and err.startswith("error:") and option in err
    assert not (tmp_path / "x").exists()
