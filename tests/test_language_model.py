"""The shipped question parser (models/question_parser.*): it loads with verified checksums and parses questions
written in the dataset's style, including wordings it was not trained on verbatim."""

from __future__ import annotations

import pytest

from po3d_ppl.language import QuestionParser, check_program, parse_program, program_to_tokens

CASES = [
    ("How many yellow objects are there?", "scene() | filter_color[yellow] | count"),
    ("What color is the front wheel of the big motorbike?",
     "scene() | filter_size[large] | filter_shape[motorbike] | unique | object2part"
     " | partfilter_partname[wheel_front] | unique | partquery_color"),
    ("What material is the left head light of the school bus?",
     "scene() | filter_shape[school] | unique | object2part | partfilter_partname[head_light_left] | unique"
     " | partquery_material"),
    # one spelling per wording: "left head light" is head_light_left on buses and sedans alike
    ("What material is the left head light of the sedan?",
     "scene() | filter_shape[sedan] | unique | object2part | partfilter_partname[head_light_left] | unique"
     " | partquery_material"),
    ("What color is the back left wheel of the cyan object?",
     "scene() | filter_color[cyan] | unique | object2part | partfilter_partname[back_left_wheel] | unique"
     " | partquery_color"),
    ("Which direction is the blue airliner facing?",
     "scene() | filter_color[blue] | filter_shape[airliner] | unique | query_pose"),
    ("What is the shape of the thing that occludes the small gray object?",
     "scene() | filter_size[small] | filter_color[gray] | unique | relate_occluded | unique | query_shape"),
]


@pytest.fixture(scope="module")
def parser(torch_one_thread):
    return QuestionParser.load()


@pytest.mark.parametrize(("question", "text"), CASES)
def test_shipped_parser_reads_dataset_style_questions(parser, question, text):
    result = parser.parse(question, n=3)
    assert program_to_tokens(result.best.program) == program_to_tokens(parse_program(text))
    assert result.best.satisfiable
    for candidate in result.candidates:
        check_program(candidate.program)


def test_shipped_parser_reports_unknown_words_and_still_parses(parser):
    result = parser.parse("How many chartreuse cars are there??")
    assert result.unknown_words == ("chartreuse",)
    assert check_program(result.best.program).type == "Integer"


def test_a_question_about_a_part_the_object_cannot_have_keeps_its_faithful_parse(parser):
    # cars have front_left_wheel / front_right_wheel; "front wheel" (wheel_front) exists on bikes only
    best = parser.parse("What color is the front wheel of the big red car?", n=2).best
    assert "partfilter_partname[wheel_front]" in best.tokens
    assert not best.satisfiable
