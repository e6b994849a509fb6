"""The realiser writes the phrasing structures people and the public CLEVR / Super-CLEVR files use (issue 13)."""

from __future__ import annotations

import numpy as np

from po3d_ppl.language import parse_program
from po3d_ppl.questions.realise import Realiser


def _texts(program_text: str, seeds: int = 300) -> set[str]:
    program = parse_program(program_text)
    return {Realiser(np.random.default_rng(s)).question(program).lower() for s in range(seeds)}


def test_there_is_a_thing_what_is_its_attribute():
    texts = _texts("scene() | filter_size[small] | filter_shape[bus] | unique | query_color")
    assert any(t.startswith("there is a small bus; what") and t.endswith(("its color?", "is it?", "its colour?"))
               for t in texts)


def test_what_is_occluding_the_object():
    texts = _texts("scene() | filter_shape[car] | unique | relate_occluded | unique | query_shape")
    assert {"what is occluding the car?", "what occludes the car?"} & texts


def test_yes_no_about_one_object_and_a_relation():
    texts = _texts("scene() | filter_shape[truck] | unique | relate_occluding | filter_shape[bus] | exist")
    assert "is the bus occluded by the truck?" in texts
    assert not any(t.startswith("does the truck") for t in texts)  # that wording is relate_occluded's
    texts = _texts("scene() | filter_shape[bus] | unique | relate_occluded | filter_shape[truck] | exist")
    assert "does the truck occlude the bus?" in texts
    assert not any(t.startswith("is the bus occluded by") for t in texts)
    texts = _texts("scene() | filter_shape[bus] | unique | relate[behind] | filter_shape[car] | exist")
    assert "is the car behind the bus?" in texts


def test_part_occluded_by_an_object():
    texts = _texts("scene() | filter_shape[car] | unique | object2part_all | partfilter_partname[bumper_front] "
                   "| unique | relate_part_occluded | filter_shape[bus] | exist")
    assert any(t.startswith("is the front bumper of the car occluded by") for t in texts)


def test_whose_part_is_occluded_by_says_is():
    texts = _texts("scene() | filter_shape[bus] | unique | relate_occluding_part | partfilter_partname[trunk] "
                   "| unique | part2object | unique | query_color", seeds=400)
    whose = [t for t in texts if "whose trunk" in t]
    assert whose and all("whose trunk is " in t or "whose trunk the" in t for t in whose)


def test_count_comparisons_in_many_words():
    texts = _texts("scene() | filter_shape[car] | count | greater_than(scene() | filter_shape[bus] | count)", 600)
    assert any(t.startswith(("is there a greater", "is there a larger", "is there a bigger"))
               and " of cars than bus" in t for t in texts)
    assert any(t.startswith("does the") and " of cars exceed" in t for t in texts)
    texts = _texts("scene() | filter_shape[car] | count | equal_integer(scene() | filter_shape[bus] | count)", 600)
    assert any(" equal in number?" in t for t in texts)


def test_parts_on_the_same_object():
    texts = _texts("scene() | object2part | partfilter_color[red] | partfilter_partname[door] | unique | part2object "
                   "| object2part | partfilter_partname[mirror] | unique | partquery_color", 400)
    assert any("the same object as the red door" in t for t in texts)


def test_pose_questions_and_orientation_words():
    texts = _texts("scene() | filter_shape[bus] | unique | query_pose")
    assert "what is the orientation of the bus?" in texts
    texts = _texts("scene() | filter_shape[bus] | unique | same_pose | filter_shape[car] | count", 600)
    assert any("oriented the same way as the bus" in t or "same orientation as the bus" in t for t in texts)


def test_clevr_shape_comparisons_keep_a_noun():
    from po3d_ppl.questions.templates.clevr.build import comparison

    texts = [text for family in comparison() for text in family["text"] if "same shape" in text]
    assert texts and all("<M> thing" in t or "<M2> thing" in t or "<M3> thing" in t or "<M4> thing" in t
                         for t in texts)
