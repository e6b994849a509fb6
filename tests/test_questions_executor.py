"""Reference executor: every operation on hand-built scenes, invalid steps, and typed errors."""

from __future__ import annotations

import dataclasses

import pytest

from po3d_ppl import ontology
from po3d_ppl.catalogue import REGISTRY
from po3d_ppl.errors import InputError, Po3dError, SceneFormatError, UnknownNameError
from po3d_ppl.language import ProgramArityError, ProgramStructureError, ProgramTypeError, ProgramValueError
from po3d_ppl.questions.context import SceneContext
from po3d_ppl.questions.executor import execute
from po3d_ppl.questions.reference import missing_references
from po3d_ppl.questions.toy_scenes import toy_object, toy_scene
from po3d_ppl.world.scene import EntityAnnotation, Occlusion


def N(fn: str, *inputs: int, value: str | None = None) -> dict:
    return {"type": fn, "inputs": list(inputs), "value_inputs": [value] if value else []}


def run(scene, *nodes):
    return execute(scene, list(nodes))


@pytest.fixture(scope="module")
def scene():
    """0 large red metal suv facing back (blue door, green wheel; a bare wheel hidden by 1 and 2), 1 small blue
    rubber road bike facing front, 2 large red metal jet in a pose dead zone, raised, occluded by 1 and 3,
    3 small gray rubber school bus facing right. Camera looks along +y (behind = +y, left = -x)."""
    return toy_scene([
        toy_object("suv", "red", "metal", "large", position=(0, 0, 0), pose_degree=10.0,
                   parts={"front_left_door": ("blue", "rubber"), "back_left_wheel": ("green", "metal")},
                   part_occluded_by={"back_right_wheel": (1, 2), "hood": ()}),
        toy_object("road", "blue", "rubber", "small", position=(-2, -1, 0), pose_degree=190.0,
                   parts={"wheel_front": ("yellow", "metal")}),
        toy_object("jet", "red", "metal", "large", position=(2, 2, 1.5), pose_degree=50.0,
                   occluded_by=(1, 3), part_occluded_by={"fin": (3,)}),
        toy_object("school", "gray", "rubber", "small", position=(1, -2, 0), pose_degree=100.0),
    ])


def test_every_operation_has_a_reference_semantics():
    assert missing_references() == []
    op = REGISTRY.resolve("filter_occluder", ("ObjectSet",))
    assert op is not None and op.world_fn is not None and op.reference_fn is not None


def test_scene_filters_and_hypernyms(scene):
    assert run(scene, N("scene")).answer == {0, 1, 2, 3}
    assert run(scene, N("scene"), N("filter_color", 0, value="red")).answer == {0, 2}
    assert run(scene, N("scene"), N("filter_material", 0, value="rubber")).answer == {1, 3}
    assert run(scene, N("scene"), N("filter_size", 0, value="small")).answer == {1, 3}
    assert run(scene, N("scene"), N("filter_shape", 0, value="car")).answer == {0}
    assert run(scene, N("scene"), N("filter_shape", 0, value="bus")).answer == {3}
    assert run(scene, N("scene"), N("filter_shape", 0, value="aeroplane")).answer == {2}
    assert run(scene, N("scene"), N("filter_shape", 0, value="road")).answer == {1}
    assert run(scene, N("scene"), N("filter_shape", 0, value="bicycle")).answer == {1}
    assert run(scene, N("scene"), N("filter_shape", 0, value="sedan")).answer == frozenset()


def test_unique_count_exist_and_invalid_unique(scene):
    res = run(scene, N("scene"), N("filter_color", 0, value="blue"), N("unique", 1), N("query_shape", 2))
    assert res.valid and res.answer == "road" and res.answer_type == "Shape"
    res = run(scene, N("scene"), N("filter_color", 0, value="red"), N("unique", 1), N("query_shape", 2))
    assert not res.valid and res.invalid_node == 2 and "2 members" in res.reason
    res = run(scene, N("scene"), N("filter_color", 0, value="green"), N("unique", 1))
    assert res.invalid_node == 2
    assert run(scene, N("scene"), N("filter_color", 0, value="red"), N("count", 1)).answer == 2
    assert run(scene, N("scene"), N("filter_color", 0, value="cyan"), N("exist", 1)).answer is False


def test_queries_and_comparisons(scene):
    base = [N("scene"), N("filter_shape", 0, value="jet"), N("unique", 1)]
    assert run(scene, *base, N("query_color", 2)).answer == "red"
    assert run(scene, *base, N("query_material", 2)).answer == "metal"
    assert run(scene, *base, N("query_size", 2)).answer == "large"
    suv = [N("filter_shape", 0, value="suv"), N("unique", 3)]
    res = run(scene, *base, *suv, N("query_color", 2), N("query_color", 4), N("equal_color", 5, 6))
    assert res.answer is True
    res = run(scene, *base, *suv, N("query_shape", 2), N("query_shape", 4), N("equal_shape", 5, 6))
    assert res.answer is False
    counts = [N("scene"), N("filter_color", 0, value="red"), N("count", 1), N("filter_size", 0, value="small"),
              N("count", 3)]
    assert run(scene, *counts, N("equal_integer", 2, 4)).answer is True
    assert run(scene, *counts, N("less_than", 2, 4)).answer is False
    assert run(scene, *counts, N("greater_than", 2, 4)).answer is False


def test_relations_and_set_operations(scene):
    suv = [N("scene"), N("filter_shape", 0, value="suv"), N("unique", 1)]
    assert run(scene, *suv, N("relate", 2, value="left")).answer == {1}
    assert run(scene, *suv, N("relate", 2, value="right")).answer == {2, 3}
    assert run(scene, *suv, N("relate", 2, value="behind")).answer == {2}
    assert run(scene, *suv, N("relate", 2, value="front")).answer == {1, 3}
    assert run(scene, *suv, N("relate", 2, value="above")).answer == {2}
    assert run(scene, *suv, N("relate", 2, value="below")).answer == frozenset()
    assert run(scene, *suv, N("relate", 2, value="closer")).answer == {1, 3}  # depth = 10 + y
    assert run(scene, *suv, N("relate", 2, value="farther")).answer == {2}
    both = suv + [N("relate", 2, value="right"), N("relate", 2, value="front")]
    assert run(scene, *both, N("intersect", 3, 4)).answer == {3}
    assert run(scene, *both, N("union", 3, 4)).answer == {1, 2, 3}


def test_relation_margin_excludes_near_ties():
    s = toy_scene([toy_object(position=(0, 0, 0)), toy_object(position=(0.15, 0, 0.1)),
                   toy_object(position=(0.3, 0, 0.25))])
    # only object 2 is farther than RELATION_EPS (0.2) from object 0, to the right and upwards
    ctx = SceneContext(s)
    assert ctx.related(0, "right") == {2}
    assert ctx.related(0, "above") == {2}
    assert ctx.related(1, "above") == frozenset()
    assert ctx.related(2, "left") == {0}


def test_same_attribute_excludes_the_object(scene):
    jet = [N("scene"), N("filter_shape", 0, value="jet"), N("unique", 1)]
    assert run(scene, *jet, N("same_color", 2)).answer == {0}
    assert run(scene, *jet, N("same_material", 2)).answer == {0}
    assert run(scene, *jet, N("same_size", 2)).answer == {0}
    assert run(scene, *jet, N("same_shape", 2)).answer == frozenset()


def test_parts_and_super_part_names(scene):
    suv = [N("scene"), N("filter_shape", 0, value="suv"), N("unique", 1)]
    door = ontology.part_id("suv", "front_left_door")
    wheel = ontology.part_id("suv", "back_left_wheel")
    occluded_wheel = ontology.part_id("suv", "back_right_wheel")
    assert run(scene, *suv, N("object2part", 2)).answer == {(0, door), (0, wheel)}
    assert run(scene, *suv, N("object2part_all", 2)).answer == {(0, door), (0, wheel), (0, occluded_wheel)}
    all_parts = run(scene, N("scene"), N("object2part", 0)).answer
    assert all_parts == {(0, door), (0, wheel), (1, ontology.part_id("road", "wheel_front"))}
    p = [N("scene"), N("object2part_all", 0)]
    assert run(scene, *p, N("partfilter_partname", 1, value="wheel")).answer == {
        (0, wheel), (0, occluded_wheel), (1, ontology.part_id("road", "wheel_front"))}
    assert run(scene, *p, N("partfilter_partname", 1, value="back_left_wheel")).answer == {(0, wheel)}
    assert run(scene, *p, N("partfilter_color", 1, value="blue")).answer == {(0, door)}
    assert run(scene, *p, N("partfilter_material", 1, value="metal")).answer == {
        (0, wheel), (1, ontology.part_id("road", "wheel_front"))}
    # size is the owner's, and only recoloured parts carry it
    assert run(scene, *p, N("partfilter_size", 1, value="large")).answer == {(0, door), (0, wheel)}
    one = p + [N("partfilter_color", 1, value="green"), N("unique", 2)]
    assert run(scene, *one, N("partquery_partname", 3)).answer == "back_left_wheel"
    assert run(scene, *one, N("partquery_material", 3)).answer == "metal"
    assert run(scene, *one, N("partquery_size", 3)).answer == "large"
    assert run(scene, *one, N("part2object", 3)).answer == {0}
    assert run(scene, *p, N("partfilter_partname", 1, value="wheel"), N("part2object", 2)).answer == {0, 1}
    bare = p + [N("partfilter_partname", 1, value="back_right_wheel"), N("unique", 2)]
    for query in ("partquery_color", "partquery_material", "partquery_size"):
        res = run(scene, *bare, N(query, 3))
        assert not res.valid and res.invalid_node == 4 and "has no" in res.reason
    assert run(scene, *bare, N("partquery_partname", 3)).answer == "back_right_wheel"


def test_canonical_part_names():
    assert ontology.canonical_part_name("wheel_back_left") == "back_left_wheel"
    assert ontology.canonical_part_name("back_left_wheel") == "back_left_wheel"
    assert ontology.canonical_part_name("right_mirror") == "mirror_right"
    assert ontology.canonical_part_name("wheel") == "wheel"  # super-part names map to themselves
    assert ontology.canonical_part_name("seat") == "seat"  # raw and super-part at once
    with pytest.raises(UnknownNameError, match="wheel_back_left"):
        ontology.canonical_part_name("wheel_back_lft")
    canonical = ontology.CANONICAL_PARTNAME_VALUES
    assert len(canonical) == len(ontology.PARTNAME_VALUES) - 17 and set(canonical) <= set(ontology.PARTNAME_VALUES)
    # one canonical name per wording: no two canonical values read the same
    words = [ontology.readable_name(v) for v in canonical]
    assert len(set(words)) == len(words)
    assert {ontology.readable_name(v) for v in ontology.PARTNAME_VALUES} == set(words)


def test_spaced_and_joined_part_names_are_one_word():
    """A bus has head_light_left and tail_light_*, a cruiser headlight_left: "the left headlight of the bus" names
    the bus's part whichever spelling the program writes."""
    s = toy_scene([
        toy_object("school", "gray", parts={"head_light_left": ("red", "metal"), "tail_light_right": ("blue", "rubber")}),
        toy_object("cruiser", "green", parts={"headlight_left": ("yellow", "metal")}, position=(2, 0, 0)),
    ])
    bus = [N("scene"), N("filter_shape", 0, value="bus"), N("unique", 1), N("object2part", 2)]
    for spelling in ("head_light_left", "headlight_left"):
        assert run(s, *bus, N("partfilter_partname", 3, value=spelling), N("unique", 4),
                   N("partquery_color", 5)).answer == "red"
    for spelling in ("taillight", "tail_light", "taillight_right", "right_tail_light"):
        assert run(s, *bus, N("partfilter_partname", 3, value=spelling), N("unique", 4),
                   N("partquery_color", 5)).answer == "blue"
    every = [N("scene"), N("object2part", 0), N("partfilter_partname", 1, value="headlight"), N("count", 2)]
    assert run(s, *every).answer == 2
    assert not ontology.partname_matches("head_light_left", "headlight_right")
    # the lexicon's narrower relation: which spelling a generated program writes
    assert ontology.spelt_alike("head_light_left", "left_head_light")
    assert not ontology.spelt_alike("head_light_left", "headlight_left")


def test_part_names_match_by_words_so_both_spellings_mean_the_same():
    """"back left wheel" is back_left_wheel on cars and wheel_back_left on buses: either spelling selects both."""
    s = toy_scene([
        toy_object("sedan", "red", parts={"back_left_wheel": ("blue", "metal")},
                   part_occluded_by={"back_right_wheel": (1,)}),
        toy_object("school", "gray", parts={"wheel_back_left": ("green", "rubber"), "door_front_right":
                                            ("yellow", "metal")}, position=(2, 0, 0),
                   part_occluded_by={"wheel_back_right": (0,)}),
    ])
    car_wheel = (0, ontology.part_id("sedan", "back_left_wheel"))
    bus_wheel = (1, ontology.part_id("school", "wheel_back_left"))
    parts = [N("scene"), N("object2part_all", 0)]
    for spelling in ("back_left_wheel", "wheel_back_left"):
        assert run(s, *parts, N("partfilter_partname", 1, value=spelling)).answer == {car_wheel, bus_wheel}
    # (occluded parts are reachable through object2part_all)
    assert run(s, *parts, N("partfilter_partname", 1, value="wheel_back_right")).answer == {
        (0, ontology.part_id("sedan", "back_right_wheel")), (1, ontology.part_id("school", "wheel_back_right"))}
    # a program with either spelling gives the same answer; the part's own name stays raw
    for bus_spelling, car_spelling in (("door_front_right", "front_right_door"),
                                       ("front_right_door", "door_front_right")):
        for spelling in (bus_spelling, car_spelling):
            door = [N("scene"), N("filter_shape", 0, value="bus"), N("unique", 1), N("object2part", 2),
                    N("partfilter_partname", 3, value=spelling), N("unique", 4)]
            assert run(s, *door, N("partquery_color", 5)).answer == "yellow"
            assert run(s, *door, N("partquery_partname", 5)).answer == "door_front_right"
    colours = [N("scene"), N("object2part", 0), N("partfilter_color", 1, value="blue"), N("unique", 2),
               N("partquery_partname", 3)]
    assert run(s, *colours).answer == "back_left_wheel"
    # a name the object does not have selects nothing, whatever the spelling
    car = [N("scene"), N("filter_shape", 0, value="car"), N("unique", 1), N("object2part_all", 2)]
    assert run(s, *car, N("partfilter_partname", 3, value="wheel_front")).answer == frozenset()


def test_pose_labels_dead_zones_and_relations(scene):
    pose = [N("scene"), N("filter_pose", 0, value="back_pose")]
    assert run(scene, *pose).answer == {0}
    assert run(scene, N("scene"), N("filter_pose", 0, value="front_pose")).answer == {1}
    assert run(scene, N("scene"), N("filter_pose", 0, value="right_pose")).answer == {3}
    jet = [N("scene"), N("filter_shape", 0, value="jet"), N("unique", 1)]  # 50 degrees: dead zone
    res = run(scene, *jet, N("query_pose", 2))
    assert not res.valid and "dead-zone" in res.reason
    for rel in ("same_pose", "opposite_pose", "vertical_pose"):
        assert run(scene, *jet, N(rel, 2)).answer == frozenset()
    suv = [N("scene"), N("filter_shape", 0, value="suv"), N("unique", 1)]  # 10 degrees
    assert run(scene, *suv, N("query_pose", 2)).answer == "back"
    # the other objects may be in a dead zone themselves: only degrees count (jet at 50 -> 40 apart -> same)
    assert run(scene, *suv, N("same_pose", 2)).answer == {2}
    assert run(scene, *suv, N("opposite_pose", 2)).answer == {1}  # 180 apart
    assert run(scene, *suv, N("vertical_pose", 2)).answer == {3}  # 90 apart


@pytest.mark.parametrize(("other", "relation"), [(44.9, "same"), (45.0, "vertical"), (135.0, "vertical"),
                                                 (135.1, "opposite"), (-44.9, "same"), (200.0, "opposite")])
def test_pose_relation_45_135_rule(other, relation):
    s = toy_scene([toy_object("suv", "red", pose_degree=0.0), toy_object("sedan", "blue", pose_degree=other)])
    suv = [N("scene"), N("filter_color", 0, value="red"), N("unique", 1)]
    for rel in ("same", "opposite", "vertical"):
        assert run(s, *suv, N(f"{rel}_pose", 2)).answer == ({1} if rel == relation else frozenset())


def test_occlusion_with_several_occluders(scene):
    jet = [N("scene"), N("filter_shape", 0, value="jet"), N("unique", 1)]
    assert run(scene, N("scene"), N("filter_occludee", 0)).answer == {2}
    assert run(scene, *jet, N("relate_occluded", 2)).answer == {1, 3}  # both, not only the largest
    bike = [N("scene"), N("filter_shape", 0, value="road"), N("unique", 1)]
    assert run(scene, *bike, N("relate_occluding", 2)).answer == {2}
    wheel = (0, ontology.part_id("suv", "back_right_wheel"))
    assert run(scene, *bike, N("relate_occluding_part", 2)).answer == {wheel}
    bus = [N("scene"), N("filter_shape", 0, value="bus"), N("unique", 1)]
    assert run(scene, *bus, N("relate_occluding_part", 2)).answer == {(2, ontology.part_id("jet", "fin"))}
    parts = [N("scene"), N("object2part_all", 0), N("partfilter_occludee", 1)]
    assert run(scene, *parts).answer == {wheel, (2, ontology.part_id("jet", "fin"))}
    one = [N("scene"), N("object2part_all", 0), N("partfilter_partname", 1, value="back_right_wheel"),
           N("unique", 2)]
    assert run(scene, *one, N("partquery_occlusion", 3)).answer is True
    assert run(scene, *one, N("relate_part_occluded", 3)).answer == {1, 2}
    door = [N("scene"), N("object2part", 0), N("partfilter_color", 1, value="blue"), N("unique", 2)]
    assert run(scene, *door, N("partquery_occlusion", 3)).answer is False
    assert run(scene, *door, N("relate_part_occluded", 3)).answer == frozenset()
    assert run(scene, N("scene"), N("filter_occluder", 0)).answer == {1, 2, 3}
    assert run(scene, N("scene"), N("filter_color", 0, value="red"), N("filter_occluder", 1)).answer == {2}


def test_occlusion_state_is_read_separately_from_occluders():
    """A scene may say 'occluded' without naming an occluder (a probabilistic or imported scene)."""
    obj = toy_object("suv")
    ann = dataclasses.replace(obj.annotation, occlusion=Occlusion(level=1, visible_before=True, occluded=True))
    hood = EntityAnnotation(100, 150, (0, 0, 1, 1), Occlusion(level=1, visible_before=True, occluded=True))
    s = toy_scene([dataclasses.replace(obj, annotation=ann, part_annotations={"hood": hood}), toy_object("jet")])
    assert run(s, N("scene"), N("filter_occludee", 0)).answer == {0}
    assert run(s, N("scene"), N("filter_color", 0, value="gray"), N("count", 1)).answer == 2
    hood_id = (0, ontology.part_id("suv", "hood"))
    assert run(s, N("scene"), N("object2part_all", 0), N("partfilter_occludee", 1)).answer == {hood_id}
    one = [N("scene"), N("object2part_all", 0), N("unique", 1)]
    assert run(s, *one, N("relate_part_occluded", 2)).answer == frozenset()
    assert run(s, N("scene"), N("filter_shape", 0, value="suv"), N("unique", 1), N("relate_occluded", 2)
               ).answer == frozenset()


def test_public_node_spellings_and_outputs(scene):
    prog = [{"function": "scene", "inputs": [], "value_inputs": [], "_output": "stale"},
            {"function": "object2part", "inputs": [0], "side_inputs": []},
            {"type": "partfilter_color", "inputs": [1], "side_inputs": ["blue"]},
            {"type": "unique", "inputs": [2]}]
    res = execute(scene, prog)
    assert res.valid
    door = ontology.part_id("suv", "front_left_door")
    assert res.public_outputs()[-1] == f"0_{door}"
    assert res.public_outputs()[2] == [f"0_{door}"]
    assert res.public_outputs()[0] == [0, 1, 2, 3]
    assert execute(scene, {"program": prog}).answer == (0, door)


@pytest.mark.parametrize(("program", "error", "text"), [
    ([N("scene"), N("filtr_color", 0, value="red")], UnknownNameError, "did you mean 'filter_color'"),
    ([N("scene"), N("filter_color", 0, value="rde")], UnknownNameError, "did you mean 'red'"),
    ([N("scene"), N("filter_shape", 0, value="wheel")], UnknownNameError, "unknown Shape value 'wheel'"),
    ([N("scene"), N("count", 2)], ProgramStructureError, "count: input 2 must be the index of an earlier node"),
    ([N("scene"), N("count", 0, 0)], ProgramArityError, "count takes 1 input(s), got 2"),
    ([N("scene"), N("query_color", 0)], ProgramTypeError, "the first input must be Object, but it is ObjectSet"),
    ([N("scene"), {"type": "filter_color", "inputs": [0]}], ProgramValueError, "needs a Color value"),
    ([N("scene"), {"inputs": [0]}], InputError, "program[1]: needs the operation name under 'type'"),
    ([], InputError, "empty"),
    ("scene", InputError, "program: not valid JSON"),
    ([N("scene"), {"type": "count", "inputs": "0"}], InputError, "program[1].inputs: must be a list"),
])
def test_bad_programs_raise_typed_errors(scene, program, error, text):
    with pytest.raises(error) as exc:
        execute(scene, program)
    assert isinstance(exc.value, Po3dError)
    assert text in str(exc.value)


def test_malformed_scenes_raise_scene_format_errors(scene):
    bad_part = dataclasses.replace(scene.objects[0], parts={"wing_left": scene.objects[0].parts["front_left_door"]})
    with pytest.raises(SceneFormatError, match=r"objects\[0\].parts: 'wing_left' is not a part of suv"):
        execute(dataclasses.replace(scene, objects=(bad_part,) + scene.objects[1:]), [N("scene")])
    bad_rel = dataclasses.replace(scene, relationships={**scene.relationships, "left": ((), ())})
    with pytest.raises(SceneFormatError, match="relationships.left"):
        execute(bad_rel, [N("scene")])
    occ = dataclasses.replace(scene.objects[2].annotation,
                              occlusion=Occlusion(level=1, visible_before=True, occluded_by=(9,)))
    bad_occ = dataclasses.replace(scene, objects=scene.objects[:2] + (
        dataclasses.replace(scene.objects[2], annotation=occ),) + scene.objects[3:])
    with pytest.raises(SceneFormatError, match=r"objects\[2\].occlusion.occluded_by: 9"):
        execute(bad_occ, [N("scene")])
    with pytest.raises(SceneFormatError):
        execute({"objects": []}, [N("scene")])
