"""Program text syntax: the grammar's forms, positions in error messages, and robustness to arbitrary text."""

from __future__ import annotations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from po3d_ppl.errors import Po3dError, UnknownNameError
from po3d_ppl.language import (
    Node,
    ProgramStructureError,
    ProgramSyntaxError,
    UnknownProgramNameError,
    parse_program,
    program_to_text,
)

CHAIN = "query_color(unique(filter_shape[car](filter_color[red](scene()))))"


def test_nested_call_gives_post_order_nodes():
    program = parse_program(CHAIN)
    assert [n.function for n in program] == ["scene", "filter_color", "filter_shape", "unique", "query_color"]
    assert [n.inputs for n in program] == [(), (0,), (1,), (2,), (3,)]
    assert program[1].value == "red" and program[2].value == "car"


def test_pipeline_form_equals_nested_form():
    assert parse_program("scene() | filter_color[red] | filter_shape[car] | unique | query_color") \
        == parse_program(CHAIN)


def test_pipeline_stage_extra_arguments_follow_the_piped_input():
    left = parse_program("equal_color(query_color(unique(scene())), query_color(unique(filter_color[red](scene()))))")
    right = parse_program("scene() | unique | query_color | equal_color(scene() | filter_color[red] | unique"
                          " | query_color)")
    assert left == right


def test_bindings_share_one_node_and_comments_and_whitespace_are_free():
    text = """
    # the object, named once
    car = unique(
        filter_shape[car](scene())   # a comment after code
    )
    equal_color(query_color(car),
                partquery_color(unique(partfilter_partname[wheel](object2part(car)))))
    """
    program = parse_program(text)
    unique_nodes = [i for i, n in enumerate(program) if n == Node("unique", (1,))]
    assert len(unique_nodes) == 1
    assert len(program.consumers[unique_nodes[0]]) == 2
    assert len(program) == 9
    assert "n2 = unique(filter_shape[car](scene()))" in program_to_text(program)


def test_quoted_values_and_value_words():
    program = parse_program('filter_color["two words \\"quoted\\""](filter_pose[front_pose](scene()))',
                            registry=None)
    assert program[1].value == "front_pose"
    assert program[2].value == 'two words "quoted"'
    assert parse_program(program_to_text(program)) == program


def test_spans_point_at_the_source():
    text = "scene()\n  | filter_color[red]"
    program = parse_program(text)
    span = program[1].span
    assert (span.line, span.column) == (2, 5)
    assert text[span.start:span.end].startswith("filter_color[red]")
    # spans do not take part in equality
    assert program == parse_program("filter_color[red](scene())")


@pytest.mark.parametrize(
    ("text", "line", "column", "expected"),
    [
        ("unique(scene()", 1, 15, "')'"),
        ("query_color(unique(scene())))", 1, 29, "end of program"),
        ("scene()\nfilter_color[](scene())", 2, 1, "'|'"),
        ("filter_color[red](scene() $", 1, 27, "')'"),
    ],
)
def test_syntax_errors_have_position_expected_tokens_and_caret(text, line, column, expected):
    with pytest.raises(ProgramSyntaxError) as info:
        parse_program(text)
    err = info.value
    assert (err.line, err.column) == (line, column)
    assert expected in err.expected
    assert f"line {line}, column {column}" in str(err)
    caret_line = str(err).splitlines()[-1]
    assert caret_line.index("^") == column + 1  # two-space indent


def test_unknown_operation_lists_close_matches_with_position():
    with pytest.raises(UnknownProgramNameError) as info:
        parse_program("scene() | filter_colour[red] | unique | query_color")
    err = info.value
    assert isinstance(err, UnknownNameError)
    assert err.suggestions[0] == "filter_color"
    assert (err.span.line, err.span.column) == (1, 11)
    assert "^^^^^^^^^^^^^" in str(err)


def test_undefined_and_reused_bindings():
    with pytest.raises(UnknownProgramNameError, match="unknown binding 'cra'; did you mean 'car'"):
        parse_program("car = unique(scene())\nquery_color(cra)")
    with pytest.raises(ProgramStructureError, match="already bound"):
        parse_program("a = scene()\na = scene()\ncount(a)")


def test_unused_binding_is_an_error():
    with pytest.raises(ProgramStructureError, match="not used by the result") as info:
        parse_program("a = scene()\nb = filter_color[red](scene())\ncount(a)")
    assert info.value.span.line == 2


def test_deep_nesting_is_a_typed_error_not_a_crash():
    with pytest.raises(Po3dError):
        parse_program("unique(" * 3000 + "scene()" + ")" * 3000)


@settings(max_examples=300, deadline=None)
@given(st.text(max_size=60))
def test_random_text_never_crashes(text):
    try:
        parse_program(text)
    except Po3dError:
        pass


_ALPHABET = st.sampled_from(["scene", "unique", "filter_color", "count", "x", "=", "(", ")", "[", "]", "|", ",",
                             "red", '"', "#", "\n", " ", "\\", "car", "0"])


@settings(max_examples=300, deadline=None)
@given(st.lists(_ALPHABET, max_size=30).map("".join))
def test_random_grammar_like_text_never_crashes(text):
    try:
        parse_program(text)
    except Po3dError:
        pass
