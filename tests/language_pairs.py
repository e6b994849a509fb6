"""A small hand-made set of (question, program text) pairs, covering every question family's shape.

Some part names are in a public raw spelling (``wheel_back_left``, ``mirror_left``); examples respell them
canonically, as ``load_examples`` does."""

from __future__ import annotations

from po3d_ppl.language import parse_program
from po3d_ppl.language.seq2seq.data import Example, canonical_targets

PAIRS: list[tuple[str, str, str]] = [
    ("parts", "What is the color of the wheel of the red car?",
     "scene() | filter_color[red] | filter_shape[car] | unique | object2part | partfilter_partname[wheel] | unique"
     " | partquery_color"),
    ("parts", "What is the material of the blue door of the small suv?",
     "scene() | filter_size[small] | filter_shape[suv] | unique | object2part | partfilter_color[blue]"
     " | partfilter_partname[door] | unique | partquery_material"),
    ("parts", "What is the name of the green part of the bus?",
     "scene() | filter_shape[bus] | unique | object2part | partfilter_color[green] | unique | partquery_partname"),
    ("parts", "What is the color of the thing that has a yellow back left wheel?",
     "scene() | object2part | partfilter_color[yellow] | partfilter_partname[wheel_back_left] | unique"
     " | part2object | unique | query_color"),
    ("parts", "What is the shape of the metal object that has a purple seat?",
     "scene() | filter_material[metal] | object2part | partfilter_color[purple] | partfilter_partname[seat]"
     " | unique | part2object | unique | query_shape"),
    ("pose", "Which direction the large gray jet is facing?",
     "scene() | filter_size[large] | filter_color[gray] | filter_shape[jet] | unique | query_pose"),
    ("pose", "What is the color of the bicycle which faces to the front?",
     "scene() | filter_pose[front_pose] | filter_shape[bicycle] | unique | query_color"),
    ("pose", "What is the size of the cyan thing that faces the same direction as the rubber truck?",
     "scene() | filter_material[rubber] | filter_shape[truck] | unique | same_pose | filter_color[cyan] | unique"
     " | query_size"),
    ("pose", "What is the shape of the brown thing that faces the opposite direction as the scooter?",
     "scene() | filter_shape[scooter] | unique | opposite_pose | filter_color[brown] | unique | query_shape"),
    ("occlusion", "Is the front wheel of the red motorbike occluded?",
     "scene() | filter_color[red] | filter_shape[motorbike] | unique | object2part_all"
     " | partfilter_partname[wheel_front] | unique | partquery_occlusion"),
    ("occlusion", "Which part of the tiny sedan is occluded?",
     "scene() | filter_size[small] | filter_shape[sedan] | unique | object2part_all | partfilter_occludee | unique"
     " | partquery_partname"),
    ("obj_occlusion", "What is the color of the fighter that is occluded?",
     "scene() | filter_occludee | filter_shape[fighter] | unique | query_color"),
    ("obj_occlusion", "What is the shape of the object that occludes the small gray object?",
     "scene() | filter_size[small] | filter_color[gray] | unique | relate_occluded | unique | query_shape"),
    ("obj_occlusion", "What is the material of the bus that is occluded by the yellow airliner?",
     "scene() | filter_color[yellow] | filter_shape[airliner] | unique | relate_occluding | filter_shape[bus]"
     " | unique | query_material"),
    ("occlusion", "Is the left mirror of the wagon occluded by the blue car?",
     "scene() | filter_shape[wagon] | unique | object2part_all | partfilter_partname[mirror_left] | unique"
     " | relate_part_occluded | filter_color[blue] | filter_shape[car] | exist"),
    ("core", "How many red things are there?", "scene() | filter_color[red] | count"),
    ("core", "Is there a metal bus?", "scene() | filter_material[metal] | filter_shape[bus] | exist"),
    ("core", "What is the color of the thing left of the truck?",
     "scene() | filter_shape[truck] | unique | relate[left] | unique | query_color"),
    ("core", "Are there more cars than buses?",
     "greater_than(scene() | filter_shape[car] | count, scene() | filter_shape[bus] | count)"),
    ("core", "Is the color of the jet the same as the scooter?",
     "equal_color(scene() | filter_shape[jet] | unique | query_color,"
     " scene() | filter_shape[scooter] | unique | query_color)"),
]


def pair_examples() -> list[Example]:
    return [Example(q, canonical_targets(parse_program(p)), source, f"{source}:{i}")
            for i, (source, q, p) in enumerate(PAIRS)]
