"""Graded occlusion (perception.occlusion): unshifted, it is the world's annotation exactly; shifted, it grades."""

import numpy as np
import pytest

from po3d_ppl import ontology
from po3d_ppl.perception.occlusion import ShiftGrid, graded_occlusion
from po3d_ppl.world import annotate, renderer
from po3d_ppl.world.sampler import ObjectSpec, make_camera
from po3d_ppl.world.scene import Occlusion, occluder_mask

CAMERA = make_camera()
BUS = ObjectSpec("school", "yellow", "rubber", "large", 47.0, 0.6, -0.5, parts={})
CAR = ObjectSpec("sedan", "red", "rubber", "small", 0.0, -1.0, 1.0, parts={})
BIKE = ObjectSpec("road", "blue", "metal", "small", 120.0, 1.6, 1.4, parts={})
SPECS = [BUS, CAR, BIKE]


@pytest.fixture(scope="module")
def rendered():
    meshes = renderer.place_meshes(SPECS)
    gbuffer, views = renderer.render_geometry(meshes, CAMERA)
    return views, annotate.measure(gbuffer, views, SPECS)


def test_occluder_mask_is_the_rule_of_from_overlaps():
    rng = np.random.default_rng(0)
    for _ in range(500):
        before = int(rng.integers(0, 80))
        overlaps = rng.integers(0, 30, size=3) * (rng.random(3) < 0.6)
        overlaps = np.minimum(overlaps, before)
        hidden = min(int(overlaps.sum()), before)
        rule = Occlusion.from_overlaps(before, hidden, {j: int(px) for j, px in enumerate(overlaps)})
        mask = occluder_mask(before, hidden, overlaps)
        assert tuple(sorted(rule.occluded_by)) == tuple(np.flatnonzero(mask))


def test_unshifted_grading_is_the_world_annotation(rendered):
    views, measures = rendered
    for i, (spec, measure) in enumerate(zip(SPECS, measures)):
        others = [j for j in range(len(SPECS)) if j != i]
        parts = len(ontology.PARTS[spec.subtype])
        graded = graded_occlusion(views[i], [views[j] for j in others], parts, ShiftGrid.gaussian(0.0), 20)
        assert graded.occluded == float(measure.obj.occlusion.occluded)
        assert graded.occludes.tolist() == [float(j in measure.obj.occlusion.occluded_by) for j in others]
        for p, ann in enumerate(measure.parts):
            assert graded.part_occluded[p] == float(ann.occlusion.occluded)
            assert graded.part_occludes[p].tolist() == [float(j in ann.occlusion.occluded_by) for j in others]
            assert graded.part_visible[p] == float(ann.visible_pixels >= 20)
    assert any(m.obj.occlusion.occluded for m in measures)  # the layout exercises the occluded branch


def test_shifts_grade_the_parts_near_an_occluders_edge(rendered):
    views, _ = rendered
    car = 1
    others = [0, 2]
    parts = len(ontology.PARTS[CAR.subtype])
    graded = graded_occlusion(views[car], [views[j] for j in others], parts, ShiftGrid.gaussian(3.0), 20)
    values = np.concatenate([graded.part_occluded, graded.part_visible])
    assert ((values > 0) & (values < 1)).any(), "some part is near an edge: shifts must move it across"
    assert np.all((values >= 0) & (values <= 1))
    assert 0.0 < graded.occluded <= 1.0


def test_gaussian_grid():
    grid = ShiftGrid.gaussian(2.5, steps=2)
    assert grid.offsets.shape == (25, 2) and grid.margin == 5
    assert np.isclose(grid.weights.sum(), 1.0) and grid.weights.argmax() == 12  # the centre weighs most
    assert ShiftGrid.gaussian(0.0).offsets.tolist() == [[0, 0]]
