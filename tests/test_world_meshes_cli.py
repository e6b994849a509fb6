"""``po3d world meshes``: GLB files coloured by part, the colour key, the contact sheet; one-line errors."""

from __future__ import annotations

import json
import sys

import cv2
import numpy as np
import pytest
import trimesh

from po3d_ppl import ontology
from po3d_ppl.cli import main
from po3d_ppl.world.meshes import vehicle_mesh
from po3d_ppl.world.meshes.export import part_palette


def run(monkeypatch, *args):
    monkeypatch.setattr(sys, "argv", ["po3d", "world", "meshes", *args])
    with pytest.raises(SystemExit) as exc:
        main()
    return exc.value.code


def test_meshes_command_writes_glb_colours_and_sheet(monkeypatch, tmp_path):
    out = tmp_path / "meshes"
    assert run(monkeypatch, "--out", str(out), "--subtype", "sedan", "--subtype", "jet", "--legends") in (0, None)
    for subtype in ("sedan", "jet"):
        vm = vehicle_mesh(subtype)
        glb = trimesh.load(out / f"{subtype}.glb", force="mesh")
        assert len(glb.faces) == len(vm.mesh.faces)
        # glTF is +y up: the vehicle's height is along y and its length along z
        np.testing.assert_allclose(glb.extents, vm.extents[[1, 2, 0]], rtol=1e-5)
        assert cv2.imread(str(out / f"legend_{subtype}.png")) is not None
    colors = json.loads((out / "part_colors.json").read_text())
    assert list(colors["sedan"]) == list(ontology.PARTS["sedan"])
    hood = ontology.PARTS["sedan"].index("hood")
    assert colors["sedan"]["hood"] == [round(c * 255) for c in part_palette(21)[hood]]
    sheet = cv2.imread(str(out / "contact_sheet.png"))
    assert sheet is not None and sheet.shape[0] >= 240 and sheet.shape[1] >= 640
    # not blank: vehicles in several colours on the white background
    assert len(np.unique(sheet.reshape(-1, 3), axis=0)) > 50


def test_unknown_subtype_is_a_one_line_error(monkeypatch, tmp_path, capsys):
    assert run(monkeypatch, "--out", str(tmp_path), "--subtype", "sedn") == 2
    err = capsys.readouterr().err
    assert "unknown subtype 'sedn'" in err and "sedan" in err and "Traceback" not in err
    assert not any(tmp_path.iterdir()), "nothing is written on bad input"


def test_unwritable_out_is_a_one_line_error(monkeypatch, tmp_path, capsys):
    blocker = tmp_path / "file"
    blocker.write_text("x")
    assert run(monkeypatch, "--out", str(blocker / "sub"), "--subtype", "road") == 2
    assert "--out" in capsys.readouterr().err
