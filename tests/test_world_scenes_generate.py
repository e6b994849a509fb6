"""generate_scene: determinism, the rejection rules, the recolouring rule, non-intersecting layouts, round trips
of generated scenes, and input validation."""

import itertools
import json

import numpy as np
import pytest

from po3d_ppl import ontology
from po3d_ppl.errors import InputError
from po3d_ppl.world import rle
from po3d_ppl.world.generate import GenerationError, generate_scene
from po3d_ppl.world.sampler import ObjectSpec, SceneConfig, intersects, sample_objects
from po3d_ppl.world.scene import compute_relationships
from po3d_ppl.world.scene_io import dumps, scene_from_public, scene_to_public

SEEDS = (0, 1, 2)


@pytest.fixture(scope="module")
def scenes():
    return {seed: generate_scene(seed) for seed in SEEDS}


def test_same_seed_gives_identical_files(scenes, tmp_path):
    again = generate_scene(1)
    assert dumps(scene_to_public(again.scene)) == dumps(scene_to_public(scenes[1].scene))
    assert np.array_equal(again.image, scenes[1].image) and np.array_equal(again.part_ids, scenes[1].part_ids)
    assert dumps(scene_to_public(scenes[0].scene)) != dumps(scene_to_public(scenes[1].scene))


def test_every_object_is_visible_enough_and_counts_match_the_id_maps(scenes):
    for result in scenes.values():
        scene = result.scene
        assert 3 <= len(scene) <= 10
        assert result.image.shape == (480, 640, 3) and result.image.dtype == np.uint8
        for i, obj in enumerate(scene.objects):
            mask = result.object_ids == i
            assert obj.annotation.visible_pixels == int(mask.sum()) >= 200
            assert np.array_equal(rle.decode(obj.annotation.visible_mask, 480, 640), mask)
            for name, ann in obj.part_annotations.items():
                pid = ontology.part_id(obj.subtype, name)
                assert ann.visible_pixels == int((mask & (result.part_ids == pid)).sum())
        assert set(np.unique(result.object_ids)) == {-1, *range(len(scene))}


def test_recoloured_parts_follow_the_public_rule(scenes):
    seen = 0
    for result in scenes.values():
        for obj in result.scene.objects:
            assert len(obj.parts) <= 3
            for name, style in obj.parts.items():
                assert obj.part_annotations[name].visible_pixels >= 20
                assert style.color != obj.color and style.material in ontology.MATERIALS
                seen += 1
            visible = [n for n, a in obj.part_annotations.items() if a.visible_pixels >= 20]
            assert len(obj.parts) == min(3, len(visible))
    assert seen > 0


def test_scene_geometry_fields(scenes):
    for result in scenes.values():
        scene = result.scene
        positions = np.array([o.position for o in scene.objects])
        assert scene.relationships == compute_relationships(positions, scene.directions)
        assert scene.directions["front"] == tuple(-v + 0.0 for v in scene.directions["behind"])
        base = np.array([7.3589, -6.9258, 4.9583])
        assert np.all(np.abs(scene.camera.location - base) <= 0.5 + 1e-9)
        for obj in scene.objects:
            assert 0.0 <= obj.rotation < 360.0 and 0.0 <= obj.pose_degree < 360.0
            assert obj.pixel_coords[2] > 0
            assert all(-4.0 < c < 4.0 for c in obj.position[:2])


def test_generated_scenes_round_trip_losslessly(scenes):
    for result in scenes.values():
        text = dumps(scene_to_public(result.scene))
        back = scene_from_public(json.loads(text))
        assert back == result.scene
        assert dumps(scene_to_public(back)) == text


def test_layouts_never_intersect():
    config = SceneConfig.with_objects(8, elevated_aeroplanes=True)
    checked = 0
    for attempt in range(40):
        specs = sample_objects(np.random.default_rng([7, attempt]), config)
        if specs is None:
            continue
        for a, b in itertools.combinations(specs, 2):
            assert not intersects(a, b, config.footprint_margin)
            checked += 1
    assert checked > 50


def test_intersection_test_detects_overlaps():
    car = ObjectSpec("sedan", "red", "rubber", "large", 0.0, 0.0, 0.0)
    assert intersects(car, ObjectSpec("suv", "red", "rubber", "large", 90.0, 1.0, 0.5), 0.1)  # crossing
    assert not intersects(car, ObjectSpec("suv", "red", "rubber", "large", 0.0, 0.0, 2.0), 0.1)  # side by side
    assert not intersects(car, ObjectSpec("suv", "red", "rubber", "large", 0.0, 0.0, 1.3), 0.0)  # 5 cm apart
    assert intersects(car, ObjectSpec("suv", "red", "rubber", "large", 0.0, 0.0, 1.3), 0.1)  # within the margin
    jet = ObjectSpec("jet", "red", "rubber", "small", 0.0, 0.0, 0.0, elevation=1.5)
    assert not intersects(car, jet, 0.1)  # flies above the car


def test_elevated_aeroplanes_fly():
    config = SceneConfig(elevated_aeroplanes=True)
    heights = []
    for attempt in range(30):
        specs = sample_objects(np.random.default_rng([3, attempt]), config) or []
        heights += [s.elevation for s in specs if ontology.CATEGORY_OF[s.subtype] == "aeroplane"]
        assert all(s.elevation == 0.0 for s in specs if ontology.CATEGORY_OF[s.subtype] != "aeroplane")
    assert heights and max(heights) > 0.5 and all(0.0 <= h <= config.max_elevation for h in heights)


@pytest.mark.parametrize("kwargs, field", [
    ({"width": 0}, "SceneConfig.width"),
    ({"min_objects": 5, "max_objects": 4}, "SceneConfig.max_objects"),
    ({"camera_jitter": -1.0}, "SceneConfig.camera_jitter"),
    ({"elevated_aeroplanes": "yes"}, "SceneConfig.elevated_aeroplanes"),
    ({"min_object_pixels": 2.5}, "SceneConfig.min_object_pixels"),
])
def test_config_validation_names_the_field(kwargs, field):
    with pytest.raises(InputError, match=field.replace(".", r"\.")):
        SceneConfig(**kwargs)


def test_bad_inputs():
    with pytest.raises(InputError, match="seed"):
        generate_scene(-3)
    with pytest.raises(InputError, match="ObjectSpec.color"):
        ObjectSpec("sedan", "pink", "rubber", "large", 0.0, 0.0, 0.0)
    with pytest.raises(GenerationError, match="2 attempts"):
        generate_scene(0, SceneConfig(min_object_pixels=10**6, max_attempts=2))
