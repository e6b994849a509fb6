"""Scene files: public layout, lossless round trips, public keep/drop rules, imports of public and older files,
and errors that name the file and the field. No rendering here (hand-built scenes and dicts)."""

import copy
import json

import numpy as np
import pytest

from po3d_ppl import ontology
from po3d_ppl.errors import SceneFormatError
from po3d_ppl.world import rle
from po3d_ppl.world.sampler import make_camera
from po3d_ppl.world.scene import EntityAnnotation, Occlusion, PartStyle, Scene, SceneObject, compute_relationships
from po3d_ppl.world.scene_io import (
    dumps,
    load_scene,
    load_scenes,
    save_scene,
    save_scenes,
    scene_from_public,
    scene_to_public,
)

H, W = 480, 640


def box_mask(x0, y0, x1, y1):
    m = np.zeros((H, W), bool)
    m[y0:y1, x0:x1] = True
    return rle.encode(m)


def annotation(visible, unoccluded, level, vb, overlaps, box=(10, 10, 20, 20)):
    occ = Occlusion.from_overlaps(unoccluded, unoccluded - visible, overlaps)
    occ = Occlusion(level, vb, occ.occluded_by, occ.overlaps)
    return EntityAnnotation(visible, unoccluded, (box[0], box[1], box[2] - box[0], box[3] - box[1]), occ,
                            box_mask(*box), box_mask(0, 0, 1, 1) if unoccluded > visible else rle.encode_indices([], H * W))


def hand_scene() -> Scene:
    """Three objects whose annotations exercise every public keep/drop rule."""
    cam = make_camera()
    empty = annotation(0, 0, 2, False, {})
    objs = []
    # 0: occluded by 1 and 2 equally (tie -> lowest index in the public field); parts: kept with a tiny occluder,
    #    dropped (not visible before), dropped (ambiguous level -1).
    names = ontology.PARTS["sedan"]
    parts0 = {n: empty for n in names}
    parts0[names[0]] = annotation(40, 60, 1, True, {2: 5})  # below MIN_OCCLUDER_PIXELS: no QA occluder
    parts0[names[1]] = annotation(0, 10, 2, False, {1: 10})
    parts0[names[2]] = annotation(30, 35, -1, True, {1: 5})
    objs.append(SceneObject("sedan", "red", "metal", "large", 12.5, (0.5, -0.25, 0.47), 124.2,
                            {names[0]: PartStyle("blue", "rubber")}, (300.0, 250.0, 11.2),
                            annotation(900, 1000, 1, True, {1: 50, 2: 50}), parts0))
    # 1: ambiguous object level (-1 -> 0 in the public file, entry of length 3).
    names = ontology.PARTS["road"]
    objs.append(SceneObject("road", "cyan", "rubber", "small", 300.0, (-1.0, 2.0, 0.42), 197.0, {}, (250.0, 180.0, 13.0),
                            annotation(500, 505, -1, True, {0: 5}), {n: empty for n in names}))
    # 2: occluded with no occluder found: the object entry stays (length 3), all its part entries are dropped.
    names = ontology.PARTS["jet"]
    parts2 = {n: empty for n in names}
    parts2[names[3]] = annotation(10, 40, 1, True, {0: 30})
    objs.append(SceneObject("jet", "gray", "rubber", "large", 0.0, (2.0, 1.0, 0.4), 90.0, {}, (400.0, 200.0, 12.0),
                            annotation(300, 400, 1, True, {}), parts2))
    directions = cam.ground_directions()
    rel = compute_relationships(np.array([o.position for o in objs]), directions)
    return Scene(tuple(objs), directions, rel, cam, 7, "superCLEVR_new_000007.png")


def test_public_keep_drop_rules():
    occ = scene_to_public(hand_scene())["occlusion"]
    names = ontology.PARTS["sedan"]
    assert occ["0"]["obj"][0] == 1 and occ["0"]["obj"][2] == "True" and occ["0"]["obj"][3] == "1"  # tie -> "1"
    assert occ["0"][names[0]][3] == "2"  # public rule: any overlap > 0 names an occluder
    assert hand_scene().objects[0].part_annotations[names[0]].occlusion.occluded_by == ()  # ours needs >= 16
    assert names[1] not in occ["0"] and names[2] not in occ["0"]  # not visible before / ambiguous level
    assert occ["1"]["obj"][0] == 0 and len(occ["1"]["obj"]) == 3  # -1 becomes 0
    assert list(occ["2"]) == ["obj"] and occ["2"]["obj"][0] == 1 and len(occ["2"]["obj"]) == 3


def test_round_trip_is_lossless_and_byte_identical(tmp_path):
    scene = hand_scene()
    path = tmp_path / "scene.json"
    save_scene(scene, path)
    back = load_scene(path)
    assert back == scene
    assert back.objects[0].annotation.occlusion.occluded_by == (1, 2)  # every occluder survives via "po3d"
    assert back.objects[1].annotation.occlusion.level == -1  # the raw level too
    assert dumps(scene_to_public(back)) == path.read_text()


def test_public_layout_fields():
    d = scene_to_public(hand_scene())
    o = d["objects"][0]
    assert list(o)[:8] == ["shape", "size", "3d_coords", "rotation", "pixel_coords", "color", "material", "texture"]
    assert o["rotation"] == pytest.approx((12.5 - 90) % 360)  # public car models face +y
    assert d["objects"][1]["rotation"] == 300.0  # bicycles face +x in both conventions
    assert o["pixel_coords"] == [[300, 250, 11.2], [640, 480]]
    assert o["parts"] == {ontology.PARTS["sedan"][0]: {"color": "blue", "material": "rubber", "size": "large",
                                                       "texture": None}}
    assert o["pose"] == "None" and d["objects"][1]["pose"] == "front_pose"
    assert set(d["obj_mask_box"]["0"]) == {"info", "obj", *ontology.PARTS["sedan"]}
    assert d["obj_mask_box"]["0"]["info"] == "sedan_0"
    assert np.allclose(np.array(d["matrix_world"]) @ np.array(d["matrix_world_inverted"]), np.eye(4), atol=1e-6)
    assert d["projection_matrix"][0][0] == pytest.approx(2 * 700 / 640)


def test_scene_list_wrapper(tmp_path):
    scene = hand_scene()
    path = tmp_path / "scenes.json"
    save_scenes([scene, scene], path)
    data = json.loads(path.read_text())
    assert data["info"]["split"] == "new" and len(data["scenes"]) == 2
    assert load_scenes(path) == [scene, scene]
    with pytest.raises(SceneFormatError, match="holds 2 scenes"):
        load_scene(path)


# A hand-written scene in the public Super-CLEVR-3D layout (not produced by our exporter).
def public_scene() -> dict:
    cam = make_camera()
    M = np.array(cam.camera_to_world)
    return {
        "split": "new", "image_index": 12, "image_filename": "superCLEVR_new_000012.png",
        "objects": [
            {"shape": "suv", "size": "large", "3d_coords": [1.0, -0.5, 0.43], "rotation": 10.0,
             "pixel_coords": [[330, 260, 10.9], [640, 480]], "color": "blue", "material": "metal", "texture": None,
             "parts": {"hood": {"color": "red", "material": "rubber", "size": "large", "texture": None}},
             "pose": "left_pose", "pose_degree": 40.0},
            {"shape": "tandem", "size": "small", "3d_coords": [-1.5, 1.5, 0.34], "rotation": 200.0,
             "pixel_coords": [[280, 190, 13.1], [640, 480]], "color": "green", "material": "rubber",
             "texture": None, "parts": {}, "pose": "front_pose", "pose_degree": 300.0},
        ],
        "directions": {k: list(v) for k, v in cam.ground_directions().items()},
        "relationships": {"behind": [[1], []], "front": [[], [0]], "left": [[1], []], "right": [[], [0]]},
        "matrix_world": M.tolist(), "matrix_world_inverted": np.linalg.inv(M).tolist(),
        "projection_matrix": [[2.1875, 0, 0, 0], [0, 2.9166667, 0, 0], [0, 0, -1.002002, -0.2002002],
                              [0, 0, -1, 0]],
        "camera_location": M[:3, 3].tolist(),
        "obj_mask_box": {
            "0": {"info": "suv_0", "obj": [[100, 2, 60, 3], "1380,60,580,60,580,60,304480"],
                  **{n: [[0, 0, 0, 0], "307200"] for n in ontology.PARTS["suv"]},
                  "hood": [[100, 2, 10, 1], "1380,10,305810"]},
            "1": {"info": "tandem_0", "obj": [[0, 0, 5, 1], "0,5,307195"],
                  **{n: [[0, 0, 0, 0], "307200"] for n in ontology.PARTS["tandem"]}},
        },
        "occlusion": {
            "0": {"obj": [1, "1440,30,305730", "True", "1"], "hood": [1, "1390,20,305790", "True", "1"]},
            "1": {"obj": [0, "307200", "True"]},
        },
    }


def test_import_public_scene():
    scene = scene_from_public(public_scene(), "public.json")
    a, b = scene.objects
    assert a.rotation == 100.0 and b.rotation == 200.0  # car +90 (public models face +y), bicycle unchanged
    assert a.pose_degree == 40.0 and a.pose == "None" and b.pose == "left_pose"  # label from the degree, not the file
    assert a.parts == {"hood": PartStyle("red", "rubber")}
    assert a.pixel_coords == (330.0, 260.0, 10.9)
    assert scene.camera.K[0, 0] == pytest.approx(700.0) and scene.camera.K[1, 1] == pytest.approx(700.0)
    assert scene.camera.K[0, 2] == 320.0 and scene.camera.K[1, 2] == 240.0
    ann = a.annotation
    assert ann.visible_pixels == 180 and ann.unoccluded_pixels == 210 and ann.bbox == (100, 2, 60, 3)
    assert ann.occlusion.level == 1 and ann.occlusion.occluded_by == (1,) and ann.occlusion.occluded
    hood = a.part_annotations["hood"]
    assert (hood.visible_pixels, hood.unoccluded_pixels, hood.occlusion.occluded_by) == (10, 30, (1,))
    roof = a.part_annotations["roof"]
    assert roof.occlusion.level == 0 and not roof.occlusion.occluded and roof.visible_pixels == 0
    assert not b.occluded and b.annotation.visible_pixels == 5
    assert scene.relationships["behind"] == ((1,), ())
    assert scene.has_occlusion


def test_import_older_super_clevr_scene_without_occlusion_pose_or_camera():
    old = {
        "split": "train", "image_index": 3, "image_filename": "superCLEVR_train_000003.png",
        "objects": [
            {"shape": "jet", "size": "small", "3d_coords": [0.0, 1.0, 0.14], "rotation": 80.0,
             "pixel_coords": [310, 200, 12.0], "color": "yellow", "material": "rubber", "parts": {}},
            {"shape": "mountain", "size": "large", "3d_coords": [2.0, -1.0, 0.84], "rotation": 20.0,
             "pixel_coords": [400, 300, 10.0], "color": "gray", "material": "metal",
             "parts": {"saddle": {"color": "red", "material": "metal", "size": "large", "texture": None}}},
        ],
        "directions": {k: list(v) for k, v in make_camera().ground_directions().items()},
    }
    scene = scene_from_public(old, "old.json")
    jet, bike = scene.objects
    assert jet.pose_degree == pytest.approx((-80.0 + 50.0) % 360)  # the public formula
    assert bike.pose_degree == pytest.approx((-20.0 + 140.0) % 360)
    assert scene.camera is None and not scene.has_occlusion and jet.annotation is None
    assert scene.relationships == compute_relationships(np.array([jet.position, bike.position]), scene.directions)
    assert bike.parts == {"saddle": PartStyle("red", "metal")}
    # re-export keeps what is known and writes no annotation fields
    d = scene_to_public(scene)
    assert "occlusion" not in d and "matrix_world" not in d
    assert scene_from_public(json.loads(dumps(d))) == scene


@pytest.mark.parametrize("edit, field", [
    (lambda d: d["objects"][1].__setitem__("color", "pink"), "objects[1].color: 'pink' is not a colour"),
    (lambda d: d["objects"][0].__setitem__("shape", "addi"), "objects[0].shape"),
    (lambda d: d["objects"][0].pop("3d_coords"), "objects[0].3d_coords: missing field"),
    (lambda d: d["objects"][0].__setitem__("rotation", "north"), "objects[0].rotation"),
    (lambda d: d["objects"][0]["parts"].__setitem__("wing_left", {"color": "red", "material": "metal"}),
     "objects[0].parts.wing_left"),
    (lambda d: d["obj_mask_box"]["0"].__setitem__("obj", [[1, 2, 3, 4], "5,5"]), "obj_mask_box.0.obj[1]"),
    (lambda d: d["occlusion"]["0"].__setitem__("obj", [1, "307200"]), "occlusion.0.obj"),
    (lambda d: d["relationships"].__setitem__("left", [[1]]), "relationships.left"),
    (lambda d: d.pop("objects"), "objects: missing field"),
])
def test_malformed_scene_names_file_and_field(tmp_path, edit, field):
    data = copy.deepcopy(public_scene())
    edit(data)
    path = tmp_path / "bad.json"
    path.write_text(json.dumps(data))
    with pytest.raises(SceneFormatError) as err:
        load_scene(path)
    assert str(path) in str(err.value) and field in str(err.value)


def test_unreadable_files(tmp_path):
    with pytest.raises(SceneFormatError, match="no such file"):
        load_scenes(tmp_path / "missing.json")
    bad = tmp_path / "bad.json"
    bad.write_text("{not json")
    with pytest.raises(SceneFormatError, match="not valid JSON"):
        load_scenes(bad)
    bad.write_text("[1, 2]")
    with pytest.raises(SceneFormatError, match="expected a scene"):
        load_scenes(bad)
