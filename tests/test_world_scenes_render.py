"""Rendering and exact annotations on hand-built layouts (render_layout): occlusion levels and occluders, solo
footprints against objects rendered alone, pixel counts against the id maps, pose, materials."""

import numpy as np
import pytest

from po3d_ppl import ontology
from po3d_ppl.world import rle
from po3d_ppl.world.generate import render_layout
from po3d_ppl.world.sampler import ObjectSpec, make_camera
from po3d_ppl.world.scene import MIN_OCCLUDER_PIXELS, PartStyle, occlusion_level
from po3d_ppl.world.scene_io import scene_to_public

CAMERA = make_camera()
H, W = CAMERA.height, CAMERA.width
# A large school bus across the view, and a small sedan behind it (further along the viewing direction).
BUS = ObjectSpec("school", "yellow", "rubber", "large", 47.0, 0.6, -0.5, parts={})
CAR = ObjectSpec("sedan", "red", "rubber", "small", 0.0, -1.0, 1.0, parts={})


@pytest.fixture(scope="module")
def pair():
    return render_layout([BUS, CAR], CAMERA)


@pytest.fixture(scope="module")
def car_alone():
    return render_layout([CAR], CAMERA)


def test_occluded_object_level_and_occluder(pair):
    bus, car = pair.scene.objects
    assert bus.annotation.occlusion.level == 0 and not bus.occluded and bus.occluded_by == ()
    occ = car.annotation.occlusion
    assert occ.level == 1 and occ.visible_before and occ.occluded_by == (0,) and car.occluded
    assert 0 < car.annotation.visible_pixels < car.annotation.unoccluded_pixels
    assert occ.overlaps == {0: car.annotation.unoccluded_pixels - car.annotation.visible_pixels}


def test_every_entity_follows_the_level_and_occluder_rules(pair):
    for obj in pair.scene.objects:
        for ann in [obj.annotation, *obj.part_annotations.values()]:
            occ = ann.occlusion
            hidden = ann.unoccluded_pixels - ann.visible_pixels
            assert hidden == sum(occ.overlaps.values())
            assert occ.level == occlusion_level(ann.unoccluded_pixels, hidden)
            assert occ.visible_before == (ann.unoccluded_pixels >= 20)
            expected = tuple(j for j, px in sorted(occ.overlaps.items(), key=lambda kv: -kv[1])
                             if px >= MIN_OCCLUDER_PIXELS) if occ.level in (1, 2) and occ.visible_before else ()
            assert occ.occluded_by == expected
    car = pair.scene.objects[1]
    # Some part of the car is hidden (level > 0) and some is fully visible.
    levels = {ann.occlusion.level for ann in car.part_annotations.values() if ann.occlusion.visible_before}
    assert 0 in levels and (1 in levels or 2 in levels)


def test_public_export_of_the_pair(pair):
    d = scene_to_public(pair.scene)
    assert d["occlusion"]["0"] == {"obj": [0, rle.encode_indices([], H * W), "True"]}
    car_entry = d["occlusion"]["1"]
    assert car_entry["obj"][0] == 1 and car_entry["obj"][2:] == ["True", "0"]
    car = pair.scene.objects[1]
    for name, ann in car.part_annotations.items():
        keep = ann.occlusion.level > 0 and ann.occlusion.visible_before and bool(ann.occlusion.overlaps)
        assert (name in car_entry) == keep, name
        if keep:
            assert car_entry[name][0] == ann.occlusion.level and car_entry[name][3] == "0"
    # the occlusion mask is exactly the pixels of the car hidden by the bus
    hidden = rle.decode(car_entry["obj"][1], H, W)
    assert (pair.object_ids[hidden] == 0).all() and hidden.sum() == car.annotation.occlusion.overlaps[0]


def test_solo_footprint_equals_rendering_the_object_alone(pair, car_alone):
    car = pair.scene.objects[1].annotation
    unoccluded = rle.decode(car.visible_mask, H, W) | rle.decode(car.occlusion_mask, H, W)
    alone = car_alone.object_ids == 0
    assert np.array_equal(unoccluded, alone)
    assert car.unoccluded_pixels == car_alone.scene.objects[0].annotation.visible_pixels
    # parts too: the solo part masks match the parts seen when the car is alone (up to ties on shared edges)
    mismatched = 0
    for name, ann in pair.scene.objects[1].part_annotations.items():
        pid = ontology.part_id("sedan", name)
        solo = rle.decode(ann.visible_mask, H, W) | rle.decode(ann.occlusion_mask, H, W)
        mismatched += int((solo != (alone & (car_alone.part_ids == pid))).sum())
    assert mismatched <= 0.001 * alone.sum()


def test_annotation_counts_masks_and_boxes_match_the_id_maps(pair):
    for i, obj in enumerate(pair.scene.objects):
        mask = pair.object_ids == i
        assert obj.annotation.visible_pixels == int(mask.sum())
        assert np.array_equal(rle.decode(obj.annotation.visible_mask, H, W), mask)
        assert obj.annotation.bbox == rle.bbox_of(mask)
        for name, ann in obj.part_annotations.items():
            pmask = mask & (pair.part_ids == ontology.part_id(obj.subtype, name))
            assert ann.visible_pixels == int(pmask.sum())
            assert ann.bbox == rle.bbox_of(pmask)
    assert set(np.unique(pair.object_ids)) == {-1, 0, 1}


def test_depth_and_pixel_coords(pair):
    bus, car = pair.scene.objects
    assert pair.depth.dtype == np.float32 and np.isfinite(pair.depth).all()  # the ground fills the view
    assert np.median(pair.depth[pair.object_ids == 0]) < np.median(pair.depth[pair.object_ids == 1])
    u, v, depth = CAMERA.project(np.array(car.position))
    assert car.pixel_coords == (round(u), round(v), pytest.approx(depth, abs=1e-6))


@pytest.mark.parametrize("offset, label", [(0.0, "back_pose"), (180.0, "front_pose"), (90.0, "left_pose"),
                                           (-90.0, "right_pose")])
def test_pose_degree_is_measured_from_the_viewing_ray(offset, label):
    # Facing along the viewing ray (away from the camera) shows the back; turning counter-clockwise by 90
    # degrees makes the object face the image's left.
    x, y = 0.5, 0.5
    ray = np.array([x, y]) - CAMERA.location[:2]
    azimuth = np.degrees(np.arctan2(ray[1], ray[0]))
    spec = ObjectSpec("suv", "blue", "rubber", "small", float((azimuth + offset) % 360), x, y, parts={})
    obj = render_layout([spec], CAMERA).scene.objects[0]
    assert obj.pose == label
    assert obj.pose_degree == pytest.approx((-offset) % 360, abs=1.0)


def test_metal_and_rubber_render_differently():
    def lum(material):
        r = render_layout([ObjectSpec("sedan", "red", material, "large", 60.0, 0.0, 0.0, parts={})], CAMERA)
        body = (r.object_ids == 0) & (r.part_ids >= -1)
        return r.image[body].astype(float).mean(axis=1)

    metal, rubber = lum("metal"), lum("rubber")
    # metal: a specular sheen on top surfaces, dark reflections of the ground on the sides -> more contrast
    assert np.percentile(metal, 95) > np.percentile(rubber, 95) + 10
    assert np.percentile(metal, 20) < np.percentile(rubber, 20) - 10
    assert metal.std() > 1.3 * rubber.std()


def test_recoloured_parts_render_in_their_colour():
    spec = ObjectSpec("sedan", "gray", "rubber", "large", 60.0, 0.0, 0.0,
                      parts={"roof": PartStyle("yellow", "rubber")})
    r = render_layout([spec], CAMERA)
    roof = (r.object_ids == 0) & (r.part_ids == ontology.part_id("sedan", "roof"))
    body = (r.object_ids == 0) & (r.part_ids == -1)
    red_minus_blue = lambda m: float((r.image[m][:, 0].astype(int) - r.image[m][:, 2]).mean())  # noqa: E731
    assert roof.sum() > 100 and red_minus_blue(roof) > 60 > abs(red_minus_blue(body))
    assert dict(r.scene.objects[0].parts) == {"roof": PartStyle("yellow", "rubber")}


def test_per_object_casting_matches_a_world_space_scene_cast():
    """Objects cast alone in their own frames and z-buffered = one cast of the world-space scene."""
    import trimesh

    from po3d_ppl.world.meshes import vehicle_mesh
    from po3d_ppl.world.raycast import RayCaster, camera_rays
    from po3d_ppl.world.renderer import place_meshes, render_geometry

    specs = [BUS, CAR, ObjectSpec("chopper", "blue", "metal", "large", 200.0, 2.5, 1.5, parts={}),
             ObjectSpec("biplane", "gray", "rubber", "small", 30.0, -2.0, -2.0, elevation=1.0, parts={})]
    meshes = place_meshes(specs)
    gbuffer, _ = render_geometry(meshes, CAMERA)
    world = [trimesh.Trimesh(m.vertices, vehicle_mesh(m.subtype).mesh.faces, process=False) for m in meshes]
    hits = RayCaster(world).cast(*camera_rays(CAMERA))
    objects = hits.geometry >= 0
    assert objects.sum() > 20000
    assert (hits.geometry != gbuffer.geometry).sum() <= 0.001 * objects.sum()
    same = objects & (hits.geometry == gbuffer.geometry)
    assert np.allclose(hits.distance[same], gbuffer.distance[same], rtol=1e-4, atol=1e-4)
