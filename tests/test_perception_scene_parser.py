"""The image's SceneEvidence: a hand-built occlusion read from pixels, empty images, and the calibration record."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from po3d_ppl.errors import ModelFileError
from po3d_ppl.evidence import SceneEvidence
from po3d_ppl.perception.calibration import TableCalibration, load_calibration
from po3d_ppl.perception.image_input import CameraPrior
from po3d_ppl.perception.scene_parser import SceneParserConfig, parse_scene
from po3d_ppl.world.generate import render_layout
from po3d_ppl.world.sampler import ObjectSpec


@pytest.fixture(scope="module")
def bus_behind_car():
    """A sedan in front of a school bus (the bus partly hidden), base camera."""
    specs = [ObjectSpec("school", "yellow", "rubber", "large", 30.0, -0.5, 0.5),
             ObjectSpec("sedan", "red", "metal", "large", 100.0, 1.2, -1.0)]
    return render_layout(specs, CameraPrior(640, 480).base)


@pytest.fixture(scope="module")
def parsed(bus_behind_car):
    return parse_scene(bus_behind_car.image)


def _nearest(evidence: SceneEvidence, xy) -> int:
    return int(np.argmin(np.linalg.norm(evidence.positions[:, :2].numpy() - np.asarray(xy), axis=1)))


def test_occlusion_is_read_by_projection(bus_behind_car, parsed):
    truth = bus_behind_car.scene.objects
    assert truth[0].occluded_by == (1,)  # the layout is what the test says
    ev = parsed.evidence
    assert ev.num_objects == 2
    bus, car = _nearest(ev, truth[0].position[:2]), _nearest(ev, truth[1].position[:2])
    assert bus != car
    assert ev.occluded_logodds[bus] > 0 > ev.occluded_logodds[car]
    assert ev.occludes_logodds[bus, car] > 0 > ev.occludes_logodds[car, bus]
    for i, obj in ((bus, truth[0]), (car, truth[1])):
        assert np.linalg.norm(ev.positions[i, :2].numpy() - np.asarray(obj.position[:2])) < 0.5


def test_evidence_fills_the_contract_from_pixels(bus_behind_car, parsed):
    ev = parsed.evidence
    ev.validate()
    assert ev.directions["left"].tolist() == pytest.approx(list(ev.camera.ground_directions()["left"]))
    # pose tables are P(azimuth | category), the category evidence sits in the subtype table only
    assert torch.allclose(torch.logsumexp(ev.pose_loglik, -1), torch.zeros(2, 5, dtype=torch.float64))
    # every projected hypothesis is recorded with its weight; per proposal the weights sum to one
    for i in range(ev.num_objects):
        assert sum(p.weight for p in parsed.projections if p.proposal == i) == pytest.approx(1.0)
    assert {"objects.coarse", "projection", "total"} <= set(parsed.timings)


def test_an_image_without_vehicles_gives_empty_evidence():
    """The world's bare ground (the one object stands behind the camera, out of view)."""
    behind = ObjectSpec("sedan", "red", "metal", "large", 0.0, 20.0, -20.0)
    bare = render_layout([behind], CameraPrior(640, 480).base)
    assert (bare.object_ids < 0).all()
    parsed = parse_scene(bare.image)
    ev = parsed.evidence
    assert ev.num_objects == 0
    assert ev.part_occludes_logodds.shape == (0, 21, ev.part_visible_logodds.shape[-1], 0)


def test_config_is_checked():
    with pytest.raises(Exception, match="projection_floor"):
        SceneParserConfig(projection_floor=0.7)


def test_calibration_round_trips_and_is_checksummed(tmp_path):
    from po3d_ppl.model_store import write_entry
    from po3d_ppl.perception.calibration import MODEL_NAME

    fitted = TableCalibration(2.5, 7.0, 0.03, -0.4)
    write_entry(MODEL_NAME, [fitted.save(tmp_path)], tmp_path, command="test")
    assert load_calibration(tmp_path, required=True) == fitted
    path = tmp_path / "object_calibration.safetensors"
    data = bytearray(path.read_bytes())
    data[-1] ^= 0xFF
    path.write_bytes(bytes(data))
    with pytest.raises(ModelFileError, match="object_calibration.safetensors"):
        load_calibration(tmp_path, required=True)
    assert load_calibration(tmp_path / "nowhere") == TableCalibration()  # nothing shipped there: raw scores
